#include "io/LevelSets.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <openvdb/tools/FastSweeping.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetMeasure.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tools/ValueTransformer.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>
#include <unordered_map>

#include "core/LevelSetGrid.h"

namespace mpm {

namespace {
std::string gridClassName(openvdb::GridClass c) { return openvdb::GridBase::gridClassToString(c); }
}  // namespace

std::size_t TriangleMesh::openEdges() const {
    std::map<std::pair<int, int>, int> uses;
    for (const Eigen::Vector3i& t : triangles)
        for (int e = 0; e < 3; ++e) {
            const int a = t[e], b = t[(e + 1) % 3];
            ++uses[{std::min(a, b), std::max(a, b)}];
        }
    std::size_t open = 0;
    for (const auto& [edge, n] : uses) open += n == 1;
    return open;
}

TriangleMesh readMesh(const std::string& path) {
    if (!std::filesystem::is_regular_file(path)) throw LevelSetError(path + ": no such mesh file");
    Assimp::Importer importer;
    // Positions only: normals, UVs and materials would keep equal corners apart.
    importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_NORMALS | aiComponent_TEXCOORDS | aiComponent_COLORS |
                                                            aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_MATERIALS);
    const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_RemoveComponent |
                                                       aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices);
    if (!scene || !scene->mRootNode) throw LevelSetError(path + ": cannot read the mesh: " + importer.GetErrorString());
    TriangleMesh mesh;
    std::unordered_map<std::string, int> index;  // welds corners of different sub-meshes at one position
    auto weld = [&](const aiVector3D& v) {
        const Vec3d p(v.x, v.y, v.z);
        const std::string key(reinterpret_cast<const char*>(p.data()), sizeof(double) * 3);
        const auto [it, added] = index.emplace(key, int(mesh.points.size()));
        if (added) mesh.points.push_back(p);
        return it->second;
    };
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh* am = scene->mMeshes[m];
        for (unsigned f = 0; f < am->mNumFaces; ++f) {
            const aiFace& face = am->mFaces[f];
            if (face.mNumIndices != 3) continue;  // points and lines of a mesh file carry no surface
            mesh.triangles.emplace_back(weld(am->mVertices[face.mIndices[0]]), weld(am->mVertices[face.mIndices[1]]),
                                        weld(am->mVertices[face.mIndices[2]]));
        }
    }
    if (mesh.triangles.empty()) throw LevelSetError(path + ": the file holds no triangles");
    return mesh;
}

double TriangleMesh::area() const {
    double sum = 0.0;
    for (const Eigen::Vector3i& t : triangles)
        sum += 0.5 * (points[t[1]] - points[t[0]]).cross(points[t[2]] - points[t[0]]).norm();
    return sum;
}

double meshFieldBytes(const TriangleMesh& mesh, double voxelSize, double bandWidth) {
    return surfaceFieldBytes(mesh.area(), mesh.points.empty() ? Vec3d::Zero() : Vec3d(mesh.bounds().sizes()), voxelSize,
                             bandWidth);
}

double surfaceFieldBytes(double area, const Vec3d& size, double voxelSize, double bandWidth) {
    // Nodes of a tree level whose nodes span `dim` voxels: a band crosses about band / span + 1 of them, each
    // straddling the surface; and an object astride their boundaries takes up to 8 however small it is.
    // The band's volume by Steiner's formula for a body grown by r = bandWidth / 2 on each side: area times the
    // width, plus the edges' and corners' terms (pi r^2 along the mesh's diagonal, 4/3 pi r^3), which dominate when
    // the band is wide against the mesh (a shell 1 m thick round a 40 cm blade: ten times the area term); at most
    // the mesh's box grown by the band.
    const double r = 0.5 * bandWidth;
    const double grownBox = (size.array() + bandWidth).prod();
    const double band = std::min(grownBox, area * bandWidth + M_PI * r * r * size.norm() + 4.0 / 3.0 * M_PI * r * r * r);
    const auto nodes = [&](double dim, double atLeast) {
        const double span = dim * voxelSize;
        return std::max(atLeast, band / (span * span * span) + 2.0 * area / (span * span));
    };
    using Leaf = openvdb::FloatTree::LeafNodeType;
    using Upper = openvdb::FloatTree::RootNodeType::ChildNodeType;
    using Lower = Upper::ChildNodeType;
    constexpr double kCorners = 8.0;
    // Each voxel of the leaves holds its distance and, while the conversion runs, its closest triangle's index.
    constexpr double kBytesPerVoxel = sizeof(float) + sizeof(int32_t);
    // The conversion's working copies on top: the peak memory of building a field measured 1.32 (the rock mesh scaled
    // 50x, 3.4 GiB held) and 1.45 (at a voxel of 1 mm, 0.6 GiB) times what the voxels and nodes hold.
    constexpr double kConversionPeak = 1.5;
    return kConversionPeak * (nodes(Leaf::DIM, 1.0) * double(Leaf::NUM_VOXELS) * kBytesPerVoxel +
                              nodes(Lower::DIM, kCorners) * sizeof(Lower) + nodes(Upper::DIM, kCorners) * sizeof(Upper));
}

