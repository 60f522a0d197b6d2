// Scenes, sampling, emission and output: every invalid field gives its named error; sampling meets its
// count, spacing and shape; emission happens on the right frames; frames read back as written; an
// interrupted write leaves no partial file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <unordered_map>

#include "io/AtomicFile.h"
#include "io/Output.h"
#include "io/PointFile.h"
#include "io/Run.h"
#include "io/Sampling.h"
#include "io/Scene.h"
#include "io/VdbWriter.h"

using namespace mpm;
namespace fs = std::filesystem;

namespace {
std::string tempDir(const std::string& name) {
    const fs::path p = fs::temp_directory_path() / ("mpm_test_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(p);
    fs::create_directories(p);
    return p.string();
}

std::string writeScene(const std::string& dir, const std::string& name, const std::string& text) {
    const std::string path = dir + "/" + name;
    std::ofstream(path) << text;
    return path;
}

const char* kValid = R"({
  "simulation": { "frames": 3, "dx": 0.05, "substeps": 2 },
  "sets": [ { "name": "a", "material": "water", "shape": { "type": "box", "min": [0,0,0], "max": [0.2,0.2,0.2] } },
            { "name": "b", "material": "water", "shape": { "type": "sphere", "center": [1,0,0], "radius": 0.1 },
              "start_frame": 1, "duration": 4, "pause": 1, "sampling": "grid" } ],
  "colliders": [ { "type": "plane", "normal": [0,1,0], "boundary": "sticky" } ]
})";

std::string errorOf(const std::string& text) {
    const std::string dir = tempDir("err");
    const std::string path = writeScene(dir, "dam.json", text);
    try {
        loadScene(path);
    } catch (const SceneError& e) {
        std::string msg = e.what();
        return msg.substr(msg.find("dam.json"));
    }
    return "no error";
}
}  // namespace

TEST(SceneFile, ValidSceneResolvesDefaults) {
    const std::string dir = tempDir("valid");
    SceneDesc s = loadScene(writeScene(dir, "ok.json", kValid));
    EXPECT_EQ(s.frames, 3);
    EXPECT_EQ(s.sets.size(), 2u);
    EXPECT_DOUBLE_EQ(s.settings.fps, 24.0);
    EXPECT_NE(s.resolvedJson.find("\"interpolation\": \"quadratic\""), std::string::npos);
    EXPECT_NE(s.resolvedJson.find("\"bulk_modulus\""), std::string::npos);
}

