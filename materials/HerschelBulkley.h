#pragma once
// Viscous and yield-stress liquids: Herschel-Bulkley viscoplastic flow on an elastic regularisation, the
// elasto-viscoplastic fluid of Yue et al. 2015 ("Continuum foam: a material point method for shear-dependent
// flows", ACM TOG 34(5)), with water's Tait-like equation of state for the pressure (materials/Water.h).
// With F_E = U Sigma V^T and eps = ln Sigma, the Kirchhoff stress is
//   tau = U (2 G dev(eps)) U^T - J p(J) I,   p(J) = k (J^-gamma - 1),   J = det F_E,
// and in simple shear the liquid flows at the rate gammaDot where its shear stress is
//   tau_xy = tau_y + K gammaDot^n   (Herschel-Bulkley; Bingham at n = 1, Newtonian at tau_y = 0 and n = 1),
// elastic with shear modulus G below the yield stress tau_y. In 3D the shear stress and rate are the equivalents
// tau_eq = |dev tau| / sqrt(2) and gammaDot = sqrt(2) |D_p|, which read tau_xy and gammaDot in simple shear.
// The flow is integrated implicitly over the step (backward Euler on the equivalent stress), in the return
// mapping's form: from the trial stress tau_tr, the plastic rate solves
//   G dt gammaDot + K gammaDot^n = tau_tr - tau_y,   tau_eq = tau_tr - G dt gammaDot,
// and dev(eps) shrinks radially to tau_eq / tau_tr of its trial. The update is stable at any viscosity: the
// stress it leaves is never above G dt gammaDot, so the time step is set by G's shear wave alone (waveSpeed),
// whatever K is. The price is elasticity: the liquid is a Maxwell fluid with relaxation time K / G (at n = 1),
// Newtonian where the flow's shear rate times K / G (the Deborah number) is small. docs/method.md, section 4.
#include <algorithm>
#include <cmath>
#include <vector>

#include "materials/ElasticPart.h"
#include "materials/VonMises.h"
#include "materials/Water.h"

namespace mpm {

struct HerschelBulkley {
    static constexpr const char* kName = "herschel_bulkley";
    static constexpr const char* kSceneName = "viscous";
    /// The colour its points take unless a set gives one (Cd, linear RGB).
    static constexpr float kColour[3] = {0.8f, 0.45f, 0.05f};
    static constexpr const char* kSummary =
        "viscous and yield-stress liquid: Herschel-Bulkley flow (Bingham and Newtonian as special cases) on an elastic "
        "regularisation, water's equation of state for pressure (Yue et al. 2015)";
    static constexpr int kDim = 3;

    /// Honey at room temperature (viscosity 10 Pa s, density 1400 kg/m^3), Newtonian. The bulk modulus is water's
    /// 5e4 Pa scaled with the density (the same sound speed, materials/Water.h).
    struct Params {
        float density = 1400.0f;      ///< rho0 [kg/m^3]
        float bulkModulus = 7.0e4f;   ///< k of the equation of state [Pa]
        float gamma = 4.0f;           ///< stiffening exponent of the equation of state
        bool tension = false;         ///< allow J > 1 (negative pressure); off: the volume is clamped to at most 1
        float viscosity = 10.0f;      ///< consistency K [Pa s^n]; the dynamic viscosity at n = 1
        float yieldStress = 0.0f;     ///< tau_y [Pa], in shear
        float flowIndex = 1.0f;       ///< n: below 1 shear-thinning, above 1 shear-thickening
        float shearModulus = 7.0e4f;  ///< G [Pa]: the elastic regularisation (by default k gamma / 4)
    };

    /// F_E and the equivalent plastic strain alpha (the flow's accumulated strain), as metal keeps them.
    using State = VonMises::State;

    /// G's default as a share of the equation of state's tangent bulk modulus k gamma: a quarter raises the P-wave
    /// speed, and so the cost of a step, by sqrt(1 + 1/3) = 15% over water's, while keeping the relaxation time
    /// K / G short (honey: 0.14 ms).
    static constexpr double kDefaultShearShare = 0.25;

