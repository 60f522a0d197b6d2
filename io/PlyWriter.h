#pragma once
// Binary little-endian PLY point clouds, which Blender imports as vertices and our own point-cloud reader
// (io/PointFile.h) reads back as a particle set: positions in double (as the engine keeps them), velocity, id,
// material, set, pscale, the set's colour as 8-bit sRGB red, green, blue, and the extra attributes the cloud
// carries (J, Jp, stress_norm, F as F00 ... F22).
#include <string>
#include <vector>

#include "io/PointCloud.h"

namespace mpm {

/// Writes the points to path, atomically. `materialNames`, the scene names of the `material` indices in order, go
/// in a header comment ("comment material_names water jelly ..."), so the file says which index is which.
void writePly(const std::string& path, const PointCloud& points, const std::vector<std::string>& materialNames = {});

}  // namespace mpm
