#pragma once
// Shapes the user brings as files, resolved into level sets when a scene is built (io/LevelSets.h): a triangle
// mesh (any format assimp reads) and a level set grid of a VDB file. Paths are relative to the scene file. As
// colliders they are solids (or containers); as particle sets, their inside is filled.
#include <string>

#include "base/Parameters.h"
#include "core/shapes/Placement.h"

namespace mpm {

struct MeshShape {
    static constexpr const char* kType = "mesh";
    /// A closed mesh can be a rigid body: its mass properties come from its triangles once read (core/shapes/Polyhedron.h).
    static constexpr bool kBodyFromFile = true;
    std::string file;
    double voxelSize = 0.0;  ///< of the distance field; 0: chosen by the builder (io/SceneBuilder.cpp, meshField)
    double thickness = 0.0;  ///< > 0: a shell of this half-thickness around the surface (open meshes need one)
    Placement transform;     ///< from the file's coordinates to the scene's

    template <class V>
    static void keys(V& v, MeshShape& s) {
        v.text(Key{.name = "file",
                   .help = "triangle mesh (OBJ, PLY, STL, glTF, FBX, ...), relative to the scene file",
                   .required = true},
               s.file);
        v.number(
            Key{.name = "voxel_size",
                .help = "voxel of its distance field; 0: for a collider dx / 2, or finer (to dx / 8) so that its thinnest wall "
                        "is two voxels thick (`mpm validate` warns of walls thinner than the field resolves), stated in the "
                        "resolved scene; "
                        "for a set dx / 2",
                .lo = 0.0,
                .hi = kHuge,
                .unit = "m"},
            s.voxelSize);
        v.number(Key{.name = "thickness",
                     .help = "0: a closed mesh, solid inside; > 0: a shell of this half-thickness around the surface (needed for "
                             "an open mesh such as a terrain or a sheet)",
                     .lo = 0.0,
                     .hi = kHuge,
                     .unit = "m"},
                 s.thickness);
        v.object(Key{.name = "transform", .help = "places the file: translate, rotate, scale"},
                 [&](auto& t) { Placement::keys(t, s.transform); });
        v.check(!s.file.empty(), "file", "must name a mesh file");
    }
};

struct VdbShape {
    static constexpr const char* kType = "vdb";
    /// A level set (not a $F sequence) can be a rigid body: its mass properties come from its zero crossing meshed
    /// (io/LevelSets.h, levelSetSurface).
    static constexpr bool kBodyFromFile = true;
    std::string file;
    std::string grid = "surface";
    std::string velocityGrid;  ///< of a sequence: the surface's velocity; empty: from the change of the level set
    Placement transform;       ///< from the file's coordinates to the scene's

    template <class V>
    static void keys(V& v, VdbShape& s) {
        v.text(
            Key{.name = "file",
                .help = "VDB file holding a level set, relative to the scene file; a collider's may hold $F (or $F4, padded to 4 "
                        "digits): a sequence, one file per frame, interpolated in time (a deforming collider; a set's "
                        "shape is one file)",
                .required = true},
            s.file);
        v.text(Key{.name = "grid", .help = "name of the level set grid in it"}, s.grid);
        v.text(Key{.name = "velocity_grid",
                   .help = "a collider sequence's velocity grid (Houdini's `vel`); empty: the velocity the level sets' change "
                           "implies. A set's shape takes none"},
               s.velocityGrid);
        v.object(Key{.name = "transform", .help = "places the file: translate, rotate, scale"},
                 [&](auto& t) { Placement::keys(t, s.transform); });
        v.check(!s.file.empty(), "file", "must name a VDB file");
    }
};

/// A point cloud (PLY): each point becomes one particle, with the file's velocities, radii, masses and densities
/// when it has them.
struct PointsShape {
    static constexpr const char* kType = "points";
    std::string file;
    Placement transform;  ///< from the file's coordinates to the scene's (velocities turn with it)

    template <class V>
    static void keys(V& v, PointsShape& s) {
        v.text(
            Key{.name = "file",
                .help =
                    "PLY point cloud (ASCII or binary), relative to the scene file: x, y, z; when present vx, vy, vz (or v.x, "
                    "...), pscale (the point's volume is (2 pscale)^3), mass or density (per point, instead of the material's)",
                .required = true},
            s.file);
        v.object(Key{.name = "transform", .help = "places the file: translate, rotate, scale"},
                 [&](auto& t) { Placement::keys(t, s.transform); });
        v.check(!s.file.empty(), "file", "must name a PLY file");
    }
};

}  // namespace mpm
