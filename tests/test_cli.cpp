// The mpm program: exit codes (0 ok, 2 bad input, 1 failed run) and that a blow-up is caught and
// reported instead of written to disk.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <chrono>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "io/SceneBuilder.h"
#include "io/SceneReader.h"
#include "tests/ProgramRuns.h"
#include "tests/TestAssets.h"

namespace fs = std::filesystem;

namespace {
struct Result {
    int code;
    std::string output;
};

/// A shell command line's exit code and output; its last command's output is the one kept.
Result runShell(const std::string& command) {
    const std::string log = (fs::temp_directory_path() / ("mpm_cli_" + std::to_string(::getpid()) + ".log")).string();
    const int status = std::system((command + " > " + log + " 2>&1").c_str());
    std::ifstream in(log);
    return {WEXITSTATUS(status), std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>())};
}

Result runMpm(const std::string& args) { return runShell(std::string(MPM_BINARY) + " " + args); }

std::string sceneFile(const std::string& name, const std::string& text) {
    const fs::path dir = fs::temp_directory_path() / ("mpm_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    std::ofstream((dir / name).string()) << text;
    return (dir / name).string();
}
}  // namespace

TEST(Cli, ValidateShippedScenesAndBadInput) {
    for (const auto& e : fs::recursive_directory_iterator(std::string(MPM_SOURCE_DIR) + "/scenes")) {
        if (!e.is_regular_file() || e.path().extension() != ".json") continue;
        const Result r = runMpm("validate " + e.path().string());
        EXPECT_EQ(r.code, 0) << e.path() << "\n" << r.output;
    }
    const Result bad = runMpm("validate " + sceneFile("bad.json", R"({"sets":[{"material":"wter"}]})"));
    EXPECT_EQ(bad.code, 2);
    EXPECT_NE(bad.output.find("bad.json: /sets/0/material: unknown material \"wter\""), std::string::npos) << bad.output;
    EXPECT_EQ(runMpm("run /nonexistent/scene.json").code, 2);
    EXPECT_EQ(runMpm("run").code, 2);
    EXPECT_EQ(runMpm("validate --explain").code, 0);
    // A legal but suspicious scene: a warning and exit 0, or exit 2 with --strict.
    const std::string tiny = sceneFile("tiny_set.json", R"({"sets":[{"material":"water","count":20,
        "shape":{"type":"sphere","center":[0,0,0],"radius":0.05}}]})");
    const Result warned = runMpm("validate " + tiny);
    EXPECT_EQ(warned.code, 0);
    EXPECT_NE(warned.output.find("warning: " + tiny + ": /sets/0: only 20 particles"), std::string::npos) << warned.output;
    EXPECT_EQ(runMpm("validate --strict " + tiny).code, 2);
}

TEST(Cli, SceneFormatReferenceIsTheExplainOutput) {
    // docs/scene-format.md is generated from the key declarations the reader walks; it must not go stale.
    const Result r = runMpm("validate --explain");
    std::ifstream in(std::string(MPM_SOURCE_DIR) + "/docs/scene-format.md");
    const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(r.output, doc)
        << "docs/scene-format.md is stale: regenerate it with `mpm validate --explain > docs/scene-format.md`";
}

TEST(Cli, TheDocumentedExampleSceneDoesWhatItsTextSays) {
    // docs/scene-format.md's complete scene: the gate lifts from frame 2 to 10 and the water runs out under it, the
    // tank holds every particle, and the jelly ball arrives at frame 12 with its velocity (gravity aside).
    using namespace mpm;
    SceneDesc scene = parseScene(std::string(exampleScene()), "example.json");
    ASSERT_EQ(scene.sets.size(), 2u);
    auto sim = buildSimulation(scene);
    sim->emitDue();
    const double gateAt = -0.09;  // the gate's centre before it lifts: the water starts behind it
    auto beyondGate = [&] {
        std::size_t n = 0;
        for (const Vec3d& x : particlesOf(sim->species().at(0)).x) n += x[0] > gateAt + 0.01;
        return n;
    };
    EXPECT_EQ(beyondGate(), 0u);
    EXPECT_EQ(particlesOf(sim->species().at(1)).size(), 0u);  // the ball is not there yet
    while (sim->state().frame < 12) sim->advanceFrame();
    EXPECT_GT(beyondGate(), particlesOf(sim->species().at(0)).size() / 10);  // a tenth at least has run out
    const ParticleArrays& ball = particlesOf(sim->species().at(1));
    ASSERT_GT(ball.size(), 0u);
    Vec3d v = Vec3d::Zero();
    for (const Vec3f& u : ball.v) v += u.cast<double>();
    v /= double(ball.size());
    // Emitted at the end of frame 11 and not yet advanced: its set velocity, to the float rounding of the particles.
    EXPECT_NEAR(v[0], -1.5, 1e-5);
    // Inside the tank or on its walls, where the particle pass puts what reaches them (to double rounding).
    const Eigen::AlignedBox3d tank(Vec3d(-0.32, 0.0, -0.12), Vec3d(0.32, 0.5, 0.12));
    for (const AnySpecies& s : sim->species())
        for (const Vec3d& x : particlesOf(s).x) EXPECT_LT(tank.exteriorDistance(x), 1e-12) << x.transpose();
}

