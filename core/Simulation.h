#pragma once
// The explicit MPM driver (docs/method.md, "One substep"): species, colliders and emitters around a sparse
// grid, advanced substep by substep with frames ending exactly on frame times. What it holds, apart:
//  - the model: settings, colliders and emitters, fixed for the run;
//  - the state (core/SimState.h): where the run is, one value that a retry copies and a checkpoint writes;
//  - the step caches: the grid, the sort permutations, the permutation buffer, rebuilt from the state;
//  - the stability guard (core/Stability.h) and the phase timings.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/Collider.h"
#include "core/Comm.h"
#include "core/Diagnostics.h"
#include "core/GridUpdate.h"
#include "core/Settings.h"
#include "core/SimState.h"
#include "core/Species.h"
#include "core/Stability.h"
#include "core/Transfer.h"
#include "sparse/SparseGrid.h"

namespace mpm {

/// A particle set that emits copies of a sampled shape at frame starts (thesis section 6.2).
struct Emitter {
    int species = 0;
    uint16_t set = 0;
    std::vector<Vec3d> positions;
    Vec3f velocity = Vec3f::Zero();
    std::vector<Vec3f> velocities;  ///< per particle, added to `velocity` (a point cloud's); empty: none
    /// The set's velocity gradient: its particles' APIC affine velocity C. A set spinning at w about a pivot moves
    /// as v = w x (x - pivot), whose gradient is [w]x: without it C starts at zero and the first transfer loses the
    /// spin's share that C carries (a sphere spun at 10 rad/s turned at 9.53).
    Mat3f affine = Mat3f::Zero();
    float mass = 0.0f, volume = 0.0f;    ///< per particle
    std::vector<float> masses, volumes;  ///< particle by particle (a point cloud's), instead of mass, volume; empty: none
    /// Material parameters particle by particle, for a species that has them (Species::perParticle).
    std::optional<AnyParamsArray> local;
    int startFrame = 0;
    int durationFrames = 1;  ///< emissions happen in [startFrame, startFrame + durationFrames)
    int pauseFrames = 0;     ///< frames skipped between two emissions
    /// A continuous source: layers of particles entering through a surface at `speed` along `normal`, one
    /// layer every `spacing` of flow, alternating between two staggered patterns (positions on the surface).
    struct Stream {
        Vec3d normal = Vec3d::UnitY();
        double speed = 0.0, spacing = 0.0;
        std::vector<Vec3d> layers[2];
    };
    bool continuous = false;
    Stream stream;

    bool emitsAt(int frame) const {
        return !continuous && frame >= startFrame && frame < startFrame + durationFrames &&
               (frame - startFrame) % (pauseFrames + 1) == 0;
    }
    /// The last frame it emits at (startFrame - 1 when it never does, a stream included).
    int lastEmission() const {
        if (continuous || durationFrames <= 0) return startFrame - 1;
        return startFrame + (durationFrames - 1) / (pauseFrames + 1) * (pauseFrames + 1);
    }
    bool released = false;  ///< its particles' arrays were freed after its last emission
    /// On ranks a set's samples are shared out: `positions` (and the arrays beside it) are then samples
    /// [first, first + positions.size()) of the set's `total`, and each rank emits its part (the particles
    /// then move to their leaves' owners). total < 0: this emitter holds the whole set.
    long long first = 0, total = -1;
    bool holdsPart() const { return total >= 0; }
};

/// Wall seconds spent in each phase of the substeps since the last reset (bench/ reports their shares).
/// The deformation update and return mapping run fused inside G2P, so their cost is part of g2p.
struct PhaseSeconds {
    double topology = 0.0;       ///< leaf set, release and neighbour tables
    double binning = 0.0;        ///< counting sort by leaf and the permutation of particle arrays
    double p2g = 0.0;            ///< grid clear and particle-to-grid scatter, stress included
    double grid = 0.0;           ///< grid velocity update, gravity and colliders
    double g2p = 0.0;            ///< grid-to-particle gather, deformation update, advection
    double other = 0.0;          ///< time step, stability checks
    double communication = 0.0;  ///< ranks: particles moving between ranks, halos, ghost velocities, global sums
    double total() const { return topology + binning + p2g + grid + g2p + other + communication; }
};

/// Books the wall time of its scope to one phase, less what the ranks' exchanges inside it booked as communication,
/// so that each second is counted once.
class PhaseTimer {
public:
    PhaseTimer(double& phase, const double& communication)
        : phase_(phase), communication_(communication), before_(communication), start_(std::chrono::steady_clock::now()) {}
    PhaseTimer(const PhaseTimer&) = delete;
    PhaseTimer& operator=(const PhaseTimer&) = delete;
    ~PhaseTimer() {
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
        phase_ += seconds - (communication_ - before_);
    }

private:
    double& phase_;
    const double& communication_;
    double before_;
    std::chrono::steady_clock::time_point start_;
};

class Simulation {
public:
    explicit Simulation(const SimulationSettings& settings);

