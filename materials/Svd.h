#pragma once
// 3x3 singular value decomposition with proper rotations, F = U diag(sigma) V^T, det U = det V = +1:
// a reflection is moved into the smallest singular value (its sign flips), as inverted elements need
// (Irving et al. 2004; Stomakhin et al. 2012).
//
// svd3 follows the outline of McAdams et al. 2011, "Computing the SVD of 3x3 matrices with minimal
// branching": Jacobi rotations give V, the columns of B = F V are sorted by length, and a Givens QR of B
// gives U and sigma. Our own code: one-sided Jacobi on F's columns (accurate for small singular values,
// where an eigensolver on F^T F loses half the digits), exact rotations and a convergence test. It is
// 2.5x faster than Eigen's JacobiSVD here (bench/bench_kernels.cpp, BM_Svd: 211 against 519 ns) and as
// robust for repeated, tiny and negative singular values (tests/test_materials.cpp). The rotations form
// one serial chain of square roots and divisions, so the transfers run eight of them at once in SIMD
// lanes (SvdBatch.h). jacobiSvd3 keeps Eigen's answer as the reference the tests compare against.
#include <Eigen/SVD>

#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "base/Types.h"

namespace mpm {

template <class T>
struct Svd3 {
    Mat3T<T> U, V;
    Vec3T<T> sigma;
};

/// Eigen's JacobiSVD with the same sign convention: the reference implementation.
template <class T>
Svd3<T> jacobiSvd3(const Mat3T<T>& F) {
    Eigen::JacobiSVD<Mat3T<T>> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Svd3<T> r{svd.matrixU(), svd.matrixV(), svd.singularValues()};
    if (r.U.determinant() < T(0)) {
        r.U.col(2) *= T(-1);
        r.sigma[2] *= T(-1);
    }
    if (r.V.determinant() < T(0)) {
        r.V.col(2) *= T(-1);
        r.sigma[2] *= T(-1);
    }
    return r;
}

namespace svd_detail {
/// Jacobi sweeps converge quadratically: 3 reach float precision near rest; the cap only guards NaN input.
inline constexpr int kMaxSweeps = 8;

/// Columns of a 3x3 matrix as plain arrays: the compiler keeps them in registers, which it does not for
/// Eigen column expressions here (measured 3x slower).
template <class T>
struct Columns {
    T c[3][3];  ///< c[column][row]
    static Columns identity() { return Columns{{{T(1), T(0), T(0)}, {T(0), T(1), T(0)}, {T(0), T(0), T(1)}}}; }
    T dot(int p, int q) const { return c[p][0] * c[q][0] + c[p][1] * c[q][1] + c[p][2] * c[q][2]; }
    /// Column p <- cs * p - sn * q, column q <- sn * p + cs * q.
    void rotate(int p, int q, T cs, T sn) {
        for (int k = 0; k < 3; ++k) {
            const T a = c[p][k], b = c[q][k];
            c[p][k] = cs * a - sn * b;
            c[q][k] = sn * a + cs * b;
        }
    }
    void swapNegate(int p, int q) {  // a swap with one sign flip keeps the determinant's sign
        for (int k = 0; k < 3; ++k) {
            const T a = c[p][k];
            c[p][k] = c[q][k];
            c[q][k] = -a;
        }
    }
};

/// One-sided (Hestenes) Jacobi rotation: rotates columns p and q of B, and of V with them, so that they
/// become orthogonal. The dot products come from B itself, not from a formed F^T F, which keeps small
/// singular values accurate. Returns false when the pair was already orthogonal to round-off.
template <class T>
inline bool orthogonalizePair(Columns<T>& B, Columns<T>& V, int p, int q) {
    const T alpha = B.dot(p, p), beta = B.dot(q, q), gamma = B.dot(p, q);
    constexpr T eps = std::numeric_limits<T>::epsilon();
    if (!(gamma * gamma > eps * eps * alpha * beta)) return false;
    // The classic t = sign(z) / (|z| + sqrt(z^2 + 1)), z = (beta - alpha) / (2 gamma), and cs = 1 / sqrt(1 + t^2),
    // multiplied through by |2 gamma|: two square roots and one division on the critical path instead of
    // three each, which is what bounds this serial chain of rotations.
    const T d = beta - alpha, g = T(2) * gamma;
    const T sum = std::abs(d) + std::sqrt(d * d + g * g);
    const T inv = T(1) / std::sqrt(sum * sum + g * g);
    const T cs = sum * inv, sn = (d < T(0) ? -g : g) * inv;
    B.rotate(p, q, cs, sn);
    V.rotate(p, q, cs, sn);
    return true;
}

/// Zeroes row i of column k of B against the pivot row j with a Givens rotation of rows j and i; U
/// accumulates it (B is stored by columns, so a row rotation touches one entry per column).
template <class T>
inline void givensZero(Columns<T>& B, Columns<T>& U, int j, int i, int k) {
    const T a = B.c[k][j], b = B.c[k][i];
    const T r = std::sqrt(a * a + b * b);  // not hypot: no overflow at our magnitudes, and 10x cheaper
    if (r == T(0)) return;
    const T cs = a / r, sn = b / r;
    for (int m = 0; m < 3; ++m) {
        const T bj = B.c[m][j], bi = B.c[m][i];
        B.c[m][j] = cs * bj + sn * bi;
        B.c[m][i] = -sn * bj + cs * bi;
    }
    U.rotate(j, i, cs, -sn);
}
}  // namespace svd_detail

template <class T>
Svd3<T> svd3(const Mat3T<T>& F) {
    using namespace svd_detail;
    // 1. V by one-sided Jacobi: rotate B = F V until its columns are orthogonal (V diagonalises F^T F).
    Columns<T> B, V = Columns<T>::identity();
    for (int col = 0; col < 3; ++col)
        for (int row = 0; row < 3; ++row) B.c[col][row] = F(row, col);
    for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
        bool rotated = orthogonalizePair(B, V, 0, 1);
        rotated |= orthogonalizePair(B, V, 0, 2);
        rotated |= orthogonalizePair(B, V, 1, 2);
        if (!rotated) break;
    }
    // 2. Order the columns of B by decreasing length so that sigma comes out sorted.
    T len[3] = {B.dot(0, 0), B.dot(1, 1), B.dot(2, 2)};
    auto order = [&](int p, int q) {
        if (len[p] >= len[q]) return;
        B.swapNegate(p, q);
        V.swapNegate(p, q);
        std::swap(len[p], len[q]);
    };
    order(0, 1);
    order(0, 2);
    order(1, 2);
    // 3. QR of B by Givens rotations: R is diagonal up to round-off, U = Q is a proper rotation, and
    //    R(2, 2) keeps the sign of det F.
    Columns<T> U = Columns<T>::identity();
    givensZero(B, U, 0, 1, 0);
    givensZero(B, U, 0, 2, 0);
    givensZero(B, U, 1, 2, 1);
    Svd3<T> out;
    for (int col = 0; col < 3; ++col)
        for (int row = 0; row < 3; ++row) {
            out.U(row, col) = U.c[col][row];
            out.V(row, col) = V.c[col][row];
        }
    out.sigma = Vec3T<T>(B.c[0][0], B.c[1][1], B.c[2][2]);
    return out;
}

}  // namespace mpm
