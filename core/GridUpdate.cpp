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

GridUpdateResult updateGridVelocities(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, const Vec3f& g,
                                      float dt, double tEnd, const SurfaceContact& surface, bool toVelocity,
                                      const std::vector<uint8_t>* owned) {
    return reduceLeafRanges(
        grid.leafCount(), LeafGrain::Nodes, GridUpdateResult{},
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
                        if (m != 0.0f) v = v / m + dt * g;
                        else v.setZero();
                    });
                for (std::size_t c = 0; c < colliders.size(); ++c) acc.work += colliders[c]->applyToLeaf(leaf, box, grid.dx(), tEnd, contexts[c].get(), surface);
                box.forEach([&](int n) {
                    if (leaf.mass[n] != 0.0f) acc.maxSpeed = std::max(acc.maxSpeed, Eigen::Map<const Vec3f>(leaf.momentum + 3 * n).norm());
                });
            }
        },
        [](GridUpdateResult a, const GridUpdateResult& b) {
            a.maxSpeed = std::max(a.maxSpeed, b.maxSpeed);
            a.work += b.work;
            return a;
        });
}

namespace {
/// The nodes whose values the velocity at a point (in cells) is interpolated from, with their trilinear weights;
/// a point on a node reads that node alone. Calls f(node, weight) for the corners of nonzero weight, in order.
template <class F>
void forEachCorner(const Vec3d& cells, F&& f) {
    constexpr double kOnNode = 1e-6;  // [cells]: an image this close to a node is that node (a wall on the grid)
    const Vec3d base = cells.array().floor();
    const Vec3d frac = cells - base;
    for (int corner = 0; corner < 8; ++corner) {
        float w = 1.0f;
        Vec3i node;
        for (int a = 0; a < 3; ++a) {
            const bool up = (corner >> a) & 1;
            double wa = up ? frac[a] : 1.0 - frac[a];
            if (frac[a] < kOnNode) wa = up ? 0.0 : 1.0;
            if (frac[a] > 1.0 - kOnNode) wa = up ? 1.0 : 0.0;
            w *= float(wa);
            node[a] = int(base[a]) + up;
        }
        if (w != 0.0f) f(node, w);
    }
}

/// The velocity at a point from the nodes around it (trilinear, over the nodes with mass only); false where
/// none of them has mass. `read(node, mass, velocity)` gives a node's values (false: no leaf there).
template <class Read>
bool velocityAt(const Vec3d& cells, Read&& read, Vec3f& v) {
    float weightSum = 0.0f;
    Vec3f sum = Vec3f::Zero();
    forEachCorner(cells, [&](const Vec3i& node, float w) {
        float m = 0.0f;
        Vec3f vn;
        if (!read(node, m, vn) || m == 0.0f) return;
        weightSum += w;
        sum += w * vn;
    });
    if (!(weightSum > 0.0f)) return false;
    v = sum / weightSum;
    return true;
}
/// Whether material moving at `normalSpeed` relative to a wall (along its normal) arrives at it or leaves it, as
/// opposed to resting on it: it covers more than kMirrorNormalCells of a cell in the step. The mirror passes leave
/// such a node held, because a mirrored arrival bounces back off the ghost nodes (docs/method.md, section 7).
bool crossesWall(float normalSpeed, float dt, double dx) { return std::abs(double(normalSpeed) * dt) > kMirrorNormalCells * dx; }

/// Node values for a pass that reads nodes of other leaves: a node's mass and the vector its leaf holds (momentum
/// before the update, velocity after). On ranks, the `wanted` nodes in leaves other ranks own (whose values here
/// are partial sums) are fetched from their owners once, sorted and each once, when the reader is made
/// (collective: every rank makes one).
class NodeReader {
public:
    NodeReader(const SparseGrid& grid, const RemoteNodes* remote, const std::vector<Vec3i>& wanted) : lookup_(grid), remote_(remote) {
        if (!remote) return;
        for (const Vec3i& node : wanted)
            if (!remote->local(node)) far_.push_back(node);
        std::sort(far_.begin(), far_.end(), nodeLess);
        far_.erase(std::unique(far_.begin(), far_.end()), far_.end());
        remote->fetch(far_, farMass_, farVector_);
    }
    /// False where no leaf holds the node; `near` is the leaf tried first.
    bool read(const Vec3i& node, const LeafView* near, float& m, Vec3f& v) const {
        if (remote_ && !remote_->local(node)) {
            const std::size_t k = std::size_t(std::lower_bound(far_.begin(), far_.end(), node, nodeLess) - far_.begin());
            m = farMass_[k], v = farVector_[k];
            return true;
        }
        int offset = 0;
        const LeafView* leaf = lookup_.at(node, near, offset);
        if (!leaf) return false;
        m = leaf->mass[offset], v = Eigen::Map<const Vec3f>(leaf->momentum + 3 * offset);
        return true;
    }

private:
    LeafLookup lookup_;
    const RemoteNodes* remote_;
    std::vector<Vec3i> far_;
    std::vector<float> farMass_;
    std::vector<Vec3f> farVector_;
};
}  // namespace

