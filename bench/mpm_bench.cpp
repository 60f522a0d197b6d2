// Scene-level performance driver (docs/performance/summary.md). Each measurement runs in a child process of its own, so that
// its peak memory is its own and no run warms the next one's caches or allocator.
//   mpm_bench one --material jelly --particles 1e6 --threads 2      one measurement, one CSV row
//   mpm_bench one --experiment paired --threads 2 ...                 1 and 2 threads interleaved, two rows
//   mpm_bench output --particles 1e6                                the cost of writing a frame
//   mpm_bench suite -o DIR [--quick]                                everything, into DIR/perf.csv
// Rows: particle-substeps per second (PSS) from the median substep of 200 by default (past the impact and the
// settling), beside the slowest block of 20; memory per particle and each phase's share of a substep.
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "BenchScene.h"
#include "Machine.h"
#include "core/LevelSetGeometry.h"
#include "core/RigidCollider.h"
#include "io/LevelSets.h"
#include "io/SceneDesc.h"
#include "io/VdbWriter.h"

using namespace mpm;
using namespace mpm::bench;

namespace {

const char* kHeader =
    "experiment,material,kernel,particles,blobs,spread_cells,threads,substeps,seconds,pss,net_bytes_per_particle,"
    "peak_rss_mb,share_topology,share_binning,share_p2g,share_grid,share_g2p,share_other,slowest_block_pss";

/// A field of /proc/self/status in bytes (VmRSS, VmHWM), 0 where there is none.
double procStatusBytes(const char* field) {
    std::ifstream in("/proc/self/status");
    for (std::string line; std::getline(in, line);)
        if (line.rfind(field, 0) == 0) return 1024.0 * std::stod(line.substr(std::strlen(field) + 1));
    return 0.0;
}

/// Restarts VmHWM from the current RSS (Linux 4.0+; elsewhere the peak keeps the set-up's transients).
void resetPeakRss() { std::ofstream("/proc/self/clear_refs") << "5"; }

struct Options {
    std::string experiment = "throughput";
    BenchScene scene;
    std::string kernel = "quadratic";
    int threads = 1;
    /// Enough that the falling block meets the floor and settles: a cliff that comes with rest (subnormal floats in
    /// the quiet material) shows in the slowest block.
    int substeps = 200;
    int warmup = 3;
};

double median(std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
}

/// Substeps per block of the slowest-block column: long enough that one burst of another process's work is
/// diluted, short enough to show a phase of the run (the settling after impact) that is slower than the rest.
constexpr int kReportBlock = 20;

/// PSS of the slowest run of kReportBlock consecutive substeps (of all of them when fewer).
double slowestBlockPss(const std::vector<double>& each, double particles) {
    const std::size_t block = std::min<std::size_t>(kReportBlock, each.size());
    double slowest = 0.0;
    for (std::size_t b = 0; b + block <= each.size(); b += block)
        slowest =
            std::max(slowest, std::accumulate(each.begin() + std::ptrdiff_t(b), each.begin() + std::ptrdiff_t(b + block), 0.0));
    return particles * double(block) / slowest;
}

/// The benchmark scene, its floor a mesh when asked: a closed box mesh whose top face is the floor plane,
/// under the whole block, turned into a distance field at half the grid spacing as a scene would.
std::unique_ptr<Simulation> makeScene(const BenchScene& b) {
    auto sim = makeBenchSimulation(b);
    if (b.floor == "mesh") {
        const double edge = std::cbrt(double(b.particles)) * 0.5 * kDx + 4 * kDx;
        TriangleMesh box;
        for (int c = 0; c < 8; ++c)
            box.points.emplace_back(c & 4 ? edge : -4 * kDx, c & 2 ? 0.0 : -8 * kDx, c & 1 ? edge : -4 * kDx);
        const int faces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
        for (const auto& q : faces) {
            box.triangles.emplace_back(q[0], q[1], q[2]);
            box.triangles.emplace_back(q[0], q[2], q[3]);
        }
        auto ls = meshLevelSet(box, "bench floor", 0.5 * kDx, 0.0, 2 * kDx + 1.5 * kDx, 3 * kDx, colliderReach(kDx));
        sim->addCollider(std::make_unique<RigidCollider<LevelSetGeometry>>(LevelSetGeometry{ls}, Boundary::Slip, 0.0f));
    }
    return sim;
}

/// One timed run: warm-up substeps (allocation, the first full sort), then `substeps` timed ones.
std::string measureSubsteps(const Options& o) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(o.threads));
    const double rssBefore = procStatusBytes("VmRSS:");
    auto sim = makeScene(o.scene);
    const double n = double(sim->particleCount());
    resetPeakRss();  // the scene set-up's own buffers are not the simulator's memory
    for (int s = 0; s < o.warmup; ++s) sim->substep(kTargetDt);
    sim->resetPhaseSeconds();
    // PSS from the median substep: this machine is shared, and a burst of someone else's work should
    // move one substep, not the result.
    std::vector<double> each;
    for (int s = 0; s < o.substeps; ++s) {
        const auto t0 = std::chrono::steady_clock::now();
        sim->substep(kTargetDt);
        each.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    const double sec = std::accumulate(each.begin(), each.end(), 0.0);
    const double mid = median(each);
    const double peak = procStatusBytes("VmHWM:");
    const PhaseSeconds& ph = sim->phaseSeconds();
    const double total = ph.total();
    std::ostringstream row;
    row << o.experiment << ',' << o.scene.material << ',' << o.kernel << ',' << long(n) << ',' << o.scene.blobs << ','
        << o.scene.spreadCells << ',' << o.threads << ',' << o.substeps << ',' << sec << ',' << n / mid << ','
        << (peak - rssBefore) / n << ',' << peak / 1048576.0 << ',' << ph.topology / total << ',' << ph.binning / total << ','
        << ph.p2g / total << ',' << ph.grid / total << ',' << ph.g2p / total << ',' << ph.other / total << ','
        << slowestBlockPss(each, n);
    return row.str();
}

