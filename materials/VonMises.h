#pragma once
// Metal: von Mises (J2) plasticity with linear isotropic hardening on Hencky (log-strain) elasticity, the
// multiplicative return map of Simo 1992 ("Algorithms for static and dynamic multiplicative plasticity that
// preserve the classical return mapping schemes of the infinitesimal theory", CMAME 99) in the principal frame
// of the elastic stretch; Simo and Hughes 1998, Computational Inelasticity, Box 3.2 and sec. 9.2. With
// F_E = U Sigma V^T and eps = ln Sigma:
//   tau = U (2 mu eps + lambda tr(eps) I) U^T,     yield f = |dev tau| - sqrt(2/3) (sigma_y + H alpha) <= 0,
// and a trial state past it returns radially in the deviatoric plane:
//   dgamma = f / (2 mu + 2 H / 3),   dev eps -= dgamma n (n = dev eps / |dev eps|),   alpha += sqrt(2/3) dgamma.
// alpha is the equivalent plastic strain; the plastic flow keeps the volume (J2 flow is isochoric). In uniaxial
// tension the Kirchhoff stress yields at sigma_y and then rises with the log strain at E H / (E + H).
#include <cmath>
#include <vector>

#include "materials/Elastic.h"
#include "materials/ElasticPart.h"
#include "materials/Sand.h"

namespace mpm {

struct VonMises {
    static constexpr const char* kName = "von_mises";
    static constexpr const char* kSceneName = "metal";
    /// The colour its points take unless a set gives one (Cd, linear RGB).
    static constexpr float kColour[3] = {0.72f, 0.74f, 0.78f};
    static constexpr const char* kSummary =
        "metal: von Mises plasticity with linear isotropic hardening on Hencky elasticity (Simo 1992; Simo and Hughes 1998, Box "
        "3.2)";
    static constexpr int kDim = 3;
    /// Aluminium alloy 6061-T6: E 68.9 GPa, nu 0.33, rho 2700 kg/m^3, yield stress 276 MPa; the hardening modulus
    /// is the mean slope from yield to the ultimate stress of 310 MPa at about 12% strain (ASM handbook values).
    static constexpr YoungPoisson kElastic{68.9e9, 0.33};

    struct Params {
        float density = 2700.0f;
        float mu = Lame::fromYoung(kElastic.E, kElastic.nu).mu;
        float lambda = Lame::fromYoung(kElastic.E, kElastic.nu).lambda;
        float yieldStress = 276e6f;  ///< sigma_y [Pa]
        float hardening = 0.3e9f;    ///< H [Pa]: the yield stress grows by H per unit of equivalent plastic strain
    };

    struct State {
        std::vector<Mat3d> Fe;     ///< in double: materials/ElasticPart.h
        std::vector<float> alpha;  ///< equivalent plastic strain
        template <class Fn>
        void forEachArray(Fn&& f) {
            f(Fe);
            f(alpha);
        }
        template <class Fn>
        void forEachArray(Fn&& f) const {
            f(Fe);
            f(alpha);
        }
        void appendRest(std::size_t n) {
            Fe.resize(Fe.size() + n, Mat3d::Identity());
            alpha.resize(alpha.size() + n, 0.0f);
        }
    };

    template <class V>
    static void keys(V& v, Params& p) {
        elasticKeys(v, p.density, p.mu, p.lambda, kElastic);
        v.number(Key{.name = "yield_stress",
                     .help = "von Mises yield stress sigma_y (uniaxial)",
                     .lo = kTiny,
                     .hi = kHuge,
                     .unit = "Pa"},
                 p.yieldStress);
        v.number(Key{.name = "hardening",
                     .help = "linear isotropic hardening modulus H: sigma_y grows by H per unit plastic strain",
                     .lo = 0.0,
                     .hi = kHuge,
                     .unit = "Pa"},
                 p.hardening);
    }
    static void scaleStiffness(Params& p, double lambdaScale, double muScale) { scaleLame(p.mu, p.lambda, lambdaScale, muScale); }

