// The same run on many processes (docs/distributed.md): `mpirun -np N mpm run SCENE` on loopback must write
// the bits one process writes, for any rank and thread count; rebalancing must not change them; a blow-up is
// reported once and every rank exits 1; a checkpoint written by 2 ranks resumes on 3, whole or as per-rank parts;
// mirrored walls and bodies with velocity fields of their own run on ranks with one process's bits;
// SIGUSR1 stops every rank at one substep; per-rank part files hold every particle once.
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ProgramRuns.h"
#include "io/Checkpoint.h"
#include "io/VdbWriter.h"

using namespace mpm::test;

namespace {

#ifdef MPM_MPIEXEC
constexpr const char* kMpiexec = MPM_MPIEXEC;
#else
constexpr const char* kMpiexec = nullptr;
#endif

/// Water and jelly crossing the ranks' boundaries (the water runs +x through the jelly ball's range), a
/// floor and a sphere with friction, an emitter of whole sets and a continuous source.
const std::string kScene = std::string(MPM_SOURCE_DIR) + "/tests/scenes/ranks_mix.json";

/// mpm on `ranks` processes (mpirun on loopback; root allowed, as in CI; more ranks than cores allowed; not
/// bound to a core each, so that a rank's threads are threads).
Result runRanks(int ranks, std::vector<std::string> args, const std::string& dir) {
    std::vector<std::string> all{"--allow-run-as-root", "--oversubscribe", "--bind-to", "none", "-np",
                                 std::to_string(ranks), MPM_BINARY};
    all.insert(all.end(), args.begin(), args.end());
    Child c = start(all, dir + "/mpirun.log", kMpiexec);
    const int code = c.wait();
    return {code, c.output()};
}

/// The particles per rank that a run's closing note reports, fewest and most.
std::pair<long, long> spread(const std::string& log) {
    std::smatch m;
    if (!std::regex_search(log, m, std::regex(R"(ranks: ([0-9]+) to ([0-9]+) particles each)"))) return {-1, -1};
    return {std::stol(m[1]), std::stol(m[2])};
}
/// The most set samples a rank held after sampling, and the sets' samples in all.
std::pair<double, double> heldSamples(const std::string& log) {
    std::smatch m;
    if (!std::regex_search(log, m, std::regex(R"(at most ([0-9]+) of the sets' ([0-9]+) samples held by a rank)")))
        return {-1, -1};
    return {std::stod(m[1]), std::stod(m[2])};
}
int recuts(const std::string& log) {
    std::smatch m;
    return std::regex_search(log, m, std::regex(R"(leaves re-cut ([0-9]+) times)")) ? std::stoi(m[1]) : -1;
}

int count(const std::string& text, const std::string& what) {
    int n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

/// A 3-frame scene on one process and on each (ranks, threads): every rank holds a share, and the frames,
/// PLY files and stats are one process's bits.
void expectSameBitsOnRanks(const std::string& scene, const std::string& name, const std::string& dir,
                           const std::vector<std::pair<int, const char*>>& runs) {
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/one", "--quiet", "--threads", "1"}, dir).code, 0);
    for (const auto& [ranks, threads] : runs) {
        const std::string out = dir + "/ranks" + std::to_string(ranks);
        const Result r = runRanks(ranks, {"run", scene, "-o", out, "--threads", threads}, dir);
        ASSERT_EQ(r.code, 0) << r.output;
        EXPECT_GT(spread(r.output).first, 0) << r.output;
        expectSameOutput(dir + "/one", out, name, 9);
    }
}

#define REQUIRE_MPI() \
    if (!kMpiexec) GTEST_SKIP() << "built without MPI"

}  // namespace

TEST(Ranks, OneTwoAndThreeRanksWriteTheSameBitsAndRebalancingKeepsThem) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks");
    ASSERT_EQ(runMpm({"run", kScene, "-o", dir + "/one", "--threads", "1", "--quiet"}, dir).code, 0);
    // 2 ranks of 2 threads, 3 of 1: neither the rank count nor the thread count may move a bit.
    for (const auto& [ranks, threads] : {std::pair{2, "2"}, std::pair{3, "1"}}) {
        const std::string out = dir + "/ranks" + std::to_string(ranks);
        const Result r = runRanks(ranks, {"run", kScene, "-o", out, "--threads", threads}, dir);
        ASSERT_EQ(r.code, 0) << r.output;
        // Really spread: every rank held a share, and the water's motion made the ranks re-cut their leaves.
        const auto [fewest, most] = spread(r.output);
        EXPECT_GT(fewest, 0) << r.output;
        EXPECT_GT(most, 0) << r.output;
        EXPECT_GE(recuts(r.output), 1) << r.output;
        // Each rank sampled and kept its part of the sets (the tiles' and the lattice's shares), not all of them.
        const auto [held, samples] = heldSamples(r.output);
        EXPECT_GT(held, 0.0) << r.output;
        EXPECT_LT(held, (1.0 / ranks + 0.15) * samples) << r.output;
        // Rank 0 speaks for all: the opening line once.
        EXPECT_EQ(count(r.output, "mpm: " + kScene), 1) << r.output;
        expectSameOutput(dir + "/one", out, "ranks_mix", 18);
    }
}

