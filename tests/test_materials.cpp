// Constitutive models: zero stress at rest and under rotation, rotation invariance, stress = dPsi/dF by
// central differences in double, the wave speed; snow's clamp and hardening sequence; sand's three
// return-mapping cases, hardening and volume correction.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include "core/Species.h"
#include "materials/Materials.h"

using namespace mpm;

namespace {
Mat3d randomRotation(std::mt19937& rng) {
    std::normal_distribution<double> n;
    Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
    return q.normalized().toRotationMatrix();
}
Mat3d randomF(std::mt19937& rng) {
    std::uniform_real_distribution<double> u(-0.3, 0.3);
    Mat3d F = Mat3d::Identity();
    for (int i = 0; i < 9; ++i) F(i / 3, i % 3) += u(rng);
    return F;
}

template <class M>
struct Elastic;
#define MPM_ELASTIC(M)                                                              \
    template <>                                                                     \
    struct Elastic<M> {                                                             \
        static double psi(const Mat3d& F) { return M::psi<double>(mu, lambda, F); } \
        static Mat3d P(const Mat3d& F) { return M::piola<double>(mu, lambda, F); }  \
        static constexpr double mu = 3.0e4, lambda = 5.0e4;                         \
    };
MPM_ELASTIC(FixedCorotated)
MPM_ELASTIC(NeoHookean)
MPM_ELASTIC(Sand)
}  // namespace

template <class M>
class ElasticModel : public ::testing::Test {};
using ElasticModels = ::testing::Types<FixedCorotated, NeoHookean, Sand>;
TYPED_TEST_SUITE(ElasticModel, ElasticModels);

TYPED_TEST(ElasticModel, ZeroStressAtRestAndUnderRotation) {
    using E = Elastic<TypeParam>;
    std::mt19937 rng(1);
    EXPECT_LT(E::P(Mat3d::Identity()).norm(), 1e-9 * E::mu);
    EXPECT_NEAR(E::psi(Mat3d::Identity()), 0.0, 1e-9 * E::mu);
    for (int i = 0; i < 20; ++i) {
        const Mat3d R = randomRotation(rng);
        EXPECT_LT(E::P(R).norm(), 1e-8 * E::mu);
        EXPECT_NEAR(E::psi(R), 0.0, 1e-8 * E::mu);
    }
}

TYPED_TEST(ElasticModel, RotationInvariance) {
    using E = Elastic<TypeParam>;
    std::mt19937 rng(2);
    for (int i = 0; i < 50; ++i) {
        const Mat3d F = randomF(rng), R = randomRotation(rng);
        EXPECT_NEAR(E::psi(R * F), E::psi(F), 1e-9 * E::mu);
        EXPECT_LT((E::P(R * F) - R * E::P(F)).norm(), 1e-8 * E::mu);
    }
}

TYPED_TEST(ElasticModel, StressIsTheEnergyDerivative) {
    using E = Elastic<TypeParam>;
    std::mt19937 rng(3);
    const double h = 1e-6;
    for (int i = 0; i < 50; ++i) {
        const Mat3d F = randomF(rng);
        const Mat3d P = E::P(F);
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) {
                Mat3d Fp = F, Fm = F;
                Fp(a, b) += h;
                Fm(a, b) -= h;
                EXPECT_NEAR(P(a, b), (E::psi(Fp) - E::psi(Fm)) / (2 * h), 1e-5 * E::mu) << "F =\n" << F;
            }
    }
}

TEST(Materials, WaveSpeedAtRest) {
    FixedCorotated::Params j;
    EXPECT_NEAR(FixedCorotated::waveSpeed(j, 1.0f), std::sqrt((j.lambda + 2 * j.mu) / j.density), 1e-4);
    NeoHookean::Params r;
    EXPECT_NEAR(NeoHookean::waveSpeed(r, 1.0f), std::sqrt((r.lambda + 2 * r.mu) / r.density), 1e-4);
    Snow::Params s;
    EXPECT_NEAR(Snow::waveSpeed(s, 1.0f), std::sqrt((s.lambda + 2 * s.mu) / s.density), 1e-4);
    Sand::Params d;
    EXPECT_NEAR(Sand::waveSpeed(d, 1.0f), std::sqrt((d.lambda + 2 * d.mu) / d.density), 1e-2);
    // Thesis Fig. 6.1 defaults: E = 1.4e5, nu = 0.2 give mu = 58333, lambda = 38889.
    EXPECT_NEAR(j.mu, 58333.3f, 1.0f);
    EXPECT_NEAR(j.lambda, 38888.9f, 1.0f);
}

