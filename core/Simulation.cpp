#include "core/Simulation.h"
// The substep in the algorithm's order (P2G, grid update, G2P, particle pass, bodies), the step policy, emission,
// checkpoint restore and diagnostics; what the ranks add lives in core/SimulationRanks.cpp.

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
    : settings_(settings), guard_(settings.stability, settings.gravity.norm(), settings.dx), comm_(&Comm::single()) {
    fields_.resize(1);
    fieldSpecies_.resize(1);
    withKernel(settings_.transfer.interpolation,
               [&]<class K>() { fields_[0].configure(settings_.dx, K::kBaseShift, K::kWidth); });
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
    populated_.push_back(particlesOf(state_.species.back()).size() > 0);
    return int(state_.species.size()) - 1;
}

void Simulation::addParticles(int s, const std::vector<Vec3d>& x, const Vec3f& v, float mass, float volume, uint16_t set,
                              const std::vector<Vec3f>& perParticle, const std::vector<float>& masses,
                              const std::vector<float>& volumes) {
    if ((!perParticle.empty() && perParticle.size() != x.size()) || (!masses.empty() && masses.size() != x.size()) ||
        (!volumes.empty() && volumes.size() != x.size()))
        throw std::logic_error("addParticles: one velocity, mass or volume per particle, or none");
    float fastest = x.empty() ? 0.0f : v.norm();
    for (const Vec3f& u : perParticle) fastest = std::max(fastest, (v + u).norm());
    // Ids are given over all the particles, on every rank; each rank keeps those in the leaves it owns.
    if (!x.empty()) populated_.at(std::size_t(s)) = 1;
    std::vector<int32_t> ids(x.size());
    for (int32_t& i : ids) i = state_.nextId++;
    if (partitioned_ && comm_->distributed()) {
        std::vector<std::size_t> keep;
        for (std::size_t i = 0; i < x.size(); ++i)
            if (ownerOf(particleLeaf(x[i])) == comm_->rank()) keep.push_back(i);
        auto pick = [&](const auto& all) {
            std::decay_t<decltype(all)> out;
            if (all.empty()) return out;
            for (std::size_t i : keep) out.push_back(all[i]);
            return out;
        };
        const std::vector<Vec3d> kx = pick(x);
        const std::vector<Vec3f> kv = pick(perParticle);
        const std::vector<float> km = pick(masses), kvol = pick(volumes);
        const std::vector<int32_t> kid = pick(ids);
        appendParticles(s, kx, v, mass, volume, set, kv, km, kvol, kid);
    } else {
        appendParticles(s, x, v, mass, volume, set, perParticle, masses, volumes, ids);
    }
    state_.bounds.maxSpeed = std::max(state_.bounds.maxSpeed, fastest);
}

void Simulation::emitPart(const Emitter& e) {
    if (!comm_->distributed() && e.total != (long long)e.positions.size())
        throw std::logic_error("emitPart: a part of a set is emitted on ranks only, after distribute()");
    // What one process computes from the whole set: the fastest particle, whether the species has any.
    float fastest = e.positions.empty() ? 0.0f : e.velocity.norm();
    for (const Vec3f& u : e.velocities) fastest = std::max(fastest, (e.velocity + u).norm());
    fastest = comm_->max(fastest);
    if (e.total > 0) populated_.at(std::size_t(e.species)) = 1;
    std::vector<int32_t> ids(e.positions.size());
    for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = int32_t(state_.nextId + e.first + (long long)i);
    state_.nextId += int32_t(e.total);
    const std::size_t before = particlesOf(state_.species.at(std::size_t(e.species))).size();
    appendParticles(e.species, e.positions, e.velocity, e.mass, e.volume, e.set, e.velocities, e.masses, e.volumes, ids);
    setAffine(e, before);
    state_.bounds.maxSpeed = std::max(state_.bounds.maxSpeed, fastest);
    if (partitioned_) sendEmittedToOwners(e.species, before);
}

void Simulation::setAffine(const Emitter& e, std::size_t from) {
    // PIC keeps no affine velocity: its particles start without one, as they go on.
    if (e.affine.isZero() || settings_.transfer.transfer != TransferScheme::APIC) return;
    ParticleArrays& P = particlesOf(state_.species.at(std::size_t(e.species)));
    std::fill(P.C.begin() + std::ptrdiff_t(from), P.C.end(), e.affine);
}

