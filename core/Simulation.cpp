#include "core/Simulation.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>
#include <type_traits>

#include "core/GridUpdate.h"
#include "core/MultiField.h"

namespace mpm {

namespace {
constexpr std::size_t kPermuteGrain = 16384;
/// Relative slack when splitting the rest of a frame into equal substeps.
constexpr double kFrameSplitSlack = 1e-9;

/// Adds the seconds since the last lap to a phase total.
class PhaseClock {
public:
    void lap(double& total) {
        const auto now = std::chrono::steady_clock::now();
        total += std::chrono::duration<double>(now - last_).count();
        last_ = now;
    }

private:
    std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};
}  // namespace

Simulation::Simulation(const SimulationSettings& settings)
    : settings_(settings), guard_(settings.stability, settings.gravity.norm(), settings.dx) {
    fields_.resize(1);
    fieldSpecies_.resize(1);
    withKernel(settings_.transfer.interpolation, [&]<class K>() { fields_[0].configure(settings_.dx, K::kBaseShift, K::kWidth); });
}

float Simulation::kernelInertiaScale() const {
    return withKernel(settings_.transfer.interpolation, []<class K>() { return 1.0f / K::kInverseInertia; });
}

int Simulation::addSpecies(AnySpecies species, int body) {
    if (body < 0) throw std::invalid_argument("addSpecies: body " + std::to_string(body) + " is negative");
    const std::size_t field = settings_.contact == ContactModel::MultiField ? std::size_t(body) : 0;
    while (fields_.size() <= field) {
        fields_.emplace_back();
        fields_.back().configure(fields_[0].geometry().dx, fields_[0].geometry().baseShift, fields_[0].geometry().width);
        fieldSpecies_.emplace_back();
    }
    fieldSpecies_[field].push_back(int(state_.species.size()));
    state_.species.push_back(std::move(species));
    state_.bounds.minStiffnessKey.push_back(std::numeric_limits<float>::infinity());
    destination_.emplace_back();
    return int(state_.species.size()) - 1;
}

void Simulation::addParticles(int s, const std::vector<Vec3d>& x, const Vec3f& v, float mass, float volume, uint16_t set,
                              const std::vector<Vec3f>& perParticle, const std::vector<float>& masses,
                              const std::vector<float>& volumes) {
    if ((!perParticle.empty() && perParticle.size() != x.size()) || (!masses.empty() && masses.size() != x.size()) ||
        (!volumes.empty() && volumes.size() != x.size()))
        throw std::logic_error("addParticles: one velocity, mass or volume per particle, or none");
    float fastest = x.empty() ? 0.0f : v.norm();
    std::visit(
        [&](auto& sp) {
            using M = typename std::decay_t<decltype(sp)>::Material;
            ParticleArrays& P = sp.p;
            const std::size_t n0 = P.size(), n = x.size();
            P.x.insert(P.x.end(), x.begin(), x.end());
            P.v.resize(n0 + n, v);
            for (std::size_t i = 0; i < perParticle.size(); ++i) {
                P.v[n0 + i] += perParticle[i];
                fastest = std::max(fastest, P.v[n0 + i].norm());
            }
            P.C.resize(n0 + n, Mat3f::Zero());
            if (masses.empty()) P.mass.resize(n0 + n, mass);
            else P.mass.insert(P.mass.end(), masses.begin(), masses.end());
            if (volumes.empty()) P.volume0.resize(n0 + n, volume);
            else P.volume0.insert(P.volume0.end(), volumes.begin(), volumes.end());
            P.set.resize(n0 + n, set);
            for (std::size_t i = 0; i < n; ++i) P.id.push_back(state_.nextId++);
            // A model whose rest state depends on its parameters (sand's cone) takes them.
            if constexpr (requires { sp.state.appendRest(n, sp.params); })
                sp.state.appendRest(n, sp.params);
            else
                sp.state.appendRest(n);
            float& key = state_.bounds.minStiffnessKey[s];
            for (std::size_t i = n0; i < n0 + n; ++i) key = std::min(key, M::stiffnessKey(sp.state, i));
        },
        state_.species.at(s));
    state_.bounds.maxSpeed = std::max(state_.bounds.maxSpeed, fastest);
}

void Simulation::restore(SimState state) {
    if (state.streamFlow.size() != emitters_.size() || state.streamLayers.size() != emitters_.size())
        throw std::invalid_argument("restore: the state has " + std::to_string(state.streamFlow.size()) + " emitters' progress, the simulation " +
                                    std::to_string(emitters_.size()) + " emitters");
    if (state.species.size() != state_.species.size())
        throw std::invalid_argument("restore: the state has " + std::to_string(state.species.size()) +
                                    " species, the simulation " + std::to_string(state_.species.size()));
    for (std::size_t s = 0; s < state.species.size(); ++s)
        if (state.species[s].index() != state_.species[s].index())
            throw std::invalid_argument("restore: species " + std::to_string(s) + " has another material");
    state_ = std::move(state);
    restDensityCount_ = ~std::size_t(0);
}

std::size_t Simulation::particleCount() const {
    std::size_t n = 0;
    for (const AnySpecies& s : state_.species) n += particlesOf(s).size();
    return n;
}

void Simulation::emitDue() {
    if (state_.emittedFrame == state_.frame) return;
    state_.emittedFrame = state_.frame;
    for (const Emitter& e : emitters_)
        if (e.emitsAt(state_.frame)) addParticles(e.species, e.positions, e.velocity, e.mass, e.volume, e.set, e.velocities, e.masses, e.volumes);
}

double Simulation::cflTimeStep() const {
    if (!settings_.adaptive) return std::numeric_limits<double>::infinity();
    float c = 0.0f;
    for (std::size_t s = 0; s < state_.species.size(); ++s) {
        if (particlesOf(state_.species[s]).size() == 0) continue;
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

Simulation::StepBound Simulation::stepBound(bool withCause) const {
    const double target = settings_.targetDt(), cfl = cflTimeStep() * guard_.stepScale();
    const std::string retry = guard_.stepScale() < 1.0 ? " (retry)" : "";
    if (target <= cfl) return {target, withCause ? "the target step 1 / (fps * substeps)" : "", "target" + retry};
    // The fastest wave of the species present, against the fastest particle.
    float c = 0.0f;
    std::string stiffest;
    for (std::size_t s = 0; s < state_.species.size(); ++s)
        std::visit(
            [&](const auto& sp) {
                using M = typename std::decay_t<decltype(sp)>::Material;
                const float w = sp.size() ? M::waveSpeed(sp.params, state_.bounds.minStiffnessKey[s]) : 0.0f;
                if (w > c) c = w, stiffest = sp.name;
            },
            state_.species[s]);
    const bool wave = c >= state_.bounds.maxSpeed;
    const std::string limit = (wave ? "cfl_wave_speed " + stiffest : std::string("cfl_particle_speed")) + retry;
    if (!withCause) return {cfl, "", limit};
    std::ostringstream cause;
    cause << "the CFL bound, C dx / (c + |v|max + |g| dt) with ";
    if (wave) cause << "the wave speed c = " << c << " m/s of species " << stiffest;
    else cause << "the fastest particle, |v| = " << state_.bounds.maxSpeed << " m/s";
    if (guard_.stepScale() < 1.0) cause << ", shortened " << 1.0 / guard_.stepScale() << "x for a retry";
    return {cfl, cause.str(), limit};
}

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
        if (far == P.size()) continue;
        std::ostringstream msg;
        msg << "particle id " << P.id[far] << " of species " << std::visit([](const auto& sp) { return sp.name; }, state_.species[s])
            << " is at (" << P.x[far].transpose() << ") m at frame " << state_.frame << ", beyond the grid's coordinate range of +-"
            << limit << " m (2^30 cells of dx = " << settings_.dx << " m); keep the scene nearer the origin or use a larger dx";
        throw LimitExceeded(msg.str());
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

void Simulation::refreshSpeedBound() {
    float& vmax = state_.bounds.maxSpeed;
    vmax = 0.0f;
    for (const AnySpecies& s : state_.species)
        for (const Vec3f& v : particlesOf(s).v) vmax = std::max(vmax, v.norm());
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
    PhaseClock clock;
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            const std::vector<int>& members = fieldSpecies_[f];
            std::vector<BinRequest> requests(species.size());
            for (std::size_t s = 0; s < species.size(); ++s) {
                std::vector<uint32_t>& dest = destination_[fields_.size() == 1 ? s : std::size_t(members[s])];
                std::visit([&](auto& sp) { requests[s] = BinRequest{&sp.p.x, &dest, &sp.leafStart}; }, species[s]);
            }
            grid.updateTopology(requests);
            clock.lap(phases_.topology);
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
            clock.lap(phases_.binning);
        });
}

SurfaceContact Simulation::surfaceContact() {
    SurfaceContact s;
    if (settings_.wallContact != WallContact::Surface) return s;
    bool unilateral = false;
    for (const auto& c : colliders_) unilateral = unilateral || c->boundary() == Boundary::Separate;
    if (!unilateral) return s;
    // The material's rest density, mass over rest volume over all particles (exact for one material); it
    // changes only when particles are added, so it is measured again only then.
    const std::size_t count = particleCount();
    if (count != restDensityCount_) {
        double mass = 0.0, volume = 0.0;
        for (const AnySpecies& sp : state_.species) {
            const ParticleArrays& P = particlesOf(sp);
            for (std::size_t i = 0; i < P.size(); ++i) mass += double(P.mass[i]), volume += double(P.volume0[i]);
        }
        restDensity_ = volume > 0.0 ? mass / volume : 0.0;
        restDensityCount_ = count;
    }
    if (!(restDensity_ > 0.0)) return s;
    s.cellMass = float(restDensity_ * std::pow(settings_.dx, 3));
    withKernel(settings_.transfer.interpolation, [&]<class K>() { s.covered = &K::covered; });
    return s;
}

GridUpdateResult Simulation::updateGrid(float dt) {
    for (const auto& c : colliders_) c->prepare(state_.time + dt);
    const Vec3f g = settings_.gravity.cast<float>();
    const double tEnd = state_.time + dt;
    const SurfaceContact surface = surfaceContact();
    const bool mirror = settings_.wallGhosts == WallGhosts::Mirror;
    if (fields_.size() == 1) {
        const GridUpdateResult r = updateGridVelocities(fields_[0], colliders_, g, dt, tEnd, surface);
        if (mirror) mirrorGhostNodes(fields_[0], colliders_, tEnd);
        return r;
    }
    // Bodies of their own: velocities in every field, then the contact between them, then the colliders.
    static const std::vector<std::unique_ptr<Collider>> kNone;
    for (const SparseGrid& field : fields_) updateGridVelocities(field, kNone, g, dt, tEnd, surface);
    resolveFieldContact(fields_, settings_.contactFriction);
    GridUpdateResult out;
    for (const SparseGrid& field : fields_) {
        const GridUpdateResult r = updateGridVelocities(field, colliders_, g, dt, tEnd, surface, false);
        if (mirror) mirrorGhostNodes(field, colliders_, tEnd);
        out.maxSpeed = std::max(out.maxSpeed, r.maxSpeed);
        out.work += r.work;
    }
    return out;
}

void Simulation::scatter(float dt) {
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) { particlesToGrid(grid, species, settings_.transfer, dt); });
}

