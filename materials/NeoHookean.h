#pragma once
// Compressible neo-Hookean elasticity ("rubber"; Bonet and Wood 2008; Jiang et al. 2016, eq. 48; thesis
// 4.3, 4.5 with the erratum F^-T):
//   Psi = mu/2 (tr(F^T F) - 3) - mu log J + lambda/2 log^2 J,   P = mu (F - F^-T) + lambda log J F^-T,
//   tau = P F^T = mu (F F^T - I) + lambda log J I.
// The model is undefined for J <= 0 (an inverted element). We do not clamp: stiffnessKey turns such a
// particle non-finite, and the run stops with a message naming the particle, frame and substep.
#include <cmath>
#include <limits>
#include <vector>

#include "materials/Elastic.h"
#include "materials/Svd.h"

namespace mpm {

struct NeoHookean {
    static constexpr const char* kName = "neo_hookean";
    static constexpr const char* kSceneName = "rubber";
    /// The colour its points take unless a set gives one (Cd, linear RGB).
    static constexpr float kColour[3] = {0.55f, 0.25f, 0.7f};
    static constexpr const char* kSummary =
        "compressible neo-Hookean elasticity (Bonet and Wood 2008; thesis 4.3, 4.5); undefined for inverted elements (J <= 0), "
        "where a run stops naming the particle";

    struct Params : ElasticParams {};  // its own type, so that a parameter set names its model
    using State = DeformationGradientState;

    template <class V>
    static void keys(V& v, Params& p) {
        elasticKeys(v, p.density, p.mu, p.lambda, kThesisElastic);
    }
    static void scaleStiffness(Params& p, double lambdaScale, double muScale) { scaleLame(p.mu, p.lambda, lambdaScale, muScale); }

    template <class T>
    static T psi(T mu, T lambda, const Mat3T<T>& F) {
        const T logJ = std::log(F.determinant());
        return T(0.5) * mu * ((F.transpose() * F).trace() - T(3)) - mu * logJ + T(0.5) * lambda * logJ * logJ;
    }
    template <class T>
    static Mat3T<T> kirchhoffOf(T mu, T lambda, const Mat3T<T>& F) {
        return mu * (F * F.transpose() - Mat3T<T>::Identity()) + lambda * std::log(F.determinant()) * Mat3T<T>::Identity();
    }
    template <class T>
    static Mat3T<T> piola(T mu, T lambda, const Mat3T<T>& F) {
        const Mat3T<T> FinvT = F.inverse().transpose();
        return mu * (F - FinvT) + lambda * std::log(F.determinant()) * FinvT;
    }

    static Mat3f kirchhoff(const Params& m, const State& s, std::size_t i) {
        return kirchhoffOf<float>(m.mu, m.lambda, s.single(i));
    }
    static void updateDeformation(const Params&, State& s, std::size_t i, const Mat3f& gradV, float dt) {
        s.update(i, gradV, dt);
    }
    static double energyDensity(const Params& m, const State& s, std::size_t i) { return psi<double>(m.mu, m.lambda, s.F[i]); }
    static float volumeRatio(const State& s, std::size_t i) { return float(s.F[i].determinant()); }
    static Mat3f deformationGradient(const State& s, std::size_t i) { return s.single(i); }
    /// J itself, or NaN once the element has inverted (stops the run).
    static float stiffnessKey(const State& s, std::size_t i) {
        const float J = float(s.F[i].determinant());
        return J > 0.0f ? J : std::numeric_limits<float>::quiet_NaN();
    }
    static float waveSpeed(const Params& m, float) { return elasticWaveSpeed(m.mu, m.lambda, m.density); }
};

}  // namespace mpm