    template <class V>
    static void keys(V& v, Params& p) {
        v.number(Key{.name = "density", .help = "rest density rho0", .lo = kTiny, .hi = kHuge, .unit = "kg/m^3"}, p.density);
        v.number(
            Key{.name = "bulk_modulus", .help = "bulk modulus k of the equation of state", .lo = 0.0, .hi = kHuge, .unit = "Pa"},
            p.bulkModulus);
        v.number(Key{.name = "gamma", .help = "stiffening exponent of the equation of state", .lo = 1.0, .hi = 20.0}, p.gamma);
        v.flag(Key{.name = "tension", .help = "hold negative pressure; false clamps the volume ratio to at most 1"}, p.tension);
        v.number(Key{.name = "viscosity",
                     .help = "consistency K: the dynamic viscosity when flow_index is 1 (water 1e-3, honey 10, lava 1e3)",
                     .lo = 0.0,
                     .hi = kHuge,
                     .unit = "Pa s^n"},
                 p.viscosity);
        v.number(Key{.name = "yield_stress",
                     .help = "shear stress below which the liquid does not flow (Bingham, Herschel-Bulkley); 0: none",
                     .lo = 0.0,
                     .hi = kHuge,
                     .unit = "Pa"},
                 p.yieldStress);
        v.number(Key{.name = "flow_index",
                     .help = "Herschel-Bulkley exponent n of the shear rate: 1 Newtonian or Bingham, below 1 shear-thinning",
                     .lo = 0.05,
                     .hi = 3.0},
                 p.flowIndex);
        if (!v.given("shear_modulus")) p.shearModulus = float(kDefaultShearShare * double(p.bulkModulus) * double(p.gamma));
        v.number(Key{.name = "shear_modulus",
                     .help = "elastic shear modulus G below the yield stress; the liquid relaxes in viscosity / G seconds",
                     .lo = kTiny,
                     .hi = kHuge,
                     .unit = "Pa",
                     .byDefault = "bulk_modulus x gamma / 4"},
                 p.shearModulus);
    }
    /// lambda_scale scales the equation of state's bulk modulus, mu_scale the shear modulus G.
    static void scaleStiffness(Params& p, double lambdaScale, double muScale) {
        p.bulkModulus = float(double(p.bulkModulus) * lambdaScale);
        p.shearModulus = float(double(p.shearModulus) * muScale);
    }

    /// The plastic shear rate gammaDot >= 0 that solves G dt gammaDot + K gammaDot^n = excess (> 0): Newton's
    /// method kept inside a shrinking bracket (the left side grows with gammaDot, so the root is unique). Double
    /// precision: at n < 1 the slope at 0 is infinite, and K gammaDot^n spans many decades between water and paste.
    static double plasticRate(double Gdt, double K, double n, double excess) {
        if (n == 1.0 || K == 0.0) return excess / (Gdt + K);
        double lo = 0.0, hi = Gdt > 0.0 ? excess / Gdt : std::pow(excess / K, 1.0 / n);
        if (K > 0.0) hi = std::min(hi, std::pow(excess / K, 1.0 / n));
        double x = 0.5 * hi;
        constexpr int kIterations = 60;
        constexpr double kRelativeTolerance = 1e-12;
        for (int it = 0; it < kIterations && hi - lo > kRelativeTolerance * hi; ++it) {
            const double f = Gdt * x + K * std::pow(x, n) - excess;
            (f > 0.0 ? hi : lo) = x;
            const double slope = Gdt + K * n * std::pow(x, n - 1.0);
            const double next = x - f / slope;
            x = next > lo && next < hi ? next : 0.5 * (lo + hi);
        }
        return x;
    }

    /// The flow over dt from the trial log principal strains eps: the returned strains and the increment of the
    /// equivalent plastic strain sqrt(2/3) |delta eps_p| (the measure metal's plastic_strain uses).
    static Vec3f flow(const Params& m, Vec3f eps, float dt, float& dAlpha) {
        dAlpha = 0.0f;
        if (!m.tension && eps.sum() > 0.0f) eps -= Vec3f::Constant(eps.sum() / kDim);
        const Vec3f dev = eps - Vec3f::Constant(eps.sum() / kDim);
        const double devNorm = dev.norm();
        const double trialStress = std::sqrt(2.0) * m.shearModulus * devNorm;  // tau_eq of 2 G dev
        const double excess = trialStress - m.yieldStress;
        if (excess <= 0.0) return eps;
        const double Gdt = double(m.shearModulus) * dt;
        const double rate = plasticRate(Gdt, m.viscosity, m.flowIndex, excess);
        const double keep = std::max(0.0, 1.0 - Gdt * rate / trialStress);
        dAlpha = float(std::sqrt(2.0 / 3.0) * devNorm * (1.0 - keep));
        return eps - float(1.0 - keep) * dev;
    }

