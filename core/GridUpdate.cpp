#include "core/GridUpdate.h"

#include <algorithm>

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
                                      float dt, double tEnd, const SurfaceContact& surface, bool toVelocity) {
    return reduceLeafRanges(
        grid.leafCount(), LeafGrain::Nodes, GridUpdateResult{},
        [&](std::size_t begin, std::size_t end, GridUpdateResult& acc) {
            const auto contexts = contextsFor(colliders);
            for (std::size_t l = begin; l < end; ++l) {
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
