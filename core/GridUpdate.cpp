#include "core/GridUpdate.h"

#include <algorithm>
#include <cmath>

#include "sparse/LeafLookup.h"
#include "sparse/LeafParallel.h"

namespace mpm {

namespace {
/// One context per collider for a task, so that a collider sampling a tree keeps its accessor warm.
std::vector<std::unique_ptr<ColliderContext>> contextsFor(const std::vector<std::unique_ptr<Collider>>& colliders) {
    std::vector<std::unique_ptr<ColliderContext>> contexts;
    for (const auto& c : colliders) contexts.push_back(c->makeContext());
    return contexts;
}
}  // namespace

std::vector<BodyImpulse> bodyImpulsesFor(const std::vector<std::unique_ptr<Collider>>& colliders) {
    const bool any = std::any_of(colliders.begin(), colliders.end(), [](const auto& c) { return c->dynamic(); });
    return std::vector<BodyImpulse>(any ? colliders.size() : 0);
}

void addBodyImpulses(std::vector<BodyImpulse>& a, const std::vector<BodyImpulse>& b) {
    if (a.empty()) a.resize(b.size());
    for (std::size_t c = 0; c < b.size(); ++c) a[c] += b[c];
}

GridUpdateResult updateGridVelocities(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders,
                                      const Vec3f& g, float dt, double tEnd, const SurfaceContact& surface, bool toVelocity,
                                      const std::vector<uint8_t>* owned) {
    GridUpdateResult none;
    none.bodies = bodyImpulsesFor(colliders);
    return reduceLeafRanges(
        grid.leafCount(), LeafGrain::Nodes, none,
        [&](std::size_t begin, std::size_t end, GridUpdateResult& acc) {
            const auto contexts = contextsFor(colliders);
            for (std::size_t l = begin; l < end; ++l) {
                if (owned && !(*owned)[l]) continue;
                const LeafView& leaf = grid.leaf(l);
                // Only the nodes P2G wrote: all others are zero, and stay so.
                const NodeBox& box = grid.writtenBox(l);
                // v = (mv) / m on nodes with mass (exact comparison: a threshold would lose momentum), then gravity.
                if (toVelocity)
                    box.forEach([&](int n) {
                        Eigen::Map<Vec3f> v(leaf.momentum + 3 * n);
                        const float m = leaf.mass[n];
                        if (m != 0.0f)
                            v = v / m + dt * g;
                        else
                            v.setZero();
                    });
                const SurfaceContact leafSurface = surface.ofLeaf(l);
                for (std::size_t c = 0; c < colliders.size(); ++c) {
                    const ColliderExchange e =
                        colliders[c]->applyToLeaf(leaf, box, grid.dx(), tEnd, contexts[c].get(), leafSurface);
                    acc.work += e.work;
                    if (!acc.bodies.empty() && colliders[c]->dynamic()) acc.bodies[c].add(e.impulse, e.angular);
                }
                box.forEach([&](int n) {
                    if (leaf.mass[n] != 0.0f)
                        acc.maxSpeed = std::max(acc.maxSpeed, Eigen::Map<const Vec3f>(leaf.momentum + 3 * n).norm());
                });
            }
        },
        [](GridUpdateResult a, const GridUpdateResult& b) {
            a.maxSpeed = std::max(a.maxSpeed, b.maxSpeed);
            a.work += b.work;
            addBodyImpulses(a.bodies, b.bodies);
            return a;
        });
}

namespace {
/// Whether material moving at `normalSpeed` relative to a wall (along its normal) arrives at it or leaves it, as
/// opposed to resting on it: it covers more than kMirrorNormalCells of a cell in the step. The mirror passes leave
/// such a node held, because a mirrored arrival bounces back off the ghost nodes (docs/method.md, section 7).
bool crossesWall(float normalSpeed, float dt, double dx) { return std::abs(double(normalSpeed) * dt) > kMirrorNormalCells * dx; }

/// Whether a collider's walls mirror: sticky ones, and slip ones without friction. Coulomb friction acts on the
/// held nodes' normal impulse, which the fold's images take over, so a mirrored slip floor lost most of its
/// friction (a block on it, gravity tilted 30 degrees, mu 0.7, slid 3-6 cells where it must hold).
bool mirrors(const Collider& c) {
    if (c.dynamic()) return false;  // a body's impulse is summed in the collider pass alone
    return c.boundary() == Boundary::Sticky || (c.boundary() == Boundary::Slip && c.friction() == 0.0f);
}

/// The image nodes' values for a mirror pass: a node's mass and the vector its leaf holds (momentum before the
/// update, velocity after). On ranks, the images in leaves other ranks own (whose values here are partial sums)
/// are fetched from their owners once, sorted and each once, when the reader is made (collective: every rank
/// makes one).
class ImageReader {
public:
    /// The images of the ghosts (`inside`) or of the nodes in front.
    ImageReader(const SparseGrid& grid, const MirrorWalls& walls, bool inside, const RemoteNodes* remote)
        : lookup_(grid), remote_(remote) {
        if (!remote) return;
        for (const auto& leafWalls : walls)
            for (const MirrorWallNode& w : leafWalls)
                if ((w.wall.phi < 0.0) == inside && !remote->local(w.wall.image)) far_.push_back(w.wall.image);
        std::sort(far_.begin(), far_.end(), nodeLess);
        far_.erase(std::unique(far_.begin(), far_.end()), far_.end());
        remote->fetch(far_, farMass_, farVector_);
    }
    /// False where no leaf holds the node or it has no mass; `near` is the leaf tried first.
    bool read(const Vec3i& node, const LeafView* near, float& m, Vec3f& v) const {
        if (remote_ && !remote_->local(node)) {
            const std::size_t k = std::size_t(std::lower_bound(far_.begin(), far_.end(), node, nodeLess) - far_.begin());
            m = farMass_[k], v = farVector_[k];
            return m != 0.0f;
        }
        int offset = 0;
        const LeafView* leaf = lookup_.at(node, near, offset);
        if (!leaf) return false;
        m = leaf->mass[offset], v = Eigen::Map<const Vec3f>(leaf->momentum + 3 * offset);
        return m != 0.0f;
    }

private:
    LeafLookup lookup_;
    const RemoteNodes* remote_;
    std::vector<Vec3i> far_;
    std::vector<float> farMass_;
    std::vector<Vec3f> farVector_;
};

/// A vector's image across a wall of normal n: odd for `sticky` (the image moves against it), odd in the normal
/// part alone for `slip`.
Vec3f reflect(const Vec3f& a, const Vec3f& n, Boundary b) {
    return b == Boundary::Sticky ? Vec3f(-a) : Vec3f(a - 2.0f * a.dot(n) * n);
}
}  // namespace

MirrorWalls findMirrorWalls(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, double tEnd,
                            const std::vector<uint8_t>* owned) {
    MirrorWalls walls(grid.leafCount());
    if (std::none_of(colliders.begin(), colliders.end(), [](const auto& c) { return mirrors(*c); })) return walls;
    const double dx = grid.dx();
    forEachLeafRange(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t begin, std::size_t end) {
        const auto contexts = contextsFor(colliders);
        std::vector<Collider::WallNode> found;
        for (std::size_t l = begin; l < end; ++l) {
            if (owned && !(*owned)[l]) continue;
            const LeafView& leaf = grid.leaf(l);
            for (std::size_t c = 0; c < colliders.size(); ++c) {
                const Boundary b = colliders[c]->boundary();
                if (!mirrors(*colliders[c])) continue;
                found.clear();
                colliders[c]->wallNodesOfLeaf(leaf, grid.writtenBox(l), dx, tEnd, kWallImageReach * dx, contexts[c].get(), found);
                for (const Collider::WallNode& w : found) walls[l].push_back({w, b});
            }
        }
    });
    return walls;
}

