#pragma once
// The grid update (thesis 3.20, 3.26, section 5): v = (mv) / m plus dt g on nodes with mass, then the
// colliders at the step's end time.
#include <memory>
#include <vector>

#include "core/Collider.h"
#include "sparse/SparseGrid.h"

namespace mpm {

/// Turns momentum into velocity on every written node, adds gravity, applies the colliders at time tEnd.
/// Returns the largest node speed.
float updateGridVelocities(const SparseGrid& grid, const std::vector<std::unique_ptr<Collider>>& colliders, const Vec3f& gravity,
                           float dt, double tEnd);

}  // namespace mpm
