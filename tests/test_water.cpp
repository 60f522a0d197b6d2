// Water: the equation of state, and the hydrostatic column (validation case 6).
#include <gtest/gtest.h>

#include "Cases.h"
#include "TestScenes.h"

using namespace mpm;
using namespace mpm::test;

TEST(WaterModel, ZeroStressAtRestAndPressureFromJ) {
    Water::Params p;
    Water::State s;
    s.appendRest(2);
    s.J[1] = 0.9f;
    EXPECT_TRUE(Water::kirchhoff(p, s, 0).isZero());
    EXPECT_EQ(Water::energyDensity(p, s, 0), 0.0);
    const float pressure = p.bulkModulus * (std::pow(0.9f, -p.gamma) - 1.0f);
    EXPECT_TRUE(Water::kirchhoff(p, s, 1).isApprox(Mat3f::Identity() * (-0.9f * pressure)));
    // dPsi/dJ = -p by central differences.
    const double h = 1e-4;
    Water::State a = s, b = s;
    a.J[1] = 0.9f + float(h);
    b.J[1] = 0.9f - float(h);
    const double dPsi = (Water::energyDensity(p, a, 1) - Water::energyDensity(p, b, 1)) / (double(a.J[1]) - double(b.J[1]));
    EXPECT_NEAR(dPsi, -pressure, 1e-3 * pressure);
    EXPECT_NEAR(Water::waveSpeed(p, 1.0f), std::sqrt(p.bulkModulus * p.gamma / p.density), 1e-3);
}

TEST(HydrostaticColumn, FloorPressureMatchesRhoGH) {
    // Validation case 6 (bench/validation/Cases.cpp) at H0/dx = 16: the column starts in the analytic
    // hydrostatic state and must stay there; floor pressure from a fit of p over the interior.
    const validation::CaseResult r = validation::findCase("hydrostatic").run(validation::CaseConfig{});
    EXPECT_LT(r.error, 0.02) << r.detail;
}