TEST(Materials, KirchhoffIsPiolaTimesFTranspose) {
    std::mt19937 rng(4);
    for (int i = 0; i < 20; ++i) {
        const Mat3d F = randomF(rng);
        EXPECT_LT((FixedCorotated::kirchhoffOf<double>(3e4, 5e4, F) - FixedCorotated::piola<double>(3e4, 5e4, F) * F.transpose())
                      .norm(),
                  1e-6);
        EXPECT_LT((NeoHookean::kirchhoffOf<double>(3e4, 5e4, F) - NeoHookean::piola<double>(3e4, 5e4, F) * F.transpose()).norm(),
                  1e-6);
        EXPECT_LT((Sand::kirchhoffOf<double>(3e4, 5e4, F) - Sand::piola<double>(3e4, 5e4, F) * F.transpose()).norm(), 1e-6);
    }
}

TEST(Materials, SvdGivesProperRotationsForInvertedF) {
    Mat3f F = Mat3f::Identity();
    F(2, 2) = -0.5f;  // inverted
    const Svd3<float> s = svd3<float>(F);
    EXPECT_NEAR(s.U.determinant(), 1.0f, 1e-5f);
    EXPECT_NEAR(s.V.determinant(), 1.0f, 1e-5f);
    EXPECT_NEAR(s.sigma.prod(), -0.5f, 1e-5f);
    EXPECT_LT((s.U * s.sigma.asDiagonal() * s.V.transpose() - F).norm(), 1e-5f);
}

namespace {
/// Checks one SVD: proper rotations, orthonormal factors, reconstruction, sorted |sigma|, and singular
/// values equal to Eigen's JacobiSVD (the reference) to a tolerance relative to the largest.
template <class T>
void expectValidSvd(const Mat3T<T>& F, T tol) {
    const Svd3<T> s = svd3<T>(F);
    const Svd3<T> ref = jacobiSvd3<T>(F);
    const T scale = std::max(T(1), F.norm());
    EXPECT_NEAR(s.U.determinant(), T(1), tol);
    EXPECT_NEAR(s.V.determinant(), T(1), tol);
    EXPECT_LT((s.U.transpose() * s.U - Mat3T<T>::Identity()).norm(), tol);
    EXPECT_LT((s.V.transpose() * s.V - Mat3T<T>::Identity()).norm(), tol);
    EXPECT_LT((s.U * s.sigma.asDiagonal() * s.V.transpose() - F).norm(), tol * scale) << F;
    EXPECT_GE(std::abs(s.sigma[0]), std::abs(s.sigma[1]) - tol * scale);
    EXPECT_GE(std::abs(s.sigma[1]), std::abs(s.sigma[2]) - tol * scale);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.sigma[k], ref.sigma[k], tol * scale) << F;
}
}  // namespace

TEST(Svd, MatchesEigenJacobiOnRandomRepeatedTinyAndInvertedF) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int n = 0; n < 200; ++n) {
        Mat3d F;
        for (int i = 0; i < 9; ++i) F(i / 3, i % 3) = u(rng);
        expectValidSvd<double>(F, 1e-12);
        expectValidSvd<float>(F.cast<float>(), 2e-5f);
    }
    for (int n = 0; n < 50; ++n) {
        const Mat3d R1 = randomRotation(rng), R2 = randomRotation(rng);
        // Repeated singular values (all three, and two), a rotation, tiny and zero ones, an inversion.
        for (const Vec3d& sigma : {Vec3d(1, 1, 1), Vec3d(2, 2, 0.5), Vec3d(1.5, 0.7, 0.7), Vec3d(1, 1e-6, 1e-7), Vec3d(1, 1, 0),
                                   Vec3d(0.9, 0.8, -0.3), Vec3d(1e3, 1, 1e-3)}) {
            const Mat3d F = R1 * sigma.asDiagonal() * R2.transpose();
            expectValidSvd<double>(F, 1e-10);
            expectValidSvd<float>(F.cast<float>(), 2e-5f);
        }
    }
    expectValidSvd<float>(Mat3f::Identity(), 1e-6f);
    expectValidSvd<float>(Mat3f::Zero(), 1e-6f);
}

