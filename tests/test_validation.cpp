// The cheap end of the validation report (bench/validation/Cases.cpp): each case at its coarsest useful
// resolution, asserted against its pass band from docs/validation/cases.md.
#include <gtest/gtest.h>

#include <cmath>

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

TEST(Validation, PlanarSandColumnsRunOutAsLubesLawWithTheMohrCoulombSurface) {
    // Case 13 at L0/dx = 10, aspect ratios 1 and 3 (0.5 is 5 cells tall here; the report runs it at 20 cells):
    // with Mohr-Coulomb's hexagon the run-out is within 0.67-1.5 of the planar law (measured 0.88 and 1.05); Klar's
    // round cone, stronger in plane strain, stops shorter (measured 0.58 and 0.71).
    const CaseConfig coarse;
    const CaseResult mc = planarColumnCollapse(coarse, mpm::YieldSurface::MohrCoulomb, {1.0, 3.0});
    EXPECT_TRUE(mc.pass) << mc.detail;
    const CaseResult dp = planarColumnCollapse(coarse, mpm::YieldSurface::DruckerPrager, {1.0, 3.0});
    for (const char* a : {"ratio_a1", "ratio_a3"})
        EXPECT_LT(detailValue(dp.detail, a), detailValue(mc.detail, a) - 0.1) << a << ": " << dp.detail << " / " << mc.detail;
}

TEST(Validation, HydrostaticColumnFloorPressureWithinOnePercentAndNoTension) {
    // Case 6 at H0/dx = 32: the fitted floor pressure within 1% of rho0 g H0, no particle below -1% of it.
    const CaseResult r = run("hydrostatic", 1);
    EXPECT_TRUE(r.pass) << "floor pressure error " << r.error << " " << r.detail;
}

TEST(Validation, MirroredTankWallsGiveTheHydrostaticFloorPressureToAFewPartsIn1e4) {
    // Case 6 with wall_ghosts = "mirror" at H0/dx = 16: frictionless slip walls mirror exactly, and the floor
    // pressure the held walls give within 0.78% comes within 0.019% (measured); no tension either way.
    const CaseResult held = run("hydrostatic", 0), mirrored = run("hydrostatic_mirror", 0);
    EXPECT_LT(mirrored.error, 1e-3) << mirrored.detail;
    EXPECT_LT(mirrored.error, 0.1 * held.error) << held.detail << " / " << mirrored.detail;
    EXPECT_TRUE(mirrored.pass) << mirrored.detail;  // the band's no-tension check included
}

TEST(Validation, ManufacturedSolutionConvergesUnderRefinement) {
    // Case 4 at N = 10 and 20 cells. Measured: 0.58 and 0.27 of G, order 1.1. The README expects about
    // second order; the first particle layer at each wall is too soft (the nodes beyond the wall are held
    // at zero instead of mirrored), which adds about a third of a cell to the cube's effective size and
    // makes the error first order. This guards the first order until the wall treatment improves it.
    const CaseResult coarse = run("manufactured", 0), fine = run("manufactured", 1);
    EXPECT_LT(fine.error, 0.3) << fine.detail;
    EXPECT_GT(std::log2(coarse.error / fine.error), 0.9) << coarse.error << " -> " << fine.error;
}

TEST(Validation, StaticFrictionHoldsABlockOnAnInclineAndOnATiltedFloor) {
    // Case 9 at the coarse level: mu above tan(theta) holds the block to under 0.1 cells in 0.4 s, on a tilted
    // plane (20 degrees, mu 0.5) and on a flat floor under tilted gravity (30 degrees, mu 0.7) in both modes, and
    // with wall_ghosts = "mirror" (which keeps a slip wall with friction held: mirrored, the block slid 2.8 cells).
    for (const char* name : {"incline_separate_20deg_mu0.5", "floor_separate_30deg_mu0.7", "floor_slip_30deg_mu0.7",
                             "floor_slip_30deg_mu0.7_mirror"}) {
        const CaseResult r = run(name);
        EXPECT_TRUE(r.pass) << name << ": slid " << r.error << " cells; " << r.detail;
    }
}

TEST(Validation, KineticFrictionGivesTheRigidBlockAcceleration) {
    // Case 9: mu below tan(theta) slides with g (sin - mu cos) within 3%, in `separate` and in `slip` (where
    // friction used to reach nodes moving away from the wall and braked the block to a near stop), and on a `slip`
    // floor in mirror mode (mirrored, it lost friction: 27% too fast).
    for (const char* name : {"incline_separate_30deg_mu0.3", "incline_slip_30deg_mu0.3", "floor_separate_30deg_mu0.3",
                             "floor_slip_30deg_mu0.3", "floor_slip_30deg_mu0.3_mirror"}) {
        const CaseResult r = run(name);
        EXPECT_TRUE(r.pass) << name << ": acceleration error " << r.error << "; " << r.detail;
    }
}

TEST(Validation, FrictionHoldsAndSlidesAtTheFinerLevelToo) {
    // Case 9 at dx = 0.01 m (20 cells along the block), where the grid's transfers hardly damp: static friction
    // holds on the tilted plane, and a `slip` floor with mu 0.3 gives the rigid block's acceleration. Released
    // unrelaxed they crept 0.59 cells and braked 37% too hard (a ringing release, docs/method.md, Friction).
    const CaseResult holds = run("incline_separate_30deg_mu0.7", 1), slides = run("floor_slip_30deg_mu0.3", 1);
    EXPECT_TRUE(holds.pass) << "slid " << holds.error << " cells; " << holds.detail;
    EXPECT_TRUE(slides.pass) << "acceleration error " << slides.error << "; " << slides.detail;
}

TEST(Validation, ASphereDroppedOnAPlaneTouchesForHertzsContactTime) {
    // Case 11 at R/dx = 10: the `separate` plane acts at the material's surface, so each contact time is within
    // 10% of Hertz's and falls with v^(-1/5). Measured: 1.00, 1.04, 1.02, 0.97 of t_c, exponent -0.21 (acting
    // wherever the stencil reached, the plane touched 1.2 cells early, for 0.07 to 0.85 of t_c).
    const CaseResult r = run("sphere_drop", 1);
    EXPECT_TRUE(r.pass) << r.error << " " << r.detail;
}

TEST(Validation, AMetalBarPulledInTensionYieldsAtTheYieldStressAndHardensAtTheTangentModulus) {
    // Case 12 at dx = 0.01 m: measured yield stress 3998.8 Pa of 4000, hardening slope 0.12% under E H / (E + H),
    // the particles' plastic strain 0.14% off the strain less its elastic part.
    const CaseResult r = run("metal_bar_tension", 0);
    EXPECT_TRUE(r.pass) << r.error << " " << r.detail;
    EXPECT_LT(detailValue(r.detail, "plastic_error"), 0.01) << r.detail;
}

TEST(Validation, AShearWaveInAViscousLiquidDecaysAtTheMaxwellFluidsRateBetweenMirroredWalls) {
    // Case 16 at H/dx = 10 (measured 1.8%; with held walls 6%, which the report shows).
    const CaseResult r = run("shear_wave_mirror");
    EXPECT_TRUE(r.pass) << "decay rate error " << r.error << " " << r.detail;
}