TEST(Cli, RunWritesFramesAndStats) {
    const std::string scene = sceneFile("tiny.json", R"({
      "simulation": { "frames": 2, "dx": 0.05, "substeps": 2 },
      "output": { "surface": false },
      "sets": [ { "material": "water", "shape": { "type": "box", "min": [0,0,0], "max": [0.2,0.2,0.2] } } ],
      "colliders": [ { "type": "plane" } ] })");
    const std::string out = (fs::temp_directory_path() / ("mpm_cli_out_" + std::to_string(::getpid()))).string();
    const Result r = runMpm("run " + scene + " -o " + out + " --threads 2 --quiet");
    EXPECT_EQ(r.code, 0) << r.output;
    // File N is the end of frame N, from 1, as Blender and Houdini count; the initial state only when asked.
    EXPECT_FALSE(fs::exists(out + "/tiny_0000.vdb"));
    EXPECT_TRUE(fs::exists(out + "/tiny_0001.vdb"));
    EXPECT_TRUE(fs::exists(out + "/tiny_0002.vdb"));
    EXPECT_FALSE(fs::exists(out + "/tiny_0003.vdb"));
    std::ifstream csv(out + "/stats.csv");
    int lines = 0;
    for (std::string line; std::getline(csv, line);) ++lines;
    EXPECT_EQ(lines, 4);  // header + frames 0 (the initial state), 1, 2
    const std::string initial = sceneFile("tiny0.json", R"({
      "simulation": { "frames": 1, "dx": 0.05, "substeps": 2 },
      "output": { "surface": false, "initial_frame": true },
      "sets": [ { "material": "water", "shape": { "type": "box", "min": [0,0,0], "max": [0.2,0.2,0.2] } } ] })");
    EXPECT_EQ(runMpm("run " + initial + " -o " + out + "0 --quiet").code, 0);
    EXPECT_TRUE(fs::exists(out + "0/tiny0_0000.vdb"));
    EXPECT_TRUE(fs::exists(out + "0/tiny0_0001.vdb"));
}

TEST(Cli, UnstableRunIsCaughtNotWritten) {
    // CFL 5 with a stiff material is far past the explicit stability bound.
    const std::string scene = sceneFile("blowup.json", R"({
      "simulation": { "frames": 10, "dx": 0.05, "substeps": 1, "cfl": 5 },
      "output": { "surface": false },
      "sets": [ { "material": "water", "material_params": { "bulk_modulus": 1e9 },
                  "shape": { "type": "box", "min": [0,0,0], "max": [0.3,0.3,0.3] } } ],
      "colliders": [ { "type": "plane" } ] })");
    const std::string out = (fs::temp_directory_path() / ("mpm_cli_blow_" + std::to_string(::getpid()))).string();
    const Result r = runMpm("run " + scene + " -o " + out + " --quiet");
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("simulation stopped"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("particle id"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out + "/blowup_0010.vdb"));
    // Validate says so beforehand (a new user's cfl 5 validated without a word).
    const Result checked = runMpm("validate " + scene);
    EXPECT_NE(checked.output.find("warning: " + scene + ": /simulation/cfl: 5 is past the explicit step's stability bound"),
              std::string::npos)
        << checked.output;
}

