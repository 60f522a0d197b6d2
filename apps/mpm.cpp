// mpm: the command-line front end. `mpm run SCENE` simulates and writes frames; `mpm validate SCENE`
// checks a scene and prints what it will cost. Exit codes: 0 success, 2 bad input, 1 failed run, 130 and
// 143 stopped by SIGINT and SIGTERM, 138 by SIGUSR1 (after writing a checkpoint to resume from). Under
// mpirun, SIGUSR1 is the one to send: OpenMPI forwards it to every rank, while SIGINT and SIGTERM make it
// kill the ranks after a second.
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <tbb/info.h>

#include <atomic>
#include <charconv>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <new>
#include <sstream>

#include "io/AtomicFile.h"
#include "io/Checkpoint.h"
#include "io/DirectoryLock.h"
#include "io/Output.h"
#include "io/Run.h"
#include "io/RunEstimate.h"
#include "io/SceneBudget.h"
#include "io/SceneBuilder.h"
#include "io/SceneReader.h"

using namespace mpm;

namespace {

constexpr int kExitOk = 0, kExitRunFailed = 1, kExitBadInput = 2;
/// The shell's convention: 128 + the signal's number.
constexpr int kExitSignalBase = 128;

/// The signal that asked the run to stop (0: none). The handler only sets it; a second signal ends the process
/// at once, with the default action, removing the directory's lock file first (a frame being written is a
/// temporary file, which the next run removes).
std::atomic<int> gStopSignal{0};
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs a lock-free flag");

extern "C" void onStopSignal(int sig) {
    if (gStopSignal.load() != 0) {
        DirectoryLock::removeHeldLockFile();
        std::signal(sig, SIG_DFL);
        std::raise(sig);
        return;
    }
    gStopSignal.store(sig);
}

/// The worker threads a run takes: those asked for (`--threads`, else the scene's `simulation.threads`; 0 or none:
/// all), at most the ones this process can run at once (TBB's default concurrency: the cores, or fewer where an
/// affinity mask or a control group limits them). More would only be queued, so asking for more is worth a word.
int threadsTaken(int option, int sceneThreads, std::vector<std::string>& warnings) {
    const int available = std::max(1, tbb::info::default_concurrency());
    const int asked = option > 0 ? option : sceneThreads;
    if (asked <= 0) return available;
    if (asked > available)
        warnings.push_back(std::string(option > 0 ? "--threads " : "simulation.threads ") + std::to_string(asked) +
                           " is more than the " + std::to_string(available) + " this process can run at once; the run takes " +
                           std::to_string(available));
    return std::min(asked, available);
}

void installStopHandlers() {
    struct sigaction sa {};
    sa.sa_handler = onStopSignal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGUSR1, &sa, nullptr);
}

const char* signalName(int sig) { return sig == SIGTERM ? "SIGTERM" : sig == SIGUSR1 ? "SIGUSR1" : "SIGINT"; }

RunOptions parseFrames(const std::string& text, RunOptions o) {
    if (text.empty()) return o;
    const auto colon = text.find(':');
    try {
        if (colon == std::string::npos) throw std::invalid_argument(text);
        o.firstFrame = colon == 0 ? 0 : std::stoi(text.substr(0, colon));
        o.lastFrame = colon + 1 == text.size() ? -1 : std::stoi(text.substr(colon + 1));
    } catch (const std::exception&) {
        throw SceneError(
            "--frames: expected A:B with whole numbers, frames counted from 1 as files are (for example 1:48), got \"" + text +
            "\"");
    }
    if (o.firstFrame < 0 || (o.lastFrame >= 0 && o.lastFrame < o.firstFrame))
        throw SceneError("--frames: need 0 <= A <= B, got \"" + text + "\"");
    o.framesGiven = true;
    return o;
}

