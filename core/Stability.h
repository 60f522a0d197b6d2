#pragma once
// Blow-up detection as one component (docs/method.md, "Stability"): its settings, the checks after each
// substep (a non-finite value, a particle outrunning its stencil, a collapsing CFL step) and on energy,
// and the retry policy. A check that fires throws SimulationError naming cause, frame, substep and particle;
// with retries, the frame restarts from a copy of the state with half the time step.
#include <optional>
#include <stdexcept>
#include <string>

#include "core/Comm.h"
#include "core/Diagnostics.h"
#include "core/Settings.h"
#include "core/SimState.h"
#include "core/Transfer.h"

namespace mpm {

/// A blow-up or invalid state found during a substep; the message names frame, substep, particle and field.
class SimulationError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// A run that would exceed a limit (the substeps a frame may take, the grid's coordinate range): not a
/// blow-up, so it is not retried. The message names the cause and what to change.
class LimitExceeded : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Thrown at a substep boundary when a stop was asked for (Simulation::setStopRequest): the state is
/// consistent, and a checkpoint of it resumes exactly.
class Interrupted : public std::runtime_error {
public:
    Interrupted() : std::runtime_error("interrupted") {}
};

class StabilityGuard {
public:
    /// gravity and dx set the energy floor of a body at rest: its weight over one cell.
    StabilityGuard(const StabilitySettings& settings, double gravity, double dx)
        : settings_(settings), gravity_(gravity), dx_(dx) {}

    const StabilitySettings& settings() const { return settings_; }
    /// The ranks the run is spread over: the particle a failure names is the one one process would name.
    void setComm(const Comm* comm) { comm_ = comm; }
    /// Factor on the CFL step: 1, halved on each retry of the current frame.
    double stepScale() const { return stepScale_; }

    /// After G2P, with the state's bounds already those G2P found; cflBefore and cflAfter are the CFL steps
    /// from the bounds before and after.
    void checkSubstep(const SimState& state, const G2PSummary& g2p, double dt, double dx, double cflBefore,
                      double cflAfter) const;

    /// Energy is checked inside a frame every kEnergyCheckInterval substeps (frame ends always).
    bool energyCheckDue(long long substeps) const { return settings_.energyGrowth > 0.0 && substeps % kEnergyCheckInterval == 0; }
    /// Starts the growth reference anew (at the first frame, and after an emission brought new energy).
    void resetEnergyReference(EnergyReference& ref, const FrameStats& st) const;
    /// Updates the reference with st; throws when the energy rose past the limit without external work.
    void checkEnergy(SimState& state, const FrameStats& st) const;

    /// Runs attempt() (a frame's substeps and checks). When it throws SimulationError and retries are left,
    /// restores `state` to what it was before and runs it again with half the step. Returns the retries used.
    /// An interruption inside a frame that could be retried restores the frame's start too, so that a
    /// checkpoint of the state replays the frame exactly (retries included).
    template <class F>
    int withRetries(SimState& state, F&& attempt) {
        std::optional<SimState> snapshot;
        if (settings_.retries > 0) snapshot = state;
        for (int retries = 0;; ++retries) {
            try {
                attempt();
                stepScale_ = 1.0;
                return retries;
            } catch (const Interrupted&) {
                if (snapshot) state = *snapshot;
                stepScale_ = 1.0;
                throw;
            } catch (const SimulationError&) {
                if (retries >= settings_.retries) {
                    stepScale_ = 1.0;
                    throw;
                }
                state = *snapshot;
                stepScale_ *= 0.5;
                ++state.retries;
            }
        }
    }

private:
    /// Measuring costs about a tenth of a substep for solids (an SVD per particle), so checking every 50
    /// substeps keeps it near 0.2%.
    static constexpr long long kEnergyCheckInterval = 50;

    StabilitySettings settings_;
    double gravity_, dx_;
    const Comm* comm_ = &Comm::single();
    double stepScale_ = 1.0;
    /// Each species' energy when the reference's minimum was last taken, so that a blow-up names the set that
    /// gained most (only for the message: a resumed run starts without it and names the fastest particle).
    mutable std::vector<double> speciesEnergyAtMin_;
};

/// Throws SimulationError: "<cause> in frame F (substep S of the run, t = T s[, dt = DT s]): particle id I of set NAME".
[[noreturn]] void failAt(const SimState& state, const std::string& cause, int species, int32_t id, double dt);

}  // namespace mpm
