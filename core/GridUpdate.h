#pragma once
// The collider passes of a substep: the grid update (thesis 3.20, 3.26, section 5): v = (mv) / m plus dt g on
// nodes with mass, then the colliders at the step's end time; and, after advection, the particle pass that
// moves particles found inside a collider back to its surface (docs/method.md, section 7).
#include <functional>
#include <memory>
#include <vector>

#include "core/Collider.h"
#include "core/ExactSum.h"
#include "core/Species.h"
#include "sparse/SparseGrid.h"

namespace mpm {

struct GridUpdateResult {
    float maxSpeed = 0.0f;  ///< largest node speed
    ExactSum work;          ///< work moving colliders did on the nodes (exact: the same bits on any split)
};

/// Turns momentum into velocity on every written node, adds gravity, applies the colliders at time tEnd.
/// With `toVelocity` false the nodes already hold velocities and only the colliders act (multi-field contact
/// runs between the two). `owned`, when given, marks the leaves this process updates (per leaf, nonzero); the
/// others are ghosts of leaves another rank owns, holding partial sums until their velocities arrive.
GridUpdateResult updateGridVelocities(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, const Vec3f& gravity,
                                      float dt, double tEnd, const SurfaceContact& surface, bool toVelocity = true,
                                      const std::vector<uint8_t>* owned = nullptr);

/// [cells per step] Mirror mode treats material moving along a wall's normal by more than this in a step as
/// arriving or leaving, not resting, and holds the wall there. Measured (docs/method.md, section 7): at 0.05-0.2
/// a sticky wall hit at 1000 m/s is as stable as held (jelly to C 1.0, rubber 0.6-0.7, sand 0.8-1.0; at 1.0 it
/// loses 0.1-0.3), while the held bodies' slowest nodes move 1e-5 cells a step and stay mirrored.
inline constexpr double kMirrorNormalCells = 0.1;

/// Ghost nodes (simulation.wall_ghosts = "mirror"): after the colliders, every node with mass inside a sticky or
/// slip collider takes the velocity mirrored from its image across the surface, odd about the wall's velocity
/// (sticky) or odd in the normal part and even in the tangential (slip), instead of being held at the wall's:
/// the velocity field the first particle layer interpolates then meets the wall at the surface itself, not a
/// fraction of a cell beyond. Only nodes whose image holds material resting on the wall are mirrored: an image
/// without material, or one whose normal speed relative to the wall covers more than kMirrorNormalCells of a cell
/// in the step (material arriving or being torn away), leaves its ghost held, so a body hitting a wall meets the
/// held condition. The images are read before any ghost is written. Returns the number of nodes mirrored.
///
/// On ranks (`remote` given) only owned leaves' ghosts are mirrored, and an image's nodes in leaves other ranks
/// own (whose values here are partial sums) are read from their owners through `remote.fetch`, called once on
/// every rank (collective): the values read are those one process reads, so the bits are the same.
struct RemoteNodes {
    const std::vector<uint8_t>* owned = nullptr;             ///< per leaf of the grid: owned by this rank
    std::function<bool(const Vec3i& node)> local;           ///< whether this rank owns the node's leaf
    /// The owners' mass and velocity of each node, in order.
    std::function<void(const std::vector<Vec3i>& nodes, std::vector<float>& mass, std::vector<Vec3f>& velocity)> fetch;
};
/// `dt`: the step the grid update took.
std::size_t mirrorGhostNodes(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, float dt, double tEnd,
                             const RemoteNodes* remote = nullptr);

/// Mirror mode's wall images, before the grid update (simulation.wall_ghosts = "mirror"): a wall as a mirror puts
/// beyond it the image of the material before it, whose particles scatter mass, momentum and stress impulse onto
/// the nodes before the wall as the real ones scatter onto the nodes beyond it. So a node of mass in front of a
/// non-`separate` collider (0 < phi <= kWallImageReach cells) whose image across the surface is a grid node adds
/// that node's mass and momentum (of the step's P2G, stress impulse included) reflected: odd about the wall's
/// velocity for `sticky`, the normal part odd for `slip`, and the image's gravity reflected alike. For a wall on
/// the grid's lines (or halfway between) this is the scatter of mirrored particles exactly, and held bodies
/// become second order (docs/method.md, section 7); where the image is not a node (a tilted or curved wall) the
/// node gets nothing, and the mirror pass after the update acts alone. A node whose own normal speed relative to
/// the wall crosses kMirrorNormalCells of a cell in the step takes no image either (as the mirror pass holds its
/// ghosts). Images are read before anything is added.
/// On ranks (`remote` given) only owned leaves' nodes take images, and images in leaves other ranks own come
/// from their owners (`remote.fetch`, collective). Returns the number of nodes that took an image.
inline constexpr double kWallImageReach = 2.5;  ///< [cells] the cubic stencil's 2 and a particle's quarter cell
std::size_t foldWallImages(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, const Vec3f& gravity,
                           float dt, double tEnd, const RemoteNodes* remote = nullptr);

struct ProjectionSummary {
    ExactSum work;          ///< work moving colliders did on the particles they moved
    float maxSpeed = 0.0f;  ///< of those particles
    std::size_t moved = 0;
};

/// The particle pass: every collider, every particle of every leaf near it, at time tEnd after a step dt.
ProjectionSummary projectOutOfColliders(const SparseGrid& grid, std::vector<AnySpecies>& species,
                                        const std::vector<std::unique_ptr<Collider>>& colliders, double tEnd, float dt, const Vec3d& gravity);

}  // namespace mpm
