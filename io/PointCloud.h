#pragma once
// The particles of a frame as flat arrays, whatever their material: what the writers (VDB, PLY) take, so
// that they know nothing of species or materials.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/Species.h"

namespace mpm {

/// What a frame's points carry beyond P, v, id, material, set and pscale: Cd from the sets' colours and the
/// attributes a scene asks for in output.attributes.
struct PointAttributes {
    bool J = false;                 ///< volume ratio det F
    bool Jp = false;                ///< plastic volume ratio (1 for models without plasticity)
    bool stressNorm = false;        ///< Frobenius norm of the Cauchy stress [Pa]
    bool F = false;                 ///< the elastic deformation gradient the model keeps (J^(1/3) I for a fluid)
    bool plasticStrain = false;     ///< equivalent plastic strain (0 for models without it)
    std::vector<Vec3f> setColours;  ///< Cd per set (linear RGB); empty: no Cd
    /// Material parameters asked for, of parameterNames(), in the order asked: each particle's own (a set's
    /// material_fields) or its set's, after the set's Lame scales.
    std::vector<std::string> parameters;

    /// The material parameters a frame can carry per particle, named as the materials' scene keys: density (its
    /// mass over its rest volume, kg/m^3), youngs_modulus and poisson_ratio (from a solid's Lame parameters; 0 for a
    /// liquid), bulk_modulus (a liquid's k, a solid's lambda + 2 mu / 3; Pa), viscosity (Pa s^n) and yield_stress
    /// (Pa; 0 for a model without them): the values given, not what hardening or softening made of them.
    static const std::vector<std::string>& parameterNames() {
        static const std::vector<std::string> n = {"density",      "youngs_modulus", "poisson_ratio",
                                                   "bulk_modulus", "viscosity",      "yield_stress"};
        return n;
    }
    /// The names output.attributes allows: the flags above in their order, then parameterNames().
    static const std::vector<std::string>& names() {
        static const std::vector<std::string> n = [] {
            std::vector<std::string> all = {"J", "Jp", "stress_norm", "F", "plastic_strain"};
            for (const std::string& p : parameterNames()) all.push_back(p);
            return all;
        }();
        return n;
    }
    /// The flags for a list of those names.
    static PointAttributes of(const std::vector<std::string>& requested);
};

struct PointCloud {
    std::vector<Vec3d> x;
    std::vector<Vec3f> v;
    std::vector<int32_t> id, material, set;
    std::vector<float> pscale;  ///< radius [m]: half the side of the particle's cube of current volume, (J V0)^(1/3) / 2
    std::vector<Vec3f> Cd;      ///< colour of the particle's set; empty unless asked for
    std::vector<float> J, Jp, stressNorm, plasticStrain;  ///< empty unless asked for
    std::vector<Mat3f> F;                                 ///< empty unless asked for
    /// A float column per material parameter asked for (PointAttributes::parameters), named as asked.
    std::vector<std::pair<std::string, std::vector<float>>> parameters;
    /// The particles of species s are [speciesStart[s], speciesStart[s + 1]).
    std::vector<std::size_t> speciesStart{0};

    std::size_t size() const { return x.size(); }
    /// The points of the given species only, in the same order.
    PointCloud subset(const std::vector<int>& species) const;
};

/// Every particle of every species, species after species; material[i] is materialOfSpecies of its species.
PointCloud gatherPoints(const std::vector<AnySpecies>& species, const std::vector<int>& materialOfSpecies,
                        const PointAttributes& attributes = {});

}  // namespace mpm
