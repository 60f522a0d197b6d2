// The validation cases' shared helpers (CaseSupport.h).
#include "CaseSupport.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace mpm::validation::support {

std::string& sceneDirectory() {
    static std::string dir = MPM_SOURCE_DIR "/scenes/validation";
    return dir;
}

Setup load(const std::string& name, const CaseConfig& c, double cflOverride, const std::function<void(SceneDesc&)>& edit) {
    Setup s;
    s.scene = loadScene(sceneDirectory() + "/" + name + ".json");
    if (edit) edit(s.scene);
    SimulationSettings& st = s.scene.settings;
    st.dx /= double(1 << c.level);
    st.transfer.interpolation = c.interpolation;
    st.transfer.force = c.force;
    st.cfl = cflOverride > 0 ? cflOverride : c.cfl;
    for (ParticleSetDesc& d : s.scene.sets) d.particlesPerCell = c.particlesPerCell;
    s.sim = buildSimulation(s.scene);
    s.sim->emitDue();
    return s;
}

/// Runs substeps until time t, landing on it exactly; returns the wall seconds spent.
double runUntil(Simulation& sim, double t) {
    const auto start = std::chrono::steady_clock::now();
    const double target = sim.settings().targetDt();
    while (sim.time() < t - 1e-12) sim.substep(std::min(target, t - sim.time()));
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string kv(std::initializer_list<std::pair<const char*, double>> items) {
    std::ostringstream s;
    bool first = true;
    for (const auto& [k, v] : items) {
        s << (first ? "" : ";") << k << "=" << v;
        first = false;
    }
    return s.str();
}

CaseResult finish(Simulation& sim, double wall, double error, bool pass, std::string detail) {
    CaseResult r;
    r.error = error;
    r.pass = pass;
    r.dx = sim.settings().dx;
    r.particles = sim.particleCount();
    r.substeps = sim.substepCount();
    r.wallSeconds = wall;
    r.detail = std::move(detail);
    return r;
}

/// Least-squares slope and intercept of y against x.
std::pair<double, double> fitLine(const std::vector<double>& x, const std::vector<double>& y) {
    const double n = double(x.size());
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < x.size(); ++i) sx += x[i], sy += y[i], sxx += x[i] * x[i], sxy += x[i] * y[i];
    const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    return {slope, (sy - slope * sx) / n};
}

std::vector<std::pair<double, double>> readTable(const std::string& file) {
    std::ifstream in(sceneDirectory() + "/" + file);
    if (!in) throw std::runtime_error("cannot open " + sceneDirectory() + "/" + file);
    std::vector<std::pair<double, double>> rows;
    for (std::string line; std::getline(in, line);) {
        if (line.empty() || line[0] == '#' || !std::isdigit(static_cast<unsigned char>(line[0]))) continue;
        const auto comma = line.find(',');
        rows.emplace_back(std::stod(line.substr(0, comma)), std::stod(line.substr(comma + 1)));
    }
    return rows;
}

}  // namespace mpm::validation::support
