// The viscous and yield-stress liquid (materials/HerschelBulkley.h) as one material point sheared at a constant
// rate: the steady shear stress against Herschel-Bulkley's law, the start-up against the Maxwell fluid's
// exponential, elasticity below the yield stress, the volume and pressure, and the update's stability at any
// viscosity.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "core/Species.h"
#include "materials/Materials.h"

using namespace mpm;

namespace {

/// Shears one point at gammaDot (v_x = gammaDot y) for `steps` steps of dt; returns tau_xy after each step.
std::vector<double> shear(const HerschelBulkley::Params& m, double gammaDot, double dt, int steps,
                          HerschelBulkley::State* out = nullptr) {
    HerschelBulkley::State s;
    s.appendRest(1);
    Mat3f gradV = Mat3f::Zero();
    gradV(0, 1) = float(gammaDot);
    std::vector<double> tau;
    for (int n = 0; n < steps; ++n) {
        HerschelBulkley::updateDeformation(m, s, 0, gradV, float(dt));
        tau.push_back(HerschelBulkley::kirchhoff(m, s, 0)(0, 1));
    }
    if (out) *out = s;
    return tau;
}

}  // namespace

TEST(ViscousModel, SteadyShearStressFollowsHerschelBulkley) {
    // Sheared at a strain of 1e-3 a step (an engine step's order) for 2000 steps, the stress settles where
    // tau_y + K gammaDot^n holds: Newtonian, Bingham, shear-thinning and -thickening, over three decades of shear
    // rate, where the elastic shear strain tau / G stays under 2% (at 14% the Hencky stress's rotated axes took 2% off
    // tau_xy: a liquid needs a G well above its flow's stresses). Backward Euler's steady state is exact at any step (the flow
    // then takes the whole strain increment), so the band is F_E's precision (float's: float's spacing of 6e-8 near 1 is G x 6e-8
    // = 4 mPa of stress, and four of them are allowed, beside 1e-3 of the stress for the Hencky stress's normal components (at an
    // elastic shear strain tau / G of at most 2% here, they change the shear stress by less than (tau / G)^2).
    struct Law {
        double tauY, K, n;
    };
    for (const Law law : {Law{0, 10, 1}, Law{50, 2, 1}, Law{30, 5, 0.5}, Law{0, 1, 1.5}}) {
        HerschelBulkley::Params m;
        m.yieldStress = float(law.tauY), m.viscosity = float(law.K), m.flowIndex = float(law.n);
        const double floatBand = 4.0 * m.shearModulus * std::numeric_limits<float>::epsilon();
        for (const double rate : {1.0, 10.0, 100.0}) {
            const double expected = law.tauY + law.K * std::pow(rate, law.n);
            const std::vector<double> tau = shear(m, rate, 1e-3 / rate, 2000);
            EXPECT_NEAR(tau.back(), expected, 1e-3 * expected + floatBand)
                << "tau_y " << law.tauY << " K " << law.K << " n " << law.n << " rate " << rate;
        }
    }
}

TEST(ViscousModel, StartUpFollowsTheMaxwellFluidsExponential) {
    // Newtonian (tau_y = 0, n = 1) at lava's viscosity: a Maxwell fluid, tau_xy(t) = K gammaDot (1 - exp(-t G / K)).
    // Backward Euler over the step gives (1 + dt / lambda)^-n in place of exp(-n dt / lambda): at dt = lambda / 100
    // that differs by at most 0.2% of K gammaDot (the largest of t/lambda e^(-t/lambda) dt / (2 lambda)); 0.5% allowed.
    HerschelBulkley::Params m;
    m.viscosity = 1e3f;
    const double rate = 1.0, lambda = m.viscosity / m.shearModulus, dt = lambda / 100.0;
    const std::vector<double> tau = shear(m, rate, dt, 500);
    double worst = 0.0;
    for (std::size_t k = 0; k < tau.size(); ++k) {
        const double t = double(k + 1) * dt;
        worst = std::max(worst, std::abs(tau[k] - m.viscosity * rate * (1.0 - std::exp(-t / lambda))));
    }
    EXPECT_LT(worst, 5e-3 * m.viscosity * rate);
}