    const SimulationSettings& settings() const { return settings_; }
    /// `body` picks the velocity field the species scatters into under ContactModel::MultiField (bodies are
    /// numbered from 0 without gaps); with one field every species shares field 0.
    int addSpecies(AnySpecies species, int body = 0);
    /// Appends particles at rest state (F = I, J = 1, C = 0) and gives them fresh ids.
    /// `perParticle`, when not empty, is added to v particle by particle; `masses` and `volumes`, when not
    /// empty, replace mass and volume particle by particle. A species with parameters per particle takes
    /// them from `local` (one per particle), and only such a species.
    void addParticles(int species, const std::vector<Vec3d>& x, const Vec3f& v, float mass, float volume, uint16_t set,
                      const std::vector<Vec3f>& perParticle = {}, const std::vector<float>& masses = {},
                      const std::vector<float>& volumes = {}, const AnyParamsArray* local = nullptr);
    void addCollider(std::unique_ptr<Collider> c) { colliders_.push_back(std::move(c)); }
    /// A rigid body the material moves (core/RigidBody.h): `c` must move by Motion::dynamic(frame), which this
    /// simulation poses before each substep's collider passes. It starts in `initial`.
    void addBody(std::unique_ptr<Collider> c, const RigidBodyModel& model, std::shared_ptr<BodyFrame> frame,
                 const RigidBodyState& initial);
    /// The dynamic bodies, in collider order: which collider each is, and what it is.
    struct Body {
        std::size_t collider;
        RigidBodyModel model;
        std::shared_ptr<BodyFrame> frame;
    };
    const std::vector<Body>& bodies() const { return bodies_; }
    /// An outside rigid-body solver in place of the built-in one (gravity, the material's impulses, contact with the
    /// fixed colliders): after each substep it gets, for each body, the substep, the impulse and the angular impulse
    /// (about the centre of mass, world axes) the material gave the body in it, and the body's state, already moved
    /// to the pose that substep used with its velocities as before; it sets the velocities (and may set the pose)
    /// the next substep starts from, which moves the body by them first. The body's energy change is booked as
    /// work, as the built-in solver's is.
    using BodyDriver = std::function<void(std::size_t body, double dt, const Vec3d& impulse, const Vec3d& angularImpulse,
                                          RigidBodyState& state)>;
    void setBodyDriver(BodyDriver driver) { bodyDriver_ = std::move(driver); }
    void addEmitter(Emitter e) {
        emitters_.push_back(std::move(e));
        state_.streamFlow.push_back(0.0);
        state_.streamLayers.push_back(0);
    }

    /// Emits the particle sets due at the current frame, once.
    void emitDue();
    /// Emits the layers of continuous sources that entered during the substep [t0, t1].
    void emitStreams(double t0, double t1);
    /// Runs substeps to the next frame time, then emits what is due there. Returns that frame's stats.
    /// Throws SimulationError when a stability check fires and no retry is left.
    FrameStats advanceFrame();
    /// One substep no longer than dtMax (and the CFL bound); returns the step taken.
    double substep(double dtMax);
    /// While *flag is nonzero, advanceFrame stops at the next substep boundary by throwing Interrupted.
    void setStopRequest(const std::atomic<int>* flag) { stop_ = flag; }

