// Rigid bodies the material moves (core/RigidBody.h), tried as a user sets them up (the default wall, a body given
// by its density) and checked against independent measures: the momentum and angular momentum the material lost
// against what the body gained, ballistics and Coulomb's law on an incline against their closed forms, Archimedes'
// draft against the water level measured from the particles, and the bits of one thread against two and against a
// checkpoint resumed.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <map>
#include <sstream>

#include "ProgramRuns.h"
#include "io/Checkpoint.h"
#include "io/Output.h"
#include "io/SceneBuilder.h"
#include "io/SceneKeys.h"
#include "io/SceneReader.h"
#include "io/VdbWriter.h"
#include "tests/SceneVariants.h"

using namespace mpm;
using mpm::test::RigidMap;
using nlohmann::json;

namespace {

constexpr double kG = 9.81;

std::unique_ptr<Simulation> build(const json& scene) {
    auto sim = buildSimulation(parseScene(scene.dump(), "/tmp/rigid_body_test.json"));
    sim->emitDue();
    return sim;
}

/// The body's momentum and its angular momentum about the origin: M v and I w + c x M v.
void bodyMomentum(const Simulation& sim, std::size_t k, Vec3d& P, Vec3d& L) {
    const Simulation::Body& b = sim.bodies()[k];
    const RigidBodyState& s = sim.state().bodies[k];
    P = b.model.mass * s.velocity;
    L = b.model.worldInertia(s.orientation) * s.spin + s.centre.cross(P);
}

/// A small jelly cube far from the body (5 m along z), on or above the plane through the origin: a scene needs
/// particles, these tests a body alone.
json farCube() {
    return json::parse(
        R"({"name": "far", "material": "jelly", "shape": {"type": "box", "min": [0, 0.03, 5], "max": [0.06, 0.09, 5.06]}})");
}

}  // namespace

TEST(RigidBody, MaterialAndBodyKeepMomentumAndAngularMomentum) {
    // No gravity, no fixed collider: a jelly ball thrown off-centre at a free, turned box sets it moving and spinning,
    // and whatever the body gains the material loses, in momentum and in angular momentum about the origin.
    json scene = json::parse(R"({"simulation": {"frames": 12, "dx": 0.02, "gravity": [0, 0, 0]}, "output": {"surface": false},
        "sets": [{"material": "jelly", "shape": {"type": "sphere", "center": [0, 0, 0], "radius": 0.1}, "velocity": [2, 0.3, 0]}],
        "colliders": [{"type": "box", "center": [0.3, 0.07, 0.02], "size": [0.1, 0.2, 0.3], "rotation": {"axis": [1, 2, 3], "degrees": 30},
                       "dynamic": {"density": 800}}]})");
    auto sim = build(scene);
    const FrameStats start = sim->measure();
    for (int f = 0; f < 12; ++f) sim->advanceFrame();
    const FrameStats end = sim->measure();
    Vec3d P, L;
    bodyMomentum(*sim, 0, P, L);
    const double p0 = start.momentum.norm();
    // The body took a real share (the ball bounced off it) and turns.
    EXPECT_GT(P.norm(), 0.3 * p0);
    EXPECT_GT(sim->state().bodies[0].spin.norm(), 1.0);
    // Particle velocities are floats (7 digits) summed over 4,000 particles and 300 substeps: measured drift
    // 1.0e-6 of the momentum and 5.5e-7 of p0 times the ball's distance from the origin (0.3 m); bands 1e-5.
    const Vec3d dP = end.momentum + P - start.momentum, dL = end.angularMomentum + L - start.angularMomentum;
    EXPECT_LT(dP.norm(), 1e-5 * p0) << dP.transpose();
    EXPECT_LT(dL.norm(), 1e-5 * p0 * 0.3) << dL.transpose();
}

