// Data safety: the program as a user and a hostile user meet it. kill -9 and signals at random moments then
// --resume, a full disk, two runs into one directory, a scene whose name starts with another's, corrupt
// checkpoints, changed scenes, and every hostile-input failure found so far as a regression case with its
// exit code and message.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "ProgramRuns.h"
#include "io/Checkpoint.h"
#include "io/Output.h"
#include "io/PointFile.h"
#include "io/SceneBudget.h"
#include "io/SceneBuilder.h"
#include "io/SceneReader.h"
#include "io/VdbWriter.h"

namespace fs = std::filesystem;
using namespace mpm;
using namespace mpm::test;

namespace {

/// A small scene that takes about a second: water and an emitted jelly ball against a floor with friction.
const char* kScene = R"({
  "simulation": { "frames": 14, "dx": 0.03, "substeps": 4 },
  "output": { "ply": true, "surface": false },
  "sets": [ { "name": "w", "material": "water", "shape": { "type": "box", "min": [0, 0, 0], "max": [0.3, 0.3, 0.24] } },
            { "name": "j", "material": "jelly", "shape": { "type": "sphere", "center": [0.5, 0.4, 0.1], "radius": 0.09 },
              "velocity": [-1, 0, 0], "start_frame": 2, "duration": 6, "pause": 2 } ],
  "colliders": [ { "type": "plane", "boundary": "slip", "friction": 0.3 }, { "type": "plane", "normal": [1, 0, 0] } ] })";

bool hasCheckpoint(const std::string& dir) {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec))
        if (e.path().extension() == ".mpmc") return true;
    return false;
}

}  // namespace

TEST(Safety, KilledRunsResumeWithTheBitsOfAnUninterruptedRun) {
    const std::string dir = tempDir("kill");
    const std::string scene = writeFile(dir + "/flow.json", kScene);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/ref", "--quiet"}, dir).code, 0);
    std::mt19937 rng(2026);
    std::uniform_int_distribution<int> afterCheckpoint(0, 600);  // ms after the first checkpoint
    for (const char* threads : {"1", "2"})
        for (int trial = 0; trial < 2; ++trial) {
            const std::string out = dir + "/killed_" + threads + "_" + std::to_string(trial);
            Child c = start({"run", scene, "-o", out, "--quiet", "--threads", threads}, dir + "/child.log");
            while (!hasCheckpoint(out)) std::this_thread::sleep_for(std::chrono::milliseconds(5));
            std::this_thread::sleep_for(std::chrono::milliseconds(afterCheckpoint(rng)));
            ::kill(c.pid, SIGKILL);
            c.wait();
            // Resume with the other thread count: bits do not depend on it.
            const Result r =
                runMpm({"run", scene, "-o", out, "--resume", "--threads", std::string(threads) == "1" ? "2" : "1"}, dir);
            ASSERT_EQ(r.code, 0) << r.output;
            EXPECT_NE(r.output.find("took over the lock"), std::string::npos) << r.output;
            expectSameOutput(dir + "/ref", out, "flow");
        }
    // Killed before its first checkpoint (as soon as it holds its directory): there is nothing to resume, and says so;
    // a fresh run takes the directory over and writes the uninterrupted run's bits.
    const std::string early = dir + "/killed_early";
    Child c = start({"run", scene, "-o", early, "--quiet"}, dir + "/child.log");
    while (!fs::exists(early + "/.mpm.lock")) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ::kill(c.pid, SIGKILL);
    c.wait();
    if (!hasCheckpoint(early)) {
        const Result resume = runMpm({"run", scene, "-o", early, "--resume"}, dir);
        EXPECT_EQ(resume.code, 2) << resume.output;
        EXPECT_NE(resume.output.find("no usable checkpoint of scene flow to resume from; run without --resume"),
                  std::string::npos)
            << resume.output;
    }
    const Result fresh = runMpm({"run", scene, "-o", early}, dir);
    ASSERT_EQ(fresh.code, 0) << fresh.output;
    expectSameOutput(dir + "/ref", early, "flow");
}

TEST(Safety, ARunExtendedByRaisingItsFramesResumesFromItsLastCheckpoint) {
    // The commonest reason to resume: a run looked right, so the user raises `frames` and asks for more. The frame count
    // changes no frame already simulated, so the run resumes (a new user's trial was refused: "the scene changed");
    // the frames it adds are an uninterrupted run's bits, and the emitter's repeats continue as scheduled.
    const std::string dir = tempDir("extend");
    const std::string scene = writeFile(dir + "/flow.json", kScene);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/ref", "--quiet"}, dir).code, 0);
    std::string shorter = kScene;
    const std::string full = "\"frames\": 14";
    shorter.replace(shorter.find(full), full.size(), "\"frames\": 6");
    writeFile(dir + "/flow.json", shorter);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/out", "--quiet"}, dir).code, 0);
    writeFile(dir + "/flow.json", kScene);
    const Result r = runMpm({"run", scene, "-o", dir + "/out", "--resume"}, dir);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("frames 7 to 14"), std::string::npos) << r.output;
    expectSameOutput(dir + "/ref", dir + "/out", "flow");
}

