#pragma once
// Level sets from the user's files: triangle meshes (any format assimp reads: OBJ, PLY, STL, glTF, FBX, ...)
// turned into narrow-band signed distance fields with OpenVDB's mesh-to-volume tools, and level sets read
// from VDB files (Houdini's or Blender's). Errors name the file and what is wrong.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/LevelSet.h"
#include "core/shapes/Placement.h"

namespace mpm {

/// A mesh or VDB file that cannot serve as a level set. what() reads "FILE: problem".
class LevelSetError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Welded triangles: positions and triangle corner indices.
struct TriangleMesh {
    std::vector<Vec3d> points;
    std::vector<Eigen::Vector3i> triangles;
    /// Edges used by exactly one triangle (0 for a closed mesh).
    std::size_t openEdges() const;
    /// The surface's area [m^2 in the points' units].
    double area() const;
    /// The points' axis-aligned box (empty for no points).
    Eigen::AlignedBox3d bounds() const {
        Eigen::AlignedBox3d box;
        for (const Vec3d& p : points) box.extend(p);
        return box;
    }
};

/// Reads every mesh of a file into one, welding corners at equal positions.
TriangleMesh readMesh(const std::string& path);

/// About how many bytes OpenVDB's mesh-to-volume conversion holds for `mesh`'s distance field at `voxelSize`,
/// with a band `bandWidth` [m] wide in all: the leaves of 8^3 voxels along the surface, each voxel with its
/// distance and the conversion's closest-triangle index, and the tree's internal nodes above them. Known before
/// building, so a mesh scaled or placed by mistake is refused with the estimate instead of exhausting memory.
double meshFieldBytes(const TriangleMesh& mesh, double voxelSize, double bandWidth);
/// The same for a surface of `area` [m^2] whose box has sides `size` [m].
double surfaceFieldBytes(double area, const Vec3d& size, double voxelSize, double bandWidth);

/// A closed mesh as a solid (thickness 0), or any mesh as a shell of half-thickness `thickness` around its
/// surface. The band reaches `exteriorBand` outside the surface and `interiorBand` inside [m]; `reach` is the
/// LevelSet's (how far from the band a point still needs the field).
std::shared_ptr<const LevelSet> meshLevelSet(const TriangleMesh& mesh, const std::string& path, double voxelSize,
                                             double thickness, double exteriorBand, double interiorBand, double reach);

/// The level set grid `grid` of a VDB file. A grid that is not a level set (a fog volume) is an error naming
/// its class; a grid with a rotated or non-uniform transform is resampled onto an axis-aligned one.
/// With a `placement`, the grid is moved there (its distances scaled with it). A band narrower than `band` [m]
/// on either side of the surface (files made with 3 voxels, Houdini's default, at a voxel under a third of
/// `band`) is grown to that width by OpenVDB's fast sweeping (dilateSdf): deeper, the field is flat and has no normal,
/// and a node or particle there would not be held. 0: the band as the file has it. A grid whose voxel is finer than
/// `finestVoxel` [m] (0: any) and whose band must grow is remade at `finestVoxel` from its surface instead
/// (volumeToMesh, then meshToSignedDistanceField, as a mesh collider is made): growing a band of a few grid cells
/// in voxels far finer than a cell costs as the band's volume in them (the rock of 1 cm voxels at dx 1.04 m: 12e6
/// voxels, 10 s).
/// `remadeFrom`, when given, receives the file's voxel as placed [m] where the field was remade, and 0 where the
/// file's own voxels were kept.
std::shared_ptr<const LevelSet> vdbLevelSet(const std::string& path, const std::string& grid, double reach,
                                            const Placement& placement = {}, double band = 0.0, double finestVoxel = 0.0,
                                            double* remadeFrom = nullptr);

/// About how many bytes grid `grid` of a VDB file takes once read, placed at `scale` and its band grown to `band` [m]
/// on either side (as vdbLevelSet does), known from the grid's metadata without reading its voxels: the memory
/// OpenVDB and Houdini record with each grid (file_mem_bytes), or else the file's size, grown in proportion to the
/// band's width over the file's (taken as the usual 3 voxels, the narrowest a level set is written with); for a grid
/// vdbLevelSet remakes at `finestVoxel`, the file's grid and the remade field's (surfaceFieldBytes, its area from
/// the file's band).
double vdbFieldBytes(const std::string& path, const std::string& grid, double scale, double band, double finestVoxel = 0.0);

/// The volume inside a level set's zero crossing [m^3] (OpenVDB's levelSetVolume).
double insideVolume(const LevelSet& ls);

/// The zero crossing of a level set as a closed triangle mesh in world coordinates (OpenVDB's volumeToMesh, not
/// adaptive: one vertex per surface voxel, its quads cut in two). A surface that runs into the band's edge or out
/// of the grid's active voxels comes out open (TriangleMesh::openEdges).
TriangleMesh levelSetSurface(const LevelSet& ls);

/// The mesh moved by a placement.
TriangleMesh placed(TriangleMesh mesh, const Placement& placement);

/// The vector grid `grid` of a VDB file (a velocity field).
std::shared_ptr<const VectorField> vdbVectorField(const std::string& path, const std::string& grid);

/// The float grid `grid` of a VDB file sampled trilinearly at world points (a level set or a fog volume; where
/// the grid has no active value, its background).
std::vector<double> vdbScalarSamples(const std::string& path, const std::string& grid, const std::vector<Vec3d>& points);

/// The frames of a sequence pattern ("wall_$F4.vdb"): the file of frame f, and the frames that exist.
std::string sequenceFile(const std::string& pattern, int frame);
std::vector<int> sequenceFrames(const std::string& pattern);

}  // namespace mpm
