#pragma once
// Sand: Drucker-Prager elastoplasticity (Klar et al. 2016; thesis 4.12-4.18, pseudocode 7) with Hencky
// (log-strain) elasticity on F_E = U Sigma V^T, eps = ln Sigma:
//   Psi = mu tr(eps^2) + lambda/2 tr(eps)^2,   tau = U (2 mu eps + lambda tr(eps) I) U^T,
// a return map with three cases (Klar sec. 4.3.1), hardening q -> phi -> alpha (sec. 4.3.2) and the volume
// correction of Tampubolon et al. 2017 (sec. 4.3): log volume removed by projecting to the tip is kept and
// added back to tr(eps) on later steps, so sand that separated does not over-compress when it lands.
#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "materials/Elastic.h"
#include "materials/ElasticPart.h"

namespace mpm {

/// Which cone bounds the stress. Drucker-Prager's is Klar et al.'s: round, through Mohr-Coulomb's compression
/// corners, so it is up to (3 + sin phi) / (3 - sin phi) stronger than Mohr-Coulomb away from them: in plane strain
/// (a slab between walls) a 32 degree sand shears as a 48 degree one would. Mohr-Coulomb's hexagonal cone bounds
/// every stress state by the friction angle; at zero dilatancy a layer sheared along its length (a slope) yields
/// at tan(slope) = sin(phi), 28 degrees for phi 32.
enum class YieldSurface : uint8_t { DruckerPrager, MohrCoulomb };
inline constexpr Named<YieldSurface> kYieldSurfaces[] = {{YieldSurface::DruckerPrager, "drucker_prager"},
                                                         {YieldSurface::MohrCoulomb, "mohr_coulomb"}};

struct Sand {
    static constexpr const char* kName = "sand";
    static constexpr const char* kSceneName = "sand";
    /// The colour its points take unless a set gives one (Cd, linear RGB).
    static constexpr float kColour[3] = {0.76f, 0.6f, 0.38f};
    static constexpr const char* kSummary = "Drucker-Prager sand with Hencky elasticity (Klar et al. 2016; thesis 4.12-4.18)";
    static constexpr int kDim = 3;
    /// Thesis Fig. 6.1.
    static constexpr YoungPoisson kElastic{3.537e7, 0.2};

    struct Params {
        float density = 2200.0f;  ///< thesis Fig. 6.1
        float mu = Lame::fromYoung(kElastic.E, kElastic.nu).mu;
        float lambda = Lame::fromYoung(kElastic.E, kElastic.nu).lambda;
        // Hardening phi(q) = h0 + (h1 q - h3) exp(-h2 q), in degrees (Klar et al. 2016).
        float h0 = 35.0f, h1 = 9.0f, h2 = 0.2f, h3 = 10.0f;
        bool volumeCorrection = true;
        YieldSurface surface = YieldSurface::DruckerPrager;
    };

    struct State {
        std::vector<Mat3d> Fe;     ///< in double: materials/ElasticPart.h
        std::vector<float> q;      ///< accumulated plastic strain (hardening state)
        std::vector<float> alpha;  ///< cone coefficient from the friction angle
        std::vector<float> logVc;  ///< volume correction: log volume to add back
        template <class Fn>
        void forEachArray(Fn&& f) {
            f(Fe);
            f(q);
            f(alpha);
            f(logVc);
        }
        template <class Fn>
        void forEachArray(Fn&& f) const {
            f(Fe);
            f(q);
            f(alpha);
            f(logVc);
        }
        void appendRest(std::size_t n, const Params& m) {
            Fe.resize(Fe.size() + n, Mat3d::Identity());
            q.resize(q.size() + n, 0.0f);
            alpha.resize(alpha.size() + n, alphaOf(m, 0.0f));
            logVc.resize(logVc.size() + n, 0.0f);
        }
    };

    template <class V>
    static void keys(V& v, Params& p) {
        elasticKeys(v, p.density, p.mu, p.lambda, kElastic);
        v.number(Key{.name = "h0",
                     .help = "hardening h0 (friction angle phi = h0 + (h1 q - h3) exp(-h2 q))",
                     .lo = 0.0,
                     .hi = 89.0,
                     .unit = "degrees"},
                 p.h0);
        v.number(Key{.name = "h1", .help = "hardening h1", .lo = -89.0, .hi = 89.0, .unit = "degrees"}, p.h1);
        v.number(Key{.name = "h2", .help = "hardening h2", .lo = 0.0, .hi = 1e3}, p.h2);
        v.number(Key{.name = "h3", .help = "hardening h3", .lo = -89.0, .hi = 89.0, .unit = "degrees"}, p.h3);
        v.flag(Key{.name = "volume_correction", .help = "add back the volume lost to tip projections (Tampubolon et al. 2017)"},
               p.volumeCorrection);
        v.choice(Key{.name = "yield_surface",
                     .help = "drucker_prager: Klar et al.'s round cone, through Mohr-Coulomb's compression corners (stronger "
                             "elsewhere: a slab in plane strain shears as if phi were about 1.5 times larger); mohr_coulomb: "
                             "Mohr-Coulomb's hexagon, phi in every stress state (a layer on a slope, at zero dilatancy, "
                             "flows above tan(slope) = sin(phi))",
                     .noun = "yield surface"},
                 p.surface, std::span<const Named<YieldSurface>>(kYieldSurfaces));
    }
    static void scaleStiffness(Params& p, double lambdaScale, double muScale) { scaleLame(p.mu, p.lambda, lambdaScale, muScale); }

