// Transfers and the substep: free fall (validation case 1), rigid rotation (case 2) with PIC as the
// negative control, conservation through P2G/G2P, thread-count determinism and translation invariance.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstring>
#include <map>
#include <random>

#include "TestScenes.h"

using namespace mpm;
using namespace mpm::test;

namespace {
SimulationSettings quietSettings(Interpolation order, double dx = 0.1) {
    SimulationSettings s;
    s.dx = dx;
    s.transfer.interpolation = order;
    s.adaptive = false;
    return s;
}

std::map<int32_t, Vec3d> positionsById(const Simulation& sim) {
    std::map<int32_t, Vec3d> out;
    for (const AnySpecies& s : sim.species()) {
        const ParticleArrays& P = particlesOf(s);
        for (std::size_t i = 0; i < P.size(); ++i) out[P.id[i]] = P.x[i];
    }
    return out;
}
}  // namespace

class FreeFall : public ::testing::TestWithParam<Interpolation> {};

TEST_P(FreeFall, IsExactToRoundOff) {
    SimulationSettings s = quietSettings(GetParam());
    s.gravity = Vec3d(0.3, -9.81, 0.0);
    Simulation sim(s);
    const Vec3f v0(1.0f, 2.0f, -0.5f);
    addWaterBlock(sim, Vec3d(0, 0, 0), Vec3d(0.5, 0.4, 0.3), v0);
    const auto x0 = positionsById(sim);
    const double dt = 2e-3;
    const int steps = 100;
    for (int n = 0; n < steps; ++n) sim.substep(dt);
    const double t = steps * dt;
    const Vec3d g = s.gravity;
    const Vec3d vExpected = v0.cast<double>() + g * t;
    const Vec3d dExpected = v0.cast<double>() * t + 0.5 * g * t * t + 0.5 * g * dt * t;
    const ParticleArrays& P = particlesOf(sim.species()[0]);
    double maxVErr = 0, maxXErr = 0;
    for (std::size_t i = 0; i < P.size(); ++i) {
        maxVErr = std::max(maxVErr, (P.v[i].cast<double>() - vExpected).norm());
        maxXErr = std::max(maxXErr, (P.x[i] - x0.at(P.id[i]) - dExpected).norm());
        EXPECT_NEAR(P.C[i].norm(), 0.0, 1e-3);
    }
    // Round-off only: a few float ulps per substep, accumulated over the run.
    const double roundOff = 4.0 * steps * std::numeric_limits<float>::epsilon();
    EXPECT_LT(maxVErr, roundOff * vExpected.norm());
    EXPECT_LT(maxXErr, roundOff * dExpected.norm());
}
INSTANTIATE_TEST_SUITE_P(BothKernels, FreeFall, ::testing::Values(Interpolation::Quadratic, Interpolation::Cubic));

namespace {
/// Angular momentum after spinning a ball rigidly for `steps` substeps, relative to the start.
double spinLoss(Interpolation order, TransferScheme scheme, int steps) {
    SimulationSettings s = quietSettings(order);
    s.gravity = Vec3d::Zero();
    s.transfer.transfer = scheme;
    Simulation sim(s);
    Water::Params soft;
    soft.bulkModulus = 1.0f;  // nearly stress free: the transfer alone is under test
    const int id = addWaterBlock(sim, Vec3d(-0.5, -0.5, -0.5), Vec3d(0.5, 0.5, 0.5), Vec3f::Zero(), soft);
    ParticleArrays& P = particlesOf(sim.species()[id]);
    // Keep a ball, and give it v = w x (x - c), C = [w]x.
    std::vector<Vec3d> ball;
    for (const Vec3d& x : P.x)
        if (x.norm() < 0.45) ball.push_back(x);
    const float mass = P.mass[0], vol = P.volume0[0];
    P = ParticleArrays();
    std::get<Species<Water>>(sim.species()[id]).state = Water::State();
    sim.addParticles(id, ball, Vec3f::Zero(), mass, vol, 0);
    const Vec3f w(0.3f, 1.0f, -0.5f);
    Mat3f cross;
    cross << 0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0;
    for (std::size_t i = 0; i < P.size(); ++i) {
        P.v[i] = w.cross(P.x[i].cast<float>());
        P.C[i] = scheme == TransferScheme::APIC ? cross : Mat3f::Zero();
    }
    const Vec3d L0 = sim.measure().angularMomentum;
    const Vec3d p0 = sim.measure().momentum;
    EXPECT_LT(p0.norm(), 1e-6 * L0.norm());
    for (int n = 0; n < steps; ++n) sim.substep(1e-3);
    const FrameStats st = sim.measure();
    EXPECT_LT((st.momentum - p0).norm(), 1e-5 * L0.norm());
    return (st.angularMomentum - L0).norm() / L0.norm();
}
}  // namespace