TEST(RigidBody, FallsAsBallisticsAndComesToRestOnTheFloor) {
    // A box dropped in air: its centre follows y0 - g t^2 / 2 to within g t dt / 2 (position-first symplectic Euler
    // falls that much short) and the energy check's books do not move (its modified energy is kept), then it rests
    // on the floor, its bottom within g dt^2 of it (the one step's fall that the contact undoes each step).
    json scene = json::parse(R"({"simulation": {"frames": 12, "dx": 0.02}, "output": {"surface": false},
        "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.5},
                      {"type": "box", "center": [0.3, 0.5, 0.2], "size": [0.2, 0.1, 0.15], "dynamic": {"density": 600}}]})");
    scene["sets"] = json::array({farCube()});
    auto sim = build(scene);
    const double y0 = 0.5;
    double dtMax = 0.0;
    const double tImpact = std::sqrt(2.0 * (y0 - 0.05) / kG);
    const double work0 = sim->state().energy.work, scale = sim->bodies()[0].model.mass * kG * y0;
    while (sim->time() < 0.8 * tImpact) {
        dtMax = std::max(dtMax, sim->substep(1.0 / 240.0));
        const double t = sim->time(), y = sim->state().bodies[0].centre[1];
        ASSERT_NEAR(y, y0 - 0.5 * kG * t * t, 0.5 * kG * t * dtMax + 1e-12) << "t = " << t;
        ASSERT_NEAR(sim->state().energy.work, work0, 1e-12 * scale) << "t = " << t;
    }
    for (int f = 0; f < 12; ++f) sim->advanceFrame();
    const RigidBodyState& s = sim->state().bodies[0];
    EXPECT_NEAR(s.centre[1], 0.05, kG * dtMax * dtMax + 1e-12);
    // Straight down: the contacts' sequential impulses, taken in a fixed order, leave a trace of sideways motion
    // (measured 9e-10 m and 4e-8 rad/s); the bands are 1e-6 m and 1e-7 rad/s.
    EXPECT_NEAR(s.centre[0], 0.3, 1e-6);
    EXPECT_LT(s.velocity.norm(), kG * dtMax * 1.0001);
    EXPECT_LT(s.spin.norm(), 1e-7);
}

TEST(RigidBody, HoldsOrSlidesOnAnInclineAsCoulombSays) {
    // A box released on a 20 degree incline (tan 20 = 0.364): friction 0.5 holds it, 0.2 lets it slide at
    // g (sin 20 - 0.2 cos 20) = 1.512 m/s^2; in the placements of tests/SceneVariants.h.
    const double theta = 20.0 * M_PI / 180.0;
    for (const RigidMap& m : mpm::test::sceneVariants(0.02))
        for (const double mu : {0.5, 0.2}) {
            SCOPED_TRACE(m.name + ", friction " + std::to_string(mu));
            const Vec3d n(-std::sin(theta), std::cos(theta), 0.0), along(-std::cos(theta), -std::sin(theta), 0.0);  // downhill
            json scene = json::parse(R"({"simulation": {"frames": 12, "dx": 0.02}, "output": {"surface": false}})");
            scene["sets"] = json::array({farCube()});
            json box = {{"type", "box"}, {"size", {0.2, 0.1, 0.15}}, {"dynamic", {{"density", 600}}}};
            const Vec3d centre = 0.05 * n;  // resting on the plane through the origin
            box["center"] = {centre[0], centre[1], centre[2]};
            box["rotation"] = {{"axis", {0, 0, 1}}, {"degrees", 20.0}};
            scene["colliders"] = json::array(
                {json{{"type", "plane"}, {"point", {0, 0, 0}}, {"normal", {n[0], n[1], n[2]}}, {"friction", mu}}, box});
            scene = mpm::test::transformScene(scene, m);
            auto sim = build(scene);
            sim->advanceFrame();  // the first frame settles the sample points onto the plane
            const double t0 = sim->time();
            const Vec3d x0 = m.pointBack(sim->state().bodies[0].centre);
            for (int f = 0; f < 12; ++f) sim->advanceFrame();
            const double t = sim->time() - t0;
            const Vec3d moved = m.pointBack(sim->state().bodies[0].centre) - x0;
            if (mu > std::tan(theta)) {
                EXPECT_LT(moved.norm(), 1e-6) << moved.transpose();  // measured 6e-10 m in 0.5 s
            } else {
                const double a = kG * (std::sin(theta) - mu * std::cos(theta));
                const Vec3d v = m.vectorBack(sim->state().bodies[0].velocity);
                // The slide starts at the first frame's speed: s = v1 t + a t^2 / 2 with v1 = v - a t.
                const double v1 = v.dot(along) - a * t;
                EXPECT_NEAR(moved.dot(along), v1 * t + 0.5 * a * t * t, 0.01 * 0.5 * a * t * t);
                EXPECT_NEAR((v.dot(along) - v1) / t, a, 0.01 * a);
                EXPECT_LT(std::abs(moved.dot(n)), 1e-4);  // on the plane
            }
        }
}