TEST(SceneFile, EveryInvalidFieldIsNamed) {
    const std::map<std::string, std::string> cases = {
        {R"({"sets":[{"material":"wter","shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}]})",
         "dam.json: /sets/0/material: unknown material \"wter\"; known: water"},
        {R"({"sets":[{"shape":{"type":"cone"}}]})", "dam.json: /sets/0/shape/type: unknown shape \"cone\"; known: box, sphere"},
        {R"({"simulation":{"dx":-1},"sets":[]})", "dam.json: /simulation/dx: value -1 out of range"},
        {R"({"simulation":{"fps":"fast"}})", "dam.json: /simulation/fps: expected a number"},
        {R"({"simulation":{"interpolation":"linear"}})",
         "dam.json: /simulation/interpolation: unknown interpolation \"linear\"; known: quadratic, cubic"},
        {R"({"simulation":{"dxx":0.1}})", "dam.json: /simulation/dxx: unknown key; known here:"},
        {R"({"sets":[]})", "dam.json: /sets: a scene needs at least one particle set"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,-1,1]}}]})", "dam.json: /sets/0/shape/max: must exceed min"},
        {R"({"sets":[{"shape":{"type":"sphere","center":[0,0]}}]})",
         "dam.json: /sets/0/shape/center: expected a list of 3 numbers"},
        {R"({"sets":[{"shape":{"type":"sphere","center":[0,0,0]}}]})", "dam.json: /sets/0/shape/radius: missing required field"},
        {R"({"sets":[{"material_params":{"bulk":1},"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}]})",
         "dam.json: /sets/0/material_params/bulk: unknown key; known here: density, bulk_modulus, gamma"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}],"colliders":[{"type":"plane","boundary":"glue"}]})",
         "dam.json: /colliders/0/boundary: unknown boundary \"glue\"; known: sticky, slip, separate"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}],"colliders":[{"type":"plane","normal":[0,0,0]}]})",
         "dam.json: /colliders/0/normal: must not be the zero vector"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}],"colliders":[{"type":"plane"},{"type":"plane","name":"collider0"}]})",
         "dam.json: /colliders/1/name: duplicate collider name \"collider0\": collider 0 has it"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}],"colliders":[{"type":"sphere","radius":0.1,"dynamic":{"restitution":1.5}}]})",
         "dam.json: /colliders/0/dynamic/restitution: value 1.5 out of range; allowed: 0 to 1"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}],"colliders":[{"type":"sphere","radius":0.1,"dynamic":{},"motion":{"velocity":[1,0,0]}}]})",
         "dam.json: /colliders/0/dynamic: a body the material moves follows a motion only until dynamic/animated_until"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}],"colliders":[{"type":"sphere","radius":0.1,"dynamic":{"animated_until":1}}]})",
         "dam.json: /colliders/0/dynamic: animated_until: the collider has no motion to follow"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}],"colliders":[{"type":"plane","name":"collider1"},{"type":"plane"}]})",
         "dam.json: /colliders/1/name: duplicate collider name \"collider1\": collider 0 has it (it is this collider's default "
         "name: give this one a name)"},
        {R"({"sets":[{"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}],"colliders":[{"type":"plane","name":""}]})",
         "dam.json: /colliders/0/name: must not be empty"},
        {R"({"sets":[{"duration":0,"shape":{"type":"box","min":[0,0,0],"max":[1,1,1]}}]})",
         "dam.json: /sets/0/duration: value 0 out of range"},
        {R"({"sets": 3})", "dam.json: /sets: expected a list of objects"},
        {R"({"sets":[ )", "dam.json: not valid JSON"},
    };
    for (const auto& [text, expected] : cases) {
        const std::string got = errorOf(text);
        EXPECT_EQ(got.substr(0, expected.size()), expected) << "scene: " << text;
    }
}

TEST(Sampling, PoissonDiskMeetsCountSpacingAndShape) {
    const Sphere sphere{Vec3d(1, 2, 3), 0.2};
    const SetRegion ball = sphere;
    const double r = 0.02;
    const auto pts = poissonDisk(ball, r, 5);
    ASSERT_GT(pts.size(), 500u);
    for (const Vec3d& p : pts) EXPECT_TRUE(sphere.contains(p));
    double minDist = 1e9;
    for (std::size_t i = 0; i < pts.size(); ++i)
        for (std::size_t j = i + 1; j < pts.size(); ++j) minDist = std::min(minDist, (pts[i] - pts[j]).norm());
    EXPECT_GE(minDist, r * (1 - 1e-9));
    // Density target: particles_per_cell within 15% (Bridson's packing is not exact).
    const auto dense = sampleShape(ball, 0.02, 8.0, 0, Sampling::Poisson, 3);
    EXPECT_NEAR(double(dense.size()) / (sphere.volume() / (0.02 * 0.02 * 0.02)), 8.0, 1.2);
    // An exact count, for both methods.
    EXPECT_EQ(sampleShape(ball, 0.02, 8.0, 1234, Sampling::Poisson, 3).size(), 1234u);
    const auto grid = sampleShape(ball, 0.02, 8.0, 777, Sampling::Grid, 3);
    EXPECT_EQ(grid.size(), 777u);
    for (const Vec3d& p : grid) EXPECT_TRUE(sphere.contains(p));
}

