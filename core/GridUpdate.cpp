#include "core/GridUpdate.h"

#include <algorithm>

#include "sparse/LeafParallel.h"

namespace mpm {

float updateGridVelocities(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, const Vec3f& g,
                           float dt, double tEnd) {
    return reduceLeafRanges(
        grid.leafCount(), LeafGrain::Nodes, 0.0f,
        [&](std::size_t begin, std::size_t end, float& vmax) {
            // One context per collider and task, so that a collider sampling a tree keeps its accessor warm.
            std::vector<std::unique_ptr<ColliderContext>> contexts;
            for (const auto& c : colliders) contexts.push_back(c->makeContext());
            for (std::size_t l = begin; l < end; ++l) {
                const LeafView& leaf = grid.leaf(l);
                // Only the nodes P2G wrote: all others are zero, and stay so.
                const NodeBox& box = grid.writtenBox(l);
                // v = (mv) / m on nodes with mass (exact comparison: a threshold would lose momentum), then gravity.
                box.forEach([&](int n) {
                    Eigen::Map<Vec3f> v(leaf.momentum + 3 * n);
                    const float m = leaf.mass[n];
                    if (m != 0.0f)
                        v = v / m + dt * g;
                    else
                        v.setZero();
                });
                for (std::size_t c = 0; c < colliders.size(); ++c)
                    colliders[c]->applyToLeaf(leaf, box, grid.dx(), tEnd, contexts[c].get());
                box.forEach([&](int n) {
                    if (leaf.mass[n] != 0.0f) vmax = std::max(vmax, Eigen::Map<const Vec3f>(leaf.momentum + 3 * n).norm());
                });
            }
        },
        [](float a, float b) { return std::max(a, b); });
}

}  // namespace mpm