std::shared_ptr<const LevelSet> meshLevelSet(const TriangleMesh& mesh, const std::string& path, double voxelSize,
                                             double thickness, double exteriorBand, double interiorBand, double reach) {
    const std::size_t open = mesh.openEdges();
    if (open > 0 && thickness <= 0.0)
        throw LevelSetError(path + ": the mesh is open (" + std::to_string(open) +
                            " edges belong to one triangle only); give it a \"thickness\" to make a shell of it, or close it");
    const auto xform = openvdb::math::Transform::createLinearTransform(voxelSize);
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    points.reserve(mesh.points.size());
    for (const Vec3d& p : mesh.points) points.emplace_back(float(p[0]), float(p[1]), float(p[2]));  // world space
    for (const Eigen::Vector3i& t : mesh.triangles) triangles.emplace_back(t[0], t[1], t[2]);
    const float ex = float(std::max(3.0, exteriorBand / voxelSize)), in = float(std::max(3.0, interiorBand / voxelSize));
    openvdb::FloatGrid::Ptr grid;
    if (thickness <= 0.0) {
        grid = openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(*xform, points, triangles, quads, ex, in);
    } else {
        // A shell: the unsigned distance less the half-thickness is negative inside the shell.
        const float shell = float(thickness / voxelSize);
        grid = openvdb::tools::meshToUnsignedDistanceField<openvdb::FloatGrid>(*xform, points, triangles, quads, ex + shell);
        const float offset = float(thickness);
        for (auto it = grid->tree().beginValueAll(); it; ++it) it.setValue(*it - offset);
        grid->tree().root().setBackground(grid->background() - offset, true);
    }
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    auto holder = std::make_shared<LevelSet::Grid>();
    holder->grid = grid;
    return std::make_shared<const LevelSet>(holder, reach);
}

namespace {
/// Throws naming the file and the grids it holds, where an open VDB file has no grid `gridName`.
void requireGrid(openvdb::io::File& file, const std::string& path, const std::string& gridName) {
    if (file.hasGrid(gridName)) return;
    // OpenVDB lists an unnamed grid as "[i]", i its place among the unnamed ones: worth saying, or it reads as no name at
    // all.
    std::string names;
    bool unnamed = false;
    for (auto it = file.beginName(); it != file.endName(); ++it) {
        const std::string name = *it;
        names += (names.empty() ? "\"" : ", \"") + name + "\"";
        unnamed = unnamed || (!name.empty() && name.front() == '[');
    }
    throw LevelSetError(path + ": no grid \"" + gridName + "\" (the file holds " + (names.empty() ? "no grids" : names) +
                        (unnamed ? "; \"[0]\" is a grid without a name, and \"grid\": \"[0]\" reads it" : "") + ")");
}

/// The grid `gridName` of a VDB file, whole (`metadataOnly`: its metadata and transform, no voxels); errors name the
/// file and, for a missing grid, the grids it has.
openvdb::GridBase::Ptr readVdbGrid(const std::string& path, const std::string& gridName, bool metadataOnly = false) {
    openvdb::initialize();
    if (!std::filesystem::is_regular_file(path)) throw LevelSetError(path + ": no such VDB file");
    try {
        openvdb::io::File file(path);
        file.open();
        requireGrid(file, path, gridName);
        openvdb::GridBase::Ptr base = metadataOnly ? file.readGridMetadata(gridName) : file.readGrid(gridName);
        file.close();
        return base;
    } catch (const openvdb::Exception& e) {
        throw LevelSetError(path + ": cannot read: " + e.what());
    }
}
}  // namespace

