#pragma once
// Fixed corotated elasticity ("jelly"; Stomakhin et al. 2012; Jiang et al. 2016, eq. 49; thesis 4.6-4.8,
// pseudocode 5). With F = U Sigma V^T and R = U V^T:
//   Psi = mu sum_i (sigma_i - 1)^2 + lambda/2 (J - 1)^2,   P = 2 mu (F - R) + lambda (J - 1) J F^-T,
//   tau = P F^T = 2 mu (F - R) F^T + lambda (J - 1) J I.
#include <vector>

#include "materials/Elastic.h"
#include "materials/SvdBatch.h"

namespace mpm {

struct FixedCorotated {
    static constexpr const char* kName = "fixed_corotated";
    static constexpr const char* kSceneName = "jelly";
    /// The colour its points take unless a set gives one (Cd, linear RGB).
    static constexpr float kColour[3] = {0.85f, 0.2f, 0.25f};
    static constexpr const char* kSummary = "fixed corotated elasticity (Stomakhin et al. 2012; thesis 4.6-4.8)";

    struct Params : ElasticParams {};  // its own type, so that a parameter set names its model
    using State = DeformationGradientState;

    template <class V>
    static void keys(V& v, Params& p) {
        elasticKeys(v, p.density, p.mu, p.lambda, kThesisElastic);
    }
    static void scaleStiffness(Params& p, double lambdaScale, double muScale) { scaleLame(p.mu, p.lambda, lambdaScale, muScale); }

    template <class T>
    static T psi(T mu, T lambda, const Mat3T<T>& F) {
        const Svd3<T> s = svd3<T>(F);
        const T J = s.sigma.prod();
        return mu * (s.sigma - Vec3T<T>::Ones()).squaredNorm() + T(0.5) * lambda * (J - T(1)) * (J - T(1));
    }
    /// tau = P F^T, which needs no inverse and stays finite for inverted F.
    template <class T>
    static Mat3T<T> kirchhoffOf(T mu, T lambda, const Mat3T<T>& F, const Svd3<T>& s) {
        const Mat3T<T> R = s.U * s.V.transpose();
        const T J = s.sigma.prod();
        return T(2) * mu * (F - R) * F.transpose() + lambda * (J - T(1)) * J * Mat3T<T>::Identity();
    }
    template <class T>
    static Mat3T<T> kirchhoffOf(T mu, T lambda, const Mat3T<T>& F) {
        return kirchhoffOf<T>(mu, lambda, F, svd3<T>(F));
    }
    template <class T>
    static Mat3T<T> piola(T mu, T lambda, const Mat3T<T>& F) {
        return kirchhoffOf<T>(mu, lambda, F) * F.inverse().transpose();
    }

    static Mat3f kirchhoff(const Params& m, const State& s, std::size_t i) {
        return kirchhoffOf<float>(m.mu, m.lambda, s.single(i));
    }
    /// kirchhoff for particles first .. first + n - 1 (n <= simd::kLanes), their SVDs in SIMD lanes.
    static void kirchhoffBatch(const LaneParams<Params>& m, const State& s, std::size_t first, int n, Mat3f* tau) {
        Mat3f F[simd::kLanes];
        Svd3<float> d[simd::kLanes];
        narrowAndSvd(&s.F[first], n, F, d);
        for (int k = 0; k < n; ++k) tau[k] = kirchhoffOf<float>(m[k].mu, m[k].lambda, F[k], d[k]);
    }
    static void updateDeformation(const Params&, State& s, std::size_t i, const Mat3f& gradV, float dt) {
        s.update(i, gradV, dt);
    }
    static double energyDensity(const Params& m, const State& s, std::size_t i) { return psi<double>(m.mu, m.lambda, s.F[i]); }
    static float volumeRatio(const State& s, std::size_t i) { return float(s.F[i].determinant()); }
    static Mat3f deformationGradient(const State& s, std::size_t i) { return s.single(i); }
    /// J, for the finite check alone: the wave speed does not depend on the state.
    static float stiffnessKey(const State& s, std::size_t i) { return float(s.F[i].determinant()); }
    static float waveSpeed(const Params& m, float) { return elasticWaveSpeed(m.mu, m.lambda, m.density); }
};

}  // namespace mpm