    /// alpha = sqrt(2/3) 2 sin(phi) / (3 - sin(phi)), phi from the hardening law.
    static float frictionAngleDegrees(const Params& m, float q) { return m.h0 + (m.h1 * q - m.h3) * std::exp(-m.h2 * q); }
    static float alphaOf(const Params& m, float q) {
        const float s = std::sin(frictionAngleDegrees(m, q) * float(M_PI) / 180.0f);
        return std::sqrt(2.0f / 3.0f) * 2.0f * s / (3.0f - s);
    }

    enum class Case { Elastic, Tip, Cone };
    struct Projection {
        Vec3f H;   ///< projected log singular values
        float dq;  ///< hardening increment
        Case which;
    };

    /// Klar et al. 2016, Algorithm 2 / thesis pseudocode 7: project the log strain onto the yield surface.
    static Projection project(const Params& m, const Vec3f& eps, float alpha) {
        const float tr = eps.sum();
        const Vec3f dev = eps - Vec3f::Constant(tr / kDim);
        const float devNorm = dev.norm();
        if (tr > 0.0f) return {Vec3f::Zero(), eps.norm(), Case::Tip};  // case II: tension, to the tip
        const float dgamma = devNorm + (kDim * m.lambda + 2.0f * m.mu) / (2.0f * m.mu) * tr * alpha;
        if (dgamma <= 0.0f) return {eps, 0.0f, Case::Elastic};  // case I: inside the cone
        // Case III, onto the cone. Here tr <= 0 and dgamma > 0, so devNorm > 0: Klar's "|eps_hat| = 0"
        // test only guards this division, and pure compression (devNorm = 0) is elastic, not the tip.
        return {eps - dgamma / devNorm * dev, dgamma, Case::Cone};
    }

    /// Cohesionless Mohr-Coulomb with zero dilatancy in principal Hencky strains: de Souza Neto, Peric and Owen
    /// 2008, Computational Methods for Plasticity, sec. 8.2.2 (return to the main plane, else to the edge it
    /// crossed), with psi = 0 so that, as in project(), the plastic flow keeps the volume, and tension goes to the
    /// tip. With t = 2 mu eps + lambda tr(eps), t1 >= t2 >= t3, a plane is f_ij = (t_i - t_j) + (t_i + t_j) sin phi <= 0
    /// and its flow takes d from eps_i and gives it to eps_j, which lowers f_ij by 4 mu d.
    static Projection projectMohrCoulomb(const Params& m, const Vec3f& eps, float sinPhi) {
        const float tr = eps.sum();
        if (tr > 0.0f) return {Vec3f::Zero(), eps.norm(), Case::Tip};
        int k[3] = {0, 1, 2};  // eps[k[0]] >= eps[k[1]] >= eps[k[2]]: the stresses order alike
        if (eps[k[0]] < eps[k[1]]) std::swap(k[0], k[1]);
        if (eps[k[1]] < eps[k[2]]) std::swap(k[1], k[2]);
        if (eps[k[0]] < eps[k[1]]) std::swap(k[0], k[1]);
        const float e1 = eps[k[0]], e2 = eps[k[1]], e3 = eps[k[2]];
        const float twoMu = 2.0f * m.mu, lt = m.lambda * tr;
        const float t1 = twoMu * e1 + lt, t2 = twoMu * e2 + lt, t3 = twoMu * e3 + lt;
        const auto plane = [sinPhi](float ti, float tj) { return (ti - tj) + (ti + tj) * sinPhi; };
        const float f13 = plane(t1, t3);
        if (f13 <= 0.0f) return {eps, 0.0f, Case::Elastic};
        // The strain each principal direction gives up, in sorted order.
        Vec3f d;
        const float main = f13 / (2.0f * twoMu);
        // Two planes at once (an edge): solve 2 mu [[2, c], [c, 2]] (x, y) = (f13, f), c the planes' coupling.
        const auto edge = [&](float f, float c, float& x, float& y) {
            const float det = twoMu * (4.0f - c * c);
            x = (2.0f * f13 - c * f) / det;
            y = (2.0f * f - c * f13) / det;
            return x >= 0.0f && y >= 0.0f;
        };
        float x = 0.0f, y = 0.0f;
        if (e1 - main >= e2 && e3 + main <= e2)
            d = Vec3f(main, 0.0f, -main);  // the main plane, the order kept
        else if (e1 - main < e2 && edge(plane(t2, t3), 1.0f - sinPhi, x, y) && e2 - y >= e3 + x + y)
            d = Vec3f(x, y, -(x + y));  // the edge where the two largest meet: planes 13 and 23
        else if (edge(plane(t1, t2), 1.0f + sinPhi, x, y) && e1 - x - y >= e2 + y)
            d = Vec3f(x + y, -y, -x);  // the edge where the two smallest meet: planes 13 and 12
        else
            d = Vec3f(e1, e2, e3) - Vec3f::Constant(tr / kDim);  // onto the axis at the same pressure
        Vec3f H = eps;
        for (int a = 0; a < 3; ++a) H[k[a]] -= d[a];
        return {H, d.norm(), Case::Cone};
    }