    /// dt (c + |v|max + |g| dt) <= C dx, i.e. C dx / (c + |v|max) without gravity: c from the stiffest
    /// species, |v|max from the last G2P, |g| dt the speed gravity adds during the step.
    double cflTimeStep() const;
    /// The thesis's displacement rule at the fastest particle: max_displacement cells a substep (infinite when off).
    double displacementTimeStep() const;
    /// What bounds the next step: its length and, in words, which rule set it (the target, or the CFL bound
    /// from which species' wave speed or the fastest particle).
    struct StepBound {
        double dt;
        std::string cause;
        std::string limit;  ///< the rule in short, as stats.csv's step_limit writes it (FrameStats::stepLimit)
    };
    /// withCause false leaves `cause` empty (each substep keeps only the short limit; the watchdog's error
    /// asks for the words).
    StepBound stepBound(bool withCause = true) const;
    /// Call after writing particle velocities directly, so that the next CFL step sees them.
    void refreshSpeedBound();
    /// Replaces every particle's velocity (species after species, in storage order), as a user's script does
    /// between frames: the kinetic energy it adds or removes is booked as external work, so the energy check
    /// holds, and the CFL bound sees the new speeds.
    void setVelocities(const std::vector<Vec3f>& v);
    FrameStats measure() const;

    /// Where the run is, whole (checkpoints write it; see core/SimState.h).
    const SimState& state() const { return state_; }
    /// Continues from a state this simulation's model produced (same species, in the same order). `share`: on
    /// one rank of several, the state holds only some of the run's particles (the parts of a checkpoint written
    /// per rank that this rank read; the other ranks hold the rest), and distribute() cuts from every rank's.
    void restore(SimState state, bool share = false);

    std::vector<AnySpecies>& species() { return state_.species; }
    const std::vector<AnySpecies>& species() const { return state_.species; }
    const std::vector<std::unique_ptr<Collider>>& colliders() const { return colliders_; }
    const std::vector<Emitter>& emitters() const { return emitters_; }
    /// The first velocity field (the only one unless bodies have fields of their own).
    const SparseGrid& grid() const { return fields_.front(); }
    /// Every velocity field: one per body under ContactModel::MultiField, else one.
    const std::vector<SparseGrid>& fields() const { return fields_; }
    double time() const { return state_.time; }
    int frame() const { return state_.frame; }
    long long substepCount() const { return state_.substeps; }
    int retryCount() const { return state_.retries; }
    /// Particles held here (on one rank of several: that rank's share).
    std::size_t particleCount() const;
    /// Particles of the whole run, over every rank.
    std::size_t totalParticleCount() const;

