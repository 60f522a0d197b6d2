#pragma once
// Binary little-endian PLY point clouds, which Blender imports as vertices and our own point-cloud reader
// (io/PointFile.h) reads back as a particle set: positions in double (as the engine keeps them), velocity, id,
// material, set, pscale, the set's colour as 8-bit sRGB red, green, blue, and the extra attributes the cloud
// carries (J, Jp, stress_norm, F as F00 ... F22).
#include <string>

#include "io/PointCloud.h"

namespace mpm {

/// Writes the points to path, atomically.
void writePly(const std::string& path, const PointCloud& points);

}  // namespace mpm
