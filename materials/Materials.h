#pragma once
// The closed list of constitutive models. A material is a struct with this shape (see Water.h):
// @code
// struct Model {
//     static constexpr const char* kName;
//     struct Params { ... };                               // constant per species, SI units
//     struct State  { vectors...; forEachArray(f); appendRest(n) or appendRest(n, params); };   // per-particle, only what it needs
//     static Mat3f  kirchhoff(const Params&, const State&, size_t i);   // tau = P F^T
//     static void   updateDeformation(const Params&, State&, size_t i, const Mat3f& gradV, float dt); // + return map
//     static double energyDensity(const Params&, const State&, size_t i);  // per reference volume
//     static float  volumeRatio(const State&, size_t i);                    // J, for diagnostics
//     static float  stiffnessKey(const State&, size_t i);                   // its minimum sets ...
//     static float  waveSpeed(const Params&, float minStiffnessKey);        // ... the fastest wave speed
//     // optional, for n <= simd::kLanes consecutive particles (the SVD-based models run their SVDs in SIMD lanes):
//     static void   kirchhoffBatch(const Params&, const State&, size_t first, int n, Mat3f* tau);
//     static void   updateDeformationBatch(const Params&, State&, size_t first, int n, const Mat3f* gradV, float dt);
// };
// @endcode
#include <type_traits>

#include "materials/FixedCorotated.h"
#include "materials/NeoHookean.h"
#include "materials/Sand.h"
#include "materials/Snow.h"
#include "materials/Water.h"

namespace mpm {

template <class... Ms> struct MaterialList {};
using AllMaterials = MaterialList<Water, FixedCorotated, NeoHookean, Snow, Sand>;

/// tau of particles first .. first + n - 1 (n <= simd::kLanes): batched where the model has it.
template <class M>
void kirchhoffOfRange(const typename M::Params& m, const typename M::State& s, std::size_t first, int n, Mat3f* tau) {
    if constexpr (requires { M::kirchhoffBatch(m, s, first, n, tau); }) M::kirchhoffBatch(m, s, first, n, tau);
    else
        for (int k = 0; k < n; ++k) tau[k] = M::kirchhoff(m, s, first + std::size_t(k));
}

/// updateDeformation of particles first .. first + n - 1 (n <= simd::kLanes): batched where the model has it.
template <class M>
void updateDeformationOfRange(const typename M::Params& m, typename M::State& s, std::size_t first, int n, const Mat3f* gradV,
                              float dt) {
    if constexpr (requires { M::updateDeformationBatch(m, s, first, n, gradV, dt); }) M::updateDeformationBatch(m, s, first, n, gradV, dt);
    else
        for (int k = 0; k < n; ++k) M::updateDeformation(m, s, first + std::size_t(k), gradV[k], dt);
}

}  // namespace mpm
