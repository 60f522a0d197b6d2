// Solids in the engine: a jelly cube dropped on a plane bounces and keeps its volume; a jelly block
// sliding on a plane with Coulomb friction mu decelerates at mu g.
#include <gtest/gtest.h>

#include "TestScenes.h"

using namespace mpm;
using namespace mpm::test;

namespace {
int addJellyBlock(Simulation& sim, const Vec3d& lo, const Vec3d& hi, const Vec3f& v) {
    Species<FixedCorotated> s;
    s.name = "jelly";
    const int id = sim.addSpecies(std::move(s));
    const double spacing = 0.5 * sim.settings().dx, vol = spacing * spacing * spacing;
    sim.addParticles(id, lattice(lo, hi, spacing), v, float(vol * 400.0), float(vol), 0);
    return id;
}
double meanJ(const Simulation& sim) {
    const auto& sp = std::get<Species<FixedCorotated>>(sim.species()[0]);
    double sum = 0;
    for (const Mat3d& F : sp.state.F) sum += F.determinant();
    return sum / double(sp.size());
}
}  // namespace

TEST(Jelly, DroppedCubeBouncesAndKeepsItsVolume) {
    SimulationSettings s;
    s.dx = 0.05;
    Simulation sim(s);
    addJellyBlock(sim, Vec3d(0, 0.2, 0), Vec3d(0.25, 0.45, 0.25), Vec3f(0.0f, -2.0f, 0.0f));
    sim.addCollider(planeCollider(Vec3d::Zero(), Vec3d::UnitY(), Boundary::Separate, 0.0f));
    double maxUp = -1e9, minJ = 1e9;
    while (sim.time() < 0.6) {
        sim.substep(s.targetDt());
        maxUp = std::max(maxUp, sim.measure().momentum[1]);
        minJ = std::min(minJ, sim.measure().minJ);
    }
    EXPECT_GT(maxUp, 0.0);               // it bounced: momentum turned upward
    EXPECT_LT(minJ, 0.99);               // and was squeezed on impact
    EXPECT_NEAR(meanJ(sim), 1.0, 0.02);  // back to its rest volume within 2%
}

TEST(Jelly, SlidingBlockDeceleratesAtMuG) {
    SimulationSettings s;
    s.dx = 0.05;
    Simulation sim(s);
    const float mu = 0.3f;
    addJellyBlock(sim, Vec3d(0, 0, 0), Vec3d(0.3, 0.1, 0.3), Vec3f(2.0f, 0.0f, 0.0f));
    sim.addCollider(planeCollider(Vec3d::Zero(), Vec3d::UnitY(), Boundary::Slip, mu));
    auto vx = [&] {
        const FrameStats st = sim.measure();
        return st.momentum[0] / st.mass;
    };
    while (sim.time() < 0.05) sim.substep(s.targetDt());
    const double t0 = sim.time(), v0 = vx();
    while (sim.time() < 0.35) sim.substep(s.targetDt());
    const double decel = (v0 - vx()) / (sim.time() - t0);
    EXPECT_NEAR(decel, mu * 9.81, 0.05 * mu * 9.81);
}
