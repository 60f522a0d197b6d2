#pragma once
// Snow (Stomakhin et al. 2013, eq. 1-3 and sec. 7; thesis 4.9-4.11, pseudocode 6): fixed corotated
// elasticity on the elastic part F_E with hardened Lame parameters
//   mu = mu0 h, lambda = lambda0 h, h = exp(xi (1 - J_P)),
// and plasticity by clamping the singular values of F_E to [1 - theta_c, 1 + theta_s] after each update;
// the plastic volume J_P <- J_P det(F_E trial) / det(F_E) is all that is kept of F_P.
#include <cmath>
#include <vector>

#include "materials/ElasticPart.h"
#include "materials/FixedCorotated.h"

namespace mpm {

struct Snow {
    static constexpr const char* kName = "snow";
    static constexpr const char* kSceneName = "snow";
    /// The colour its points take unless a set gives one (Cd, linear RGB).
    static constexpr float kColour[3] = {0.92f, 0.94f, 0.97f};
    static constexpr const char* kSummary =
        "Stomakhin et al. 2013 snow: fixed corotated on F_E, hardening, clamped singular values";
    struct Params {
        float density = kThesisElasticDensity;  ///< thesis Fig. 6.1
        float mu = Lame::fromYoung(kThesisElastic.E, kThesisElastic.nu).mu;
        float lambda = Lame::fromYoung(kThesisElastic.E, kThesisElastic.nu).lambda;
        float thetaC = 0.025f;   ///< critical compression
        float thetaS = 0.0075f;  ///< critical stretch
        float xi = 10.0f;        ///< hardening coefficient
    };

    /// Packed snow stiffens (xi > 0), and its wave speed with it: the CFL step at rest overestimates the run's.
    static const char* stiffens(const Params& p) {
        return p.xi > 0.0f ? "hardens as it is packed (its moduli grow as exp(xi (1 - J_P)))" : nullptr;
    }

    struct State {
        std::vector<Mat3d> Fe;   ///< in double: materials/ElasticPart.h
        std::vector<double> Jp;  ///< in double for the same reason: a step's plastic volume change can be under float's ulp
        template <class Fn>
        void forEachArray(Fn&& f) {
            f(Fe);
            f(Jp);
        }
        template <class Fn>
        void forEachArray(Fn&& f) const {
            f(Fe);
            f(Jp);
        }
        void appendRest(std::size_t n) {
            Fe.resize(Fe.size() + n, Mat3d::Identity());
            Jp.resize(Jp.size() + n, 1.0);
        }
    };

    template <class V>
    static void keys(V& v, Params& p) {
        elasticKeys(v, p.density, p.mu, p.lambda, kThesisElastic);
        v.number(Key{.name = "theta_c", .help = "critical compression theta_c", .lo = 0.0, .hi = 1.0}, p.thetaC);
        v.number(Key{.name = "theta_s", .help = "critical stretch theta_s", .lo = 0.0, .hi = 10.0}, p.thetaS);
        v.number(Key{.name = "xi", .help = "hardening coefficient xi", .lo = 0.0, .hi = 100.0}, p.xi);
    }
    static void scaleStiffness(Params& p, double lambdaScale, double muScale) { scaleLame(p.mu, p.lambda, lambdaScale, muScale); }

    static float hardening(const Params& m, float Jp) { return std::exp(m.xi * (1.0f - Jp)); }

    static Mat3f kirchhoff(const Params& m, const State& s, std::size_t i) {
        const float h = hardening(m, float(s.Jp[i]));
        return FixedCorotated::kirchhoffOf<float>(m.mu * h, m.lambda * h, deformationGradient(s, i));
    }
    /// kirchhoff for n <= simd::kLanes particles from first, their SVDs in SIMD lanes.
    static void kirchhoffBatch(const LaneParams<Params>& m, const State& s, std::size_t first, int n, Mat3f* tau) {
        Mat3f F[simd::kLanes];
        Svd3<float> d[simd::kLanes];
        narrowAndSvd(&s.Fe[first], n, F, d);
        for (int k = 0; k < n; ++k) {
            const float h = hardening(m[k], float(s.Jp[first + k]));
            tau[k] = FixedCorotated::kirchhoffOf<float>(m[k].mu * h, m[k].lambda * h, F[k], d[k]);
        }
    }

    /// Elastic predictor F_E trial = (I + dt grad v) F_E, then the return map.
    static void updateDeformation(const Params& m, State& s, std::size_t i, const Mat3f& gradV, float dt) {
        predictAndReturnMap<Snow>(m, s, i, gradV, dt);
    }
    static void updateDeformationBatch(const LaneParams<Params>& m, State& s, std::size_t first, int n, const Mat3f* gradV,
                                       float dt) {
        predictAndReturnMapBatch<Snow>(m, s, first, n, gradV, dt);
    }
    /// Clamp sigma of the trial F_E = U Sigma V^T, and push the clamped-away volume into J_P.
    static void returnMap(const Params& m, State& s, std::size_t i, const ElasticTrial& t) {
        const Vec3f clamped = t.d.sigma.cwiseMax(1.0f - m.thetaC).cwiseMin(1.0f + m.thetaS);
        s.Fe[i] = t.returned(clamped - t.d.sigma);
        // J_P times det(trial) / det(F_E), one ratio per stretch: exactly 1 where the stretch was not clamped.
        double ratio = 1.0;
        for (int a = 0; a < 3; ++a) ratio *= double(t.d.sigma[a]) / double(clamped[a]);
        s.Jp[i] = std::min(s.Jp[i] * ratio, double(kMaxPlasticVolume));
    }
    /// J_P's ceiling. A particle that flew off alone keeps its affine velocity C under APIC, so a C with
    /// positive trace grows J_P exponentially, to float overflow within seconds (the spinning sphere of the
    /// stability sweep). Past this value the hardening factor exp(xi (1 - J_P)) is below 1e-40 for any
    /// xi of 0.1 or more, so the cap changes no stress that float can tell apart.
    static constexpr float kMaxPlasticVolume = 1e3f;
    static double energyDensity(const Params& m, const State& s, std::size_t i) {
        const double h = hardening(m, float(s.Jp[i]));
        return FixedCorotated::psi<double>(m.mu * h, m.lambda * h, s.Fe[i]);
    }
    static float volumeRatio(const State& s, std::size_t i) { return float(s.Fe[i].determinant() * s.Jp[i]); }
    static Mat3f deformationGradient(const State& s, std::size_t i) { return s.Fe[i].cast<float>(); }
    static float plasticVolumeRatio(const State& s, std::size_t i) { return float(s.Jp[i]); }
    /// Hardening grows as J_P shrinks, so the smallest J_P sets the fastest wave.
    static float stiffnessKey(const State& s, std::size_t i) { return float(s.Jp[i]); }
    static float waveSpeed(const Params& m, float minJp) {
        return elasticWaveSpeed(m.mu, m.lambda, m.density) * std::sqrt(hardening(m, minJp));
    }
};

}  // namespace mpm
