// Blow-up detection in the engine (stability issue): each check stops the run with its cause, frame,
// substep and particle, and a retry restarts the frame with half the time step.
#include <gtest/gtest.h>

#include <cmath>

#include "TestScenes.h"

using namespace mpm;
using namespace mpm::test;

namespace {
/// A stiff water block on a floor, run at CFL 5: far past the explicit bound (about 1).
SimulationSettings unstable() {
    SimulationSettings s;
    s.dx = 0.05;
    s.cfl = 5.0;
    s.substepsPerFrame = 1;
    return s;
}

std::string failure(Simulation& sim, int frames) {
    try {
        for (int f = 0; f < frames; ++f) sim.advanceFrame();
    } catch (const SimulationError& e) {
        return e.what();
    }
    return "";
}

void addStiffBlock(Simulation& sim) {
    Water::Params w;
    w.bulkModulus = 1e7f;
    addWaterBlock(sim, Vec3d(0, 0, 0), Vec3d(0.3, 0.3, 0.3), Vec3f::Zero(), w);
    sim.addCollider(planeCollider(Vec3d::Zero(), Vec3d::UnitY(), Boundary::Sticky, 0.0f));
}
}  // namespace

TEST(Stability, CellCrossingStopsTheRunNamingTheParticle) {
    Simulation sim(unstable());
    addStiffBlock(sim);
    const std::string msg = failure(sim, 20);
    EXPECT_NE(msg.find("cells in one substep"), std::string::npos) << msg;
    EXPECT_NE(msg.find("in frame 1 (substep "), std::string::npos) << msg;  // frames counted as files are, from 1
    EXPECT_NE(msg.find("particle id"), std::string::npos) << msg;
}

TEST(Stability, EnergyGrowthIsCaughtBeforeValuesTurnNonFinite) {
    SimulationSettings s = unstable();
    s.stability.cellCrossing = false;
    s.stability.stepCollapse = 0.0;
    s.maxSubstepsPerFrame = 1LL << 40;  // the substep watchdog would stop the collapsing step first
    Simulation sim(s);
    addStiffBlock(sim);
    const std::string msg = failure(sim, 20);
    EXPECT_NE(msg.find("total energy rose"), std::string::npos) << msg;
}

TEST(Stability, AnEnergyBlowUpNamesTheSetThatGainedTheEnergy) {
    // The check named the fastest particle, which may be one of another set than the one blowing up: here a block
    // thrown at 10 m/s beside a stiff one whose stored energy rises from 0 to 100 J between two checks. It names the
    // set whose energy rose most since the reference minimum, and that set's fastest particle. (A real blow-up races
    // the other checks, which may stop it first: the guard is driven with the measured energies directly.)
    SimulationSettings s;
    s.dx = 0.05;
    Simulation sim(s);
    const auto add = [&](const char* name, const Vec3d& lo) {
        Species<Water> w;
        w.name = name;
        const double density = w.params.density, spacing = 0.5 * s.dx, vol = spacing * spacing * spacing;
        const int id = sim.addSpecies(std::move(w));
        sim.addParticles(id, lattice(lo, lo + Vec3d(0.1, 0.1, 0.1), spacing), Vec3f::Zero(), float(vol * density), float(vol), 0);
    };
    add("thrown", Vec3d(-3.0, 2.0, 0.0));
    add("stiff", Vec3d(0, 0, 0));
    std::vector<Vec3f> v(sim.particleCount(), Vec3f(0.0f, 0.01f, 0.0f));
    v[0] = Vec3f(10.0f, 0.0f, 0.0f);  // the first particle of "thrown", the first set
    sim.setVelocities(v);
    SimState state = sim.state();
    StabilityGuard guard(s.stability, 9.81, s.dx);
    FrameStats before;
    before.particles = sim.particleCount();
    before.mass = 2.0;
    before.kineticEnergy = 1.0;
    before.speciesEnergy = {1.0, 0.0};
    guard.resetEnergyReference(state.energy, before);
    FrameStats after = before;
    after.elasticEnergy = 100.0;  // a rise of 100 J, past half the largest kinetic + stored energy (101 J)
    after.speciesEnergy = {1.0, 100.0};
    std::string msg;
    try {
        guard.checkEnergy(state, after);
    } catch (const SimulationError& e) {
        msg = e.what();
    }
    EXPECT_NE(msg.find("total energy rose by 100 J"), std::string::npos) << msg;
    EXPECT_NE(msg.find("set stiff gained most (100 J)"), std::string::npos) << msg;
    EXPECT_NE(msg.find("of set stiff"), std::string::npos) << msg;
}

