// mpm_report: error against run time over resolutions and accuracy/speed choices, and the stability
// sweep. Writes CSVs and machine.txt; tools/validation_report.py turns them into PNG plots and report.md.
//   mpm_report accuracy  [--out DIR] [--cases a,b] [--quick]
//   mpm_report stability [--out DIR] [--quick] [--setups a,b] [--materials a,b]
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "../Machine.h"
#include "Cases.h"
#include "Stability.h"
#include "base/Text.h"
#include "io/AtomicFile.h"
#include "io/Scene.h"

using namespace mpm;
using namespace mpm::validation;

namespace {

std::string csvQuote(const std::string& s) {
    std::string out = "\"";
    for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
    return out + "\"";
}

/// The baseline and one change per trade-off the issue names.
std::vector<std::pair<std::string, CaseConfig>> choices(bool quick) {
    CaseConfig base;
    std::vector<std::pair<std::string, CaseConfig>> v{{"baseline", base}};
    if (quick) return v;
    CaseConfig c = base;
    c.interpolation = Interpolation::Cubic;
    v.emplace_back("cubic", c);
    c = base;
    c.particlesPerCell = 27;
    v.emplace_back("ppc27", c);
    c = base;
    c.cfl = 0.25;
    v.emplace_back("cfl0.25", c);
    c = base;
    c.force = ForceScheme::MLS;
    v.emplace_back("mls", c);
    return v;
}

void writeMachine(const std::string& dir, int threads) {
    std::ostringstream m;
    m << "cpu: " << bench::cpuModel() << "\nthreads: " << threads << "\nhardware_threads: " << std::thread::hardware_concurrency()
      << "\ncompiler: " << __VERSION__ << "\nbuild: " << MPM_BUILD_FLAGS << "\n";
    writeTextAtomically(dir + "/machine.txt", m.str());
}

int accuracy(const std::string& dir, const std::string& only, bool quick, int threads) {
    std::ostringstream csv;
    csv << "case,choice,settings,level,dx,particles,substeps,wall_seconds,threads,error,pass,pass_level,metric,band,detail\n";
    for (const ValidationCase& vc : cases()) {
        if (!only.empty() && ("," + only + ",").find("," + vc.name + ",") == std::string::npos) continue;
        for (const auto& [name, cfg] : choices(quick)) {
            const int maxLevel = quick ? std::min(1, vc.maxLevel) : name == "baseline" ? vc.maxLevel : vc.maxLevelChoices;
            double previousError = 0.0;
            for (int level = 0; level <= maxLevel; ++level) {
                CaseConfig c = cfg;
                c.level = level;
                CaseResult r = vc.run(c);
                // A convergence band: the observed order against the level before.
                if (vc.minOrder > 0.0) r.pass = r.pass && level > 0 && std::log2(previousError / r.error) >= vc.minOrder;
                previousError = r.error;
                std::fprintf(stderr, "%-20s %-9s level %d dx %-9.4g particles %-8zu substeps %-7lld %7.2fs error %-11.4g %s\n",
                             vc.name.c_str(), name.c_str(), level, r.dx, r.particles, r.substeps, r.wallSeconds, r.error,
                             level < vc.passLevel ? "(below pass level)"
                             : r.pass             ? "pass"
                                                  : "FAIL");
                csv << vc.name << "," << name << "," << csvQuote(c.label()) << "," << level << "," << r.dx << "," << r.particles
                    << "," << r.substeps << "," << r.wallSeconds << "," << threads << "," << r.error << "," << (r.pass ? 1 : 0)
                    << "," << vc.passLevel << "," << csvQuote(vc.metric) << "," << csvQuote(vc.band) << "," << csvQuote(r.detail)
                    << "\n";
                writeTextAtomically(dir + "/accuracy.csv", csv.str());  // keep what is done if interrupted
            }
        }
    }
    return 0;
}

int stability(const std::string& dir, const std::string& only, const std::string& materials, bool quick, int threads) {
    const std::vector<double> cfls = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.2};
    std::ostringstream csv;
    csv << "setup,material,kernel,cfl,stable,substeps,particles,min_J,max_speed,energy_growth,wall_seconds,threads,reason\n";
    for (const std::string& setup : stabilitySetups()) {
        if (!only.empty() && ("," + only + ",").find("," + setup + ",") == std::string::npos) continue;
        for (const std::string& material : stabilityMaterials())
            for (Interpolation k : {Interpolation::Quadratic, Interpolation::Cubic}) {
                if (quick && k == Interpolation::Cubic) continue;
                if (!materials.empty() && ("," + materials + ",").find("," + material + ",") == std::string::npos) continue;
                // Descending from the largest C: the first stable value is the largest stable one (stability
                // is taken as monotone in C; cheap where everything is stable, the common case). The default C
                // is run too, so that its verdict is measured rather than inferred.
                const double defaultCfl = SimulationSettings().cfl;
                bool ranDefault = false;
                double largestStable = 0.0;
                auto runOne = [&](double cfl) {
                    StabilityRun run{setup, material, k, cfl, quick ? 400 : 2000};
                    const StabilityOutcome o = runStability(run);
                    const char* kname = k == Interpolation::Cubic ? "cubic" : "quadratic";
                    std::fprintf(stderr, "%-16s %-7s %-9s cfl %-4g %-8s %6.2fs %s\n", setup.c_str(), material.c_str(), kname, cfl,
                                 o.stable ? "stable" : "UNSTABLE", o.wallSeconds, o.reason.substr(0, 90).c_str());
                    csv << setup << "," << material << "," << kname << "," << cfl << "," << (o.stable ? 1 : 0) << ","
                        << o.substeps << "," << o.particles << "," << o.minJ << "," << o.maxSpeed << "," << o.energyGrowth << ","
                        << o.wallSeconds << "," << threads << "," << csvQuote(o.reason) << "\n";
                    writeTextAtomically(dir + "/stability.csv", csv.str());
                    ranDefault |= cfl == defaultCfl;
                    return o.stable;
                };
                for (auto it = cfls.rbegin(); it != cfls.rend(); ++it) {
                    if (quick && *it != defaultCfl && *it != cfls.back()) continue;
                    if (runOne(*it)) {
                        largestStable = *it;
                        break;
                    }
                }
                if (!ranDefault && largestStable > defaultCfl) runOne(defaultCfl);
            }
    }
    return 0;
}

}  // namespace

