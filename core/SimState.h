#pragma once
// Where a simulation is: everything a later substep depends on, as one value. Copying it is a retry's
// snapshot; writing and reading it whole is a checkpoint. The grid, the sort buffers and the timings are
// not part of it: each substep rebuilds them from the particles.
#include <cstdint>
#include <vector>

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
};

struct SimState {
    std::vector<AnySpecies> species;  ///< particles of every species, with their parameters
    double time = 0.0;                ///< [s]
    int frame = 0;                    ///< frames completed
    long long substeps = 0;           ///< substeps completed
    int32_t nextId = 0;               ///< id of the next particle emitted
    int emittedFrame = -1;            ///< emitters' progress: the last frame whose emissions are done
    int retries = 0;                  ///< frames restarted so far (stability retries)
    StepBounds bounds;
    EnergyReference energy;

    /// Calls f on every field but the species, in a fixed order (checkpoints write them in this order).
    template <class F>
    void forEachScalar(F&& f) {
        f(time);
        f(frame);
        f(substeps);
        f(nextId);
        f(emittedFrame);
        f(retries);
        f(bounds.maxSpeed);
        f(energy.set);
        f(energy.min);
        f(energy.scale);
    }
};

}  // namespace mpm