TEST(Sampling, PoissonDiskPartsAreTheWholeSamplingCut) {
    // Each part is sampled alone (a rank's share) and must give the whole sampling's points there, in order:
    // the tiles' points depend only on tiles within 7 of them, each grown from a seed of its coordinate.
    Box box;
    box.min = Vec3d(-0.3, 0.1, 0.2);
    box.max = Vec3d(0.25, 0.4, 0.5);
    const SetRegion region = box;
    const double r = 0.012;
    const auto whole = poissonDisk(region, r, 11);
    ASSERT_GT(whole.size(), 10000u);
    for (int parts : {2, 3, 7}) {
        std::vector<Vec3d> joined;
        for (int k = 0; k < parts; ++k) {
            const auto part = poissonDisk(region, r, 11, SamplePart{k, parts});
            EXPECT_LT(part.size(), whole.size());
            joined.insert(joined.end(), part.begin(), part.end());
        }
        ASSERT_EQ(joined.size(), whole.size()) << parts << " parts";
        EXPECT_TRUE(std::equal(joined.begin(), joined.end(), whole.begin())) << parts << " parts";
        // A jittered lattice holds only its part too, the whole lattice's points.
        const auto lattice = sampleShape(region, 0.02, 8.0, 0, Sampling::Grid, 5);
        std::vector<Vec3d> lattices;
        for (int k = 0; k < parts; ++k) {
            const auto part = sampleShape(region, 0.02, 8.0, 0, Sampling::Grid, 5, SamplePart{k, parts});
            lattices.insert(lattices.end(), part.begin(), part.end());
        }
        ASSERT_EQ(lattices.size(), lattice.size()) << parts << " parts";
        EXPECT_TRUE(std::equal(lattices.begin(), lattices.end(), lattice.begin())) << parts << " parts";
    }
    // Across tile borders the spacing holds too: a spatial hash of cell r finds every pair closer than r.
    std::unordered_map<long long, std::vector<std::size_t>> cells;
    auto keyOf = [&](const Vec3i& c) { return ((long long)(c[0] + 1000) * 4096 + (c[1] + 1000)) * 4096 + (c[2] + 1000); };
    auto cellOf = [&](const Vec3d& x) { return (x / r).array().floor().cast<int>().matrix().eval(); };
    for (std::size_t i = 0; i < whole.size(); ++i) cells[keyOf(cellOf(whole[i]))].push_back(i);
    double minDist = 1e9;
    for (std::size_t i = 0; i < whole.size(); ++i) {
        const Vec3i c = cellOf(whole[i]);
        for (int a = -1; a <= 1; ++a)
            for (int b = -1; b <= 1; ++b)
                for (int d = -1; d <= 1; ++d) {
                    const auto it = cells.find(keyOf(c + Vec3i(a, b, d)));
                    if (it == cells.end()) continue;
                    for (std::size_t j : it->second)
                        if (j != i) minDist = std::min(minDist, (whole[i] - whole[j]).norm());
                }
    }
    EXPECT_GE(minDist, r * (1 - 1e-9));
    // Filled to the borders: the density near the faces (within 2 r) is that of the interior within 10%.
    std::size_t nearFace = 0;
    for (const Vec3d& x : whole) nearFace += ((x - box.min).cwiseMin(box.max - x).minCoeff() < 2 * r);
    const Vec3d e = box.max - box.min, inner = e - Vec3d::Constant(4 * r);
    const double shellVolume = e.prod() - inner.prod();
    const double interiorDensity = double(whole.size() - nearFace) / inner.prod();
    EXPECT_NEAR(double(nearFace) / shellVolume / interiorDensity, 1.0, 0.1);
}

TEST(Emission, HappensOnTheRightFrames) {
    const std::string dir = tempDir("emit");
    SceneDesc scene = loadScene(writeScene(dir, "emit.json", kValid));
    auto sim = buildSimulation(scene);
    auto countOfSet = [&](int s) { return particlesOf(sim->species()[s]).size(); };
    sim->emitDue();
    const std::size_t a = countOfSet(0);
    EXPECT_GT(a, 0u);
    EXPECT_EQ(countOfSet(1), 0u);
    std::vector<std::size_t> b;
    for (int f = 1; f <= 5; ++f) {
        sim->advanceFrame();
        b.push_back(countOfSet(1));
        EXPECT_EQ(countOfSet(0), a);  // duration 1: emitted once
    }
    // start 1, duration 4, pause 1: emissions at frames 1 and 3 only.
    EXPECT_GT(b[0], 0u);
    EXPECT_EQ(b[1], b[0]);
    EXPECT_EQ(b[2], 2 * b[0]);
    EXPECT_EQ(b[3], 2 * b[0]);
    EXPECT_EQ(b[4], 2 * b[0]);
    EXPECT_NEAR(sim->time(), 5.0 / 24.0, 1e-12);  // substeps end exactly on frame times
}

