// The cheap end of the validation report (bench/validation/Cases.cpp): each case at its coarsest useful
// resolution, asserted against its pass band from ../shared/validation/README.md.
#include <gtest/gtest.h>

#include "Cases.h"

using namespace mpm::validation;

namespace {
CaseResult run(const std::string& name, int level = 0) {
    CaseConfig c;
    c.level = level;
    return findCase(name).run(c);
}
}  // namespace

TEST(Validation, FreeFallIsExactToRoundOff) {
    const CaseResult r = run("free_fall");
    EXPECT_LT(r.error, 1e-4) << r.detail;
}

TEST(Validation, RigidRotationKeepsAngularMomentum) {
    const CaseResult r = run("rigid_rotation");
    EXPECT_LT(r.error, 1e-4) << r.detail;
}

TEST(Validation, VibratingBarPeriodWithinOnePercentAtFiftyCells) {
    const CaseResult r = run("vibrating_bar", 1);  // L/dx = 50
    EXPECT_TRUE(r.pass) << "period error " << r.error << " " << r.detail;
}

TEST(Validation, DamBreakFrontFollowsMartinAndMoyce) {
    const CaseResult r = run("dam_break");  // a / dx = 8
    EXPECT_LT(r.error, 0.10) << r.detail;
}

TEST(Validation, SandPileAngleOfReposeWithinBandForThirtyDegrees) {
    // Case 8: a low column of phi = 30 degree sand settles to an angle in [phi - 3, phi + 6].
    const CaseResult r = run("angle_of_repose_30");
    EXPECT_TRUE(r.pass) << "angle " << r.error << " " << r.detail;
}