G2PSummary Simulation::gather(float dt) {
    if (fields_.size() == 1) return gridToParticles(fields_[0], state_.species, settings_.transfer, dt);
    // Field by field, with each field's per-species results put back at the species' own index.
    G2PSummary out;
    out.minStiffnessKey.assign(state_.species.size(), std::numeric_limits<float>::infinity());
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            const G2PSummary r = gridToParticles(grid, species, settings_.transfer, dt);
            const std::vector<int>& members = fieldSpecies_[f];
            out.maxSpeed = std::max(out.maxSpeed, r.maxSpeed);
            for (std::size_t s = 0; s < members.size(); ++s) out.minStiffnessKey[members[s]] = r.minStiffnessKey[s];
            if (out.badParticle < 0 && r.badParticle >= 0) {
                out.badSpecies = members[r.badSpecies];
                out.badParticle = r.badParticle;
                out.badField = r.badField;
            }
        });
    return out;
}

ProjectionSummary Simulation::holdOutOfColliders(float dt) {
    ProjectionSummary out;
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            const ProjectionSummary r = projectOutOfColliders(grid, species, colliders_, state_.time + dt, dt, settings_.gravity);
            out.work += r.work;
            out.maxSpeed = std::max(out.maxSpeed, r.maxSpeed);
            out.moved += r.moved;
        });
    return out;
}

