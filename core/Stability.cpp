#include "core/Stability.h"

#include <sstream>

namespace mpm {

namespace {

float volumeRatioOf(const SimState& state, int s, std::size_t i) {
    return std::visit([&](const auto& sp) { return std::decay_t<decltype(sp)>::Material::volumeRatio(sp.state, i); },
                      state.species[s]);
}

std::pair<int, std::size_t> fastestParticle(const SimState& state) {
    std::pair<int, std::size_t> best{0, 0};
    float vmax = -1.0f;
    for (std::size_t s = 0; s < state.species.size(); ++s) {
        const ParticleArrays& P = particlesOf(state.species[s]);
        for (std::size_t i = 0; i < P.size(); ++i)
            if (P.v[i].squaredNorm() > vmax) vmax = P.v[i].squaredNorm(), best = {int(s), i};
    }
    return best;
}

/// The species with the fastest wave, and in it the particle with the smallest stiffness key; or the
/// fastest particle, when speed rather than stiffness collapsed the step.
std::pair<int, std::size_t> stiffestParticle(const SimState& state) {
    std::pair<int, std::size_t> best{0, 0};
    float cmax = -1.0f;
    for (std::size_t s = 0; s < state.species.size(); ++s) {
        std::visit(
            [&](const auto& sp) {
                using M = typename std::decay_t<decltype(sp)>::Material;
                const float key = state.bounds.minStiffnessKey[s];
                if (sp.size() == 0 || M::waveSpeed(sp.params, key) <= cmax) return;
                cmax = M::waveSpeed(sp.params, key);
                std::size_t arg = 0;
                for (std::size_t i = 1; i < sp.size(); ++i)
                    if (M::stiffnessKey(sp.state, i) < M::stiffnessKey(sp.state, arg)) arg = i;
                best = {int(s), arg};
            },
            state.species[s]);
    }
    const auto fast = fastestParticle(state);
    return particlesOf(state.species[fast.first]).v[fast.second].norm() > cmax ? fast : best;
}

}  // namespace

void failAt(const SimState& state, const std::string& cause, int s, std::size_t i, double dt) {
    std::ostringstream msg;
    msg << cause << " at frame " << state.frame << ", substep " << state.substeps << " (t = " << state.time << " s, dt = " << dt
        << " s): particle id " << particlesOf(state.species[s]).id[i] << " of species "
        << std::visit([](const auto& sp) { return sp.name; }, state.species[s]);
    throw SimulationError(msg.str());
}

void StabilityGuard::checkSubstep(const SimState& state, const G2PSummary& g2p, double dt, double dx, double cflBefore,
                                  double cflAfter) const {
    if (g2p.badParticle >= 0)
        failAt(state, std::string("non-finite ") + g2p.badField, g2p.badSpecies, std::size_t(g2p.badParticle), dt);
    // Advection moved every particle by dt v: more than a cell means the step outran its own stencil.
    if (settings_.cellCrossing && double(g2p.maxSpeed) * dt > dx) {
        const auto [s, i] = fastestParticle(state);
        std::ostringstream cause;
        cause << "particle moved " << double(g2p.maxSpeed) * dt / dx << " cells in one substep (speed " << g2p.maxSpeed
              << " m/s)";
        failAt(state, cause.str(), s, i, dt);
    }
    // A material crushed (or a particle flung) far past anything physical makes the CFL step collapse and
    // the frame stall: stop there instead of crawling on with ever smaller steps.
    const double collapse = settings_.stepCollapse;
    if (collapse > 0.0 && cflAfter < cflBefore / collapse) {
        const auto [s, i] = stiffestParticle(state);
        std::ostringstream cause;
        cause << "time step collapsed from " << cflBefore << " s to " << cflAfter
              << " s in one substep (wave speed or particle speed exploded; J = " << volumeRatioOf(state, s, i) << ")";
        failAt(state, cause.str(), s, i, dt);
    }
}

void StabilityGuard::resetEnergyReference(EnergyReference& ref, const FrameStats& st) const {
    ref.set = true;
    ref.min = st.totalEnergy() - ref.work;
    ref.scale = std::max(ref.scale, st.kineticEnergy + st.elasticEnergy);
}

void StabilityGuard::checkEnergy(SimState& state, const FrameStats& st) const {
    EnergyReference& ref = state.energy;
    const double limit = settings_.energyGrowth;
    ref.scale = std::max(ref.scale, st.kineticEnergy + st.elasticEnergy);
    // A body at rest has almost no kinetic energy: the floor of the scale is its weight over one cell.
    const double scale = ref.scale + st.mass * gravity_ * dx_;
    // Energy less the work moving colliders did: without a blow-up it does not grow.
    const double own = st.totalEnergy() - ref.work;
    const double rise = own - ref.min;
    if (limit > 0.0 && st.particles > 0 && rise > limit * scale) {
        const auto [s, i] = fastestParticle(state);
        std::ostringstream cause;
        cause << "total energy rose by " << rise << " J without external work (" << 100.0 * rise / scale
              << "% of the largest kinetic + stored energy; the limit is " << 100.0 * limit << "%); fastest";
        failAt(state, cause.str(), s, i, 0.0);
    }
    ref.min = std::min(ref.min, own);
}

}  // namespace mpm
