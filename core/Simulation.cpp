#include "core/Simulation.h"
// The coordinator: a frame cut into substeps, the substep in the algorithm's order (bin, P2G, grid update, G2P,
// particle pass, bodies, checks, emission), binning, restore and the frame's measurements. Beside it:
// core/SimulationStep.cpp (the step policy), core/SimulationEmission.cpp (emission), core/SimulationColliders.cpp
// (walls' contact test, rigid bodies) and core/SimulationRanks.cpp (what the ranks add).

#include "sparse/LeafLookup.h"
#include "sparse/LeafParallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>
#include <type_traits>

#include "core/FloatingPoint.h"
#include "core/GridUpdate.h"
#include "core/MultiField.h"

namespace mpm {

namespace {
constexpr std::size_t kPermuteGrain = 16384;
/// Relative slack when splitting the rest of a frame into equal substeps.
constexpr double kFrameSplitSlack = 1e-9;

/// The energy check, with the rigid bodies' kinetic energy in its scale beside the material's: bodies colliding far
/// from material at rest (no gravity) tripped it on round-off against a scale of zero.
template <class Bodies>
void checkEnergy(SimState& state, const Bodies& bodies, const StabilityGuard& guard, const FrameStats& st) {
    double moving = 0.0;
    for (std::size_t k = 0; k < bodies.size(); ++k) {
        const RigidBodyState& s = state.bodies[k];
        const RigidBodyModel& m = bodies[k].model;
        moving += 0.5 * m.mass * s.velocity.squaredNorm() + 0.5 * s.spin.dot(m.worldInertia(s.orientation) * s.spin);
    }
    state.energy.scale = std::max(state.energy.scale, st.kineticEnergy + st.elasticEnergy + moving);
    guard.checkEnergy(state, st);
}
}  // namespace

Simulation::Simulation(const SimulationSettings& settings)
    : settings_(settings), guard_(settings.stability, settings.gravity.norm(), settings.dx), comm_(&Comm::single()) {
    fields_.resize(1);
    fieldSpecies_.resize(1);
    withKernel(settings_.transfer.interpolation,
               [&]<class K>() { fields_[0].configure(settings_.dx, K::kBaseShift, K::kWidth); });
}

float Simulation::kernelInertiaScale() const {
    return withKernel(settings_.transfer.interpolation, []<class K>() { return 1.0f / K::kInverseInertia; });
}
/// Whether a species' particles have parameters of their own (Species::perParticle).
static bool hasParticleParams(const AnySpecies& s) {
    return std::visit([](const auto& sp) { return sp.perParticle; }, s);
}

void Simulation::restore(SimState state, bool share) {
    if (state.streamFlow.size() != emitters_.size() || state.streamLayers.size() != emitters_.size())
        throw std::invalid_argument("restore: the state has " + std::to_string(state.streamFlow.size()) +
                                    " emitters' progress, the simulation " + std::to_string(emitters_.size()) + " emitters");
    if (state.species.size() != state_.species.size())
        throw std::invalid_argument("restore: the state has " + std::to_string(state.species.size()) +
                                    " species, the simulation " + std::to_string(state_.species.size()));
    for (std::size_t s = 0; s < state.species.size(); ++s) {
        if (state.species[s].index() != state_.species[s].index())
            throw std::invalid_argument("restore: species " + std::to_string(s) + " has another material");
        if (hasParticleParams(state.species[s]) != hasParticleParams(state_.species[s]))
            throw std::invalid_argument("restore: species " + std::to_string(s) +
                                        (hasParticleParams(state.species[s])
                                             ? " has parameters per particle, which the scene does not give"
                                             : " has no parameters per particle, which the scene gives"));
    }
    for (const Emitter& e : emitters_)
        if (e.released && state.emittedFrame < e.lastEmission())
            throw std::logic_error("restore: an emitter whose samples were released would emit again; restore before emitting");
    if (state.bodies.size() != bodies_.size())
        throw std::invalid_argument("restore: the state has " + std::to_string(state.bodies.size()) +
                                    " rigid bodies, the simulation " + std::to_string(bodies_.size()));
    state_ = std::move(state);
    poseBodies(0.0);
    for (std::size_t s = 0; s < state_.species.size(); ++s) populated_[s] = particlesOf(state_.species[s]).size() > 0;
    restDensityVersion_ = -1;
    partitioned_ = false;  // every rank holds the whole state (or its share) again: distribute() cuts it anew
    holdsShare_ = share;
}

std::size_t Simulation::particleCount() const {
    std::size_t n = 0;
    for (const AnySpecies& s : state_.species) n += particlesOf(s).size();
    return n;
}

std::size_t Simulation::totalParticleCount() const { return std::size_t(comm_->sum((long long)particleCount())); }
void Simulation::checkCoordinates() const {
    const double limit = kMaxGridCoordinate * settings_.dx;
    for (std::size_t s = 0; s < state_.species.size(); ++s) {
        const ParticleArrays& P = particlesOf(state_.species[s]);
        const std::size_t far = tbb::parallel_reduce(
            tbb::blocked_range<std::size_t>(0, P.size(), kPermuteGrain), P.size(),
            [&](const auto& r, std::size_t found) {
                for (std::size_t i = r.begin(); i < r.end() && found == P.size(); ++i)
                    if (!(P.x[i].cwiseAbs().maxCoeff() < limit)) found = i;
                return found;
            },
            [](std::size_t a, std::size_t b) { return std::min(a, b); });
        // The first rank with one reports it (one process reports the first in storage order: rank order).
        const int reporter = comm_->firstRank(far < P.size());
        if (reporter >= comm_->size()) continue;
        if (comm_->rank() != reporter) {
            const Bytes text = comm_->broadcast({}, reporter);
            throw LimitExceeded(std::string(reinterpret_cast<const char*>(text.data()), text.size()));
        }
        std::ostringstream msg;
        msg << "particle id " << P.id[far] << " of set " << std::visit([](const auto& sp) { return sp.name; }, state_.species[s])
            << " is at (" << P.x[far].transpose() << ") m in frame " << state_.frame + 1
            << ", beyond the grid's coordinate range of +-" << limit << " m (2^30 cells of dx = " << settings_.dx
            << " m); keep the scene nearer the origin or use a larger dx";
        const std::string text = msg.str();
        Bytes b(text.size());
        std::memcpy(b.data(), text.data(), text.size());
        comm_->broadcast(b, reporter);
        throw LimitExceeded(text);
    }
}

void Simulation::setVelocities(const std::vector<Vec3f>& v) {
    if (v.size() != particleCount()) throw std::invalid_argument("setVelocities: one velocity per particle");
    std::size_t k = 0;
    double added = 0.0;
    for (AnySpecies& s : state_.species) {
        ParticleArrays& P = particlesOf(s);
        for (std::size_t i = 0; i < P.size(); ++i, ++k) {
            added += 0.5 * double(P.mass[i]) * (double(v[k].squaredNorm()) - double(P.v[i].squaredNorm()));
            P.v[i] = v[k];
        }
    }
    state_.energy.work += added;
    refreshSpeedBound();
}
template <class S>
void Simulation::permute(S& sp, const std::vector<uint32_t>& dest) {
    // One byte buffer, sized once for the widest attribute, serves every array in turn: a scratch array
    // per attribute type would cost as much memory as the particles themselves, and growing it in steps
    // would leave the smaller buffers behind in the allocator.
    std::size_t widest = 0;
    sp.forEachArray([&](auto& arr) { widest = std::max(widest, arr.size() * sizeof(arr[0])); });
    if (scratch_.size() < widest) {
        scratch_.clear();
        scratch_.shrink_to_fit();
        scratch_.resize(widest);
    }
    sp.forEachArray([&](auto& arr) {
        using T = typename std::decay_t<decltype(arr)>::value_type;
        static_assert(std::is_trivially_destructible_v<T>, "particle attributes are plain values");
        const std::size_t n = arr.size();
        std::byte* tmp = scratch_.data();
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPermuteGrain), [&](const auto& r) {
            for (std::size_t i = r.begin(); i < r.end(); ++i) std::memcpy(tmp + dest[i] * sizeof(T), &arr[i], sizeof(T));
        });
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kPermuteGrain), [&](const auto& r) {
            std::memcpy(static_cast<void*>(arr.data() + r.begin()), tmp + r.begin() * sizeof(T), r.size() * sizeof(T));
        });
    });
}