TEST(Svd, BatchOfEightMatchesOneAtATime) {
    // The SIMD lanes run svd3's operations with identity rotations where a lane needs none, so every
    // lane must give svd3's singular values and a valid SVD, whatever its neighbours hold: here a
    // batch mixes random, repeated, tiny, zero, inverted and NaN matrices, and a short batch pads.
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<Mat3f> F;
    for (int n = 0; n < 64; ++n) {
        Mat3f f;
        for (int i = 0; i < 9; ++i) f(i / 3, i % 3) = u(rng);
        F.push_back(f);
        const Mat3d R1 = randomRotation(rng), R2 = randomRotation(rng);
        const Vec3d sigmas[] = {Vec3d(1, 1, 1), Vec3d(2, 2, 0.5), Vec3d(1, 1e-6, 1e-7), Vec3d(1, 1, 0), Vec3d(0.9, 0.8, -0.3)};
        F.push_back((R1 * sigmas[n % 5].asDiagonal() * R2.transpose()).cast<float>());
    }
    F.push_back(Mat3f::Identity());
    F.push_back(Mat3f::Zero());
    for (std::size_t first = 0; first < F.size(); first += simd::kLanes) {
        const int n = int(std::min<std::size_t>(simd::kLanes, F.size() - first));
        Svd3<float> batch[simd::kLanes];
        svd3Batch(&F[first], n, batch);
        for (int k = 0; k < n; ++k) {
            const Svd3<float> one = svd3<float>(F[first + k]);
            EXPECT_TRUE(batch[k].sigma.isApprox(one.sigma, 1e-5f) || (batch[k].sigma - one.sigma).norm() < 1e-6f) << first + k;
            // U and V are unique only up to the repeated-value subspaces, so check them as an SVD.
            const Svd3<float>& b = batch[k];
            EXPECT_LT((b.U * b.sigma.asDiagonal() * b.V.transpose() - F[first + k]).norm(), 1e-5f * (1.0f + F[first + k].norm()))
                << first + k;
            EXPECT_NEAR(b.U.determinant(), 1.0f, 1e-5f) << first + k;
            EXPECT_NEAR(b.V.determinant(), 1.0f, 1e-5f) << first + k;
            EXPECT_LT((b.U.transpose() * b.U - Mat3f::Identity()).norm(), 1e-5f) << first + k;
            EXPECT_LT((b.V.transpose() * b.V - Mat3f::Identity()).norm(), 1e-5f) << first + k;
        }
    }
    // A NaN lane stays NaN and does not spill into its neighbours.
    std::vector<Mat3f> withNaN(F.begin(), F.begin() + simd::kLanes);
    withNaN[3](1, 2) = std::numeric_limits<float>::quiet_NaN();
    Svd3<float> out[simd::kLanes];
    svd3Batch(withNaN.data(), simd::kLanes, out);
    EXPECT_FALSE(out[3].sigma.allFinite());
    for (int k = 0; k < simd::kLanes; ++k) {
        if (k == 3) continue;
        EXPECT_TRUE(out[k].sigma.isApprox(svd3<float>(withNaN[k]).sigma, 1e-5f)) << k;
    }
}

/// The batched stress and return map of an SVD-based model agree with its one-particle versions.
template <class M>
void expectBatchMatchesScalar() {
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(-0.3f, 0.3f);
    const int n = 13;  // one full batch and a short one
    Species<M> one, batch;
    if constexpr (requires { one.state.appendRest(n, one.params); }) {
        one.state.appendRest(n, one.params);
        batch.state.appendRest(n, batch.params);
    } else {
        one.state.appendRest(n);
        batch.state.appendRest(n);
    }
    std::vector<Mat3f> gradV(n);
    for (int i = 0; i < n; ++i) {
        Mat3f F = Mat3f::Identity();
        for (int k = 0; k < 9; ++k) F(k / 3, k % 3) += u(rng), gradV[i](k / 3, k % 3) = 10.0f * u(rng);
        if constexpr (requires { one.state.F; })
            one.state.F[i] = batch.state.F[i] = F.cast<double>();
        else
            one.state.Fe[i] = batch.state.Fe[i] = F.cast<double>();
    }
    const float dt = 1e-3f;
    for (int first = 0; first < n; first += simd::kLanes) {
        const int m = std::min(simd::kLanes, n - first);
        Mat3f tau[simd::kLanes];
        kirchhoffOfRange<M>(batch.params, batch.state, first, m, tau);
        for (int k = 0; k < m; ++k) {
            const Mat3f ref = M::kirchhoff(one.params, one.state, first + k);
            EXPECT_LT((tau[k] - ref).norm(), 1e-4f * (1.0f + ref.norm())) << M::kName << " " << first + k;
        }
        updateDeformationOfRange<M>(batch.params, batch.state, first, m, &gradV[first], dt);
        for (int k = 0; k < m; ++k) M::updateDeformation(one.params, one.state, first + k, gradV[first + k], dt);
    }
    for (int i = 0; i < n; ++i) {
        EXPECT_NEAR(M::stiffnessKey(batch.state, i), M::stiffnessKey(one.state, i), 1e-5f) << M::kName << " " << i;
        EXPECT_NEAR(M::volumeRatio(batch.state, i), M::volumeRatio(one.state, i), 1e-5f) << M::kName << " " << i;
    }
}