void Simulation::appendParticles(int s, const std::vector<Vec3d>& x, const Vec3f& v, float mass, float volume, uint16_t set,
                                 const std::vector<Vec3f>& perParticle, const std::vector<float>& masses,
                                 const std::vector<float>& volumes, const std::vector<int32_t>& ids) {
    std::visit(
        [&](auto& sp) {
            using M = typename std::decay_t<decltype(sp)>::Material;
            ParticleArrays& P = sp.p;
            const std::size_t n0 = P.size(), n = x.size();
            P.x.insert(P.x.end(), x.begin(), x.end());
            P.v.resize(n0 + n, v);
            for (std::size_t i = 0; i < perParticle.size(); ++i) P.v[n0 + i] += perParticle[i];
            P.C.resize(n0 + n, Mat3f::Zero());
            if (masses.empty())
                P.mass.resize(n0 + n, mass);
            else
                P.mass.insert(P.mass.end(), masses.begin(), masses.end());
            if (volumes.empty())
                P.volume0.resize(n0 + n, volume);
            else
                P.volume0.insert(P.volume0.end(), volumes.begin(), volumes.end());
            P.set.resize(n0 + n, set);
            P.id.insert(P.id.end(), ids.begin(), ids.end());
            // A model whose rest state depends on its parameters (sand's cone) takes them.
            if constexpr (requires { sp.state.appendRest(n, sp.params); })
                sp.state.appendRest(n, sp.params);
            else
                sp.state.appendRest(n);
            float& key = state_.bounds.minStiffnessKey[s];
            for (std::size_t i = n0; i < n0 + n; ++i) key = std::min(key, M::stiffnessKey(sp.state, i));
        },
        state_.species.at(s));
    // A rank that kept none of them still takes their rest-state stiffness, as one process would.
    comm_->min(state_.bounds.minStiffnessKey);
}