TEST(Safety, SignalsStopAtASubstepWithACheckpointAndTheRunResumes) {
    const std::string dir = tempDir("signal");
    const std::string scene = writeFile(dir + "/flow.json", kScene);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/ref", "--quiet"}, dir).code, 0);
    for (const auto& [sig, code] : {std::pair{SIGINT, 130}, std::pair{SIGTERM, 143}}) {
        const std::string out = dir + "/stopped_" + std::to_string(sig);
        Child c = start({"run", scene, "-o", out, "--quiet"}, dir + "/child.log");
        while (!hasCheckpoint(out)) std::this_thread::sleep_for(std::chrono::milliseconds(5));
        std::this_thread::sleep_for(std::chrono::milliseconds(150));
        ::kill(c.pid, sig);
        EXPECT_EQ(c.wait(), code);
        const std::string said = c.output();
        EXPECT_NE(said.find("resume with: mpm run " + scene + " -o " + out + " --resume"), std::string::npos) << said;
        for (const auto& e : fs::directory_iterator(out))
            EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
        const Result r = runMpm({"run", scene, "-o", out, "--resume", "--quiet"}, dir);
        ASSERT_EQ(r.code, 0) << r.output;
        expectSameOutput(dir + "/ref", out, "flow");
    }
    // Stopped in frame 1, before its files (the signal comes as soon as the run holds its directory): the resumed
    // run writes the initial state's stats row once, not again with the state it resumed from. A signal that lands
    // while the sets are still sampled ends the set-up instead, leaving nothing to resume: the run starts afresh.
    const std::string early = dir + "/early";
    Child first = start({"run", scene, "-o", early}, dir + "/child.log");
    while (!fs::exists(early + "/.mpm.lock")) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ::kill(first.pid, SIGINT);
    EXPECT_EQ(first.wait(), 130);
    const std::string said = first.output();  // frames named as files are: before frame 1's, or inside it
    const bool inSetup = said.find("stopped by SIGINT during the set-up (") != std::string::npos;
    EXPECT_TRUE(inSetup || said.find("stopped by SIGINT after frame 0 ") != std::string::npos ||
                said.find("stopped by SIGINT inside frame 1 ") != std::string::npos)
        << said;
    const Result resumed = runMpm({"run", scene, "-o", early, inSetup ? "--quiet" : "--resume"}, dir);
    ASSERT_EQ(resumed.code, 0) << resumed.output;
    expectSameOutput(dir + "/ref", early, "flow");
    // Resuming a run that has finished says so and runs nothing.
    const Result done = runMpm({"run", scene, "-o", early, "--resume"}, dir);
    EXPECT_EQ(done.code, 0);
    EXPECT_NE(done.output.find("all 14 frames of " + scene + " are done in " + early + "; nothing to run"), std::string::npos)
        << done.output;
    // A second Ctrl-C while the first is being served ends the run at once, and removes the directory's lock file
    // (left behind, the next run took it over with a warning).
    const std::string twice = dir + "/twice";
    Child c = start({"run", scene, "-o", twice, "--quiet"}, dir + "/child.log");
    while (!hasCheckpoint(twice)) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ::kill(c.pid, SIGINT);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ::kill(c.pid, SIGINT);
    EXPECT_EQ(c.wait(), 130);
    EXPECT_FALSE(fs::exists(twice + "/.mpm.lock"));
    const Result again = runMpm({"run", scene, "-o", twice, "--quiet"}, dir);
    EXPECT_EQ(again.code, 0) << again.output;
    EXPECT_EQ(again.output.find("took over the lock"), std::string::npos) << again.output;
}

TEST(Safety, ACtrlCInsideAFrameKeepsTheCheckpointWrittenAfterTheFrameBefore) {
    // The checkpoint of a run stopped inside frame N was stored under frame N-1's name, replacing the one written
    // after frame N-1. Now it is <scene>_checkpoint_NNNN_inside.mpmc beside it; --resume continues from it to the
    // uninterrupted run's bits, and it goes once a newer checkpoint is written. 60 substeps a frame make a frame
    // last far longer than the 1 ms poll.
    const std::string dir = tempDir("inside");
    std::string text = kScene;
    text.replace(text.find("\"substeps\": 4"), std::strlen("\"substeps\": 4"), "\"substeps\": 60");
    text.replace(text.find("\"frames\": 14"), std::strlen("\"frames\": 14"), "\"frames\": 5");
    const std::string scene = writeFile(dir + "/flow.json", text);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/ref", "--quiet"}, dir).code, 0);
    const std::string out = dir + "/out";
    // Half a frame after frame 2's file (a frame lasts as long as the one between the files of the first two): past
    // the check for a stop between frames, well inside frame 3. On a loaded machine a frame's length varies, and a stop
    // that landed elsewhere is tried again from the start.
    const auto stopInsideFrame3 = [&](const std::string& sceneFile, const std::string& outDir, const std::string& file1,
                                      const std::string& file2) {
        constexpr int kTries = 3;
        std::string said;
        for (int i = 0; i < kTries && said.find("stopped by SIGINT inside frame 3 ") == std::string::npos; ++i) {
            fs::remove_all(outDir);
            Child c = start({"run", sceneFile, "-o", outDir}, dir + "/child.log");
            const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(3);
            const auto appears = [&](const std::string& path) {
                while (!fs::exists(path) && std::chrono::steady_clock::now() < deadline)
                    std::this_thread::sleep_for(std::chrono::milliseconds(1));
                return std::chrono::steady_clock::now();
            };
            const auto first = appears(outDir + "/" + file1);
            std::this_thread::sleep_for((appears(outDir + "/" + file2) - first) / 2);
            ::kill(c.pid, SIGINT);
            EXPECT_EQ(c.wait(), 130);
            said = c.output();
        }
        return said;
    };
    const std::string said = stopInsideFrame3(scene, out, "flow_checkpoint_0001.mpmc", "flow_checkpoint_0002.mpmc");
    ASSERT_NE(said.find("stopped by SIGINT inside frame 3 "), std::string::npos) << said;
    EXPECT_NE(said.find("the state is in " + out + "/flow_checkpoint_0003_inside.mpmc"), std::string::npos) << said;
    const CheckpointInfo after2 = readCheckpointInfo(out + "/flow_checkpoint_0002.mpmc");
    EXPECT_EQ(after2.frame, 2);
    EXPECT_FALSE(after2.midFrame);
    const CheckpointInfo inside3 = readCheckpointInfo(out + "/flow_checkpoint_0003_inside.mpmc");
    EXPECT_EQ(inside3.frame, 2);
    EXPECT_TRUE(inside3.midFrame);
    const Result r = runMpm({"run", scene, "-o", out, "--resume"}, dir);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("continuing from " + out + "/flow_checkpoint_0003_inside.mpmc (inside frame 3"), std::string::npos)
        << r.output;
    expectSameOutput(dir + "/ref", out, "flow", 10);
    EXPECT_FALSE(fs::exists(out + "/flow_checkpoint_0003_inside.mpmc"));  // superseded by frame 3's own
    EXPECT_TRUE(fs::exists(out + "/flow_checkpoint_0005.mpmc"));

    // Without periodic checkpoints the stop's is the only one; once the resumed run has written the frames after it,
    // it goes: a later --resume would redo them (there is nothing to resume from then, and it says so).
    text.replace(text.find("\"output\": {"), std::strlen("\"output\": {"), "\"output\": { \"checkpoint_every\": 0,");
    fs::create_directories(dir + "/bare");
    const std::string bare = writeFile(dir + "/bare/flow.json", text), quiet = dir + "/bare/out";
    const std::string stopped = stopInsideFrame3(bare, quiet, "flow_0001.ply", "flow_0002.ply");
    ASSERT_TRUE(fs::exists(quiet + "/flow_checkpoint_0003_inside.mpmc")) << stopped;
    const Result finished = runMpm({"run", bare, "-o", quiet, "--resume"}, dir);
    ASSERT_EQ(finished.code, 0) << finished.output;
    expectSameOutput(dir + "/ref", quiet, "flow", 10);
    EXPECT_FALSE(fs::exists(quiet + "/flow_checkpoint_0003_inside.mpmc"));
    const Result again = runMpm({"run", bare, "-o", quiet, "--resume"}, dir);
    EXPECT_EQ(again.code, 2) << again.output;
    EXPECT_NE(again.output.find("no usable checkpoint"), std::string::npos) << again.output;
}