double Simulation::substep(double dtMax) {
    // Bin particles by leaf; allocate the leaves their stencils reach and release the others.
    bin();
    PhaseClock clock;
    // Time step: the caller's bound (target and frame end), and the CFL condition (halved on retries).
    double dt = std::min(dtMax, cflTimeStep() * guard_.stepScale());
    // P2G: mass and momentum, with the stress impulse of this step folded in (thesis 3.14, 3.15, 3.24).
    scatter(float(dt));
    clock.lap(phases_.p2g);
    // Grid update: v = mv/m, gravity, colliders and friction (3.20, 3.26, section 5).
    GridUpdateResult gridUpdate = updateGrid(float(dt));
    clock.lap(phases_.grid);
    // Thesis pseudocode 3: if a node would move more than maxDisplacement cells, redo with a shorter step.
    if (settings_.maxDisplacement > 0.0 && gridUpdate.maxSpeed * dt > settings_.maxDisplacement * settings_.dx) {
        dt = settings_.maxDisplacement * settings_.dx / gridUpdate.maxSpeed;
        scatter(float(dt));
        clock.lap(phases_.p2g);
        gridUpdate = updateGrid(float(dt));
        clock.lap(phases_.grid);
    }
    // G2P: velocity, affine velocity, deformation update with return mapping, advection (3.17-3.19, 3.21).
    const G2PSummary g2p = gather(float(dt));
    // Particles found inside a collider (walls thinner than a cell included) go back to its surface.
    const ProjectionSummary held = holdOutOfColliders(float(dt));
    clock.lap(phases_.g2p);
    // Work moving colliders did is external: the energy check counts it.
    state_.energy.work += gridUpdate.work + held.work;
    // The bounds the next step starts from, then the blow-up checks: a non-finite value, a particle that
    // outran its stencil, a CFL step that collapsed.
    const double cflBefore = cflTimeStep();
    state_.bounds = StepBounds{std::max(g2p.maxSpeed, held.maxSpeed), g2p.minStiffnessKey};
    guard_.checkSubstep(state_, g2p, dt, settings_.dx, cflBefore, cflTimeStep());
    emitStreams(state_.time, state_.time + dt);
    state_.time += dt;
    ++state_.substeps;
    clock.lap(phases_.other);
    return dt;
}