template <class Fn>
void Simulation::withField(std::size_t f, Fn&& fn) {
    if (fields_.size() == 1) {
        fn(fields_[0], state_.species);
        return;
    }
    const std::vector<int>& members = fieldSpecies_[f];
    fieldScratch_.clear();
    for (int s : members) fieldScratch_.push_back(std::move(state_.species[s]));
    // Back where they belong whatever fn does (a throw included).
    struct Return {
        Simulation& sim;
        const std::vector<int>& members;
        ~Return() {
            for (std::size_t i = 0; i < members.size(); ++i) sim.state_.species[members[i]] = std::move(sim.fieldScratch_[i]);
        }
    } back{*this, members};
    fn(fields_[f], fieldScratch_);
}

void Simulation::bin() {
    const bool ranks = partitioned_ && comm_->distributed();
    if (ranks)
        communicating([&] {
            rebalanceIfNeeded();
            migrateParticles();
        });
    rankLeaves_.resize(fields_.size());
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            const std::vector<int>& members = fieldSpecies_[f];
            std::vector<BinRequest> requests(species.size());
            for (std::size_t s = 0; s < species.size(); ++s) {
                std::vector<uint32_t>& dest = destination_[fields_.size() == 1 ? s : std::size_t(members[s])];
                std::visit([&](auto& sp) { requests[s] = BinRequest{&sp.p.x, &sp.p.id, &dest, &sp.leafStart}; }, species[s]);
            }
            timed(phases_.topology, [&] {
                grid.collectLeaves(requests);
                RankLeaves& rl = rankLeaves_[f];
                if (ranks) exchangeReachedLeaves(grid, rl);
                grid.allocateLeaves();
                if (ranks) ownLeaves(grid, rl);
            });
            timed(phases_.binning, [&] {
                grid.sortParticles(requests);
                for (std::size_t s = 0; s < species.size(); ++s) {
                    const std::vector<uint32_t>& dest = *requests[s].destination;
                    // Particles rarely change leaf between substeps: skip the permutation when it is the identity.
                    const bool identity = tbb::parallel_reduce(
                        tbb::blocked_range<std::size_t>(0, dest.size(), kPermuteGrain), true,
                        [&](const auto& r, bool ok) {
                            for (std::size_t i = r.begin(); ok && i < r.end(); ++i) ok = dest[i] == i;
                            return ok;
                        },
                        [](bool a, bool b) { return a && b; });
                    if (!identity) std::visit([&](auto& sp) { permute(sp, dest); }, species[s]);
                }
            });
        });
}
GridUpdateResult Simulation::updateGrid(float dt) {
    poseBodies(double(dt));
    for (const auto& c : colliders_) c->prepare(state_.time + dt);
    const Vec3f g = settings_.gravity.cast<float>();
    const double tEnd = state_.time + dt;
    if (leafCellMass_.size() != fields_.size()) leafCellMass_.resize(fields_.size());
    const bool mirror = settings_.wallGhosts == WallGhosts::Mirror;
    const bool ranks = partitioned_ && comm_->distributed();
    const auto owned = [&](std::size_t f) { return ranks ? &rankLeaves_[f].owned : nullptr; };
    // On ranks, the passes that read other leaves' nodes (contact normals, mirror images) read those other
    // ranks own from their owners.
    const auto local = [&](const Vec3i& node) { return ownerOf(leafOfNode(node)) == comm_->rank(); };
    // The remote reads of the mirror passes, field by field.
    const auto remoteNodes = [&](std::size_t f) {
        RemoteNodes remote;
        if (ranks) {
            remote.owned = owned(f);
            remote.local = local;
            remote.fetch = [&, f](const std::vector<Vec3i>& nodes, std::vector<float>& m, std::vector<Vec3f>& v) {
                communicating([&] { fetchNodes(fields_[f], nodes, m, v); });
            };
        }
        return remote;
    };
    // Mirror mode's wall nodes, field by field: the fold before the update and the mirror after share them.
    std::vector<MirrorWalls> walls(mirror ? fields_.size() : 0);
    for (std::size_t f = 0; f < walls.size(); ++f) {
        walls[f] = findMirrorWalls(fields_[f], colliders_, tEnd, owned(f));
        const RemoteNodes remote = remoteNodes(f);
        foldWallImages(fields_[f], walls[f], g, dt, ranks ? &remote : nullptr);
    }
    GridUpdateResult out;
    if (fields_.size() == 1) {
        out = updateGridVelocities(fields_[0], colliders_, g, dt, tEnd, surfaceContact(0), true, owned(0));
    } else {
        // Bodies of their own: velocities in every field, then the contact between them, then the colliders.
        static const std::vector<std::unique_ptr<Collider>> kNone;
        for (std::size_t f = 0; f < fields_.size(); ++f)
            updateGridVelocities(fields_[f], kNone, g, dt, tEnd, SurfaceContact{}, true, owned(f));
        RemoteFields remote;
        if (ranks) {
            for (std::size_t f = 0; f < fields_.size(); ++f) remote.owned.push_back(owned(f));
            remote.local = local;
            remote.fetch = [&](std::size_t f, const std::vector<Vec3i>& nodes, std::vector<float>& m) {
                std::vector<Vec3f> unused;
                communicating([&] { fetchNodes(fields_[f], nodes, m, unused); });
            };
        }
        resolveFieldContact(fields_, settings_.contactFriction, ranks ? &remote : nullptr);
        for (std::size_t f = 0; f < fields_.size(); ++f) {
            const GridUpdateResult r =
                updateGridVelocities(fields_[f], colliders_, g, dt, tEnd, surfaceContact(f), false, owned(f));
            out.maxSpeed = std::max(out.maxSpeed, r.maxSpeed);
            out.work += r.work;
            addBodyImpulses(out.bodies, r.bodies);
        }
    }
    for (std::size_t f = 0; f < walls.size(); ++f) {
        const RemoteNodes remote = remoteNodes(f);
        mirrorGhostNodes(fields_[f], walls[f], dt, ranks ? &remote : nullptr);
    }
    // The mirrored nodes go to their holders with the other ghost velocities.
    if (ranks)
        communicating([&] {
            out.maxSpeed = comm_->max(out.maxSpeed);
            comm_->sum(out.work);
            for (std::size_t f = 0; f < fields_.size(); ++f) sendGhostVelocities(fields_[f], rankLeaves_[f]);
        });
    return out;
}

