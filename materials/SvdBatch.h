#pragma once
// Eight 3x3 SVDs at once, one per SIMD lane: the algorithm of svd3 (Svd.h) with every branch turned into
// a per-lane select. A rotation a lane does not need is applied as the identity (cos 1, sin 0), which
// leaves its numbers bit for bit as they were, so each lane ends where svd3 alone would have (up to the
// compiler contracting a*b+c differently in the two versions), and a particle's result never depends
// on which other particles share its batch. Why: svd3 is one serial chain of square roots and divisions
// per matrix, so one matrix uses one lane of the divider; eight matrices fill it
// (bench/bench_kernels.cpp, BM_SvdBatch against BM_Svd).
#include <algorithm>
#include <cmath>
#include <limits>

#include "materials/Svd.h"

#if defined(__AVX__)
#include <immintrin.h>
#endif

namespace mpm {

namespace simd {

inline constexpr int kLanes = 8;
using f8 = float __attribute__((vector_size(32)));
using i8 = int __attribute__((vector_size(32)));  ///< a lane mask: all bits set where true

inline f8 splat(float a) { return f8{a, a, a, a, a, a, a, a}; }
inline f8 sqrt(f8 a) {
#if defined(__AVX__)
    return f8(_mm256_sqrt_ps(__m256(a)));
#else
    for (int k = 0; k < kLanes; ++k) a[k] = std::sqrt(a[k]);
    return a;
#endif
}
inline f8 select(i8 mask, f8 a, f8 b) { return mask ? a : b; }
inline f8 abs(f8 a) { return select(a < 0.0f, -a, a); }
inline bool any(i8 mask) {
    int r = 0;
    for (int k = 0; k < kLanes; ++k) r |= mask[k];
    return r != 0;
}

}  // namespace simd

namespace svd_detail {

/// Columns of eight 3x3 matrices, lane k holding matrix k: c[column][row].
struct Columns8 {
    simd::f8 c[3][3];
    static Columns8 identity() {
        Columns8 m{};
        for (int i = 0; i < 3; ++i) m.c[i][i] = simd::splat(1.0f);
        return m;
    }
    simd::f8 dot(int p, int q) const { return c[p][0] * c[q][0] + c[p][1] * c[q][1] + c[p][2] * c[q][2]; }
    void rotate(int p, int q, simd::f8 cs, simd::f8 sn) {
        for (int k = 0; k < 3; ++k) {
            const simd::f8 a = c[p][k], b = c[q][k];
            c[p][k] = cs * a - sn * b;
            c[q][k] = sn * a + cs * b;
        }
    }
    /// svd3's swapNegate in the lanes where mask is set.
    void swapNegate(int p, int q, simd::i8 mask) {
        for (int k = 0; k < 3; ++k) {
            const simd::f8 a = c[p][k], b = c[q][k];
            c[p][k] = simd::select(mask, b, a);
            c[q][k] = simd::select(mask, -a, b);
        }
    }
};

/// orthogonalizePair in eight lanes; returns the lanes that rotated.
inline simd::i8 orthogonalizePair8(Columns8& B, Columns8& V, int p, int q) {
    using namespace simd;
    const f8 alpha = B.dot(p, p), beta = B.dot(q, q), gamma = B.dot(p, q);
    constexpr float eps = std::numeric_limits<float>::epsilon();
    // Written as in svd3 so that NaN input fails the test the same way (it does not rotate).
    const i8 rotate = gamma * gamma > (eps * eps) * alpha * beta;
    const f8 d = beta - alpha, g = 2.0f * gamma;
    const f8 sum = abs(d) + sqrt(d * d + g * g);
    const f8 inv = 1.0f / sqrt(sum * sum + g * g);
    const f8 cs = select(rotate, sum * inv, splat(1.0f));
    const f8 sn = select(rotate, select(d < 0.0f, -g, g) * inv, splat(0.0f));
    B.rotate(p, q, cs, sn);
    V.rotate(p, q, cs, sn);
    return rotate;
}

/// givensZero in eight lanes (identity where the pair is already zero).
inline void givensZero8(Columns8& B, Columns8& U, int j, int i, int k) {
    using namespace simd;
    const f8 a = B.c[k][j], b = B.c[k][i];
    const f8 r = sqrt(a * a + b * b);
    const i8 zero = r == 0.0f;
    const f8 safe = select(zero, splat(1.0f), r);
    const f8 cs = select(zero, splat(1.0f), a / safe), sn = select(zero, splat(0.0f), b / safe);
    for (int m = 0; m < 3; ++m) {
        const f8 bj = B.c[m][j], bi = B.c[m][i];
        B.c[m][j] = cs * bj + sn * bi;
        B.c[m][i] = -sn * bj + cs * bi;
    }
    U.rotate(j, i, cs, -sn);
}

}  // namespace svd_detail

/// The parameters of a batch's lanes: one set for every lane (a species' own), or lane k's at each[k] (particles
/// with parameters of their own, a set's material_fields). The SVDs, most of a batch's work, need none, so both
/// kinds of species run them in SIMD lanes.
template <class Params>
struct LaneParams {
    const Params* shared;
    const Params* each = nullptr;
    LaneParams(const Params& all) : shared(&all) {}  // NOLINT(google-explicit-constructor): one set is the usual case
    LaneParams(const Params& fallback, const Params* perLane) : shared(&fallback), each(perLane) {}
    const Params& operator[](int k) const { return each ? each[k] : *shared; }
};

/// The SVDs of F[0..n), n <= simd::kLanes, into out[0..n); the same convention as svd3.
inline void svd3Batch(const Mat3f* F, int n, Svd3<float>* out) {
    using namespace svd_detail;
    using simd::f8;
    Columns8 B = Columns8::identity(), V = Columns8::identity();  // unused lanes stay the identity
    for (int k = 0; k < n; ++k)
        for (int col = 0; col < 3; ++col)
            for (int row = 0; row < 3; ++row) B.c[col][row][k] = F[k](row, col);
    for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
        simd::i8 rotated = orthogonalizePair8(B, V, 0, 1);
        rotated |= orthogonalizePair8(B, V, 0, 2);
        rotated |= orthogonalizePair8(B, V, 1, 2);
        if (!simd::any(rotated)) break;
    }
    f8 len[3] = {B.dot(0, 0), B.dot(1, 1), B.dot(2, 2)};
    auto order = [&](int p, int q) {
        const simd::i8 swap = ~(len[p] >= len[q]);  // svd3's test, NaN included
        B.swapNegate(p, q, swap);
        V.swapNegate(p, q, swap);
        const f8 lp = len[p];
        len[p] = simd::select(swap, len[q], lp);
        len[q] = simd::select(swap, lp, len[q]);
    };
    order(0, 1);
    order(0, 2);
    order(1, 2);
    Columns8 U = Columns8::identity();
    givensZero8(B, U, 0, 1, 0);
    givensZero8(B, U, 0, 2, 0);
    givensZero8(B, U, 1, 2, 1);
    for (int k = 0; k < n; ++k) {
        for (int col = 0; col < 3; ++col)
            for (int row = 0; row < 3; ++row) {
                out[k].U(row, col) = U.c[col][row][k];
                out[k].V(row, col) = V.c[col][row][k];
            }
        out[k].sigma = Vec3f(B.c[0][0][k], B.c[1][1][k], B.c[2][2][k]);
    }
}

/// The state's F in double rounded to float, for n <= simd::kLanes particles from Fd (identity in the unused lanes),
/// and their SVDs: the stress is evaluated in float (materials/Elastic.h, materials/ElasticPart.h).
inline void narrowAndSvd(const Mat3d* Fd, int n, Mat3f* F, Svd3<float>* out) {
    for (int k = 0; k < simd::kLanes; ++k) F[k] = k < n ? Mat3f(Fd[k].cast<float>()) : Mat3f::Identity();
    svd3Batch(F, n, out);
}

}  // namespace mpm