namespace {
/// The fewest voxels a remade field spans an object with along its narrowest side: coarser, a small object (the rock
/// of 0.35 m under a grid of dx 4 m, whose dx/8 is 0.5 m) would be remade at a voxel that holds none of it.
constexpr double kRemadeVoxelsAcross = 8.0;

/// The voxel vdbLevelSet remakes a file's field at (0: none, the file's voxel is kept): finestVoxel, or finer where
/// the object (its box `object` [m], in the file's axes) would span fewer than kRemadeVoxelsAcross of them, and only
/// where that is at least twice the file's voxel.
double remadeVoxel(double fileVoxel, const Vec3d& object, double finestVoxel) {
    const double voxel = std::min(finestVoxel, object.minCoeff() / kRemadeVoxelsAcross);
    // A remake pays where it at least doubles the voxel (an eighth of the voxels to grow the band in); nearer the
    // file's voxel it would round the surface for little gain (at dx/8 = 1.001 file voxels, nothing but rounding).
    constexpr double kCoarserBy = 2.0, kRounding = 1e-6;
    return voxel >= fileVoxel * kCoarserBy * (1.0 - kRounding) ? voxel : 0.0;
}

/// The band a remade field gets on each side: `band`, but no wider than the object and three voxels (inside, no
/// point lies deeper; outside, farther is the background's, as where vdbLevelSet grows a band).
double remadeBand(double band, double voxel, const Vec3d& object) {
    constexpr double kNarrowestBandVoxels = 3.0;
    return std::min(band, kNarrowestBandVoxels * voxel + object.norm());
}

}  // namespace

double vdbFieldBytes(const std::string& path, const std::string& gridName, double scale, double band, double finestVoxel) {
    const openvdb::GridBase::Ptr meta = readVdbGrid(path, gridName, true);
    double bytes = double(std::filesystem::file_size(path));
    if (const auto recorded = meta->getMetadata<openvdb::Int64Metadata>(openvdb::GridBase::META_FILE_MEM_BYTES))
        bytes = double(recorded->value());
    // vdbLevelSet grows the band to `band`, by no more voxels than the object is wide.
    constexpr double kNarrowestBandVoxels = 3.0;
    const double voxel = meta->voxelSize()[0] * scale;
    if (!(voxel > 0.0)) return bytes;
    double widest = std::numeric_limits<double>::infinity();
    const auto lo = meta->getMetadata<openvdb::Vec3IMetadata>(openvdb::GridBase::META_FILE_BBOX_MIN);
    const auto hi = meta->getMetadata<openvdb::Vec3IMetadata>(openvdb::GridBase::META_FILE_BBOX_MAX);
    if (lo && hi) widest = std::max(1.0, openvdb::Vec3d(hi->value() - lo->value()).length());
    const auto count = meta->getMetadata<openvdb::Int64Metadata>(openvdb::GridBase::META_FILE_VOXEL_COUNT);
    if (band > kNarrowestBandVoxels * voxel && lo && hi && count) {
        // The object: the band's box less the band (taken at its usual width) on each side.
        const Vec3d box = voxel * Vec3d(double(hi->value()[0] - lo->value()[0]), double(hi->value()[1] - lo->value()[1]),
                                        double(hi->value()[2] - lo->value()[2]));
        const Vec3d object = (box.array() - 2.0 * kNarrowestBandVoxels * voxel).max(voxel);
        if (const double remade = remadeVoxel(voxel, object, finestVoxel); remade > 0.0) {
            // Remade from its surface: the file's grid and the new field's, for a surface of the area the file's
            // band covers at its usual width.
            const double area = double(count->value()) / (2.0 * kNarrowestBandVoxels) * voxel * voxel;
            return bytes + surfaceFieldBytes(area, object, remade, 2.0 * remadeBand(band, remade, object));
        }
    }
    const double grownVoxels = std::min(band / voxel, kNarrowestBandVoxels + widest);
    return bytes * std::max(1.0, grownVoxels / kNarrowestBandVoxels);
}

