#pragma once
// Leaf geometry, in one place: the 8x8x8 leaf and its node order, the 8 neighbours a stencil can reach and
// how their index is encoded, and the rule that puts a particle's stencil on the grid (its base node). P2G,
// G2P, binning and the colliders must agree on these bit for bit, so nothing else may write them again.
#include <algorithm>
#include <cstdint>

#include "base/Types.h"

namespace mpm {

/// Edge of a leaf in nodes, and its node count (OpenVDB's LeafNode<T, 3>).
inline constexpr int kLeafLog2 = 3;
inline constexpr int kLeafDim = 1 << kLeafLog2;
inline constexpr int kLeafNodes = kLeafDim * kLeafDim * kLeafDim;

/// Offset of node (x, y, z), each in [0, 8), inside a leaf buffer (OpenVDB's x-major order).
inline int leafOffset(int x, int y, int z) { return (x << (2 * kLeafLog2)) | (y << kLeafLog2) | z; }
/// The inverse: the leaf-local coordinate of a node offset.
inline Vec3i leafLocal(int offset) {
    return Vec3i(offset >> (2 * kLeafLog2), (offset >> kLeafLog2) & (kLeafDim - 1), offset & (kLeafDim - 1));
}

/// A stencil is narrower than a leaf, so it reaches at most its own leaf and the next one along each axis:
/// the 8 leaves at leaf coordinate + d, d in {0,1}^3, numbered d_x * 4 + d_y * 2 + d_z (0 is the leaf itself).
inline constexpr int kNeighbours = 8;
/// Component a (0 = x, 1 = y, 2 = z) of neighbour d: 0 or 1.
inline constexpr int neighbourStep(int d, int a) { return (d >> (2 - a)) & 1; }
inline constexpr int neighbourIndex(int dx, int dy, int dz) { return (dx << 2) | (dy << 1) | dz; }
/// The neighbour that holds node (a, b, c) of a block starting at the leaf's first node (a, b, c < 16).
inline constexpr int neighbourOfBlockNode(int a, int b, int c) {
    return neighbourIndex(a >> kLeafLog2, b >> kLeafLog2, c >> kLeafLog2);
}

/// Positions must stay within +-kMaxGridCoordinate cells of the origin: node coordinates are ints, floorToInt
/// below is exact under 2^31, and the margin leaves room for a frame's travel (at most a cell per substep).
inline constexpr double kMaxGridCoordinate = double(1 << 30);

/// floor(t) as an int without a libm call (the portable x86-64 baseline has no SSE4.1 round instruction);
/// exact for |t| < 2^31, which bounds the grid anyway.
inline int floorToInt(double t) {
    const int i = int(t);  // truncates towards zero
    return i - (t < double(i));
}

/// Where a stencil sits on one axis: g = x / dx in cells, its base node floor(g - shift), and the offset
/// of the particle from that node in cells (exact up to double rounding, far from the origin too).
struct AxisPlacement {
    int base;
    float offset;
};
inline AxisPlacement placeOnAxis(double x, double invDx, double baseShift) {
    const double g = x * invDx;
    const int base = floorToInt(g - baseShift);
    return {base, float(g - double(base))};
}

/// The grid's spacing and the stencil's placement rule: base node = floor(x / dx - baseShift), width
/// nodes per axis from there (B-spline kernels, core/Kernels.h).
struct StencilGeometry {
    double dx = 1.0, invDx = 1.0, baseShift = 0.5;
    int width = 3;

    StencilGeometry() = default;
    StencilGeometry(double spacing, double shift, int stencilWidth)
        : dx(spacing), invDx(1.0 / spacing), baseShift(shift), width(stencilWidth) {}

    int baseOnAxis(double x) const { return placeOnAxis(x, invDx, baseShift).base; }
    Vec3i baseNode(const Vec3d& x) const { return Vec3i(baseOnAxis(x[0]), baseOnAxis(x[1]), baseOnAxis(x[2])); }
    /// World position of a node [m].
    Vec3d nodePosition(const Vec3i& node) const { return node.cast<double>() * dx; }
};

/// Leaf coordinate (one unit per leaf) of a node.
inline Vec3i leafOfNode(const Vec3i& node) { return Vec3i(node[0] >> kLeafLog2, node[1] >> kLeafLog2, node[2] >> kLeafLog2); }
/// Whether a node lies in the leaf at leaf coordinate `leaf`.
inline bool nodeInLeaf(const Vec3i& node, const Vec3i& leaf) {
    return (node[0] >> kLeafLog2) == leaf[0] && (node[1] >> kLeafLog2) == leaf[1] && (node[2] >> kLeafLog2) == leaf[2];
}
/// The neighbour (of the leaf holding `base`) that holds the far corner of a stencil starting at node `base`.
inline int farCornerNeighbour(const Vec3i& base, int width) {
    auto step = [&](int a) { return ((base[a] & (kLeafDim - 1)) + width - 1) >> kLeafLog2; };
    return neighbourIndex(step(0), step(1), step(2));
}

/// A box of a leaf's nodes, [lo, hi) per axis in leaf-local coordinates 0..8; empty when lo >= hi on an axis.
struct NodeBox {
    int8_t lo[3] = {kLeafDim, kLeafDim, kLeafDim};
    int8_t hi[3] = {0, 0, 0};
    bool empty() const { return lo[0] >= hi[0] || lo[1] >= hi[1] || lo[2] >= hi[2]; }
    /// Grows this box to hold b too.
    void add(const NodeBox& b) {
        if (b.empty()) return;
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], b.lo[a]);
            hi[a] = std::max(hi[a], b.hi[a]);
        }
    }
    /// Calls f(node offset) for every node in the box, the innermost (z) runs contiguous in memory.
    template <class F>
    void forEach(F&& f) const {
        for (int x = lo[0]; x < hi[0]; ++x)
            for (int y = lo[1]; y < hi[1]; ++y)
                for (int z = lo[2]; z < hi[2]; ++z) f(leafOffset(x, y, z));
    }
};

/// Raw view of one leaf: its buffers and the integer coordinate of its first node.
struct LeafView {
    float* mass = nullptr;
    float* momentum = nullptr;  ///< 3 floats per node; holds velocity after the grid update
    Vec3i origin = Vec3i::Zero();
};

}  // namespace mpm

namespace mpm {

/// The order of leaves everywhere (the grid's leaf list, particle storage, the ranks' ranges): Morton order
/// of leaf coordinates, x the most significant axis of each bit triple. Coordinates are offset to unsigned
/// (the grid stays within 2^30 cells, 2^27 leaves, of the origin), and two keys compare by the axis whose
/// coordinates differ in the highest bit (Chan's trick), so no 84-bit key is built.
inline bool mortonLess(const Vec3i& a, const Vec3i& b) {
    constexpr uint32_t kOffset = uint32_t(1) << 30;
    uint32_t ua[3], ub[3];
    for (int k = 0; k < 3; ++k) ua[k] = uint32_t(a[k]) + kOffset, ub[k] = uint32_t(b[k]) + kOffset;
    int axis = 0;
    uint32_t highest = ua[0] ^ ub[0];
    for (int k = 1; k < 3; ++k) {
        const uint32_t diff = ua[k] ^ ub[k];
        if (highest < diff && highest < (highest ^ diff)) highest = diff, axis = k;
    }
    return ua[axis] < ub[axis];
}

/// Lexicographic order of node coordinates: for sorted lists of nodes looked up by binary search.
inline bool nodeLess(const Vec3i& a, const Vec3i& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
}

}  // namespace mpm