TEST(Output, PointsCarryHoudinisAttributesAndGroups) {
    // Water and a jelly of two names (one with characters no group name may hold): pscale, Cd (the set's colour
    // or the material's), J, Jp, stress_norm and F as asked, a group per material and per set, and the PLY with
    // double positions and the same attributes, read back by the engine's own point-cloud reader.
    const std::string dir = tempDir("houdini");
    SceneDesc scene = loadScene(writeScene(dir, "h.json", R"({
      "simulation": { "frames": 2, "dx": 0.05, "substeps": 2 },
      "output": { "attributes": ["J", "Jp", "stress_norm", "F"], "ply": true, "split_files": true },
      "sets": [ { "name": "pool", "material": "water", "shape": { "type": "box", "min": [0,0,0], "max": [0.2,0.2,0.2] } },
                { "name": "red block/1", "material": "jelly", "color": [1, 0, 0.5],
                  "shape": { "type": "box", "min": [0.5,0,0], "max": [0.7,0.2,0.2] } } ],
      "colliders": [ { "type": "plane" } ] })"));
    auto sim = buildSimulation(scene);
    sim->emitDue();
    sim->advanceFrame();
    FrameWriter writer(scene, speciesLayout(scene), dir + "/frames");
    writer.writeFrame(1, *sim, sim->measure());
    const PointsReadBack back = readVdbPoints(writer.framePath(1, "points_"));
    const std::size_t n = back.x.size();
    ASSERT_GT(n, 100u);
    for (auto* a : {&back.pscale, &back.J, &back.Jp, &back.stressNorm}) ASSERT_EQ(a->size(), n);
    ASSERT_EQ(back.Cd.size(), n);
    ASSERT_EQ(back.F.size(), n);
    // The truth, particle by particle from the state, by id.
    std::map<int32_t, std::tuple<float, Mat3f, float>> truth;  // pscale, F, |sigma|
    for (const AnySpecies& s : sim->species())
        std::visit(
            [&](const auto& sp) {
                using M = typename std::decay_t<decltype(sp)>::Material;
                for (std::size_t i = 0; i < sp.p.size(); ++i) {
                    const float J = M::volumeRatio(sp.state, i);
                    Mat3f F = std::cbrt(J) * Mat3f::Identity();
                    if constexpr (requires { M::deformationGradient(sp.state, i); }) F = M::deformationGradient(sp.state, i);
                    truth[sp.p.id[i]] = {0.5f * std::cbrt(sp.p.volume0[i] * J), F,
                                         M::kirchhoff(sp.params, sp.state, i).norm() / J};
                }
            },
            s);
    const Vec3f water(0.15f, 0.4f, 0.9f), mine(1.0f, 0.0f, 0.5f);
    EXPECT_EQ(back.groupNames.at("material_water"), "water");
    EXPECT_EQ(back.groupNames.at("material_jelly"), "jelly");
    EXPECT_EQ(back.groupNames.at("set_pool"), "pool");
    EXPECT_EQ(back.groupNames.at("set_red_block_1"), "red block/1");
    EXPECT_EQ(back.groupNames.size(), 4u);  // the materials no set uses have no group
    double maxStress = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const auto& [pscale, F, stress] = truth.at(back.id[i]);
        const bool jelly = back.set[i] == 1;
        EXPECT_FLOAT_EQ(back.pscale[i], pscale);
        EXPECT_EQ(back.Cd[i], jelly ? mine : water);
        EXPECT_TRUE(back.F[i].isApprox(F, 1e-6f));
        EXPECT_NEAR(back.J[i], F.determinant(), 1e-5f);
        EXPECT_EQ(back.Jp[i], 1.0f);  // neither model is plastic
        EXPECT_NEAR(back.stressNorm[i], stress, 1e-3f * std::max(1.0f, stress));
        maxStress = std::max(maxStress, double(stress));
        EXPECT_EQ(back.groups.at("material_jelly")[i], jelly);
        EXPECT_EQ(back.groups.at("set_red_block_1")[i], jelly);
        EXPECT_EQ(back.groups.at("material_water")[i], !jelly);
        EXPECT_EQ(back.groups.at("set_pool")[i], !jelly);
    }
    EXPECT_GT(maxStress, 1.0);  // a frame under gravity is stressed
    // pscale is half the side of the particle's cube: 8 per cell at rest gives dx / 4.
    EXPECT_NEAR(back.pscale[0], 0.05 / 4.0, 0.05 * 0.05);
    // The PLY: the same particles with positions in double, as the state holds them.
    const PointCloudData ply = readPlyPoints(writer.framePath(1, "", ".ply"));
    // Its header names the material indices, as the VDB's material_names does.
    std::string names;
    for (const std::string& m : materialSceneNames()) names += " " + m;
    std::ifstream plyFile(writer.framePath(1, "", ".ply"), std::ios::binary);
    const std::string plyBytes((std::istreambuf_iterator<char>(plyFile)), std::istreambuf_iterator<char>());
    EXPECT_NE(plyBytes.find("\ncomment material_names" + names + "\n"), std::string::npos);
    std::map<int32_t, Vec3d> x;
    for (const AnySpecies& s : sim->species())
        for (std::size_t i = 0; i < particlesOf(s).size(); ++i) x[particlesOf(s).id[i]] = particlesOf(s).x[i];
    ASSERT_EQ(ply.x.size(), x.size());
    std::size_t k = 0;
    for (const auto& s : sim->species())
        for (std::size_t i = 0; i < particlesOf(s).size(); ++i, ++k) {
            EXPECT_EQ(ply.x[k], particlesOf(s).x[i]);  // bit for bit
            EXPECT_EQ(ply.v[k], particlesOf(s).v[i]);
            EXPECT_FLOAT_EQ(ply.pscale[k], std::get<0>(truth.at(particlesOf(s).id[i])));
        }
    // A name the list does not hold is a named error.
    std::string what;
    try {
        loadScene(writeScene(dir, "bad.json", R"({"output": {"attributes": ["J", "stress"]}})"));
    } catch (const SceneError& e) {
        what = e.what();
    }
    EXPECT_NE(what.find("bad.json: /output/attributes/1: unknown point attribute \"stress\"; known: J, Jp, stress_norm, F"),
              std::string::npos)
        << what;
    // A name given twice is refused where the second one stands, not silently dropped.
    what.clear();
    try {
        loadScene(writeScene(dir, "twice.json", R"({"output": {"attributes": ["J", "F", "J"]}})"));
    } catch (const SceneError& e) {
        what = e.what();
    }
    EXPECT_NE(what.find("twice.json: /output/attributes/2: point attribute \"J\" is already in the list"), std::string::npos)
        << what;
}