void Simulation::particlesToGrid(float dt) {
    // On ranks, halo parts for ghost leaves go to their owners; the owners' leaves add every part in order d.
    const bool ranks = partitioned_ && comm_->distributed();
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            const RemoteHalos remote = ranks ? remoteHalos(f) : RemoteHalos{};
            mpm::particlesToGrid(grid, species, settings_.transfer, dt, ranks ? &remote : nullptr);
        });
}

G2PSummary Simulation::gridToParticles(float dt) {
    if (fields_.size() == 1) {
        G2PSummary g2p = mpm::gridToParticles(fields_[0], state_.species, settings_.transfer, dt);
        reduceSummary(g2p);
        return g2p;
    }
    // Field by field, with each field's per-species results put back at the species' own index.
    G2PSummary out;
    out.minStiffnessKey.assign(state_.species.size(), std::numeric_limits<float>::infinity());
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            const G2PSummary r = mpm::gridToParticles(grid, species, settings_.transfer, dt);
            const std::vector<int>& members = fieldSpecies_[f];
            out.maxSpeed = std::max(out.maxSpeed, r.maxSpeed);
            for (std::size_t s = 0; s < members.size(); ++s) out.minStiffnessKey[members[s]] = r.minStiffnessKey[s];
            if (out.badParticle < 0 && r.badParticle >= 0) {
                out.badSpecies = members[r.badSpecies];
                out.badParticle = r.badParticle;
                out.badField = r.badField;
            }
        });
    reduceSummary(out);
    return out;
}

