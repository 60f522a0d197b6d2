#pragma once
// Point clouds from the user's tools as particle sets: the vertices of a PLY file (ASCII or binary, either
// byte order, as Houdini, Blender and CloudCompare write them) with their positions and, when the file has
// them, velocities (vx, vy, vz, or Houdini's v.x...), radii (pscale), masses (mass) and densities (density). Our own reader:
// assimp, the mesh library used elsewhere, keeps a PLY's positions but drops custom vertex properties such as velocity.
#include <stdexcept>
#include <string>
#include <vector>

#include "base/Types.h"

namespace mpm {

/// A point file that cannot serve as a particle set. what() reads "FILE: problem".
class PointFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// A vertex property asked for by name that the file does not have: `column` is its place in the names asked for.
class PointFileMissingProperty : public PointFileError {
public:
    PointFileMissingProperty(const std::string& what, std::size_t c) : PointFileError(what), column(c) {}
    std::size_t column;
};

struct PointCloudData {
    std::vector<Vec3d> x;
    std::vector<Vec3f> v;        ///< empty when the file has no velocities
    std::vector<float> pscale;   ///< empty when the file has no radii
    std::vector<float> mass;     ///< [kg]; empty when the file has no masses
    std::vector<float> density;  ///< [kg/m^3]; empty when the file has no densities
    /// The vertex properties asked for by name, in the order asked, one value per point.
    std::vector<std::vector<float>> columns;
};

/// Reads the `vertex` element of a PLY file, and the vertex properties named in `columns`. Errors: no such file,
/// not a PLY, no x, y, z or no property of a name asked for (naming the properties it has), a truncated body, no
/// points.
PointCloudData readPlyPoints(const std::string& path, const std::vector<std::string>& columns = {});

}  // namespace mpm
