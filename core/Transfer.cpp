#include "core/Transfer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "sparse/LeafParallel.h"

namespace mpm {

namespace {

/// Up to this many particles in a leaf, the transfers find the part of the local block they reach.
constexpr std::size_t kFewParticles = 32;

/// Four floats in one SSE register (GCC/Clang vector extension): a node's (mass, momentum) in P2G and its
/// (velocity, 0) in G2P, so that each node costs one vector operation instead of four scalar ones.
using f4 = float __attribute__((vector_size(16)));
inline f4 splat(float a) { return f4{a, a, a, a}; }
/// (0, a) for a 3-vector a: a column that adds to momentum and leaves mass alone.
inline f4 lanes123(float a, float b, float c) { return f4{0.0f, a, b, c}; }

/// A dense block covering a leaf plus the stencil's reach into its +x/+y/+z neighbours.
template <class K>
struct LocalBlock {
    static constexpr int N = kLeafDim + K::kWidth - 1;
    static constexpr int kNodes = N * N * N;
    static int index(int a, int b, int c) { return (a * N + b) * N + c; }
    /// Block nodes [lo, hi) per axis.
    struct Range {
        int lo[3], hi[3];
    };
    /// The part of the block that the particles of leaf l reach. A leaf with few particles (spray) needs a
    /// small part of its block; zeroing, adding and gathering only that part makes a lone particle cost its
    /// stencil rather than the N^3 block. Crowded leaves skip the scan and take the whole block.
    static Range reach(const std::vector<AnySpecies>& species, uint32_t l, const Vec3i& origin, double dx) {
        std::size_t count = 0;
        for (const AnySpecies& s : species)
            std::visit([&](const auto& sp) { count += sp.leafStart[l + 1] - sp.leafStart[l]; }, s);
        if (count > kFewParticles) return Range{{0, 0, 0}, {N, N, N}};
        Range r{{N, N, N}, {0, 0, 0}};
        const double invDx = 1.0 / dx;
        for (const AnySpecies& s : species)
            std::visit(
                [&](const auto& sp) {
                    for (uint32_t p = sp.leafStart[l]; p < sp.leafStart[l + 1]; ++p)
                        for (int a = 0; a < 3; ++a) {
                            const int base = placeOnAxis(sp.p.x[p][a], invDx, K::kBaseShift).base - origin[a];
                            r.lo[a] = std::min(r.lo[a], base);
                            r.hi[a] = std::max(r.hi[a], base + K::kWidth);
                        }
                },
                s);
        return r;
    }
    static bool whole(const Range& r) {
        return r.lo[0] == 0 && r.lo[1] == 0 && r.lo[2] == 0 && r.hi[0] == N && r.hi[1] == N && r.hi[2] == N;
    }
    /// Visits the block nodes in r with the leaf among the 8 neighbours that holds each and its offset there.
    template <class F>
    static void forEachNode(const SparseGrid& grid, uint32_t l, const Range& r, F&& f) {
        // The whole block with constant bounds, which the compiler unrolls; a part of it with the range's.
        if (whole(r))
            visit(grid, l, Range{{0, 0, 0}, {N, N, N}}, f, std::true_type{});
        else
            visit(grid, l, r, f, std::false_type{});
    }
    template <class F, bool Whole>
    static void visit(const SparseGrid& grid, uint32_t l, const Range& r, F& f, std::bool_constant<Whole>) {
        const auto& nb = grid.neighbours(l);
        const int lo0 = Whole ? 0 : r.lo[0], lo1 = Whole ? 0 : r.lo[1], lo2 = Whole ? 0 : r.lo[2];
        const int hi0 = Whole ? N : r.hi[0], hi1 = Whole ? N : r.hi[1], hi2 = Whole ? N : r.hi[2];
        for (int a = lo0; a < hi0; ++a)
            for (int b = lo1; b < hi1; ++b)
                for (int c = lo2; c < hi2; ++c) {
                    // A neighbour that no stencil of this leaf reaches is not allocated; nothing reads it.
                    const uint32_t n = nb[neighbourOfBlockNode(a, b, c)];
                    if (n == SparseGrid::kNoLeaf) continue;
                    f(index(a, b, c), grid.leaf(n), leafOffset(a & (kLeafDim - 1), b & (kLeafDim - 1), c & (kLeafDim - 1)));
                }
    }
};

/// Weights of one particle: base node relative to its leaf, and per axis the weights w, their derivatives
/// dw (per cell) and the node offsets d = x_i - x_p [m].
template <class K>
struct Stencil {
    int local[3];
    float fx[3];
    float w[3][K::kWidth];
    float dw[3][K::kWidth];
    float d[3][K::kWidth];