TEST(Cli, UnstableFrameIsRetriedWithHalfTheStepWhenAsked) {
    // The same blow-up, but the scene allows retries: each failed frame restarts with half the step until
    // the CFL number is back inside the stable range (5 -> 2.5 -> 1.25 -> 0.625 -> 0.3125), and stats.csv counts them.
    const std::string scene = sceneFile("retry.json", R"({
      "simulation": { "frames": 3, "dx": 0.05, "substeps": 1, "cfl": 5, "retries": 5 },
      "output": { "surface": false, "points": false },
      "sets": [ { "material": "water", "material_params": { "bulk_modulus": 1e7 },
                  "shape": { "type": "box", "min": [0,0,0], "max": [0.3,0.3,0.3] } } ],
      "colliders": [ { "type": "plane" } ] })");
    const std::string out = (fs::temp_directory_path() / ("mpm_cli_retry_" + std::to_string(::getpid()))).string();
    const Result r = runMpm("run " + scene + " -o " + out + " --quiet");
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream csv(out + "/stats.csv");
    std::string header, line;
    std::getline(csv, header);
    const auto column = [&](const std::string& row, const std::string& name) {
        std::size_t idx = 0, pos = 0;
        for (std::size_t p = 0; (p = header.find(',', pos)) != std::string::npos && header.substr(pos, p - pos) != name;
             pos = p + 1)
            ++idx;
        std::stringstream ss(row);
        std::string cell;
        for (std::size_t i = 0; i <= idx; ++i) std::getline(ss, cell, ',');
        return std::stoi(cell);
    };
    int retries = 0;
    while (std::getline(csv, line)) retries += column(line, "retries");
    EXPECT_GE(retries, 1);
}

namespace {
/// The resolved scene of `path` with what the builder derives written in: what validate prints and a run writes.
std::string resolvedOf(const std::string& path) {
    const mpm::SceneDesc scene = mpm::loadScene(path);
    return mpm::resolvedWithDerived(scene, mpm::deriveValues(scene));
}
}  // namespace

TEST(Cli, TheResolvedSceneOfEveryShippedSceneReadsBackToItself) {
    // Every default stated as the engine applies it: the resolved scene, read again from another folder (its
    // scene_file pointing home), resolves to the same text. A key the reader wrote as a default it did not use
    // (a box's centre beside its corners, a collider's pivot, a rectangle's axis) would differ.
    const fs::path out = fs::temp_directory_path() / ("mpm_cli_resolved_" + std::to_string(::getpid()));
    fs::create_directories(out);
    int scenes = 0;
    for (const auto& e : fs::recursive_directory_iterator(std::string(MPM_SOURCE_DIR) + "/scenes")) {
        if (!e.is_regular_file() || e.path().extension() != ".json") continue;
        const std::string first = resolvedOf(e.path().string());
        nlohmann::ordered_json j = nlohmann::ordered_json::parse(first);
        j["scene_file"] = e.path().string();
        const std::string again = (out / "scene.json").string();
        std::ofstream(again) << j.dump(2);
        EXPECT_EQ(resolvedOf(again), first) << e.path();
        // Defaults held as floats are written as a user would write them (0.15, not 0.15000000596046448), and so are the
        // pivots the builder derives (0.055, not 0.05499999999999999; a mesh's 0.45, not 0.45000001788139343): every
        // number in at most 9 significant digits.
        const std::function<void(const nlohmann::ordered_json&, const std::string&)> noNoise = [&](const auto& v,
                                                                                                   const std::string& key) {
            if (v.is_structured()) {
                for (auto it = v.begin(); it != v.end(); ++it) noNoise(*it, v.is_object() ? it.key() : key);
            } else if (v.is_number_float()) {
                char text[32];
                std::snprintf(text, sizeof(text), "%.9g", v.template get<double>());
                EXPECT_EQ(std::strtod(text, nullptr), v.template get<double>()) << e.path() << ": " << key << " " << v.dump();
            }
        };
        noNoise(j, "");
        ++scenes;
    }
    EXPECT_GE(scenes, 20);
}

