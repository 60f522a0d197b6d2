#pragma once
// What the validation cases share: loading a case scene refined and configured, running to a time, and
// reducing a run to a CaseResult.
#include <functional>
#include <initializer_list>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "Cases.h"
#include "io/Scene.h"

namespace mpm::validation::support {

std::string& sceneDirectory();

/// A loaded case scene, refined and configured, with its particles emitted.
struct Setup {
    SceneDesc scene;
    std::unique_ptr<Simulation> sim;
};

/// Loads scenes/validation/<name>.json at dx = h / 2^level with the choice c; `edit`, when given, changes the
/// scene (colliders, gravity) before the simulation is built.
Setup load(const std::string& name, const CaseConfig& c, double cflOverride = -1.0,
           const std::function<void(SceneDesc&)>& edit = nullptr);

/// Runs substeps until time t, landing on it exactly; returns the wall seconds spent.
double runUntil(Simulation& sim, double t);

template <class M>
Species<M>& only(Simulation& sim) {
    return std::get<Species<M>>(sim.species().at(0));
}

/// "key=value;..." for CaseResult::detail.
std::string kv(std::initializer_list<std::pair<const char*, double>> items);

CaseResult finish(Simulation& sim, double wall, double error, bool pass, std::string detail = "");

/// Least-squares slope and intercept of y against x.
std::pair<double, double> fitLine(const std::vector<double>& x, const std::vector<double>& y);

/// Rows "x,y" of a CSV file beside the scenes (lines not starting with a digit are skipped).
std::vector<std::pair<double, double>> readTable(const std::string& file);

/// The contact cases (bench/validation/ContactCases.cpp), in the order of docs/validation/cases.md.
void addContactCases(std::vector<ValidationCase>& cases);

/// The viscous and yield-stress liquid cases (bench/validation/ViscousCases.cpp).
void addViscousCases(std::vector<ValidationCase>& cases);

}  // namespace mpm::validation::support