    static Mat3f kirchhoffOf(const Params& m, const Svd3<float>& d) {
        const Vec3f e = d.sigma.array().abs().log().matrix();
        const float J = d.sigma.prod();
        const Vec3f t = 2.0f * m.shearModulus * (e - Vec3f::Constant(e.sum() / kDim)) - Vec3f::Constant(J * pressure(m, J));
        return d.U * t.asDiagonal() * d.U.transpose();
    }
    static float pressure(const Params& m, float J) { return m.bulkModulus * (Water::powNegative(J, m.gamma) - 1.0f); }

    static Mat3f kirchhoff(const Params& m, const State& s, std::size_t i) {
        return kirchhoffOf(m, svd3<float>(deformationGradient(s, i)));
    }
    static void kirchhoffBatch(const LaneParams<Params>& m, const State& s, std::size_t first, int n, Mat3f* tau) {
        Mat3f F[simd::kLanes];
        Svd3<float> d[simd::kLanes];
        narrowAndSvd(&s.Fe[first], n, F, d);
        for (int k = 0; k < n; ++k) tau[k] = kirchhoffOf(m[k], d[k]);
    }

    /// The flow over dt on the SVD of the elastic predictor F_E trial = (I + dt grad v) F_E.
    static void returnMap(const Params& m, State& s, std::size_t i, const ElasticTrial& t) {
        const Vec3f eps = logStretches(t.d.sigma);
        float dAlpha = 0.0f;
        const Vec3f H = flow(m, eps, t.dt, dAlpha);
        s.Fe[i] = t.returnedToLog(eps, H);
        s.alpha[i] += dAlpha;
    }
    static void updateDeformation(const Params& m, State& s, std::size_t i, const Mat3f& gradV, float dt) {
        predictAndReturnMap<HerschelBulkley>(m, s, i, gradV, dt);
    }
    static void updateDeformationBatch(const LaneParams<Params>& m, State& s, std::size_t first, int n, const Mat3f* gradV,
                                       float dt) {
        predictAndReturnMapBatch<HerschelBulkley>(m, s, first, n, gradV, dt);
    }

    /// G |dev eps|^2 plus the equation of state's energy (Water::energyDensity's formula) at J = det F_E.
    static double energyDensity(const Params& m, const State& s, std::size_t i) {
        const Svd3<double> d = svd3<double>(s.Fe[i]);
        const Eigen::Vector3d e = d.sigma.array().abs().max(double(kSmallestStretch)).log().matrix();
        const Eigen::Vector3d dev = e - Eigen::Vector3d::Constant(e.sum() / kDim);
        const double k = m.bulkModulus, g = m.gamma, J = std::exp(e.sum());
        return double(m.shearModulus) * dev.squaredNorm() - k * ((std::pow(J, 1.0 - g) - 1.0) / (1.0 - g) - (J - 1.0));
    }
    static float volumeRatio(const State& s, std::size_t i) { return float(s.Fe[i].determinant()); }
    static Mat3f deformationGradient(const State& s, std::size_t i) { return s.Fe[i].cast<float>(); }
    static float plasticStrain(const State& s, std::size_t i) { return s.alpha[i]; }
    /// The P-wave speed sqrt((k gamma J^(1-gamma) + 4 G / 3) / rho0): the equation of state stiffens as J shrinks.
    static float stiffnessKey(const State& s, std::size_t i) { return float(s.Fe[i].determinant()); }
    static float waveSpeed(const Params& m, float minJ) {
        const float J = std::fmax(minJ, 1e-3f);
        const float bulk = m.bulkModulus * m.gamma * std::pow(J, 1.0f - m.gamma);
        return std::sqrt((bulk + 4.0f / 3.0f * m.shearModulus) / m.density);
    }
};

}  // namespace mpm
