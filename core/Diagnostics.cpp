#include "core/Diagnostics.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cstdio>
#include <limits>

namespace mpm {

namespace {
constexpr std::size_t kReduceGrain = 8192;

struct Sums {
    double mass = 0, ke = 0, pe = 0, ge = 0, vmax = 0;
    Vec3d p = Vec3d::Zero(), L = Vec3d::Zero();
    double minJ = std::numeric_limits<double>::infinity(), maxJ = -std::numeric_limits<double>::infinity();
    Sums operator+(const Sums& o) const {
        Sums s;
        s.mass = mass + o.mass;
        s.ke = ke + o.ke;
        s.pe = pe + o.pe;
        s.ge = ge + o.ge;
        s.vmax = std::max(vmax, o.vmax);
        s.p = p + o.p;
        s.L = L + o.L;
        s.minJ = std::min(minJ, o.minJ);
        s.maxJ = std::max(maxJ, o.maxJ);
        return s;
    }
};
}  // namespace

FrameStats measureParticles(const std::vector<AnySpecies>& species, double dx, float inertiaScale, const Vec3d& gravity) {
    Sums total;
    const double D = inertiaScale * dx * dx;
    for (const AnySpecies& s : species) {
        total = total + std::visit(
                            [&](const auto& sp) {
                                using M = typename std::decay_t<decltype(sp)>::Material;
                                const ParticleArrays& P = sp.p;
                                return tbb::parallel_deterministic_reduce(
                                    tbb::blocked_range<std::size_t>(0, P.size(), kReduceGrain), Sums(),
                                    [&](const tbb::blocked_range<std::size_t>& r, Sums acc) {
                                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                                            const double m = P.mass[i];
                                            const Vec3d v = P.v[i].cast<double>();
                                            const Mat3d B = P.C[i].cast<double>() * D;
                                            acc.mass += m;
                                            acc.p += m * v;
                                            acc.L += P.x[i].cross(m * v) +
                                                     m * Vec3d(B(2, 1) - B(1, 2), B(0, 2) - B(2, 0), B(1, 0) - B(0, 1));
                                            // APIC's kinetic energy includes the affine part, 1/2 m D |C|^2 (B = C D): a spinning
                                            // body keeps part of its energy there, and hands it to v when it flies apart.
                                            acc.ke +=
                                                0.5 * m * (v.squaredNorm() + (B.array() * P.C[i].cast<double>().array()).sum());
                                            acc.pe += P.volume0[i] * M::energyDensity(sp.params, sp.state, i);
                                            acc.ge -= m * gravity.dot(P.x[i]);
                                            acc.vmax = std::max(acc.vmax, v.norm());
                                            const double J = M::volumeRatio(sp.state, i);
                                            acc.minJ = std::min(acc.minJ, J);
                                            acc.maxJ = std::max(acc.maxJ, J);
                                        }
                                        return acc;
                                    },
                                    [](const Sums& a, const Sums& b) { return a + b; });
                            },
                            s);
    }
    FrameStats st;
    for (const AnySpecies& s : species) st.particles += particlesOf(s).size();
    st.mass = total.mass;
    st.momentum = total.p;
    st.angularMomentum = total.L;
    st.kineticEnergy = total.ke;
    st.elasticEnergy = total.pe;
    st.gravityEnergy = total.ge;
    st.maxSpeed = total.vmax;
    if (st.particles) {
        st.minJ = total.minJ;
        st.maxJ = total.maxJ;
    }
    return st;
}

std::string FrameStats::csvHeader() {
    return "frame,time,particles,mass,momentum_x,momentum_y,momentum_z,angular_momentum_x,angular_momentum_y,"
           "angular_momentum_z,kinetic_energy,elastic_energy,gravity_energy,max_speed,min_J,max_J,active_leaves,grid_bytes,"
           "substeps,retries,step_dt,step_limit,wall_seconds";
}

std::string FrameStats::csvRow() const {
    char buf[1024], dt[32], wall[32];
    std::snprintf(buf, sizeof(buf), "%d,%.9g,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%zu,%zu,%d,%d,",
                  frame, time, particles, mass, momentum[0], momentum[1], momentum[2], angularMomentum[0], angularMomentum[1],
                  angularMomentum[2], kineticEnergy, elasticEnergy, gravityEnergy, maxSpeed, minJ, maxJ, activeLeaves, gridBytes,
                  substeps, retries);
    std::snprintf(dt, sizeof(dt), "%.9g,", stepDt);
    std::snprintf(wall, sizeof(wall), ",%.6f", wallSeconds);
    // The limit names a species, which may hold any character: quoted as CSV quotes (RFC 4180) when it must be.
    std::string limit = stepLimit;
    if (limit.find_first_of(",\"\n\r") != std::string::npos) {
        std::string q = "\"";
        for (char c : limit) q += c == '"' ? std::string("\"\"") : std::string(1, c);
        limit = q + "\"";
    }
    return std::string(buf) + dt + limit + wall;
}

}  // namespace mpm