TEST(MaterialBatch, StressAndReturnMapMatchOneParticleAtATime) {
    expectBatchMatchesScalar<FixedCorotated>();
    expectBatchMatchesScalar<Snow>();
    expectBatchMatchesScalar<Sand>();
    expectBatchMatchesScalar<NeoHookean>();  // no batch of its own: the fallback loop
    expectBatchMatchesScalar<VonMises>();
    expectBatchMatchesScalar<HerschelBulkley>();
}

// A stiff solid moving slowly: dt = 1e-5 s and a stretch and shear rate of 1e-4 /s give increments of 1e-9 a step, a
// sixtieth of float's half ulp at 1, which a float F rounded away at every step (it stayed I). After 1e5 steps F must
// be the product of the steps' factors: (1 + a)^N on the diagonal and (1 + a)^N - 1 below it; the tolerance, 2e-11, is
// twice the worst case of 1e5 steps' double rounding (a half ulp at 1, 1.1e-16, a step).
template <class M>
void expectFRegistersASlowStrain() {
    const float dt = 1e-5f;
    Mat3f gradV = Mat3f::Zero();
    gradV(0, 0) = 1e-4f, gradV(1, 0) = 1e-4f;
    const int steps = 100000;
    const double a = double(dt * gradV(0, 0));  // the increment as the update forms it, in float
    typename M::State s;
    s.appendRest(1);
    for (int k = 0; k < steps; ++k) M::updateDeformation(typename M::Params{}, s, 0, gradV, dt);
    const double grown = std::expm1(steps * std::log1p(a));
    EXPECT_NEAR(s.F[0](0, 0) - 1.0, grown, 2e-11) << M::kSceneName;
    EXPECT_NEAR(s.F[0](1, 0), grown, 2e-11) << M::kSceneName;
    EXPECT_EQ(s.F[0](1, 1), 1.0) << M::kSceneName;
    EXPECT_GT(s.F[0](0, 0) - 1.0, 0.99e-4) << M::kSceneName;  // the strain 1e-4 is there
}

TEST(ElasticModels, FRegistersAStrainRateWhoseStepsFloatCouldNotHold) {
    expectFRegistersASlowStrain<FixedCorotated>();
    expectFRegistersASlowStrain<NeoHookean>();
}

// The plastic models' F_E, strained inside their elastic range at the same sub-ulp rate, is the product of the steps'
// factors bit for bit: without flow the return map leaves the trial, formed in double, as it is (materials/ElasticPart.h).
// Shear and stretch for snow and metal; sand and the viscous liquid flow under any shear, so theirs is a slow
// isotropic compression.
template <class M>
void expectFeRegistersASlowStrain(const Mat3f& gradV) {
    const float dt = 1e-5f;
    const int steps = 100000;
    const typename M::Params params{};
    typename M::State s;
    if constexpr (requires { s.appendRest(1, params); })
        s.appendRest(1, params);
    else
        s.appendRest(1);
    Mat3d expected = Mat3d::Identity();
    const Mat3d step = Mat3d::Identity() + (dt * gradV).cast<double>();
    for (int k = 0; k < steps; ++k) {
        M::updateDeformation(params, s, 0, gradV, dt);
        expected = step * expected;
    }
    EXPECT_EQ(s.Fe[0], expected) << M::kSceneName;
    EXPECT_NEAR(expected(0, 0) - 1.0, std::expm1(steps * std::log1p(double(dt * gradV(0, 0)))), 2e-11) << M::kSceneName;
}

TEST(PlasticModels, FeRegistersAStrainRateWhoseStepsFloatCouldNotHold) {
    Mat3f shear = Mat3f::Zero();
    shear(0, 0) = 1e-4f, shear(1, 0) = 1e-4f;
    expectFeRegistersASlowStrain<Snow>(shear);
    expectFeRegistersASlowStrain<VonMises>(shear);
    const Mat3f compression = -1e-4f * Mat3f::Identity();
    expectFeRegistersASlowStrain<Sand>(compression);
    expectFeRegistersASlowStrain<HerschelBulkley>(compression);
}

