#include "core/Diagnostics.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cstdio>
#include <limits>

namespace mpm {

namespace {
constexpr std::size_t kReduceGrain = 8192;
enum Sum { kMass, kKinetic, kElastic, kGravity, kMomentum, kAngular = kMomentum + 3 };
static_assert(kAngular + 3 == ParticleSums::kSums);
}  // namespace

void ParticleSums::add(const ParticleSums& o) {
    for (int k = 0; k < kSums; ++k) sum[k] += o.sum[k];
    maxSpeed = std::max(maxSpeed, o.maxSpeed);
    minJ = std::min(minJ, o.minJ);
    maxJ = std::max(maxJ, o.maxJ);
    particles += o.particles;
}

ParticleSums sumParticles(const std::vector<AnySpecies>& species, double dx, float inertiaScale, const Vec3d& gravity) {
    ParticleSums total;
    const double D = inertiaScale * dx * dx;
    for (const AnySpecies& s : species) {
        const ParticleSums part = std::visit(
            [&](const auto& sp) {
                using M = typename std::decay_t<decltype(sp)>::Material;
                const ParticleArrays& P = sp.p;
                return tbb::parallel_reduce(
                    tbb::blocked_range<std::size_t>(0, P.size(), kReduceGrain), ParticleSums(),
                    [&](const tbb::blocked_range<std::size_t>& r, ParticleSums acc) {
                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                            const double m = P.mass[i];
                            const Vec3d v = P.v[i].cast<double>();
                            const Mat3d B = P.C[i].cast<double>() * D;
                            const Vec3d p = m * v;
                            const Vec3d L = P.x[i].cross(p) + m * Vec3d(B(2, 1) - B(1, 2), B(0, 2) - B(2, 0), B(1, 0) - B(0, 1));
                            acc.sum[kMass] += m;
                            for (int a = 0; a < 3; ++a) acc.sum[kMomentum + a] += p[a], acc.sum[kAngular + a] += L[a];
                            // APIC's kinetic energy includes the affine part, 1/2 m D |C|^2 (B = C D): a spinning
                            // body keeps part of its energy there, and hands it to v when it flies apart.
                            acc.sum[kKinetic] += 0.5 * m * (v.squaredNorm() + (B.array() * P.C[i].cast<double>().array()).sum());
                            acc.sum[kElastic] += P.volume0[i] * M::energyDensity(sp.paramsOf(i), sp.state, i);
                            acc.sum[kGravity] += -m * gravity.dot(P.x[i]);
                            acc.maxSpeed = std::max(acc.maxSpeed, v.norm());
                            const double J = M::volumeRatio(sp.state, i);
                            acc.minJ = std::min(acc.minJ, J);
                            acc.maxJ = std::max(acc.maxJ, J);
                        }
                        acc.particles += r.size();
                        return acc;
                    },
                    [](ParticleSums a, const ParticleSums& b) {
                        a.add(b);
                        return a;
                    });
            },
            s);
        total.add(part);
        ExactSum energy = part.sum[kKinetic];
        energy += part.sum[kElastic];
        energy += part.sum[kGravity];
        total.speciesEnergy.push_back(energy);
    }
    return total;
}

FrameStats ParticleSums::stats() const {
    FrameStats st;
    st.particles = particles;
    st.mass = sum[kMass].value();
    for (int a = 0; a < 3; ++a) st.momentum[a] = sum[kMomentum + a].value(), st.angularMomentum[a] = sum[kAngular + a].value();
    st.kineticEnergy = sum[kKinetic].value();
    st.elasticEnergy = sum[kElastic].value();
    st.gravityEnergy = sum[kGravity].value();
    st.maxSpeed = maxSpeed;
    for (const ExactSum& e : speciesEnergy) st.speciesEnergy.push_back(e.value());
    if (particles) {
        st.minJ = minJ;
        st.maxJ = maxJ;
    }
    return st;
}

FrameStats measureParticles(const std::vector<AnySpecies>& species, double dx, float inertiaScale, const Vec3d& gravity) {
    return sumParticles(species, dx, inertiaScale, gravity).stats();
}

std::string FrameStats::csvHeader(std::size_t bodies) {
    std::string h =
        "frame,time,particles,mass,momentum_x,momentum_y,momentum_z,angular_momentum_x,angular_momentum_y,"
        "angular_momentum_z,kinetic_energy,elastic_energy,gravity_energy,max_speed,min_J,max_J,active_leaves,grid_bytes,"
        "substeps,retries,step_dt,step_limit,wall_seconds";
    static const char* const kBodyColumns[RigidBodyState::kDoubles] = {"x",  "y",  "z",  "qw", "qx", "qy", "qz",
                                                                       "vx", "vy", "vz", "wx", "wy", "wz"};
    for (std::size_t k = 0; k < bodies; ++k)
        for (const char* c : kBodyColumns) h += ",body" + std::to_string(k) + "_" + c;
    return h;
}

std::string csvField(const std::string& text) {
    if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
    std::string q = "\"";
    for (char c : text) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

std::string FrameStats::csvRow() const {
    char buf[1024], dt[32], wall[32];
    std::snprintf(buf, sizeof(buf), "%d,%.9g,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%zu,%zu,%d,%d,",
                  frame, time, particles, mass, momentum[0], momentum[1], momentum[2], angularMomentum[0], angularMomentum[1],
                  angularMomentum[2], kineticEnergy, elasticEnergy, gravityEnergy, maxSpeed, minJ, maxJ, activeLeaves, gridBytes,
                  substeps, retries);
    std::snprintf(dt, sizeof(dt), "%.9g,", stepDt);
    std::snprintf(wall, sizeof(wall), ",%.6f", wallSeconds);
    // The limit names a species, which may hold any character.
    std::string row = std::string(buf) + dt + csvField(stepLimit) + wall;
    for (const RigidBodyState& b : bodies) {
        double v[RigidBodyState::kDoubles];
        b.write(v);
        for (double x : v) {
            char cell[32];
            std::snprintf(cell, sizeof(cell), ",%.9g", x);
            row += cell;
        }
    }
    return row;
}

}  // namespace mpm
