#pragma once
// 3x3 singular value decomposition with proper rotations, F = U diag(sigma) V^T, det U = det V = +1:
// a reflection is moved into the smallest singular value (its sign flips), as inverted elements need
// (Irving et al. 2004; Stomakhin et al. 2012). Eigen's JacobiSVD is exact and robust for repeated and
// tiny singular values; it is the measured choice until a McAdams-style SVD beats it (issue 4 notes).
#include <Eigen/SVD>

#include <vector>

#include "core/Types.h"

namespace mpm {

template <class T> using Mat3T = Eigen::Matrix<T, 3, 3>;
template <class T> using Vec3T = Eigen::Matrix<T, 3, 1>;

template <class T>
struct Svd3 {
    Mat3T<T> U, V;
    Vec3T<T> sigma;
};

template <class T>
Svd3<T> svd3(const Mat3T<T>& F) {
    Eigen::JacobiSVD<Mat3T<T>> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Svd3<T> r{svd.matrixU(), svd.matrixV(), svd.singularValues()};
    if (r.U.determinant() < T(0)) {
        r.U.col(2) *= T(-1);
        r.sigma[2] *= T(-1);
    }
    if (r.V.determinant() < T(0)) {
        r.V.col(2) *= T(-1);
        r.sigma[2] *= T(-1);
    }
    return r;
}

/// Lame parameters from Young's modulus and Poisson's ratio (thesis eq. 4.4).
struct Lame {
    float mu, lambda;
    static Lame fromYoung(double E, double nu) {
        return {float(E / (2.0 * (1.0 + nu))), float(E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)))};
    }
};

/// P-wave speed sqrt((lambda + 2 mu) / rho) of an isotropic solid at rest.
inline float elasticWaveSpeed(float mu, float lambda, float rho) { return std::sqrt((lambda + 2.0f * mu) / rho); }

/// Parameters of the hyperelastic models that keep the full F (thesis Fig. 6.1 defaults: rho 400, E 1.4e5, nu 0.2).
struct ElasticParams {
    float density = 400.0f;
    float mu = Lame::fromYoung(1.4e5, 0.2).mu;
    float lambda = Lame::fromYoung(1.4e5, 0.2).lambda;
};

/// Per-particle state of those models: F alone, updated by F <- (I + dt grad v) F (thesis 3.19).
struct DeformationGradientState {
    std::vector<Mat3f> F;
    template <class Fn> void forEachArray(Fn&& f) { f(F); }
    void appendRest(std::size_t n) { F.resize(F.size() + n, Mat3f::Identity()); }
    void update(std::size_t i, const Mat3f& gradV, float dt) { F[i] = (Mat3f::Identity() + dt * gradV) * F[i]; }
};

}  // namespace mpm