TEST(Safety, CtrlCDuringTheSetUpOfALargeSceneActsAtOnceAndTouchesNothing) {
    // A million particles sampled Poisson-disk take seconds to set up (4.1 million took 25 s here), during which the run
    // said nothing and a Ctrl-C waited for the set-up to end (31 s for a radius given in cm as m). Now the run says
    // which set it samples and a Ctrl-C ends it within a second: exit 130, the phase named, the lock gone, and the
    // directory as it was (here a file of the user's, and no frame, checkpoint or temporary).
    const std::string dir = tempDir("setup_stop");
    const std::string scene = writeFile(dir + "/big.json", R"({ "simulation": { "frames": 2, "dx": 0.02 },
        "sets": [ { "name": "ball", "material": "water", "shape": { "type": "sphere", "center": [0, 1, 0], "radius": 0.6 } } ],
        "colliders": [ { "type": "plane" } ] })");
    const std::string out = dir + "/out";
    fs::create_directories(out);
    writeFile(out + "/notes.txt", "the user's");
    Child c = start({"run", scene, "-o", out}, dir + "/child.log");
    const auto begun = std::chrono::steady_clock::now();
    while (c.output().find("sampling set 0 'ball'") == std::string::npos) {
        ASSERT_LT(std::chrono::steady_clock::now() - begun, std::chrono::seconds(60)) << c.output();
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    const auto asked = std::chrono::steady_clock::now();
    ::kill(c.pid, SIGINT);
    EXPECT_EQ(c.wait(), 130);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - asked).count();
    const std::string said = c.output();
    ASSERT_NE(said.find("stopped by SIGINT during the set-up (sampling set 0 'ball'); nothing was simulated, written or removed"),
              std::string::npos)
        << said;
    // Measured: under 0.1 s (a check between the lattice's slabs and the Poisson tiles); a second allows for a loaded machine.
    EXPECT_LT(seconds, 1.0);
    std::vector<std::string> left;
    for (const auto& e : fs::directory_iterator(out)) left.push_back(e.path().filename().string());
    EXPECT_EQ(left, std::vector<std::string>{"notes.txt"});
}

TEST(Safety, CheckpointReadsBackBitForBit) {
    SceneDesc desc = parseScene(kScene, "flow.json");
    auto sim = buildSimulation(desc);
    sim->emitDue();
    for (int f = 0; f < 3; ++f) sim->advanceFrame();
    const std::string dir = tempDir("ckpt");
    CheckpointInfo info;
    info.format = kCheckpointFormat;
    info.frame = sim->frame();
    info.sceneJson = sceneIdentity(desc.resolvedJson);
    info.sceneHash = sceneHash(info.sceneJson);
    writeCheckpoint(dir + "/c.mpmc", info, sim->state());
    const Checkpoint back = readCheckpoint(dir + "/c.mpmc");
    const SimState& a = sim->state();
    const SimState& b = back.state;
    std::string sa, sb;
    a.forEachScalar([&](const auto& v) { sa.append(reinterpret_cast<const char*>(&v), sizeof(v)); });
    b.forEachScalar([&](const auto& v) { sb.append(reinterpret_cast<const char*>(&v), sizeof(v)); });
    EXPECT_EQ(sa, sb);
    EXPECT_EQ(a.bounds.minStiffnessKey, b.bounds.minStiffnessKey);
    ASSERT_EQ(a.species.size(), b.species.size());
    for (std::size_t s = 0; s < a.species.size(); ++s) {
        ASSERT_EQ(a.species[s].index(), b.species[s].index());
        std::vector<std::string> arraysA, arraysB;
        std::visit(
            [&](const auto& sp) {
                sp.forEachArray([&](const auto& v) { arraysA.emplace_back((const char*)v.data(), v.size() * sizeof(v[0])); });
            },
            a.species[s]);
        std::visit(
            [&](const auto& sp) {
                sp.forEachArray([&](const auto& v) { arraysB.emplace_back((const char*)v.data(), v.size() * sizeof(v[0])); });
            },
            b.species[s]);
        EXPECT_EQ(arraysA, arraysB);
    }
    // Any flipped byte is found, and a truncated file too.
    std::string bytes = readFile(dir + "/c.mpmc");
    bytes[bytes.size() / 2] ^= 0x10;
    writeFile(dir + "/flipped.mpmc", bytes);
    EXPECT_THROW(readCheckpoint(dir + "/flipped.mpmc"), CheckpointError);
    writeFile(dir + "/short.mpmc", readFile(dir + "/c.mpmc").substr(0, bytes.size() - 100));
    EXPECT_THROW(readCheckpoint(dir + "/short.mpmc"), CheckpointError);
}