TEST(RigidRotation, ApicKeepsAngularMomentum) {
    EXPECT_LT(spinLoss(Interpolation::Quadratic, TransferScheme::APIC, 1000), 1e-4);
    EXPECT_LT(spinLoss(Interpolation::Cubic, TransferScheme::APIC, 300), 1e-4);
}

TEST(RigidRotation, PicLosesSpinAsTheNegativeControl) {
    EXPECT_GT(spinLoss(Interpolation::Quadratic, TransferScheme::PIC, 1), 0.03);
}

TEST(Transfer, P2GThenG2PConservesMassAndMomentum) {
    for (Interpolation order : {Interpolation::Quadratic, Interpolation::Cubic}) {
        SimulationSettings s = quietSettings(order);
        s.gravity = Vec3d::Zero();
        Simulation sim(s);
        Water::Params free;
        free.bulkModulus = 0.0f;
        const int id = addWaterBlock(sim, Vec3d(0, 0, 0), Vec3d(0.6, 0.5, 0.4), Vec3f::Zero(), free);
        ParticleArrays& P = particlesOf(sim.species()[id]);
        std::mt19937 rng(3);
        std::normal_distribution<float> n01;
        for (std::size_t i = 0; i < P.size(); ++i) {
            P.x[i] += Vec3d(n01(rng), n01(rng), n01(rng)) * 0.01;
            P.v[i] = Vec3f(n01(rng), n01(rng), n01(rng));
            P.C[i] = Mat3f::Random();
        }
        const FrameStats before = sim.measure();
        sim.substep(1e-4);
        double gridMass = 0;
        for (std::size_t l = 0; l < sim.grid().leafCount(); ++l)
            for (int n = 0; n < kLeafNodes; ++n) gridMass += sim.grid().leaf(l).mass[n];
        const FrameStats after = sim.measure();
        EXPECT_NEAR(gridMass, before.mass, 1e-5 * before.mass);
        EXPECT_DOUBLE_EQ(after.mass, before.mass);
        const double scale = before.mass * 1.0;  // |v| ~ 1
        EXPECT_LT((after.momentum - before.momentum).norm(), 1e-5 * scale);
    }
}

namespace {
Simulation dropOnFloor(const Vec3d& shift, Interpolation order = Interpolation::Quadratic) {
    SimulationSettings s = quietSettings(order, 0.05);
    s.adaptive = true;
    Simulation sim(s);
    addWaterBlock(sim, shift + Vec3d(0, 0.1, 0), shift + Vec3d(0.4, 0.5, 0.3), Vec3f(0.5f, 0.0f, 0.0f));
    sim.addCollider(planeCollider(shift, Vec3d::UnitY(), Boundary::Slip, 0.2f));
    return sim;
}
}  // namespace

TEST(Determinism, OneAndTwoThreadsGiveIdenticalBits) {
    std::vector<std::vector<Vec3d>> runs;
    for (int threads : {1, 2}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        Simulation sim = dropOnFloor(Vec3d::Zero());
        for (int n = 0; n < 100; ++n) sim.substep(1e-3);
        const ParticleArrays& P = particlesOf(sim.species()[0]);
        std::vector<Vec3d> state(P.x);
        for (std::size_t i = 0; i < P.size(); ++i) state.push_back(P.v[i].cast<double>());
        runs.push_back(state);
    }
    ASSERT_EQ(runs[0].size(), runs[1].size());
    EXPECT_EQ(0, std::memcmp(runs[0].data(), runs[1].data(), runs[0].size() * sizeof(Vec3d)));
}

TEST(Precision, SceneShiftedByMillionCellsMovesTheSame) {
    const double dx = 0.05;
    const Vec3d shift(1e6 * dx, -1e6 * dx, 1e6 * dx);
    Simulation a = dropOnFloor(Vec3d::Zero());
    Simulation b = dropOnFloor(shift);
    const auto a0 = positionsById(a), b0 = positionsById(b);
    for (int n = 0; n < 100; ++n) {
        a.substep(1e-3);
        b.substep(1e-3);
    }
    const auto a1 = positionsById(a), b1 = positionsById(b);
    double worst = 0, travel = 0;
    for (const auto& [id, x] : a1) {
        const Vec3d da = x - a0.at(id), db = b1.at(id) - b0.at(id);
        worst = std::max(worst, (da - db).norm());
        travel = std::max(travel, da.norm());
    }
    EXPECT_GT(travel, 0.01);
    EXPECT_LT(worst, 1e-5 * dx);
}