TEST(RigidBody, SameBitsOnOneAndTwoThreadsAndAfterACheckpoint) {
    // The impulses are summed exactly (core/ExactSum.h), so threads change nothing; a checkpoint carries the body.
    json scene = json::parse(R"({"simulation": {"frames": 6, "dx": 0.02}, "output": {"surface": false},
        "sets": [{"material": "water", "shape": {"type": "box", "min": [0, 0, 0], "max": [0.3, 0.12, 0.2]}}],
        "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]},
                      {"type": "sphere", "center": [0.15, 0.25, 0.1], "radius": 0.05, "dynamic": {"density": 2000, "velocity": [0.3, 0, 0]}}]})");
    std::vector<RigidBodyState> runs[2];
    for (int threads : {1, 2}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        auto sim = build(scene);
        for (int f = 0; f < 6; ++f) sim->advanceFrame();
        runs[threads - 1] = sim->state().bodies;
    }
    const auto same = [](const RigidBodyState& a, const RigidBodyState& b) {
        double x[RigidBodyState::kDoubles], y[RigidBodyState::kDoubles];
        a.write(x);
        b.write(y);
        return std::memcmp(x, y, sizeof x) == 0;
    };
    EXPECT_TRUE(same(runs[0][0], runs[1][0]));
    EXPECT_LT(runs[0][0].centre[1], 0.2);  // it fell into the water

    auto first = build(scene);
    for (int f = 0; f < 3; ++f) first->advanceFrame();
    std::ostringstream bytes;
    CheckpointInfo info;
    info.format = kCheckpointFormat;
    encodeCheckpoint(bytes, info, first->state());
    const std::string b = bytes.str();
    Checkpoint c = decodeCheckpoint(std::vector<char>(b.begin(), b.end()), "memory");
    auto resumed = buildSimulation(parseScene(scene.dump(), "/tmp/rigid_body_test.json"));
    resumed->restore(std::move(c.state));
    for (int f = 0; f < 3; ++f) resumed->advanceFrame();
    EXPECT_TRUE(same(resumed->state().bodies[0], runs[1][0]));
}

TEST(RigidBody, FloatsNearArchimedesDraft) {
    // A box of half water's density floating in a slab of water (two slip planes 4 cells apart), released at the
    // surface: its draft over 1.5-2 s, against the water level measured from the particles, is Archimedes'
    // M / (rho A) = 3 cells to within a cell and a half, and no shallower than a quarter cell less. This is a guard,
    // not the 2% the physics asks: the wall acts on the rows of nodes inside it (docs/method.md, sec. 7), so the
    // body rides about a cell deep and drifts within it; measured 0.98 cells deep as written and 1.23 moved off the
    // nodes (docs/method.md, Rigid bodies). Two placements: as written and moved by a fraction of a cell.
    const double dx = 0.01, draft = 0.12 / (1000.0 * 0.1 * 0.04);
    for (const Vec3d& offset : {Vec3d::Zero().eval(), Vec3d(0.37 * dx, 0.61 * dx, 0.0)}) {
        SCOPED_TRACE("offset " + std::to_string(offset[1]));
        RigidMap m{"moved", Mat3d::Identity(), offset};
        json scene = json::parse(R"({"simulation": {"frames": 48, "dx": 0.01}, "output": {"surface": false},
            "sets": [{"material": "water", "shape": {"type": "box", "min": [0, 0, 0], "max": [0.3, 0.1, 0.04]}}],
            "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]}, {"type": "plane", "point": [0, 0, 0], "normal": [1, 0, 0]},
                          {"type": "plane", "point": [0.3, 0, 0], "normal": [-1, 0, 0]}, {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "boundary": "slip"},
                          {"type": "plane", "point": [0, 0, 0.04], "normal": [0, 0, -1], "boundary": "slip"},
                          {"type": "box", "min": [0.1, 0.1, -0.05], "max": [0.2, 0.16, 0.09],
                           "dynamic": {"mass": 0.12, "lock_translation": "z", "lock_rotation": "xy"}}]})");
        auto sim = build(mpm::test::transformScene(scene, m));
        double sum = 0.0;
        int samples = 0;
        for (int f = 0; f < 48; ++f) {
            sim->advanceFrame();
            if (f < 36) continue;
            // The level: the top particles away from the body, a quarter cell below the surface they fill to.
            std::vector<double> top;
            for (const AnySpecies& s : sim->species()) {
                const ParticleArrays& P = particlesOf(s);
                for (std::size_t i = 0; i < P.size(); ++i) {
                    const Vec3d x = m.pointBack(P.x[i]);
                    if (x[0] < 0.05 || x[0] > 0.25) top.push_back(x[1]);
                }
            }
            std::sort(top.rbegin(), top.rend());
            double level = 0.0;
            for (int i = 0; i < 30; ++i) level += top[std::size_t(i)] / 30.0;
            level += 0.25 * dx;
            const double bottom = m.pointBack(sim->state().bodies[0].centre)[1] - 0.03;
            sum += level - bottom;
            ++samples;
        }
        const double measured = sum / samples;
        EXPECT_NEAR(measured, draft, 1.5 * dx) << "draft " << measured << " against " << draft;
        EXPECT_GT(measured, draft - 0.25 * dx);  // a body floats no higher than its wall's reach lets it
    }
}

