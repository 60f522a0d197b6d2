// The exact sum behind every diagnostic and energy total (core/ExactSum.h): the same bits in any order or
// split, because it is exact; and its rounding to a double is right.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/ExactSum.h"

using namespace mpm;

namespace {
double sumOf(const std::vector<double>& x) {
    ExactSum s;
    for (double v : x) s += v;
    return s.value();
}
}  // namespace

TEST(ExactSum, CancellationThatDoublesLoseIsKept) {
    // 1e16 + 1 - 1e16 is 0 in doubles, 1 exactly; and a term 2^-1074 (the smallest subnormal) survives 2^1000.
    EXPECT_EQ(sumOf({1e16, 1.0, -1e16}), 1.0);
    EXPECT_EQ(sumOf({std::ldexp(1.0, 1000), std::numeric_limits<double>::denorm_min(), -std::ldexp(1.0, 1000)}),
              std::numeric_limits<double>::denorm_min());
    // (0.1 + 0.2) - 0.3 is 2^-54 in doubles; the exact sum of those three doubles is 2^-55.
    EXPECT_EQ(sumOf({0.1, 0.2, -0.3}), std::ldexp(1.0, -55));
    EXPECT_EQ(sumOf({-2.5, -0.25}), -2.75);
    EXPECT_EQ(sumOf({}), 0.0);
}

TEST(ExactSum, AnyOrderAndAnySplitGiveTheSameBits) {
    // Terms over 80 orders of magnitude and both signs, where a plain double sum depends on the order.
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
    std::uniform_int_distribution<int> exponent(-130, 130);
    std::vector<double> x(20000);
    for (double& v : x) v = std::ldexp(mantissa(rng), exponent(rng));
    const double reference = sumOf(x);
    bool plainDiffers = false;
    for (int trial = 0; trial < 5; ++trial) {
        std::shuffle(x.begin(), x.end(), rng);
        EXPECT_EQ(sumOf(x), reference);
        // Split in parts summed apart and merged, as threads and ranks do.
        ExactSum parts[7], merged;
        for (std::size_t i = 0; i < x.size(); ++i) parts[i % 7] += x[i];
        for (ExactSum& p : parts) merged += p;
        EXPECT_EQ(merged.value(), reference);
        double plain = 0.0;
        for (double v : x) plain += v;
        plainDiffers = plainDiffers || plain != reference;
    }
    EXPECT_TRUE(plainDiffers) << "the test's terms should defeat a plain sum";
}

TEST(ExactSum, RoundsToTheNearestDouble) {
    // The sum of doubles that a long double holds exactly: the rounded value is the nearest double to it.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int trial = 0; trial < 200; ++trial) {
        const double a = u(rng), b = std::ldexp(u(rng), -30), c = std::ldexp(u(rng), -60);
        const long double exact = (long double)a + (long double)b + (long double)c;
        const double got = sumOf({a, b, c});
        EXPECT_LE(std::fabs((long double)got - exact), std::ldexp(std::fabs((long double)got), -53)) << a << " " << b << " " << c;
    }
}
