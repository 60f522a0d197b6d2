#pragma once
// Binary little-endian PLY point clouds with velocity and id, which Blender imports as vertices.
#include <string>
#include <vector>

#include "core/Species.h"

namespace mpm {

/// Writes the particles of the given species (all when the list is empty) to path, atomically.
void writePly(const std::string& path, const std::vector<AnySpecies>& species, const std::vector<int>& which = {});

}  // namespace mpm
