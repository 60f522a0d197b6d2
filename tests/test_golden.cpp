// Golden results: a handful of scenes run for a fixed number of substeps, and the hash of every particle
// array (and of the clocks) compared with the value recorded when the scene was added. A refactoring must
// leave these bits alone; a change that alters results on purpose updates the hashes and says why in its
// commit. Every scene is also run with one thread, which must give the same bits.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <type_traits>

#include "io/Scene.h"

using namespace mpm;

namespace {

/// FNV-1a over raw bytes: any changed bit of any particle changes the hash.
struct Hasher {
    uint64_t h = 1469598103934665603ull;
    void bytes(const void* p, std::size_t n) {
        const auto* b = static_cast<const unsigned char*>(p);
        for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
    }
    template <class T>
    void value(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes(&v, sizeof(T));
    }
    template <class T>
    void array(const std::vector<T>& a) {
        value(a.size());
        if (!a.empty()) bytes(a.data(), a.size() * sizeof(T));
    }
};

uint64_t hashState(Simulation& sim) {
    Hasher h;
    h.value(sim.time());
    h.value(sim.frame());
    h.value(sim.substepCount());
    for (AnySpecies& s : sim.species()) std::visit([&](auto& sp) { sp.forEachArray([&](const auto& arr) { h.array(arr); }); }, s);
    return h.h;
}

struct GoldenScene {
    const char* name;
    const char* text;
    int frames;     ///< whole frames run with advanceFrame (emission, energy checks and retries included)
    int substeps;   ///< then this many substeps of the target length
    uint64_t hash;  ///< recorded when the scene was added, or by the last change that altered results on purpose
};

uint64_t runScene(const GoldenScene& g) {
    SceneDesc scene = parseScene(g.text, std::string("golden_") + g.name + ".json");
    auto sim = buildSimulation(scene);
    sim->emitDue();
    for (int f = 0; f < g.frames; ++f) sim->advanceFrame();
    for (int n = 0; n < g.substeps; ++n) sim->substep(sim->settings().targetDt());
    return hashState(*sim);
}

const GoldenScene kScenes[] = {
    {"water_dam", R"({
      "simulation": { "dx": 0.05, "substeps": 5 },
      "sets": [ { "material": "water", "shape": { "type": "box", "min": [0, 0, 0], "max": [0.3, 0.5, 0.3] }, "seed": 3 } ],
      "colliders": [ { "type": "plane", "boundary": "slip", "friction": 0.3 },
                     { "type": "plane", "point": [0, 0, 0], "normal": [1, 0, 0], "boundary": "separate" } ] })",
     1, 20, 0x10043800a5e4d396ull},
    {"jelly_cubic_sphere", R"({
      "simulation": { "dx": 0.05, "substeps": 5, "interpolation": "cubic" },
      "sets": [ { "material": "jelly", "shape": { "type": "box", "min": [-0.15, 0.3, -0.15], "max": [0.15, 0.6, 0.15] },
                  "velocity": [0.5, -2, 0], "sampling": "grid" } ],
      "colliders": [ { "type": "sphere", "center": [0, 0, 0], "radius": 0.25, "boundary": "sticky" } ] })",
     1, 20, 0x9c2b3de21b1e6131ull},
    {"rubber_mls", R"({
      "simulation": { "dx": 0.05, "substeps": 5, "force": "mls", "wall_contact": "surface" },
      "sets": [ { "material": "rubber", "shape": { "type": "sphere", "center": [0, 0.2, 0], "radius": 0.15 },
                  "velocity": [0, -3, 0], "mu_scale": 2 } ],
      "colliders": [ { "type": "plane", "boundary": "separate", "friction": 0.5 } ] })",
     1, 20, 0x0fdc0a2e5e3c3538ull},
    {"snow_wall", R"({
      "simulation": { "dx": 0.04, "substeps": 5 },
      "sets": [ { "material": "snow", "shape": { "type": "sphere", "center": [0.3, 0.3, 0], "radius": 0.12 },
                  "velocity": [6, 2, 0] } ],
      "colliders": [ { "type": "plane", "point": [0.5, 0, 0], "normal": [-1, 0, 0], "boundary": "sticky" },
                     { "type": "plane", "boundary": "slip", "friction": 0.2 } ] })",
     1, 20, 0xdcf131a60b0ea50eull},
    {"sand_pile_pic", R"({
      "simulation": { "dx": 0.04, "substeps": 5, "transfer": "pic" },
      "sets": [ { "material": "sand", "shape": { "type": "box", "min": [0, 0, 0], "max": [0.2, 0.4, 0.2] },
                  "material_params": { "h0": 30 } } ],
      "colliders": [ { "type": "plane", "boundary": "sticky" } ] })",
     1, 20, 0x77f5a0ad533bca52ull},
    {"emitter_two_species", R"({
      "simulation": { "dx": 0.05, "substeps": 4, "wall_contact": "surface" },
      "sets": [ { "name": "stream", "material": "water", "shape": { "type": "sphere", "center": [0, 0.5, 0], "radius": 0.08 },
                  "velocity": [1, -1, 0], "duration": 4, "pause": 1, "count": 300 },
                { "name": "block", "material": "jelly", "shape": { "type": "box", "min": [-0.2, 0, -0.2], "max": [0.2, 0.15, 0.2] },
                  "start_frame": 1 } ],
      "colliders": [ { "type": "plane", "boundary": "separate", "friction": 0.4 } ] })",
     4, 0, 0xbf1547d99bb6a49dull},
    {"retried_frame", R"({
      "simulation": { "dx": 0.05, "substeps": 1, "cfl": 5, "retries": 5 },
      "sets": [ { "material": "water", "material_params": { "bulk_modulus": 1e7 },
                  "shape": { "type": "box", "min": [0, 0, 0], "max": [0.3, 0.3, 0.3] } } ],
      "colliders": [ { "type": "plane", "boundary": "slip" } ] })",
     1, 0, 0x0d58dabd5ffddfbfull},
};

/// gtest prints the scene's name, not its bytes.
void PrintTo(const GoldenScene& g, std::ostream* os) { *os << g.name; }

}  // namespace

class Golden : public ::testing::TestWithParam<GoldenScene> {};

TEST_P(Golden, ParticleArraysKeepTheirBits) {
    const GoldenScene& g = GetParam();
    const uint64_t all = runScene(g);
    uint64_t one = 0;
    {
        tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
        one = runScene(g);
    }
    EXPECT_EQ(all, one) << "the thread count changed the result";
    std::printf("golden %s: 0x%016llxull\n", g.name, static_cast<unsigned long long>(all));
#ifdef MPM_GOLDEN_BUILD
    EXPECT_EQ(all, g.hash) << "particle arrays of " << g.name << " changed";
#else
    std::printf("golden %s: hashes are recorded for GCC Release x86-64-v3 builds; this build checks thread counts only\n",
                g.name);
#endif
}

INSTANTIATE_TEST_SUITE_P(Scenes, Golden, ::testing::ValuesIn(kScenes),
                         [](const ::testing::TestParamInfo<GoldenScene>& i) { return std::string(i.param.name); });
