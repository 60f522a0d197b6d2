// mpm: the command-line front end. `mpm run SCENE` simulates and writes frames; `mpm validate SCENE`
// checks a scene. Exit codes: 0 success, 2 bad input, 1 failed run.
#include <tbb/global_control.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <thread>

#include "io/Output.h"
#include "io/Scene.h"

using namespace mpm;

namespace {

constexpr int kExitOk = 0, kExitRunFailed = 1, kExitBadInput = 2;

struct FrameRange {
    int first = 0, last = -1;
};

FrameRange parseFrames(const std::string& text, int sceneFrames) {
    FrameRange r{0, sceneFrames};
    if (text.empty()) return r;
    const auto colon = text.find(':');
    try {
        if (colon == std::string::npos) throw std::invalid_argument(text);
        r.first = colon == 0 ? 0 : std::stoi(text.substr(0, colon));
        r.last = colon + 1 == text.size() ? sceneFrames : std::stoi(text.substr(colon + 1));
    } catch (const std::exception&) {
        throw SceneError("--frames: expected A:B with whole numbers (for example 0:48), got \"" + text + "\"");
    }
    if (r.first < 0 || r.last < r.first) throw SceneError("--frames: need 0 <= A <= B, got \"" + text + "\"");
    return r;
}

std::string clock(double seconds) {
    char buf[32];
    const long s = long(seconds + 0.5);
    std::snprintf(buf, sizeof(buf), "%02ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    return buf;
}

int run(const std::string& scenePath, const std::string& outDir, int threads, const std::string& frames, bool quiet) {
    SceneDesc scene = loadScene(scenePath);
    const FrameRange range = parseFrames(frames, scene.frames);
    const int nThreads = threads > 0 ? threads : scene.threads > 0 ? scene.threads : int(std::thread::hardware_concurrency());
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(nThreads));
    std::unique_ptr<Simulation> sim = buildSimulation(scene);
    FrameWriter writer(scene, speciesLayout(scene), outDir.empty() ? scene.output.directory : outDir);
    const bool tty = ::isatty(STDERR_FILENO) && !quiet;
    if (!quiet) {
        std::fprintf(stderr, "mpm: %s, %d frames at %g fps, dx %g m, %d threads -> %s\n", scenePath.c_str(), range.last,
                     scene.settings.fps, scene.settings.dx, nThreads, writer.directory().c_str());
        if (writer.removedFiles())
            std::fprintf(stderr, "mpm: removed %d frame files of an earlier run of this scene\n", writer.removedFiles());
    }
    const auto start = std::chrono::steady_clock::now();
    sim->emitDue();
    FrameStats st = sim->measure();
    if (range.first == 0)
        writer.writeFrame(0, *sim, st);
    else
        writer.recordStats(st);
    long long particleSteps = 0;
    for (int f = 1; f <= range.last; ++f) {
        const std::size_t n = sim->particleCount();
        st = sim->advanceFrame();
        particleSteps += (long long)n * st.substeps;
        if (f >= range.first)
            writer.writeFrame(f, *sim, st);
        else
            writer.recordStats(st);
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const double eta = elapsed / f * (range.last - f);
        if (quiet) continue;
        const double pss = particleSteps / std::max(elapsed, 1e-9);
        if (tty)
            std::fprintf(stderr, "\rframe %d/%d | %d substeps | %zu particles | %.3g particle-substeps/s | ETA %s   ", f,
                         range.last, st.substeps, st.particles, pss, clock(eta).c_str());
        else
            std::fprintf(stderr, "frame %d/%d substeps %d particles %zu max_speed %.3g sim %.2fs write %.2fs pss %.3g eta %s\n",
                         f, range.last, st.substeps, st.particles, st.maxSpeed, st.wallSeconds, writer.lastWriteSeconds(), pss,
                         clock(eta).c_str());
        if (st.retries)
            std::fprintf(stderr, "%smpm: frame %d was restarted %d times with half the time step (stability retries)\n",
                         tty ? "\n" : "", f, st.retries);
    }
    if (tty) std::fprintf(stderr, "\n");
    if (!quiet)
        std::fprintf(stderr, "mpm: done in %s, frames in %s\n",
                     clock(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()).c_str(),
                     writer.directory().c_str());
    return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Sparse-grid Material Point Method simulator (OpenVDB grid, APIC, oneTBB)"};
    app.require_subcommand(1);
    std::string scenePath, outDir, frames;
    int threads = 0;
    bool quiet = false, explain = false;

    CLI::App* runCmd = app.add_subcommand("run", "simulate a scene and write its frames");
    runCmd->add_option("scene", scenePath, "scene file (JSON)")->required();
    runCmd->add_option("-o,--output", outDir, "output directory (default: the scene's output.directory)");
    runCmd->add_option("--threads", threads, "worker threads (default: the scene's, else all cores)")
        ->check(CLI::NonNegativeNumber);
    runCmd->add_option("--frames", frames, "frames to write, A:B (simulation always starts at frame 0)");
    runCmd->add_flag("--quiet", quiet, "print nothing but errors");

    CLI::App* validateCmd = app.add_subcommand("validate", "check a scene file and print it with every default filled in");
    validateCmd->add_option("scene", scenePath, "scene file (JSON)");
    validateCmd->add_flag("--explain", explain, "list every scene field, its default and allowed values");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int rc = app.exit(e);
        return rc == 0 ? kExitOk : kExitBadInput;
    }
    try {
        if (*validateCmd) {
            if (explain) {
                std::cout << explainSceneFormat();
                return kExitOk;
            }
            if (scenePath.empty()) throw SceneError("validate: give a scene file, or --explain");
            const SceneDesc scene = loadScene(scenePath);
            std::cout << scene.resolvedJson << "\n";
            std::fprintf(stderr, "%s: valid (%zu particle sets)\n", scenePath.c_str(), scene.sets.size());
            return kExitOk;
        }
        return run(scenePath, outDir, threads, frames, quiet);
    } catch (const SceneError& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return kExitBadInput;
    } catch (const SimulationError& e) {
        std::fprintf(stderr, "\nerror: simulation stopped: %s (nothing of that frame was written)\n", e.what());
        return kExitRunFailed;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "\nerror: %s\n", e.what());
        return kExitRunFailed;
    }
}