std::string clock(double seconds) {
    char buf[32];
    const long s = long(seconds + 0.5);
    std::snprintf(buf, sizeof(buf), "%02ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    return buf;
}

struct Progress {
    bool quiet, tty;
    std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
    int firstFrame = 0;

    void frame(int f, int last, const FrameStats& st, double writeSeconds) {
        if (quiet) return;
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const double eta = elapsed / std::max(1, f - firstFrame) * (last - f);
        // This frame's rate of simulation, writing left out: a run's average hid a frame that slowed as water thinned to
        // spray (1.92e6 reported where the frame ran at 8e5, a new user's trial).
        const double pss = double(st.particles) * st.substeps / std::max(st.wallSeconds, 1e-9);
        if (tty)
            std::fprintf(stderr, "\rframe %d/%d | %d substeps | %zu particles | %.3g particle-substeps/s | ETA %s   ", f, last,
                         st.substeps, st.particles, pss, clock(eta).c_str());
        else
            std::fprintf(stderr, "frame %d/%d substeps %d particles %zu max_speed %.3g sim %.2fs write %.2fs pss %.3g eta %s\n",
                         f, last, st.substeps, st.particles, st.maxSpeed, st.wallSeconds, writeSeconds, pss, clock(eta).c_str());
        if (st.retries)
            std::fprintf(stderr, "%smpm: frame %d was restarted %d times with half the time step (stability retries)\n",
                         tty ? "\n" : "", f, st.retries);
    }
};

int run(const std::string& scenePath, const RunOptions& options, int threads, bool quiet) {
    // On several ranks rank 0 speaks for all of them.
    const Comm& comm = Comm::world();
    const bool speaks = comm.rank() == 0;
    quiet = quiet || !speaks;
    Progress progress{quiet, ::isatty(STDERR_FILENO) && !quiet};
    RunEvents events;
    events.note = [&](const std::string& s) {
        if (!quiet) std::fprintf(stderr, "mpm: %s\n", s.c_str());
    };
    events.warning = [&](const std::string& s) {
        if (speaks) std::fprintf(stderr, "warning: %s\n", s.c_str());
    };
    events.frameDone = [&](int f, int last, const FrameStats& st, double w) { progress.frame(f, last, st, w); };
    // The scene's thread count is known only once it is read; the limit must be in place before any work.
    const SceneDesc peek = loadScene(scenePath);
    std::vector<std::string> threadWarnings;
    const int nThreads = threadsTaken(threads, peek.threads, threadWarnings);
    for (const std::string& w : threadWarnings) events.warning(w);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(nThreads));
    installStopHandlers();
    events.stop = &gStopSignal;
    // Set-up (sampling millions of particles can take a while) says what it does and heeds Ctrl-C at once, after a
    // line saying what it runs on, so that a wrong thread count shows before the wait.
    if (!quiet)
        std::fprintf(stderr, "mpm: setting up %s on %d rank%s x %d thread%s\n", scenePath.c_str(), comm.size(),
                     comm.size() == 1 ? "" : "s", nThreads, nThreads == 1 ? "" : "s");
    const auto setupStart = std::chrono::steady_clock::now();
    std::unique_ptr<SceneRun> made;
    try {
        made = std::make_unique<SceneRun>(scenePath, options, events);
    } catch (const SetupInterrupted& e) {
        const int sig = gStopSignal.load();
        if (speaks)
            std::fprintf(stderr,
                         "mpm: stopped by %s during the set-up (%s); nothing was simulated, written or removed: run the "
                         "scene again to start it\n",
                         signalName(sig), e.phase.c_str());
        return kExitSignalBase + (sig ? sig : SIGINT);
    }
    SceneRun& job = *made;
    const double setupSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - setupStart).count();
    constexpr double kSlowSetup = 1.0;  // [s] a set-up worth a line of its own
    if (!quiet && setupSeconds > kSlowSetup) std::fprintf(stderr, "mpm: set up in %.1f s\n", setupSeconds);
    progress.firstFrame = job.startFrame();
    if (job.startFrame() >= job.lastFrame()) {
        // A resumed run that had finished: its checkpoint is of the last frame.
        if (!quiet)
            std::fprintf(stderr, "mpm: all %d frames of %s are done in %s; nothing to run\n", job.lastFrame(), scenePath.c_str(),
                         job.directory().c_str());
        return kExitOk;
    }
    // The frames written; with --frames A:B the run may first simulate from an earlier frame without writing it.
    const int firstWritten = std::max(job.startFrame() + 1, options.firstFrame);
    const std::string from = firstWritten > job.startFrame() + 1
                                 ? " (simulated from frame " + std::to_string(job.startFrame() + 1) + " on, frames before " +
                                       std::to_string(firstWritten) + " not written)"
                                 : std::string();
    if (!quiet)
        std::fprintf(stderr, "mpm: %s, frames %d to %d%s at %g fps, dx %g m, %d rank%s x %d thread%s -> %s\n", scenePath.c_str(),
                     firstWritten, job.lastFrame(), from.c_str(), job.scene().settings.fps, job.scene().settings.dx, comm.size(),
                     comm.size() == 1 ? "" : "s", nThreads, nThreads == 1 ? "" : "s", job.directory().c_str());
    try {
        job.run(&gStopSignal);
    } catch (const Interrupted&) {
        const int sig = gStopSignal.load();
        // Frames counted as files are: inside frame F + 1, or after frame F's files when between frames.
        const SimState& at = job.simulation().state();
        const bool inside = at.frameSubsteps > 0;
        if (speaks)
            std::fprintf(
                stderr,
                "%smpm: stopped by %s %s frame %d (t = %g s); the state is in %s\nmpm: resume with: mpm run %s -o %s --resume\n",
                progress.tty ? "\n" : "", signalName(sig), inside ? "inside" : "after", at.frame + (inside ? 1 : 0), at.time,
                job.lastCheckpoint().c_str(), scenePath.c_str(), job.directory().c_str());
        return kExitSignalBase + (sig ? sig : SIGINT);
    }
    if (progress.tty) std::fprintf(stderr, "\n");
    if (!quiet)
        std::fprintf(stderr, "mpm: done in %s, frames in %s\n",
                     clock(std::chrono::duration<double>(std::chrono::steady_clock::now() - progress.start).count()).c_str(),
                     job.directory().c_str());
    return kExitOk;
}

