#pragma once
// The OpenVDB side of core/LevelSet.h, for the few files that make or sample level sets.
#include <openvdb/openvdb.h>

#include "core/LevelSet.h"

namespace mpm {

struct LevelSet::Grid {
    openvdb::FloatGrid::ConstPtr grid;
};

/// LevelSet::insideBounds of an OpenVDB level set.
void insideBoundsOf(const openvdb::FloatGrid& grid, Vec3d& lo, Vec3d& hi);

struct VectorField::Grid {
    openvdb::Vec3SGrid::ConstPtr grid;
};

}  // namespace mpm
