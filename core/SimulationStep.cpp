#include "core/Simulation.h"
// The step policy: the bounds on a substep's length (the target step, the CFL condition, the displacement
// rule), which one set it and why, and the speed bound they read.

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace mpm {

double Simulation::cflTimeStep() const {
    if (!settings_.adaptive) return std::numeric_limits<double>::infinity();
    float c = 0.0f;
    for (std::size_t s = 0; s < state_.species.size(); ++s) {
        if (!populated_[s]) continue;
        c = std::max(c, std::visit(
                            [&](const auto& sp) {
                                using M = typename std::decay_t<decltype(sp)>::Material;
                                return M::waveSpeed(sp.params, state_.bounds.minStiffnessKey[s]);
                            },
                            state_.species[s]));
    }
    // dt (c + |v| + |g| dt) = C dx: the speed bound is the one at the end of the step, so that gravity
    // cannot carry a very soft or resting body more than C dx in one step (c + |v| near 0 would allow any
    // dt). Solved without cancellation; it is C dx / (c + |v|) when g = 0.
    const double speed = double(c) + double(state_.bounds.maxSpeed), g = settings_.gravity.norm(),
                 reach = settings_.cfl * settings_.dx;
    const double denominator = speed + std::sqrt(speed * speed + 4.0 * g * reach);
    return denominator > 0.0 ? 2.0 * reach / denominator : std::numeric_limits<double>::infinity();
}

double Simulation::displacementTimeStep() const {
    const double speed = double(state_.bounds.maxSpeed);
    return settings_.maxDisplacement > 0.0 && speed > 0.0 ? settings_.maxDisplacement * settings_.dx / speed
                                                          : std::numeric_limits<double>::infinity();
}

Simulation::StepBound Simulation::stepBound(bool withCause) const {
    const double target = settings_.targetDt(), cfl = cflTimeStep() * guard_.stepScale();
    const double displacement = displacementTimeStep() * guard_.stepScale();
    const std::string retry = guard_.stepScale() < 1.0 ? " (retry)" : "";
    if (displacement < std::min(target, cfl)) {
        if (!withCause) return {displacement, "", "max_displacement" + retry};
        std::ostringstream cause;
        cause << "the displacement rule, simulation.max_displacement = " << settings_.maxDisplacement
              << " cells a substep at the fastest particle's |v| = " << state_.bounds.maxSpeed << " m/s";
        return {displacement, cause.str(), "max_displacement" + retry};
    }
    if (target <= cfl) return {target, withCause ? "the target step 1 / (fps * substeps)" : "", "target" + retry};
    // The fastest wave of the species present, against the fastest particle.
    float c = 0.0f;
    std::string stiffest;
    for (std::size_t s = 0; s < state_.species.size(); ++s)
        std::visit(
            [&](const auto& sp) {
                using M = typename std::decay_t<decltype(sp)>::Material;
                const float w = populated_[s] ? M::waveSpeed(sp.params, state_.bounds.minStiffnessKey[s]) : 0.0f;
                if (w > c) c = w, stiffest = sp.name;
            },
            state_.species[s]);
    const bool wave = c >= state_.bounds.maxSpeed;
    const std::string limit = (wave ? "cfl_wave_speed " + stiffest : std::string("cfl_particle_speed")) + retry;
    if (!withCause) return {cfl, "", limit};
    std::ostringstream cause;
    cause << "the CFL bound, C dx / (c + |v|max + |g| dt) with ";
    if (wave)
        cause << "the wave speed c = " << c << " m/s of set " << stiffest;
    else
        cause << "the fastest particle, |v| = " << state_.bounds.maxSpeed << " m/s";
    if (guard_.stepScale() < 1.0) cause << ", shortened " << 1.0 / guard_.stepScale() << "x for a retry";
    return {cfl, cause.str(), limit};
}

void Simulation::refreshSpeedBound() {
    float& vmax = state_.bounds.maxSpeed;
    vmax = 0.0f;
    for (const AnySpecies& s : state_.species)
        for (const Vec3f& v : particlesOf(s).v) vmax = std::max(vmax, v.norm());
    vmax = comm_->max(vmax);
}

}  // namespace mpm