    /// Spreads the run over the ranks of `comm` (docs/distributed.md). Every rank built the same model and
    /// holds the same particles (a scene built, or a checkpoint restored, on each), or a share of them (restore
    /// with `share`); each then keeps only the particles of the leaves it owns, and receives those of its leaves
    /// another rank held. The leaves, in Morton order, are cut into ranges of equal particle counts. With one
    /// rank this changes nothing.
    void distribute(const Comm& comm);
    const Comm& comm() const { return *comm_; }
    /// Every particle of the run on rank 0, species by species in the order one process would hold them
    /// (elsewhere empty species). One process: a copy of the species. Collective.
    std::vector<AnySpecies> gatherSpecies() const;
    /// The state with every particle (gatherSpecies), on rank 0: what a checkpoint of the run holds. Collective.
    SimState gatherState();
    /// Times the ranks re-cut their leaves since the start of this process.
    int rebalanceCount() const { return rebalances_; }
    /// Leaves this rank holds as ghosts of other ranks' (0 on one process).
    std::size_t ghostLeafCount() const {
        std::size_t n = 0;
        if (partitioned_)
            for (const RankLeaves& f : rankLeaves_)
                n += f.owned.size() - std::size_t(std::count(f.owned.begin(), f.owned.end(), uint8_t(1)));
        return n;
    }
    /// The rank owning a leaf (by leaf coordinate).
    int ownerOf(const Vec3i& leafCoord) const;
    /// The leaf a particle at x belongs to: its base node's (the same in every field).
    Vec3i particleLeaf(const Vec3d& x) const { return leafOfNode(fields_[0].baseNode(x)); }
    float kernelInertiaScale() const;
    const PhaseSeconds& phaseSeconds() const { return phases_; }
    void resetPhaseSeconds() { phases_ = PhaseSeconds(); }

private:
    /// One velocity field's leaves on ranks: whose they are, and the ghost leaves each side of every rank pair.
    struct RankLeaves {
        std::vector<uint8_t> owned;                      ///< per leaf of the field: owned by this rank
        std::vector<std::vector<uint32_t>> ghostsFrom;   ///< per rank: this rank's ghost leaves that rank owns
        std::vector<std::vector<uint32_t>> ghostsFor;    ///< per rank: owned leaves that rank holds as ghosts
        std::vector<std::vector<Vec3i>> ghostCoordsFor;  ///< the same by leaf coordinate, as that rank sent them
        std::vector<std::vector<NodeBox>> ghostBoxFor;   ///< per rank and ghost leaf: the nodes that rank's halo parts wrote
    };
    void runFrameSubsteps();
    // Ranks (docs/distributed.md): the cut of the leaves, particles moving to their leaf's owner, the leaves
    // other ranks' stencils reach, and the ghost leaves' velocities after the grid update.
    void cutLeaves(const std::vector<std::pair<Vec3i, long long>>& leafCounts);
    std::vector<std::pair<Vec3i, long long>> particlesPerLeaf() const;
    /// Every rank's particlesPerLeaf, merged (the same on every rank). Collective.
    std::vector<std::pair<Vec3i, long long>> allParticlesPerLeaf() const { return mergedOverRanks(particlesPerLeaf()); }
    /// Every rank's leaf counts added up, in Morton order (the same on every rank). Collective.
    std::vector<std::pair<Vec3i, long long>> mergedOverRanks(const std::vector<std::pair<Vec3i, long long>>& mine) const;
    /// Emits a rank's part of a set (Emitter::holdsPart) with the ids one process gives them; once the leaves
    /// are cut, the particles outside this rank's leaves go to their owners at once. Collective.
    void emitPart(const Emitter& e);
    /// Sends the particles of species s from index `from` on to their leaves' owners. Collective.
    void sendEmittedToOwners(int s, std::size_t from);
    void rebalanceIfNeeded();
    void migrateParticles();
    void exchangeReachedLeaves(SparseGrid& grid, RankLeaves& leaves);
    /// Which of a field's leaves are this rank's, and its ghost leaves each side of every rank pair, in leaf order.
    void ownLeaves(const SparseGrid& grid, RankLeaves& leaves) const;
    void sendGhostVelocities(SparseGrid& grid, const RankLeaves& leaves);
    /// The mass and velocity of nodes other ranks own, from their owners (the mirror pass). Collective.
    void fetchNodes(const SparseGrid& grid, const std::vector<Vec3i>& nodes, std::vector<float>& mass,
                    std::vector<Vec3f>& velocity);
    /// Globalises a G2P summary: extremes over ranks, and the bad particle one process would report first.
    void reduceSummary(G2PSummary& g2p) const;
    StepBound lastBound_{0.0, "", ""};  ///< what set the latest substep's step (stats only, not state)
    void checkCoordinates() const;
    void bin();
    GridUpdateResult updateGrid(float dt);
    /// The wall-contact test of this substep (none unless simulation.wall_contact is "surface").
    /// The `separate` walls' contact test for field f (SurfaceContact): the rest density of its leaves' material.
    SurfaceContact surfaceContact(std::size_t field);
    /// P2G, G2P and the particle pass of the colliders, field by field.
    void particlesToGrid(float dt);
    G2PSummary gridToParticles(float dt);
    ProjectionSummary holdOutOfColliders(float dt);
    /// Runs fn (a phase of the substep), booking its wall time to `phase` (PhaseTimer).
    template <class Fn>
    decltype(auto) timed(double& phase, Fn&& fn) {
        const PhaseTimer timer(phase, phases_.communication);
        return fn();
    }
    /// Runs fn (an exchange between ranks), booking its wall time as communication.
    template <class Fn>
    decltype(auto) communicating(Fn&& fn) {
        return timed(phases_.communication, std::forward<Fn>(fn));
    }
    /// The ranks' halo exchange of field f's P2G (ghost leaves' parts to their owners).
    RemoteHalos remoteHalos(std::size_t f);
    /// Poses every dynamic body where its velocities take it in a step dt, for the step's collider passes.
    void poseBodies(double dt);
    /// Moves the bodies through the step, then changes their velocities by gravity and what the material took from
    /// them (the nodes' and the particles' impulses, summed over ranks). Their energy change is booked as the energy check's
    /// external work, so material and bodies are checked as one system.
    /// Returns the speed of the bodies' fastest point, which bounds the next step as the particles' speed does.
    float moveBodies(double dt, const std::vector<BodyImpulse>& nodes, const std::vector<BodyImpulse>& particles);
    template <class S>
    void permute(S& species, const std::vector<uint32_t>& destination);
    /// addParticles' second half: appends the particles (already those this rank keeps) with the given ids.
    /// Gives the particles of emitter e appended from index `from` of its species its affine velocity.
    void setAffine(const Emitter& e, std::size_t from);
    void appendParticles(int species, const std::vector<Vec3d>& x, const Vec3f& v, float mass, float volume, uint16_t set,
                         const std::vector<Vec3f>& perParticle, const std::vector<float>& masses,
                         const std::vector<float>& volumes, const std::vector<int32_t>& ids, const AnyParamsArray* local);
    /// Calls fn(grid, species) for field f with the species that scatter into it, in species order (with one
    /// field, all of them in place; otherwise they are moved into a scratch list and back, pointers only).
    template <class Fn>
    void withField(std::size_t f, Fn&& fn);

