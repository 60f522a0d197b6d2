#include "io/RunEstimate.h"

#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <sstream>

#include "io/Output.h"
#include "io/SceneBuilder.h"
#include "io/SceneReader.h"

namespace mpm {

namespace {

namespace fs = std::filesystem;

/// seconds = fixed + perParticle * particles, fitted through two measurements.
struct Cost {
    double fixed = 0.0, perParticle = 0.0;
    static Cost through(double n1, double t1, double n2, double t2) {
        Cost c;
        c.perParticle = std::max(0.0, (t2 - t1) / (n2 - n1));
        c.fixed = std::max(0.0, t1 - c.perParticle * n1);
        return c;
    }
};

double secondsSince(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

struct Measured {
    double particles = 0.0, substepSeconds = 0.0, writeSeconds = 0.0;
};

/// A block of water `side` m wide resting on a floor, at dx 0.02 and the scene's particles per cell of its
/// first set: one frame written with the scene's output settings after a warm-up, then simulated for `seconds`.
Measured measureBlock(const SceneDesc& scene, double side, double seconds, const std::string& dir) {
    constexpr int kWarmUp = 2;
    std::ostringstream text;
    text << R"({"simulation": {"dx": 0.02}, "sets": [{"material": "water", "sampling": "lattice", "particles_per_cell": )"
         << scene.sets.front().particlesPerCell << R"(, "shape": {"type": "box", "min": [0, 0.02, 0], "max": [)" << side << ", "
         << 0.02 + side << ", " << side << R"(]}}], "colliders": [{"type": "plane"}]})";
    SceneDesc block = parseScene(text.str(), dir + "/block.json");
    block.output = scene.output;
    block.output.initialFrame = false;
    auto sim = buildSimulation(block);
    sim->emitDue();
    const double dt = block.settings.targetDt();
    for (int i = 0; i < kWarmUp; ++i) sim->substep(dt);
    Measured m;
    m.particles = double(particlesOf(sim->species().front()).size());
    // The frame is written before the timed substeps, so that both blocks are written in the same state: the small
    // block runs more substeps in the time and had spread further, with more surface to write (its frame took twice
    // the large one's, and the fit read that as a fixed cost: 11.7 s estimated for 3.6 s written).
    FrameWriter writer(block, speciesLayout(block), dir);
    const FrameStats stats = sim->measure();
    const auto written = std::chrono::steady_clock::now();
    writer.writeFrame(1, *sim, stats);
    m.writeSeconds = secondsSince(written);
    const auto start = std::chrono::steady_clock::now();
    long long steps = 0;
    for (double elapsed = 0.0; elapsed < seconds; elapsed = secondsSince(start)) sim->substep(dt), ++steps;
    m.substepSeconds = secondsSince(start) / double(steps);
    return m;
}

std::string fewDigits(double x) {
    std::ostringstream s;
    s.precision(3);
    s << x;
    return s.str();
}

}  // namespace

void estimateRunTime(const SceneDesc& scene, SceneBudget& budget) {
    if (scene.sets.empty() || budget.substepsPerFrame <= 0.0) return;
    // Two blocks, 512 and 4,096 cells: the fixed cost of a step shows in the small one, the cost per particle in
    // the difference. A tenth of a second of substeps each keeps validate quick.
    constexpr double kSmall = 0.16, kLarge = 0.32, kSeconds = 0.1;
    fs::path dir;
    Measured small, large;
    std::error_code ec;
    try {
        dir = fs::temp_directory_path() / ("mpm_estimate_" + std::to_string(::getpid()));
        fs::create_directories(dir);
        small = measureBlock(scene, kSmall, kSeconds, dir.string());
        large = measureBlock(scene, kLarge, kSeconds, dir.string());
    } catch (const std::exception&) {
        // The estimate is an aid: a machine where the blocks cannot be written (a full or read-only temporary
        // folder) validates the scene without it.
        if (!dir.empty()) fs::remove_all(dir, ec);
        return;
    }
    fs::remove_all(dir, ec);
    const Cost step = Cost::through(small.particles, small.substepSeconds, large.particles, large.substepSeconds);
    const Cost write = Cost::through(small.particles, small.writeSeconds, large.particles, large.writeSeconds);
    // The run's frames, substeps, and particles summed over frames (its particle-substeps over a frame's substeps).
    const double frames = double(scene.frames), substeps = frames * budget.substepsPerFrame;
    const double particleFrames = budget.particleSubsteps / budget.substepsPerFrame;
    const double simulate = substeps * step.fixed + budget.particleSubsteps * step.perParticle;
    const double writing = frames * write.fixed + particleFrames * write.perParticle;
    budget.runSeconds = simulate + writing;
    // The threads the costs were measured on: the arena's, under the caller's global_control limit (validate's --threads).
    const int threads =
        int(std::min<std::size_t>(std::size_t(tbb::this_task_arena::max_concurrency()),
                                  tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
    // Measured against runs (AMD EPYC, 1 and 2 threads, 2026-12-07): dam_break 1.31-1.35 times the estimate,
    // jelly_bounce 1.36, jelly_on_sphere 1.00, water_on_jelly 2.0, a sand column 2.4, a water ball spreading on a floor
    // into a sheet and spray 4.1. The block rests; a run speeds up (more substeps) and spreads (more leaves).
    budget.runBasis = fewDigits(substeps) + " substeps, " + fewDigits(budget.particleSubsteps) + " particle-substeps and " +
                      fewDigits(frames) + " frames written, from costs measured now on a block of water on " +
                      std::to_string(threads) + " thread" + (threads == 1 ? "" : "s") + ": " + fewDigits(simulate) +
                      " s simulating, " + fewDigits(writing) +
                      " s writing; runs take 1 to 2.5 times this, and 4 times where water thins into spray";
}

}  // namespace mpm
