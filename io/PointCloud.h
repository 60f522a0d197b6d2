#pragma once
// The particles of a frame as flat arrays, whatever their material: what the writers (VDB, PLY) take, so
// that they know nothing of species or materials.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/Species.h"

namespace mpm {

struct PointCloud {
    std::vector<Vec3d> x;
    std::vector<Vec3f> v;
    std::vector<int32_t> id, material, set;
    /// The particles of species s are [speciesStart[s], speciesStart[s + 1]).
    std::vector<std::size_t> speciesStart{0};

    std::size_t size() const { return x.size(); }
    /// The points of the given species only, in the same order.
    PointCloud subset(const std::vector<int>& species) const;
};

/// Every particle of every species, species after species; material[i] is materialOfSpecies of its species.
PointCloud gatherPoints(const std::vector<AnySpecies>& species, const std::vector<int>& materialOfSpecies);

}  // namespace mpm