namespace {
/// The level set `in` (its transform turned) sampled trilinearly at the voxels of an axis-aligned grid of `voxel`
/// [m] that lie within one voxel of its band. OpenVDB's resampleToMatch would rebuild a level set through a mesh,
/// whose faces cut inside a convex surface (a ball of 10 voxels lost 1.2% of its volume, its surface 1e-3 m).
openvdb::FloatGrid::Ptr resampledAxisAligned(const openvdb::FloatGrid& in, double voxel) {
    const float background = in.background();
    auto out = openvdb::FloatGrid::create(background);
    out->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    out->setGridClass(openvdb::GRID_LEVEL_SET);
    // The output voxels nearest the band's, grown by one so that the turned lattice leaves no gap.
    openvdb::MaskGrid mask(false);
    for (auto it = in.cbeginValueOn(); it; ++it)
        mask.tree().setValueOn(out->transform().worldToIndexCellCentered(in.indexToWorld(it.getCoord())));
    openvdb::tools::dilateActiveValues(mask.tree(), 1, openvdb::tools::NN_FACE_EDGE_VERTEX, openvdb::tools::IGNORE_TILES);
    out->tree().topologyUnion(mask.tree());
    // The grid sampler reads the tree without an accessor's cache, so the threads share it.
    const openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(in);
    const openvdb::math::Transform& placed = out->transform();
    openvdb::tools::foreach (out->beginValueOn(), [&](const openvdb::FloatGrid::ValueOnIter& v) {
        v.setValue(std::clamp(sampler.wsSample(placed.indexToWorld(v.getCoord())), -background, background));
    });
    openvdb::tools::pruneLevelSet(out->tree());
    openvdb::tools::signedFloodFill(out->tree());
    return out;
}

/// The level set `in` remade at `voxel` [m] through its zero crossing (volumeToMesh, not adaptive), with a band
/// `band` [m] wide on each side. The surface is taken about the band's middle, so that its float points keep their
/// precision far from the origin.
openvdb::FloatGrid::Ptr remadeAtVoxel(const openvdb::FloatGrid& in, double voxel, double band) {
    const openvdb::CoordBBox box = in.evalActiveVoxelBoundingBox();
    const openvdb::Vec3d middle = in.indexToWorld(0.5 * (box.min().asVec3d() + box.max().asVec3d()));
    auto local = in.transform().copy();
    local->postTranslate(-middle);
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*in.copyReplacingTransform(local), points, triangles, quads, 0.0);
    auto xform = openvdb::math::Transform::createLinearTransform(voxel);
    xform->postTranslate(-middle);
    // The points are in the local frame, which this transform maps onto index space as the world's voxels of
    // `voxel` would be: the field made is the world's, on the lattice through the origin.
    const float width = float(std::max(3.0, band / voxel));
    openvdb::FloatGrid::Ptr out =
        openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(*xform, points, triangles, quads, width, width);
    out->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    out->setGridClass(openvdb::GRID_LEVEL_SET);
    return out;
}