TEST(Ranks, ABlowUpOnOneRankIsReportedOnceAndEveryRankExitsOne) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_blowup");
    // Two blocks of equal size far apart, one rank each: at five times the stable CFL number of the stiff one
    // (no retries) only the stiff block blows up, on its rank alone; the soft one is far inside its limit.
    const std::string scene = writeFile(dir + "/blowup.json", R"({
      "simulation": { "frames": 3, "dx": 0.05, "substeps": 1, "cfl": 5 },
      "sets": [ { "name": "soft", "material": "water", "shape": { "type": "box", "min": [0, 0, 0], "max": [0.6, 0.3, 0.3] } },
                { "name": "stiff", "material": "water", "material_params": { "bulk_modulus": 1e7 },
                  "shape": { "type": "box", "min": [3, 0, 0], "max": [3.6, 0.3, 0.3] } } ],
      "colliders": [ { "type": "plane" } ] })");
    const Result one = runMpm({"run", scene, "-o", dir + "/one", "--quiet"}, dir);
    ASSERT_EQ(one.code, 1) << one.output;
    // Each rank says how it ended, then waits: mpirun kills the other ranks as soon as one exits nonzero, which
    // could otherwise come before a slower rank has said it.
    const std::string each = std::string(MPM_BINARY) + " run " + scene + " -o " + dir +
                             "/two --quiet --threads 1; c=$?; echo rank exit $c; sleep 2; exit $c";
    std::vector<std::string> args{"--allow-run-as-root", "--oversubscribe", "-np", "2", "/bin/sh", "-c", each};
    Child c = start(args, dir + "/mpirun.log", kMpiexec);
    const int code = c.wait();
    const std::string out = c.output();
    EXPECT_EQ(count(out, "rank exit 1"), 2) << out;
    EXPECT_EQ(count(out, "rank exit"), 2) << out;
    EXPECT_EQ(code, 1) << out;
    EXPECT_EQ(count(out, "error: simulation stopped"), 1) << out;
    // The same particle, substep and cause as one process names.
    const auto line = [](const std::string& s) {
        const std::size_t at = s.find("error: simulation stopped");
        return at == std::string::npos ? std::string() : s.substr(at, s.find('\n', at) - at);
    };
    EXPECT_EQ(line(out), line(one.output));
    EXPECT_NE(line(one.output).find("of set stiff"), std::string::npos) << one.output;
}

