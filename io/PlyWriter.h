#pragma once
// Binary little-endian PLY point clouds with velocity and id, which Blender imports as vertices.
#include <string>

#include "io/PointCloud.h"

namespace mpm {

/// Writes the points to path, atomically.
void writePly(const std::string& path, const PointCloud& points);

}  // namespace mpm
