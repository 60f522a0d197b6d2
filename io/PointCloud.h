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

    /// The names output.attributes allows, in the order the flags above are declared.
    static const std::vector<std::string>& names() {
        static const std::vector<std::string> n = {"J", "Jp", "stress_norm", "F", "plastic_strain"};
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