TEST(ViscousModel, BelowTheYieldStressItIsElasticAndDoesNotFlow) {
    // Bingham: a shear strain that stays below tau_y / G is held elastically (tau = G gamma), with no flow.
    HerschelBulkley::Params m;
    m.yieldStress = 100.0f;
    const double strain = 0.5 * m.yieldStress / m.shearModulus, dt = 1e-3;
    HerschelBulkley::State s;
    const std::vector<double> tau = shear(m, strain / (10 * dt), dt, 10, &s);
    EXPECT_EQ(s.alpha[0], 0.0f);
    EXPECT_NEAR(tau.back(), m.shearModulus * strain, 1e-3 * m.shearModulus * strain);
}

TEST(ViscousModel, FlowKeepsTheVolumeAndThePressureIsWaters) {
    // The flow is deviatoric: sheared far past yield, the volume stays the trial's; squeezed to J = 0.9 the pressure
    // is water's equation of state at the same k and gamma, and nothing flows.
    HerschelBulkley::Params m;
    m.yieldStress = 10.0f;
    HerschelBulkley::State s;
    s.appendRest(2);
    const float c = float(std::cbrt(0.9) - 1.0);
    HerschelBulkley::updateDeformation(m, s, 0, Vec3f::Constant(c).asDiagonal(), 1.0f);
    EXPECT_EQ(s.alpha[0], 0.0f);
    EXPECT_NEAR(HerschelBulkley::volumeRatio(s, 0), 0.9f, 1e-6f);
    Water::Params w;
    w.bulkModulus = m.bulkModulus, w.gamma = m.gamma;
    const double p = Water::pressure(w, 0.9f);
    EXPECT_NEAR(-HerschelBulkley::kirchhoff(m, s, 0).trace() / 3.0, 0.9 * p, 1e-5 * p);
    Mat3f shearRate = Mat3f::Zero();
    shearRate(0, 1) = 0.05f;
    const float before = (Mat3f::Identity() + shearRate).determinant();
    HerschelBulkley::updateDeformation(m, s, 1, shearRate, 1.0f);
    EXPECT_GT(s.alpha[1], 0.0f);
    EXPECT_NEAR(HerschelBulkley::volumeRatio(s, 1), before, 1e-5f);
}

TEST(ViscousModel, OneStepNeverLeavesMoreStressThanItsElasticTrialAtAnyViscosity) {
    // Water's 1e-3 Pa s to lava's 1e3 and a stiff paste at n = 0.3, at steps from 1e-6 to 1e-2 s and shear rates
    // up to 1e3/s (trial strains from 1e-8 to 10): the returned equivalent stress |dev tau| / sqrt(2) lies between
    // tau_y and the elastic trial's (the update cannot amplify, so no viscosity shortens the time step), and below
    // K gammaDot^n + tau_y (no overshoot). The trial's stress is Hencky's, from a double-precision SVD.
    for (const double K : {1e-3, 1.0, 1e3})
        for (const double n : {0.3, 1.0, 2.0})
            for (const double dt : {1e-6, 1e-4, 1e-2})
                for (const double rate : {1e-2, 1.0, 1e3}) {
                    HerschelBulkley::Params m;
                    m.viscosity = float(K), m.flowIndex = float(n), m.yieldStress = 1.0f;
                    Mat3d F = Mat3d::Identity();
                    F(0, 1) = dt * rate;
                    const Eigen::Vector3d logStretch = Eigen::JacobiSVD<Mat3d>(F).singularValues().array().log().matrix();
                    const double trial =
                        std::sqrt(2.0) * m.shearModulus * (logStretch.array() - logStretch.mean()).matrix().norm();
                    HerschelBulkley::State s;
                    shear(m, rate, dt, 1, &s);
                    const Mat3f tau = HerschelBulkley::kirchhoff(m, s, 0);
                    const double returned = (tau - tau.trace() / 3.0f * Mat3f::Identity()).norm() / std::sqrt(2.0);
                    // F_E's precision (float's spacing near 1, times G; see above) on top of the bounds.
                    const double floatBand = 4.0 * m.shearModulus * std::numeric_limits<float>::epsilon();
                    const std::string at = "K " + std::to_string(K) + " n " + std::to_string(n) + " dt " + std::to_string(dt) +
                                           " rate " + std::to_string(rate);
                    EXPECT_LE(returned, trial * (1 + 1e-5) + floatBand) << at;
                    if (trial > m.yieldStress) {
                        EXPECT_GE(returned, m.yieldStress - floatBand) << at;
                        EXPECT_LE(returned, m.yieldStress + K * std::pow(rate, n) + floatBand) << at;
                    }
                }
}