TEST(Cli, TheSceneARunWritesRunsAgainToTheSameBits) {
    // A keyframed gate without a pivot (it turns about its centre), a spinning set (about its centroid), a box by
    // corners and a turned one by centre and size, a mesh found beside the scene: `mpm run OUT/scene.json`, from
    // another folder, writes the frames the scene wrote, bit for bit, under the scene's name.
    const fs::path dir = fs::temp_directory_path() / ("mpm_cli_rerun_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir / "scene");
    std::ofstream((dir / "scene" / "cup.obj").string()) << mpm::test::cupObj(0.1, 0.1, 0.01);
    const std::string scene = (dir / "scene" / "gate.json").string();
    std::ofstream(scene) << R"({"simulation": {"frames": 4, "dx": 0.02},
        "output": {"ply": true, "surface": false},
        "sets": [{"material": "water", "shape": {"type": "box", "min": [-0.3, 0.0, -0.1], "max": [-0.1, 0.2, 0.1]}},
                 {"material": "jelly", "angular_velocity": [0, 0, 3], "shape": {"type": "box", "center": [0.3, 0.3, 0], "size": [0.1, 0.1, 0.1],
                  "rotation": {"axis": [1, 1, 0], "degrees": 30}}}],
        "colliders": [{"type": "plane"},
                      {"type": "box", "min": [-0.06, 0.0, -0.2], "max": [-0.04, 0.3, 0.2], "boundary": "sticky",
                       "motion": {"keyframes": [{"frame": 0}, {"frame": 4, "rotation": {"axis": [0, 0, 1], "degrees": -60}}]}},
                      {"type": "mesh", "file": "cup.obj", "transform": {"translate": [0.3, 0.0, 0.0]}}]})";
    const Result first = runMpm("run " + scene + " -o " + (dir / "a").string() + " --quiet");
    ASSERT_EQ(first.code, 0) << first.output;
    // The gate's pivot is stated as the centre it turned about.
    const nlohmann::ordered_json written = nlohmann::ordered_json::parse(std::ifstream((dir / "a" / "scene.json").string()));
    EXPECT_EQ(written["colliders"][1]["motion"]["pivot"], nlohmann::ordered_json::parse("[-0.05, 0.15, 0.0]"));
    EXPECT_EQ(written["colliders"][1]["motion"]["keyframes"][1]["position"], nlohmann::ordered_json::parse("[-0.05, 0.15, 0.0]"));
    EXPECT_TRUE(written["sets"][1].contains("pivot"));
    const Result again = runMpm("run " + (dir / "a" / "scene.json").string() + " -o " + (dir / "b").string() + " --quiet");
    ASSERT_EQ(again.code, 0) << again.output;
    mpm::test::expectSameOutput((dir / "a").string(), (dir / "b").string(), "gate", 8);
}

TEST(Cli, ValidateGivesTheRunTimeAndWarnsOfAScaleMistakeWithinSeconds) {
    // A ball of radius 2 where 0.02 was meant: 33.5 million particles, 59 substeps a frame (the CFL bound of
    // water at dx 0.02), 4,800 frames: 9.5e12 particle-substeps, days on any machine of today. validate neither
    // samples it nor stalls: it says how long the run would take, from this machine's measured rate.
    const std::string big = sceneFile("big.json", R"({"simulation": {"frames": 4800}, "sets": [{"material": "water",
        "shape": {"type": "sphere", "center": [0, 2.1, 0], "radius": 2.0}}], "colliders": [{"type": "plane"}]})");
    const auto start = std::chrono::steady_clock::now();
    const Result r = runMpm("validate " + big);
    // About a second in Release here; the bound holds under the sanitizers on a loaded machine. Sampling the ball whole
    // (33.5 million particles) takes minutes.
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 60.0);
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("run time: about "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("frames written, from costs measured now on a block of water"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("big.json: /sets: the run would take about "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("(33510321 particles, 59 substeps a frame, 4800 frames)"), std::string::npos) << r.output;
    EXPECT_EQ(runMpm("validate --strict " + big).code, 2);
}

TEST(Cli, ResumeWithNoCheckpointSaysSoBeforeSamplingTheSets) {
    // --resume into a directory with no checkpoint of the scene: exit 2 with the message, before any set is sampled
    // (a helper waited 17 s for a 0.9M-particle scene to sample before being told there was nothing to resume). The
    // set's sampling note must not appear.
    const std::string scene = sceneFile("resume_none.json", R"({"simulation": {"frames": 2, "dx": 0.02},
        "sets": [{"name": "ball", "material": "water", "shape": {"type": "sphere", "center": [0, 0.3, 0], "radius": 0.2}}]})");
    const fs::path out = fs::temp_directory_path() / ("mpm_cli_resume_none_" + std::to_string(::getpid()));
    fs::remove_all(out);
    const Result r = runMpm("run " + scene + " -o " + out.string() + " --resume");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("no usable checkpoint of scene resume_none to resume from; run without --resume"), std::string::npos)
        << r.output;
    EXPECT_EQ(r.output.find("sampling set"), std::string::npos) << r.output;
    fs::remove_all(out);
}