TEST(SnowModel, PlasticVolumeRegistersACompactionWhoseStepsFloatCouldNotHold) {
    // Snow held at its compression limit 1 - theta_c and compacted at a rate whose step, 1e-9 of the stretch, is under
    // float's half ulp there (3e-8): each step's clamp moves that volume into J_P, which must reach (1 - a)^(3 N). The
    // float SVD sees the trial only once its excess passes an ulp, so J_P lags by at most that: 1.2e-7 relative per
    // stretch, 4e-7 for three (the tolerance).
    Snow::Params m;
    Snow::State s;
    s.appendRest(1);
    s.Fe[0] = double(1.0f - m.thetaC) * Mat3d::Identity();
    const float dt = 1e-5f, rate = 1e-4f;
    const int steps = 100000;
    for (int k = 0; k < steps; ++k) Snow::updateDeformation(m, s, 0, -rate * Mat3f::Identity(), dt);
    const double expected = std::exp(3.0 * steps * std::log1p(-double(dt * rate)));
    EXPECT_NEAR(s.Jp[0] / expected - 1.0, 0.0, 4e-7);
    EXPECT_LT(s.Jp[0], 1.0 - 2.9e-4);                           // the compaction, 3e-4, is there
    EXPECT_NEAR(s.Fe[0](0, 0), double(1.0f - m.thetaC), 1e-7);  // and F_E stays at the limit
}

TEST(NeoHookeanModel, InvertedElementIsReportedNotClamped) {
    NeoHookean::State s;
    s.appendRest(1);
    s.F[0](1, 1) = -0.1f;
    EXPECT_TRUE(std::isnan(NeoHookean::stiffnessKey(s, 0)));
}

TEST(SnowModel, ClampAndHardeningFollowTheHandSequence) {
    Snow::Params m;
    Snow::State s;
    s.appendRest(1);
    // Uniform compression at rate a: each step scales F_E by (1 - a dt) until sigma reaches 1 - theta_c.
    const float a = 1.0f, dt = 0.01f;
    double sigma = 1.0, Jp = 1.0;
    for (int n = 0; n < 10; ++n) {
        Snow::updateDeformation(m, s, 0, -a * Mat3f::Identity(), dt);
        const double trial = sigma * (1.0 - a * dt);
        const double clamped = std::max(trial, 1.0 - m.thetaC);
        Jp *= std::pow(trial / clamped, 3);
        sigma = clamped;
        const Svd3<float> d = svd3<float>(Snow::deformationGradient(s, 0));
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(d.sigma[k], sigma, 1e-5);
            EXPECT_GE(d.sigma[k], 1.0f - m.thetaC - 1e-6f);
            EXPECT_LE(d.sigma[k], 1.0f + m.thetaS + 1e-6f);
        }
        EXPECT_NEAR(s.Jp[0], Jp, 1e-5);
    }
    EXPECT_LT(s.Jp[0], 1.0);  // compressed past the band: plastic volume loss
    EXPECT_NEAR(Snow::hardening(m, float(s.Jp[0])), std::exp(m.xi * (1.0 - Jp)), 1e-4);
    EXPECT_GT(Snow::waveSpeed(m, float(s.Jp[0])), Snow::waveSpeed(m, 1.0f));
}

TEST(SnowModel, SustainedExpansionKeepsPlasticVolumeFinite) {
    // An isolated particle keeps an expanding affine velocity: J_P would overflow; it stops at the cap,
    // where the hardening factor is negligible, and the elastic part stays in the band.
    Snow::Params m;
    Snow::State s;
    s.appendRest(1);
    for (int n = 0; n < 5000; ++n) Snow::updateDeformation(m, s, 0, 50.0f * Mat3f::Identity(), 1e-3f);
    EXPECT_TRUE(std::isfinite(s.Jp[0]));
    EXPECT_EQ(s.Jp[0], Snow::kMaxPlasticVolume);
    EXPECT_LT(Snow::hardening(m, float(s.Jp[0])), 1e-30f);
    EXPECT_NEAR(s.Fe[0].determinant(), std::pow(1.0 + m.thetaS, 3.0), 1e-4);
}

