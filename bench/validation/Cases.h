#pragma once
// Validation cases with known answers (docs/validation/cases.md): each loads its scene from
// scenes/validation/, refines it, runs it and measures its error with the metric defined here. Used by
// `mpm_report` (error against run time, over resolutions and accuracy/speed choices) and, at their
// cheapest settings, by the unit tests.
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "core/Kernels.h"
#include "core/Transfer.h"

namespace mpm::validation {

/// A choice that trades accuracy for speed, and the resolution level (dx = h / 2^level).
struct CaseConfig {
    int level = 0;
    Interpolation interpolation = Interpolation::Quadratic;
    ForceScheme force = ForceScheme::Standard;
    double particlesPerCell = 8.0;
    double cfl = 0.5;
    std::string label() const;  ///< "quadratic ppc8 cfl0.5 standard"
};

struct CaseResult {
    double error = 0.0;  ///< the case's metric (see ValidationCase::metric)
    bool pass = false;   ///< within the pass band (only meaningful at or past passLevel)
    double dx = 0.0;
    std::size_t particles = 0;
    long long substeps = 0;
    double wallSeconds = 0.0;  ///< simulation only, set-up and measuring excluded
    std::string detail;        ///< secondary numbers, "key=value;..."
};

/// A number from CaseResult::detail ("key=value;..."); NaN when the key is not there.
inline double detailValue(const std::string& detail, const std::string& key) {
    const auto at = detail.find(key + "=");
    return at == std::string::npos ? std::nan("") : std::stod(detail.substr(at + key.size() + 1));
}

/// A set's mass, and its mass-weighted centroid and mean velocity.
struct Centroid {
    double mass = 0.0;
    Vec3d x = Vec3d::Zero(), v = Vec3d::Zero();
};
inline Centroid centroidOf(const ParticleArrays& P) {
    Centroid c;
    for (std::size_t i = 0; i < P.size(); ++i)
        c.mass += P.mass[i], c.x += P.mass[i] * P.x[i], c.v += P.mass[i] * P.v[i].cast<double>();
    c.x /= c.mass;
    c.v /= c.mass;
    return c;
}

struct ValidationCase {
    std::string name;
    std::string metric;       ///< what error means, with units
    std::string band;         ///< the pass band in words
    int passLevel = 0;        ///< the band applies from this level on (e.g. L/dx >= 25)
    int maxLevel = 2;         ///< finest level the report runs for the baseline choice
    int maxLevelChoices = 2;  ///< finest level for the other choices (cost control)
    std::function<CaseResult(const CaseConfig&)> run;
    double minOrder = 0.0;  ///< when > 0, a level passes only if log2(e(h) / e(h/2)) against the level before reaches it
};

/// Where scenes/validation/ lives (defaults to the source tree this was built from).
void setSceneDirectory(const std::string& dir);

/// All cases, in the order of docs/validation/cases.md.
const std::vector<ValidationCase>& cases();
/// Case 13: planar sand columns of the aspect ratios given collapse with either yield surface; detail gives each
/// run-out against Lube et al. 2005's law as ratio_a<aspect>.
CaseResult planarColumnCollapse(const CaseConfig& c, YieldSurface surface, const std::vector<double>& aspects);
const ValidationCase& findCase(const std::string& name);

}  // namespace mpm::validation