TEST(Safety, ACheckpointOfFormatTwoResumesWithEachSetsMaterialWhereverTheListOfMaterialsHasGrown) {
    // tests/data/every_material_format2.mpmc is frame 1 of tests/data/every_material.json (a block of each of the seven
    // materials, 64 particles each) as a build of format 2 wrote it: a material by its position in the list. Format
    // 3 names it, so a material added anywhere in the list no longer changes which model an old checkpoint loads.
    const std::string data = std::string(MPM_SOURCE_DIR) + "/tests/data/";
    const Checkpoint old = readCheckpoint(data + "every_material_format2.mpmc");
    EXPECT_EQ(old.info.format, 2);
    const SceneDesc desc = parseScene(readFile(data + "every_material.json"), "every_material.json");
    auto fresh = buildSimulation(desc);
    fresh->emitDue();
    const auto materialOf = [](const AnySpecies& s) {
        return std::visit([](const auto& sp) { return std::string(std::decay_t<decltype(sp)>::Material::kSceneName); }, s);
    };
    const auto paramBytes = [](const AnySpecies& s) {
        return std::visit([](const auto& sp) { return std::string((const char*)&sp.params, sizeof(sp.params)); }, s);
    };
    ASSERT_EQ(old.state.species.size(), desc.sets.size());
    for (std::size_t s = 0; s < desc.sets.size(); ++s) {
        EXPECT_EQ(materialOf(old.state.species[s]), desc.sets[s].material);
        EXPECT_EQ(std::visit([](const auto& sp) { return sp.name; }, old.state.species[s]), desc.sets[s].name);
        EXPECT_EQ(particlesOf(old.state.species[s]).size(), 64u) << desc.sets[s].name;
        EXPECT_EQ(paramBytes(old.state.species[s]), paramBytes(fresh->state().species[s])) << desc.sets[s].name;
    }
    // Formats 2 and 3 kept the elastic models' F in float, formats 2-4 the plastic models' F_E, snow's J_P and water's J:
    // each is read as written, widened to double.
    int widenedF = 0, widenedFe = 0, snowJp = 0, waterJ = 0;
    const auto exactlyWidened = [](const Mat3d& F) { return F == F.template cast<float>().template cast<double>(); };
    for (const AnySpecies& species : old.state.species)
        std::visit(
            [&](const auto& sp) {
                if constexpr (requires { sp.state.F; })
                    for (const Mat3d& F : sp.state.F) {
                        EXPECT_TRUE(exactlyWidened(F));
                        widenedF += !F.isIdentity(0.0);
                    }
                if constexpr (requires { sp.state.Fe; })
                    for (const Mat3d& F : sp.state.Fe) {
                        EXPECT_TRUE(exactlyWidened(F));
                        widenedFe += !F.isIdentity(0.0);
                    }
                if constexpr (requires { sp.state.Jp; })
                    for (const double Jp : sp.state.Jp) {
                        EXPECT_EQ(Jp, double(float(Jp)));
                        snowJp += 1;
                    }
                if constexpr (requires { sp.state.J; })
                    for (const double J : sp.state.J) {
                        EXPECT_EQ(J, double(float(J)));
                        waterJ += J != 1.0;
                    }
            },
            species);
    EXPECT_GT(widenedF, 0);  // the falling blocks are strained by frame 1
    EXPECT_GT(widenedFe, 0);
    EXPECT_EQ(snowJp, 64);
    EXPECT_GT(waterJ, 0);
    // Written again it is the current format and reads back with the same materials and bits.
    const std::string dir = tempDir("format2");
    writeCheckpoint(dir + "/again.mpmc", old.info, old.state);
    const Checkpoint again = readCheckpoint(dir + "/again.mpmc");
    EXPECT_EQ(again.info.format, kCheckpointFormat);
    ASSERT_EQ(again.state.species.size(), old.state.species.size());
    for (std::size_t s = 0; s < old.state.species.size(); ++s) {
        EXPECT_EQ(materialOf(again.state.species[s]), materialOf(old.state.species[s]));
        EXPECT_EQ(paramBytes(again.state.species[s]), paramBytes(old.state.species[s]));
        EXPECT_EQ(particlesOf(again.state.species[s]).x, particlesOf(old.state.species[s]).x);
    }
    // And `--resume` continues from it to frame 2, every set keeping its mass, without --force: the keys added to the
    // scene format since the file was made (colliders' names, bodies' restitution, ...) count at their defaults.
    fs::create_directories(dir + "/out");
    fs::copy_file(data + "every_material_format2.mpmc", dir + "/out/every_material_checkpoint_0001.mpmc");
    const std::string scene = writeFile(dir + "/every_material.json", readFile(data + "every_material.json"));
    const auto r = runMpm({"run", scene, "-o", dir + "/out", "--resume", "--quiet"}, dir);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(r.output.find("changed"), std::string::npos) << r.output;
    EXPECT_TRUE(fs::exists(dir + "/out/every_material_0002.vdb"));
    const Checkpoint resumed = readCheckpoint(dir + "/out/every_material_checkpoint_0002.mpmc");
    EXPECT_EQ(resumed.info.frame, 2);
    ASSERT_EQ(resumed.state.species.size(), old.state.species.size());
    for (std::size_t s = 0; s < old.state.species.size(); ++s) {
        EXPECT_EQ(materialOf(resumed.state.species[s]), desc.sets[s].material);
        EXPECT_EQ(particlesOf(resumed.state.species[s]).mass, particlesOf(old.state.species[s]).mass);
    }
}

TEST(Safety, ACorruptCheckpointFallsBackToTheOneBeforeAndAChangedSceneIsRefused) {
    const std::string dir = tempDir("corrupt");
    const std::string scene = writeFile(dir + "/flow.json", kScene);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/ref", "--quiet"}, dir).code, 0);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/out", "--quiet", "--frames", "0:9"}, dir).code, 0);
    // Checkpoints 8 and 9 are kept; truncate the newest.
    const std::string newest = dir + "/out/flow_checkpoint_0009.mpmc";
    fs::resize_file(newest, fs::file_size(newest) / 2);
    const Result r = runMpm({"run", scene, "-o", dir + "/out", "--resume"}, dir);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("flow_checkpoint_0009.mpmc: truncated"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("continuing from " + dir + "/out/flow_checkpoint_0008.mpmc"), std::string::npos) << r.output;
    expectSameOutput(dir + "/ref", dir + "/out", "flow");
    // The scene changes: resuming is refused, naming what changed, unless forced.
    std::string changed = kScene;
    changed.replace(changed.find("\"velocity\": [-1, 0, 0]"), 22, "\"velocity\": [-2, 0, 0]");
    writeFile(scene, changed);
    const Result refused = runMpm({"run", scene, "-o", dir + "/out", "--resume"}, dir);
    EXPECT_EQ(refused.code, 2);
    EXPECT_NE(refused.output.find("/sets/1/velocity: [-1.0,0.0,0.0] -> [-2.0,0.0,0.0]"), std::string::npos) << refused.output;
    EXPECT_EQ(runMpm({"run", scene, "-o", dir + "/out", "--resume", "--force", "--quiet"}, dir).code, 0);
}