TEST(SandModel, ReturnMappingCases) {
    Sand::Params m;
    const float alpha = Sand::alphaOf(m, 0.0f);
    const float k = (3 * m.lambda + 2 * m.mu) / (2 * m.mu);
    // Case II: expansion goes to the tip.
    Sand::Projection p = Sand::project(m, Vec3f(0.01f, 0.0f, -0.005f), alpha);
    EXPECT_EQ(p.which, Sand::Case::Tip);
    EXPECT_TRUE(p.H.isZero());
    EXPECT_NEAR(p.dq, Vec3f(0.01f, 0.0f, -0.005f).norm(), 1e-7f);
    // Case I: compression with little shear stays.
    const Vec3f inside(-0.01f, -0.011f, -0.012f);
    p = Sand::project(m, inside, alpha);
    EXPECT_EQ(p.which, Sand::Case::Elastic);
    EXPECT_TRUE(p.H.isApprox(inside));
    EXPECT_EQ(p.dq, 0.0f);
    // Case III: shear beyond the cone lands on it: |dev H| + k tr(H) alpha = 0, trace kept.
    const Vec3f sheared(-0.001f, 0.02f, -0.03f);
    p = Sand::project(m, sheared, alpha);
    EXPECT_EQ(p.which, Sand::Case::Cone);
    const Vec3f dev = p.H - Vec3f::Constant(p.H.sum() / 3);
    EXPECT_NEAR(dev.norm() + k * p.H.sum() * alpha, 0.0f, 1e-6f);
    EXPECT_NEAR(p.H.sum(), sheared.sum(), 1e-7f);
    EXPECT_GT(p.dq, 0.0f);
    // Friction angle hardens monotonically from 25 degrees over the early plastic strain (Klar Fig. 5).
    EXPECT_NEAR(Sand::frictionAngleDegrees(m, 0.0f), 25.0f, 1e-5f);
    for (float q = 0.0f; q < 5.0f; q += 0.1f) EXPECT_GT(Sand::alphaOf(m, q + 0.1f), Sand::alphaOf(m, q));
}

namespace {
/// The principal Kirchhoff stresses of Hencky log strains eps (sand's elasticity), largest first.
Vec3f sortedStress(const Sand::Params& m, const Vec3f& eps) {
    Vec3f t = 2.0f * m.mu * eps + Vec3f::Constant(m.lambda * eps.sum());
    std::sort(t.data(), t.data() + 3, std::greater<float>());
    return t;
}
}  // namespace

TEST(SandModel, MohrCoulombReturnLandsOnTheHexagonKeepingTheVolume) {
    // Cohesionless Mohr-Coulomb: (t1 - t3) + (t1 + t3) sin(phi) <= 0 for the largest and smallest principal
    // stresses, whatever the middle one. Trial strains from every sextant and both edges: each lands on the
    // surface (to float round-off of the stresses, 1e-5 of their size), keeps its trace (zero dilatancy) and
    // keeps the order of its principal directions; the plastic strain is the strain removed.
    Sand::Params m;
    const float s = std::sin(32.0f * float(M_PI) / 180.0f);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-0.03f, 0.01f);
    int returned = 0;
    for (int n = 0; n < 2000; ++n) {
        Vec3f eps(u(rng), u(rng), u(rng));
        if (n % 3 == 1) eps[1] = eps[0];  // on an edge of the hexagon already
        const Sand::Projection p = Sand::projectMohrCoulomb(m, eps, s);
        if (eps.sum() > 0.0f) {
            EXPECT_EQ(p.which, Sand::Case::Tip);
            continue;
        }
        const Vec3f t = sortedStress(m, p.H), t0 = sortedStress(m, eps);
        const float f = (t[0] - t[2]) + (t[0] + t[2]) * s, scale = t0.cwiseAbs().maxCoeff();
        if (p.which == Sand::Case::Elastic) {
            EXPECT_LE((t0[0] - t0[2]) + (t0[0] + t0[2]) * s, 0.0f);
            EXPECT_EQ(p.H, eps);
            continue;
        }
        ++returned;
        EXPECT_NEAR(f, 0.0f, 1e-5f * scale) << eps.transpose();
        EXPECT_NEAR(p.H.sum(), eps.sum(), 1e-6f) << eps.transpose();
        EXPECT_NEAR(p.dq, (eps - p.H).norm(), 1e-6f);
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
                if (eps[a] > eps[b]) EXPECT_GE(p.H[a], p.H[b] - 1e-6f) << eps.transpose();
    }
    EXPECT_GT(returned, 500);
}

