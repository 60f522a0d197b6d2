#pragma once
// Per-frame diagnostics: conservation quantities, energies, extremes, grid size (stats.csv).
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/ExactSum.h"
#include "core/RigidBody.h"
#include "core/Species.h"

namespace mpm {

/// A CSV field as RFC 4180 quotes it when it must be (a name may hold any character: commas, quotes, newlines).
std::string csvField(const std::string& text);

struct FrameStats {
    int frame = 0;
    double time = 0.0;
    std::size_t particles = 0;
    double mass = 0.0;
    Vec3d momentum = Vec3d::Zero();
    Vec3d angularMomentum = Vec3d::Zero();  ///< about the origin, APIC affine part included
    double kineticEnergy = 0.0;             ///< 1/2 m (|v|^2 + D |C|^2): APIC's affine part included
    double elasticEnergy = 0.0;
    double gravityEnergy = 0.0;  ///< -sum m g . x (zero at the origin)
    double maxSpeed = 0.0;
    double minJ = 1.0, maxJ = 1.0;
    std::size_t activeLeaves = 0;
    std::size_t gridBytes = 0;  ///< the grid's leaves and per-leaf tables (SparseGrid::contentBytes)
    int substeps = 0;
    int retries = 0;  ///< times this frame was restarted with half the time step
    /// What set the step at the frame's last substep: its bound dt [s] (before the frame is cut into equal
    /// substeps) and the rule: "target", "cfl_wave_speed <species>", "cfl_particle_speed" or "max_displacement",
    /// with " (retry)" when a retry shortened it.
    double stepDt = 0.0;
    std::string stepLimit;
    double wallSeconds = 0.0;
    /// The dynamic colliders at the frame's end, in collider order: columns body<k>_* after the others.
    std::vector<RigidBodyState> bodies;
    /// Each species' (set's) kinetic + stored + gravitational energy, in species order: the energy check names
    /// the one that gained most (not written to stats.csv).
    std::vector<double> speciesEnergy;

    /// Kinetic + stored + gravitational: without external work and dissipation it is constant.
    double totalEnergy() const { return kineticEnergy + elasticEnergy + gravityEnergy; }

    /// The columns; a scene with rigid bodies adds, per body k, its centre of mass body<k>_x, _y, _z, orientation
    /// quaternion _qw, _qx, _qy, _qz (its turn from the scene's placement), velocity _vx, _vy, _vz and angular velocity
    /// _wx, _wy, _wz.
    static std::string csvHeader(std::size_t bodies = 0);
    std::string csvRow() const;
};

/// The particle sums behind FrameStats, exact (core/ExactSum.h): the same bits whatever the split over
/// threads or ranks, and those of several ranks add (Comm::sum).
struct ParticleSums {
    static constexpr int kSums = 10;  ///< mass, kinetic, elastic, gravity energy, momentum (3), angular momentum (3)
    ExactSum sum[kSums];
    double maxSpeed = 0.0;
    double minJ = std::numeric_limits<double>::infinity(), maxJ = -std::numeric_limits<double>::infinity();
    std::size_t particles = 0;
    /// Per species, in order: kinetic + stored + gravitational energy (sumParticles fills it; add leaves it).
    std::vector<ExactSum> speciesEnergy;
    void add(const ParticleSums& o);
    /// Mass, momenta, energies and extremes (frame, time and grid fields left for the caller).
    FrameStats stats() const;
};

/// Sums over the particles held here. inertiaScale is D_p / dx^2 (1/4 quadratic, 1/3 cubic), for the APIC
/// angular momentum m eps : (C D)^T.
ParticleSums sumParticles(const std::vector<AnySpecies>& species, double dx, float inertiaScale, const Vec3d& gravity);
/// sumParticles(...).stats().
FrameStats measureParticles(const std::vector<AnySpecies>& species, double dx, float inertiaScale, const Vec3d& gravity);

}  // namespace mpm