/// The speed-up, measured so that the machine's drift cancels: one simulation whose substeps alternate, in
/// blocks of kPairedBlock, between 1 thread and `threads` (two task arenas), so both counts run under the
/// same outside load. Results do not depend on the thread count, so the alternation changes nothing in the
/// simulation. Two rows, "paired" at 1 thread and at `threads`; PSS from the median substep of each.
constexpr int kPairedBlock = 5;  // timed substeps per block; one more runs first, untimed
std::vector<std::string> measurePaired(const Options& o) {
    tbb::task_arena single(1), many(o.threads);
    auto sim = makeScene(o.scene);
    const double n = double(sim->particleCount());
    for (int s = 0; s < o.warmup; ++s) many.execute([&] { sim->substep(kTargetDt); });
    std::vector<double> each[2];
    for (int s = 0; s < o.substeps; s += kPairedBlock)
        for (int a = 0; a < 2; ++a)
            for (int b = 0; b <= kPairedBlock; ++b) {
                const auto t0 = std::chrono::steady_clock::now();
                (a == 0 ? single : many).execute([&] { sim->substep(kTargetDt); });
                // The first substep after a switch pays for TBB moving its worker threads between arenas.
                if (b > 0) each[a].push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            }
    std::vector<std::string> rows;
    for (int a = 0; a < 2; ++a) {
        std::ostringstream row;
        row << "paired," << o.scene.material << ',' << o.kernel << ',' << long(n) << ',' << o.scene.blobs << ','
            << o.scene.spreadCells << ',' << (a == 0 ? 1 : o.threads) << ',' << o.substeps << ','
            << std::accumulate(each[a].begin(), each[a].end(), 0.0) << ',' << n / median(each[a]) << ",,,,,,,,,"
            << slowestBlockPss(each[a], n);
        rows.push_back(row.str());
    }
    return rows;
}

