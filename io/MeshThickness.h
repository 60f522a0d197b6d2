#pragma once
// How thin a collider mesh's solid gets: measured from each triangle along its normal into the solid, to the
// next surface (a ray cast through Eigen's bounding-volume hierarchy). A distance field resolves a wall only
// when its voxel is at most half the wall's thickness; thinner, the field shows no inside there and material
// passes through. The scene builder picks the voxel of a mesh collider from this, and `mpm validate` warns
// when a mesh has parts thinner than its field resolves.
#include "io/LevelSets.h"

namespace mpm {

struct WallThickness {
    double thinnest = 0.0;        ///< [m]: the least thickness found, or the search limit when none is thinner
    Vec3d where = Vec3d::Zero();  ///< the triangle centroid it was measured from
    int triangle = -1;            ///< and that triangle's index (-1: none thinner than the limit)
};

/// The least thickness of the mesh's solid below `limit` [m]. The solid is the mesh's inside (its signed
/// volume tells which way its triangles face), or with `solidOutside` its outside (a collider that keeps
/// material inside the mesh). Gaps of air are not walls and are not measured.
WallThickness thinnestWall(const TriangleMesh& mesh, double limit, bool solidOutside = false);

/// A wall is resolved by a distance field whose voxel is at most this fraction of its thickness: two voxels
/// across it (a water-filled cup with walls dx/4 thick held at voxel dx/8 and leaked at dx/2 and dx/4).
inline constexpr double kVoxelsAcrossWall = 2.0;

}  // namespace mpm
