#include "core/Simulation.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <type_traits>
#include <sstream>

namespace mpm {

namespace {
constexpr std::size_t kPermuteGrain = 16384;
/// Relative slack when splitting the rest of a frame into equal substeps.
constexpr double kFrameSplitSlack = 1e-9;
/// Substeps between energy checks inside a frame (frame ends are always checked). Measuring costs about
/// a tenth of a substep for solids (an SVD per particle), so this keeps it near 0.2%.
constexpr long long kEnergyCheckInterval = 50;

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

Simulation::Simulation(const SimulationSettings& settings) : settings_(settings) {
    withKernel(settings_.transfer.interpolation,
               [&]<class K>() { grid_.configure(settings_.dx, K::kBaseShift, K::kWidth); });
}

float Simulation::kernelInertiaScale() const {
    return withKernel(settings_.transfer.interpolation, []<class K>() { return 1.0f / K::kInverseInertia; });
}

int Simulation::addSpecies(AnySpecies species) {
    species_.push_back(std::move(species));
    minStiffnessKey_.push_back(std::numeric_limits<float>::infinity());
    destination_.emplace_back();
    return int(species_.size()) - 1;
}

void Simulation::addParticles(int s, const std::vector<Vec3d>& x, const Vec3f& v, float mass, float volume, uint16_t set) {
    std::visit(
        [&](auto& sp) {
            using M = typename std::decay_t<decltype(sp)>::Material;
            ParticleArrays& P = sp.p;
            const std::size_t n0 = P.size(), n = x.size();
            P.x.insert(P.x.end(), x.begin(), x.end());
            P.v.resize(n0 + n, v);
            P.C.resize(n0 + n, Mat3f::Zero());
            P.mass.resize(n0 + n, mass);
            P.volume0.resize(n0 + n, volume);
            P.set.resize(n0 + n, set);
            for (std::size_t i = 0; i < n; ++i) P.id.push_back(nextId_++);
            // A model whose rest state depends on its parameters (sand's cone) takes them.
            if constexpr (requires { sp.state.appendRest(n, sp.params); }) sp.state.appendRest(n, sp.params);
            else sp.state.appendRest(n);
            for (std::size_t i = n0; i < n0 + n; ++i)
                minStiffnessKey_[s] = std::min(minStiffnessKey_[s], M::stiffnessKey(sp.state, i));
        },
        species_.at(s));
    if (!x.empty()) maxSpeed_ = std::max(maxSpeed_, v.norm());
}

std::size_t Simulation::particleCount() const {
    std::size_t n = 0;
    for (const AnySpecies& s : species_) n += particlesOf(s).size();
    return n;
}

void Simulation::emitDue() {
    if (emittedFrame_ == frame_) return;
    emittedFrame_ = frame_;
    for (const Emitter& e : emitters_)
        if (e.emitsAt(frame_)) addParticles(e.species, e.positions, e.velocity, e.mass, e.volume, e.set);
}

double Simulation::cflTimeStep() const {
    if (!settings_.adaptive) return std::numeric_limits<double>::infinity();
    float c = 0.0f;
    for (std::size_t s = 0; s < species_.size(); ++s) {
        if (particlesOf(species_[s]).size() == 0) continue;
        c = std::max(c, std::visit(
                            [&](const auto& sp) {
                                using M = typename std::decay_t<decltype(sp)>::Material;
                                return M::waveSpeed(sp.params, minStiffnessKey_[s]);
                            },
                            species_[s]));
    }
    // dt (c + |v| + |g| dt) = C dx: the speed bound is the one at the end of the step, so that gravity
    // cannot carry a very soft or resting body more than C dx in one step (c + |v| near 0 would allow any
    // dt). Solved without cancellation; it is C dx / (c + |v|) when g = 0.
    const double speed = double(c) + double(maxSpeed_), g = settings_.gravity.norm(), reach = settings_.cfl * settings_.dx;
    const double denominator = speed + std::sqrt(speed * speed + 4.0 * g * reach);
    return denominator > 0.0 ? 2.0 * reach / denominator : std::numeric_limits<double>::infinity();
}

void Simulation::refreshSpeedBound() {
    maxSpeed_ = 0.0f;
    for (const AnySpecies& s : species_)
        for (const Vec3f& v : particlesOf(s).v) maxSpeed_ = std::max(maxSpeed_, v.norm());
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

void Simulation::bin() {
    PhaseClock clock;
    std::vector<BinRequest> requests(species_.size());
    for (std::size_t s = 0; s < species_.size(); ++s) {
        std::visit([&](auto& sp) { requests[s] = BinRequest{&sp.p.x, &destination_[s], &sp.leafStart}; }, species_[s]);
    }
    grid_.updateTopology(requests);
    clock.lap(phases_.topology);
    grid_.sortParticles(requests);
    for (std::size_t s = 0; s < species_.size(); ++s) {
        const std::vector<uint32_t>& dest = destination_[s];
        // Particles rarely change leaf between substeps: skip the permutation when it is the identity.
        const bool identity = tbb::parallel_reduce(
            tbb::blocked_range<std::size_t>(0, dest.size(), kPermuteGrain), true,
            [&](const auto& r, bool ok) {
                for (std::size_t i = r.begin(); ok && i < r.end(); ++i) ok = dest[i] == i;
                return ok;
            },
            [](bool a, bool b) { return a && b; });
        if (!identity) std::visit([&](auto& sp) { permute(sp, dest); }, species_[s]);
    }
    clock.lap(phases_.binning);
}

float updateGridVelocities(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders,
                           const Vec3f& g, float dt, double tEnd) {
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, grid.leafCount()), 0.0f,
        [&](const tbb::blocked_range<std::size_t>& r, float vmax) {
            for (std::size_t l = r.begin(); l < r.end(); ++l) {
                const LeafView& leaf = grid.leaf(l);
                // Only the nodes P2G wrote: all others are zero, and stay so.
                const NodeBox& box = grid.writtenBox(l);
                // v = (mv) / m on nodes with mass (exact comparison: a threshold would lose momentum), then gravity.
                box.forEach([&](int n) {
                    Eigen::Map<Vec3f> v(leaf.momentum + 3 * n);
                    const float m = leaf.mass[n];
                    if (m != 0.0f) v = v / m + dt * g;
                    else v.setZero();
                });
                for (const auto& c : colliders) c->applyToLeaf(leaf, box, grid.dx(), tEnd);
                box.forEach([&](int n) {
                    if (leaf.mass[n] != 0.0f) vmax = std::max(vmax, Eigen::Map<const Vec3f>(leaf.momentum + 3 * n).norm());
                });
            }
            return vmax;
        },
        [](float a, float b) { return std::max(a, b); });
}

float Simulation::updateGrid(float dt) {
    return updateGridVelocities(grid_, colliders_, settings_.gravity.cast<float>(), dt, time_ + dt);
}

double Simulation::substep(double dtMax) {
    // Bin particles by leaf; allocate the leaves their stencils reach and release the others.
    bin();
    PhaseClock clock;
    // Time step: the caller's bound (target and frame end), and the CFL condition (halved on retries).
    double dt = std::min(dtMax, cflTimeStep() * dtScale_);
    // P2G: mass and momentum, with the stress impulse of this step folded in (thesis 3.14, 3.15, 3.24).
    particlesToGrid(grid_, species_, settings_.transfer, float(dt));
    clock.lap(phases_.p2g);
    // Grid update: v = mv/m, gravity, colliders and friction (3.20, 3.26, section 5).
    const float vmaxGrid = updateGrid(float(dt));
    clock.lap(phases_.grid);
    // Thesis pseudocode 3: if a node would move more than maxDisplacement cells, redo with a shorter step.
    if (settings_.maxDisplacement > 0.0 && vmaxGrid * dt > settings_.maxDisplacement * settings_.dx) {
        dt = settings_.maxDisplacement * settings_.dx / vmaxGrid;
        particlesToGrid(grid_, species_, settings_.transfer, float(dt));
        clock.lap(phases_.p2g);
        updateGrid(float(dt));
        clock.lap(phases_.grid);
    }
    // G2P: velocity, affine velocity, deformation update with return mapping, advection (3.17-3.19, 3.21).
    const G2PSummary g2p = gridToParticles(grid_, species_, settings_.transfer, float(dt));
    clock.lap(phases_.g2p);
    if (g2p.badParticle >= 0) fail(std::string("non-finite ") + g2p.badField, g2p.badSpecies, std::size_t(g2p.badParticle), dt);
    // Advection moved every particle by dt v: more than a cell means the step outran its own stencil.
    if (settings_.stability.cellCrossing && double(g2p.maxSpeed) * dt > settings_.dx) {
        const auto [s, i] = fastestParticle();
        std::ostringstream cause;
        cause << "particle moved " << double(g2p.maxSpeed) * dt / settings_.dx << " cells in one substep (speed "
              << g2p.maxSpeed << " m/s)";
        fail(cause.str(), s, i, dt);
    }
    const double cflBefore = cflTimeStep();
    maxSpeed_ = g2p.maxSpeed;
    minStiffnessKey_ = g2p.minStiffnessKey;
    // A material crushed (or a particle flung) far past anything physical makes the CFL step collapse and
    // the frame stall: stop there instead of crawling on with ever smaller steps.
    const double collapse = settings_.stability.stepCollapse;
    const double cflAfter = collapse > 0.0 ? cflTimeStep() : cflBefore;
    if (collapse > 0.0 && cflAfter < cflBefore / collapse) {
        const auto [s, i] = stiffestParticle();
        std::ostringstream cause;
        cause << "time step collapsed from " << cflBefore << " s to " << cflAfter
              << " s in one substep (wave speed or particle speed exploded; J = " << volumeRatioOf(s, i) << ")";
        fail(cause.str(), s, i, dt);
    }
    time_ += dt;
    ++substeps_;
    clock.lap(phases_.other);
    return dt;
}

void Simulation::fail(const std::string& cause, int s, std::size_t i, double dt) const {
    std::ostringstream msg;
    msg << cause << " at frame " << frame_ << ", substep " << substeps_ << " (t = " << time_ << " s, dt = " << dt
        << " s): particle id " << particlesOf(species_[s]).id[i] << " of species "
        << std::visit([](const auto& sp) { return sp.name; }, species_[s]);
    throw SimulationError(msg.str());
}

float Simulation::volumeRatioOf(int s, std::size_t i) const {
    return std::visit([&](const auto& sp) { return std::decay_t<decltype(sp)>::Material::volumeRatio(sp.state, i); }, species_[s]);
}

std::pair<int, std::size_t> Simulation::stiffestParticle() const {
    // The species with the fastest wave, and in it the particle with the smallest stiffness key.
    std::pair<int, std::size_t> best{0, 0};
    float cmax = -1.0f;
    for (std::size_t s = 0; s < species_.size(); ++s) {
        std::visit(
            [&](const auto& sp) {
                using M = typename std::decay_t<decltype(sp)>::Material;
                if (sp.size() == 0 || M::waveSpeed(sp.params, minStiffnessKey_[s]) <= cmax) return;
                cmax = M::waveSpeed(sp.params, minStiffnessKey_[s]);
                std::size_t arg = 0;
                for (std::size_t i = 1; i < sp.size(); ++i)
                    if (M::stiffnessKey(sp.state, i) < M::stiffnessKey(sp.state, arg)) arg = i;
                best = {int(s), arg};
            },
            species_[s]);
    }
    // Speed, not stiffness, may be what collapsed the step.
    const auto fast = fastestParticle();
    return particlesOf(species_[fast.first]).v[fast.second].norm() > cmax ? fast : best;
}

std::pair<int, std::size_t> Simulation::fastestParticle() const {
    std::pair<int, std::size_t> best{0, 0};
    float vmax = -1.0f;
    for (std::size_t s = 0; s < species_.size(); ++s) {
        const ParticleArrays& P = particlesOf(species_[s]);
        for (std::size_t i = 0; i < P.size(); ++i)
            if (P.v[i].squaredNorm() > vmax) vmax = P.v[i].squaredNorm(), best = {int(s), i};
    }
    return best;
}

void Simulation::resetEnergyReference(const FrameStats& st) {
    energyReferenceSet_ = true;
    energyMin_ = st.totalEnergy();
    energyScale_ = std::max(energyScale_, st.kineticEnergy + st.elasticEnergy);
}

void Simulation::checkEnergy(const FrameStats& st) {
    const double limit = settings_.stability.energyGrowth;
    energyScale_ = std::max(energyScale_, st.kineticEnergy + st.elasticEnergy);
    // A body at rest has almost no kinetic energy: the floor of the scale is its weight over one cell.
    const double scale = energyScale_ + st.mass * settings_.gravity.norm() * settings_.dx;
    const double rise = st.totalEnergy() - energyMin_;
    if (limit > 0.0 && particleCount() > 0 && rise > limit * scale) {
        const auto [s, i] = fastestParticle();
        std::ostringstream cause;
        cause << "total energy rose by " << rise << " J without external work (" << 100.0 * rise / scale
              << "% of the largest kinetic + stored energy; the limit is " << 100.0 * limit << "%); fastest";
        fail(cause.str(), s, i, 0.0);
    }
    energyMin_ = std::min(energyMin_, st.totalEnergy());
}

/// What a retry restores: every particle and the clocks. The grid is rebuilt from particles each substep.
struct Simulation::Snapshot {
    std::vector<AnySpecies> species;
    double time;
    long long substeps;
    float maxSpeed;
    std::vector<float> minStiffnessKey;
    double energyMin, energyScale;
};

int Simulation::runFrameSubsteps() {
    const double frameEnd = double(frame_ + 1) / settings_.fps;
    int steps = 0;
    while (time_ < frameEnd) {
        const double remaining = frameEnd - time_;
        const double dtMax = std::min(settings_.targetDt(), cflTimeStep()) * dtScale_;
        // Split the rest of the frame into equal substeps so that the last one lands on the frame time.
        const double pieces = std::max(1.0, std::ceil(remaining / dtMax - kFrameSplitSlack));
        const double dt = remaining / pieces;
        const double taken = substep(dt);
        ++steps;
        if (settings_.stability.energyGrowth > 0.0 && substeps_ % kEnergyCheckInterval == 0) checkEnergy(measure());
        if (pieces == 1.0 && taken == dt) time_ = frameEnd;
    }
    return steps;
}

FrameStats Simulation::advanceFrame() {
    const auto start = std::chrono::steady_clock::now();
    emitDue();
    if (!energyReferenceSet_) resetEnergyReference(measure());
    std::unique_ptr<Snapshot> snap;
    if (settings_.stability.retries > 0)
        snap.reset(new Snapshot{species_, time_, substeps_, maxSpeed_, minStiffnessKey_, energyMin_, energyScale_});
    int steps = 0, retries = 0;
    FrameStats st;
    for (;;) {
        try {
            steps = runFrameSubsteps();
            st = measure();
            checkEnergy(st);
            break;
        } catch (const SimulationError& e) {
            if (retries >= settings_.stability.retries) {
                dtScale_ = 1.0;
                throw;
            }
            // Restart the frame from its start with half the time step.
            species_ = snap->species;
            time_ = snap->time;
            substeps_ = snap->substeps;
            maxSpeed_ = snap->maxSpeed;
            minStiffnessKey_ = snap->minStiffnessKey;
            energyMin_ = snap->energyMin;
            energyScale_ = snap->energyScale;
            dtScale_ *= 0.5;
            ++retries;
            ++retriesTotal_;
        }
    }
    dtScale_ = 1.0;
    ++frame_;
    const std::size_t before = particleCount();
    emitDue();
    if (particleCount() != before) {
        // New material brings its own energy: measure again and restart the growth reference.
        st = measure();
        resetEnergyReference(st);
    }
    st.frame = frame_;
    st.substeps = steps;
    st.retries = retries;
    st.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return st;
}

FrameStats Simulation::measure() const {
    FrameStats st = measureParticles(species_, settings_.dx, kernelInertiaScale(), settings_.gravity);
    st.frame = frame_;
    st.time = time_;
    st.activeLeaves = grid_.leafCount();
    st.gridBytes = grid_.memoryBytes();
    return st;
}

}  // namespace mpm