/// Whether every name of a comma-separated list is one of `known` (an empty list is everything); says which is not.
bool knownNames(const char* option, const std::string& list, const std::vector<std::string>& known) {
    std::stringstream in(list);
    for (std::string name; std::getline(in, name, ',');)
        if (!name.empty() && std::find(known.begin(), known.end(), name) == known.end()) {
            std::fprintf(stderr, "mpm_report: error: %s: unknown name \"%s\"; known: %s\n", option, name.c_str(),
                         joinNames(known).c_str());
            return false;
        }
    return true;
}

int main(int argc, char** argv) {
    CLI::App app{"mpm_report: validation cases (error against run time) and the stability sweep"};
    app.require_subcommand(1);
    std::string out = "docs/validation", only, scenes;
    bool quick = false;
    int threads = 0;
    for (CLI::App* sub : {app.add_subcommand("accuracy", "run every validation case over resolutions and choices"),
                          app.add_subcommand("stability", "CFL sweep for every material, kernel and extreme setup")}) {
        sub->add_option("-o,--out", out, "output directory (default docs/validation)");
        sub->add_option("--threads", threads, "worker threads (default all cores)");
        sub->add_flag("--quick", quick, "a cheap subset (baseline choice, coarse levels)");
        sub->add_option("--scenes", scenes, "the scenes/validation directory (default: the source tree's)");
    }
    app.get_subcommand("accuracy")->add_option("--cases", only, "comma-separated case names (default all)");
    std::string setups, materials;
    app.get_subcommand("stability")->add_option("--setups", setups, "comma-separated setup names (default all)");
    app.get_subcommand("stability")->add_option("--materials", materials, "comma-separated materials (default all)");
    CLI11_PARSE(app, argc, argv);
    const int n = threads > 0 ? threads : int(std::thread::hardware_concurrency());
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(n));
    if (!scenes.empty()) setSceneDirectory(scenes);
    try {
        // A misspelt name would otherwise run nothing and still overwrite the report's machine.txt.
        std::vector<std::string> caseNames;
        for (const ValidationCase& vc : cases()) caseNames.push_back(vc.name);
        if (!knownNames("--cases", only, caseNames) || !knownNames("--setups", setups, stabilitySetups()) ||
            !knownNames("--materials", materials, stabilityMaterials()))
            return 2;
        std::filesystem::create_directories(out);
        writeMachine(out, n);
        if (app.got_subcommand("accuracy")) return accuracy(out, only, quick, n);
        return stability(out, setups, materials, quick, n);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "mpm_report: error: %s\n", e.what());
        return 1;
    }
}
