// Colliders on grid nodes (docs/method.md, section 7): the node response rule, and water on a plane.
#include <gtest/gtest.h>

#include "TestScenes.h"

using namespace mpm;
using namespace mpm::test;

TEST(ColliderResponse, StickySlipSeparate) {
    const Vec3f n(0, 1, 0), still = Vec3f::Zero();
    const Vec3f into(2.0f, -1.0f, 0.5f), away(2.0f, 1.0f, 0.5f);
    EXPECT_TRUE(Collider::respond(into, n, still, Boundary::Sticky, 0.0f).isZero());
    EXPECT_TRUE(Collider::respond(into, n, still, Boundary::Slip, 0.0f).isApprox(Vec3f(2.0f, 0.0f, 0.5f)));
    EXPECT_TRUE(Collider::respond(away, n, still, Boundary::Slip, 0.0f).isApprox(Vec3f(2.0f, 0.0f, 0.5f)));
    EXPECT_TRUE(Collider::respond(away, n, still, Boundary::Separate, 0.5f).isApprox(away));
    EXPECT_TRUE(Collider::respond(into, n, still, Boundary::Separate, 0.0f).isApprox(Vec3f(2.0f, 0.0f, 0.5f)));
}

TEST(ColliderResponse, CoulombFriction) {
    const Vec3f n(0, 1, 0), still = Vec3f::Zero();
    // Normal change 1, friction 0.5: the tangential speed drops by 0.5 along its direction.
    const Vec3f out = Collider::respond(Vec3f(3.0f, -1.0f, 4.0f), n, still, Boundary::Slip, 0.5f);
    EXPECT_NEAR(out.norm(), 4.5f, 1e-5f);
    EXPECT_NEAR(out[1], 0.0f, 1e-6f);
    EXPECT_NEAR(out[0] / out[2], 0.75f, 1e-5f);
    // Enough friction to stop the tangential motion: static.
    EXPECT_TRUE(Collider::respond(Vec3f(0.3f, -1.0f, 0.4f), n, still, Boundary::Slip, 0.6f).isZero(1e-6f));
    // A moving collider: the response is relative to its velocity.
    const Vec3f belt(1.0f, 0.0f, 0.0f);
    EXPECT_TRUE(Collider::respond(Vec3f(1.0f, -2.0f, 0.0f), n, belt, Boundary::Slip, 0.5f).isApprox(belt));
}

TEST(ColliderResponse, NoFrictionOnANodeMovingAway) {
    // Friction scales with the normal impulse of a node pressed into the wall; one moving away has none:
    // `slip` holds it on the surface and leaves its tangential velocity whole.
    const Vec3f n(0, 1, 0), still = Vec3f::Zero(), away(2.0f, 1.0f, 0.5f);
    EXPECT_TRUE(Collider::respond(away, n, still, Boundary::Slip, 0.8f).isApprox(Vec3f(2.0f, 0.0f, 0.5f)));
    EXPECT_TRUE(Collider::respond(away, n, still, Boundary::Separate, 0.8f).isApprox(away));
}

TEST(FrictionPatches, ACoulombBudgetPerPatchWithTensileImpulsesAgainstIt) {
    // Two pressed nodes and one held against leaving, all in one leaf: N = 2 * 1 + 1 * 0.5 - 1 * 0.5 = 2,
    // T = 2 * (1, 0, 0) + 1 * (2, 0, 0) = (4, 0, 0). mu = 1: budget 2 < 4, so each pressed node keeps 1 - 2/4.
    FrictionPatches p;
    p.addNormal(0, 2.0f, -1.0f);
    p.addPressed(0, 2.0f, Vec3f(1, 0, 0));
    p.addNormal(1, 1.0f, -0.5f);
    p.addPressed(1, 1.0f, Vec3f(2, 0, 0));
    p.addNormal(2, 1.0f, 0.5f);
    EXPECT_FLOAT_EQ(p.keep(0, 1.0f), 0.5f);
    EXPECT_FLOAT_EQ(p.keep(1, 1.0f), 0.5f);
    // mu = 2 covers |T|: the patch sticks.
    EXPECT_EQ(p.keep(0, 2.0f), 0.0f);
    // Net tension leaves no budget at all.
    FrictionPatches pulled;
    pulled.addNormal(0, 1.0f, -0.2f);
    pulled.addPressed(0, 1.0f, Vec3f(1, 0, 0));
    pulled.addNormal(1, 1.0f, 0.5f);
    EXPECT_EQ(pulled.keep(0, 5.0f), 1.0f);
}

