// Scene-level throughput: particle-substeps per second (PSS) of a water block at 8 particles per cell,
// falling onto a floor, after a warm-up, at 1 thread and at all threads. Prints the machine, the thread
// counts and the speed-up as a ratio measured in the same run.
//   mpm_bench_substep [particles=1000000] [substeps=20] [quadratic|cubic] [standard|mls]
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>

#include "Machine.h"
#include "core/Simulation.h"

using namespace mpm;

namespace {
double measure(int threads, long particles, int substeps, const SimulationSettings& s) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    Simulation sim(s);
    Species<Water> w;
    w.name = "water";
    const int id = sim.addSpecies(std::move(w));
    // A cube at 8 particles per cell: spacing dx/2.
    const double spacing = 0.5 * s.dx;
    const int side = int(std::cbrt(double(particles)) + 0.5);
    std::vector<Vec3d> x;
    x.reserve(std::size_t(side) * side * side);
    for (int i = 0; i < side; ++i)
        for (int j = 0; j < side; ++j)
            for (int k = 0; k < side; ++k) x.emplace_back((i + 0.5) * spacing, s.dx + (j + 0.5) * spacing, (k + 0.5) * spacing);
    const double vol = spacing * spacing * spacing;
    sim.addParticles(id, x, Vec3f::Zero(), float(vol * 1000.0), float(vol), 0);
    sim.addCollider(std::make_unique<PlaneCollider>(Vec3d::Zero(), Vec3d::UnitY(), Boundary::Slip, 0.0f));
    const double dt = 1e-4;
    for (int n = 0; n < 3; ++n) sim.substep(dt);  // warm-up: allocation, first sort
    const auto t0 = std::chrono::steady_clock::now();
    for (int n = 0; n < substeps; ++n) sim.substep(dt);
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return double(x.size()) * substeps / sec;
}
}  // namespace

int main(int argc, char** argv) {
    const long particles = argc > 1 ? std::atol(argv[1]) : 1000000;
    const int substeps = argc > 2 ? std::atoi(argv[2]) : 20;
    SimulationSettings s;
    s.dx = 0.01;
    s.adaptive = false;
    if (argc > 3 && std::strcmp(argv[3], "cubic") == 0) s.transfer.interpolation = Interpolation::Cubic;
    if (argc > 4 && std::strcmp(argv[4], "mls") == 0) s.transfer.force = ForceScheme::MLS;
    const int all = int(std::thread::hardware_concurrency());
    std::printf("machine: %s, %d hardware threads\n", bench::cpuModel().c_str(), all);
    std::printf("scene: water block, %ld particles, 8 per cell, %s kernel, %s force, %d timed substeps\n", particles,
                s.transfer.interpolation == Interpolation::Cubic ? "cubic" : "quadratic",
                s.transfer.force == ForceScheme::MLS ? "MLS" : "standard", substeps);
    const double one = measure(1, particles, substeps, s);
    std::printf("threads 1: %.3e particle-substeps/s\n", one);
    if (all > 1) {
        const double many = measure(all, particles, substeps, s);
        std::printf("threads %d: %.3e particle-substeps/s (%.2fx of 1 thread)\n", all, many, many / one);
    }
    return 0;
}
