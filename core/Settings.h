#pragma once
// What a scene chooses for the engine as a whole, as plain values: the transfer scheme, the stability checks, how
// walls and bodies in contact act, the step policy. The scene description (io/SceneDesc.h) holds these without
// the engine; the engine (core/Simulation.h) reads them.
#include "base/Types.h"
#include "core/Kernels.h"

namespace mpm {

enum class TransferScheme { APIC, PIC };
enum class ForceScheme { Standard, MLS };

struct TransferSettings {
    Interpolation interpolation = Interpolation::Quadratic;
    TransferScheme transfer = TransferScheme::APIC;
    ForceScheme force = ForceScheme::Standard;
};

struct StabilitySettings {
    bool cellCrossing = true;  ///< a particle moving more than one cell in a substep breaks the stencil
    /// Total energy (kinetic + stored + gravity) may not rise above its lowest value since the last emission
    /// by more than this fraction of the largest kinetic + stored energy seen; 0 = off. Colliders are static
    /// and dissipative, so without emission nothing does positive work.
    double energyGrowth = 0.5;
    /// The CFL step may not shrink by more than this factor in one substep (a crushed material or a flung
    /// particle makes the step collapse and the run stall); 0 = off.
    double stepCollapse = 100.0;
    int retries = 0;  ///< restarts of a failed frame, each halving the time step; 0 = stop at once
};

/// What a collider's wall does to the material at it (a collider's `boundary`).
enum class Boundary {
    Sticky,    ///< node velocity becomes the collider's
    Slip,      ///< the normal component is removed, in both directions (only inwards on a wall with friction)
    Separate,  ///< the normal component is removed only while the node moves into the object
};

/// How bodies in contact share the grid: one velocity field for all material (bodies that touch move
/// together there), or one field per body with a contact condition between them (core/MultiField.h).
enum class ContactModel { SingleField, MultiField };
/// Where walls act: wherever the stencil reaches them, or at the material's surface (core/Collider.h SurfaceContact).
enum class WallContact { Stencil, Surface };
/// What nodes inside a sticky or slip wall hold: the wall's velocity, or the velocity mirrored from their image
/// across the surface (core/GridUpdate.h mirrorGhostNodes).
enum class WallGhosts { Held, Mirror };

struct SimulationSettings {
    double dx = 0.02;                        ///< grid spacing [m]
    Vec3d gravity = Vec3d(0.0, -9.81, 0.0);  ///< Y is up, as in Houdini [m/s^2]
    TransferSettings transfer;
    double fps = 24.0;
    int substepsPerFrame = 20;              ///< target dt = 1 / (fps * substepsPerFrame)
    bool adaptive = true;                   ///< also bound dt by the CFL condition
    double cfl = 0.5;                       ///< C in dt <= C dx / (c + |v|max)
    double maxDisplacement = 0.0;           ///< thesis rule: max node displacement per substep in cells; 0 = off
    long long maxSubstepsPerFrame = 20000;  ///< watchdog: a frame that would need more stops the run
    StabilitySettings stability;
    ContactModel contact = ContactModel::SingleField;
    float contactFriction = 0.0f;  ///< Coulomb mu between bodies (multi_field)
    WallGhosts wallGhosts = WallGhosts::Held;
    WallContact wallContact = WallContact::Stencil;  ///< for `separate` colliders (sticky and slip hold from the stencil's reach)

    /// Ranks re-cut the leaves into equal shares of particles when the most loaded holds more than this much
    /// above the mean (simulation.rebalance_imbalance; docs/distributed.md has the measurement); results do
    /// not depend on it, only the time per substep does.
    double rebalanceImbalance = 0.1;

    double targetDt() const { return 1.0 / (fps * substepsPerFrame); }
};

}  // namespace mpm