TEST(RigidBody, ACylinderRollsDownAnInclineAtTwoThirdsOfGSin) {
    // A cylinder on its side on a 20 degree incline with friction 0.5 rolls without slipping at (2/3) g sin 20 =
    // 2.237 m/s^2 (I = m r^2 / 2). Its side touches through balls of its radius on its axis, so it rolls as a
    // cylinder (as a 16-gon of rim points it made 1.42); measured 2.231, the rims' 64-gons brushing the plane.
    const double theta = 20.0 * M_PI / 180.0, r = 0.05;
    const Vec3d n(-std::sin(theta), std::cos(theta), 0.0), down(-std::cos(theta), -std::sin(theta), 0.0);
    json scene = json::parse(R"({"simulation": {"frames": 12, "dx": 0.02}, "output": {"surface": false}})");
    scene["sets"] = json::array({farCube()});
    const Vec3d centre = r * n;
    scene["colliders"] =
        json::array({json{{"type", "plane"}, {"point", {0, 0, 0}}, {"normal", {n[0], n[1], n[2]}}, {"friction", 0.5}},
                     json{{"type", "cylinder"},
                          {"center", {centre[0], centre[1], centre[2]}},
                          {"axis", {0, 0, 1}},
                          {"radius", r},
                          {"height", 0.2},
                          {"dynamic", {{"density", 500}}}}});
    auto sim = build(scene);
    sim->advanceFrame();
    const double t0 = sim->time(), v0 = sim->state().bodies[0].velocity.dot(down);
    for (int f = 0; f < 11; ++f) sim->advanceFrame();
    const RigidBodyState& s = sim->state().bodies[0];
    const double a = (s.velocity.dot(down) - v0) / (sim->time() - t0);
    EXPECT_NEAR(a, 2.0 / 3.0 * kG * std::sin(theta), 0.01 * kG * std::sin(theta));
    EXPECT_NEAR(s.spin[2] * r, s.velocity.dot(down), 1e-3 * s.velocity.dot(down));  // no slip (rolling to -x turns it about +z)
    EXPECT_NEAR((s.centre - Vec3d::Zero()).dot(n), r, 1e-4 * r);                    // on the plane
}

