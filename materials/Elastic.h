#pragma once
// What the hyperelastic models share: Lame parameters from Young's modulus and Poisson's ratio, the P-wave
// speed, the parameters and state of the models that keep the full F, and their scene keys (density,
// youngs_modulus, poisson_ratio; the models keep mu and lambda).
#include <cmath>
#include <vector>

#include "base/Parameters.h"
#include "base/Types.h"

namespace mpm {

/// Lame parameters from Young's modulus and Poisson's ratio (thesis eq. 4.4):
/// mu = E / (2 (1 + nu)), lambda = E nu / ((1 + nu)(1 - 2 nu)).
struct Lame {
    float mu, lambda;
    static constexpr Lame fromYoung(double E, double nu) {
        return {float(E / (2.0 * (1.0 + nu))), float(E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)))};
    }
};

/// P-wave speed sqrt((lambda + 2 mu) / rho) of an isotropic solid at rest.
inline float elasticWaveSpeed(float mu, float lambda, float rho) { return std::sqrt((lambda + 2.0f * mu) / rho); }

/// Young's modulus [Pa] and Poisson's ratio, as a scene gives them.
struct YoungPoisson {
    double E, nu;
};

/// The thesis's elastic defaults (Fig. 6.1): rho 400 kg/m^3, E 1.4e5 Pa, nu 0.2.
inline constexpr float kThesisElasticDensity = 400.0f;
inline constexpr YoungPoisson kThesisElastic{1.4e5, 0.2};

/// Scene keys density, youngs_modulus and poisson_ratio; E and nu become mu and lambda. `defaults` must be
/// the E and nu the model's Params were initialised from, so that an unset key changes nothing.
template <class V>
void elasticKeys(V& v, float& density, float& mu, float& lambda, YoungPoisson defaults) {
    v.number(Key{.name = "density", .help = "rest density rho0", .lo = kTiny, .hi = kHuge, .unit = "kg/m^3"}, density);
    YoungPoisson e = defaults;
    v.number(Key{.name = "youngs_modulus", .help = "Young's modulus E", .lo = 0.0, .hi = 1e15, .unit = "Pa"}, e.E);
    v.number(Key{.name = "poisson_ratio", .help = "Poisson's ratio nu", .lo = 0.0, .hi = 0.49}, e.nu);
    const Lame l = Lame::fromYoung(e.E, e.nu);
    mu = l.mu;
    lambda = l.lambda;
}

/// A set's lambda_scale and mu_scale multiply the Lame parameters (thesis section 6.2).
inline void scaleLame(float& mu, float& lambda, double lambdaScale, double muScale) {
    mu = float(double(mu) * muScale);
    lambda = float(double(lambda) * lambdaScale);
}

/// Parameters of the hyperelastic models that keep the full F (thesis defaults).
struct ElasticParams {
    float density = kThesisElasticDensity;
    float mu = Lame::fromYoung(kThesisElastic.E, kThesisElastic.nu).mu;
    float lambda = Lame::fromYoung(kThesisElastic.E, kThesisElastic.nu).lambda;
};

/// Per-particle state of those models: F alone, updated by F <- (I + dt grad v) F (thesis 3.19).
/// F is kept in double: in float a step's increment dt grad v F below half an ulp of F's entries (6e-8 near 1)
/// is lost, so a stiff solid moving slowly stops registering its strain while its particles still move. A
/// cantilever under gravity then rose 6% of its deflection a second (docs/method.md, section 5).
struct DeformationGradientState {
    std::vector<Mat3d> F;
    template <class Fn>
    void forEachArray(Fn&& f) {
        f(F);
    }
    template <class Fn>
    void forEachArray(Fn&& f) const {
        f(F);
    }
    void appendRest(std::size_t n) { F.resize(F.size() + n, Mat3d::Identity()); }
    /// dt grad v is small and exact enough in float; adding it to I is where float would round it away.
    void update(std::size_t i, const Mat3f& gradV, float dt) { F[i] = (Mat3d::Identity() + (dt * gradV).cast<double>()) * F[i]; }
    Mat3f single(std::size_t i) const { return F[i].cast<float>(); }
};

}  // namespace mpm
