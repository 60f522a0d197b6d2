#pragma once
// The explicit MPM driver: species, colliders and emitters around a sparse grid, advanced substep by
// substep (ALGORITHM.md, "One explicit step") with frames ending exactly on frame times.
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <cstddef>
#include <vector>

#include "core/Collider.h"
#include "core/Diagnostics.h"
#include "core/Species.h"
#include "sparse/SparseGrid.h"
#include "sparse/Transfer.h"

namespace mpm {

/// Blow-up detection (ALGORITHM.md, "Stability"). A check that fires stops the run with its cause, frame,
/// substep and particle, or, with retries > 0, restarts the frame from its start with half the time step.
struct StabilitySettings {
    bool cellCrossing = true;   ///< a particle moving more than one cell in a substep breaks the stencil
    /// Total energy (kinetic + stored + gravity) may not rise above its lowest value since the last emission
    /// by more than this fraction of the largest kinetic + stored energy seen; 0 = off. Colliders are static
    /// and dissipative, so without emission nothing does positive work.
    double energyGrowth = 0.5;
    /// The CFL step may not shrink by more than this factor in one substep (a crushed material or a flung
    /// particle makes the step collapse and the run stall); 0 = off.
    double stepCollapse = 100.0;
    int retries = 0;            ///< restarts of a failed frame, each halving the time step; 0 = stop at once
};

struct SimulationSettings {
    double dx = 0.02;                         ///< grid spacing [m]
    Vec3d gravity = Vec3d(0.0, -9.81, 0.0);   ///< Y is up, as in Houdini [m/s^2]
    TransferSettings transfer;
    double fps = 24.0;
    int substepsPerFrame = 20;                ///< target dt = 1 / (fps * substepsPerFrame)
    bool adaptive = true;                     ///< also bound dt by the CFL condition
    double cfl = 0.5;                         ///< C in dt <= C dx / (c + |v|max)
    double maxDisplacement = 0.0;             ///< thesis rule: max node displacement per substep in cells; 0 = off
    StabilitySettings stability;

    double targetDt() const { return 1.0 / (fps * substepsPerFrame); }
};

/// A particle set that emits copies of a sampled shape at frame starts (thesis section 6.2).
struct Emitter {
    int species = 0;
    uint16_t set = 0;
    std::vector<Vec3d> positions;
    Vec3f velocity = Vec3f::Zero();
    float mass = 0.0f, volume = 0.0f;  ///< per particle
    int startFrame = 0;
    int durationFrames = 1;            ///< emissions happen in [startFrame, startFrame + durationFrames)
    int pauseFrames = 0;               ///< frames skipped between two emissions

    bool emitsAt(int frame) const {
        return frame >= startFrame && frame < startFrame + durationFrames && (frame - startFrame) % (pauseFrames + 1) == 0;
    }
};

/// Wall seconds spent in each phase of the substeps since the last reset (bench/ reports their shares).
/// The deformation update and return mapping run fused inside G2P, so their cost is part of g2p.
struct PhaseSeconds {
    double topology = 0.0;  ///< leaf set, release and neighbour tables
    double binning = 0.0;   ///< counting sort by leaf and the permutation of particle arrays
    double p2g = 0.0;       ///< grid clear and particle-to-grid scatter, stress included
    double grid = 0.0;      ///< grid velocity update, gravity and colliders
    double g2p = 0.0;       ///< grid-to-particle gather, deformation update, advection
    double other = 0.0;     ///< time step, stability checks
    double total() const { return topology + binning + p2g + grid + g2p + other; }
};

/// Grid update (thesis 3.20, 3.26, section 5): v = (mv) / m plus dt g on nodes with mass, then the
/// colliders at time tEnd. Returns the largest node speed.
float updateGridVelocities(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders,
                           const Vec3f& gravity, float dt, double tEnd);

/// A blow-up or invalid state found during a substep; the message names frame, substep, particle and field.
class SimulationError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

class Simulation {
public:
    explicit Simulation(const SimulationSettings& settings);

    const SimulationSettings& settings() const { return settings_; }
    int addSpecies(AnySpecies species);
    /// Appends particles at rest state (F = I, J = 1, C = 0) and gives them fresh ids.
    void addParticles(int species, const std::vector<Vec3d>& x, const Vec3f& v, float mass, float volume, uint16_t set);
    void addCollider(std::unique_ptr<Collider> c) { colliders_.push_back(std::move(c)); }
    void addEmitter(Emitter e) { emitters_.push_back(std::move(e)); }

    /// Emits the particle sets due at the current frame, once.
    void emitDue();
    /// Runs substeps to the next frame time, then emits what is due there. Returns that frame's stats.
    /// Throws SimulationError when a stability check fires and no retry is left.
    FrameStats advanceFrame();
    /// One substep no longer than dtMax (and the CFL bound); returns the step taken.
    double substep(double dtMax);

    /// dt (c + |v|max + |g| dt) <= C dx, i.e. C dx / (c + |v|max) without gravity: c from the stiffest
    /// species, |v|max from the last G2P, |g| dt the speed gravity adds during the step.
    double cflTimeStep() const;
    /// Call after writing particle velocities directly, so that the next CFL step sees them.
    void refreshSpeedBound();
    FrameStats measure() const;

    std::vector<AnySpecies>& species() { return species_; }
    const std::vector<AnySpecies>& species() const { return species_; }
    const SparseGrid& grid() const { return grid_; }
    double time() const { return time_; }
    int frame() const { return frame_; }
    long long substepCount() const { return substeps_; }
    int retryCount() const { return retriesTotal_; }
    std::size_t particleCount() const;
    float kernelInertiaScale() const;
    const PhaseSeconds& phaseSeconds() const { return phases_; }
    void resetPhaseSeconds() { phases_ = PhaseSeconds(); }

private:
    struct Snapshot;
    int runFrameSubsteps();
    void checkEnergy(const FrameStats& st);
    void resetEnergyReference(const FrameStats& st);
    [[noreturn]] void fail(const std::string& cause, int species, std::size_t particle, double dt) const;
    std::pair<int, std::size_t> fastestParticle() const;
    std::pair<int, std::size_t> stiffestParticle() const;
    float volumeRatioOf(int species, std::size_t i) const;
    void bin();
    float updateGrid(float dt);
    template <class S> void permute(S& species, const std::vector<uint32_t>& destination);

    SimulationSettings settings_;
    SparseGrid grid_;
    std::vector<AnySpecies> species_;
    std::vector<std::unique_ptr<Collider>> colliders_;
    std::vector<Emitter> emitters_;
    std::vector<std::vector<uint32_t>> destination_;
    std::vector<float> minStiffnessKey_;
    float maxSpeed_ = 0.0f;
    double time_ = 0.0;
    int frame_ = 0;
    int emittedFrame_ = -1;
    long long substeps_ = 0;
    int32_t nextId_ = 0;
    double dtScale_ = 1.0;          ///< halved on each retry of the current frame
    int retriesTotal_ = 0;
    PhaseSeconds phases_;
    bool energyReferenceSet_ = false;
    double energyMin_ = 0.0;        ///< lowest total energy since the last emission
    double energyScale_ = 0.0;      ///< largest kinetic + stored energy seen
    std::vector<std::byte> scratch_;  ///< permutation buffer, shared by every particle array
};

}  // namespace mpm