std::shared_ptr<const LevelSet> placedVdbLevelSet(const std::string& path, const std::string& gridName, double reach,
                                                  const Placement& placement, double band, double finestVoxel,
                                                  double* remadeFrom) {
    const openvdb::GridBase::Ptr base = readVdbGrid(path, gridName);
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid)
        throw LevelSetError(path + ": grid \"" + gridName + "\" holds " + base->valueType() +
                            " values; a level set holds floats");
    if (grid->getGridClass() != openvdb::GRID_LEVEL_SET)
        throw LevelSetError(path + ": grid \"" + gridName + "\" is a " + gridClassName(grid->getGridClass()) +
                            ", not a level set; a collider needs a signed distance field (Houdini: VDB from Polygons, distance)");
    // The object's box in the file's own axes, at the placement's scale: the size a remade voxel is chosen by, the
    // same however the object is turned (and as vdbFieldBytes reads it from the file's metadata).
    Vec3d fileLo, fileHi;
    insideBoundsOf(*grid, fileLo, fileHi);
    const double fileVoxelPlaced = grid->voxelSize()[0] * placement.scale;
    const Vec3d object =
        fileLo[0] <= fileHi[0] ? Vec3d(placement.scale * (fileHi - fileLo) + Vec3d::Constant(fileVoxelPlaced)) : Vec3d::Zero();
    if (!placement.identity()) {
        // Distances scale with the grid; the index-to-world map gains the placement (OpenVDB's maps act on row
        // vectors, so the rotation enters transposed).
        const float s = float(placement.scale);
        for (auto it = grid->tree().beginValueAll(); it; ++it) it.setValue(*it * s);
        grid->tree().root().setBackground(grid->background() * s, true);
        const Mat3d R = placement.rotate.matrix();
        openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) m(i, j) = placement.scale * R(j, i);
        m.setTranslation(openvdb::Vec3d(placement.translate[0], placement.translate[1], placement.translate[2]));
        grid->transform().postMult(m);
    }
    const openvdb::math::Transform& t = grid->transform();
    const openvdb::Vec3d vs = grid->voxelSize();
    const bool aligned = t.isLinear() && t.hasUniformScale() &&
                         t.baseMap()->getAffineMap()->getMat4().getMat3().eq(openvdb::math::Mat3d::identity() * vs[0], 1e-9);
    if (!aligned) {
        // Resample onto an axis-aligned grid of the same voxel size, so that sampling needs no rotation.
        grid = resampledAxisAligned(*grid, vs[0]);
    }
    // The background is the band's half width in world units (a level set's convention), stored as a float.
    constexpr double kFloatRounding = 1e-6;
    const bool narrow = double(grid->background()) < band * (1.0 - kFloatRounding);
    const double remade = narrow ? remadeVoxel(vs[0], object, finestVoxel) : 0.0;
    if (remadeFrom) *remadeFrom = remade > 0.0 ? vs[0] : 0.0;
    Vec3d insideLo, insideHi;  // the placed file's box of inside voxels, kept by a remade field
    if (remade > 0.0) {
        insideBoundsOf(*grid, insideLo, insideHi);
        grid = remadeAtVoxel(*grid, remade, remadeBand(band, remade, object));
    } else if (narrow) {
        // Extend the band by solving |grad phi| = 1 outward from it (fast sweeping), which keeps the values the file
        // has; a rebuild through a mesh would move them and break the field's symmetries.
        // No deeper than the object is wide: inside, no point lies deeper; outside, a band wider than the object is
        // all background's business (a scene of dx 1e6 m asked for 3e8 voxels here, and OpenVDB stalled making them).
        const openvdb::CoordBBox extent = grid->evalActiveVoxelBoundingBox();
        const double widest = double(extent.dim().asVec3d().length());
        const int grow = int(std::min(std::ceil((band - double(grid->background())) / vs[0]), std::max(widest, 1.0)));
        grid = openvdb::tools::dilateSdf(*grid, grow, openvdb::tools::NN_FACE_EDGE_VERTEX);
        grid->setGridClass(openvdb::GRID_LEVEL_SET);
    }
    auto holder = std::make_shared<LevelSet::Grid>();
    holder->grid = grid;
    auto ls = std::make_shared<LevelSet>(holder, reach);
    if (remade > 0.0) ls->keepInsideBounds(insideLo, insideHi);
    return ls;
}
}  // namespace

std::shared_ptr<const LevelSet> vdbLevelSet(const std::string& path, const std::string& gridName, double reach,
                                            const Placement& placement, double band, double finestVoxel, double* remadeFrom) {
    try {
        return placedVdbLevelSet(path, gridName, reach, placement, band, finestVoxel, remadeFrom);
    } catch (const openvdb::Exception& e) {
        // A placement OpenVDB cannot represent: a scale that makes the voxel too small for its maps, for one.
        std::ostringstream what;
        what << path << ": cannot place grid \"" << gridName << "\" at transform.scale " << placement.scale << ": " << e.what()
             << "; use a larger scale, or resample the grid to the size wanted before saving it";
        throw LevelSetError(what.str());
    }
}

double insideVolume(const LevelSet& ls) { return openvdb::tools::levelSetVolume(*ls.grid().grid); }

/// Newton steps that put a surface vertex on the field's zero crossing: the first leaves an error of the order of
/// the voxel's curvature term, the second squares it.
constexpr int kSurfaceNewtonSteps = 2;