TEST(Safety, FramesAToBDeleteNothingElseAndStartFromACheckpoint) {
    const std::string dir = tempDir("frames");
    const std::string scene = writeFile(dir + "/flow.json", kScene);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/ref", "--quiet"}, dir).code, 0);
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/out", "--quiet"}, dir).code, 0);  // checkpoints 13 and 14
    writeFile(dir + "/out/flow_0014.vdb", "a frame the user edited");
    const Result r = runMpm({"run", scene, "-o", dir + "/out", "--frames", "14:14"}, dir);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("continuing from " + dir + "/out/flow_checkpoint_0013.mpmc"), std::string::npos) << r.output;
    for (int f = 1; f <= 14; ++f) {
        char name[32];
        std::snprintf(name, sizeof name, "/flow_%04d.vdb", f);
        EXPECT_TRUE(fs::exists(dir + "/out" + name)) << name;  // nothing before 14 deleted
    }
    EXPECT_EQ(vdbWithoutUuid(dir + "/out/flow_0014.vdb"), vdbWithoutUuid(dir + "/ref/flow_0014.vdb"));
    // A range in the middle: every other frame, every other stats row (wall times included) and the newest
    // checkpoints stay as they were; the range's rows are replaced in place.
    const std::string statsBefore = readFile(dir + "/out/stats.csv");
    const std::string frame9 = readFile(dir + "/out/flow_0009.vdb");
    const Result middle = runMpm({"run", scene, "-o", dir + "/out", "--frames", "5:6", "--quiet"}, dir);
    ASSERT_EQ(middle.code, 0) << middle.output;
    const std::map<int, std::string> before = statsRows(statsBefore), after = statsRows(readFile(dir + "/out/stats.csv"));
    ASSERT_EQ(after.size(), 15u);
    const std::map<int, std::string> ref = statsRows(statsWithoutWallTime(dir + "/ref/stats.csv"));
    for (const auto& [frame, row] : after) {
        if (frame == 5 || frame == 6)
            EXPECT_EQ(row.substr(0, row.rfind(',')), ref.at(frame)) << frame;
        else
            EXPECT_EQ(row, before.at(frame)) << frame;
    }
    EXPECT_EQ(readFile(dir + "/out/flow_0009.vdb"), frame9);
    std::vector<std::string> checkpoints;
    for (const auto& e : fs::directory_iterator(dir + "/out"))
        if (e.path().extension() == ".mpmc") checkpoints.push_back(e.path().filename().string());
    std::sort(checkpoints.begin(), checkpoints.end());
    EXPECT_EQ(checkpoints, (std::vector<std::string>{"flow_checkpoint_0013.mpmc", "flow_checkpoint_0014.mpmc"}));
    // A range past the scene's end is refused, naming the scene's frames.
    const Result past = runMpm({"run", scene, "-o", dir + "/out", "--frames", "14:15"}, dir);
    EXPECT_EQ(past.code, 2);
    EXPECT_NE(past.output.find("--frames 14:15: the scene has 14 frames"), std::string::npos) << past.output;
}

TEST(Safety, OneRunPerDirectoryAndNoOtherScenesFramesRemoved) {
    const std::string dir = tempDir("lock");
    const std::string scene = writeFile(dir + "/dam.json", kScene);
    fs::create_directories(dir + "/out");
    for (const char* name : {"dam_break_0004.vdb", "dam_break_points_0004.vdb", "dam_break_checkpoint_0004.mpmc"})
        writeFile(dir + "/out/" + name, "another scene's frame");
    Child first = start({"run", scene, "-o", dir + "/out", "--quiet"}, dir + "/first.log");
    while (!fs::exists(dir + "/out/dam_0001.vdb")) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const Result second = runMpm({"run", scene, "-o", dir + "/out"}, dir);
    EXPECT_EQ(second.code, 2);
    EXPECT_NE(second.output.find("in use by another run (pid " + std::to_string(first.pid)), std::string::npos) << second.output;
    EXPECT_EQ(first.wait(), 0) << first.output();
    for (const char* name : {"dam_break_0004.vdb", "dam_break_points_0004.vdb", "dam_break_checkpoint_0004.mpmc"})
        EXPECT_EQ(readFile(dir + "/out/" + name), "another scene's frame") << name;
    EXPECT_FALSE(fs::exists(dir + "/out/.mpm.lock"));  // released at the end
    // A lock left by a process that is gone is taken over, with a warning.
    writeFile(dir + "/out/.mpm.lock", "pid 999999 on host elsewhere since yesterday\n");
    writeFile(dir + "/out/dam_0003.vdb.tmp999999", "half a frame");
    const Result again = runMpm({"run", scene, "-o", dir + "/out", "--frames", "0:1"}, dir);
    EXPECT_EQ(again.code, 0) << again.output;
    EXPECT_NE(again.output.find("took over the lock of " + dir + "/out from a run that is gone (pid 999999"), std::string::npos)
        << again.output;
    EXPECT_NE(again.output.find("removed 1 temporary files"), std::string::npos) << again.output;
    EXPECT_FALSE(fs::exists(dir + "/out/dam_0003.vdb.tmp999999"));
}