int validate(const std::string& scenePath, bool strict, bool printScene, int threadOption) {
    const SceneDesc scene = loadScene(scenePath);
    // The report goes to standard output, unless the resolved scene takes it; warnings, errors and progress to
    // standard error, so `mpm validate SCENE > report.txt` keeps the report and still shows what is wrong.
    std::FILE* report = printScene ? stderr : stdout;
    // Each set sampled, and each file set's distance field built, once for the estimate and the warnings.
    SetCache sets(scene);
    sets.note = [](const std::string& what) { std::fprintf(stderr, "mpm: %s\n", what.c_str()); };
    SceneBudget budget = estimateBudget(scene, true, 1, &sets);
    // The run time from costs measured here, on the threads the run will take (--threads, the scene's, all cores).
    std::vector<std::string> threadWarnings;
    const int threads = threadsTaken(threadOption, scene.threads, threadWarnings);
    if (budget.problems.empty()) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        estimateRunTime(scene, budget);
    }
    std::fprintf(report, "%s", describeBudget(budget).c_str());
    checkBudget(scene, budget);
    std::vector<std::string> bodies;
    std::vector<std::string> warnings = sceneWarnings(scene, &bodies, &sets);
    warnings.insert(warnings.end(), threadWarnings.begin(), threadWarnings.end());
    for (const std::string& b : bodies) std::fprintf(report, "%s\n", b.c_str());
    // A scene far larger than meant (sizes in other units: a radius of 2 m for 2 cm) shows first as a run of hours.
    constexpr double kLongRun = 3600.0;
    if (budget.runSeconds > kLongRun) {
        std::ostringstream w;
        w.precision(3);
        w << scene.file << ": /sets: the run would take about " << budget.runSeconds / 3600.0 << " hours here ("
          << (long long)budget.peakParticles << " particles, " << budget.substepsPerFrame << " substeps a frame, " << scene.frames
          << " frames); if that is more than meant, check the shapes' sizes and dx are in metres (a radius of 2 is 2 m)";
        warnings.insert(warnings.begin(), w.str());
    }
    std::fflush(report);
    for (const std::string& w : summarisedWarnings(warnings)) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (strict && !warnings.empty()) {
        std::fprintf(stderr, "error: %s: %zu warning%s, and --strict makes them errors\n", scenePath.c_str(), warnings.size(),
                     warnings.size() == 1 ? "" : "s");
        return kExitBadInput;
    }
    // The scene with every default stated (what a run writes as scene.json) when asked for, and only for a scene
    // that passed: a script reading it must not take a rejected scene's.
    if (printScene) std::cout << withSceneFile(resolvedWithDerived(scene, deriveValues(scene)), scene.file) << std::endl;
    std::fprintf(report, "%s: valid (%zu particle set%s)\n", scenePath.c_str(), scene.sets.size(),
                 scene.sets.size() == 1 ? "" : "s");
    return kExitOk;
}

}  // namespace

namespace {
int cli(int argc, char** argv);
}

int main(int argc, char** argv) {
    // Under mpirun every rank runs this program; alone it is one rank.
    Comm::start(&argc, &argv);
    const int rc = cli(argc, argv);
    Comm::finish();
    return rc;
}