TEST(RigidBody, PosesGoToBodiesCsvAndEachFramesBodiesGrid) {
    // Two bodies listed among fixed colliders (so a body's index is not its collider's): bodies.csv has a row per
    // frame and body with the stats.csv columns' numbers, and each frame's VDB its grid "bodies" with the same pose.
    // Checked against an independent measure too: the ball falls freely (nothing under it in 4 frames), so its
    // height follows y0 - g t^2 / 2 to the symplectic Euler step's g t dt / 2 (and 1e-6 m: bodies move by the step
    // rounded to float, as the transfers take it), and its velocity -g t.
    const std::string dir = mpm::test::tempDir("bodies_out");
    const std::string scene = mpm::test::writeFile(dir + "/two.json", R"({"simulation": {"frames": 4, "dx": 0.02},
        "sets": [{"material": "water", "shape": {"type": "box", "min": [0, 0, 0], "max": [0.2, 0.1, 0.2]}}],
        "colliders": [{"type": "plane"},
                      {"type": "sphere", "center": [3, 2, 0], "radius": 0.05, "dynamic": {"density": 2000}},
                      {"type": "plane", "point": [0, 0, 0], "normal": [1, 0, 0]},
                      {"type": "box", "center": [0.1, 0.3, 0.1], "size": [0.08, 0.04, 0.08], "dynamic": {"density": 500,
                       "angular_velocity": [0, 2, 0]}}]})");
    const mpm::test::Result r = mpm::test::runMpm({"run", scene, "-o", dir + "/out", "--quiet"}, dir);
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string stats = mpm::test::readFile(dir + "/out/stats.csv");
    const std::string csv = mpm::test::readFile(dir + "/out/bodies.csv");
    EXPECT_EQ(csv, bodiesCsv(stats, {1, 3}));
    std::istringstream in(csv);
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "frame,time,body,collider,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz");
    std::map<std::pair<int, int>, std::vector<double>> rows;  // (frame, collider) -> time, pose, velocities
    while (std::getline(in, line)) {
        std::vector<double> v;
        std::istringstream cells(line);
        for (std::string cell; std::getline(cells, cell, ',');) v.push_back(std::stod(cell));
        ASSERT_EQ(v.size(), 17u) << line;
        rows[{int(v[0]), int(v[3])}] = {v[1],  v[4],  v[5],  v[6],  v[7],  v[8],  v[9],
                                        v[10], v[11], v[12], v[13], v[14], v[15], v[16]};
    }
    ASSERT_EQ(rows.size(), 10u);  // frames 0 (the initial state) to 4, two bodies
    // The longest step so far: a frame's substeps are equal, its substeps column counts them.
    double dt = 0.0;
    for (int f = 0; f <= 4; ++f) {
        if (f > 0) {
            std::istringstream cells(statsRows(stats).at(f));
            std::string cell;
            for (int c = 0; c <= 18; ++c) std::getline(cells, cell, ',');  // column 18: substeps
            dt = std::max(dt, 1.0 / 24.0 / std::stod(cell));
        }
        const std::vector<double>& ball = rows.at({f, 1});
        const double t = ball[0];
        EXPECT_NEAR(ball[2], 2.0 - 0.5 * kG * t * t, 0.5 * kG * t * dt + 1e-6) << "frame " << f;
        EXPECT_NEAR(ball[9], -kG * t, 1e-9 + kG * dt) << "frame " << f;
        EXPECT_NEAR(ball[1], 3.0, 1e-12);
        if (f == 0) continue;
        char name[64];
        std::snprintf(name, sizeof name, "/out/two_%04d.vdb", f);
        const BodyPoints grid = readVdbBodies(dir + name);
        ASSERT_EQ(grid.x.size(), 2u);
        for (std::size_t k = 0; k < 2; ++k) {
            const std::vector<double>& row = rows.at({f, grid.collider[k]});
            for (int a = 0; a < 3; ++a) {
                EXPECT_NEAR(grid.x[k][a], row[1 + a], 1e-6);  // P in float, relative to its voxel
                EXPECT_NEAR(grid.v[k][a], row[8 + a], 1e-6 * std::max(1.0, std::abs(row[8 + a])));
                EXPECT_NEAR(grid.w[k][a], row[11 + a], 1e-6 * std::max(1.0, std::abs(row[11 + a])));
            }
            // Houdini's order: x, y, z, w.
            const double q[4] = {row[5], row[6], row[7], row[4]};
            for (int a = 0; a < 4; ++a) EXPECT_NEAR(grid.orient[k][a], q[a], 1e-6);
        }
    }
    // The box spins about y at 2 rad/s while it falls onto the water: after frame 1 its turn is about y.
    const std::vector<double>& box = rows.at({1, 3});
    EXPECT_NEAR(2.0 * std::atan2(box[6], box[4]), 2.0 * box[0], 1e-6);
}

