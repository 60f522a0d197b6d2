#pragma once
// Particles are grouped in species: one constitutive model with one parameter set, stored as structure of
// arrays holding only what that model needs (water: J; elastic: F; ...). Kernels are templates over the
// material and are dispatched once per species and leaf range with std::visit, never per particle.
#include <string>
#include <variant>
#include <vector>

#include "base/Types.h"
#include "materials/Materials.h"

namespace mpm {

/// Attributes every particle has, whatever its material.
struct ParticleArrays {
    std::vector<Vec3d> x;        ///< position [m], double so that precision does not decay far from the origin
    std::vector<Vec3f> v;        ///< velocity [m/s]
    std::vector<Mat3f> C;        ///< APIC affine velocity C = B D^-1 [1/s]
    std::vector<float> mass;     ///< [kg]
    std::vector<float> volume0;  ///< reference volume V_p^0 [m^3]
    std::vector<int32_t> id;     ///< stable identifier across frames
    std::vector<uint16_t> set;   ///< index of the particle set that emitted it

    template <class F>
    void forEachArray(F&& f) {
        each(*this, f);
    }
    template <class F>
    void forEachArray(F&& f) const {
        each(*this, f);
    }
    std::size_t size() const { return x.size(); }

private:
    template <class Self, class F>
    static void each(Self& p, F& f) {
        f(p.x);
        f(p.v);
        f(p.C);
        f(p.mass);
        f(p.volume0);
        f(p.id);
        f(p.set);
    }
};

/// One material model with one parameter set and its particles, or with parameters particle by particle.
template <class M>
struct Species {
    using Material = M;
    using Params = typename M::Params;
    std::string name;
    /// The set's parameters; with parameters per particle, the stiffest particle's (the CFL bound reads them).
    Params params;
    ParticleArrays p;
    typename M::State state;
    /// Particles of grid leaf l are [leafStart[l], leafStart[l+1]) after binning (a step cache: binning
    /// rebuilds it before every use).
    std::vector<uint32_t> leafStart;
    /// Whether each particle has parameters of its own in `local` (a set's material_fields): then `local` is one
    /// more per-particle array, moved, sent and checkpointed with the others; a species without pays nothing.
    bool perParticle = false;
    std::vector<Params> local;

    const Params& paramsOf(std::size_t i) const { return perParticle ? local[i] : params; }

    template <class F>
    void forEachArray(F&& f) {
        p.forEachArray(f);
        state.forEachArray(f);
        if (perParticle) f(local);
    }
    template <class F>
    void forEachArray(F&& f) const {
        p.forEachArray(f);
        state.forEachArray(f);
        if (perParticle) f(local);
    }
    std::size_t size() const { return p.size(); }
};

/// The parameters of particles first .. first + kLanes - 1 of a species, lane by lane.
template <class M>
LaneParams<typename M::Params> lanesFrom(const Species<M>& sp, std::size_t first) {
    return sp.perParticle ? LaneParams<typename M::Params>(sp.params, &sp.local[first])
                          : LaneParams<typename M::Params>(sp.params);
}

/// tau of particles first .. first + n - 1 (n <= simd::kLanes) of a species, in one batch whether the particles
/// share the species' parameters or have their own: a lane computes the same bits either way, so a field equal
/// everywhere changes none. One call site for both: a second one changes how GCC inlines the models' batches, and
/// with that where it contracts multiply-adds, which moved the bits of species without fields.
template <class M>
void kirchhoffOfRange(const Species<M>& sp, std::size_t first, int n, Mat3f* tau) {
    kirchhoffOfRange<M>(lanesFrom(sp, first), sp.state, first, n, tau);
}

/// The deformation update and return map of particles first .. first + n - 1 (n <= simd::kLanes) of a species,
/// the same way.
template <class M>
void updateDeformationOfRange(Species<M>& sp, std::size_t first, int n, const Mat3f* gradV, float dt) {
    updateDeformationOfRange<M>(lanesFrom(sp, first), sp.state, first, n, gradV, dt);
}

/// The closed set of species types, one per material in materials/Materials.h, and of their parameters.
template <class List>
struct SpeciesVariantOf;
template <class... Ms>
struct SpeciesVariantOf<MaterialList<Ms...>> {
    using type = std::variant<Species<Ms>...>;
    using params = std::variant<typename Ms::Params...>;
    using paramsArray = std::variant<std::vector<typename Ms::Params>...>;
};
using AnySpecies = SpeciesVariantOf<AllMaterials>::type;
/// Parameters of any one material; the alternative says which.
using AnyMaterialParams = SpeciesVariantOf<AllMaterials>::params;
/// Parameters particle by particle, of any one material.
using AnyParamsArray = SpeciesVariantOf<AllMaterials>::paramsArray;

/// Common attributes of any species, without knowing its material.
inline ParticleArrays& particlesOf(AnySpecies& s) {
    return std::visit([](auto& sp) -> ParticleArrays& { return sp.p; }, s);
}
inline const ParticleArrays& particlesOf(const AnySpecies& s) {
    return std::visit([](const auto& sp) -> const ParticleArrays& { return sp.p; }, s);
}

/// An empty species of the material that `params` belong to.
inline AnySpecies makeSpecies(const std::string& name, const AnyMaterialParams& params) {
    return std::visit(
        [&]<class P>(const P& p) -> AnySpecies {
            AnySpecies out;
            forEachMaterial(AllMaterials{}, [&]<class M>() {
                if constexpr (std::is_same_v<typename M::Params, P>) out = Species<M>{name, p, {}, {}, {}, false, {}};
            });
            return out;
        },
        params);
}

/// Calls f.template operator()<M>(params) with M the model the parameters belong to.
template <class Params, class F>
void visitMaterialParams(Params& params, F&& f) {
    forEachMaterial(AllMaterials{}, [&]<class M>() {
        if (auto* p = std::get_if<typename M::Params>(&params)) f.template operator()<M>(*p);
    });
}

/// Scene names of the materials, in list order (the order of the `material` index written with the points).
const std::vector<std::string>& materialSceneNames();
/// Index in that list of the model a species or a parameter set belongs to.
inline int materialIndex(const AnySpecies& s) { return int(s.index()); }
inline int materialIndex(const AnyMaterialParams& p) { return int(p.index()); }
/// Default parameters of the material called `sceneName`, or nothing when no material has that name.
bool defaultMaterialParams(const std::string& sceneName, AnyMaterialParams& out);
/// Default parameters of the material at `index` in the list; false when there is none.
bool defaultMaterialParamsAt(std::size_t index, AnyMaterialParams& out);

}  // namespace mpm