TriangleMesh levelSetSurface(const LevelSet& ls) {
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    // volumeToMesh writes float points: taken about the band's middle, they keep their precision far from the origin.
    Vec3d lo, hi;
    ls.bounds(lo, hi);
    const Vec3d middle = 0.5 * (lo + hi);
    auto local = ls.grid().grid->transform().copy();
    local->postTranslate(openvdb::Vec3d(-middle[0], -middle[1], -middle[2]));
    openvdb::tools::volumeToMesh(*ls.grid().grid->copyReplacingTransform(local), points, triangles, quads, 0.0);
    TriangleMesh mesh;
    mesh.points.reserve(points.size());
    // Each vertex is moved onto the zero crossing of the field the collider samples (trilinear), by Newton steps
    // along its gradient: volumeToMesh puts it at the mean of its cell's edge crossings, inside a convex surface.
    LevelSet::Sampler field(ls);
    for (const openvdb::Vec3s& q : points) {
        Vec3d p = middle + Vec3d(q[0], q[1], q[2]);
        for (int step = 0; step < kSurfaceNewtonSteps; ++step) {
            double phi;
            Vec3d gradient;
            field.phiAndGradient(p, phi, gradient);
            if (gradient.squaredNorm() > 0.0) p -= phi * gradient / gradient.squaredNorm();
        }
        mesh.points.push_back(p);
    }
    mesh.triangles.reserve(triangles.size() + 2 * quads.size());
    for (const openvdb::Vec3I& t : triangles) mesh.triangles.emplace_back(int(t[0]), int(t[1]), int(t[2]));
    for (const openvdb::Vec4I& q : quads) {
        mesh.triangles.emplace_back(int(q[0]), int(q[1]), int(q[2]));
        mesh.triangles.emplace_back(int(q[0]), int(q[2]), int(q[3]));
    }
    return mesh;
}

TriangleMesh placed(TriangleMesh mesh, const Placement& placement) {
    if (!placement.identity())
        for (Vec3d& p : mesh.points) p = placement.apply(p);
    return mesh;
}

std::shared_ptr<const VectorField> vdbVectorField(const std::string& path, const std::string& gridName) {
    const openvdb::GridBase::Ptr base = readVdbGrid(path, gridName);
    auto grid = openvdb::gridPtrCast<openvdb::Vec3SGrid>(base);
    if (!grid)
        throw LevelSetError(path + ": grid \"" + gridName + "\" holds " + base->valueType() +
                            " values; a velocity grid holds vec3s");
    auto holder = std::make_shared<VectorField::Grid>();
    holder->grid = grid;
    return std::make_shared<const VectorField>(holder);
}

std::vector<double> vdbScalarSamples(const std::string& path, const std::string& gridName, const std::vector<Vec3d>& points) {
    const openvdb::GridBase::Ptr base = readVdbGrid(path, gridName);
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid)
        throw LevelSetError(path + ": grid \"" + gridName + "\" holds " + base->valueType() +
                            " values; a scalar field holds floats");
    const openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sample(*grid);
    std::vector<double> out(points.size());
    for (std::size_t p = 0; p < points.size(); ++p)
        out[p] = double(sample.wsSample(openvdb::Vec3d(points[p][0], points[p][1], points[p][2])));
    return out;
}

namespace {
/// The pattern split around its $F or $Fn, and n (0: no padding).
struct Pattern {
    std::string before, after;
    int digits = 0;
};
Pattern splitPattern(const std::string& pattern) {
    const std::size_t at = pattern.find("$F");
    if (at == std::string::npos) throw LevelSetError(pattern + ": not a sequence (no $F)");
    Pattern p;
    std::size_t end = at + 2;
    while (end < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[end]))) ++end;
    p.digits = end > at + 2 ? std::stoi(pattern.substr(at + 2, end - at - 2)) : 0;
    p.before = pattern.substr(0, at);
    p.after = pattern.substr(end);
    return p;
}
}  // namespace

std::string sequenceFile(const std::string& pattern, int frame) {
    const Pattern p = splitPattern(pattern);
    std::string n = std::to_string(frame);
    if (int(n.size()) < p.digits) n = std::string(std::size_t(p.digits) - n.size(), '0') + n;
    return p.before + n + p.after;
}

std::vector<int> sequenceFrames(const std::string& pattern) {
    const Pattern p = splitPattern(pattern);
    const std::filesystem::path dir = std::filesystem::path(p.before).parent_path();
    const std::string prefix = std::filesystem::path(p.before).filename().string();
    std::vector<int> frames;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir.empty() ? "." : dir, ec)) {
        const std::string name = e.path().filename().string();
        if (name.size() <= prefix.size() + p.after.size() || name.compare(0, prefix.size(), prefix) != 0 ||
            name.compare(name.size() - p.after.size(), p.after.size(), p.after) != 0)
            continue;
        const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - p.after.size());
        if (digits.empty() ||
            !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
            continue;
        frames.push_back(std::stoi(digits));
    }
    std::sort(frames.begin(), frames.end());
    if (frames.empty()) throw LevelSetError(pattern + ": no file of the sequence exists");
    return frames;
}

}  // namespace mpm