TEST(Ranks, ACheckpointOfTwoRanksResumesOnThreeWithTheBitsOfAnUninterruptedRun) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_resume");
    ASSERT_EQ(runMpm({"run", kScene, "-o", dir + "/one", "--quiet"}, dir).code, 0);
    const std::string out = dir + "/split";
    // Frames 1-3 on two ranks (the scene checkpoints at frame 3), then the rest on three.
    const Result first = runRanks(2, {"run", kScene, "-o", out, "--frames", "0:3", "--quiet", "--threads", "1"}, dir);
    ASSERT_EQ(first.code, 0) << first.output;
    const Result second = runRanks(3, {"run", kScene, "-o", out, "--resume", "--threads", "1"}, dir);
    ASSERT_EQ(second.code, 0) << second.output;
    EXPECT_NE(second.output.find("continuing from"), std::string::npos) << second.output;
    expectSameOutput(dir + "/one", out, "ranks_mix", 18);
}

TEST(Ranks, CheckpointPartsOfTwoRanksResumeOnThreeAndOnOneWithTheBitsOfAnUninterruptedRun) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_checkpoint_parts");
    ASSERT_EQ(runMpm({"run", kScene, "-o", dir + "/one", "--quiet"}, dir).code, 0);
    // Frames 0-3 on two ranks writing per-rank files: the checkpoint of frame 3 is a set of two parts, nothing
    // gathered. (The output section is not part of the scene's identity: the gathered scene resumes from it.)
    std::string text = readFile(kScene);
    text.replace(text.find("\"checkpoint_every\""), 0, "\"rank_files\": \"per_rank\", ");
    fs::create_directories(dir + "/per_rank");
    const std::string perRank = writeFile(dir + "/per_rank/ranks_mix.json", text);
    const std::string out = dir + "/parts";
    const Result first = runRanks(2, {"run", perRank, "-o", out, "--frames", "0:3", "--quiet", "--threads", "1"}, dir);
    ASSERT_EQ(first.code, 0) << first.output;
    const std::string part0 = "/ranks_mix_checkpoint_0003_rank000.mpmc", part1 = "/ranks_mix_checkpoint_0003_rank001.mpmc";
    ASSERT_TRUE(fs::exists(out + part0) && fs::exists(out + part1));
    EXPECT_FALSE(fs::exists(out + "/ranks_mix_checkpoint_0003.mpmc"));
    EXPECT_FALSE(fs::exists(out + "/ranks_mix_checkpoint_0003_rank002.mpmc"));
    // Each part holds its rank's particles only, and together they hold all of them once.
    const mpm::Checkpoint a = mpm::readCheckpoint(out + part0), b = mpm::readCheckpoint(out + part1);
    EXPECT_EQ(a.info.parts, 2);
    EXPECT_EQ(b.info.part, 1);
    EXPECT_EQ(a.info.set, b.info.set);
    std::set<int32_t> ids;
    std::size_t inParts = 0;
    for (const mpm::Checkpoint* c : {&a, &b}) {
        std::size_t here = 0;
        for (const mpm::AnySpecies& s : c->state.species) {
            for (int32_t id : mpm::particlesOf(s).id) ids.insert(id);
            here += mpm::particlesOf(s).id.size();
        }
        EXPECT_GT(here, 0u);
        inParts += here;
    }
    EXPECT_EQ(ids.size(), inParts);
    EXPECT_EQ(int32_t(inParts), a.state.nextId);
    // Resumed on three ranks (one reads no part) and on one process (reads both): frames 4-6 and the stats of
    // the uninterrupted one-process run.
    for (int ranks : {3, 1}) {
        const std::string resumed = dir + "/on" + std::to_string(ranks);
        fs::create_directories(resumed);
        fs::copy_file(out + part0, resumed + part0);
        fs::copy_file(out + part1, resumed + part1);
        const std::vector<std::string> args{"run", kScene, "-o", resumed, "--resume", "--threads", "1"};
        const Result r = ranks > 1 ? runRanks(ranks, args, dir) : runMpm(args, dir);
        ASSERT_EQ(r.code, 0) << r.output;
        EXPECT_NE(r.output.find("continuing from " + resumed + "/ranks_mix_checkpoint_0003_rank*.mpmc"), std::string::npos)
            << r.output;
        expectSameOutput(resumed, dir + "/one", "ranks_mix", 9);
    }
    // A set missing a part is not used: named, and the run has nothing else to resume from.
    const std::string broken = dir + "/broken";
    fs::create_directories(broken);
    fs::copy_file(out + part0, broken + part0);
    const Result r = runRanks(2, {"run", kScene, "-o", broken, "--resume", "--threads", "1"}, dir);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_EQ(count(r.output, "1 of its set's 2 parts are present (part 1 is missing)"), 1) << r.output;
    EXPECT_NE(r.output.find("no usable checkpoint"), std::string::npos) << r.output;
}