    [[gnu::always_inline]] Stencil(const Vec3d& x, double invDx, float dx, const Vec3i& leafOrigin) {
        for (int a = 0; a < 3; ++a) {
            const AxisPlacement at = placeOnAxis(x[a], invDx, K::kBaseShift);
            fx[a] = at.offset;
            local[a] = at.base - leafOrigin[a];
            K::weights(fx[a], w[a], dw[a]);
            for (int i = 0; i < K::kWidth; ++i) d[a][i] = (float(i) - fx[a]) * dx;
        }
    }
    int node(int i, int j, int k) const { return LocalBlock<K>::index(local[0] + i, local[1] + j, local[2] + k); }
};

/// P2G of one species' particles into the local block (lane 0 mass, lanes 1-3 momentum). Per node:
///   m_i += w m,   (mv)_i += w (m v + A d) + S grad w,
/// with A = m C (APIC) or m C - dt V0 D^-1 tau (MLS, and then S = 0), S = -dt V0 tau / dx (standard force).
/// The sums factor along the axes, so the inner loop does a handful of vector operations per node.
template <class K, bool MLS, class Sp>
void scatterSpecies(Sp& sp, uint32_t begin, uint32_t end, const Vec3i& origin, double dx, float dt, f4* block) {
    using M = typename Sp::Material;
    constexpr int W = K::kWidth;
    const double invDx = 1.0 / dx;
    const float fdx = float(dx), finvDx = float(invDx);
    const float Dinv = K::kInverseInertia * finvDx * finvDx;
    const ParticleArrays& P = sp.p;
    Mat3f stress[simd::kLanes];
    for (uint32_t p = begin; p < end; ++p) {
        // Stresses a batch at a time: the SVD-based models evaluate theirs in SIMD lanes.
        const uint32_t lane = (p - begin) % simd::kLanes;
        if (lane == 0) kirchhoffOfRange<M>(sp, p, int(std::min<uint32_t>(simd::kLanes, end - p)), stress);
        const Mat3f& tau = stress[lane];
        const Stencil<K> st(P.x[p], invDx, fdx, origin);
        const float m = P.mass[p];
        const Vec3f mv = m * P.v[p];
        const Mat3f A = MLS ? Mat3f(m * P.C[p] - (dt * P.volume0[p] * Dinv) * tau) : Mat3f(m * P.C[p]);
        const f4 q{m, mv[0], mv[1], mv[2]};
        const f4 ax = lanes123(A(0, 0), A(1, 0), A(2, 0)), ay = lanes123(A(0, 1), A(1, 1), A(2, 1)),
                 az = lanes123(A(0, 2), A(1, 2), A(2, 2));
        f4 sx{}, sy{}, sz{};
        if constexpr (!MLS) {
            const Mat3f S = (-dt * P.volume0[p] * finvDx) * tau;
            sx = lanes123(S(0, 0), S(1, 0), S(2, 0));
            sy = lanes123(S(0, 1), S(1, 1), S(2, 1));
            sz = lanes123(S(0, 2), S(1, 2), S(2, 2));
        }
        // Node (i, j, k) gets w_k Q_ij + w_k d_k A_ij + dw_k Sz_ij, where Q_ij = w_ij (q + d_i ax + d_j ay)
        // + the x, y stress terms, A_ij = w_ij az and Sz_ij = w_ij sz: three FMAs per node, the rest per row.
        float wd2[W];
        for (int k = 0; k < W; ++k) wd2[k] = st.w[2][k] * st.d[2][k];
        for (int i = 0; i < W; ++i) {
            const f4 qi = q + st.d[0][i] * ax;
            for (int j = 0; j < W; ++j) {
                const float wij = st.w[0][i] * st.w[1][j];
                f4 Qij = wij * (qi + st.d[1][j] * ay);
                const f4 Aij = wij * az;
                f4 Szij{};
                if constexpr (!MLS) {
                    Qij += (st.dw[0][i] * st.w[1][j]) * sx + (st.w[0][i] * st.dw[1][j]) * sy;
                    Szij = wij * sz;
                }
                f4* row = block + st.node(i, j, 0);
                for (int k = 0; k < W; ++k) {
                    f4 c = st.w[2][k] * Qij + wd2[k] * Aij;
                    if constexpr (!MLS) c += st.dw[2][k] * Szij;
                    row[k] += c;
                }
            }
        }
    }
}

/// Zeroes the nodes of a leaf in box b.
void zero(const LeafView& leaf, const NodeBox& b) {
    if (b.empty()) return;
    const int run = b.hi[2] - b.lo[2];
    for (int x = b.lo[0]; x < b.hi[0]; ++x)
        for (int y = b.lo[1]; y < b.hi[1]; ++y) {
            const int o = leafOffset(x, y, b.lo[2]);
            std::memset(leaf.mass + o, 0, sizeof(float) * run);
            std::memset(leaf.momentum + 3 * o, 0, sizeof(float) * 3 * run);
        }
}

/// P2G in two passes, neither of which needs colouring or locks, so that every leaf is a task of its own:
///  1. each particle leaf scatters into a local block on its stack, writes the block's own-leaf part into its
///     leaf (no one else writes there yet), and keeps the halo, the parts that belong to its +x/+y/+z
///     neighbours, in the grid's workspace;
///  2. each grid leaf adds the halos of the (up to 7) particle leaves below it, in a fixed order, so the
///     sums do not depend on the thread count.
template <class K, bool MLS>
void scatterAll(SparseGrid& grid, std::vector<AnySpecies>& species, float dt, const RemoteHalos* remote) {
    using B = LocalBlock<K>;
    using Range = typename B::Range;
    const std::vector<uint32_t>& leaves = grid.particleLeaves();
    const std::size_t P = leaves.size();
    // Part d of a range: the block nodes that lie in neighbour d (d = 0 the leaf itself).
    auto part = [](const Range& r, int d) {
        Range q;
        for (int a = 0; a < 3; ++a) {
            const bool up = neighbourStep(d, a);
            q.lo[a] = std::max(r.lo[a], up ? kLeafDim : 0);
            q.hi[a] = std::min(r.hi[a], up ? B::N : kLeafDim);
        }
        return q;
    };
    auto volume = [](const Range& r) {
        return std::size_t(std::max(0, r.hi[0] - r.lo[0]) * std::max(0, r.hi[1] - r.lo[1]) * std::max(0, r.hi[2] - r.lo[2]));
    };
    // Part d of a range in the coordinates of neighbour d.
    auto box = [](const Range& q, int d) {
        NodeBox b;
        for (int a = 0; a < 3; ++a) {
            const int shift = neighbourStep(d, a) * kLeafDim;
            b.lo[a] = int8_t(q.lo[a] - shift);
            b.hi[a] = int8_t(q.hi[a] - shift);
        }
        return b;
    };
    std::vector<Range> range(P);
    std::vector<std::size_t> offset(P);
    std::vector<std::array<std::size_t, kNeighbours>> partStart(P);  // where pass 1 put each halo part d = 1..7
    // The part of particle leaf i's block kept for neighbour d: none where that neighbour is not
    // allocated (no stencil reaches it, so the block is zero there).
    auto halo = [&](std::size_t i, int d) {
        return grid.neighbours(leaves[i])[d] == SparseGrid::kNoLeaf ? Range{{0, 0, 0}, {0, 0, 0}} : part(range[i], d);
    };
    auto haloVolume = [&](std::size_t i) {
        std::size_t v = 0;
        for (int d = 1; d < kNeighbours; ++d) v += volume(halo(i, d));
        return v;
    };
    forEachLeaf(P, LeafGrain::Particles,
                [&](std::size_t i) { range[i] = B::reach(species, leaves[i], grid.leaf(leaves[i]).origin, grid.dx()); });
    const std::size_t total =
        prefixSumOverLeaves<std::size_t>(P, haloVolume, [&](std::size_t i, std::size_t sum) { offset[i] = sum; });
    std::vector<float>& scratch = grid.transferScratch();
    if (scratch.size() < 4 * total) scratch.resize(4 * total);
    f4* const halos = reinterpret_cast<f4*>(scratch.data());  // malloc aligns to 16 bytes on x86-64

    // Pass 1. The halo parts d = 1..7 are stored one after another, each x-major over its box.
    forEachLeaf(P, LeafGrain::Particles, [&](std::size_t i) {
        const uint32_t l = leaves[i];
        const Range& r = range[i];
        const LeafView& leaf = grid.leaf(l);
        // Zeroed to +0, so no sum in the block or in a node is ever -0: the halo parts that hold only zeros (a
        // crowded leaf keeps its whole block's) then leave every node's bits as they are, on one rank or many.
        f4 block[B::kNodes];
        if (B::whole(r))
            std::memset(static_cast<void*>(block), 0, sizeof(block));
        else
            for (int a = r.lo[0]; a < r.hi[0]; ++a)
                for (int b = r.lo[1]; b < r.hi[1]; ++b)
                    std::memset(static_cast<void*>(block + B::index(a, b, r.lo[2])), 0, sizeof(f4) * (r.hi[2] - r.lo[2]));
        for (AnySpecies& s : species)
            std::visit(
                [&](auto& sp) {
                    scatterSpecies<K, MLS>(sp, sp.leafStart[l], sp.leafStart[l + 1], leaf.origin, grid.dx(), dt, block);
                },
                s);
        const Range own = part(r, 0);
        if (volume(own) < std::size_t(kLeafNodes)) zero(leaf, grid.writtenBox(l));  // what the last substep left
        for (int a = own.lo[0]; a < own.hi[0]; ++a)
            for (int b = own.lo[1]; b < own.hi[1]; ++b)
                for (int c = own.lo[2]; c < own.hi[2]; ++c) {
                    const f4 v = block[B::index(a, b, c)];
                    const int o = leafOffset(a, b, c);
                    leaf.mass[o] = v[0];
                    leaf.momentum[3 * o + 0] = v[1];
                    leaf.momentum[3 * o + 1] = v[2];
                    leaf.momentum[3 * o + 2] = v[3];
                }
        f4* out = halos + offset[i];
        for (int d = 1; d < kNeighbours; ++d) {
            partStart[i][d] = std::size_t(out - halos);
            const Range q = halo(i, d);
            if (volume(q) == 0) continue;
            for (int a = q.lo[0]; a < q.hi[0]; ++a)
                for (int b = q.lo[1]; b < q.hi[1]; ++b, out += q.hi[2] - q.lo[2])
                    std::memcpy(static_cast<void*>(out), block + B::index(a, b, q.lo[2]), sizeof(f4) * (q.hi[2] - q.lo[2]));
        }
    });

    // Between the passes, on several ranks: parts for leaves another rank owns go there, and parts other
    // ranks computed for leaves owned here come in; remotePart[8 g + d] is the incoming part d of leaf g.
    const std::vector<uint8_t>* owned = remote ? remote->owned : nullptr;
    HaloParts incoming;
    std::vector<int32_t> remotePart;
    if (owned) {
        HaloParts out;
        for (std::size_t g = 0; g < grid.leafCount(); ++g) {
            if ((*owned)[g]) continue;
            const std::array<uint32_t, kNeighbours>& src = grid.sources(g);
            for (int d = 1; d < kNeighbours; ++d) {
                if (src[d] == SparseGrid::kNoLeaf) continue;
                const Range q = halo(src[d], d);
                const std::size_t n = volume(q);
                if (n == 0) continue;
                HaloParts::Part part{leafOfNode(grid.leaf(g).origin), d, {}, {}, out.data.size() / 4};
                for (int a = 0; a < 3; ++a) part.lo[a] = int8_t(q.lo[a]), part.hi[a] = int8_t(q.hi[a]);
                const float* from = reinterpret_cast<const float*>(halos + partStart[src[d]][d]);
                out.data.insert(out.data.end(), from, from + 4 * n);
                out.parts.push_back(part);
            }
        }
        incoming = remote->exchange(std::move(out));
        remotePart.assign(kNeighbours * grid.leafCount(), -1);
        for (std::size_t k = 0; k < incoming.parts.size(); ++k) {
            const uint32_t g = grid.indexOfLeaf(incoming.parts[k].leaf);
            remotePart[kNeighbours * std::size_t(g) + std::size_t(incoming.parts[k].d)] = int32_t(k);
        }
    }

    // Pass 2. Block node (a, b, c) of the particle leaf at offset -d lies in this leaf at (a, b, c) - 8 d.
    forEachLeaf(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t g) {
        if (owned && !(*owned)[g]) return;  // a ghost: its owner sums it and sends the velocities back
        const LeafView& leaf = grid.leaf(g);
        const std::array<uint32_t, kNeighbours>& src = grid.sources(g);
        NodeBox written;
        if (src[0] == SparseGrid::kNoLeaf)
            zero(leaf, grid.writtenBox(g));  // no particles of its own: pass 1 did not write it
        else
            written = box(part(range[src[0]], 0), 0);
        for (int d = 1; d < kNeighbours; ++d) {
            const f4* in = nullptr;
            Range q;
            if (src[d] != SparseGrid::kNoLeaf) {
                in = halos + partStart[src[d]][d];
                q = halo(src[d], d);
            } else if (owned && remotePart[kNeighbours * g + std::size_t(d)] >= 0) {
                const HaloParts::Part& part = incoming.parts[std::size_t(remotePart[kNeighbours * g + std::size_t(d)])];
                in = reinterpret_cast<const f4*>(incoming.data.data()) + part.offset;
                for (int a = 0; a < 3; ++a) q.lo[a] = part.lo[a], q.hi[a] = part.hi[a];
            } else {
                continue;
            }
            if (volume(q) == 0) continue;
            const int shift[3] = {kLeafDim * neighbourStep(d, 0), kLeafDim * neighbourStep(d, 1), kLeafDim * neighbourStep(d, 2)};
            written.add(box(q, d));
            for (int a = q.lo[0]; a < q.hi[0]; ++a)
                for (int b = q.lo[1]; b < q.hi[1]; ++b)
                    for (int c = q.lo[2]; c < q.hi[2]; ++c, ++in) {
                        const int o = leafOffset(a - shift[0], b - shift[1], c - shift[2]);
                        leaf.mass[o] += (*in)[0];
                        leaf.momentum[3 * o + 0] += (*in)[1];
                        leaf.momentum[3 * o + 1] += (*in)[2];
                        leaf.momentum[3 * o + 2] += (*in)[3];
                    }
        }
        grid.writtenBox(g) = written;
    });
}

/// G2P of one species' particles from the local velocity block (lanes 0-2). Gathers
///   v = sum w v_i,  B = sum w v_i d^T (eq. 3.18),  grad v = sum v_i grad w^T (eq. 3.19),
/// axis by axis: the k sums first, then j, then i, so each node costs three vector FMAs.
template <class K, bool MLS, class Sp>
void gatherSpecies(Sp& sp, uint32_t begin, uint32_t end, const Vec3i& origin, double dx, float dt, bool apic, const f4* vel,
                   float& maxSpeed, float& minKey, G2PSummary& bad, int speciesIndex) {
    using M = typename Sp::Material;
    constexpr int W = K::kWidth;
    const double invDx = 1.0 / dx;
    const float fdx = float(dx), finvDx = float(invDx);
    const float Dinv = K::kInverseInertia * finvDx * finvDx;
    ParticleArrays& P = sp.p;
    Mat3f gradVs[simd::kLanes];
    for (uint32_t p = begin; p < end; ++p) {
        const Stencil<K> st(P.x[p], invDx, fdx, origin);
        f4 v{}, b0{}, b1{}, b2{}, g0{}, g1{}, g2{};  // v; columns of B; columns of grad v (per cell)
        for (int i = 0; i < W; ++i) {
            f4 s{}, sdy{}, sdz{}, sgy{}, sgz{};  // sums over j, k of w_j w_k v_i, times d_y, d_z, or with dw_j, dw_k
            for (int j = 0; j < W; ++j) {
                const f4* row = vel + st.node(i, j, 0);
                f4 r{}, rdz{}, rgz{};  // sums over k of w_k v_i, w_k d_z v_i, dw_k v_i
                for (int k = 0; k < W; ++k) {
                    r += st.w[2][k] * row[k];
                    rdz += (st.w[2][k] * st.d[2][k]) * row[k];
                    if constexpr (!MLS) rgz += st.dw[2][k] * row[k];
                }
                s += st.w[1][j] * r;
                sdy += (st.w[1][j] * st.d[1][j]) * r;
                sdz += st.w[1][j] * rdz;
                if constexpr (!MLS) {
                    sgy += st.dw[1][j] * r;
                    sgz += st.w[1][j] * rgz;
                }
            }
            v += st.w[0][i] * s;
            b0 += (st.w[0][i] * st.d[0][i]) * s;
            b1 += st.w[0][i] * sdy;
            b2 += st.w[0][i] * sdz;
            if constexpr (!MLS) {
                g0 += st.dw[0][i] * s;
                g1 += st.w[0][i] * sgy;
                g2 += st.w[0][i] * sgz;
            }
        }
        const Vec3f vp(v[0], v[1], v[2]);
        Mat3f C;
        C << b0[0], b1[0], b2[0], b0[1], b1[1], b2[1], b0[2], b1[2], b2[2];
        C *= Dinv;
        Mat3f gradV;
        if constexpr (MLS) {
            gradV = C;
        } else {
            gradV << g0[0], g1[0], g2[0], g0[1], g1[1], g2[1], g0[2], g1[2], g2[2];
            gradV *= finvDx;
        }
        P.v[p] = vp;
        P.C[p] = apic ? C : Mat3f::Zero();
        P.x[p] += double(dt) * vp.cast<double>();
        // Deformation updates a batch at a time: the SVD-based return maps run their SVDs in SIMD lanes.
        const uint32_t lane = (p - begin) % simd::kLanes;
        gradVs[lane] = gradV;
        if (lane + 1 < simd::kLanes && p + 1 < end) continue;
        const uint32_t first = p - lane;
        updateDeformationOfRange<M>(sp, first, int(lane + 1), gradVs, dt);
        for (uint32_t q = first; q <= p; ++q) {
            const float key = M::stiffnessKey(sp.state, q);
            const Vec3f& vq = P.v[q];
            if (!(std::isfinite(vq[0]) && std::isfinite(vq[1]) && std::isfinite(vq[2]) && std::isfinite(key))) {
                if (bad.badParticle < 0) {
                    bad.badSpecies = speciesIndex;
                    bad.badParticle = q;
                    bad.badField = std::isfinite(key) ? "velocity" : "deformation";
                }
                continue;
            }
            maxSpeed = std::max(maxSpeed, vq.norm());
            minKey = std::min(minKey, key);
        }
    }
}

template <class K, bool MLS>
void gatherLeaf(const SparseGrid& grid, std::vector<AnySpecies>& species, uint32_t l, float dt, bool apic, float& maxSpeed,
                float* minKey, G2PSummary& bad) {
    using B = LocalBlock<K>;
    f4 vel[B::kNodes];
    const Vec3i origin = grid.leaf(l).origin;
    B::forEachNode(grid, l, B::reach(species, l, origin, grid.dx()), [&](int n, const LeafView& leaf, int off) {
        const float* src = leaf.momentum + 3 * off;
        vel[n] = f4{src[0], src[1], src[2], 0.0f};
    });
    for (std::size_t s = 0; s < species.size(); ++s)
        std::visit(
            [&](auto& sp) {
                gatherSpecies<K, MLS>(sp, sp.leafStart[l], sp.leafStart[l + 1], origin, grid.dx(), dt, apic, vel, maxSpeed,
                                      minKey[s], bad, int(s));
            },
            species[s]);
}

template <class F>
decltype(auto) withScheme(const TransferSettings& s, F&& f) {
    return withKernel(s.interpolation, [&]<class K>() {
        if (s.force == ForceScheme::MLS) return f.template operator()<K, true>();
        return f.template operator()<K, false>();
    });
}

}  // namespace