void Simulation::restore(SimState state, bool share) {
    if (state.streamFlow.size() != emitters_.size() || state.streamLayers.size() != emitters_.size())
        throw std::invalid_argument("restore: the state has " + std::to_string(state.streamFlow.size()) +
                                    " emitters' progress, the simulation " + std::to_string(emitters_.size()) + " emitters");
    if (state.species.size() != state_.species.size())
        throw std::invalid_argument("restore: the state has " + std::to_string(state.species.size()) +
                                    " species, the simulation " + std::to_string(state_.species.size()));
    for (std::size_t s = 0; s < state.species.size(); ++s)
        if (state.species[s].index() != state_.species[s].index())
            throw std::invalid_argument("restore: species " + std::to_string(s) + " has another material");
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

void Simulation::emitDue() {
    return withSubnormalsFlushed([&] {
        if (state_.emittedFrame == state_.frame) return;
        state_.emittedFrame = state_.frame;
        for (Emitter& e : emitters_) {
            if (!e.emitsAt(state_.frame)) continue;
            if (e.holdsPart()) {
                emitPart(e);
            } else {
                const std::size_t before = particlesOf(state_.species.at(std::size_t(e.species))).size();
                addParticles(e.species, e.positions, e.velocity, e.mass, e.volume, e.set, e.velocities, e.masses, e.volumes);
                setAffine(e, before);
            }
            // Emitted for the last time: its samples (24 bytes a particle and more, on every rank) are not needed again.
            if (state_.frame == e.lastEmission()) {
                std::vector<Vec3d>().swap(e.positions);
                std::vector<Vec3f>().swap(e.velocities);
                std::vector<float>().swap(e.masses);
                std::vector<float>().swap(e.volumes);
                e.released = true;
            }
        }
    });
}

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

void Simulation::refreshSpeedBound() {
    float& vmax = state_.bounds.maxSpeed;
    vmax = 0.0f;
    for (const AnySpecies& s : state_.species)
        for (const Vec3f& v : particlesOf(s).v) vmax = std::max(vmax, v.norm());
    vmax = comm_->max(vmax);
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
    const bool ranks = partitioned_ && comm_->distributed();
    if (ranks) {
        rebalanceIfNeeded();
        migrateParticles();
        clock.lap(phases_.communication);
    }
    rankLeaves_.resize(fields_.size());
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            const std::vector<int>& members = fieldSpecies_[f];
            std::vector<BinRequest> requests(species.size());
            for (std::size_t s = 0; s < species.size(); ++s) {
                std::vector<uint32_t>& dest = destination_[fields_.size() == 1 ? s : std::size_t(members[s])];
                std::visit([&](auto& sp) { requests[s] = BinRequest{&sp.p.x, &sp.p.id, &dest, &sp.leafStart}; }, species[s]);
            }
            grid.collectLeaves(requests);
            RankLeaves& rl = rankLeaves_[f];
            if (ranks) exchangeReachedLeaves(grid, rl);
            grid.allocateLeaves();
            if (ranks) {
                // Which leaves are whose, and the ghost leaves each side of every rank pair, in leaf order.
                rl.owned.assign(grid.leafCount(), 0);
                for (auto& g : rl.ghostsFrom) g.clear();
                rl.ghostsFrom.resize(std::size_t(comm_->size()));
                for (std::size_t l = 0; l < grid.leafCount(); ++l) {
                    const int owner = ownerOf(leafOfNode(grid.leaf(l).origin));
                    if (owner == comm_->rank())
                        rl.owned[l] = 1;
                    else
                        rl.ghostsFrom[std::size_t(owner)].push_back(uint32_t(l));
                }
                rl.ghostsFor.assign(std::size_t(comm_->size()), {});
                for (std::size_t r = 0; r < rl.ghostCoordsFor.size(); ++r)
                    for (const Vec3i& c : rl.ghostCoordsFor[r]) rl.ghostsFor[r].push_back(grid.indexOfLeaf(c));
            }
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

SurfaceContact Simulation::surfaceContact(std::size_t field) {
    SurfaceContact s;
    if (settings_.wallContact != WallContact::Surface) return s;
    bool unilateral = false;
    for (const auto& c : colliders_) unilateral = unilateral || c->boundary() == Boundary::Separate;
    if (!unilateral) return s;
    // The material's rest density, mass over rest volume over all particles (exact for one material), and whether
    // the species differ in it; both change only when particles are added (nextId moves, on every rank alike).
    if (state_.nextId != restDensityVersion_) {
        ExactSum mass, volume;
        std::vector<double> densities;
        for (const AnySpecies& sp : state_.species) {
            const ParticleArrays& P = particlesOf(sp);
            ExactSum m, v;
            for (std::size_t i = 0; i < P.size(); ++i) {
                mass += double(P.mass[i]), volume += double(P.volume0[i]);
                m += double(P.mass[i]), v += double(P.volume0[i]);
            }
            comm_->sum(m);
            comm_->sum(v);
            if (v.value() > 0.0) densities.push_back(m.value() / v.value());
        }
        comm_->sum(mass);
        comm_->sum(volume);
        restDensity_ = volume.value() > 0.0 ? mass.value() / volume.value() : 0.0;
        const auto [lo, hi] = std::minmax_element(densities.begin(), densities.end());
        // Equal to a part in a million: sets of one material, whose particle masses are rounded to float.
        constexpr double kSameDensity = 1e-6;
        densitiesDiffer_ = !densities.empty() && *hi > *lo * (1.0 + kSameDensity);
        restDensityVersion_ = state_.nextId;
    }
    if (!(restDensity_ > 0.0)) return s;
    const double cell = std::pow(settings_.dx, 3);
    s.cellMass = float(restDensity_ * cell);
    withKernel(settings_.transfer.interpolation, [&]<class K>() { s.covered = &K::covered; });
    if (!densitiesDiffer_) return s;
    // Bodies of different densities: a leaf's nodes take their mass from the particles binned in it and in the 7
    // leaves below it (stencils spill towards +x, +y, +z), so its density is theirs: mass over rest volume. A leaf
    // none of them holds particles for takes the scene's.
    const SparseGrid& grid = fields_[field];
    const std::vector<int>& members = fieldSpecies_[field];
    const std::vector<uint32_t>& leaves = grid.particleLeaves();
    struct Sums {
        double mass = 0.0, volume = 0.0;
    };
    std::vector<Sums> own(leaves.size());
    forEachLeafRange(leaves.size(), LeafGrain::Particles, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) {
            const uint32_t l = leaves[i];
            for (int k : members)
                std::visit(
                    [&](const auto& sp) {
                        for (uint32_t p = sp.leafStart[l]; p < sp.leafStart[l + 1]; ++p)
                            own[i].mass += double(sp.p.mass[p]), own[i].volume += double(sp.p.volume0[p]);
                    },
                    state_.species[std::size_t(k)]);
        }
    });
    // On ranks the leaves below a leaf may hold their particles on other ranks: each rank sends its leaves' sums to
    // the owners of the leaves above them, which add them in the order one process does.
    std::vector<std::array<Sums, kNeighbours>> remote;
    if (partitioned_ && comm_->distributed()) {
        remote.assign(grid.leafCount(), {});
        std::vector<Bytes> send(static_cast<std::size_t>(comm_->size()));
        for (std::size_t i = 0; i < leaves.size(); ++i) {
            const Vec3i from = leafOfNode(grid.leaf(leaves[i]).origin);
            for (int d = 1; d < kNeighbours; ++d) {
                const Vec3i to = from + Vec3i(neighbourStep(d, 0), neighbourStep(d, 1), neighbourStep(d, 2));
                const int owner = ownerOf(to);
                if (owner == comm_->rank()) continue;
                Bytes& b = send[std::size_t(owner)];
                putArray(b, to.data(), 3);
                put(b, int32_t(d));
                put(b, own[i].mass);
                put(b, own[i].volume);
            }
        }
        for (const Bytes& b : comm_->exchange(send)) {
            ByteReader r{b};
            while (!r.done()) {
                Vec3i to;
                r.getArray(to.data(), 3);
                const int d = r.get<int32_t>();
                Sums sums;
                sums.mass = r.get<double>();
                sums.volume = r.get<double>();
                const uint32_t l = grid.indexOfLeaf(to);
                if (l != SparseGrid::kNoLeaf) remote[l][std::size_t(d)] = sums;
            }
        }
    }
    std::vector<float>& cellMass = leafCellMass_[field];
    cellMass.assign(grid.leafCount(), s.cellMass);
    forEachLeafRange(grid.leafCount(), LeafGrain::Nodes, [&](std::size_t begin, std::size_t end) {
        for (std::size_t l = begin; l < end; ++l) {
            double mass = 0.0, volume = 0.0;
            for (int d = 0; d < kNeighbours; ++d) {
                const uint32_t source = grid.sources(l)[std::size_t(d)];
                const Sums& sums = source != SparseGrid::kNoLeaf ? own[source]
                                   : remote.empty()              ? Sums{}
                                                                 : remote[l][std::size_t(d)];
                mass += sums.mass, volume += sums.volume;
            }
            if (volume > 0.0) cellMass[l] = float(mass / volume * cell);
        }
    });
    s.leafCellMass = cellMass.data();
    return s;
}