TEST(Safety, ASceneWhoseNameExtendsAnothersCannotRunIntoItsDirectory) {
    // dam's split points files would be named as dam_points's frames, and the two would share stats.csv and
    // scene.json: the run of one into the other's directory is refused, and nothing of the other's changes.
    const std::string dir = tempDir("clash");
    const std::string points = writeFile(dir + "/dam_points.json", kScene), dam = writeFile(dir + "/dam.json", kScene);
    ASSERT_EQ(runMpm({"run", points, "-o", dir + "/out", "--quiet", "--frames", "0:2"}, dir).code, 0);
    std::map<std::string, std::string> before;
    for (const auto& e : fs::directory_iterator(dir + "/out")) before[e.path().filename().string()] = readFile(e.path().string());
    for (const std::string& scene : {dam, dam}) {  // and again: a refused run leaves nothing that lets the next one in
        const Result r = runMpm({"run", scene, "-o", dir + "/out", "--quiet"}, dir);
        EXPECT_EQ(r.code, 2);
        EXPECT_NE(r.output.find("holds the frames of scene \"dam_points\""), std::string::npos) << r.output;
    }
    std::map<std::string, std::string> after;
    for (const auto& e : fs::directory_iterator(dir + "/out")) after[e.path().filename().string()] = readFile(e.path().string());
    EXPECT_EQ(after, before);
}

namespace {
/// What a run into a tmpfs of `kb` KiB met: the kind of the file it could not write ("vdb", "ply", "mpmc", "stats.csv";
/// "" when it finished). Checks what a full disk must leave: exit 1 naming the file, no temporary file, every file under
/// a final name whole (frames, point files, checkpoints), stats.csv of whole rows, one per frame from 0.
std::string fillDisk(const std::string& dir, const std::string& scene, int kb) {
    const std::string mnt = dir + "/disk" + std::to_string(kb);
    fs::create_directories(mnt);
    if (::mount("tmpfs", mnt.c_str(), "tmpfs", 0, ("size=" + std::to_string(kb) + "k").c_str()) != 0) {
        ADD_FAILURE() << "cannot mount a tmpfs: " << std::strerror(errno);
        return "";
    }
    const std::string out = mnt + "/out";
    const Result r = runMpm({"run", scene, "-o", out, "--quiet"}, dir);
    std::string kind;
    const std::string prefix = "cannot write " + out + "/";
    if (const auto at = r.output.find(prefix); at != std::string::npos) {
        const std::string file = r.output.substr(at + prefix.size(), r.output.find(':', at + prefix.size()) - at - prefix.size());
        kind = file == "stats.csv" ? file : file.substr(file.rfind('.') + 1);
        EXPECT_EQ(r.code, 1) << r.output;
        EXPECT_NE(r.output.find("No space left on device"), std::string::npos) << r.output;
    } else {
        EXPECT_EQ(r.code, 0) << kb << " KiB: " << r.output;
    }
    for (const auto& e : fs::directory_iterator(out)) {
        const std::string path = e.path().string(), ext = e.path().extension().string();
        EXPECT_EQ(path.find(".tmp"), std::string::npos) << path;
        if (ext == ".vdb") EXPECT_NO_THROW(readVdbPoints(path)) << path;
        if (ext == ".ply") EXPECT_NO_THROW(readPlyPoints(path)) << path;
        if (ext == ".mpmc") EXPECT_NO_THROW(readCheckpoint(path)) << path;
    }
    const std::string csv = readFile(out + "/stats.csv");
    EXPECT_EQ(csv.back(), '\n') << kb << " KiB: stats.csv ends inside a row";
    int expected = 0;
    for (const auto& [frame, row] : statsRows(csv)) EXPECT_EQ(frame, expected++) << kb << " KiB";
    ::umount(mnt.c_str());
    return kind;
}
}  // namespace