TEST(RigidBody, BodiesCollideKeepingMomentumAndRestOnOneAnother) {
    // No gravity: a ball thrown off-centre at a heavier, turned box. Contact between bodies gives equal and opposite
    // impulses, so the two keep their momentum to round-off, and they do not pass through each other. The jelly cube far away is
    // the particles a scene needs.
    json scene = json::parse(R"({"simulation": {"frames": 12, "dx": 0.02, "gravity": [0, 0, 0]}, "output": {"surface": false},
        "colliders": [{"type": "sphere", "center": [0.1, 1.03, 0.01], "radius": 0.05, "friction": 0.4,
                       "dynamic": {"density": 1000, "velocity": [2, 0, 0], "angular_velocity": [0, 0, 3]}},
                      {"type": "box", "center": [0.4, 1.0, 0.0], "size": [0.1, 0.2, 0.15], "rotation": {"axis": [1, 2, 3], "degrees": 25},
                       "friction": 0.4, "dynamic": {"density": 2500}}]})");
    scene["sets"] = json::array({farCube()});
    auto sim = build(scene);
    Vec3d P0 = Vec3d::Zero(), L0 = Vec3d::Zero();
    for (std::size_t k = 0; k < 2; ++k) {
        Vec3d P, L;
        bodyMomentum(*sim, k, P, L);
        P0 += P, L0 += L;
    }
    double closest = 1e9;
    for (int f = 0; f < 12; ++f) {
        sim->advanceFrame();
        // The ball's centre against the box's shape: never closer than its radius less a hundredth of it.
        const Collider& box = *sim->colliders()[sim->bodies()[1].collider];
        closest = std::min(closest, box.signedDistance(sim->state().bodies[0].centre, sim->time()));
    }
    Vec3d P1 = Vec3d::Zero(), L1 = Vec3d::Zero();
    for (std::size_t k = 0; k < 2; ++k) {
        Vec3d P, L;
        bodyMomentum(*sim, k, P, L);
        P1 += P, L1 += L;
    }
    const double p0 = P0.norm();
    EXPECT_GT(sim->state().bodies[1].velocity.norm(), 0.1);  // the box was hit
    EXPECT_LT(closest, 0.06);                                // the ball reached it
    EXPECT_GT(closest, 0.05 * 0.99);
    EXPECT_LT((P1 - P0).norm(), 1e-12 * p0) << (P1 - P0).transpose();
    // The impulses keep angular momentum too (equal and opposite at one point); the push apart moves the centres
    // without their momentum and changes it by m_a dx_a x (v_a - v_b): measured 3.7e-5 of p0 times 1 m (the lever
    // arm about the origin), band 1e-4.
    EXPECT_LT((L1 - L0).norm(), 1e-4 * p0 * 1.0) << (L1 - L0).transpose();

    // With gravity: a ball dropped on a box resting on the floor comes to rest on it, the box on the floor.
    json stack = json::parse(R"({"simulation": {"frames": 24, "dx": 0.02}, "output": {"surface": false},
        "colliders": [{"type": "plane"},
                      {"type": "box", "center": [0.0, 0.05, 0.0], "size": [0.2, 0.1, 0.2], "dynamic": {"density": 500}},
                      {"type": "sphere", "center": [0.02, 0.3, 0.01], "radius": 0.04, "dynamic": {"density": 2000}}]})");
    stack["sets"] = json::array({farCube()});
    auto rest = build(stack);
    for (int f = 0; f < 24; ++f) rest->advanceFrame();
    const RigidBodyState& box = rest->state().bodies[0];
    const RigidBodyState& ball = rest->state().bodies[1];
    // Resting contact holds each within g dt^2 of touching (speculative contacts; dt about 1e-3 s here): 1e-4 m.
    EXPECT_NEAR(box.centre[1], 0.05, 1e-4);
    EXPECT_NEAR(ball.centre[1], 0.14, 1e-4);
    // Pair by pair after the floor, the ball's contact pushes the box into the floor for one step: each step leaves at
    // most about one step's gravity, g dt = 0.01 m/s, in the two (measured 1.7e-3 and 1.4e-3 m/s).
    EXPECT_LT(ball.velocity.norm(), 0.01);
    EXPECT_LT(box.velocity.norm(), 0.01);
}

TEST(RigidBody, AShapeWithoutMassPropertiesIsRefusedNamingTheShapesThatCan) {
    // Which shapes can be bodies follows from the shapes' types (massProperties), in the error and in the key's help.
    const std::string names = bodyShapeNames();
    EXPECT_EQ(names, "sphere, box, cylinder");
    const auto scene = [](const std::string& collider) {
        return R"({"simulation": {"frames": 1}, "sets": [{"material": "water", "shape": {"type": "box", "min": [0, 0, 0],
            "max": [0.1, 0.1, 0.1]}}], "colliders": [)" +
               collider + "]}";
    };
    try {
        buildSimulation(parseScene(scene(R"({"type": "plane", "dynamic": {"density": 100}})"), "/tmp/rigid_body_test.json"));
        FAIL() << "a dynamic plane was built";
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("/colliders/0/dynamic: a plane collider cannot be a rigid body yet; the shapes "
                                             "that can: " +
                                             names),
                  std::string::npos)
            << e.what();
    }
}