TEST(Cli, AMeshScaledByMistakeIsRefusedBeforeItsFieldIsBuilt) {
    // A 0.1 m tetrahedron scaled by 1e6: its distance field at a voxel of dx/2 would need about 2e8 GiB
    // (area 2.4e10 m^2); OpenVDB's conversion ran out of memory and aborted (rc 134). A vertex at 1e300 lies
    // beyond any grid. Both are refused with the file and what to check, in well under the seconds a field takes.
    sceneFile("tet.obj", "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    sceneFile("far.obj", "v 0 0 0\nv 1e300 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    const auto scene = [](const std::string& mesh, double scale) {
        return R"({"simulation": {"frames": 2}, "sets": [{"material": "water", "shape": {"type": "box", "min": [0.3, 0.3, 0.3],
            "max": [0.4, 0.4, 0.4]}}], "colliders": [{"type": "mesh", "file": ")" +
               mesh + R"(", "transform": {"scale": )" + std::to_string(scale) + "}}]}";
    };
    const std::string scaled = sceneFile("scaled.json", scene("tet.obj", 1e6)),
                      far = sceneFile("far.json", scene("far.obj", 1.0));
    for (const std::string& command : {"validate " + scaled, "run " + scaled + " -o " + scaled + ".out"}) {
        const Result r = runMpm(command);
        EXPECT_EQ(r.code, 2) << r.output;
        EXPECT_NE(r.output.find("scaled.json: /colliders/0/file: tet.obj: its distance field would take about"),
                  std::string::npos)
            << r.output;
        EXPECT_NE(r.output.find("transform.scale (1e+06)"), std::string::npos) << r.output;
    }
    const Result r = runMpm("validate " + far);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("far.json: /colliders/0/file: far.obj: a vertex lies at"), std::string::npos) << r.output;
}

TEST(Cli, AVdbColliderInASceneOfHugeCellsValidatesInSeconds) {
    // dx = 1e6 m around a rock of 1 cm voxels: the collider's reach is 1e7 m, 1e8 of the field's coarse cells, and
    // growing its near-surface mask that far stalled validate for minutes. The mask stops at 64 coarse cells and
    // the band's box answers beyond.
    const std::string scene =
        sceneFile("huge_cells.json", R"({"simulation": {"frames": 1, "dx": 1e6}, "sets": [{"material": "water",
        "shape": {"type": "box", "min": [0, 0, 0], "max": [3e6, 3e6, 3e6]}}], "colliders": [{"type": "vdb", "file": ")" +
                                         std::string(MPM_SOURCE_DIR) + R"(/scenes/assets/rock.vdb", "grid": "surface"}]})");
    const auto start = std::chrono::steady_clock::now();
    const Result r = runMpm("validate " + scene);
    // 6 s in Release here (the field's own band growth and the run-time estimate); minutes before.
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 60.0);
    EXPECT_EQ(r.code, 0) << r.output;
}