void particlesToGrid(SparseGrid& grid, std::vector<AnySpecies>& species, const TransferSettings& s, float dt,
                     const RemoteHalos* remote) {
    withScheme(s, [&]<class K, bool MLS>() { scatterAll<K, MLS>(grid, species, dt, remote); });
}

G2PSummary gridToParticles(const SparseGrid& grid, std::vector<AnySpecies>& species, const TransferSettings& s, float dt) {
    const std::vector<uint32_t>& leaves = grid.particleLeaves();
    G2PSummary none;
    none.minStiffnessKey.assign(species.size(), std::numeric_limits<float>::infinity());
    const bool apic = s.transfer == TransferScheme::APIC;
    // A deterministic reduction (fixed split, joins in leaf order): the first bad particle reported is the
    // first in leaf order whatever the thread count, and no serial pass over the leaves is left.
    return withScheme(s, [&]<class K, bool MLS>() {
        return reduceLeaves(
            leaves.size(), LeafGrain::Particles, none,
            [&](std::size_t i, G2PSummary& acc) {
                gatherLeaf<K, MLS>(grid, species, leaves[i], dt, apic, acc.maxSpeed, acc.minStiffnessKey.data(), acc);
            },
            [](G2PSummary a, const G2PSummary& b) {
                a.maxSpeed = std::max(a.maxSpeed, b.maxSpeed);
                for (std::size_t sp = 0; sp < a.minStiffnessKey.size(); ++sp)
                    a.minStiffnessKey[sp] = std::min(a.minStiffnessKey[sp], b.minStiffnessKey[sp]);
                if (a.badParticle < 0 && b.badParticle >= 0) {
                    a.badSpecies = b.badSpecies;
                    a.badParticle = b.badParticle;
                    a.badField = b.badField;
                }
                return a;
            });
    });
}

}  // namespace mpm