std::size_t foldWallImages(const SparseGrid& grid, const MirrorWalls& walls, const Vec3f& gravity, float dt,
                           const RemoteNodes* remote) {
    const ImageReader reader(grid, walls, false, remote);
    // Read every image first, then add: a node in front of one wall may be another's image.
    struct Add {
        int node;
        float mass;
        Vec3f momentum;
    };
    std::vector<std::vector<Add>> adds(grid.leafCount());
    forEachLeafRange(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t begin, std::size_t end) {
        for (std::size_t l = begin; l < end; ++l) {
            const LeafView& leaf = grid.leaf(l);
            for (const MirrorWallNode& mw : walls[l]) {
                const Collider::WallNode& w = mw.wall;
                if (w.phi < 0.0) continue;  // a ghost: the pass after the update's
                const Vec3f rel = Eigen::Map<const Vec3f>(leaf.momentum + 3 * w.node) / leaf.mass[w.node] - w.velocity;
                if (crossesWall(rel.dot(w.normal), dt, grid.dx())) continue;
                float m = 0.0f;
                Vec3f p;
                if (!reader.read(w.image, &leaf, m, p)) continue;
                // The image's momentum reflected about the wall's, and its gravity impulse reflected (the update
                // adds m dt g to the node's whole mass after).
                const Vec3f momentum = m * w.velocity + reflect(p - m * w.velocity, w.normal, mw.boundary) +
                                       m * dt * (reflect(gravity, w.normal, mw.boundary) - gravity);
                adds[l].push_back({w.node, m, momentum});
            }
        }
    });
    std::size_t folded = 0;
    for (std::size_t l = 0; l < adds.size(); ++l) {
        const LeafView& leaf = grid.leaf(l);
        for (const Add& a : adds[l]) {
            leaf.mass[a.node] += a.mass;
            Eigen::Map<Vec3f>(leaf.momentum + 3 * a.node) += a.momentum;
        }
        folded += adds[l].size();
    }
    return folded;
}

