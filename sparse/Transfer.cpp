#include "sparse/Transfer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace mpm {

namespace {

/// A dense block covering a leaf plus the stencil's reach into its +x/+y/+z neighbours.
template <class K>
struct LocalBlock {
    static constexpr int N = kLeafDim + K::kWidth - 1;
    static constexpr int kNodes = N * N * N;
    static int index(int a, int b, int c) { return (a * N + b) * N + c; }
};

/// Weights of one particle: base node relative to its leaf, and per-axis weights and derivatives.
template <class K>
struct Stencil {
    int local[3];
    float fx[3];
    float w[3][K::kWidth];
    float dw[3][K::kWidth];

    Stencil(const Vec3d& x, double invDx, const Vec3i& leafOrigin) {
        for (int a = 0; a < 3; ++a) {
            const double g = x[a] * invDx;
            const double base = std::floor(g - K::kBaseShift);
            fx[a] = float(g - base);  // exact up to double rounding, far from the origin too
            local[a] = int(base) - leafOrigin[a];
            K::weights(fx[a], w[a], dw[a]);
        }
    }
};

template <class K, bool MLS, class Sp>
void scatterSpecies(Sp& sp, uint32_t begin, uint32_t end, const Vec3i& origin, double dx, float dt, float* mass,
                    float (*mom)[3]) {
    using M = typename Sp::Material;
    using B = LocalBlock<K>;
    constexpr int W = K::kWidth;
    const double invDx = 1.0 / dx;
    const float fdx = float(dx), finvDx = float(invDx);
    const float Dinv = K::kInverseInertia * finvDx * finvDx;
    const ParticleArrays& P = sp.p;
    for (uint32_t p = begin; p < end; ++p) {
        const Stencil<K> st(P.x[p], invDx, origin);
        const float m = P.mass[p];
        const Vec3f mv = m * P.v[p];
        const Mat3f tau = M::kirchhoff(sp.params, sp.state, p);
        // MLS folds the stress into the affine term; the standard force uses grad w explicitly.
        const Mat3f affine = MLS ? Mat3f(m * P.C[p] - (dt * P.volume0[p] * Dinv) * tau) : Mat3f(m * P.C[p]);
        const Mat3f stressImpulse = (-dt * P.volume0[p] * finvDx) * tau;
        for (int i = 0; i < W; ++i) {
            const float dxi = (float(i) - st.fx[0]) * fdx;
            for (int j = 0; j < W; ++j) {
                const float dyj = (float(j) - st.fx[1]) * fdx;
                const float wij = st.w[0][i] * st.w[1][j];
                for (int k = 0; k < W; ++k) {
                    const float dzk = (float(k) - st.fx[2]) * fdx;
                    const float w = wij * st.w[2][k];
                    Vec3f contrib = w * (mv + affine * Vec3f(dxi, dyj, dzk));
                    if constexpr (!MLS) {
                        const Vec3f gradW(st.dw[0][i] * st.w[1][j] * st.w[2][k], st.w[0][i] * st.dw[1][j] * st.w[2][k],
                                          st.w[0][i] * st.w[1][j] * st.dw[2][k]);
                        contrib += stressImpulse * gradW;
                    }
                    const int n = B::index(st.local[0] + i, st.local[1] + j, st.local[2] + k);
                    mass[n] += w * m;
                    mom[n][0] += contrib[0];
                    mom[n][1] += contrib[1];
                    mom[n][2] += contrib[2];
                }
            }
        }
    }
}

template <class K, bool MLS>
void scatterLeaf(const SparseGrid& grid, std::vector<AnySpecies>& species, uint32_t l, float dt) {
    using B = LocalBlock<K>;
    float mass[B::kNodes];
    float mom[B::kNodes][3];
    std::memset(mass, 0, sizeof(mass));
    std::memset(mom, 0, sizeof(mom));
    const Vec3i origin = grid.leaf(l).origin;
    for (AnySpecies& s : species)
        std::visit([&](auto& sp) { scatterSpecies<K, MLS>(sp, sp.leafStart[l], sp.leafStart[l + 1], origin, grid.dx(), dt, mass, mom); },
                   s);
    // Add the local block into the leaf and its 7 neighbours; the colouring keeps this race free.
    const auto& nb = grid.neighbours(l);
    for (int a = 0; a < B::N; ++a)
        for (int b = 0; b < B::N; ++b)
            for (int c = 0; c < B::N; ++c) {
                const int n = B::index(a, b, c);
                if (mass[n] == 0.0f) continue;
                const LeafView& leaf = grid.leaf(nb[((a >> kLeafLog2) << 2) | ((b >> kLeafLog2) << 1) | (c >> kLeafLog2)]);
                const int off = leafOffset(a & (kLeafDim - 1), b & (kLeafDim - 1), c & (kLeafDim - 1));
                leaf.mass[off] += mass[n];
                leaf.momentum[3 * off + 0] += mom[n][0];
                leaf.momentum[3 * off + 1] += mom[n][1];
                leaf.momentum[3 * off + 2] += mom[n][2];
            }
}

template <class K, bool MLS, class Sp>
void gatherSpecies(Sp& sp, uint32_t begin, uint32_t end, const Vec3i& origin, double dx, float dt, bool apic,
                   const float (*vel)[3], float& maxSpeed, float& minKey, G2PSummary& bad, int speciesIndex) {
    using M = typename Sp::Material;
    constexpr int W = K::kWidth;
    using B = LocalBlock<K>;
    const double invDx = 1.0 / dx;
    const float fdx = float(dx), finvDx = float(invDx);
    const float Dinv = K::kInverseInertia * finvDx * finvDx;
    ParticleArrays& P = sp.p;
    for (uint32_t p = begin; p < end; ++p) {
        const Stencil<K> st(P.x[p], invDx, origin);
        Vec3f v = Vec3f::Zero();
        Mat3f Bp = Mat3f::Zero();      // sum w v_i (x_i - x_p)^T  (eq. 3.18)
        Mat3f gradV = Mat3f::Zero();   // sum v_i grad w^T         (eq. 3.19)
        for (int i = 0; i < W; ++i) {
            const float dxi = (float(i) - st.fx[0]) * fdx;
            for (int j = 0; j < W; ++j) {
                const float dyj = (float(j) - st.fx[1]) * fdx;
                const float wij = st.w[0][i] * st.w[1][j];
                for (int k = 0; k < W; ++k) {
                    const float dzk = (float(k) - st.fx[2]) * fdx;
                    const float w = wij * st.w[2][k];
                    const float* vi = vel[B::index(st.local[0] + i, st.local[1] + j, st.local[2] + k)];
                    const Vec3f vn(vi[0], vi[1], vi[2]);
                    v += w * vn;
                    Bp += (w * vn) * Vec3f(dxi, dyj, dzk).transpose();
                    if constexpr (!MLS) {
                        const Vec3f gradW(st.dw[0][i] * st.w[1][j] * st.w[2][k], st.w[0][i] * st.dw[1][j] * st.w[2][k],
                                          st.w[0][i] * st.w[1][j] * st.dw[2][k]);
                        gradV += vn * (finvDx * gradW).transpose();
                    }
                }
            }
        }
        const Mat3f C = Bp * Dinv;
        if constexpr (MLS) gradV = C;
        P.v[p] = v;
        P.C[p] = apic ? C : Mat3f::Zero();
        M::updateDeformation(sp.params, sp.state, p, gradV, dt);
        P.x[p] += double(dt) * v.cast<double>();
        const float key = M::stiffnessKey(sp.state, p);
        if (!(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]) && std::isfinite(key))) {
            if (bad.badParticle < 0) {
                bad.badSpecies = speciesIndex;
                bad.badParticle = p;
                bad.badField = std::isfinite(key) ? "velocity" : "deformation";
            }
            continue;
        }
        maxSpeed = std::max(maxSpeed, v.norm());
        minKey = std::min(minKey, key);
    }
}

