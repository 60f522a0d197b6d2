#pragma once
// Shapes the user brings as files, resolved into level sets when a scene is built (io/LevelSets.h): a triangle
// mesh (any format assimp reads) and a level set grid of a VDB file. Paths are relative to the scene file.
#include <string>

#include "materials/Parameters.h"

namespace mpm {

struct MeshShape {
    static constexpr const char* kType = "mesh";
    std::string file;
    double voxelSize = 0.0;  ///< of the distance field; 0: half the grid spacing
    double thickness = 0.0;  ///< > 0: a shell of this half-thickness around the surface (open meshes need one)

    template <class V>
    static void keys(V& v, MeshShape& s) {
        v.text(Key{.name = "file", .help = "triangle mesh (OBJ, PLY, STL, glTF, FBX, ...), relative to the scene file", .required = true},
               s.file);
        v.number(Key{.name = "voxel_size", .help = "voxel of its distance field; 0: dx / 2", .lo = 0.0, .hi = kHuge, .unit = "m"},
                 s.voxelSize);
        v.number(Key{.name = "thickness",
                     .help = "0: a closed mesh, solid inside; > 0: a shell of this half-thickness around the surface (needed for "
                             "an open mesh such as a terrain or a sheet)",
                     .lo = 0.0, .hi = kHuge, .unit = "m"},
                 s.thickness);
        v.check(!s.file.empty(), "file", "must name a mesh file");
    }
};

struct VdbShape {
    static constexpr const char* kType = "vdb";
    std::string file;
    std::string grid = "surface";

    template <class V>
    static void keys(V& v, VdbShape& s) {
        v.text(Key{.name = "file", .help = "VDB file holding a level set, relative to the scene file", .required = true}, s.file);
        v.text(Key{.name = "grid", .help = "name of the level set grid in it"}, s.grid);
        v.check(!s.file.empty(), "file", "must name a VDB file");
    }
};

}  // namespace mpm
