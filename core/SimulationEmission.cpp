#include "core/Simulation.h"
// Emission: species, the particles a set adds at its frames, and the streams that enter during substeps.

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "core/FloatingPoint.h"

namespace mpm {

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
                              const std::vector<float>& volumes, const AnyParamsArray* local) {
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
        std::optional<AnyParamsArray> kept;
        if (local) kept = std::visit([&](const auto& all) { return AnyParamsArray(pick(all)); }, *local);
        appendParticles(s, kx, v, mass, volume, set, kv, km, kvol, kid, kept ? &*kept : nullptr);
    } else {
        appendParticles(s, x, v, mass, volume, set, perParticle, masses, volumes, ids, local);
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
    appendParticles(e.species, e.positions, e.velocity, e.mass, e.volume, e.set, e.velocities, e.masses, e.volumes, ids,
                    e.local ? &*e.local : nullptr);
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
                                 const std::vector<float>& volumes, const std::vector<int32_t>& ids,
                                 const AnyParamsArray* local) {
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
            using Params = typename M::Params;
            const auto* own = local ? std::get_if<std::vector<Params>>(local) : nullptr;
            if (sp.perParticle != bool(own) || (own && own->size() != n))
                throw std::logic_error(
                    "appendParticles: parameters per particle, one each, for a species that has them and only then");
            if (own) sp.local.insert(sp.local.end(), own->begin(), own->end());
            // A model whose rest state depends on its parameters (sand's cone) takes them.
            if constexpr (requires { sp.state.appendRest(n, sp.params); }) {
                if (own)
                    for (std::size_t i = 0; i < n; ++i) sp.state.appendRest(1, (*own)[i]);
                else
                    sp.state.appendRest(n, sp.params);
            } else {
                sp.state.appendRest(n);
            }
            float& key = state_.bounds.minStiffnessKey[s];
            for (std::size_t i = n0; i < n0 + n; ++i) key = std::min(key, M::stiffnessKey(sp.state, i));
        },
        state_.species.at(s));
    // A rank that kept none of them still takes their rest-state stiffness, as one process would.
    comm_->min(state_.bounds.minStiffnessKey);
}

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
                addParticles(e.species, e.positions, e.velocity, e.mass, e.volume, e.set, e.velocities, e.masses, e.volumes,
                             e.local ? &*e.local : nullptr);
                setAffine(e, before);
            }
            // Emitted for the last time: its samples (24 bytes a particle and more, on every rank) are not needed again.
            if (state_.frame == e.lastEmission()) {
                std::vector<Vec3d>().swap(e.positions);
                std::vector<Vec3f>().swap(e.velocities);
                std::vector<float>().swap(e.masses);
                std::vector<float>().swap(e.volumes);
                e.local.reset();
                e.released = true;
            }
        }
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

}  // namespace mpm