TEST(Ranks, RetriedFramesRestartOnEveryRankAlike) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_retry");
    // Too long a step for the stiff water: its first frames are retried with half the step, on every rank.
    const std::string scene = writeFile(dir + "/retry.json", R"({
      "simulation": { "frames": 2, "dx": 0.05, "substeps": 1, "cfl": 5, "retries": 5 },
      "output": { "ply": true },
      "sets": [ { "material": "water", "material_params": { "bulk_modulus": 1e7 },
                  "shape": { "type": "box", "min": [0, 0, 0], "max": [0.6, 0.3, 0.3] } } ],
      "colliders": [ { "type": "plane" } ] })");
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/one", "--quiet"}, dir).code, 0);
    const Result r = runRanks(2, {"run", scene, "-o", dir + "/two", "--quiet", "--threads", "1"}, dir);
    ASSERT_EQ(r.code, 0) << r.output;
    expectSameOutput(dir + "/one", dir + "/two", "retry", 4);
    const std::string stats = readFile(dir + "/two/stats.csv");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(stats, m, std::regex(R"(\n1,[^\n]*,[0-9]+,([0-9]+),[^,]*,[^,]*,[^,]*\n)"))) << stats;
    EXPECT_GT(std::stoi(m[1]), 0) << "frame 1 should have been retried: " << stats;
}

TEST(Ranks, MirroredWallsGiveTheBitsOfOneProcess) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_mirror");
    // Jelly held on a sticky floor and water against a slip wall, both mirrored, across the ranks' ranges:
    // the images of ghost nodes near a range's end lie in leaves another rank owns.
    const std::string scene = writeFile(dir + "/mirror.json", R"({
      "simulation": { "frames": 3, "substeps": 8, "dx": 0.02, "wall_ghosts": "mirror" },
      "output": { "split_files": true, "ply": true, "checkpoint_every": 0 },
      "sets": [ { "name": "jelly", "material": "jelly", "velocity": [0.5, -0.5, 0],
                  "shape": { "type": "box", "min": [-0.3, 0.0, -0.1], "max": [0.1, 0.12, 0.1] } },
                { "name": "water", "material": "water", "velocity": [-1.5, 0, 0],
                  "shape": { "type": "box", "min": [0.2, 0.02, -0.1], "max": [0.36, 0.2, 0.1] } } ],
      "colliders": [ { "type": "plane", "boundary": "sticky" },
                     { "type": "plane", "point": [0.4, 0, 0], "normal": [-1, 0, 0], "boundary": "slip" } ] })");
    expectSameBitsOnRanks(scene, "mirror", dir, {{2, "1"}, {3, "1"}});
}

TEST(Ranks, BodiesWithFieldsOfTheirOwnGiveTheBitsOfOneProcess) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_multi_field");
    // Two jelly balls thrown at each other and a body of two water sets, each a velocity field of its own,
    // over a mirrored slip floor: the contact normals near a range's end read masses of leaves another rank
    // owns, in every field.
    const std::string scene = std::string(MPM_SOURCE_DIR) + "/tests/scenes/bodies.json";
    expectSameBitsOnRanks(scene, "bodies", dir, {{2, "2"}, {3, "1"}});
}

