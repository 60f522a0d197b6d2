#pragma once
// The closed list of constitutive models, and the contract each one meets (checked by MaterialModel below
// with a readable static_assert). A material is a struct with this shape (see Water.h):
// @code
// struct Model {
//     static constexpr const char* kName;        // the model ("fixed_corotated")
//     static constexpr const char* kSceneName;   // what a scene calls it ("jelly"); unique in the list
//     static constexpr const char* kSummary;     // one line for `mpm validate --explain`, with its paper
//     static constexpr float kColour[3];          // its points' colour unless a set gives one (Cd, linear RGB)
//     struct Params { ... };                     // constant per species, SI units; initial values are the defaults
//     struct State  { vectors...; forEachArray(f) (and const); appendRest(n) or appendRest(n, params); };
//     template <class V> static void keys(V&, Params&);          // its scene keys (base/Parameters.h)
//     static void   scaleStiffness(Params&, double lambdaScale, double muScale);  // a set's Lame scales
//     static Mat3f  kirchhoff(const Params&, const State&, size_t i);              // tau = P F^T
//     static void   updateDeformation(const Params&, State&, size_t i, const Mat3f& gradV, float dt); // + return map
//     static double energyDensity(const Params&, const State&, size_t i);           // per reference volume
//     static float  volumeRatio(const State&, size_t i);                            // J, for diagnostics
//     static float  stiffnessKey(const State&, size_t i);                           // its minimum sets ...
//     static float  waveSpeed(const Params&, float minStiffnessKey);                // ... the fastest wave speed
//     // optional, for output attributes (io/PointCloud.cpp; without them F = J^(1/3) I and Jp = 1):
//     static Mat3f  deformationGradient(const State&, size_t i);                    // the elastic F the model keeps
//     static float  plasticVolumeRatio(const State&, size_t i);                     // Jp, volume change from plasticity
//     static float  plasticStrain(const State&, size_t i);                          // equivalent plastic strain
//     // optional traits, read by the scene reader and the budget:
//     static constexpr bool kShearModulus = false;  // no shear modulus: a set's mu_scale is refused (water)
//     static const char* stiffens(const Params&);  // why its step shortens as it deforms, in words, or nullptr (snow)
//     // optional, for n <= simd::kLanes consecutive particles (the SVD-based models run their SVDs in SIMD lanes):
//     // (lane k's parameters m[k]: one set for all, or each particle's; materials/SvdBatch.h, LaneParams):
//     static void   kirchhoffBatch(const LaneParams<Params>& m, const State&, size_t first, int n, Mat3f* tau);
//     static void   updateDeformationBatch(const LaneParams<Params>& m, State&, size_t first, int n, const Mat3f* gradV,
//                                          float dt);
// };
// @endcode
// A new model is a new header and one entry in AllMaterials. A build may append models of its own without
// touching this file (the test suite adds linear elasticity this way): MPM_EXTRA_MATERIALS_HEADER names the
// header and MPM_EXTRA_MATERIALS lists the types, each preceded by a comma.
#include <concepts>
#include <cstddef>
#include <string_view>
#include <type_traits>

#include "materials/FixedCorotated.h"
#include "materials/HerschelBulkley.h"
#include "materials/NeoHookean.h"
#include "materials/Sand.h"
#include "materials/Snow.h"
#include "materials/VonMises.h"
#include "materials/Water.h"

#ifdef MPM_EXTRA_MATERIALS_HEADER
#include MPM_EXTRA_MATERIALS_HEADER
#endif
#ifndef MPM_EXTRA_MATERIALS
#define MPM_EXTRA_MATERIALS
#endif

