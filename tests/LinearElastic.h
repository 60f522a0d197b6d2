#pragma once
// Small-strain linear elasticity (Jiang et al. 2016, MPM course notes, sec. 6.1), defined outside the engine:
// the test suite appends it to the material list (materials/Materials.h, MPM_EXTRA_MATERIALS) to show that a
// model joins scenes, `mpm validate --explain` and the transfers with this header and one list entry.
//   eps = (F + F^T) / 2 - I,   Psi = mu eps : eps + lambda/2 tr(eps)^2,   P = 2 mu eps + lambda tr(eps) I.
// It is not rotation invariant, which is why the engine does not ship it.
#include "materials/Elastic.h"

namespace mpm {

struct LinearElastic {
    static constexpr const char* kName = "linear_elastic";
    static constexpr const char* kSceneName = "linear";
    static constexpr float kColour[3] = {0.6f, 0.6f, 0.6f};
    static constexpr const char* kSummary = "small-strain linear elasticity (Jiang et al. 2016, sec. 6.1; defined by the tests)";
    static constexpr YoungPoisson kDefault{1.0e5, 0.3};

    struct Params {
        float density = 1000.0f;
        float mu = Lame::fromYoung(kDefault.E, kDefault.nu).mu;
        float lambda = Lame::fromYoung(kDefault.E, kDefault.nu).lambda;
    };
    using State = DeformationGradientState;

    template <class V>
    static void keys(V& v, Params& p) {
        elasticKeys(v, p.density, p.mu, p.lambda, kDefault);
    }
    static void scaleStiffness(Params& p, double lambdaScale, double muScale) { scaleLame(p.mu, p.lambda, lambdaScale, muScale); }

    template <class T>
    static Mat3T<T> strain(const Mat3T<T>& F) {
        return T(0.5) * (F + F.transpose()) - Mat3T<T>::Identity();
    }
    template <class T>
    static T psi(T mu, T lambda, const Mat3T<T>& F) {
        const Mat3T<T> e = strain(F);
        return mu * (e.array() * e.array()).sum() + T(0.5) * lambda * e.trace() * e.trace();
    }
    template <class T>
    static Mat3T<T> piola(T mu, T lambda, const Mat3T<T>& F) {
        const Mat3T<T> e = strain(F);
        return T(2) * mu * e + lambda * e.trace() * Mat3T<T>::Identity();
    }

    static Mat3f kirchhoff(const Params& m, const State& s, std::size_t i) {
        return piola<float>(m.mu, m.lambda, s.single(i)) * s.single(i).transpose();
    }
    static void updateDeformation(const Params&, State& s, std::size_t i, const Mat3f& gradV, float dt) {
        s.update(i, gradV, dt);
    }
    static double energyDensity(const Params& m, const State& s, std::size_t i) { return psi<double>(m.mu, m.lambda, s.F[i]); }
    static float volumeRatio(const State& s, std::size_t i) { return float(s.F[i].determinant()); }
    static float stiffnessKey(const State& s, std::size_t i) { return float(s.F[i].determinant()); }
    static float waveSpeed(const Params& m, float) { return elasticWaveSpeed(m.mu, m.lambda, m.density); }
};

}  // namespace mpm
