#pragma once
// The benchmark scene of the performance report (docs/performance/summary.md): blocks of particles at 8 per cell (spacing dx/2)
// resting one cell above a slip floor and falling onto it (upper blobs fall freely), for any material, as one block or as 8 blobs
// at the corners of a cube spread over many cells. Shared by the scene-level driver and the Google Benchmark kernels.
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/Colliders.h"
#include "core/Simulation.h"

namespace mpm::bench {

/// Grid spacing of every benchmark scene [m].
inline constexpr double kDx = 0.01;
/// Target substep [s]; the CFL bound may shorten it.
inline constexpr double kTargetDt = 1e-4;

struct BenchScene {
    std::string material = "water";  ///< water, jelly, rubber, snow, sand
    Interpolation kernel = Interpolation::Quadratic;
    long particles = 1000000;
    int blobs = 1;             ///< 1 block, or 8 blobs at the corners of a cube
    double spreadCells = 0.0;  ///< edge of that cube in cells (blobs only)
    bool spray = false;        ///< particles scattered at random, most alone in their leaf
    /// The floor: "plane" (analytic), "mesh" (the same floor as a triangle mesh's distance field, added by
    /// the scene driver, which links the mesh reader) or "none".
    std::string floor = "plane";
};

/// Cube edge for spray, in cells: about four leaves' volume per particle, so most particles are alone.
inline double sprayEdgeCells(long particles) { return std::cbrt(double(particles) * 4.0 * kLeafNodes); }

/// A species of the material with its default (thesis) parameters, by the name a scene gives it.
inline AnySpecies presetSpecies(const std::string& material) {
    AnyMaterialParams params;
    if (!defaultMaterialParams(material, params)) {
        std::string known;
        for (const std::string& n : materialSceneNames()) known += (known.empty() ? "" : ", ") + n;
        throw std::invalid_argument("unknown material '" + material + "' (allowed: " + known + ")");
    }
    return makeSpecies(material, params);
}

inline float densityOf(const AnySpecies& s) {
    return std::visit([](const auto& sp) { return float(sp.params.density); }, s);
}

/// A cube of n^3 lattice points at spacing h with its low corner at lo.
inline void appendCube(std::vector<Vec3d>& x, const Vec3d& lo, int n, double h) {
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k) x.push_back(lo + h * Vec3d(i + 0.5, j + 0.5, k + 0.5));
}

/// Builds the simulation of a benchmark scene (adaptive CFL 0.5, the shipped defaults otherwise).
inline std::unique_ptr<Simulation> makeBenchSimulation(const BenchScene& b) {
    SimulationSettings s;
    s.dx = kDx;
    s.transfer.interpolation = b.kernel;
    s.stability.energyGrowth = 0.0;  // the benchmark times the substep alone
    auto sim = std::make_unique<Simulation>(s);
    const int id = sim->addSpecies(presetSpecies(b.material));
    const double h = 0.5 * kDx;  // 8 particles per cell
    const int perBlob = int(std::cbrt(double(b.particles) / b.blobs) + 0.5);
    std::vector<Vec3d> x;
    x.reserve(std::size_t(b.blobs) * perBlob * perBlob * perBlob);
    if (b.spray) {
        std::mt19937 rng(7);
        std::uniform_real_distribution<double> u(0.0, sprayEdgeCells(b.particles) * kDx);
        for (long i = 0; i < b.particles; ++i) x.emplace_back(u(rng), kDx + u(rng), u(rng));
    } else if (b.blobs == 1) {
        appendCube(x, Vec3d(0, kDx, 0), perBlob, h);
    } else {
        for (int c = 0; c < 8; ++c) {
            const Vec3d corner(c >> 2, (c >> 1) & 1, c & 1);
            appendCube(x, Vec3d(0, kDx, 0) + b.spreadCells * kDx * corner, perBlob, h);
        }
    }
    const double vol = h * h * h;
    sim->addParticles(id, x, Vec3f::Zero(), float(vol * densityOf(sim->species()[id])), float(vol), 0);
    if (b.floor == "plane") sim->addCollider(planeCollider(Vec3d::Zero(), Vec3d::UnitY(), Boundary::Slip, 0.0f));
    return sim;
}

}  // namespace mpm::bench