TEST(Ranks, ParametersPerParticleTravelWithTheirParticlesAndResumeFromACheckpoint) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_fields");
    // A jelly block whose stiffness and density ramp, thrown across the ranks' ranges into a pool whose density
    // ramps: each particle's parameters move with it from rank to rank.
    const std::string scene = std::string(MPM_SOURCE_DIR) + "/tests/scenes/fields.json";
    expectSameBitsOnRanks(scene, "fields", dir, {{2, "2"}, {3, "1"}});
    // Frames 1-2 on two ranks (the scene checkpoints at frame 2), the rest on one process: the bits of the whole run.
    const std::string out = dir + "/split";
    const Result first = runRanks(2, {"run", scene, "-o", out, "--frames", "0:2", "--quiet", "--threads", "1"}, dir);
    ASSERT_EQ(first.code, 0) << first.output;
    const Result second = runMpm({"run", scene, "-o", out, "--resume", "--threads", "1"}, dir);
    ASSERT_EQ(second.code, 0) << second.output;
    EXPECT_NE(second.output.find("continuing from"), std::string::npos) << second.output;
    for (const char* frame : {"0003", "0004"})
        EXPECT_EQ(mpm::test::vdbWithoutUuid(dir + "/one/fields_points_" + frame + ".vdb"),
                  mpm::test::vdbWithoutUuid(out + "/fields_points_" + frame + ".vdb"))
            << frame;
}

TEST(Ranks, RigidBodiesInMaterialSpreadOverTheRanksGiveTheBitsOfOneProcess) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_rigid");
    // A heavy ball thrown spinning into a pool that spans the ranks' ranges, and a light box on the water in its way:
    // each body's impulse is summed from nodes and particles on every rank, and the ball meets the box and the tank.
    const std::string scene = writeFile(dir + "/rigid.json", R"({
      "simulation": { "frames": 3, "substeps": 8, "dx": 0.02 },
      "output": { "split_files": true, "ply": true, "checkpoint_every": 0 },
      "sets": [ { "name": "pool", "material": "water",
                  "shape": { "type": "box", "min": [0.0, 0.0, 0.0], "max": [0.6, 0.12, 0.2] } } ],
      "colliders": [
        { "type": "box", "min": [0.0, 0.0, 0.0], "max": [0.6, 0.4, 0.2], "inside": true, "friction": 0.3 },
        { "type": "sphere", "center": [0.21, 0.19, 0.1], "radius": 0.05, "friction": 0.3,
          "dynamic": { "density": 3500, "velocity": [1.5, -1.5, 0], "angular_velocity": [0, 0, -5] } },
        { "type": "box", "center": [0.33, 0.13, 0.1], "size": [0.08, 0.04, 0.08], "friction": 0.3,
          "dynamic": { "density": 500 } } ] })");
    expectSameBitsOnRanks(scene, "rigid", dir, {{2, "1"}, {3, "1"}});
    // The rows compared above hold both bodies, and the ball went into the water: its centre at the last frame is
    // below the surface (0.12 m).
    const std::vector<std::string> ballY = statsColumn(dir + "/one/stats.csv", "body0_y");
    ASSERT_FALSE(statsColumn(dir + "/one/stats.csv", "body1_wz").empty());
    ASSERT_FALSE(ballY.empty());
    EXPECT_LT(std::stod(ballY.back()), 0.12);
}

