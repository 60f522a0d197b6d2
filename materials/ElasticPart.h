#pragma once
// The elastic part F_E of the plastic models (snow, sand, metal, viscous): its predictor
// F_E trial = (I + dt grad v) F_E, and how a return map's new principal stretches are put back.
//
// F_E is kept in double, for the reason the elastic models keep F in double (materials/Elastic.h): in float
// a step's increment below half an ulp of F_E's entries (6e-8 near 1) is lost, so a slowly loaded stiff
// material (a sand pile settling, a plate under a load) stops registering its strain. Rebuilding
// F_E = U diag(sigma') V^T from a float SVD would round it to float every step as well, so the map's
// change is added to the trial instead:
//   F_E = trial + U diag(sigma' - sigma) V^T,
// which equals U diag(sigma') V^T up to the trial's own digits, and is the trial itself where no direction
// flows. The SVDs stay in float (eight at once, SvdBatch.h): the stress from F_E rounded once is an error that
// does not accumulate.
#include <cmath>

#include "base/Types.h"
#include "materials/SvdBatch.h"

namespace mpm {

/// A floor under principal stretches before their logarithm (a crushed particle's stretch of 0 has none).
inline constexpr float kSmallestStretch = 1e-12f;

/// ln |sigma|, each stretch floored at kSmallestStretch.
inline Vec3f logStretches(const Vec3f& sigma) { return sigma.array().abs().max(kSmallestStretch).log().matrix(); }

/// The trial state a return map works on: F_E trial in double and its float SVD.
struct ElasticTrial {
    Mat3d F;
    Svd3<float> d;
    float dt;
    /// F_E after the map moved the stretches by delta = sigma' - sigma (see the file comment). The sum carries the
    /// float SVD's error in sigma, about eps max(sigma); rebuilding carries eps max(sigma'). Where a stretch changes by
    /// more than this share of itself (a large flow, a stretch crushed to nothing) the rebuild is the more accurate,
    /// and the trial's sub-ulp digits are then a negligible part of the step.
    static constexpr float kLargestAddedFlow = 0.5f;
    Mat3d returned(const Vec3f& delta) const {
        if (delta.isZero(0.0f)) return F;
        if ((delta.array().abs() > kLargestAddedFlow * d.sigma.array().abs()).any())
            return (d.U * (d.sigma + delta).asDiagonal() * d.V.transpose()).cast<double>();
        return F + d.U.cast<double>() * delta.cast<double>().asDiagonal() * d.V.cast<double>().transpose();
    }
    /// ... and by new log stretches H, given lnSigma = logStretches(d.sigma): sigma' = e^H. Where the stretch is
    /// positive, sigma (e^(H - ln sigma) - 1) keeps the digits of a small flow that e^H - sigma would cancel.
    Mat3d returnedToLog(const Vec3f& lnSigma, const Vec3f& H) const {
        Vec3f delta;
        for (int a = 0; a < 3; ++a)
            delta[a] = d.sigma[a] >= kSmallestStretch ? d.sigma[a] * std::expm1(H[a] - lnSigma[a]) : std::exp(H[a]) - d.sigma[a];
        return returned(delta);
    }
};

inline Mat3d predictElastic(const Mat3d& Fe, const Mat3f& gradV, float dt) {
    return (Mat3d::Identity() + (dt * gradV).cast<double>()) * Fe;
}

/// The predictor, then the model's return map on the trial: one particle ...
template <class M>
void predictAndReturnMap(const typename M::Params& m, typename M::State& s, std::size_t i, const Mat3f& gradV, float dt) {
    ElasticTrial t{predictElastic(s.Fe[i], gradV, dt), {}, dt};
    t.d = svd3<float>(t.F.cast<float>());
    M::returnMap(m, s, i, t);
}

/// ... and particles first .. first + n - 1 (n <= simd::kLanes), their SVDs in SIMD lanes.
template <class M>
void predictAndReturnMapBatch(const LaneParams<typename M::Params>& m, typename M::State& s, std::size_t first, int n,
                              const Mat3f* gradV, float dt) {
    Mat3d trial[simd::kLanes];
    Mat3f narrow[simd::kLanes];
    Svd3<float> d[simd::kLanes];
    for (int k = 0; k < n; ++k) trial[k] = predictElastic(s.Fe[first + k], gradV[k], dt);
    narrowAndSvd(trial, n, narrow, d);
    for (int k = 0; k < n; ++k) M::returnMap(m[k], s, first + k, ElasticTrial{trial[k], d[k], dt});
}

}  // namespace mpm