TEST(Safety, AFullDiskFailsNamingTheFileAndKeepsEveryFileWhole) {
    if (::geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root; run the suite as root to check a full disk";
    const std::string dir = tempDir("full");
    const std::string scene = writeFile(dir + "/flow.json", kScene);
    {
        const std::string probe = dir + "/probe";
        fs::create_directories(probe);
        if (::mount("tmpfs", probe.c_str(), "tmpfs", 0, "size=64k") != 0)
            GTEST_SKIP() << "cannot mount a tmpfs here (" << std::strerror(errno) << "); the full-disk check needs one";
        ::umount(probe.c_str());
    }
    // Frame 1 writes flow_0001.vdb, flow_0001.ply, stats.csv, then its checkpoint: the disk fills in each in turn as
    // it grows. Where it fills in stats.csv is one size (a page) wide: found by bisection between the largest disk
    // that fills in the PLY file and the smallest that gets past stats.csv.
    std::set<std::string> met;
    int lo = 64, hi = 2048;  // KiB: the first fills in frame 1's VDB file, the second gets past stats.csv
    met.insert(fillDisk(dir, scene, lo));
    while (hi - lo > 4) {
        const int mid = (lo + hi) / 8 * 4;
        const std::string kind = fillDisk(dir, scene, mid);
        met.insert(kind);
        if (kind == "vdb" || kind == "ply")
            lo = mid;
        else
            hi = mid;
        if (kind == "stats.csv") break;
    }
    // One page past the disk that fills in stats.csv, the checkpoint written next is the one that does not fit.
    met.insert(fillDisk(dir, scene, hi));
    met.insert(fillDisk(dir, scene, hi + 4));
    for (const char* kind : {"vdb", "ply", "stats.csv", "mpmc"})
        EXPECT_TRUE(met.count(kind)) << "no disk filled in a " << kind << " file";
}

namespace {
struct BadCase {
    const char* what;
    std::string text;
    int code;
    std::string message;
};

std::string nested(int depth) { return std::string(std::size_t(depth), '[') + std::string(std::size_t(depth), ']'); }

std::string waterScene(const std::string& simulation, const std::string& set, const std::string& params = "{}") {
    return R"({"simulation": {)" + simulation + R"(}, "sets": [{"material": "water", "material_params": )" + params + R"(, )" +
           set + R"(}]})";
}
}  // namespace

TEST(Safety, HostileScenesGetANamedErrorAndExitTwo) {
    const std::string box = R"("shape": {"type": "box", "min": [0, 0, 0], "max": [0.2, 0.2, 0.2]})";
    const std::vector<BadCase> cases = {
        {"deep nesting in a printed value", R"({"simulation": {"frames": )" + nested(100000) + "}}", 2,
         "nested deeper than 64 levels"},
        {"deep nesting anywhere", nested(1000000), 2, "nested deeper than 64 levels"},
        {"a number past double", R"({"simulation": {"dx": 1e400}})", 2, "bad.json: not valid JSON: a number is out of range"},
        {"truncated", R"({"simulation": {"dx": 0.)", 2, "bad.json: not valid JSON: parse error at line 1, column"},
        {"invalid UTF-8", "{\"sets\": [{\"name\": \"\xff\xfe\"}]}", 2, "bad.json: not valid JSON"},
        {"2^63 as an integer", R"({"simulation": {"frames": 9223372036854775808}})", 2,
         "/simulation/frames: value 9223372036854775808 out of range"},
        {"a set beyond the grid's range",
         waterScene(R"("dx": 0.02)", R"("shape": {"type": "sphere", "center": [1e8, 0, 0], "radius": 0.1})"), 2,
         "/sets/0/shape: lies 1e+08 m from the origin, beyond the grid's coordinate range"},
        {"a particle at 1e30 m/s", waterScene(R"("dx": 0.05)", box + R"(, "velocity": [1e30, 0, 0])"), 2, "substeps each (dt = "},
        {"density 1e-12", waterScene(R"("dx": 0.05)", box, R"({"density": 1e-12})"), 2,
         "the limit is simulation.max_substeps_per_frame"},
        {"bulk modulus 1e12", waterScene(R"("dx": 0.05)", box, R"({"bulk_modulus": 1e12})"), 2, "wave speed"},
        {"1e6 substeps per frame", waterScene(R"("dx": 0.05, "substeps": 1000000)", box), 2,
         "/simulation/substeps: frames would need"},
        {"2e9 particles", waterScene(R"("dx": 0.05)", box + R"(, "count": 2000000000)"), 2, "/sets: the run needs about"},
        // The key quoted as any value is: cut to 80 characters (a 1 MB key made a 1 MB message).
        {"a 1 MB unknown key", R"({"simulation": {")" + std::string(1 << 20, 'k') + R"(": 1}})", 2,
         "/simulation/" + std::string(80, 'k') + "...: unknown key; known here: frames"},
    };
    const std::string dir = tempDir("bad");
    for (const BadCase& c : cases) {
        const std::string path = writeFile(dir + "/bad.json", c.text);
        const Result r = runMpm({"validate", path}, dir);
        EXPECT_EQ(r.code, c.code) << c.what << ": " << r.output.substr(0, 400);
        EXPECT_NE(r.output.find(c.message), std::string::npos) << c.what << ": " << r.output.substr(0, 400);
        EXPECT_NE(r.output.find("bad.json"), std::string::npos) << c.what << " does not name the file";
        EXPECT_LT(r.output.size(), 4000u) << c.what << ": a message to read, not the scene again";
    }
    // E = 1e15 for a solid, as the set's own material.
    const std::string stiff =
        R"({"simulation": {"dx": 0.05}, "sets": [{"material": "jelly", "material_params": {"youngs_modulus": 1e15}, )" + box +
        "}]}";
    const Result r = runMpm({"validate", writeFile(dir + "/stiff.json", stiff)}, dir);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("stiff.json: /simulation: frames would need about"), std::string::npos) << r.output;
    // A directory is not a scene; a run names it and exits 2 too.
    const Result d = runMpm({"run", dir}, dir);
    EXPECT_EQ(d.code, 2);
    EXPECT_NE(d.output.find(dir + ": is a directory, not a scene file"), std::string::npos) << d.output;
    // 1e6 is an integer.
    const Result ok =
        runMpm({"validate", "--print-scene", writeFile(dir + "/ok.json", waterScene(R"("frames": 1e2, "dx": 0.05)", box))}, dir);
    EXPECT_EQ(ok.code, 0) << ok.output;
    EXPECT_NE(ok.output.find("\"frames\": 100"), std::string::npos) << ok.output;
}