TEST(Ranks, PerRankPartFilesHoldEveryParticleOnceWithTheBitsOfTheWholeFrame) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_parts");
    const std::string scene = writeFile(dir + "/parts.json", R"({
      "simulation": { "frames": 3, "substeps": 8, "dx": 0.02 },
      "output": { "split_files": true, "rank_files": "per_rank", "checkpoint_every": 0 },
      "sets": [ { "name": "water", "material": "water", "velocity": [1.5, 0, 0],
                  "shape": { "type": "box", "min": [-0.4, 0.02, -0.1], "max": [-0.1, 0.2, 0.1] } },
                { "name": "jelly", "material": "jelly", "velocity": [-1, 0, 0.2],
                  "shape": { "type": "sphere", "center": [0.2, 0.15, 0], "radius": 0.1 } } ],
      "colliders": [ { "type": "plane", "boundary": "separate", "friction": 0.4 } ] })");
    // One process writes whole frames (rank_files speaks of ranks only); three ranks write a part each.
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/one", "--quiet"}, dir).code, 0);
    const Result r = runRanks(3, {"run", scene, "-o", dir + "/three", "--quiet", "--threads", "1"}, dir);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(statsWithoutWallTime(dir + "/one/stats.csv"), statsWithoutWallTime(dir + "/three/stats.csv"));
    for (int f = 1; f <= 3; ++f) {
        char name[64];
        std::snprintf(name, sizeof name, "/parts_points_%04d.vdb", f);
        const mpm::PointsReadBack whole = mpm::readVdbPoints(dir + "/one" + name);
        // Every part's particles, by id: each exactly once, at the bits of the whole frame.
        std::map<int32_t, std::pair<mpm::Vec3d, mpm::Vec3f>> byId;
        for (int part = 0; part < 3; ++part) {
            std::snprintf(name, sizeof name, "/parts_points_%04d_rank%03d.vdb", f, part);
            const mpm::PointsReadBack p = mpm::readVdbPoints(dir + "/three" + name);
            EXPECT_GT(p.id.size(), 0u) << name;
            for (std::size_t i = 0; i < p.id.size(); ++i)
                EXPECT_TRUE(byId.emplace(p.id[i], std::pair{p.x[i], p.v[i]}).second) << p.id[i];
        }
        ASSERT_EQ(byId.size(), whole.id.size()) << "frame " << f;
        for (std::size_t i = 0; i < whole.id.size(); ++i) {
            const auto& [x, v] = byId.at(whole.id[i]);
            EXPECT_EQ(x, whole.x[i]) << whole.id[i];
            EXPECT_EQ(v, whole.v[i]) << whole.id[i];
        }
    }
}

TEST(Ranks, SigusrOneStopsEveryRankAtOneSubstepAndTheRunResumesOnThreeRanks) {
    REQUIRE_MPI();
    const std::string dir = tempDir("ranks_signal");
    // The rank scene over 12 frames, so that the signal lands well before its end.
    std::string text = readFile(kScene);
    text.replace(text.find("\"frames\": 6"), 11, "\"frames\": 12");
    const std::string scene = writeFile(dir + "/ranks_mix.json", text);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/one", "--quiet"}, dir).code, 0);
    // OpenMPI forwards SIGUSR1 to every rank (SIGINT and SIGTERM make mpirun kill them within a second).
    const std::string out = dir + "/stopped";
    std::vector<std::string> args{"--allow-run-as-root",
                                  "--oversubscribe",
                                  "--bind-to",
                                  "none",
                                  "-np",
                                  "2",
                                  MPM_BINARY,
                                  "run",
                                  scene,
                                  "-o",
                                  out,
                                  "--threads",
                                  "1"};
    Child c = start(args, dir + "/mpirun.log", kMpiexec);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(5);
    while (!fs::exists(out + "/ranks_mix_checkpoint_0003.mpmc") && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_TRUE(fs::exists(out + "/ranks_mix_checkpoint_0003.mpmc")) << "no checkpoint within 5 minutes";
    ::kill(c.pid, SIGUSR1);
    EXPECT_EQ(c.wait(), 128 + SIGUSR1) << c.output();
    EXPECT_EQ(count(c.output(), "mpm: stopped by SIGUSR1"), 1) << c.output();
    const Result resumed = runRanks(3, {"run", scene, "-o", out, "--resume", "--threads", "1"}, dir);
    ASSERT_EQ(resumed.code, 0) << resumed.output;
    EXPECT_NE(resumed.output.find("continuing from"), std::string::npos) << resumed.output;
    expectSameOutput(dir + "/one", out, "ranks_mix", 36);
}