ProjectionSummary Simulation::holdOutOfColliders(float dt) {
    ProjectionSummary out;
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            const ProjectionSummary r = projectOutOfColliders(grid, species, colliders_, state_.time + dt, dt, settings_.gravity);
            out.work += r.work;
            addBodyImpulses(out.bodies, r.bodies);
            out.maxSpeed = std::max(out.maxSpeed, r.maxSpeed);
            out.moved += r.moved;
        });
    if (comm_->distributed() && !colliders_.empty()) {
        comm_->sum(out.work);
        out.maxSpeed = comm_->max(out.maxSpeed);
        out.moved = std::size_t(comm_->sum((long long)out.moved));
    }
    return out;
}

double Simulation::substep(double dtMax) {
    return withSubnormalsFlushed([&] {
        // Bin particles by leaf; allocate the leaves their stencils reach and release the others.
        bin();
        // Time step: the caller's bound (target and frame end), and the CFL condition (halved on retries).
        double dt = std::min(dtMax, cflTimeStep() * guard_.stepScale());
        // P2G: mass and momentum, with the stress impulse of this step folded in (thesis 3.14, 3.15, 3.24).
        timed(phases_.p2g, [&] { particlesToGrid(float(dt)); });
        // Grid update: v = mv/m, gravity, colliders and friction (3.20, 3.26, section 5).
        GridUpdateResult grid = timed(phases_.grid, [&] { return updateGrid(float(dt)); });
        // Thesis pseudocode 3: if a node would move more than maxDisplacement cells, redo with a shorter step.
        if (settings_.maxDisplacement > 0.0 && grid.maxSpeed * dt > settings_.maxDisplacement * settings_.dx) {
            dt = settings_.maxDisplacement * settings_.dx / grid.maxSpeed;
            timed(phases_.p2g, [&] { particlesToGrid(float(dt)); });
            grid = timed(phases_.grid, [&] { return updateGrid(float(dt)); });
        }
        // G2P: velocity, affine velocity, deformation update with return mapping, advection (3.17-3.19, 3.21).
        const G2PSummary g2p = timed(phases_.g2p, [&] { return gridToParticles(float(dt)); });
        // The particle pass: particles found inside a collider (walls thinner than a cell included) go back to its
        // surface.
        const ProjectionSummary held = timed(phases_.g2p, [&] { return holdOutOfColliders(float(dt)); });
        timed(phases_.other, [&] {
            // Work moving colliders did is external: the energy check counts it.
            ExactSum work = grid.work;
            work += held.work;
            state_.energy.work += work.value();
            // Bodies the material moves take what it gained from them (the step the transfers took, in float).
            const float bodySpeed = moveBodies(double(float(dt)), grid.bodies, held.bodies);
            // The bounds the next step starts from, then the blow-up checks: a non-finite value, a particle that
            // outran its stencil, a CFL step that collapsed.
            const double cflBefore = cflTimeStep();
            state_.bounds = StepBounds{std::max({g2p.maxSpeed, held.maxSpeed, bodySpeed}), g2p.minStiffnessKey};
            guard_.checkSubstep(state_, g2p, dt, settings_.dx, cflBefore, cflTimeStep());
            // Streams emit the particles that entered during the step.
            emitStreams(state_.time, state_.time + dt);
            state_.time += dt;
            ++state_.substeps;
        });
        return dt;
    });
}
void Simulation::runFrameSubsteps() {
    const double frameEnd = double(state_.frame + 1) / settings_.fps;
    while (state_.time < frameEnd) {
        // A stop asked for (a signal) is honoured here, between two substeps, where the state is consistent.
        // On several ranks every rank stops at the same substep: a signal reaches them at different times.
        const bool stopAsked = stop_ && stop_->load(std::memory_order_relaxed) != 0;
        if (comm_->max(stopAsked ? 1.0f : 0.0f) > 0.0f) throw Interrupted();
        const double remaining = frameEnd - state_.time;
        // The displacement rule too, so that the frame is cut into substeps it will take (a substep whose nodes
        // still move too far is redone shorter).
        const double dtMax = std::min({settings_.targetDt(), cflTimeStep(), displacementTimeStep()}) * guard_.stepScale();
        // Split the rest of the frame into equal substeps so that the last one lands on the frame time.
        const double pieces = std::max(1.0, std::ceil(remaining / dtMax - kFrameSplitSlack));
        // Watchdog: a frame that would take more substeps than allowed stops here, saying what bounds the step.
        if (double(state_.frameSubsteps) + pieces > double(settings_.maxSubstepsPerFrame)) {
            const StepBound b = stepBound();
            std::ostringstream msg;
            msg << "frame " << state_.frame + 1 << " would need about " << double(state_.frameSubsteps) + pieces
                << " substeps (dt = " << dtMax << " s, set by " << b.cause
                << "); the limit is simulation.max_substeps_per_frame = " << settings_.maxSubstepsPerFrame;
            throw LimitExceeded(msg.str());
        }
        const double dt = remaining / pieces;
        // What sets this step, kept for the frame's stats (the last substep's is the frame's; a retry redoes it).
        StepBound bound = stepBound(false);
        bound.dt = dtMax;
        const double taken = substep(dt);
        if (taken < dt) bound.dt = taken, bound.limit = "max_displacement";
        lastBound_ = std::move(bound);
        ++state_.frameSubsteps;
        if (guard_.energyCheckDue(state_.substeps)) checkEnergy(state_, bodies_, guard_, measure());
        if (pieces == 1.0 && taken == dt) state_.time = frameEnd;
    }
}