TEST(Safety, AFrameThatWouldExceedTheSubstepLimitStopsTheRunWithItsCause) {
    // Valid at the start (about 7 substeps per frame), but a jet speeds up under strong gravity until the
    // CFL bound asks for more than the limit of 40.
    const std::string dir = tempDir("watchdog");
    const std::string scene = writeFile(dir + "/jet.json", R"({
      "simulation": { "frames": 40, "dx": 0.02, "substeps": 1, "gravity": [0, -400, 0], "max_substeps_per_frame": 40 },
      "output": { "surface": false, "points": false },
      "sets": [ { "material": "water", "material_params": { "bulk_modulus": 50 },
                  "shape": { "type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1] } } ] })");
    const Result r = runMpm({"run", scene, "-o", dir + "/out", "--quiet"}, dir);
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("substeps (dt = "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("the fastest particle"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("the limit is simulation.max_substeps_per_frame = 40"), std::string::npos) << r.output;
}

TEST(Safety, TheDisplacementRuleIsInTheEstimateAndNamedWhenItExceedsTheLimit) {
    // v = 10 m/s with max_displacement 0.01 cells: 2e-5 s a substep, about 2,084 a frame; the estimate counts it
    // (it said 41, from the CFL bound alone), the run takes as many, and the watchdog names the rule.
    const std::string dir = tempDir("displacement");
    auto scene = [&](const std::string& extra) {
        return writeFile(dir + "/fast.json", R"({"simulation": {"frames": 1, "dx": 0.02, "max_displacement": 0.01,
            "gravity": [0, 0, 0])" + extra + R"(}, "output": {"surface": false, "points": false},
            "sets": [{"material": "jelly", "velocity": [10, 0, 0], "shape": {"type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1]}}]})");
    };
    const Result estimate = runMpm({"validate", scene("")}, dir);
    EXPECT_EQ(estimate.code, 0) << estimate.output;
    EXPECT_NE(estimate.output.find("about 2084 at the start (dt = 2e-05 s, set by the displacement rule"), std::string::npos)
        << estimate.output;
    ASSERT_EQ(runMpm({"run", scene(""), "-o", dir + "/out", "--quiet"}, dir).code, 0);
    const std::map<int, std::string> rows = statsRows(readFile(dir + "/out/stats.csv"));
    EXPECT_NE(rows.at(1).find(",2084,"), std::string::npos) << rows.at(1);  // substeps taken: the estimate's
    EXPECT_NE(rows.at(1).find("max_displacement"), std::string::npos) << rows.at(1);
    const Result refused = runMpm({"validate", scene(R"(, "max_substeps_per_frame": 1000)")}, dir);
    EXPECT_EQ(refused.code, 2);
    EXPECT_NE(refused.output.find("set by the displacement rule"), std::string::npos) << refused.output;
}

TEST(Safety, TheEstimateSaysWhenAMaterialThatStiffensWillShortenTheStep) {
    // Snow thrown at a wall packs and hardens, and its wave speed grows: the run takes more substeps a frame than
    // the step at rest gives, and validate says so; jelly does not stiffen.
    const std::string dir = tempDir("stiffens");
    auto scene = [&](const std::string& material, const std::string& params = "{}") {
        return writeFile(dir + "/" + material + ".json", R"({"simulation": {"frames": 6, "fps": 24, "dx": 0.05},
            "output": {"surface": false},
            "sets": [{"name": "ball", "material": ")" + material +
                                                             R"(", "velocity": [-8, 0, 0], "material_params": )" + params + R"(,
                      "shape": {"type": "sphere", "center": [0.2, 0.3, 0], "radius": 0.15}}],
            "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [1, 0, 0], "boundary": "sticky"}]})");
    };
    const Result snow = runMpm({"validate", scene("snow")}, dir);
    EXPECT_EQ(snow.code, 0) << snow.output;
    EXPECT_NE(snow.output.find("and more later: set ball's snow hardens as it is packed"), std::string::npos) << snow.output;
    const std::size_t at = snow.output.find("substeps per frame: about ");
    ASSERT_NE(at, std::string::npos) << snow.output;
    const int estimated = std::stoi(snow.output.substr(at + std::string("substeps per frame: about ").size()));
    ASSERT_EQ(runMpm({"run", scene("snow"), "-o", dir + "/out", "--quiet"}, dir).code, 0);
    // The most substeps any frame took: stats.csv's `substeps` column.
    const std::vector<std::string> substeps = statsColumn(dir + "/out/stats.csv", "substeps");
    ASSERT_FALSE(substeps.empty());
    int most = 0;
    for (const std::string& cell : substeps) most = std::max(most, std::stoi(cell));
    EXPECT_GT(most, estimated) << "the snow never took more substeps a frame than the estimate's " << estimated;
    const Result jelly = runMpm({"validate", scene("jelly")}, dir);
    EXPECT_EQ(jelly.code, 0) << jelly.output;
    EXPECT_EQ(jelly.output.find("more later"), std::string::npos) << jelly.output;
    // Snow without hardening (xi = 0) keeps its moduli however it is packed: no word either.
    const Result soft = runMpm({"validate", scene("snow", R"({"xi": 0})")}, dir);
    EXPECT_EQ(soft.code, 0) << soft.output;
    EXPECT_EQ(soft.output.find("more later"), std::string::npos) << soft.output;
}

TEST(Safety, SetNamesWithCommasSurviveTheMetadata) {
    const std::string dir = tempDir("names");
    const std::string scene = writeFile(dir + "/names.json", R"({
      "simulation": { "frames": 1, "dx": 0.05, "substeps": 1 },
      "output": { "surface": false },
      "sets": [ { "name": "a,b", "material": "water", "shape": { "type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1] } },
                { "name": "say \"c\"", "material": "jelly", "shape": { "type": "box", "min": [0.2, 0, 0], "max": [0.3, 0.1, 0.1] } } ] })");
    ASSERT_EQ(runMpm({"run", scene, "-o", dir + "/out", "--quiet"}, dir).code, 0);
    const PointsReadBack back = readVdbPoints(dir + "/out/names_0001.vdb");
    EXPECT_EQ(back.setNames, (std::vector<std::string>{"a,b", "say \"c\""}));
    const auto jelly = std::find(back.set.begin(), back.set.end(), 1);
    ASSERT_NE(jelly, back.set.end());
    EXPECT_EQ(back.materialNames.at(std::size_t(back.material[std::size_t(jelly - back.set.begin())])), "jelly");
}

TEST(Safety, AControlGroupsMemoryLimitIsTheMemoryTheBudgetHas) {
    // A container or a batch slot caps memory with a control group, below the machine's: the budget reads the least
    // limit of the process's group and of every group above it, in cgroup v2 (memory.max) and v1
    // (memory.limit_in_bytes), as /proc/self/cgroup names them. A tree like /sys/fs/cgroup, made here.
    const std::string root = tempDir("cgroup");
    const auto put = [&](const std::string& file, const std::string& text) {
        fs::create_directories(fs::path(root + file).parent_path());
        writeFile(root + file, text + "\n");
    };
    put("/slice/memory.max", "1073741824");                       // 1 GiB on the parent
    put("/slice/job/memory.max", "max");                          // none on the group itself
    put("/memory/memory.limit_in_bytes", "9223372036854771712");  // v1's "no limit"
    put("/memory/batch/memory.limit_in_bytes", "2147483648");
    std::string where;
    EXPECT_EQ(cgroupMemoryLimit("0::/slice/job\n", root, where), 1073741824.0);
    EXPECT_EQ(where, root + "/slice/memory.max");
    EXPECT_EQ(cgroupMemoryLimit("4:memory:/batch\n1:cpu:/\n", root, where), 2147483648.0);
    EXPECT_EQ(where, root + "/memory/batch/memory.limit_in_bytes");
    // Both hierarchies (the hybrid layout): the lesser counts.
    EXPECT_EQ(cgroupMemoryLimit("4:memory:/batch\n0::/slice/job\n", root, where), 1073741824.0);
    // No limit anywhere, or no such group: infinite, and the machine's memory is the budget's.
    EXPECT_TRUE(std::isinf(cgroupMemoryLimit("0::/\n3:cpuset:/\n", root, where)));
    EXPECT_TRUE(std::isinf(cgroupMemoryLimit("0::/elsewhere\n", root + "/none", where)));
    // This process: never more than the machine's physical memory.
    const MemoryLimit here = memoryLimit();
    EXPECT_GT(here.bytes, 0.0);
    EXPECT_LE(here.bytes, double(::sysconf(_SC_PHYS_PAGES)) * double(::sysconf(_SC_PAGE_SIZE)));
}