TEST(Cli, OverlappingSetsGetOneLineEachAndManyOfThemAnswerWithinSeconds) {
    // 300 boxes of water in one place and one apart: every set in the pile overlaps the 299 others, and says so in
    // one line naming three; the one apart says nothing. Tested pair by pair, this took 17 s and printed 14 MB. The
    // first kRepeatsShown lines are printed whole, the rest summed up in one naming their paths.
    nlohmann::json scene = {{"simulation", {{"frames", 1}, {"dx", 0.02}}}, {"sets", nlohmann::json::array()}};
    const auto box = [](double x) {
        return nlohmann::json{{"material", "water"},
                              {"sampling", "lattice"},
                              {"shape", {{"type", "box"}, {"min", {x, 0, 0}}, {"max", {x + 0.1, 0.1, 0.1}}}}};
    };
    constexpr int kPile = 300;
    for (int i = 0; i < kPile; ++i) scene["sets"].push_back(box(0.0));
    scene["sets"].push_back(box(1.0));
    const std::string path = sceneFile("pile.json", scene.dump());
    const auto start = std::chrono::steady_clock::now();
    const Result r = runMpm("validate " + path);
    // About 2 s in Release here (most of it the run-time estimate); the bound leaves room for the sanitizers.
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 60.0);
    EXPECT_EQ(r.code, 0) << r.output.substr(0, 2000);
    std::size_t lines = 0;
    for (std::size_t at = r.output.find("emitted into the same space"); at != std::string::npos;
         at = r.output.find("emitted into the same space", at + 1))
        ++lines;
    EXPECT_EQ(lines, mpm::kRepeatsShown);
    EXPECT_NE(r.output.find("pile.json: the same as above for 297 more: /sets/3/shape, /sets/4/shape"), std::string::npos)
        << r.output.substr(0, 2000);
    EXPECT_NE(
        r.output.find(
            "pile.json: /sets/0/shape: 1000 of 1000 particles lie inside set 1 (\"set1\"); 1000 of 1000 particles lie inside "
            "set 2 (\"set2\"); 1000 of 1000 particles lie inside set 3 (\"set3\"); and inside 296 more sets: they are emitted"),
        std::string::npos)
        << r.output.substr(0, 2000);
    EXPECT_EQ(r.output.find("/sets/300/shape"), std::string::npos);
    // Three lines of about 420 characters (three sets named, the rest counted, what to change) and the summary.
    std::size_t warned = 0;
    std::istringstream text(r.output);
    for (std::string line; std::getline(text, line);)
        if (line.rfind("warning: ", 0) == 0) warned += line.size();
    EXPECT_LT(warned, std::size_t(2000));
    // Two sets: the line names the one.
    scene["sets"] = {box(0.0), box(0.05)};
    const Result two = runMpm("validate " + sceneFile("two.json", scene.dump()));
    EXPECT_NE(
        two.output.find(
            "two.json: /sets/1/shape: 500 of 1000 particles lie inside set 0 (\"set0\"): both are emitted into the same space"),
        std::string::npos)
        << two.output;
}

TEST(Cli, RunningOutOfMemorySaysWhatWasBeingDone) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space: a limit on it (ulimit -v) stops it from starting";
#else
    // 16 million particles (about 3.71 GiB by the estimate) under a 600 MB address-space limit (the program and its
    // libraries take about 260 MB of it here): the sampling runs out, and the message names the phase, the
    // particles and the estimate, where it was a bare "out of memory" (exit 1).
    const std::string big =
        sceneFile("oom.json", R"({"simulation": {"frames": 2, "dx": 0.005}, "sets": [{"name": "pool", "material": "water",
        "sampling": "lattice", "shape": {"type": "box", "min": [0, 0, 0], "max": [1, 0.5, 0.5]}}]})");
    const std::string out = big + ".out";
    const Result r = runShell("ulimit -v 600000; " + std::string(MPM_BINARY) + " run " + big + " -o " + out + " --threads 2");
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("error: simulation stopped: out of memory while sampling the particle sets"), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("(the scene needs about 3.71 GiB at its peak"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out + "/oom_0001.vdb"));
#endif
}

TEST(Cli, AMeshFieldBeyondTheAddressSpaceLimitIsRefusedBeforeItIsBuilt) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space: a limit on it (ulimit -v) stops it from starting";
#else
    // The example rock scaled 50x: its field would peak at about 5.5 GiB. OpenVDB builds it in worker threads, where
    // running out of memory under ulimit -v ended validate with std::terminate (rc 134, found by a new user's trial);
    // it is refused first, naming the file, the limit and what to change.
    const std::string scene =
        sceneFile("big_rock.json", R"({"simulation": {"frames": 1, "dx": 0.02}, "sets": [{"material":
        "water", "shape": {"type": "box", "min": [0, 0.4, 0], "max": [0.1, 0.5, 0.1]}}], "colliders": [{"type": "mesh", "file": ")" +
                                       std::string(MPM_SOURCE_DIR) +
                                       R"(/scenes/assets/rock.obj", "transform": {"scale": 50, "translate": [100, 0, 0]}}]})");
    for (const std::string& command : {"validate " + scene, "run " + scene + " -o " + scene + ".out"}) {
        const Result r = runShell("ulimit -v 1500000; " + std::string(MPM_BINARY) + " " + command);
        EXPECT_EQ(r.code, 2) << r.output;
        EXPECT_NE(r.output.find("rock.obj: its distance field would take about"), std::string::npos) << r.output;
        EXPECT_NE(r.output.find("(its address-space limit, ulimit -v)"), std::string::npos) << r.output;
    }
#endif
}