TEST(ColliderGeometry, SignedDistances) {
    const auto plane = planeCollider(Vec3d(0, 1, 0), Vec3d(0, 2, 0), Boundary::Slip, 0.0f);
    EXPECT_DOUBLE_EQ(plane->signedDistance(Vec3d(5, 3, 1), 0.0), 2.0);
    EXPECT_DOUBLE_EQ(plane->signedDistance(Vec3d(5, 0.5, 1), 0.0), -0.5);
    const auto ball = sphereCollider(Vec3d(1, 0, 0), 0.5, Boundary::Sticky, 0.0f);
    EXPECT_DOUBLE_EQ(ball->signedDistance(Vec3d(1, 2, 0), 0.0), 1.5);
    EXPECT_TRUE(ball->normal(Vec3d(1, 2, 0), 0.0).isApprox(Vec3d::UnitY()));
}

namespace {
struct PlaneRun {
    double deepest = 0;  // largest penetration below the plane, in cells
    FrameStats start, end;
    double bottomSpeed = 0;       // mean |v| of the particles within half a cell of the plane
    double contactNodeSpeed = 0;  // largest |v| of a grid node with mass at or below the plane
};

PlaneRun runOnPlane(Boundary boundary, float friction, const Vec3f& v0, int steps) {
    SimulationSettings s;
    s.dx = 0.05;
    Simulation sim(s);
    addWaterBlock(sim, Vec3d(0, 0.0, 0), Vec3d(0.4, 0.3, 0.4), v0);
    sim.addCollider(planeCollider(Vec3d::Zero(), Vec3d::UnitY(), boundary, friction));
    PlaneRun out;
    out.start = sim.measure();
    for (int n = 0; n < steps; ++n) {
        sim.substep(1e-3);
        for (const Vec3d& x : particlesOf(sim.species()[0]).x) out.deepest = std::max(out.deepest, -x[1] / s.dx);
    }
    out.end = sim.measure();
    const ParticleArrays& P = particlesOf(sim.species()[0]);
    int count = 0;
    for (std::size_t i = 0; i < P.size(); ++i)
        if (P.x[i][1] < 0.5 * s.dx) {
            out.bottomSpeed += P.v[i].norm();
            ++count;
        }
    out.bottomSpeed /= std::max(count, 1);
    for (std::size_t l = 0; l < sim.grid().leafCount(); ++l) {
        const LeafView& leaf = sim.grid().leaf(l);
        for (int n = 0; n < kLeafNodes; ++n)
            if (leaf.mass[n] != 0.0f && leaf.origin[1] + ((n >> kLeafLog2) & (kLeafDim - 1)) <= 0)
                out.contactNodeSpeed =
                    std::max(out.contactNodeSpeed, double(Eigen::Map<const Vec3f>(leaf.momentum + 3 * n).norm()));
    }
    return out;
}
}  // namespace

TEST(WaterOnPlane, NoParticleSinksHalfACell) {
    const PlaneRun r = runOnPlane(Boundary::Separate, 0.0f, Vec3f(0.0f, -1.0f, 0.0f), 300);
    EXPECT_LT(r.deepest, 0.5);
}

TEST(WaterOnPlane, StickyHoldsTheContactLayerStill) {
    const PlaneRun sticky = runOnPlane(Boundary::Sticky, 0.0f, Vec3f(1.0f, 0.0f, 0.0f), 100);
    const PlaneRun slip = runOnPlane(Boundary::Slip, 0.0f, Vec3f(1.0f, 0.0f, 0.0f), 100);
    EXPECT_LT(sticky.deepest, 0.5);
    EXPECT_EQ(sticky.contactNodeSpeed, 0.0);  // nodes on and below the plane do not move at all
    EXPECT_LT(sticky.bottomSpeed, 0.35 * slip.bottomSpeed);
}

TEST(WaterOnPlane, SlipSlidesWithoutFriction) {
    const PlaneRun r = runOnPlane(Boundary::Slip, 0.0f, Vec3f(1.0f, 0.0f, 0.0f), 100);
    EXPECT_LT(r.deepest, 0.5);
    // No tangential force: horizontal momentum is kept exactly (to float round-off).
    EXPECT_NEAR(r.end.momentum[0], r.start.momentum[0], 1e-4 * r.start.momentum[0]);
    EXPECT_NEAR(r.end.momentum[2], 0.0, 1e-4 * r.start.momentum[0]);
}

TEST(WaterOnPlane, FrictionRemovesTangentialMomentum) {
    const PlaneRun r = runOnPlane(Boundary::Slip, 0.5f, Vec3f(1.0f, 0.0f, 0.0f), 100);
    EXPECT_LT(r.end.momentum[0], 0.99 * r.start.momentum[0]);
    EXPECT_GT(r.end.momentum[0], 0.0);
}