void Simulation::emitStreams(double t0, double t1) {
    for (std::size_t k = 0; k < emitters_.size(); ++k) {
        const Emitter& e = emitters_[k];
        if (!e.continuous) continue;
        // The part of the substep during which the source runs.
        const double open = double(e.startFrame) / settings_.fps, close = double(e.startFrame + e.durationFrames) / settings_.fps;
        const double during = std::min(t1, close) - std::max(t0, open);
        if (!(during > 0.0)) continue;
        double& flow = state_.streamFlow[k];
        int64_t& layers = state_.streamLayers[k];
        flow += e.stream.speed * during;
        // Layer n stands for the slab of flow [n, n + 1) spacings: it enters as the flow passes its middle, and
        // is by now (flow - (n + 1/2) spacing) past the surface.
        std::vector<Vec3d> x;
        for (; (double(layers) + 0.5) * e.stream.spacing <= flow; ++layers) {
            const Vec3d depth = e.stream.normal * (flow - (double(layers) + 0.5) * e.stream.spacing);
            for (const Vec3d& p : e.stream.layers[layers & 1]) x.push_back(p + depth);
        }
        if (x.empty()) continue;
        // New material brings energy in from outside, as a moving collider does: count it as external work.
        const double v2 = double(e.velocity.squaredNorm());
        for (const Vec3d& p : x) state_.energy.work += double(e.mass) * (0.5 * v2 - settings_.gravity.dot(p));
        addParticles(e.species, x, e.velocity, e.mass, e.volume, e.set);
    }
}

void Simulation::runFrameSubsteps() {
    const double frameEnd = double(state_.frame + 1) / settings_.fps;
    while (state_.time < frameEnd) {
        // A stop asked for (a signal) is honoured here, between two substeps, where the state is consistent.
        if (stop_ && stop_->load(std::memory_order_relaxed)) throw Interrupted();
        const double remaining = frameEnd - state_.time;
        const double dtMax = std::min(settings_.targetDt(), cflTimeStep()) * guard_.stepScale();
        // Split the rest of the frame into equal substeps so that the last one lands on the frame time.
        const double pieces = std::max(1.0, std::ceil(remaining / dtMax - kFrameSplitSlack));
        // Watchdog: a frame that would take more substeps than allowed stops here, saying what bounds the step.
        if (double(state_.frameSubsteps) + pieces > double(settings_.maxSubstepsPerFrame)) {
            const StepBound b = stepBound();
            std::ostringstream msg;
            msg << "frame " << state_.frame + 1 << " would need about " << double(state_.frameSubsteps) + pieces
                << " substeps (dt = " << dtMax << " s, set by " << b.cause << "); the limit is simulation.max_substeps_per_frame = "
                << settings_.maxSubstepsPerFrame;
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
        if (guard_.energyCheckDue(state_.substeps)) guard_.checkEnergy(state_, measure());
        if (pieces == 1.0 && taken == dt) state_.time = frameEnd;
    }
}

FrameStats Simulation::advanceFrame() {
    const auto start = std::chrono::steady_clock::now();
    emitDue();
    if (!state_.energy.set) guard_.resetEnergyReference(state_.energy, measure());
    FrameStats st;
    const int retries = guard_.withRetries(state_, [&] {
        runFrameSubsteps();
        st = measure();
        guard_.checkEnergy(state_, st);
    });
    const int steps = state_.frameSubsteps;
    state_.frameSubsteps = 0;
    ++state_.frame;
    checkCoordinates();
    const std::size_t before = particleCount();
    emitDue();
    if (particleCount() != before) {
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
}

FrameStats Simulation::measure() const {
    FrameStats st = measureParticles(state_.species, settings_.dx, kernelInertiaScale(), settings_.gravity);
    st.frame = state_.frame;
    st.time = state_.time;
    st.activeLeaves = 0;
    st.gridBytes = 0;
    for (const SparseGrid& field : fields_) st.activeLeaves += field.leafCount(), st.gridBytes += field.contentBytes();
    return st;
}

}  // namespace mpm