TEST(Stability, TimeStepCollapseStopsAStallingRun) {
    SimulationSettings s = unstable();
    s.stability.cellCrossing = false;
    Simulation sim(s);
    addStiffBlock(sim);
    const std::string msg = failure(sim, 20);
    EXPECT_NE(msg.find("time step collapsed"), std::string::npos) << msg;
}

TEST(Stability, ARestingBlockAtDefaultSettingsTripsNoCheck) {
    SimulationSettings s;
    s.dx = 0.05;
    Simulation sim(s);
    Water::Params w;
    addWaterBlock(sim, Vec3d(0, 0, 0), Vec3d(0.3, 0.3, 0.3), Vec3f::Zero(), w);
    sim.addCollider(planeCollider(Vec3d::Zero(), Vec3d::UnitY(), Boundary::Sticky, 0.0f));
    EXPECT_EQ(failure(sim, 24), "");
    EXPECT_EQ(sim.retryCount(), 0);
}

TEST(Stability, RetryHalvesTheStepUntilTheFrameSucceeds) {
    SimulationSettings s = unstable();
    s.stability.retries = 6;
    Simulation sim(s);
    addStiffBlock(sim);
    const FrameStats first = sim.advanceFrame();
    EXPECT_GE(first.retries, 1);
    for (int f = 1; f < 4; ++f) EXPECT_NO_THROW(sim.advanceFrame());
    EXPECT_NEAR(sim.time(), 4.0 / s.fps, 1e-12);  // retried frames still end on frame times
    // What is left is water collapsing under gravity, not a blow-up: no particle is faster than a free
    // fall from the block's full height (0.3 m) would make it.
    EXPECT_LT(sim.measure().maxSpeed, std::sqrt(2.0 * 9.81 * 0.3));
}

TEST(Stability, CflStepBoundsTheDistanceGravityAddsToAVerySoftBody) {
    // Water so soft that its wave speed is near zero: without the |g| dt term the CFL step would be the
    // whole frame and the block would fall through several cells in its first substep.
    SimulationSettings s;
    s.dx = 0.02;
    s.cfl = 0.8;
    s.fps = 5.0;  // a 0.2 s frame: one substep of it would fall 19 cells
    s.substepsPerFrame = 1;
    Simulation sim(s);
    Water::Params w;
    w.bulkModulus = 1e-2f;
    addWaterBlock(sim, Vec3d(0, 0.1, 0), Vec3d(0.1, 0.2, 0.1), Vec3f::Zero(), w);
    const double dt = sim.cflTimeStep();
    const double c = Water::waveSpeed(w, 1.0f), g = s.gravity.norm();
    EXPECT_NEAR(dt * (c + g * dt), s.cfl * s.dx, 1e-9);  // the quadratic's root
    EXPECT_NO_THROW(sim.advanceFrame());                 // and no particle crosses a cell in a substep
    SimulationSettings still = s;
    still.gravity.setZero();
    Simulation noGravity(still);
    addWaterBlock(noGravity, Vec3d(0, 0.1, 0), Vec3d(0.1, 0.2, 0.1), Vec3f::Zero(), w);
    EXPECT_NEAR(noGravity.cflTimeStep(), still.cfl * still.dx / c, 1e-12 * still.cfl * still.dx / c);
}
