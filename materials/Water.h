#pragma once
// Weakly compressible water (thesis eq. 4.1-4.2, pseudocode 4; Tait-like equation of state as used by
// Tampubolon et al. 2017). The species stores J only, never F: deviatoric strain carries no energy.
//   Psi(J) = -k (J^(1-gamma) / (1-gamma) - J),   p = -dPsi/dJ = k (J^-gamma - 1),
//   Kirchhoff stress tau = J dPsi/dJ I = -J p I,  J <- (1 + dt tr(grad v)) J.
// Water holds no tension by default: expansion past the rest volume is taken as plastic (the liquid
// separates, as a free surface or spray), J <- min(J, 1), the clipped-negative-pressure rule of
// weakly compressible SPH. Without it, free-surface particles drift to J > 1 through the truncated
// kernel support and pull on their neighbours (the hydrostatic validation case measured -940 Pa at
// the surface of a 1 m column after 0.25 s, where the answer is 0).
#include <cmath>
#include <vector>

#include "base/Parameters.h"
#include "base/Types.h"

namespace mpm {

struct Water {
    static constexpr const char* kName = "water";
    static constexpr const char* kSceneName = "water";
    /// The colour its points take unless a set gives one (Cd, linear RGB).
    static constexpr float kColour[3] = {0.15f, 0.4f, 0.9f};
    static constexpr const char* kSummary =
        "weakly compressible water, Tait-like equation of state (thesis 4.1-4.2; Tampubolon et al. 2017)";

    struct Params {
        float density = 1000.0f;     ///< rho0 [kg/m^3]
        float bulkModulus = 5.0e4f;  ///< k [Pa]; the thesis's k = 50 at rho = 1, scaled with rho (same sound speed)
        float gamma = 4.0f;          ///< stiffening exponent (thesis default 4; Becker and Teschner use 7)
        bool tension = false;        ///< allow J > 1 (negative pressure); off: J is clamped to at most 1
    };

    struct State {
        /// Volume ratio det F, in double: in float a step's change under half an ulp (6e-8) is lost, so a stiff
        /// column that settles slowly stops registering its volume while its particles move (docs/method.md, section 5).
        std::vector<double> J;
        template <class F>
        void forEachArray(F&& f) {
            f(J);
        }
        template <class F>
        void forEachArray(F&& f) const {
            f(J);
        }
        void appendRest(std::size_t n) { J.resize(J.size() + n, 1.0); }
    };

    /// Scene keys. The defaults keep the thesis's k = 50 at rho = 1 scaled with the density, so that the
    /// sound speed sqrt(k gamma / rho) = 14.1 m/s is the thesis's.
    template <class V>
    static void keys(V& v, Params& p) {
        v.number(Key{.name = "density", .help = "rest density rho0", .lo = kTiny, .hi = kHuge, .unit = "kg/m^3"}, p.density);
        v.number(Key{.name = "bulk_modulus", .help = "bulk modulus k", .lo = 0.0, .hi = kHuge, .unit = "Pa"}, p.bulkModulus);
        v.number(Key{.name = "gamma", .help = "stiffening exponent of the equation of state", .lo = 1.0, .hi = 20.0}, p.gamma);
        v.flag(
            Key{.name = "tension",
                .help =
                    "hold negative pressure (the thesis's EOS: free-surface water turns cohesive); false clamps J to at most 1"},
            p.tension);
    }
    /// A set's lambda_scale scales the bulk modulus, water's only Lame-like parameter; mu_scale has nothing to scale
    /// (a set giving it is refused, io/SceneKeys.h).
    static constexpr bool kShearModulus = false;
    static void scaleStiffness(Params& p, double lambdaScale, double /*muScale*/) {
        p.bulkModulus = float(double(p.bulkModulus) * lambdaScale);
    }

    static float pressure(const Params& m, float J) { return m.bulkModulus * (powNegative(J, m.gamma) - 1.0f); }

    /// J^-gamma; integer exponents (the usual 4 and 7) by repeated squaring, since powf dominated water's stress.
    static float powNegative(float J, float gamma) {
        constexpr float kLargestIntegerExponent = 16.0f;
        if (gamma >= 1.0f && gamma <= kLargestIntegerExponent && gamma == float(int(gamma))) {
            float r = 1.0f, b = 1.0f / J;
            for (int e = int(gamma); e > 0; e >>= 1, b *= b)
                if (e & 1) r *= b;
            return r;
        }
        return std::pow(J, -gamma);
    }

    /// The stress in float from J rounded once, an error that does not accumulate.
    static Mat3f kirchhoff(const Params& m, const State& s, std::size_t i) {
        const float J = float(s.J[i]);
        return Mat3f::Identity() * (-J * pressure(m, J));
    }

    /// dt tr(grad v) is exact enough in float; adding it to 1 is where float would round it away.
    static void updateDeformation(const Params& m, State& s, std::size_t i, const Mat3f& gradV, float dt) {
        const double J = s.J[i] * (1.0 + double(dt * gradV.trace()));
        s.J[i] = m.tension ? J : std::fmin(J, 1.0);
    }

    /// Psi(J) - Psi(1) = -k ((J^(1-gamma) - 1) / (1 - gamma) - (J - 1)): zero at rest exactly, and without the
    /// cancellation of two large terms.
    static double energyDensity(const Params& m, const State& s, std::size_t i) {
        const double k = m.bulkModulus, g = m.gamma, J = s.J[i];
        return -k * ((std::pow(J, 1.0 - g) - 1.0) / (1.0 - g) - (J - 1.0));
    }

    static float volumeRatio(const State& s, std::size_t i) { return float(s.J[i]); }

    /// The wave speed grows as J shrinks: c = sqrt(k gamma / rho0) J^((1-gamma)/2) (docs/method.md, section 4).
    static float stiffnessKey(const State& s, std::size_t i) { return float(s.J[i]); }
    static float waveSpeed(const Params& m, float minJ) {
        const float J = std::fmax(minJ, 1e-3f);
        return std::sqrt(m.bulkModulus * m.gamma / m.density) * std::pow(J, 0.5f * (1.0f - m.gamma));
    }
};

}  // namespace mpm
