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

}  // namespace mpm