namespace mpm {

namespace material_detail {
/// Stands for the f of State::forEachArray(f): any per-particle vector.
struct ArrayVisitor {
    template <class T>
    void operator()(const std::vector<T>&) const {}
};
}  // namespace material_detail

template <class M>
concept MaterialModel = requires(const typename M::Params& cp, typename M::Params& p, const typename M::State& cs,
                                 typename M::State& s, std::size_t i, const Mat3f& gradV, float dt, KeyVisitorArchetype& v,
                                 material_detail::ArrayVisitor f) {
    { M::kName } -> std::convertible_to<const char*>;
    { M::kSceneName } -> std::convertible_to<const char*>;
    { M::kSummary } -> std::convertible_to<const char*>;
    { M::kColour[2] } -> std::convertible_to<float>;
    M::keys(v, p);
    M::scaleStiffness(p, 1.0, 1.0);
    { M::kirchhoff(cp, cs, i) } -> std::convertible_to<Mat3f>;
    M::updateDeformation(cp, s, i, gradV, dt);
    { M::energyDensity(cp, cs, i) } -> std::convertible_to<double>;
    { M::volumeRatio(cs, i) } -> std::convertible_to<float>;
    { M::stiffnessKey(cs, i) } -> std::convertible_to<float>;
    { M::waveSpeed(cp, 1.0f) } -> std::convertible_to<float>;
    s.forEachArray(f);
    cs.forEachArray(f);
    requires requires { s.appendRest(i); } || requires {
        s.appendRest(i, cp);
    };
};

/// Whether a set's mu_scale has a modulus to scale in M: a model without a shear modulus (water) declares
/// `static constexpr bool kShearModulus = false;`, and the scene reader refuses mu_scale on it.
template <class M>
constexpr bool hasShearModulus() {
    if constexpr (requires { M::kShearModulus; })
        return M::kShearModulus;
    else
        return true;
}

/// Why M's step shortens as a run goes on with parameters p, in words, or nullptr: a model whose stiffness can grow
/// as it deforms declares `static const char* stiffens(const Params&)`, so that estimates made from the rest state
/// say they are short where it does (snow with a hardening coefficient, not without).
template <class M>
const char* stiffening(const typename M::Params& p) {
    if constexpr (requires { M::stiffens(p); })
        return M::stiffens(p);
    else
        return nullptr;
}

template <class... Ms>
struct MaterialList {
    static constexpr std::size_t size = sizeof...(Ms);
};

/// Checks one model against the contract above, with a message that says where the contract is written.
template <class M>
constexpr bool checkMaterial() {
    static_assert(MaterialModel<M>,
                  "this type does not meet the material contract: see the @code block at the top of materials/Materials.h "
                  "(kName, kSceneName, kSummary, kColour, Params, State, keys, scaleStiffness, kirchhoff, updateDeformation, "
                  "energyDensity, volumeRatio, stiffnessKey, waveSpeed)");
    return true;
}

template <class... Ms>
constexpr bool checkMaterials(MaterialList<Ms...>) {
    return (checkMaterial<Ms>() && ...);
}

/// Scene names must be unique: a scene picks its model by that name.
template <class... Ms>
constexpr bool sceneNamesUnique(MaterialList<Ms...>) {
    return namesDistinct({Ms::kSceneName...});
}

/// Parameter types must differ between models too: a scene's parameter set says which model it is for.
template <class T, class... Ts>
constexpr std::size_t countOf = (std::size_t(std::is_same_v<T, Ts>) + ... + 0);
template <class... Ms>
constexpr bool paramsUnique(MaterialList<Ms...>) {
    return ((countOf<typename Ms::Params, typename Ms::Params...> == 1) && ...);
}

// The order is free: checkpoints name a material by kSceneName, and output files carry the names of the indices
// they write (the VDB points' `material_names` metadata, a PLY header's comment).
using AllMaterials = MaterialList<Water, FixedCorotated, NeoHookean, Snow, Sand, VonMises, HerschelBulkley MPM_EXTRA_MATERIALS>;
static_assert(checkMaterials(AllMaterials{}));
static_assert(sceneNamesUnique(AllMaterials{}), "two materials share a kSceneName");
static_assert(paramsUnique(AllMaterials{}), "two materials share a Params type (derive one of its own)");

/// Calls f.template operator()<M>() for every model in the list, in order.
template <class... Ms, class F>
void forEachMaterial(MaterialList<Ms...>, F&& f) {
    (f.template operator()<Ms>(), ...);
}

/// tau of particles first .. first + n - 1 (n <= simd::kLanes), lane k with parameters m[k]: batched where the
/// model has it.
template <class M>
void kirchhoffOfRange(const LaneParams<typename M::Params>& m, const typename M::State& s, std::size_t first, int n, Mat3f* tau) {
    if constexpr (requires { M::kirchhoffBatch(m, s, first, n, tau); })
        M::kirchhoffBatch(m, s, first, n, tau);
    else
        for (int k = 0; k < n; ++k) tau[k] = M::kirchhoff(m[k], s, first + std::size_t(k));
}

/// updateDeformation of particles first .. first + n - 1 (n <= simd::kLanes), the same way.
template <class M>
void updateDeformationOfRange(const LaneParams<typename M::Params>& m, typename M::State& s, std::size_t first, int n,
                              const Mat3f* gradV, float dt) {
    if constexpr (requires { M::updateDeformationBatch(m, s, first, n, gradV, dt); })
        M::updateDeformationBatch(m, s, first, n, gradV, dt);
    else
        for (int k = 0; k < n; ++k) M::updateDeformation(m[k], s, first + std::size_t(k), gradV[k], dt);
}

}  // namespace mpm