TEST(SandModel, MohrCoulombHoldsTheFrictionAngleWhereDruckerPragerIsStronger) {
    // In triaxial compression (t1 = t2 > t3) Klar's round cone and Mohr-Coulomb's hexagon meet: both return to
    // (t1 - t3) / -(t1 + t3) = sin(phi). In plane strain at zero dilatancy the middle stress is the mean of the
    // others (pure shear), where the hexagon still holds sin(phi) but the cone holds more.
    Sand::Params m;
    m.h0 = 32.0f, m.h1 = 0.0f, m.h3 = 0.0f;
    const float s = std::sin(32.0f * float(M_PI) / 180.0f), alpha = Sand::alphaOf(m, 0.0f);
    const auto ratio = [&](const Vec3f& H) {
        const Vec3f t = sortedStress(m, H);
        return (t[0] - t[2]) / -(t[0] + t[2]);
    };
    // Triaxial compression: squeezed along z beyond yield, the two others equal.
    const Vec3f triaxial(0.002f, 0.002f, -0.03f);
    EXPECT_NEAR(ratio(Sand::projectMohrCoulomb(m, triaxial, s).H), s, 1e-4f);
    EXPECT_NEAR(ratio(Sand::project(m, triaxial, alpha).H), s, 1e-4f);
    // Pure shear in the x-y plane at a pressure: eps = (-p + g, -p - g, -p).
    const Vec3f shear(-0.01f + 0.02f, -0.01f - 0.02f, -0.01f);
    EXPECT_NEAR(ratio(Sand::projectMohrCoulomb(m, shear, s).H), s, 1e-4f);
    const float cone = ratio(Sand::project(m, shear, alpha).H);
    // Klar's cone at Lode angle 0: |dev t| = sqrt(2) g', t1 - t3 = 2 g', -(t1 + t3) = 2 p', and |dev t| = -alpha tr t
    // = 3 alpha p', so the ratio is 3 alpha / sqrt(2): 0.743 for 32 degrees, the sin of 48 degrees.
    EXPECT_NEAR(cone, 3.0f * alpha / std::sqrt(2.0f), 1e-4f);
    EXPECT_GT(cone, 1.35f * s);
}

TEST(SandModel, VolumeCorrectionRestoresVolumeLostUnderTension) {
    Sand::Params m;
    for (bool correct : {true, false}) {
        m.volumeCorrection = correct;
        Sand::State s;
        s.appendRest(1, m);
        const float dt = 1e-3f;
        // Pull apart (projected to the tip, F_E reset to I), then push back by the same amount.
        Sand::updateDeformation(m, s, 0, 10.0f * Mat3f::Identity(), dt);
        EXPECT_TRUE(s.Fe[0].isApprox(Mat3d::Identity(), 1e-6));  // to float's precision: the SVD is in float
        Sand::updateDeformation(m, s, 0, Mat3f::Identity() * (1.0f / (1.0f + 10.0f * dt) - 1.0f) / dt, dt);
        const double J = s.Fe[0].determinant();
        if (correct)
            EXPECT_NEAR(J, 1.0f, 1e-4f);  // the separation is remembered: back at rest volume
        else
            EXPECT_LT(J, 0.98f);  // without it the sand is compressed below rest
    }
}

namespace {
/// One material point of metal pulled in uniaxial stress: the axial log strain grows by `step` a stage, and the
/// lateral stretch rate is found by the secant method so that the lateral stress stays zero (to 1e-6 sigma_y).
/// Each stage is one updateDeformation with dt 1, grad v = diag(step, r, r). Returns (axial log strain, axial
/// Kirchhoff stress, equivalent plastic strain) after each stage.
struct UniaxialStage {
    double strain, stress, plastic;
};
std::vector<UniaxialStage> pullUniaxially(const VonMises::Params& m, double step, int stages) {
    Species<VonMises> point;
    point.params = m;
    point.state.appendRest(1);
    const auto lateralStress = [&](double r, VonMises::State& s) {
        s = point.state;
        const Mat3f L = Vec3f(float(step), float(r), float(r)).asDiagonal();
        VonMises::updateDeformation(m, s, 0, L, 1.0f);
        return double(VonMises::kirchhoff(m, s, 0)(1, 1));
    };
    std::vector<UniaxialStage> out;
    double guess = -0.33 * step;
    for (int k = 0; k < stages; ++k) {
        VonMises::State s;
        double a = guess, b = 0.9 * guess, fa = lateralStress(a, s), fb = lateralStress(b, s);
        for (int it = 0; it < 50 && std::abs(fb) > 1e-6 * m.yieldStress && fb != fa; ++it) {
            const double c = b - fb * (b - a) / (fb - fa);
            a = b, fa = fb, b = c, fb = lateralStress(b, s);
        }
        guess = b;
        point.state = s;
        // The axial log strain: elastic (Fe's stretch) plus plastic (in uniaxial stress the axial plastic strain is the
        // equivalent one). Taken from the state, not summed from the steps, which float rounds by up to 0.1% each.
        const double strain = std::log(s.Fe[0](0, 0)) + double(s.alpha[0]);
        out.push_back({strain, double(VonMises::kirchhoff(m, s, 0)(0, 0)), double(s.alpha[0])});
    }
    return out;
}
}  // namespace

