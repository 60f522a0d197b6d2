// Stability setups, written as scene text and read through the scene parser, so that every material
// preset, override and collider is exactly what a user's scene would get.
#include "Stability.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "io/Scene.h"

namespace mpm::validation {

namespace {

constexpr double kDx = 0.02;     ///< grid spacing of every setup [m]
constexpr double kBlock = 0.08;  ///< block edge: 4 cells, 512 particles
constexpr double kSphereRadius = 0.08;
constexpr double kImpactSpeed = 1000.0;
constexpr double kSpinFraction = 0.3;       ///< w R = 0.3 c
constexpr double kCollisionFraction = 0.3;  ///< closing speed 0.3 c
constexpr long long kEnergyEvery = 50;      ///< substeps between energy samples

std::string vec(double x, double y, double z) {
    std::ostringstream s;
    s << "[" << x << ", " << y << ", " << z << "]";
    return s.str();
}

std::string box(double x0, double y0, double z0, double x1, double y1, double z1) {
    return R"({ "type": "box", "min": )" + vec(x0, y0, z0) + R"(, "max": )" + vec(x1, y1, z1) + " }";
}

/// material_params for a preset; stiffness: "" (preset), "steel" or "soft".
std::string materialParams(const std::string& material, const std::string& stiffness) {
    if (stiffness.empty()) return "{}";
    const char* rho = stiffness == "steel" ? "7850" : "1000";
    const char* modulus = stiffness == "steel" ? "2e11" : "1e2";
    // The liquids' stiffness is their equation of state's bulk modulus (the viscous liquid's shear modulus follows it).
    if (material == "water" || material == "viscous")
        return std::string(R"({ "density": )") + rho + R"(, "bulk_modulus": )" + modulus + " }";
    return std::string(R"({ "density": )") + rho + R"(, "youngs_modulus": )" + modulus + " }";
}

std::string set(const std::string& name, const std::string& material, const std::string& params, const std::string& shape,
                const std::string& velocity, const char* sampling = "lattice") {
    return R"({ "name": ")" + name + R"(", "material": ")" + material + R"(", "material_params": )" + params + R"(, "shape": )" +
           shape + R"(, "velocity": )" + velocity + R"(, "sampling": ")" + sampling + R"(" })";
}

/// Setups named "<setup>_mirror" are <setup> with simulation.wall_ghosts = "mirror" (their walls are sticky).
constexpr const char* kMirrorSuffix = "_mirror";
bool mirrored(const std::string& setup) {
    const std::string suffix = kMirrorSuffix;
    return setup.size() > suffix.size() && setup.compare(setup.size() - suffix.size(), suffix.size(), suffix) == 0;
}
std::string baseSetup(const std::string& setup) {
    return mirrored(setup) ? setup.substr(0, setup.size() - std::string(kMirrorSuffix).size()) : setup;
}

std::string scene(const StabilityRun& r, const std::string& sets, const std::string& colliders, bool gravity) {
    std::ostringstream s;
    s << R"({ "simulation": { "frames": 1, "fps": 1, "substeps": 1, "dx": )" << kDx << R"(, "cfl": )" << r.cfl
      << (mirrored(r.setup) ? R"(, "wall_ghosts": "mirror")" : "") << R"(, "interpolation": ")"
      << (r.interpolation == Interpolation::Cubic ? "cubic" : "quadratic") << R"(", "gravity": )"
      << (gravity ? vec(0, -9.81, 0) : vec(0, 0, 0)) << R"(, "energy_growth_limit": 0.5 },)"
      << R"( "output": { "surface": false }, "sets": [ )" << sets << R"( ], "colliders": [ )" << colliders << " ] }";
    return s.str();
}

const std::string kFloor = R"({ "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "boundary": "sticky" })";

/// The wave speed of a material at rest, read off the CFL step of a probe scene.
double restWaveSpeed(const StabilityRun& r, const std::string& params) {
    SceneDesc probe =
        parseScene(scene(r, set("probe", r.material, params, box(0, 0, 0, kBlock, kBlock, kBlock), vec(0, 0, 0)), "", false),
                   "stability_probe.json");
    auto sim = buildSimulation(probe);
    sim->emitDue();
    return r.cfl * kDx / sim->cflTimeStep();
}

/// Setups whose speeds are fractions of the wave speed.
bool needsWaveSpeed(const std::string& setup) { return setup == "collision" || setup == "spinning_sphere"; }