std::size_t mirrorGhostNodes(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, float dt, double tEnd,
                             const RemoteNodes* remote) {
    bool any = false;
    for (const auto& c : colliders) any = any || c->boundary() != Boundary::Separate;
    if (!any) return 0;
    const double invDx = 1.0 / grid.dx();
    // The ghosts of every (owned) leaf first.
    struct Ghost {
        Collider::Ghost g;
        Boundary boundary;
    };
    std::vector<std::vector<Ghost>> ghosts(grid.leafCount());
    forEachLeafRange(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t begin, std::size_t end) {
        const auto contexts = contextsFor(colliders);
        std::vector<Collider::Ghost> found;
        for (std::size_t l = begin; l < end; ++l) {
            if (remote && !(*remote->owned)[l]) continue;
            for (std::size_t c = 0; c < colliders.size(); ++c) {
                const Boundary b = colliders[c]->boundary();
                if (b == Boundary::Separate) continue;
                found.clear();
                colliders[c]->ghostsOfLeaf(grid.leaf(l), grid.writtenBox(l), grid.dx(), tEnd, contexts[c].get(), found);
                for (const Collider::Ghost& g : found) ghosts[l].push_back({g, b});
            }
        }
    });
    // On ranks: the images' nodes other ranks own, from their owners.
    std::vector<Vec3i> wanted;
    if (remote)
        for (const auto& leafGhosts : ghosts)
            for (const Ghost& gh : leafGhosts) forEachCorner(gh.g.mirror * invDx, [&](const Vec3i& node, float) { wanted.push_back(node); });
    const NodeReader reader(grid, remote, wanted);
    // Read every image first, then write: an image may lie next to another ghost.
    std::vector<std::vector<std::pair<int, Vec3f>>> values(grid.leafCount());
    forEachLeafRange(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t begin, std::size_t end) {
        for (std::size_t l = begin; l < end; ++l) {
            const LeafView* near = &grid.leaf(l);
            const auto read = [&](const Vec3i& node, float& m, Vec3f& v) { return reader.read(node, near, m, v); };
            for (const Ghost& gh : ghosts[l]) {
                const Collider::Ghost& g = gh.g;
                Vec3f image;
                if (!velocityAt(g.mirror * invDx, read, image)) continue;
                const Vec3f rel = image - g.velocity;
                if (crossesWall(rel.dot(g.normal), dt, grid.dx())) continue;  // held, as the collider left it
                const Vec3f ghost =
                    gh.boundary == Boundary::Sticky ? Vec3f(g.velocity - rel) : Vec3f(g.velocity + rel - 2.0f * rel.dot(g.normal) * g.normal);
                values[l].emplace_back(g.node, ghost);
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

std::size_t foldWallImages(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, const Vec3f& gravity,
                           float dt, double tEnd, const RemoteNodes* remote) {
    bool any = false;
    for (const auto& c : colliders) any = any || c->boundary() != Boundary::Separate;
    if (!any) return 0;
    const double dx = grid.dx(), invDx = 1.0 / dx;
    const double halfDiagonal = 0.5 * std::sqrt(3.0) * (kLeafDim - 1) * dx, reach = kWallImageReach * dx;
    constexpr double kOnNode = 1e-6;  // [cells]: as in forEachCorner, an image this close to a node is that node
    struct Image {
        int node;        ///< the node in front of the wall, in its leaf
        Vec3i source;    ///< the node its image falls on, beyond the wall
        Vec3f normal, velocity;
        Boundary boundary;
    };
    std::vector<std::vector<Image>> images(grid.leafCount());
    forEachLeafRange(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t begin, std::size_t end) {
        for (std::size_t l = begin; l < end; ++l) {
            if (remote && !(*remote->owned)[l]) continue;
            const LeafView& leaf = grid.leaf(l);
            const Vec3d centre = (leaf.origin.cast<double>() + Vec3d::Constant(0.5 * (kLeafDim - 1))) * dx;
            for (const auto& c : colliders) {
                if (c->boundary() == Boundary::Separate) continue;
                const double atCentre = c->signedDistance(centre, tEnd);  // phi is 1-Lipschitz
                if (atCentre > halfDiagonal + reach || atCentre < -halfDiagonal) continue;
                grid.writtenBox(l).forEach([&](int n) {
                    if (leaf.mass[n] == 0.0f) return;
                    const Vec3d x = (leaf.origin + leafLocal(n)).cast<double>() * dx;
                    const double phi = c->signedDistance(x, tEnd);
                    if (!(phi > 0.0) || phi > reach) return;
                    const Vec3d normal = c->normal(x, tEnd), image = (x - 2.0 * phi * normal) * invDx;
                    const Vec3i source = image.array().round().cast<int>();
                    if ((image - source.cast<double>()).cwiseAbs().maxCoeff() > kOnNode) return;
                    const Vec3f vc = c->moving() ? Vec3f(c->velocity(x - phi * normal, tEnd).cast<float>()) : Vec3f(Vec3f::Zero());
                    const Vec3f rel = Eigen::Map<const Vec3f>(leaf.momentum + 3 * n) / leaf.mass[n] - vc;
                    if (crossesWall(rel.dot(normal.cast<float>()), dt, dx)) return;
                    images[l].push_back({n, source, normal.cast<float>(), vc, c->boundary()});
                });
            }
        }
    });
    // On ranks: the images' nodes other ranks own, from their owners.
    std::vector<Vec3i> wanted;
    if (remote)
        for (const auto& leafImages : images)
            for (const Image& im : leafImages) wanted.push_back(im.source);
    const NodeReader reader(grid, remote, wanted);
    // Read every image first, then add: a node in front of one wall may lie beyond another (a corner).
    struct Add {
        int node;
        float mass;
        Vec3f momentum;
    };
    std::vector<std::vector<Add>> adds(grid.leafCount());
    forEachLeafRange(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t begin, std::size_t end) {
        for (std::size_t l = begin; l < end; ++l) {
            const LeafView* near = &grid.leaf(l);
            for (const Image& im : images[l]) {
                float m = 0.0f;
                Vec3f p = Vec3f::Zero();
                if (!reader.read(im.source, near, m, p) || m == 0.0f) continue;
                const auto reflect = [&](const Vec3f& a) {
                    return im.boundary == Boundary::Sticky ? Vec3f(-a) : Vec3f(a - 2.0f * a.dot(im.normal) * im.normal);
                };
                // The image's momentum reflected about the wall's, and its gravity impulse reflected (the update
                // adds m dt g to the node's whole mass after).
                const Vec3f momentum = m * im.velocity + reflect(p - m * im.velocity) + m * dt * (reflect(gravity) - gravity);
                adds[l].push_back({im.node, m, momentum});
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

ProjectionSummary projectOutOfColliders(const SparseGrid& grid, std::vector<AnySpecies>& species,
                                        const std::vector<std::unique_ptr<Collider>>& colliders, double tEnd, float dt, const Vec3d& gravity) {
    if (colliders.empty()) return {};
    const std::vector<uint32_t>& leaves = grid.particleLeaves();
    return reduceLeafRanges(
        leaves.size(), LeafGrain::Particles, ProjectionSummary{},
        [&](std::size_t begin, std::size_t end, ProjectionSummary& acc) {
            const auto contexts = contextsFor(colliders);
            for (std::size_t i = begin; i < end; ++i) {
                const uint32_t l = leaves[i];
                for (AnySpecies& s : species)
                    std::visit(
                        [&](auto& sp) {
                            for (std::size_t c = 0; c < colliders.size(); ++c) {
                                const Collider::ProjectionResult r = colliders[c]->projectParticles(
                                    sp.p, sp.leafStart[l], sp.leafStart[l + 1], grid.leaf(l).origin, grid.dx(), tEnd, dt, gravity, contexts[c].get());
                                acc.work += r.work;
                                acc.maxSpeed = std::max(acc.maxSpeed, r.maxSpeed);
                                acc.moved += r.moved;
                            }
                        },
                        s);
            }
        },
        [](ProjectionSummary a, const ProjectionSummary& b) {
            a.work += b.work;
            a.maxSpeed = std::max(a.maxSpeed, b.maxSpeed);
            a.moved += b.moved;
            return a;
        });
}

}  // namespace mpm