TEST(MetalModel, UniaxialTensionYieldsAtTheYieldStressAndHardensWithTheTangentModulus) {
    // Aluminium (the preset): E 68.9 GPa, sigma_y 276 MPa (yield strain 0.4%), H 0.3 GPa. Pulled to 2% log strain
    // in 2000 stages: elastic at E up to sigma_y, then along E H / (E + H) (Simo and Hughes 1998, sec. 2.2); the
    // tolerances are float round-off (7 digits) over stages of 1e-5 strain, far inside the 2%.
    const VonMises::Params m;
    const double E = m.mu * (3.0 * m.lambda + 2.0 * m.mu) / (m.lambda + m.mu);
    const std::vector<UniaxialStage> path = pullUniaxially(m, 1e-5, 2000);
    std::size_t firstPlastic = path.size();
    for (std::size_t k = 0; k < path.size() && firstPlastic == path.size(); ++k)
        if (path[k].plastic > 0.0) firstPlastic = k;
    ASSERT_LT(firstPlastic, path.size());
    // Before yield: Hencky's uniaxial stress is exactly E times the log strain.
    const UniaxialStage& last = path[firstPlastic - 1];
    EXPECT_NEAR(last.stress, E * last.strain, 1e-4 * last.stress);
    // Yield within one stage of sigma_y / E, at sigma_y.
    EXPECT_NEAR(path[firstPlastic].strain, m.yieldStress / E, 1.5e-5);
    EXPECT_NEAR(path[firstPlastic].stress, m.yieldStress, 0.002 * m.yieldStress);
    // Hardening: the slope from 1% to 2% strain, and the plastic strain is the strain less the elastic part.
    const UniaxialStage &a = path[999], &b = path.back();
    const double tangent = E * m.hardening / (E + m.hardening);
    EXPECT_NEAR((b.stress - a.stress) / (b.strain - a.strain), tangent, 0.01 * tangent);
    EXPECT_NEAR(b.stress, m.yieldStress + m.hardening * b.plastic, 1e-3 * b.stress);
    EXPECT_NEAR(b.plastic, b.strain - b.stress / E, 1e-3 * b.plastic);
}

TEST(MetalModel, PlasticFlowKeepsTheVolumeAndPressureNeverYields) {
    // J2 flow is deviatoric: a hydrostatic squeeze to 10% of the volume stays elastic (no plastic strain, stress
    // K ln J), and a shear far past yield leaves the volume as the elastic trial had it.
    VonMises::Params m;
    Species<VonMises> p;
    p.state.appendRest(2);
    const float c = float(std::cbrt(0.9) - 1.0);  // F = (1 + c) I: J = 0.9
    VonMises::updateDeformation(m, p.state, 0, Vec3f::Constant(c).asDiagonal(), 1.0f);
    EXPECT_EQ(p.state.alpha[0], 0.0f);
    EXPECT_NEAR(VonMises::volumeRatio(p.state, 0), 0.9f, 1e-6f);
    const double K = m.lambda + 2.0 / 3.0 * m.mu;
    EXPECT_NEAR(VonMises::kirchhoff(m, p.state, 0).trace() / 3.0, K * std::log(0.9), 1e-4 * K * std::abs(std::log(0.9)));
    Mat3f shear = Mat3f::Zero();
    shear(0, 1) = 0.05f;  // 5% shear: 30 times the shear yield strain
    const float before = (Mat3f::Identity() + shear).determinant();
    VonMises::updateDeformation(m, p.state, 1, shear, 1.0f);
    EXPECT_GT(p.state.alpha[1], 0.0f);
    EXPECT_NEAR(VonMises::volumeRatio(p.state, 1), before, 1e-5f);
    // On the yield surface after the return: |dev tau| = sqrt(2/3) (sigma_y + H alpha).
    const Mat3f tau = VonMises::kirchhoff(m, p.state, 1);
    const Mat3f dev = tau - tau.trace() / 3.0f * Mat3f::Identity();
    EXPECT_NEAR(dev.norm(), std::sqrt(2.0 / 3.0) * (m.yieldStress + m.hardening * p.state.alpha[1]), 1e-4 * m.yieldStress);
}