TEST(SceneErrors, MuScaleOnAMaterialWithoutAShearModulusIsRefused) {
    const std::string dir = tempDir("mu_scale");
    const auto scene = [](const std::string& material) {
        return R"({"sets": [{"material": ")" + material +
               R"(", "mu_scale": 2, "shape": {"type": "box", "min": [0, 0, 0], "max": [0.1, 0.1, 0.1]}}]})";
    };
    std::string what;
    try {
        loadScene(writeScene(dir, "water.json", scene("water")));
    } catch (const SceneError& e) {
        what = e.what();
    }
    EXPECT_NE(what.find("water.json: /sets/0/mu_scale: water has no shear modulus to scale"), std::string::npos) << what;
    // Every other material has one: the key is read, not refused.
    for (const char* m : {"jelly", "rubber", "snow", "sand", "metal", "viscous"})
        EXPECT_NO_THROW(loadScene(writeScene(dir, std::string(m) + ".json", scene(m)))) << m;
}

TEST(Output, FrameReadsBackWithSameParticles) {
    const std::string dir = tempDir("out");
    SceneDesc scene = loadScene(writeScene(dir, "rb.json", kValid));
    scene.output.splitFiles = true;
    auto sim = buildSimulation(scene);
    sim->emitDue();
    sim->advanceFrame();
    sim->advanceFrame();
    FrameWriter writer(scene, speciesLayout(scene), dir + "/frames");
    writer.writeFrame(2, *sim, sim->measure());
    const PointsReadBack back = readVdbPoints(writer.framePath(2, "points_"));
    std::map<int32_t, std::pair<Vec3d, Vec3f>> truth;
    std::size_t n = 0;
    for (const AnySpecies& s : sim->species()) {
        const ParticleArrays& P = particlesOf(s);
        for (std::size_t i = 0; i < P.size(); ++i) truth[P.id[i]] = {P.x[i], P.v[i]};
        n += P.size();
    }
    ASSERT_EQ(back.x.size(), n);
    const double codec = scene.settings.dx / 65536.0 * 2;  // 16-bit fixed point within a voxel
    for (std::size_t i = 0; i < back.x.size(); ++i) {
        ASSERT_TRUE(truth.count(back.id[i]));
        EXPECT_LT((back.x[i] - truth[back.id[i]].first).norm(), codec + 1e-6);
        EXPECT_TRUE(back.v[i].isApprox(truth[back.id[i]].second, 1e-6f));
    }
    const auto names = vdbGridNames(writer.framePath(2));
    EXPECT_NE(std::find(names.begin(), names.end(), "surface"), names.end());
    EXPECT_TRUE(fs::exists(dir + "/frames/stats.csv"));
    // The resolved scene says where it came from, so tools find the assets its paths are relative to.
    std::ifstream resolved(dir + "/frames/scene.json");
    const std::string text((std::istreambuf_iterator<char>(resolved)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("\"scene_file\": \"" + fs::absolute(scene.file).lexically_normal().string() + "\""), std::string::npos)
        << text;
}

TEST(Output, InterruptedWriteLeavesNoPartialFile) {
    const std::string dir = tempDir("atomic");
    const std::string path = dir + "/frame.vdb";
    writeTextAtomically(path, "old complete frame");
    EXPECT_THROW(writeAtomically(path,
                                 [](std::ostream& out) {
                                     out << "half a fr";
                                     throw std::runtime_error("disk full");
                                 }),
                 std::runtime_error);
    std::ifstream in(path);
    std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(content, "old complete frame");
    int files = 0;
    for (const auto& e : fs::directory_iterator(dir)) (void)e, ++files;
    EXPECT_EQ(files, 1);  // no temporary left behind
}

TEST(Output, RerunRemovesOldFramesOfTheSceneOnly) {
    const std::string dir = tempDir("rerun");
    const std::string scene = writeScene(dir, "rr.json", kValid);
    fs::create_directories(dir + "/f");
    for (const char* name :
         {"rr_0007.vdb", "rr_points_0007.vdb", "rr_checkpoint_0007.mpmc", "rr_checkpoint_0007_rank001.mpmc", "other_0007.vdb",
          "rr_break_0007.vdb", "rr_break_checkpoint_0007_rank000.mpmc", "rr_0007.vdb.tmp12345"})
        std::ofstream(dir + "/f/" + name) << "stale";
    RunOptions options;
    options.outDir = dir + "/f";
    int notes = 0;
    RunEvents events;
    events.note = [&](const std::string& s) { notes += s.rfind("removed ", 0) == 0; };  // set-up says more besides
    SceneRun run(scene, options, events);
    EXPECT_FALSE(fs::exists(dir + "/f/rr_0007.vdb"));
    EXPECT_FALSE(fs::exists(dir + "/f/rr_points_0007.vdb"));
    EXPECT_FALSE(fs::exists(dir + "/f/rr_checkpoint_0007.mpmc"));
    EXPECT_FALSE(fs::exists(dir + "/f/rr_checkpoint_0007_rank001.mpmc"));  // a part of a per-rank set
    EXPECT_FALSE(fs::exists(dir + "/f/rr_0007.vdb.tmp12345"));             // a killed run's temporary file
    EXPECT_TRUE(fs::exists(dir + "/f/other_0007.vdb"));
    EXPECT_TRUE(fs::exists(dir + "/f/rr_break_0007.vdb"));  // a scene whose name starts with this one's
    EXPECT_TRUE(fs::exists(dir + "/f/rr_break_checkpoint_0007_rank000.mpmc"));
    EXPECT_FALSE(fs::exists(dir + "/f/rr_0000.vdb"));  // the initial state is not a frame unless asked for
    EXPECT_EQ(notes, 2);                               // both removals are reported
}
