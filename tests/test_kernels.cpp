// B-spline kernels: partition of unity, zero gradient sum, linear reproduction, inertia D_p, and the
// derivative against central finite differences, for both orders at many random positions.
#include <gtest/gtest.h>

#include <random>

#include "core/Kernels.h"

using namespace mpm;

template <class K>
class KernelTest : public ::testing::Test {};
using KernelTypes = ::testing::Types<QuadraticBSpline, CubicBSpline>;
TYPED_TEST_SUITE(KernelTest, KernelTypes);

TYPED_TEST(KernelTest, PartitionOfUnityAndMoments) {
    using K = TypeParam;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> pos(-1000.0, 1000.0);
    for (int trial = 0; trial < 10000; ++trial) {
        const double x = pos(rng);
        const double base = std::floor(x - K::kBaseShift);
        const float fx = float(x - base);
        float w[K::kWidth], dw[K::kWidth];
        K::weights(fx, w, dw);
        double sw = 0, sdw = 0, first = 0, second = 0, dwMoment = 0;
        for (int i = 0; i < K::kWidth; ++i) {
            EXPECT_GE(w[i], 0.0f);
            sw += w[i];
            sdw += dw[i];
            first += w[i] * (i - fx);              // sum w (x_i - x_p) = 0
            second += w[i] * (i - fx) * (i - fx);  // D_p / dx^2
            dwMoment += dw[i] * (i - fx);          // sum grad w (x_i - x_p)^T = I
        }
        EXPECT_NEAR(sw, 1.0, 1e-6);
        EXPECT_NEAR(sdw, 0.0, 1e-6);
        EXPECT_NEAR(first, 0.0, 1e-6);
        EXPECT_NEAR(second, 1.0 / K::kInverseInertia, 1e-6);
        EXPECT_NEAR(dwMoment, 1.0, 1e-6);
    }
}

TYPED_TEST(KernelTest, DerivativeMatchesFiniteDifference) {
    using K = TypeParam;
    std::mt19937 rng(11);
    const double lo = K::kBaseShift, hi = K::kBaseShift + 1.0;
    std::uniform_real_distribution<double> frac(lo + 1e-3, hi - 1e-3);
    const float h = 1e-3f;
    for (int trial = 0; trial < 1000; ++trial) {
        const float fx = float(frac(rng));
        float w[K::kWidth], dw[K::kWidth], wp[K::kWidth], wm[K::kWidth], tmp[K::kWidth];
        K::weights(fx, w, dw);
        K::weights(fx + h, wp, tmp);
        K::weights(fx - h, wm, tmp);
        for (int i = 0; i < K::kWidth; ++i) EXPECT_NEAR(dw[i], (wp[i] - wm[i]) / (2 * h), 2e-3) << "node " << i;
    }
}

TEST(Kernels, MatchThePiecewiseDefinition) {
    // N(0) = 3/4 and N(1) = 1/8 for the quadratic; N(0) = 2/3 and N(1) = 1/6 for the cubic.
    float w3[3], d3[3];
    QuadraticBSpline::weights(1.0f, w3, d3);
    EXPECT_FLOAT_EQ(w3[1], 0.75f);
    EXPECT_FLOAT_EQ(w3[0], 0.125f);
    EXPECT_FLOAT_EQ(w3[2], 0.125f);
    float w4[4], d4[4];
    CubicBSpline::weights(1.0f, w4, d4);
    EXPECT_FLOAT_EQ(w4[1], 2.0f / 3.0f);
    EXPECT_FLOAT_EQ(w4[0], 1.0f / 6.0f);
    EXPECT_FLOAT_EQ(w4[2], 1.0f / 6.0f);
    EXPECT_FLOAT_EQ(w4[3], 0.0f);
}
