#pragma once
// Where a simulation is: everything a later substep depends on, as one value. Copying it is a retry's
// snapshot; writing and reading it whole is a checkpoint. The grid, the sort buffers and the timings are
// not part of it: each substep rebuilds them from the particles.
#include <cstdint>
#include <vector>

#include "core/RigidBody.h"
#include "core/Species.h"

namespace mpm {

/// The bounds the next CFL step starts from, as the last G2P (or emission) left them: the largest particle
/// speed and, per species, the smallest stiffness key (core/Simulation.h, cflTimeStep). They follow from the
/// particles, but are kept so that a restored state takes exactly the step the original would have.
struct StepBounds {
    float maxSpeed = 0.0f;
    std::vector<float> minStiffnessKey;  ///< per species
};

/// The references of the energy blow-up check (core/Stability.h).
struct EnergyReference {
    bool set = false;    ///< measured once the first frame starts
    double min = 0.0;    ///< lowest total energy since the last emission
    double scale = 0.0;  ///< largest kinetic + stored energy seen
    double work = 0.0;   ///< energy moving colliders put in since the start (external work)
};

/// Where a run is, apart from its particles.
struct SimProgress {
    double time = 0.0;       ///< [s]
    int frame = 0;           ///< frames completed
    long long substeps = 0;  ///< substeps completed
    int frameSubsteps = 0;   ///< substeps completed in the frame under way (0 between frames)
    int32_t nextId = 0;      ///< id of the next particle emitted
    int emittedFrame = -1;   ///< emitters' progress: the last frame whose emissions are done
    int retries = 0;         ///< frames restarted so far (stability retries)
    /// Continuous emitters' progress, per emitter (zero for the others): how far material has flowed through
    /// the source surface [m], and how many layers of particles have entered.
    std::vector<double> streamFlow;
    std::vector<int64_t> streamLayers;
    StepBounds bounds;
    EnergyReference energy;
    std::vector<RigidBodyState> bodies;  ///< the dynamic colliders', in collider order
};

struct SimState : SimProgress {
    std::vector<AnySpecies> species;  ///< particles of every species, with their parameters

    /// Everything but the particles: the progress, and each species' name and parameters with no particle.
    SimState withoutParticles() const {
        SimState out;
        static_cast<SimProgress&>(out) = *this;
        for (const AnySpecies& s : species)
            std::visit(
                [&](const auto& sp) {
                    out.species.emplace_back(std::decay_t<decltype(sp)>{sp.name, sp.params, {}, {}, {}, sp.perParticle, {}});
                },
                s);
        return out;
    }

    /// Calls f on every field but the species and the stiffness keys, in a fixed order (checkpoints write
    /// them in this order).
    template <class F>
    void forEachScalar(F&& f) {
        each(*this, f);
    }
    template <class F>
    void forEachScalar(F&& f) const {
        each(*this, f);
    }

private:
    template <class Self, class F>
    static void each(Self& s, F& f) {
        f(s.time);
        f(s.frame);
        f(s.substeps);
        f(s.frameSubsteps);
        f(s.nextId);
        f(s.emittedFrame);
        f(s.retries);
        f(s.bounds.maxSpeed);
        f(s.energy.set);
        f(s.energy.min);
        f(s.energy.scale);
        f(s.energy.work);
    }
};

}  // namespace mpm
