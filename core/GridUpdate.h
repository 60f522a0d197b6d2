#pragma once
// The collider passes of a substep: the grid update (thesis 3.20, 3.26, section 5): v = (mv) / m plus dt g on
// nodes with mass, then the colliders at the step's end time; and, after advection, the particle pass that
// moves particles found inside a collider back to its surface (docs/method.md, section 7).
#include <functional>
#include <memory>
#include <vector>

#include "core/Collider.h"
#include "core/ExactSum.h"
#include "core/RigidBody.h"
#include "core/Species.h"
#include "sparse/SparseGrid.h"

namespace mpm {

struct GridUpdateResult {
    float maxSpeed = 0.0f;  ///< largest node speed
    ExactSum work;          ///< work moving colliders did on the nodes (exact: the same bits on any split)
    /// Per collider, what a dynamic one gave the nodes; empty when no collider is dynamic.
    std::vector<BodyImpulse> bodies;
};

/// Per collider, an empty exchange where some collider is a dynamic body; else no list at all (nothing to sum).
std::vector<BodyImpulse> bodyImpulsesFor(const std::vector<std::unique_ptr<Collider>>& colliders);
/// a += b, collider by collider (b empty: nothing).
void addBodyImpulses(std::vector<BodyImpulse>& a, const std::vector<BodyImpulse>& b);

/// Turns momentum into velocity on every written node, adds gravity, applies the colliders at time tEnd.
/// With `toVelocity` false the nodes already hold velocities and only the colliders act (multi-field contact
/// runs between the two). `owned`, when given, marks the leaves this process updates (per leaf, nonzero); the
/// others are ghosts of leaves another rank owns, holding partial sums until their velocities arrive.
GridUpdateResult updateGridVelocities(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders,
                                      const Vec3f& gravity, float dt, double tEnd, const SurfaceContact& surface,
                                      bool toVelocity = true, const std::vector<uint8_t>* owned = nullptr);

/// [cells per step] Mirror mode treats material moving along a wall's normal by more than this in a step as
/// arriving or leaving, not resting, and holds the wall there. Measured (docs/method.md, section 7): at 0.05-0.2
/// a sticky wall hit at 1000 m/s is as stable as held (jelly to C 1.0, rubber 0.6-0.7, sand 0.8-1.0; at 1.0 it
/// loses 0.1-0.3), while the held bodies' slowest nodes move 1e-5 cells a step and stay mirrored.
inline constexpr double kMirrorNormalCells = 0.1;
inline constexpr double kWallImageReach = 2.5;  ///< [cells] the cubic stencil's 2 and a particle's quarter cell

/// Mirror mode's walls (simulation.wall_ghosts = "mirror") treat a wall as a mirror: beyond it lies the image of
/// the material before it. That image is exact where a node's image across the surface is a node, so the walls
/// act only there: on sticky and frictionless slip walls on the grid's lines (or halfway between), within
/// kWallImageReach cells of the surface. Slip walls with friction stay held (their friction needs the held
/// nodes' normal impulse). Tilted and curved walls stay held: mirroring an image interpolated between nodes, with
/// no matching scatter, fed energy into sand resting on a hopper's cone until it blew up (docs/method.md,
/// section 7).
struct MirrorWallNode {
    Collider::WallNode wall;
    Boundary boundary;
};
using MirrorWalls = std::vector<std::vector<MirrorWallNode>>;  ///< per leaf of the grid
/// The mirror walls' nodes at a substep's end time tEnd, found once for both passes (neither changes which nodes
/// have mass); on ranks (`owned` given) of owned leaves only.
MirrorWalls findMirrorWalls(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, double tEnd,
                            const std::vector<uint8_t>* owned = nullptr);

/// On ranks, the mirror passes read an image node in a leaf another rank owns (whose values here are partial
/// sums) from its owner through `fetch`, called once on every rank (collective): the values read are those one
/// process reads, so the bits are the same.
struct RemoteNodes {
    const std::vector<uint8_t>* owned = nullptr;   ///< per leaf of the grid: owned by this rank
    std::function<bool(const Vec3i& node)> local;  ///< whether this rank owns the node's leaf
    /// The owners' mass and velocity of each node, in order.
    std::function<void(const std::vector<Vec3i>& nodes, std::vector<float>& mass, std::vector<Vec3f>& velocity)> fetch;
};

/// Before the grid update: the particles of the image scatter mass, momentum and stress impulse onto the nodes in
/// front of the wall as the real ones scatter onto the nodes beyond it. So a wall node in front of the wall adds
/// its image node's mass and momentum (of the step's P2G, stress impulse included) reflected: odd about the
/// wall's velocity for `sticky`, the normal part odd for `slip`, and the image's gravity reflected alike. This is
/// the scatter of mirrored particles exactly, and held bodies become second order (docs/method.md, section 7). A
/// node whose own normal speed relative to the wall crosses kMirrorNormalCells of a cell in the step (arriving
/// or being torn away) takes no image. Images are read before anything is added. Returns the nodes folded.
std::size_t foldWallImages(const SparseGrid& grid, const MirrorWalls& walls, const Vec3f& gravity, float dt,
                           const RemoteNodes* remote = nullptr);

/// After the colliders: a wall node inside the wall (a ghost) takes its image's velocity mirrored, odd about the
/// wall's velocity (sticky) or odd in the normal part and even in the tangential (slip), instead of being held
/// at the wall's: the velocity field the first particle layer interpolates then meets the wall at the surface
/// itself, not a fraction of a cell beyond. An image without mass, or one whose normal speed relative to the wall
/// covers more than kMirrorNormalCells of a cell in the step, leaves its ghost held, so a body hitting a wall
/// meets the held condition. Images are read before any ghost is written. Returns the nodes mirrored.
std::size_t mirrorGhostNodes(const SparseGrid& grid, const MirrorWalls& walls, float dt, const RemoteNodes* remote = nullptr);

struct ProjectionSummary {
    ExactSum work;                    ///< work moving colliders did on the particles they moved
    std::vector<BodyImpulse> bodies;  ///< per collider, what a dynamic one gave the particles (as GridUpdateResult's)
    float maxSpeed = 0.0f;            ///< of those particles
    std::size_t moved = 0;
};

/// The particle pass: every collider, every particle of every leaf near it, at time tEnd after a step dt.
ProjectionSummary projectOutOfColliders(const SparseGrid& grid, std::vector<AnySpecies>& species,
                                        const std::vector<std::unique_ptr<Collider>>& colliders, double tEnd, float dt,
                                        const Vec3d& gravity);

}  // namespace mpm
