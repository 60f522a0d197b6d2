#pragma once
// The stability sweep (docs/validation/cases.md, "Stability sweep"): for every
// material and kernel, CFL numbers from 0.1 to 1.2 on small stiff and extreme setups. A run is stable when
// no blow-up check fires and total energy grows by less than 1% over its substeps.
#include <string>
#include <vector>

#include "core/Kernels.h"

namespace mpm::validation {

struct StabilityRun {
    std::string setup, material;
    Interpolation interpolation = Interpolation::Quadratic;
    double cfl = 0.5;
    int substeps = 2000;
};

struct StabilityOutcome {
    bool stable = false;
    std::string reason;  ///< why not ("energy grew 3.2%", the engine's message, ...)
    long long substeps = 0;
    std::size_t particles = 0;
    double minJ = 1.0, maxSpeed = 0.0, energyGrowth = 0.0, wallSeconds = 0.0;
};

/// Setups: resting_block, sliver, collision, spinning_sphere, dropped_column, steel_block, soft_block, wall_impact.
const std::vector<std::string>& stabilitySetups();
/// water, jelly, rubber, snow, sand.
const std::vector<std::string>& stabilityMaterials();
StabilityOutcome runStability(const StabilityRun& run);

/// Energy growth above this fraction over a run counts as unstable.
inline constexpr double kStableEnergyGrowth = 0.01;

}  // namespace mpm::validation
