#pragma once
// B-spline interpolation kernels (thesis eq. 3.10-3.13; Jiang et al. 2016, sec. 9.1).
// A particle at x (in cells) is served by the nodes base+d, d = 0..kWidth-1, where base = floor(x - kBaseShift).
#include <cmath>

namespace mpm {

enum class Interpolation { Quadratic, Cubic };

/// Quadratic B-spline, 3 nodes per axis, inertia tensor D_p = dx^2/4 I.
struct QuadraticBSpline {
    static constexpr int kWidth = 3;
    static constexpr double kBaseShift = 0.5;
    /// D_p^-1 = kInverseInertia / dx^2 (APIC, Jiang et al. 2015, eq. 9).
    static constexpr float kInverseInertia = 4.0f;

    /// fx: particle position minus base node, in cells, in [0.5, 1.5).
    /// w[d] = N(fx - d); dw[d] = N'(fx - d) (derivative per cell, divide by dx for physical units).
    static inline void weights(float fx, float w[kWidth], float dw[kWidth]) {
        const float u0 = 1.5f - fx;  // |fx - 0| on the outer piece: 0.5 (1.5 - |u|)^2
        const float u1 = fx - 1.0f;  // inner piece: 0.75 - u^2
        const float u2 = fx - 0.5f;  // 1.5 - |fx - 2| on the outer piece
        w[0] = 0.5f * u0 * u0;
        w[1] = 0.75f - u1 * u1;
        w[2] = 0.5f * u2 * u2;
        dw[0] = -u0;
        dw[1] = -2.0f * u1;
        dw[2] = u2;
    }
    /// The share of a node's weight that material filling x > s (cells from the node, along one axis) carries:
    /// the integral of N from s on; 1/2 when the material's surface passes through the node.
    static double covered(double s) {
        if (s < 0.0) return 1.0 - covered(-s);
        if (s >= 1.5) return 0.0;
        if (s >= 0.5) return (1.5 - s) * (1.5 - s) * (1.5 - s) / 6.0;
        return 0.5 - 0.75 * s + s * s * s / 3.0;
    }
};

/// Cubic B-spline, 4 nodes per axis, inertia tensor D_p = dx^2/3 I.
struct CubicBSpline {
    static constexpr int kWidth = 4;
    static constexpr double kBaseShift = 1.0;
    static constexpr float kInverseInertia = 3.0f;

    /// fx: particle position minus base node, in cells, in [1, 2).
    static inline void weights(float fx, float w[kWidth], float dw[kWidth]) {
        const float a = 2.0f - fx;   // outer piece at node 0: (2 - |u|)^3 / 6, u = fx
        const float u1 = fx - 1.0f;  // inner piece at node 1, u in [0, 1)
        const float u2 = 2.0f - fx;  // inner piece at node 2, |u| in (0, 1]
        const float b = fx - 1.0f;   // outer piece at node 3: 2 - |fx - 3| = fx - 1
        w[0] = a * a * a / 6.0f;
        w[1] = 0.5f * u1 * u1 * u1 - u1 * u1 + 2.0f / 3.0f;
        w[2] = 0.5f * u2 * u2 * u2 - u2 * u2 + 2.0f / 3.0f;
        w[3] = b * b * b / 6.0f;
        dw[0] = -0.5f * a * a;
        dw[1] = 1.5f * u1 * u1 - 2.0f * u1;
        dw[2] = -(1.5f * u2 * u2 - 2.0f * u2);
        dw[3] = 0.5f * b * b;
    }
    /// As QuadraticBSpline::covered.
    static double covered(double s) {
        if (s < 0.0) return 1.0 - covered(-s);
        if (s >= 2.0) return 0.0;
        if (s >= 1.0) return (2.0 - s) * (2.0 - s) * (2.0 - s) * (2.0 - s) / 24.0;
        return 0.5 - s * s * s * s / 8.0 + s * s * s / 3.0 - 2.0 * s / 3.0;
    }
};

/// Calls f.template operator()<Kernel>() with the kernel type chosen at run time.
template <class F>
decltype(auto) withKernel(Interpolation order, F&& f) {
    if (order == Interpolation::Cubic) return f.template operator()<CubicBSpline>();
    return f.template operator()<QuadraticBSpline>();
}

}  // namespace mpm