    template <class T>
    static T psi(T mu, T lambda, const Mat3T<T>& F) {
        const Svd3<T> s = svd3<T>(F);
        const Vec3T<T> e = s.sigma.array().abs().log().matrix();
        return mu * e.squaredNorm() + T(0.5) * lambda * e.sum() * e.sum();
    }
    template <class T>
    static Mat3T<T> kirchhoffOf(T mu, T lambda, const Mat3T<T>& F) {
        return kirchhoffOf<T>(mu, lambda, svd3<T>(F));
    }
    template <class T>
    static Mat3T<T> kirchhoffOf(T mu, T lambda, const Svd3<T>& s) {
        const Vec3T<T> e = s.sigma.array().abs().log().matrix();
        const Vec3T<T> t = T(2) * mu * e + Vec3T<T>::Constant(lambda * e.sum());
        return s.U * t.asDiagonal() * s.U.transpose();
    }
    template <class T>
    static Mat3T<T> piola(T mu, T lambda, const Mat3T<T>& F) {
        return kirchhoffOf<T>(mu, lambda, F) * F.inverse().transpose();
    }

    static Mat3f kirchhoff(const Params& m, const State& s, std::size_t i) {
        return kirchhoffOf<float>(m.mu, m.lambda, deformationGradient(s, i));
    }
    /// kirchhoff for n <= simd::kLanes particles from first, their SVDs in SIMD lanes.
    static void kirchhoffBatch(const LaneParams<Params>& m, const State& s, std::size_t first, int n, Mat3f* tau) {
        Mat3f F[simd::kLanes];
        Svd3<float> d[simd::kLanes];
        narrowAndSvd(&s.Fe[first], n, F, d);
        for (int k = 0; k < n; ++k) tau[k] = kirchhoffOf<float>(m[k].mu, m[k].lambda, d[k]);
    }

    /// Elastic predictor F_E trial = (I + dt grad v) F_E, then the return map.
    static void updateDeformation(const Params& m, State& s, std::size_t i, const Mat3f& gradV, float dt) {
        predictAndReturnMap<Sand>(m, s, i, gradV, dt);
    }
    static void updateDeformationBatch(const LaneParams<Params>& m, State& s, std::size_t first, int n, const Mat3f* gradV,
                                       float dt) {
        predictAndReturnMapBatch<Sand>(m, s, first, n, gradV, dt);
    }
    /// Project eps = ln Sigma of the trial F_E = U Sigma V^T (plus the volume correction) and harden.
    static void returnMap(const Params& m, State& s, std::size_t i, const ElasticTrial& t) {
        const Vec3f lnSigma = logStretches(t.d.sigma);
        Vec3f eps = lnSigma;
        if (m.volumeCorrection) eps += Vec3f::Constant(s.logVc[i] / kDim);
        const Projection p = m.surface == YieldSurface::MohrCoulomb
                                 ? projectMohrCoulomb(m, eps, std::sin(frictionAngleDegrees(m, s.q[i]) * float(M_PI) / 180.0f))
                                 : project(m, eps, s.alpha[i]);
        s.Fe[i] = t.returnedToLog(lnSigma, p.H);
        if (m.volumeCorrection) s.logVc[i] = eps.sum() - p.H.sum();
        s.q[i] += p.dq;
        s.alpha[i] = alphaOf(m, s.q[i]);
    }
    static double energyDensity(const Params& m, const State& s, std::size_t i) { return psi<double>(m.mu, m.lambda, s.Fe[i]); }
    static float volumeRatio(const State& s, std::size_t i) { return float(s.Fe[i].determinant()); }
    static Mat3f deformationGradient(const State& s, std::size_t i) { return s.Fe[i].cast<float>(); }
    /// The volume change the return mapping took out of Fe, which the volume correction keeps as log v_c.
    static float plasticVolumeRatio(const State& s, std::size_t i) { return std::exp(s.logVc[i]); }
    static float stiffnessKey(const State& s, std::size_t i) { return float(s.Fe[i].determinant()); }
    static float waveSpeed(const Params& m, float) { return elasticWaveSpeed(m.mu, m.lambda, m.density); }
};

}  // namespace mpm