FrameStats Simulation::advanceFrame() {
    return withSubnormalsFlushed([&] {
        const auto start = std::chrono::steady_clock::now();
        emitDue();
        if (!state_.energy.set) guard_.resetEnergyReference(state_.energy, measure());
        FrameStats st;
        const int retries = guard_.withRetries(state_, [&] {
            runFrameSubsteps();
            st = measure();
            checkEnergy(state_, bodies_, guard_, st);
        });
        const int steps = state_.frameSubsteps;
        state_.frameSubsteps = 0;
        ++state_.frame;
        checkCoordinates();
        const int32_t before = state_.nextId;
        emitDue();
        if (state_.nextId != before) {
            // New material brings its own energy: measure again and restart the growth reference.
            st = measure();
            guard_.resetEnergyReference(state_.energy, st);
        }
        st.frame = state_.frame;
        st.substeps = steps;
        st.retries = retries;
        st.stepDt = lastBound_.dt;
        st.stepLimit = lastBound_.limit;
        st.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return st;
    });
}

FrameStats Simulation::measure() const {
    return withSubnormalsFlushed([&] {
        ParticleSums sums = sumParticles(state_.species, settings_.dx, kernelInertiaScale(), settings_.gravity);
        std::size_t leaves = 0;
        for (const SparseGrid& field : fields_) leaves += field.leafCount();
        if (comm_->distributed()) {
            for (ExactSum& e : sums.sum) comm_->sum(e);
            for (ExactSum& e : sums.speciesEnergy) comm_->sum(e);
            sums.maxSpeed = comm_->max(sums.maxSpeed);
            sums.minJ = comm_->min(sums.minJ);
            sums.maxJ = comm_->max(sums.maxJ);
            sums.particles = std::size_t(comm_->sum((long long)sums.particles));
            // A leaf counts once, on its owner (the others hold it as a ghost).
            if (partitioned_) {
                leaves = 0;
                for (const RankLeaves& f : rankLeaves_)
                    leaves += std::size_t(std::count(f.owned.begin(), f.owned.end(), uint8_t(1)));
            }
            leaves = std::size_t(comm_->sum((long long)leaves));
        }
        FrameStats st = sums.stats();
        st.frame = state_.frame;
        st.time = state_.time;
        st.bodies = state_.bodies;
        st.activeLeaves = leaves;
        st.gridBytes = leaves * SparseGrid::bytesPerLeaf();
        return st;
    });
}

}  // namespace mpm