namespace {

/// `text` with each run of characters without a space longer than a line or two cut to its ends: a path or name
/// of 100,000 characters is quoted in a message, not echoed whole.
std::string withLongWordsCut(const std::string& text) {
    constexpr std::size_t kLongest = 240, kHead = 120, kTail = 60;
    std::string out;
    std::size_t start = 0;
    while (start < text.size()) {
        std::size_t end = text.find_first_of(" \n", start);
        if (end == std::string::npos) end = text.size();
        const std::size_t n = end - start;
        if (n > kLongest)
            out += text.substr(start, kHead) + "...(" + std::to_string(n) + " characters)..." + text.substr(end - kTail, kTail);
        else
            out += text.substr(start, n);
        if (end < text.size()) out += text[end];
        start = end + 1;
    }
    return out;
}

/// Prints an error once (rank 0) for a failure every rank met; one only this rank met ends all of them.
int fail(int code, const char* format, const char* message, bool everyRank = true) {
    const std::string shown = withLongWordsCut(message);
    const char* what = shown.c_str();
    const Comm& comm = Comm::world();
    if (!everyRank && comm.distributed()) {
        std::fprintf(stderr, "error: rank %d of %d: ", comm.rank(), comm.size());
        std::fprintf(stderr, format, what);
        comm.abort(code);
    }
    if (comm.rank() == 0) std::fprintf(stderr, format, what);
    return code;
}

int cli(int argc, char** argv) {
    CLI::App app{"Sparse-grid Material Point Method simulator (OpenVDB grid, APIC, oneTBB)"};
    app.set_version_flag("--version", std::string("sparse-mpm ") + MPM_VERSION + " (" + MPM_BUILD_OPTIONS + ")");
    app.require_subcommand(1);
    std::string scenePath, outDir, frames;
    int threads = 0;
    bool quiet = false, explain = false, resume = false, force = false;

    CLI::App* runCmd = app.add_subcommand("run", "simulate a scene and write its frames");
    runCmd->add_option("scene", scenePath, "scene file (JSON)")->required();
    runCmd->add_option("-o,--output", outDir, "output directory (default: the scene's output.directory)");
    constexpr int kMostThreads = 4096;  // as simulation.threads allows
    // A whole number in range, checked on the text: CLI11's Range alone calls "abc" a value out of range.
    const CLI::Validator threadCount(
        [](std::string& text) -> std::string {
            int n = 0;
            const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
            if (ec == std::errc() && end == text.data() + text.size() && n >= 0 && n <= kMostThreads) return "";
            return "'" + text + "' is not a thread count; allowed: a whole number 0 .. " + std::to_string(kMostThreads) +
                   " (0: the scene's, else all cores)";
        },
        "0 .. 4096");
    runCmd->add_option("--threads", threads, "worker threads, 0 .. 4096 (default: the scene's, else all cores)")
        ->check(threadCount);
    runCmd->add_option("--frames", frames,
                       "write only frames A:B (nothing else is deleted; starts from a checkpoint before A when there is one)");
    runCmd->add_flag("--resume", resume, "continue from the newest valid checkpoint in the output directory");
    runCmd->add_flag("--force", force, "with --resume: continue even though the scene changed since the checkpoint");
    runCmd->add_flag("--quiet", quiet, "print nothing but errors and warnings");

    CLI::App* validateCmd =
        app.add_subcommand("validate", "check a scene, print it with every default filled in and what it will cost");
    validateCmd->add_option("scene", scenePath, "scene file (JSON)");
    validateCmd->add_flag("--explain", explain, "list every scene field, its default and allowed values");
    bool strict = false, printScene = false;
    validateCmd->add_flag("--strict", strict,
                          "exit 2 on warnings too (a tiny set, a set inside a collider, overlapping sets, thin mesh walls, a set "
                          "after the last frame)");
    validateCmd->add_flag("--print-scene", printScene,
                          "print the scene with every default stated (as a run writes it to scene.json) on standard output "
                          "(the report then goes to standard error)");
    validateCmd
        ->add_option("--threads", threads,
                     "the threads the run will take, for its time estimate (default: the scene's, else all cores)")
        ->check(threadCount);

    // Command-line errors as the program's own: "error: " first, as a scene's are.
    app.failure_message(
        [](const CLI::App* failed, const CLI::Error& e) { return "error: " + CLI::FailureMessage::simple(failed, e); });
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
            return validate(scenePath, strict, printScene, threads);
        }
        RunOptions options;
        options.outDir = outDir;
        options.resume = resume;
        options.force = force;
        return run(scenePath, parseFrames(frames, options), threads, quiet);
    } catch (const SceneError& e) {
        return fail(kExitBadInput, "error: %s\n", e.what());
    } catch (const LockError& e) {
        return fail(kExitBadInput, "error: %s\n", e.what());
    } catch (const SimulationError& e) {
        return fail(kExitRunFailed, "\nerror: simulation stopped: %s (nothing of that frame was written)\n", e.what());
    } catch (const LimitExceeded& e) {
        return fail(kExitRunFailed, "\nerror: simulation stopped: %s\n", e.what());
    } catch (const WriteError& e) {
        return fail(kExitRunFailed, "\nerror: cannot write %s (earlier files are intact)\n", e.what());
    } catch (const std::bad_alloc&) {
        // The run's phases say what they were doing (SceneRun::guarded); this is reading the scene or its files.
        return fail(kExitRunFailed,
                    "\nerror: out of memory while reading %s and the files it names, before any particle was made\n",
                    scenePath.c_str(), false);
    } catch (const std::exception& e) {
        return fail(kExitRunFailed, "\nerror: %s\n", e.what(), false);
    }
}

}  // namespace
