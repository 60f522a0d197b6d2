#include "core/Stability.h"

#include <limits>
#include <optional>
#include <sstream>

namespace mpm {

namespace {

/// A particle a failure names: its species and id, and what the message says of it.
struct Culprit {
    int species = 0;
    int32_t id = -1;
    float speed = 0.0f, J = 1.0f;
    float rank = 0.0f;  ///< what it was picked by, larger first (speed squared; minus the stiffness key)
};

float volumeRatioOf(const SimState& state, int s, std::size_t i) {
    return std::visit([&](const auto& sp) { return std::decay_t<decltype(sp)>::Material::volumeRatio(sp.state, i); },
                      state.species[s]);
}
Culprit describe(const SimState& state, int s, std::size_t i) {
    const ParticleArrays& P = particlesOf(state.species[s]);
    return Culprit{s, P.id[i], P.v[i].norm(), volumeRatioOf(state, s, i)};
}

/// Of the candidates of every rank (one each, or none), the one a single process would find first: the
/// best key, then the lower species, then the lower rank (ranks hold the leaves in order).
std::optional<Culprit> firstOverRanks(const Comm& comm, const std::optional<Culprit>& mine) {
    if (!comm.distributed()) return mine;
    Bytes b;
    if (mine) put(b, *mine);
    std::optional<Culprit> best;
    for (const Bytes& theirs : comm.allGather(b)) {
        if (theirs.empty()) continue;
        ByteReader r{theirs};
        const Culprit c = r.get<Culprit>();
        if (!best || c.rank > best->rank || (c.rank == best->rank && c.species < best->species)) best = c;
    }
    return best;
}

/// The fastest particle of every species, or of species `only`.
Culprit fastestParticle(const SimState& state, const Comm& comm, int only = -1) {
    std::optional<Culprit> best;
    float vmax = -1.0f;
    for (std::size_t s = 0; s < state.species.size(); ++s) {
        if (only >= 0 && int(s) != only) continue;
        const ParticleArrays& P = particlesOf(state.species[s]);
        for (std::size_t i = 0; i < P.size(); ++i)
            if (P.v[i].squaredNorm() > vmax) {
                vmax = P.v[i].squaredNorm();
                best = describe(state, int(s), i);
                best->rank = vmax;
            }
    }
    return firstOverRanks(comm, best).value_or(Culprit{});
}

/// The species with the fastest wave, and in it the particle with the smallest stiffness key; or the
/// fastest particle, when speed rather than stiffness collapsed the step.
Culprit stiffestParticle(const SimState& state, const Comm& comm) {
    int stiffest = -1;
    float cmax = -1.0f;
    for (std::size_t s = 0; s < state.species.size(); ++s)
        std::visit(
            [&](const auto& sp) {
                using M = typename std::decay_t<decltype(sp)>::Material;
                const long long count = comm.sum((long long)sp.size());
                const float c = M::waveSpeed(sp.params, state.bounds.minStiffnessKey[s]);
                if (count > 0 && c > cmax) cmax = c, stiffest = int(s);
            },
            state.species[s]);
    std::optional<Culprit> mine;
    if (stiffest >= 0)
        std::visit(
            [&](const auto& sp) {
                using M = typename std::decay_t<decltype(sp)>::Material;
                if (sp.size() == 0) return;
                std::size_t arg = 0;
                for (std::size_t i = 1; i < sp.size(); ++i)
                    if (M::stiffnessKey(sp.state, i) < M::stiffnessKey(sp.state, arg)) arg = i;
                const float key = M::stiffnessKey(sp.state, arg);
                mine = describe(state, stiffest, arg);
                mine->rank = -key;  // the smallest key first
            },
            state.species[std::size_t(stiffest)]);
    const std::optional<Culprit> best = firstOverRanks(comm, mine);
    const Culprit fast = fastestParticle(state, comm);
    return fast.speed > cmax || !best ? fast : *best;
}

}  // namespace

void failAt(const SimState& state, const std::string& cause, int s, int32_t id, double dt) {
    std::ostringstream msg;
    // Frames counted as their files are, from 1: the one under way. The energy check spans substeps (dt 0): no step to name.
    msg << cause << " in frame " << state.frame + 1 << " (substep " << state.substeps << " of the run, t = " << state.time
        << " s";
    if (dt > 0.0) msg << ", dt = " << dt << " s";
    msg << "): particle id " << id << " of set " << std::visit([](const auto& sp) { return sp.name; }, state.species[s]);
    throw SimulationError(msg.str());
}

void StabilityGuard::checkSubstep(const SimState& state, const G2PSummary& g2p, double dt, double dx, double cflBefore,
                                  double cflAfter) const {
    if (g2p.badId >= 0) failAt(state, std::string("non-finite ") + g2p.badField, g2p.badSpecies, g2p.badId, dt);
    // Advection moved every particle by dt v: more than a cell means the step outran its own stencil.
    if (settings_.cellCrossing && double(g2p.maxSpeed) * dt > dx) {
        const Culprit p = fastestParticle(state, *comm_);
        std::ostringstream cause;
        cause << "particle moved " << double(g2p.maxSpeed) * dt / dx << " cells in one substep (speed " << g2p.maxSpeed
              << " m/s)";
        failAt(state, cause.str(), p.species, p.id, dt);
    }
    // A material crushed (or a particle flung) far past anything physical makes the CFL step collapse and
    // the frame stall: stop there instead of crawling on with ever smaller steps.
    const double collapse = settings_.stepCollapse;
    if (collapse > 0.0 && cflAfter < cflBefore / collapse) {
        const Culprit p = stiffestParticle(state, *comm_);
        std::ostringstream cause;
        cause << "time step collapsed from " << cflBefore << " s to " << cflAfter
              << " s in one substep (wave speed or particle speed exploded; J = " << p.J << ")";
        failAt(state, cause.str(), p.species, p.id, dt);
    }
}

void StabilityGuard::resetEnergyReference(EnergyReference& ref, const FrameStats& st) const {
    ref.set = true;
    ref.min = st.totalEnergy() - ref.work;
    ref.scale = std::max(ref.scale, st.kineticEnergy + st.elasticEnergy);
    speciesEnergyAtMin_ = st.speciesEnergy;
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
        std::ostringstream cause;
        cause << "total energy rose by " << rise << " J without external work (" << 100.0 * rise / scale
              << "% of the largest kinetic + stored energy; the limit is " << 100.0 * limit << "%); ";
        // The set that gained most since the minimum is the one blowing up (the fastest particle may be one it flung).
        int gainer = -1;
        if (speciesEnergyAtMin_.size() == st.speciesEnergy.size() && st.speciesEnergy.size() > 1) {
            double most = -std::numeric_limits<double>::infinity();
            for (std::size_t s = 0; s < st.speciesEnergy.size(); ++s)
                if (st.speciesEnergy[s] - speciesEnergyAtMin_[s] > most)
                    most = st.speciesEnergy[s] - speciesEnergyAtMin_[s], gainer = int(s);
            cause << "set " << std::visit([](const auto& sp) { return sp.name; }, state.species[std::size_t(gainer)])
                  << " gained most (" << most << " J); its fastest";
        } else {
            cause << "fastest";
        }
        const Culprit p = fastestParticle(state, *comm_, gainer);
        failAt(state, cause.str(), p.species, p.id, 0.0);
    }
    if (own <= ref.min) speciesEnergyAtMin_ = st.speciesEnergy;
    ref.min = std::min(ref.min, own);
}

}  // namespace mpm