template <class K, bool MLS>
void gatherLeaf(const SparseGrid& grid, std::vector<AnySpecies>& species, uint32_t l, float dt, bool apic,
                float& maxSpeed, float* minKey, G2PSummary& bad) {
    using B = LocalBlock<K>;
    float vel[B::kNodes][3];
    const auto& nb = grid.neighbours(l);
    for (int a = 0; a < B::N; ++a)
        for (int b = 0; b < B::N; ++b)
            for (int c = 0; c < B::N; ++c) {
                const LeafView& leaf = grid.leaf(nb[((a >> kLeafLog2) << 2) | ((b >> kLeafLog2) << 1) | (c >> kLeafLog2)]);
                const float* src = leaf.momentum + 3 * leafOffset(a & (kLeafDim - 1), b & (kLeafDim - 1), c & (kLeafDim - 1));
                float* dst = vel[B::index(a, b, c)];
                dst[0] = src[0];
                dst[1] = src[1];
                dst[2] = src[2];
            }
    const Vec3i origin = grid.leaf(l).origin;
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

void particlesToGrid(SparseGrid& grid, std::vector<AnySpecies>& species, const TransferSettings& s, float dt) {
    tbb::parallel_for(std::size_t(0), grid.leafCount(), [&](std::size_t l) {
        const LeafView& leaf = grid.leaf(l);
        std::memset(leaf.mass, 0, sizeof(float) * kLeafNodes);
        std::memset(leaf.momentum, 0, sizeof(float) * 3 * kLeafNodes);
    });
    withScheme(s, [&]<class K, bool MLS>() {
        for (const std::vector<uint32_t>& colour : grid.coloredParticleLeaves())
            tbb::parallel_for(std::size_t(0), colour.size(),
                              [&](std::size_t i) { scatterLeaf<K, MLS>(grid, species, colour[i], dt); });
    });
}

G2PSummary gridToParticles(const SparseGrid& grid, std::vector<AnySpecies>& species, const TransferSettings& s, float dt) {
    const std::vector<uint32_t>& leaves = grid.particleLeaves();
    const std::size_t S = species.size();
    std::vector<float> maxSpeed(leaves.size(), 0.0f);
    std::vector<float> minKey(leaves.size() * S, std::numeric_limits<float>::infinity());
    std::vector<G2PSummary> bad(leaves.size());
    const bool apic = s.transfer == TransferScheme::APIC;
    withScheme(s, [&]<class K, bool MLS>() {
        tbb::parallel_for(std::size_t(0), leaves.size(), [&](std::size_t i) {
            gatherLeaf<K, MLS>(grid, species, leaves[i], dt, apic, maxSpeed[i], minKey.data() + i * S, bad[i]);
        });
    });
    // Reduce in leaf order, so that the first bad particle reported does not depend on scheduling.
    G2PSummary out;
    out.minStiffnessKey.assign(S, std::numeric_limits<float>::infinity());
    for (std::size_t i = 0; i < leaves.size(); ++i) {
        out.maxSpeed = std::max(out.maxSpeed, maxSpeed[i]);
        for (std::size_t sp = 0; sp < S; ++sp) out.minStiffnessKey[sp] = std::min(out.minStiffnessKey[sp], minKey[i * S + sp]);
        if (out.badParticle < 0 && bad[i].badParticle >= 0) {
            out.badSpecies = bad[i].badSpecies;
            out.badParticle = bad[i].badParticle;
            out.badField = bad[i].badField;
        }
    }
    return out;
}

}  // namespace mpm