/// c: the material's rest wave speed, for the setups that need it.
std::string sceneText(const StabilityRun& r, double c) {
    const std::string setup = baseSetup(r.setup);
    const std::string& m = r.material;
    const std::string zero = vec(0, 0, 0);
    const double b = kBlock;
    if (setup == "resting_block") return scene(r, set("block", m, "{}", box(0, 0, 0, b, b, b), zero), kFloor, true);
    if (setup == "steel_block" || setup == "soft_block") {
        const std::string params = materialParams(m, setup == "steel_block" ? "steel" : "soft");
        return scene(r, set("block", m, params, box(0, 0, 0, b, b, b), zero), kFloor, true);
    }
    if (setup == "sliver")  // one particle thick: a lattice of spacing dx / 2 in a slab dx / 2 high
        return scene(r, set("sliver", m, "{}", box(0, 0.1, 0, 0.2, 0.1 + 0.5 * kDx, 0.2), zero), kFloor, true);
    if (setup == "dropped_column")  // a column dropped from twice its height
        return scene(r, set("column", m, "{}", box(0, 2 * b, 0, 0.5 * b, 3 * b, 0.5 * b), zero), kFloor, true);
    if (setup == "wall_impact")
        return scene(
            r, set("body", m, "{}", box(0, 0, 0, b, b, b), vec(kImpactSpeed, 0, 0)),
            R"({ "type": "plane", "point": )" + vec(b + 2 * kDx, 0, 0) + R"(, "normal": [-1, 0, 0], "boundary": "sticky" })",
            false);
    if (setup == "collision") {
        const double v = 0.5 * kCollisionFraction * c;
        return scene(r,
                     set("left", m, "{}", box(0, 0, 0, b, b, b), vec(v, 0, 0)) + ", " +
                         set("right", m, "{}", box(b + kDx, 0, 0, 2 * b + kDx, b, b), vec(-v, 0, 0)),
                     "", false);
    }
    if (setup == "spinning_sphere")  // spin set after loading: v = w x r, C = [w]x
        return scene(r,
                     set("sphere", m, "{}",
                         R"({ "type": "sphere", "center": [0, 0, 0], "radius": )" + std::to_string(kSphereRadius) + " }", zero),
                     "", false);
    throw std::invalid_argument("unknown stability setup \"" + r.setup + "\"");
}

void spin(Simulation& sim, double omega) {
    const Vec3d w(0, omega, 0);
    Mat3f W;
    W << 0, -float(w[2]), float(w[1]), float(w[2]), 0, -float(w[0]), -float(w[1]), float(w[0]), 0;
    ParticleArrays& P = particlesOf(sim.species()[0]);
    for (std::size_t i = 0; i < P.size(); ++i) {
        P.v[i] = w.cross(P.x[i]).cast<float>();
        P.C[i] = W;
    }
    sim.refreshSpeedBound();
}

}  // namespace

const std::vector<std::string>& stabilitySetups() {
    // The setups with sticky walls once more with mirrored ghost nodes (simulation.wall_ghosts = "mirror").
    static const std::vector<std::string> s = {"resting_block",
                                               "sliver",
                                               "collision",
                                               "spinning_sphere",
                                               "dropped_column",
                                               "steel_block",
                                               "soft_block",
                                               "wall_impact",
                                               "resting_block_mirror",
                                               "sliver_mirror",
                                               "dropped_column_mirror",
                                               "steel_block_mirror",
                                               "soft_block_mirror",
                                               "wall_impact_mirror"};
    return s;
}

const std::vector<std::string>& stabilityMaterials() {
    static const std::vector<std::string> m = {"water", "jelly", "rubber", "snow", "sand", "metal", "viscous"};
    return m;
}

StabilityOutcome runStability(const StabilityRun& r) {
    const double c = needsWaveSpeed(r.setup) ? restWaveSpeed(r, "{}") : 0.0;
    SceneDesc desc = parseScene(sceneText(r, c), "stability_" + r.setup + ".json");
    auto sim = buildSimulation(desc);
    sim->emitDue();
    if (r.setup == "spinning_sphere") spin(*sim, kSpinFraction * c / kSphereRadius);
    StabilityOutcome out;
    out.particles = sim->particleCount();
    FrameStats st = sim->measure();
    const double e0 = st.totalEnergy();
    double eMax = e0, scale = st.kineticEnergy + st.elasticEnergy;
    const double floor = st.mass * 9.81 * kDx;
    out.minJ = st.minJ;
    const auto start = std::chrono::steady_clock::now();
    try {
        // Frame length is irrelevant here: substeps are taken one by one at the CFL step.
        for (int n = 1; n <= r.substeps; ++n) {
            sim->substep(sim->settings().targetDt());
            if (n % kEnergyEvery == 0 || n == r.substeps) {
                st = sim->measure();
                eMax = std::max(eMax, st.totalEnergy());
                scale = std::max(scale, st.kineticEnergy + st.elasticEnergy);
                out.minJ = std::min(out.minJ, st.minJ);
                out.maxSpeed = std::max(out.maxSpeed, st.maxSpeed);
                if (!std::isfinite(st.totalEnergy())) throw SimulationError("non-finite energy");
            }
        }
        out.energyGrowth = (eMax - e0) / (scale + floor);
        out.stable = out.energyGrowth < kStableEnergyGrowth;
        if (!out.stable) {
            std::ostringstream s;
            s << "energy grew " << 100.0 * out.energyGrowth << "%";
            out.reason = s.str();
        }
    } catch (const SimulationError& e) {
        out.stable = false;
        out.reason = e.what();
    }
    out.substeps = sim->substepCount();
    out.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
}

}  // namespace mpm::validation