    /// The radial return of log principal strains eps at plastic strain alpha: the returned strains and the increment of alpha.
    static Vec3f project(const Params& m, const Vec3f& eps, float alpha, float& dAlpha) {
        dAlpha = 0.0f;
        const Vec3f dev = eps - Vec3f::Constant(eps.sum() / kDim);
        const float devNorm = dev.norm();
        const float sqrtTwoThirds = std::sqrt(2.0f / 3.0f);
        const float f = 2.0f * m.mu * devNorm - sqrtTwoThirds * (m.yieldStress + m.hardening * alpha);
        if (f <= 0.0f) return eps;
        const float dgamma = f / (2.0f * m.mu + 2.0f / 3.0f * m.hardening);
        dAlpha = sqrtTwoThirds * dgamma;
        return eps - (dgamma / devNorm) * dev;
    }

    /// Hencky's tau = U (2 mu eps + lambda tr(eps) I) U^T, the formula of Sand::kirchhoffOf. Written here, not called
    /// there: a second caller changed how GCC inlines sand's copy, and with it where FMA contraction falls
    /// (-ffp-contract=fast on x86-64-v3), which moved sand's bits (the sand_pile_pic golden) with no change of physics.
    static Mat3f henckyTau(float mu, float lambda, const Svd3<float>& d) {
        const Vec3f e = d.sigma.array().abs().log().matrix();
        const Vec3f t = 2.0f * mu * e + Vec3f::Constant(lambda * e.sum());
        return d.U * t.asDiagonal() * d.U.transpose();
    }
    static Mat3f kirchhoff(const Params& m, const State& s, std::size_t i) {
        return henckyTau(m.mu, m.lambda, svd3<float>(deformationGradient(s, i)));
    }
    static void kirchhoffBatch(const LaneParams<Params>& m, const State& s, std::size_t first, int n, Mat3f* tau) {
        Mat3f F[simd::kLanes];
        Svd3<float> d[simd::kLanes];
        narrowAndSvd(&s.Fe[first], n, F, d);
        for (int k = 0; k < n; ++k) tau[k] = henckyTau(m[k].mu, m[k].lambda, d[k]);
    }

    /// Elastic predictor F_E trial = (I + dt grad v) F_E, then the return map.
    static void updateDeformation(const Params& m, State& s, std::size_t i, const Mat3f& gradV, float dt) {
        predictAndReturnMap<VonMises>(m, s, i, gradV, dt);
    }
    static void updateDeformationBatch(const LaneParams<Params>& m, State& s, std::size_t first, int n, const Mat3f* gradV,
                                       float dt) {
        predictAndReturnMapBatch<VonMises>(m, s, first, n, gradV, dt);
    }
    static void returnMap(const Params& m, State& s, std::size_t i, const ElasticTrial& t) {
        const Vec3f eps = logStretches(t.d.sigma);
        float dAlpha = 0.0f;
        const Vec3f H = project(m, eps, s.alpha[i], dAlpha);
        s.Fe[i] = t.returnedToLog(eps, H);
        s.alpha[i] += dAlpha;
    }

    static double energyDensity(const Params& m, const State& s, std::size_t i) {
        return Sand::psi<double>(m.mu, m.lambda, s.Fe[i]);
    }
    static float volumeRatio(const State& s, std::size_t i) { return float(s.Fe[i].determinant()); }
    static Mat3f deformationGradient(const State& s, std::size_t i) { return s.Fe[i].cast<float>(); }
    static float plasticStrain(const State& s, std::size_t i) { return s.alpha[i]; }
    static float stiffnessKey(const State& s, std::size_t i) { return float(s.Fe[i].determinant()); }
    static float waveSpeed(const Params& m, float) { return elasticWaveSpeed(m.mu, m.lambda, m.density); }
};

}  // namespace mpm
