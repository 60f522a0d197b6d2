#include "core/Simulation.h"
// What the colliders and rigid bodies need from the simulation: the `separate` walls' rest density for the
// surface contact test, and the bodies' poses and motion through a substep.

#include <algorithm>
#include <array>
#include <cmath>

#include "sparse/LeafLookup.h"
#include "sparse/LeafParallel.h"

namespace mpm {

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
    for (std::size_t k = 0; k < bodies_.size(); ++k) {
        const RigidBodyModel& model = bodies_[k].model;
        const bool animated = model.animatedAt(state_.time);
        *bodies_[k].frame = model.frame(animated ? model.animated(state_.time + dt) : model.moved(state_.bodies[k], dt));
        bodies_[k].frame->released = !animated;
    }
}

float Simulation::moveBodies(double dt, const std::vector<BodyImpulse>& nodes, const std::vector<BodyImpulse>& particles) {
    float fastest = 0.0f;
    if (bodies_.empty()) return fastest;
    // What bodies touch that they cannot move: the colliders that are not bodies, and the bodies still animated.
    std::vector<FixedCollider> fixed;
    for (const auto& c : colliders_)
        if (!c->dynamic()) fixed.push_back(FixedCollider{c.get(), 0.0});
    for (const Body& b : bodies_)
        if (b.model.animatedAt(state_.time))
            for (FixedCollider& f : fixed)
                if (f.collider == colliders_[b.collider].get()) f.restitution = b.model.restitution;
    for (std::size_t k = 0; k < bodies_.size(); ++k) {
        const Body& b = bodies_[k];
        if (b.model.animatedAt(state_.time)) {
            // Prescribed: where its animation has it (the collider passes booked its work as a moving collider's).
            state_.bodies[k] = b.model.animated(state_.time + dt);
            *b.frame = b.model.frame(state_.bodies[k]);
            b.frame->released = false;
            continue;
        }
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
            double wallWork = 0.0;
            b.model.touch(next, fixed, state_.time + dt, dt, settings_.gravity, wallWork);
            // A moving collider's push on the body is work from outside, as its push on the material is.
            state_.energy.work += wallWork;
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
                // An animated body is one of the fixed colliders the other touched.
                if (a.model.animatedAt(state_.time) || b.model.animatedAt(state_.time)) continue;
                RigidBodyState &sa = state_.bodies[i], &sb = state_.bodies[j];
                const double before = a.model.energy(sa, settings_.gravity, dt) + b.model.energy(sb, settings_.gravity, dt);
                if (touchBodies(a.model, sa, *colliders_[a.collider], b.model, sb, *colliders_[b.collider], state_.time + dt, dt,
                                settings_.gravity) == 0)
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

}  // namespace mpm