/// Writes one frame's points, then its surface, of a settled block; PSS holds particles written per second.
std::vector<std::string> measureOutput(const Options& o) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(o.threads));
    auto sim = makeScene(o.scene);
    sim->substep(kTargetDt);
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("mpm_bench_output_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::vector<std::string> rows;
    // The surface raw and closed and smoothed as a scene's defaults ask (output.surface_dilate/smooth/erode):
    // the filter's cost per particle is the ratio of the two rows.
    const OutputDesc defaults;
    for (const std::string what : {"points", "surface", "surface_filtered"}) {
        VdbFrameRequest r;
        r.volumePath = (dir / (what + ".vdb")).string();
        r.points = what == "points";
        r.surface = !r.points;
        if (what == "surface_filtered") {
            r.surfaceDilate = defaults.surfaceDilate;
            r.surfaceSmooth = defaults.surfaceSmooth;
            r.surfaceErode = defaults.surfaceErode;
        }
        r.pointVoxelSize = kDx;
        r.surfaceVoxelSize = 0.5 * kDx;  // the particle spacing at 8 per cell
        r.surfaceRadius = 0.5 * kDx;
        r.surfaces = {SurfaceGroup{"surface", {0}}};
        r.materialNames = {o.scene.material};
        r.setNames = {"block"};
        const auto t0 = std::chrono::steady_clock::now();  // the gather is part of writing a frame
        const std::size_t written = writeVdbFrame(r, gatherPoints(sim->species(), {0}));
        const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::ostringstream row;
        row << "output_" << what << ',' << o.scene.material << ",," << written << ",1,0," << o.threads << ",1," << sec << ','
            << double(written) / sec << ",," << procStatusBytes("VmHWM:") / 1048576.0 << ",,,,,,,";
        rows.push_back(row.str());
    }
    std::filesystem::remove_all(dir);
    return rows;
}

/// One timed run on the ranks this program was started on (mpirun -np N mpm_bench ranks ...): the same
/// scene built on every rank and spread over them, as `mpm run` does. Rank 0 prints one row: PSS of the whole
/// run from the median substep, and over the ranks the most bytes sent per substep, the largest share of a
/// substep spent communicating, the ghost leaves' share of a rank's leaves and of its memory, and the
/// imbalance (most particles on a rank over the mean).
std::string measureRanks(const Options& o) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(o.threads));
    const Comm& comm = Comm::world();
    auto sim = makeScene(o.scene);
    const double n = double(sim->particleCount());
    sim->distribute(comm);
    for (int s = 0; s < o.warmup; ++s) sim->substep(kTargetDt);
    sim->resetPhaseSeconds();
    Comm::world().resetCounters();
    std::vector<double> each;
    for (int s = 0; s < o.substeps; ++s) {
        const auto t0 = std::chrono::steady_clock::now();
        sim->substep(kTargetDt);
        each.push_back(comm.max(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()));
    }
    const double sec = std::accumulate(each.begin(), each.end(), 0.0);
    const PhaseSeconds& ph = sim->phaseSeconds();
    const double sent = comm.max(double(comm.bytesSent()) / o.substeps);
    const double commShare = comm.max(ph.total() > 0.0 ? ph.communication / ph.total() : 0.0);
    const double leaves = double(sim->grid().leafCount()), ghosts = double(sim->ghostLeafCount());
    const double ghostLeafShare = comm.max(leaves > 0.0 ? ghosts / leaves : 0.0);
    // A rank's memory: its particles' arrays and its grid (ghost leaves included).
    double held = double(sim->grid().memoryBytes());
    for (const AnySpecies& sp : sim->species())
        std::visit(
            [&](const auto& x) { x.forEachArray([&](const auto& arr) { held += double(arr.capacity() * sizeof(arr[0])); }); },
            sp);
    const double ghostMemoryShare = comm.max(ghosts * double(SparseGrid::bytesPerLeaf()) / held);
    const double mine = double(sim->particleCount());
    const double imbalance = comm.max(mine) / (n / comm.size());
    std::ostringstream row;
    row << "ranks," << o.scene.material << ',' << long(n) << ',' << comm.size() << ',' << o.threads << ',' << o.substeps << ','
        << sec << ',' << n / median(each) << ',' << sent << ',' << commShare << ',' << ghostLeafShare << ',' << ghostMemoryShare
        << ',' << imbalance << ',' << sim->rebalanceCount();
    return row.str();
}

