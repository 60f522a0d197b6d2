#pragma once
// The OpenVDB side of core/LevelSet.h, for the few files that make or sample level sets.
#include <openvdb/openvdb.h>

#include "core/LevelSet.h"

namespace mpm {

struct LevelSet::Grid {
    openvdb::FloatGrid::ConstPtr grid;
};

struct VectorField::Grid {
    openvdb::Vec3SGrid::ConstPtr grid;
};

}  // namespace mpm
