#pragma once
// A grid's leaves by origin, for passes that read nodes of other leaves by coordinate (the mass gradient of
// multi-field contact, the mirror points of ghost nodes). Built once per pass, read by any number of tasks.
#include <cstdint>
#include <unordered_map>

#include "sparse/SparseGrid.h"

namespace mpm {

class LeafLookup {
public:
    explicit LeafLookup(const SparseGrid& grid) : grid_(&grid) {
        index_.reserve(grid.leafCount());
        for (std::size_t l = 0; l < grid.leafCount(); ++l) index_.emplace(grid.leaf(l).origin, uint32_t(l));
    }
    /// The origin of the leaf holding a node (floor to a multiple of the leaf size, negative coordinates too).
    static Vec3i originOf(const Vec3i& node) {
        return Vec3i(node[0] & ~(kLeafDim - 1), node[1] & ~(kLeafDim - 1), node[2] & ~(kLeafDim - 1));
    }
    const LeafView* find(const Vec3i& origin) const {
        const auto it = index_.find(origin);
        return it == index_.end() ? nullptr : &grid_->leaf(it->second);
    }
    /// The leaf holding a node and the node's offset in it; `near` is tried first. Null where no leaf is.
    const LeafView* at(const Vec3i& node, const LeafView* near, int& offset) const {
        const Vec3i o = originOf(node);
        const LeafView* leaf = near && near->origin == o ? near : find(o);
        if (leaf) offset = leafOffset(node[0] - o[0], node[1] - o[1], node[2] - o[2]);
        return leaf;
    }
    /// Mass at a node (zero where the grid has no leaf: nothing reaches there).
    float massAt(const Vec3i& node, const LeafView* near) const {
        int offset = 0;
        const LeafView* leaf = at(node, near, offset);
        return leaf ? leaf->mass[offset] : 0.0f;
    }

private:
    struct OriginHash {
        std::size_t operator()(const Vec3i& o) const {
            uint64_t h = uint64_t(uint32_t(o[0])) * 0x9E3779B97F4A7C15ull;
            h ^= uint64_t(uint32_t(o[1])) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
            h ^= uint64_t(uint32_t(o[2])) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
            return std::size_t(h);
        }
    };
    const SparseGrid* grid_;
    std::unordered_map<Vec3i, uint32_t, OriginHash> index_;
};

}  // namespace mpm