void Simulation::addBody(std::unique_ptr<Collider> c, const RigidBodyModel& model, std::shared_ptr<BodyFrame> frame,
                         const RigidBodyState& initial) {
    bodies_.push_back(Body{colliders_.size(), model, std::move(frame)});
    colliders_.push_back(std::move(c));
    state_.bodies.push_back(initial);
    *bodies_.back().frame = model.frame(initial);
}

void Simulation::poseBodies(double dt) {
    for (std::size_t k = 0; k < bodies_.size(); ++k)
        *bodies_[k].frame = bodies_[k].model.frame(bodies_[k].model.moved(state_.bodies[k], dt));
}

float Simulation::moveBodies(double dt, const std::vector<BodyImpulse>& nodes, const std::vector<BodyImpulse>& particles) {
    float fastest = 0.0f;
    if (bodies_.empty()) return fastest;
    std::vector<const Collider*> fixed;
    for (const auto& c : colliders_)
        if (!c->dynamic()) fixed.push_back(c.get());
    for (std::size_t k = 0; k < bodies_.size(); ++k) {
        const Body& b = bodies_[k];
        BodyImpulse taken;
        if (!nodes.empty()) taken += nodes[b.collider];
        if (!particles.empty()) taken += particles[b.collider];
        if (comm_->distributed())
            for (ExactSum& e : taken.sum) comm_->sum(e);
        RigidBodyState& s = state_.bodies[k];
        const double before = b.model.energy(s, settings_.gravity, dt);
        RigidBodyState next = b.model.moved(s, dt);
        if (bodyDriver_) {
            bodyDriver_(k, dt, -taken.impulse(), -taken.angular(), next);
            next.orientation.normalize();
        } else {
            b.model.accelerate(s, next, dt, settings_.gravity, taken.impulse(), taken.angular());
            b.model.touch(next, fixed, state_.time + dt, dt);
        }
        s = next;
        // The bodies belong to the checked system: what they lose, the material may gain.
        state_.energy.work -= b.model.energy(s, settings_.gravity, dt) - before;
        *b.frame = b.model.frame(s);
    }
    // Bodies against bodies, pair by pair in collider order (the built-in solver only: a driver moves its own).
    if (!bodyDriver_)
        for (std::size_t i = 0; i < bodies_.size(); ++i)
            for (std::size_t j = i + 1; j < bodies_.size(); ++j) {
                const Body &a = bodies_[i], &b = bodies_[j];
                RigidBodyState &sa = state_.bodies[i], &sb = state_.bodies[j];
                const double before = a.model.energy(sa, settings_.gravity, dt) + b.model.energy(sb, settings_.gravity, dt);
                if (touchBodies(a.model, sa, *colliders_[a.collider], b.model, sb, *colliders_[b.collider], state_.time + dt,
                                dt) == 0)
                    continue;
                state_.energy.work -=
                    a.model.energy(sa, settings_.gravity, dt) + b.model.energy(sb, settings_.gravity, dt) - before;
                *a.frame = a.model.frame(sa);
                *b.frame = b.model.frame(sb);
            }
    for (std::size_t k = 0; k < bodies_.size(); ++k)
        fastest = std::max(fastest, float(bodies_[k].model.fastestPoint(state_.bodies[k])));
    return fastest;
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
    PhaseClock clock;
    double computing = 0.0;  // the caller books this phase's time less its communication as grid
    const auto local = [&](const Vec3i& node) { return ownerOf(leafOfNode(node)) == comm_->rank(); };
    // The remote reads of the mirror passes, field by field.
    const auto remoteNodes = [&](std::size_t f) {
        RemoteNodes remote;
        if (ranks) {
            remote.owned = owned(f);
            remote.local = local;
            remote.fetch = [&, f](const std::vector<Vec3i>& nodes, std::vector<float>& m, std::vector<Vec3f>& v) {
                clock.lap(computing);
                fetchNodes(fields_[f], nodes, m, v);
                clock.lap(phases_.communication);
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
                clock.lap(computing);
                std::vector<Vec3f> unused;
                fetchNodes(fields_[f], nodes, m, unused);
                clock.lap(phases_.communication);
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
    if (ranks) {
        // The mirrored nodes go to their holders with the other ghost velocities.
        clock.lap(computing);
        out.maxSpeed = comm_->max(out.maxSpeed);
        comm_->sum(out.work);
        for (std::size_t f = 0; f < fields_.size(); ++f) sendGhostVelocities(fields_[f], rankLeaves_[f]);
        clock.lap(phases_.communication);
    }
    return out;
}

void Simulation::scatter(float dt) {
    if (partitioned_ && comm_->distributed()) {
        // Halo parts for ghost leaves go to their owners; the owners' leaves add every part in order d. Field by
        // field (a leaf coordinate has one owner in every field).
        for (std::size_t f = 0; f < fields_.size(); ++f) {
            RankLeaves& rl = rankLeaves_[f];
            RemoteHalos remote;
            remote.owned = &rl.owned;
            remote.exchange = [&](HaloParts&& out) {
                PhaseClock clock;
                std::vector<Bytes> send(static_cast<std::size_t>(comm_->size()));
                for (const HaloParts::Part& part : out.parts) {
                    Bytes& b = send[std::size_t(ownerOf(part.leaf))];
                    for (int a = 0; a < 3; ++a) put(b, int32_t(part.leaf[a]));
                    put(b, part.d);
                    putArray(b, part.lo, 3);
                    putArray(b, part.hi, 3);
                    std::size_t n = 1;
                    for (int a = 0; a < 3; ++a) n *= std::size_t(part.hi[a] - part.lo[a]);
                    put(b, uint64_t(n));
                    putArray(b, out.data.data() + 4 * part.offset, 4 * n);
                }
                const std::vector<Bytes> received = comm_->exchange(send);
                HaloParts in;
                // What each rank's stencils read of a ghost leaf is what its parts wrote there: the velocities go
                // back for that box alone, not for all the owner wrote.
                rl.ghostBoxFor.assign(received.size(), {});
                for (std::size_t from = 0; from < received.size(); ++from) {
                    const Bytes& b = received[from];
                    const std::vector<Vec3i>& coords = rl.ghostCoordsFor[from];
                    rl.ghostBoxFor[from].assign(coords.size(), NodeBox{});
                    ByteReader r{b};
                    while (!r.done()) {
                        HaloParts::Part part;
                        for (int a = 0; a < 3; ++a) part.leaf[a] = r.get<int32_t>();
                        part.d = r.get<int32_t>();
                        r.getArray(part.lo, 3);
                        r.getArray(part.hi, 3);
                        const auto at = std::lower_bound(coords.begin(), coords.end(), part.leaf, mortonLess);
                        if (at != coords.end() && *at == part.leaf) {
                            NodeBox box;
                            for (int a = 0; a < 3; ++a) {
                                const int shift = kLeafDim * neighbourStep(part.d, a);
                                box.lo[a] = int8_t(part.lo[a] - shift);
                                box.hi[a] = int8_t(part.hi[a] - shift);
                            }
                            rl.ghostBoxFor[from][std::size_t(at - coords.begin())].add(box);
                        }
                        const std::size_t n = r.get<uint64_t>();
                        part.offset = in.data.size() / 4;
                        in.data.resize(in.data.size() + 4 * n);
                        r.getArray(in.data.data() + 4 * part.offset, 4 * n);
                        in.parts.push_back(part);
                    }
                }
                clock.lap(phases_.communication);
                return in;
            };
            withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
                particlesToGrid(grid, species, settings_.transfer, dt, &remote);
            });
        }
        return;
    }
    for (std::size_t f = 0; f < fields_.size(); ++f)
        withField(f, [&](SparseGrid& grid, std::vector<AnySpecies>& species) {
            particlesToGrid(grid, species, settings_.transfer, dt);
        });
}

G2PSummary Simulation::gather(float dt) {
    if (fields_.size() == 1) {
        G2PSummary g2p = gridToParticles(fields_[0], state_.species, settings_.transfer, dt);
        reduceSummary(g2p);
        return g2p;
    }
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
        PhaseClock clock;
        // Time step: the caller's bound (target and frame end), and the CFL condition (halved on retries).
        double dt = std::min(dtMax, cflTimeStep() * guard_.stepScale());
        // On ranks a phase books its exchanges as communication itself; the phase keeps the rest of its time.
        const auto lap = [&](double& phase, double communicationBefore) {
            clock.lap(phase);
            phase -= phases_.communication - communicationBefore;
        };
        // P2G: mass and momentum, with the stress impulse of this step folded in (thesis 3.14, 3.15, 3.24).
        double before = phases_.communication;
        scatter(float(dt));
        lap(phases_.p2g, before);
        // Grid update: v = mv/m, gravity, colliders and friction (3.20, 3.26, section 5).
        before = phases_.communication;
        GridUpdateResult gridUpdate = updateGrid(float(dt));
        lap(phases_.grid, before);
        // Thesis pseudocode 3: if a node would move more than maxDisplacement cells, redo with a shorter step.
        if (settings_.maxDisplacement > 0.0 && gridUpdate.maxSpeed * dt > settings_.maxDisplacement * settings_.dx) {
            dt = settings_.maxDisplacement * settings_.dx / gridUpdate.maxSpeed;
            before = phases_.communication;
            scatter(float(dt));
            lap(phases_.p2g, before);
            before = phases_.communication;
            gridUpdate = updateGrid(float(dt));
            lap(phases_.grid, before);
        }
        // G2P: velocity, affine velocity, deformation update with return mapping, advection (3.17-3.19, 3.21).
        const G2PSummary g2p = gather(float(dt));
        // Particles found inside a collider (walls thinner than a cell included) go back to its surface.
        const ProjectionSummary held = holdOutOfColliders(float(dt));
        clock.lap(phases_.g2p);
        // Work moving colliders did is external: the energy check counts it.
        ExactSum work = gridUpdate.work;
        work += held.work;
        state_.energy.work += work.value();
        // Bodies the material moves take what it gained from them (the step the transfers took, in float).
        const float bodySpeed = moveBodies(double(float(dt)), gridUpdate.bodies, held.bodies);
        // The bounds the next step starts from, then the blow-up checks: a non-finite value, a particle that
        // outran its stencil, a CFL step that collapsed.
        const double cflBefore = cflTimeStep();
        state_.bounds = StepBounds{std::max({g2p.maxSpeed, held.maxSpeed, bodySpeed}), g2p.minStiffnessKey};
        guard_.checkSubstep(state_, g2p, dt, settings_.dx, cflBefore, cflTimeStep());
        emitStreams(state_.time, state_.time + dt);
        state_.time += dt;
        ++state_.substeps;
        clock.lap(phases_.other);
        return dt;
    });
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