std::size_t mirrorGhostNodes(const SparseGrid& grid, const MirrorWalls& walls, float dt, const RemoteNodes* remote) {
    const ImageReader reader(grid, walls, true, remote);
    // Read every image first, then write: an image may lie next to another ghost.
    std::vector<std::vector<std::pair<int, Vec3f>>> values(grid.leafCount());
    forEachLeafRange(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t begin, std::size_t end) {
        for (std::size_t l = begin; l < end; ++l) {
            for (const MirrorWallNode& mw : walls[l]) {
                const Collider::WallNode& w = mw.wall;
                if (w.phi > 0.0) continue;  // in front: the fold's
                float m = 0.0f;
                Vec3f image;
                if (!reader.read(w.image, &grid.leaf(l), m, image)) continue;
                const Vec3f rel = image - w.velocity;
                if (crossesWall(rel.dot(w.normal), dt, grid.dx())) continue;  // held, as the collider left it
                values[l].emplace_back(w.node, w.velocity + reflect(rel, w.normal, mw.boundary));
            }
        }
    });
    std::size_t mirrored = 0;
    for (std::size_t l = 0; l < values.size(); ++l) {
        for (const auto& [node, v] : values[l]) Eigen::Map<Vec3f>(grid.leaf(l).momentum + 3 * node) = v;
        mirrored += values[l].size();
    }
    return mirrored;
}

ProjectionSummary projectOutOfColliders(const SparseGrid& grid, std::vector<AnySpecies>& species,
                                        const std::vector<std::unique_ptr<Collider>>& colliders, double tEnd, float dt,
                                        const Vec3d& gravity) {
    if (colliders.empty()) return {};
    const std::vector<uint32_t>& leaves = grid.particleLeaves();
    ProjectionSummary none;
    none.bodies = bodyImpulsesFor(colliders);
    return reduceLeafRanges(
        leaves.size(), LeafGrain::Particles, none,
        [&](std::size_t begin, std::size_t end, ProjectionSummary& acc) {
            const auto contexts = contextsFor(colliders);
            for (std::size_t i = begin; i < end; ++i) {
                const uint32_t l = leaves[i];
                for (AnySpecies& s : species)
                    std::visit(
                        [&](auto& sp) {
                            for (std::size_t c = 0; c < colliders.size(); ++c) {
                                const Collider::ProjectionResult r = colliders[c]->projectParticles(
                                    sp.p, sp.leafStart[l], sp.leafStart[l + 1], grid.leaf(l).origin, grid.dx(), tEnd, dt, gravity,
                                    contexts[c].get());
                                acc.work += r.work;
                                if (!acc.bodies.empty() && colliders[c]->dynamic()) acc.bodies[c].add(r.impulse, r.angular);
                                acc.maxSpeed = std::max(acc.maxSpeed, r.maxSpeed);
                                acc.moved += r.moved;
                            }
                        },
                        s);
            }
        },
        [](ProjectionSummary a, const ProjectionSummary& b) {
            a.work += b.work;
            addBodyImpulses(a.bodies, b.bodies);
            a.maxSpeed = std::max(a.maxSpeed, b.maxSpeed);
            a.moved += b.moved;
            return a;
        });
}

}  // namespace mpm
