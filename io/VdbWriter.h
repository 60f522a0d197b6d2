#pragma once
// Per-frame VDB output for Houdini and Blender: a PointDataGrid "points" (P fixed-point, v, id, material,
// set), narrow-band level sets "surface" built from the particles with OpenVDB's own rasteriser, and
// optionally a fog volume "density" and a velocity grid "vel", and where the scene has rigid bodies a
// PointDataGrid "bodies" of one point each. OpenVDB's heavy headers live only in VdbWriter.cpp.
#include <array>
#include <map>
#include <string>
#include <vector>

#include "io/PointCloud.h"

namespace mpm {

/// The rigid bodies at a frame, one point each, as Houdini instances geometry: P (centre of mass), orient (a unit
/// quaternion in Houdini's order x, y, z, w: the turn from the scene's placement), v, w (angular velocity, rad/s)
/// collider (the body's index in the scene's collider list, to copy its geometry onto the point) and name (the
/// collider's name in the scene, the attribute Houdini's packed primitives are matched by).
struct BodyPoints {
    std::vector<Vec3d> x;
    std::vector<std::array<float, 4>> orient;
    std::vector<Vec3f> v, w;
    std::vector<int32_t> collider;
    std::vector<std::string> name;
};

struct SurfaceGroup {
    std::string gridName;      ///< "surface", or "surface_<material or set>"
    std::vector<int> species;  ///< species that make up this surface (distinct)
};

struct VdbFrameRequest {
    std::string volumePath;  ///< file for surface/density/vel (and points unless pointsPath is set)
    std::string pointsPath;  ///< separate file for points, empty to keep them with the volumes
    bool points = true, surface = true, density = false, velocity = false;
    double pointVoxelSize = 0.02;  ///< VDB points voxel (Houdini's default is ~8 points per voxel)
    double surfaceVoxelSize = 0.01;
    double surfaceRadius = 0.01;  ///< world-space sphere radius
    /// Morphological closing and smoothing of each surface (OpenVDB's LevelSetFilter), in voxels: dilate
    /// outward, smooth by that many Gaussian passes, then erode inward.
    double surfaceDilate = 0.0, surfaceErode = 0.0;
    int surfaceSmooth = 0;
    std::vector<SurfaceGroup> surfaces;
    std::vector<std::string> materialNames, setNames;  ///< what the cloud's material and set indices mean
    BodyPoints bodies;                                 ///< written as the grid "bodies" beside the volumes when there are any
};

/// Writes the requested grids atomically. Returns the number of particles written.
std::size_t writeVdbFrame(const VdbFrameRequest& request, const PointCloud& points);

/// Reads back the "points" grid of a file: positions, velocities, ids and every attribute and group there is
/// (for tests and tools; an attribute the file lacks stays empty).
struct PointsReadBack {
    std::vector<Vec3d> x;
    std::vector<Vec3f> v;
    std::vector<int32_t> id, material, set;
    std::vector<float> pscale, J, Jp, stressNorm, plasticStrain;
    std::vector<Vec3f> Cd;
    std::vector<Mat3f> F;
    std::vector<std::pair<std::string, std::vector<float>>> parameters;  ///< the material parameters written
    std::vector<std::string> materialNames, setNames;                    ///< from the grid's metadata
    std::map<std::string, std::string> groupNames;    ///< point group -> the material or set name it stands for
    std::map<std::string, std::vector<bool>> groups;  ///< point group -> membership, point by point
};
PointsReadBack readVdbPoints(const std::string& path);
/// Reads back the "bodies" grid of a file (empty when it has none).
BodyPoints readVdbBodies(const std::string& path);

/// Names of the grids in a VDB file.
std::vector<std::string> vdbGridNames(const std::string& path);

}  // namespace mpm