/// Runs this program again with `args` and returns the rows it printed.
std::vector<std::string> runChild(const std::string& args) {
    const std::string cmd = std::filesystem::read_symlink("/proc/self/exe").string() + " " + args;
    std::vector<std::string> rows;
    FILE* pipe = ::popen(cmd.c_str(), "r");
    if (!pipe) throw std::runtime_error("cannot run " + cmd);
    char buf[4096];
    while (std::fgets(buf, sizeof buf, pipe)) {
        std::string line(buf);
        if (line.rfind("row,", 0) == 0) rows.push_back(line.substr(4, line.find_last_not_of("\r\n") - 3));
    }
    if (::pclose(pipe) != 0) throw std::runtime_error("benchmark run failed: " + cmd);
    return rows;
}

/// Runs per throughput measurement: the machine is shared, and one run can land in someone else's burst.
constexpr int kThroughputRepeats = 3;

void suite(const std::string& outDir, bool quick) {
    const int all = int(tbb::info::default_concurrency());
    const long million = quick ? 100000 : 1000000;
    std::vector<std::string> runs;
    auto add = [&](const std::string& exp, const std::string& material, const std::string& kernel, long n, int threads,
                   const std::string& extra = "") {
        std::ostringstream a;
        a << "one --experiment " << exp << " --material " << material << " --kernel " << kernel << " --particles " << n
          << " --threads " << threads << ' ' << extra;
        runs.push_back(a.str());
    };
    // Throughput: every material with the quadratic kernel, water and jelly with the cubic one, 1 and all
    // threads; each run three times, in processes of their own (the report takes the median run).
    const std::vector<std::pair<const char*, const char*>> materials = {
        {"water", "quadratic"}, {"jelly", "quadratic"}, {"rubber", "quadratic"}, {"snow", "quadratic"},
        {"sand", "quadratic"},  {"water", "cubic"},     {"jelly", "cubic"}};
    for (int repeat = 0; repeat < kThroughputRepeats; ++repeat)
        for (const auto& [m, k] : materials)
            for (int t : {1, all}) add("throughput", m, k, million, t);
    // Speed-up: 1 and all threads interleaved in one process (measurePaired), also three times.
    for (int repeat = 0; repeat < kThroughputRepeats; ++repeat)
        for (const auto& [m, k] : materials) add("paired", m, k, million, all);
    // Strong scaling: PSS against thread count.
    for (const char* m : {"water", "jelly"})
        for (int t = 1; t <= all; ++t) add("strong", m, "quadratic", million, t);
    // Weak scaling: PSS and memory against particle count.
    for (long n : {10000L, 30000L, 100000L, 300000L, 1000000L, 3000000L, 10000000L})
        if (!quick || n <= 1000000L) add("weak", "water", "quadratic", n, all);
    // Sparsity: eight blobs over an ever larger cube; time and memory must not follow the spread.
    for (double spread : {1e2, 1e3, 1e4, 1e5, 1e6})
        add("sparsity", "water", "quadratic", million, all, "--blobs 8 --spread " + std::to_string(spread));
    // Colliders: the benchmark block on no floor, the analytic plane and the same floor as a mesh's distance
    // field, three times each, interleaved: what a collider costs.
    for (int repeat = 0; repeat < kThroughputRepeats; ++repeat)
        for (const char* floor : {"none", "plane", "mesh"})
            add(std::string("floor_") + floor, "water", "quadratic", million, all, std::string("--floor ") + floor);
    // Frame output, apart from simulation.
    std::ostringstream out;
    out << "output --material water --particles " << million << " --threads " << all;
    runs.push_back(out.str());

    std::filesystem::create_directories(outDir);
    std::ofstream csv(outDir + "/perf.csv");
    csv << kHeader << '\n';
    for (const std::string& r : runs) {
        std::cerr << "mpm_bench " << r << '\n';
        for (const std::string& row : runChild(r)) {
            csv << row << '\n' << std::flush;
            std::cerr << "  " << row << '\n';
        }
    }
    std::ofstream machine(outDir + "/machine.txt");
    machine << "cpu: " << cpuModel() << "\nhardware threads: " << std::thread::hardware_concurrency()
            << "\ncompiler: " << MPM_COMPILER << "\nflags: " << MPM_BUILD_FLAGS << '\n';
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"mpm_bench: particle-substeps per second, scaling, memory and phase breakdown"};
    app.require_subcommand(1);
    Options o;
    std::string outDir = "docs/performance";
    bool quick = false;
    auto addScene = [&](CLI::App* c) {
        c->add_option("--material", o.scene.material, "a material of scenes' `material` key")
            ->check(CLI::IsMember(materialSceneNames()));
        c->add_option("--kernel", o.kernel, "quadratic or cubic")->check(CLI::IsMember({"quadratic", "cubic"}));
        c->add_option("--particles", o.scene.particles, "particle count (rounded to a cube per blob)");
        c->add_option("--threads", o.threads, "worker threads")->check(CLI::PositiveNumber);
        c->add_option("--blobs", o.scene.blobs, "1 block or 8 blobs")->check(CLI::IsMember({1, 8}));
        c->add_option("--spread", o.scene.spreadCells, "edge of the cube the 8 blobs sit on, in cells");
        c->add_flag("--spray", o.scene.spray, "particles scattered at random, most alone in their leaf");
        c->add_option("--floor", o.scene.floor, "plane (analytic), mesh (a box mesh's distance field) or none")
            ->check(CLI::IsMember({"plane", "mesh", "none"}));
    };
    CLI::App* one = app.add_subcommand("one", "one timed run; prints one CSV row");
    addScene(one);
    one->add_option("--experiment", o.experiment, "label of the row; \"paired\": 1 thread and --threads interleaved");
    one->add_option("--substeps", o.substeps, "timed substeps")->check(CLI::PositiveNumber);
    one->add_option("--warmup", o.warmup, "untimed substeps first");
    CLI::App* ranks = app.add_subcommand("ranks", "one timed run over the ranks of mpirun -np N; rank 0 prints one CSV row");
    addScene(ranks);
    ranks->add_option("--substeps", o.substeps, "timed substeps")->check(CLI::PositiveNumber);
    ranks->add_option("--warmup", o.warmup, "untimed substeps first");
    CLI::App* output = app.add_subcommand("output", "time writing one frame's points and surface");
    addScene(output);
    CLI::App* all = app.add_subcommand("suite", "every experiment, each in its own process, into DIR/perf.csv");
    all->add_option("-o,--out", outDir, "output directory");
    all->add_flag("--quick", quick, "1e5 instead of 1e6 particles, no runs above 1e6 (a smoke run)");
    Comm::start(&argc, &argv);
    struct Finish {
        ~Finish() { Comm::finish(); }
    } finish;
    CLI11_PARSE(app, argc, argv);
    try {
        if (*ranks) {
            const std::string row = measureRanks(o);
            if (Comm::world().rank() == 0) std::printf("row,%s\n", row.c_str());
        }
        o.scene.kernel = o.kernel == "cubic" ? Interpolation::Cubic : Interpolation::Quadratic;
        if (*one && o.experiment == "paired")
            for (const std::string& r : measurePaired(o)) std::printf("row,%s\n", r.c_str());
        else if (*one)
            std::printf("row,%s\n", measureSubsteps(o).c_str());
        if (*output)
            for (const std::string& r : measureOutput(o)) std::printf("row,%s\n", r.c_str());
        if (*all) suite(outDir, quick);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "mpm_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