    // The model.
    SimulationSettings settings_;
    std::vector<std::unique_ptr<Collider>> colliders_;
    std::vector<Body> bodies_;
    std::vector<Emitter> emitters_;
    // The state.
    SimState state_;
    // Step caches, rebuilt from the state every substep.
    std::vector<SparseGrid> fields_;                ///< velocity fields: one, or one per body
    std::vector<std::vector<int>> fieldSpecies_;    ///< per field, its species
    std::vector<AnySpecies> fieldScratch_;          ///< a field's species while its transfers run
    double restDensity_ = 0.0;                      ///< of all particles, for SurfaceContact
    bool densitiesDiffer_ = false;                  ///< whether the species' rest densities differ
    std::vector<std::vector<float>> leafCellMass_;  ///< per field and leaf, where they differ: rest density times dx^3
    /// Per species: whether it has particles anywhere (on any rank); particles are never removed, so this is
    /// set by emission and restore alone, on every rank alike.
    std::vector<uint8_t> populated_;
    std::vector<std::vector<uint32_t>> destination_;  ///< per species: sorted slot of each particle
    std::vector<std::byte> scratch_;                  ///< permutation buffer, shared by every particle array
    // Policy and timings.
    StabilityGuard guard_;
    PhaseSeconds phases_;
    const std::atomic<int>* stop_ = nullptr;
    BodyDriver bodyDriver_;
    // Ranks.
    const Comm* comm_;
    std::vector<Vec3i> splitters_;  ///< leaf coordinate where rank r + 1's range starts (Morton order)
    bool partitioned_ = false;
    bool holdsShare_ = false;             ///< restored from checkpoint parts: distribute() merges every rank's counts
    std::vector<RankLeaves> rankLeaves_;  ///< per field
    std::vector<int> ownerScratch_;       ///< migration: the owner of each particle's leaf
    int rebalances_ = 0;
    double cutImbalance_ = 0.0;        ///< how far above the mean the last cut left the most loaded rank
    int32_t restDensityVersion_ = -1;  ///< nextId when the rest density was measured (the same on every rank)
};

}  // namespace mpm