TEST(Cli, VersionThreadsFramesAndAnUnwritableOutputAreClear) {
    const Result version = runMpm("--version");
    EXPECT_EQ(version.code, 0);
    EXPECT_NE(version.output.find("sparse-mpm "), std::string::npos) << version.output;
    EXPECT_NE(version.output.find("OpenVDB"), std::string::npos) << version.output;
    const std::string scene = sceneFile("small.json", R"({"simulation": {"frames": 2, "dx": 0.05}, "output": {"surface": false},
        "sets": [{"shape": {"type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1]}}]})");
    const Result threads = runMpm("run " + scene + " --threads abc");
    EXPECT_EQ(threads.code, 2);
    EXPECT_LT(threads.output.size(), 200u) << threads.output;  // no 300-digit range
    EXPECT_NE(threads.output.find("'abc' is not a thread count"), std::string::npos) << threads.output;
    EXPECT_EQ(threads.output.rfind("error: ", 0), 0u) << threads.output;  // as a scene's errors are
    // More threads than this process can run at once: said, and the run reports the ones it takes (no machine
    // running this has 4096 cores).
    const Result many = runMpm("run " + scene + " --threads 4096 -o " + scene + "_many");
    EXPECT_EQ(many.code, 0) << many.output;
    EXPECT_NE(many.output.find("warning: --threads 4096 is more than the "), std::string::npos) << many.output;
    EXPECT_EQ(many.output.find("x 4096 threads"), std::string::npos) << many.output;
    EXPECT_NE(runMpm("validate --threads 4096 " + scene).output.find("warning: --threads 4096 is more than the "),
              std::string::npos);
    // The particles the start emits are those the first frame has; a set that comes later is counted apart.
    // And validate's step leaves out a set that never appears (thrown at 50 m/s, it would set the step).
    const std::string lateScene = sceneFile("late_set.json", R"({"simulation": {"frames": 1, "dx": 0.05},
        "output": {"surface": false}, "sets": [{"shape": {"type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1]}},
        {"start_frame": 5, "velocity": [50, 0, 0], "shape": {"type": "box", "min": [0, 0.2, 0], "max": [0.2, 0.3, 0.1]}}]})");
    const std::string aloneScene = sceneFile("alone_set.json", R"({"simulation": {"frames": 1, "dx": 0.05},
        "output": {"surface": false}, "sets": [{"shape": {"type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1]}}]})");
    const auto stepLine = [](const std::string& out) {
        const std::size_t at = out.find("substeps per frame:");
        return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
    };
    const std::string lateStep = stepLine(runMpm("validate " + lateScene).output);
    EXPECT_FALSE(lateStep.empty());
    EXPECT_EQ(lateStep, stepLine(runMpm("validate " + aloneScene).output));
    // A scene whose every set comes after its last frame says so as a whole, validated and run.
    const std::string onlyLate = sceneFile("only_late.json", R"({"simulation": {"frames": 2, "dx": 0.05},
        "output": {"surface": false}, "sets": [{"start_frame": 5, "shape": {"type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1]}}]})");
    for (const std::string& command : {"validate " + onlyLate, "run " + onlyLate + " -o " + scene + "_only_late"})
        EXPECT_NE(runMpm(command).output.find("/sets: no set appears within the scene's 2 frames"), std::string::npos) << command;
    const Result late = runMpm("run " + lateScene + " -o " + scene + "_late");
    const auto numberAfter = [&](const std::string& key) {
        const std::size_t at = late.output.find(key);
        return at == std::string::npos ? -1L : std::atol(late.output.c_str() + at + key.size());
    };
    EXPECT_GT(numberAfter("due at the start ("), 0) << late.output;
    EXPECT_EQ(numberAfter("due at the start ("), numberAfter(" particles ")) << late.output;
    EXPECT_NE(late.output.find(" more sampled for the sets due later)"), std::string::npos) << late.output;
    const Result frames = runMpm("run " + scene + " --frames x");
    EXPECT_EQ(frames.code, 2);
    EXPECT_NE(frames.output.find("(for example 1:48)"), std::string::npos) << frames.output;
    const Result unwritable = runMpm("run " + scene + " -o " + scene + "/out");  // under a file
    EXPECT_EQ(unwritable.code, 2);
    EXPECT_NE(unwritable.output.find("cannot create the output directory"), std::string::npos) << unwritable.output;
    // A name of 100,000 characters is quoted by its ends, not echoed whole.
    const Result huge = runMpm("run " + scene + " -o " + std::string(100000, 'a'));
    EXPECT_EQ(huge.code, 2);
    EXPECT_NE(huge.output.find("...(100001 characters)...aaa"), std::string::npos) << huge.output.substr(0, 400);
    EXPECT_LT(huge.output.size(), 500u);
    // A scene whose name makes its frames' names too long for the file system fails before it runs, not at its first frame.
    const std::string longName = std::string(240, 'n') + ".json";
    const Result tooLong = runMpm("run " + sceneFile(longName, R"({"simulation": {"frames": 2, "dx": 0.05},
        "sets": [{"shape": {"type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1]}}]})") +
                                  " -o " + scene + "_long");
    EXPECT_EQ(tooLong.code, 2);
    EXPECT_NE(tooLong.output.find("the scene's name (its file's, 240 characters) makes file names of up to"), std::string::npos)
        << tooLong.output;
    EXPECT_EQ(tooLong.output.find("frame 1/2"), std::string::npos) << tooLong.output;
    // validate: the summary, and the scene only when asked for.
    const Result plain = runMpm("validate " + scene), printed = runMpm("validate --print-scene " + scene);
    EXPECT_EQ(plain.output.find("\"simulation\""), std::string::npos) << plain.output;
    EXPECT_NE(printed.output.find("\"simulation\""), std::string::npos) << printed.output;
    // The report on standard output, to be kept in a file; with --print-scene standard output is the scene alone,
    // JSON that parses. --threads sets the threads the run-time estimate is measured on.
    const Result report = runShell("(" + std::string(MPM_BINARY) + " validate --threads 1 " + scene + " 2>/dev/null)");
    EXPECT_NE(report.output.find(": valid (1 particle set)"), std::string::npos) << report.output;
    EXPECT_NE(report.output.find("on a block of water on 1 thread:"), std::string::npos) << report.output;
    const Result json = runShell("(" + std::string(MPM_BINARY) + " validate --print-scene " + scene + " 2>/dev/null)");
    EXPECT_EQ(json.code, 0);
    ASSERT_TRUE(nlohmann::json::accept(json.output)) << json.output;
    // As a run's scene.json: it names the scene it came from, so that it finds its assets from anywhere.
    EXPECT_EQ(nlohmann::json::parse(json.output).value("scene_file", std::string()),
              std::filesystem::absolute(scene).lexically_normal().string());
    EXPECT_EQ(runMpm("validate --threads -1 " + scene).code, 2);
    // A scene --strict rejects prints no scene.
    const std::string tinySet = sceneFile("tiny_strict.json", R"({"sets":[{"material":"water","count":20,
        "shape":{"type":"sphere","center":[0,0,0],"radius":0.05}}]})");
    const Result rejected =
        runShell("(" + std::string(MPM_BINARY) + " validate --strict --print-scene " + tinySet + " 2>/dev/null)");
    EXPECT_EQ(rejected.code, 2);
    EXPECT_EQ(rejected.output.find("\"simulation\""), std::string::npos) << rejected.output;
}

TEST(Cli, WarningsThatRepeatAreSummarised) {
    // Forty copies of one small set: each is small (a warning each) and lies inside the 39 others (a warning each).
    // Each kind is printed in full three times, then once for the rest, naming them by their paths; --strict still
    // counts every one.
    nlohmann::json scene = {{"simulation", {{"frames", 1}, {"dx", 0.05}}}, {"sets", nlohmann::json::array()}};
    constexpr int kSets = 40;
    for (int i = 0; i < kSets; ++i)
        scene["sets"].push_back({{"count", 50}, {"shape", {{"type", "box"}, {"min", {0, 0, 0}}, {"max", {0.1, 0.1, 0.1}}}}});
    const std::string file = sceneFile("forty_sets.json", scene.dump());
    const Result r = runMpm("validate " + file);
    EXPECT_EQ(r.code, 0) << r.output;
    std::istringstream lines(r.output);
    int warnings = 0;
    for (std::string line; std::getline(lines, line);) warnings += line.rfind("warning: ", 0) == 0;
    EXPECT_EQ(warnings, 2 * int(mpm::kRepeatsShown + 1)) << r.output;
    EXPECT_NE(r.output.find(": the same as above for 37 more: /sets/3, /sets/4, "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("(28 more), /sets/39"), std::string::npos) << r.output;
    const Result strict = runMpm("validate --strict " + file);
    EXPECT_EQ(strict.code, 2);
    EXPECT_NE(strict.output.find("80 warnings, and --strict makes them errors"), std::string::npos) << strict.output;
}
