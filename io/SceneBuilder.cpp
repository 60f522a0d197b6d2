#include "io/SceneBuilder.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "core/Colliders.h"
#include "core/ExactSum.h"
#include "core/LevelSetGeometry.h"
#include "core/LevelSetSequence.h"
#include "core/shapes/Polyhedron.h"
#include "io/LevelSets.h"
#include "io/MaterialFields.h"
#include "io/MeshThickness.h"
#include "io/PointFile.h"
#include "io/Sampling.h"
#include "io/SceneBudget.h"
#include "io/SceneKeys.h"

namespace mpm {

std::string besideScene(const SceneDesc& scene, const std::string& file) {
    const std::filesystem::path p(file);
    return p.is_absolute() ? file : (std::filesystem::path(scene.file).parent_path() / p).string();
}

namespace {

/// How deep inside a collider's surface its level set must reach [m]: nodes get mass from particles up to the
/// stencil's half width away, and particles may be a substep's travel inside before the particle pass moves them
/// out; deeper than that no node or particle has business.
constexpr double kInteriorCells = 3.0;
double levelSetBand(double dx) { return kInteriorCells * dx; }

/// The finest voxel the builder picks by itself for a mesh collider [cells]: a mesh with walls thinner than two of
/// these gets a warning from `mpm validate` instead (the field's memory grows as 1 / voxel^2).
constexpr double kFinestAutoVoxelCells = 1.0 / 8.0;
/// A VDB collider's voxel finer than this is remade at it before its band grows (io/LevelSets.h, vdbLevelSet): the
/// voxel a mesh collider takes at the finest.
double finestVdbVoxel(double dx) { return kFinestAutoVoxelCells * dx; }

/// Whether a field of this voxel resolves a wall this thick: two voxels across it, to 1% (a faceted round wall
/// measures thinner at its triangles' centres than at their corners: the example glass's 5 mm wall, 4.997 mm).
bool resolves(double voxel, double wall) {
    constexpr double kWallTolerance = 0.01;
    return wall >= kVoxelsAcrossWall * voxel * (1.0 - kWallTolerance);
}

/// A mesh file's triangles and the voxel of its distance field.
struct MeshField {
    TriangleMesh mesh;
    double voxel = 0.0;   ///< in the mesh's coordinates
    WallThickness wall;   ///< the thinnest wall below two default voxels (a collider's; sets are not measured)
    bool placed = true;   ///< in the scene's coordinates (a collider); else a set's, in its file's
    double metres = 1.0;  ///< per unit of the mesh's coordinates: 1 placed, a set's scale in its file's
};

/// A mesh shape's triangles (placed by its transform for a collider, `place`; in the file's own coordinates for a
/// set) and its voxel: the scene's `voxel_size`, else dx/2 for a set; for a collider dx/2, or finer where its solid
/// (outside the mesh with `solidOutside`) has walls thinner than two voxels resolve, down to kFinestAutoVoxelCells.
MeshField meshField(const SceneDesc& scene, const std::string& where, const MeshShape& m, bool place, bool solidOutside) {
    // In the file's coordinates a scaled shape's cells are dx / scale.
    const double dx = scene.settings.dx / (place ? 1.0 : m.transform.scale), coarse = 0.5 * dx;
    MeshField f;
    try {
        const std::string path = besideScene(scene, m.file);
        f.mesh = place ? placed(readMesh(path), m.transform) : readMesh(path);
    } catch (const LevelSetError& e) {
        throw SceneError(scene.file + ": " + where + "/file: " + e.what());
    }
    // voxel_size is in metres, as every length a scene gives.
    f.placed = place;
    f.metres = place ? 1.0 : m.transform.scale;
    f.voxel = m.voxelSize > 0.0 ? m.voxelSize / f.metres : coarse;
    if (!place) return f;
    // A shell is twice its half-thickness thick everywhere; a solid is measured.
    f.wall = m.thickness > 0.0 ? WallThickness{2.0 * m.thickness, Vec3d::Zero(), -1}
                               : thinnestWall(f.mesh, kVoxelsAcrossWall * std::max(coarse, m.voxelSize), solidOutside);
    if (m.voxelSize <= 0.0 && !resolves(coarse, f.wall.thinnest))
        f.voxel = std::max(f.wall.thinnest / kVoxelsAcrossWall, kFinestAutoVoxelCells * dx);
    return f;
}

/// "FILE: /colliders/i/file: ... walls as thin as ...": a mesh collider whose field's voxel is too coarse for its
/// thinnest wall (material passes through it).
std::string thinWallWarning(const SceneDesc& scene, const std::string& where, const MeshShape& mesh, const MeshField& f) {
    std::ostringstream w;
    w.precision(3);
    w << scene.file << ": " << where << "/file: " << mesh.file << " has walls as thin as " << f.wall.thinnest << " m";
    if (f.wall.triangle >= 0) w << " (at " << f.wall.where[0] << ", " << f.wall.where[1] << ", " << f.wall.where[2] << ")";
    w << "; its distance field's voxel of " << f.voxel << " m"
      << (mesh.voxelSize > 0.0 ? "" : " (the finest picked by itself, dx/8)") << " resolves walls down to "
      << kVoxelsAcrossWall * f.voxel << " m, and material passes through thinner ones: set voxel_size to "
      << f.wall.thinnest / kVoxelsAcrossWall << " or less";
    return w.str();
}

/// "collider i (name): the distance field of FILE ... is remade ...": a VDB collider far finer than the grid, remade from
/// its surface at a coarser voxel, so that a user sees the field that acts is not the file's, and by which rule.
std::string remadeVdbNote(const ColliderEntry& collider, const VdbShape& v, double fileVoxel, double voxel) {
    const double dx = collider.scene.settings.dx, eighth = finestVdbVoxel(dx);
    constexpr double kSameVoxel = 1e-9;  // relative: the voxel is dx/8 up to rounding
    std::ostringstream w;
    w.precision(3);
    w << "collider " << collider.index << " (" << collider.desc().name << "): the distance field of " << v.file << " (voxels of "
      << fileVoxel << " m) is remade from its surface at a voxel of " << voxel << " m, ";
    if (std::abs(voxel - eighth) <= kSameVoxel * eighth)
        w << "dx/8; details smaller than that are rounded (a smaller dx keeps more of them)";
    else
        w << "an eighth of the narrowest side of its box (" << 8.0 * voxel << " m), which dx/8 (" << eighth
          << " m) would not resolve; details smaller than that are rounded (a dx under " << 8.0 * voxel
          << " m keeps more of them)";
    return w.str();
}

/// What building a collider's field found: the centre its motion turns about unless the scene names a pivot, the
/// voxel it chose, and a warning about walls thinner than that voxel resolves (empty: none).
struct FieldNotes {
    Vec3d centre = Vec3d::Zero();
    double voxel = 0.0;
    std::string warning;
    double fileVoxel = 0.0;  ///< a VDB's voxel where its field was remade at `voxel` (0: not remade)
    bool keepMesh = false;   ///< asked for a body: the mesh as placed, which must be closed, for its mass properties
    TriangleMesh mesh;
};

/// How far a mesh's distance field reaches outside and inside its surface [m]: outside past a leaf's half diagonal
/// of the skip test where it can, inside levelSetBand.
struct MeshBand {
    double exterior = 0.0, interior = 0.0;
    /// Across the surface in all, a shell's own thickness included.
    double width(const MeshShape& m) const { return exterior + interior + 2.0 * m.thickness; }
};
MeshBand meshBand(double dx, double voxel) {
    constexpr double kExteriorCells = 2.0, kExteriorVoxels = 3.0;
    return MeshBand{kExteriorCells * dx + kExteriorVoxels * voxel, levelSetBand(dx)};
}

/// A mesh whose vertices lie beyond the grid's coordinate range, or whose distance field would not fit in the memory
/// this process may use (a scale or a unit given by mistake: a 0.1 m part scaled by 1e6), is refused before OpenVDB
/// tries to build the field, naming what to change.
void refuseFieldTooLarge(const SceneDesc& scene, const std::string& where, const MeshShape& m, const MeshField& f, double band) {
    const std::string at = scene.file + ": " + where + "/file: " + m.file;
    for (std::size_t i = 0; i < f.mesh.points.size(); ++i) {
        if (!(f.mesh.points[i].cwiseAbs().maxCoeff() < kMaxGridCoordinate * f.voxel)) {
            // In metres: a set's field is built in its file's coordinates, scaled but not yet turned or moved.
            const Vec3d p = f.metres * f.mesh.points[i];
            const double voxel = f.metres * f.voxel;
            std::ostringstream e;
            e.precision(3);
            e << at << ": a vertex lies at (" << p[0] << ", " << p[1] << ", " << p[2] << ") m once "
              << (f.placed ? "placed" : "scaled") << " (transform.scale " << m.transform.scale
              << "), beyond the distance field's range of +-2^30 voxels (" << kMaxGridCoordinate * voxel << " m at its voxel of "
              << voxel << " m); check the mesh's units and the shape's transform";
            throw SceneError(e.str());
        }
    }
    // OpenVDB builds the field in its worker threads, where running out of memory ends the program (std::terminate)
    // instead of reaching our handler: so the field must also fit what this process may still map (ulimit -v).
    const MemoryLimit limit = memoryLimit();
    const double bytes = meshFieldBytes(f.mesh, f.voxel, band), machine = limit.bytes, mappable = addressSpaceLeft();
    if (bytes > std::min(machine, mappable)) {
        std::ostringstream e;
        e.precision(3);
        e << at << ": its distance field would take about " << bytes / double(1u << 30) << " GiB (a surface of "
          << f.mesh.area() * f.metres * f.metres << " m^2 at a voxel of " << f.voxel * f.metres << " m), and ";
        if (mappable < machine)
            e << "this process may map " << mappable / double(1u << 30) << " GiB more (its address-space limit, ulimit -v)";
        else
            e << limit.holder << " " << machine / double(1u << 30) << " GiB";
        e << "; check the mesh's units and transform.scale (" << m.transform.scale << "), or set a coarser voxel_size";
        throw SceneError(e.str());
    }
}

/// The grid's cell in the coordinates a mesh's field is built in: the world's (placed, a collider), or the file's
/// (a set, sampled there and then placed), where it is dx / scale.
double cellInField(const SceneDesc& scene, const MeshShape& m, bool place) {
    return scene.settings.dx / (place ? 1.0 : m.transform.scale);
}

/// The level set of a file shape, built or read once: placed by its transform (a collider), or in the file's
/// own coordinates (`placed` false: a set, sampled there and then placed).
std::shared_ptr<const LevelSet> levelSetOf(const SceneDesc& scene, const std::string& where, const MeshShape& m,
                                           bool place = true, bool solidOutside = false, FieldNotes* notes = nullptr) {
    const double dx = cellInField(scene, m, place);
    const MeshField f = meshField(scene, where, m, place, solidOutside);
    if (const std::size_t open = notes && notes->keepMesh ? f.mesh.openEdges() : 0; open > 0)
        throw SceneError(scene.file + ": " + where + "/file: " + m.file + ": a rigid body's mesh must be closed (watertight); " +
                         std::to_string(open) + " of its edges border one triangle only");
    if (notes) {
        // The centre of the mesh's own box: exact, where the field's box is rounded to voxels and wider by its band.
        notes->centre = f.mesh.bounds().center();
        notes->voxel = f.voxel;
        if (place && !resolves(f.voxel, f.wall.thinnest)) notes->warning = thinWallWarning(scene, where, m, f);
        if (notes->keepMesh) notes->mesh = f.mesh;
    }
    const MeshBand band = meshBand(dx, f.voxel);
    refuseFieldTooLarge(scene, where, m, f, band.width(m));
    try {
        return meshLevelSet(f.mesh, besideScene(scene, m.file), f.voxel, m.thickness, band.exterior, band.interior,
                            colliderReach(dx));
    } catch (const LevelSetError& e) {
        throw SceneError(scene.file + ": " + where + "/file: " + e.what());
    }
}

std::shared_ptr<const LevelSet> levelSetOf(const SceneDesc& scene, const std::string& where, const VdbShape& v, bool place = true,
                                           bool = false, FieldNotes* notes = nullptr) {
    try {
        double remadeFrom = 0.0;
        auto ls = vdbLevelSet(besideScene(scene, v.file), v.grid, colliderReach(scene.settings.dx),
                              place ? v.transform : Placement{}, place ? levelSetBand(scene.settings.dx) : 0.0,
                              place ? finestVdbVoxel(scene.settings.dx) : 0.0, &remadeFrom);
        if (notes) {
            notes->fileVoxel = remadeFrom;
            // The middle of what is inside: a file's band may be wider on one side than on the other.
            Vec3d lo, hi;
            ls->insideBounds(lo, hi);
            if (!(lo[0] <= hi[0])) ls->bounds(lo, hi);
            notes->centre = 0.5 * (lo + hi);
            notes->voxel = ls->voxelSize();
        }
        return ls;
    } catch (const LevelSetError& e) {
        throw SceneError(scene.file + ": " + where + "/file: " + e.what());
    }
}

/// A point the builder derives to turn things about (a moving collider's centre, a spinning set's centroid), rounded
/// to a decimal step of 1e-4 of dx's decade (a micrometre for dx of 0.01-0.099 m), so that a resolved scene writes it
/// in a few digits (0.055, not 0.05499999999999999 or a mesh's 0.45000001788139343) and reads it back to the same
/// bits; the point moves by at most half a step, 5e-5 dx. A rigid body's pivot is its centre of mass, kept exact: a
/// centre of mass half a micrometre off its geometry's spins two spheres that meet head on (RigidBody tests).
Vec3d derivedPivot(const Vec3d& x, double dx) {
    constexpr int kDigitsBelowDx = 4;
    constexpr double kWholeBelow = 9007199254740992.0;  // 2^53: past it, whole steps are not exact in a double
    const double perMetre = std::pow(10.0, kDigitsBelowDx - std::floor(std::log10(dx)));
    Vec3d out = x;
    for (int a = 0; a < 3; ++a)
        if (const double n = std::round(x[a] * perMetre); std::abs(n) < kWholeBelow) out[a] = n / perMetre;
    return out;
}

Motion motionOf(const MotionDesc& m, const Vec3d& centre, double fps) {
    const Vec3d pivot = m.pivotGiven ? m.pivot : centre;
    if (m.keyframes.empty()) return Motion::constant(m.velocity, m.angularVelocity, pivot);
    std::vector<Motion::Key> keys;
    for (const KeyframeDesc& k : m.keyframes)
        keys.push_back(Motion::Key{k.frame, k.positionGiven ? k.position : pivot, Eigen::Quaterniond(k.rotation.matrix())});
    return Motion::keyframes(std::move(keys), pivot, fps);
}

/// A VDB sequence: a deforming collider whose frames are read as the run reaches them.
std::unique_ptr<Collider> sequenceCollider(const SceneDesc& scene, const std::string& where, const ColliderDesc& c,
                                           const VdbShape& v) {
    if (c.motion.velocity.any() || c.motion.angularVelocity.any() || !c.motion.keyframes.empty())
        throw SceneError(scene.file + ": " + where + "/motion: a sequence moves by its frames; it takes no motion");
    const std::string pattern = besideScene(scene, v.file);
    try {
        const std::vector<int> frames = sequenceFrames(pattern);
        const double reach = colliderReach(scene.settings.dx);
        const double band = levelSetBand(scene.settings.dx), finest = finestVdbVoxel(scene.settings.dx);
        const auto first = vdbLevelSet(sequenceFile(pattern, frames.front()), v.grid, reach, v.transform, band,
                                       finest);  // checked now, not hours later
        if (!v.velocityGrid.empty() && v.transform.rotate.degrees != 0.0)
            throw LevelSetError(pattern +
                                ": a rotated sequence cannot turn its velocity grid; leave out \"rotate\" or \"velocity_grid\"");
        auto load = [pattern, grid = v.grid, vel = v.velocityGrid, reach, placement = v.transform, band, finest](int f) {
            LevelSetFrame frame;
            const std::string file = sequenceFile(pattern, f);
            frame.phi = vdbLevelSet(file, grid, reach, placement, band, finest);
            if (!vel.empty()) frame.velocity = vdbVectorField(file, vel);
            return frame;
        };
        return std::make_unique<RigidCollider<LevelSetSequenceGeometry>>(
            LevelSetSequenceGeometry(load, frames.front(), frames.back(), scene.settings.fps, first->voxelSize()), c.boundary,
            c.friction, Motion(), c.inside);
    } catch (const LevelSetError& e) {
        throw SceneError(scene.file + ": " + where + "/file: " + e.what());
    }
}

/// A collider the material moves: what the simulation integrates, and the frame its motion reads.
struct BodySpec {
    RigidBodyModel model;
    RigidBodyState initial;
    std::shared_ptr<BodyFrame> frame;
};

/// A mesh body touches colliders at its vertices and at points on its faces this many to its largest side: twice a
/// box's (core/shapes/MassProperties.h), a mesh's faces being curved where a box's are flat.
constexpr double kMeshContactSamplesPerSide = 8.0;

/// The rigid body of these mass properties (a shape's closed form, core/shapes/MassProperties.h, or a closed mesh's).
BodySpec bodyOf(const DynamicDesc& d, const MassProperties& props, std::shared_ptr<const Motion> animation) {
    BodySpec b;
    b.model.mass = d.mass > 0.0 ? d.mass : d.density * props.volume;
    b.model.inertia = props.inertia * (b.model.mass / props.volume);
    b.model.restCentre = props.centre;
    b.model.contactPoints = props.contactPoints;
    b.model.contactRadii = props.contactRadii;
    b.model.restitution = d.restitution;
    b.model.rollingResistance = d.rollingResistance;
    for (int a = 0; a < 3; ++a) {
        const char axis = char('x' + a);
        b.model.moveFree[a] = d.lockTranslation.find(axis) == std::string::npos ? 1.0 : 0.0;
        b.model.turnFree[a] = d.lockRotation.find(axis) == std::string::npos ? 1.0 : 0.0;
    }
    if (animation) b.model.animation = std::move(animation), b.model.release = d.animatedUntil;
    b.initial = b.model.animation ? b.model.animated(0.0) : b.model.initial(d.velocity, d.angularVelocity);
    b.frame = std::make_shared<BodyFrame>(b.model.frame(b.initial));
    return b;
}

/// What is worth a word about an animated body: keys that end before its release (it leaves them at rest), or a
/// release after the scene's last frame (it never leaves them).
void animationWarnings(const SceneDesc& scene, const std::string& where, const ColliderDesc& c,
                       std::vector<std::string>& warnings) {
    const double fps = scene.settings.fps, release = c.dynamic.animatedUntil;
    const auto say = [&](const auto&... parts) {
        std::ostringstream w;
        w.precision(4);
        w << scene.file << ": " << where << "/dynamic/animated_until: " << release << " s (frame " << release * fps << ") ";
        (w << ... << parts);
        warnings.push_back(w.str());
    };
    double last = -1.0;
    for (const KeyframeDesc& k : c.motion.keyframes) last = std::max(last, k.frame);
    if (last >= 0.0 && last / fps < release)
        say("is after the motion's last key (frame ", last, ", ", last / fps,
            " s), where it is held: the body leaves its animation at rest");
    if (release >= scene.frames / fps)
        say("is not before the scene's end (frame ", scene.frames, "): the body never leaves its animation");
}

/// A locked axis takes no velocity: what a body's scene gives along one is dropped, with a word.
void lockWarnings(const SceneDesc& scene, const std::string& where, const DynamicDesc& d, const RigidBodyModel& m,
                  std::vector<std::string>& warnings) {
    if (!d.angularVelocity.cwiseProduct(Vec3d::Ones() - m.turnFree).isZero())
        warnings.push_back(scene.file + ": " + where + "/dynamic/angular_velocity: turns about an axis lock_rotation holds (\"" +
                           d.lockRotation + "\"); that part is dropped");
    if (!d.velocity.cwiseProduct(Vec3d::Ones() - m.moveFree).isZero())
        warnings.push_back(scene.file + ": " + where + "/dynamic/velocity: moves along an axis lock_translation holds (\"" +
                           d.lockTranslation + "\"); that part is dropped");
}

/// The collider; `pivot`, if given, receives the pivot its motion turns about (the scene's, or its centre), and
/// `warnings` what is worth a word about its field; `body`, what a dynamic collider is as a rigid body; `report`, a line
/// saying that a VDB's field was remade at a coarser voxel.
std::unique_ptr<Collider> colliderOf(const ColliderEntry& collider, Vec3d* pivot = nullptr,
                                     std::vector<std::string>* warnings = nullptr, double* voxel = nullptr,
                                     std::optional<BodySpec>* body = nullptr, std::vector<std::string>* report = nullptr) {
    const SceneDesc& scene = collider.scene;
    const ColliderDesc& c = collider.desc();
    const auto motion = [&](const Vec3d& centre) {
        const Vec3d turnsAbout = c.dynamic.enabled ? centre : derivedPivot(centre, scene.settings.dx);
        if (pivot) *pivot = c.motion.pivotGiven ? c.motion.pivot : turnsAbout;
        return motionOf(c.motion, turnsAbout, scene.settings.fps);
    };
    const std::string where = collider.path();
    // What building its field found: warnings, the voxel chosen, and the line saying a VDB's field was remade.
    const auto keep = [&](const FieldNotes& notes) {
        if (warnings && !notes.warning.empty()) warnings->push_back(notes.warning);
        if (voxel) *voxel = notes.voxel;
        if (const auto* v = std::get_if<VdbShape>(&c.shape); report && v && notes.fileVoxel > 0.0)
            report->push_back(remadeVdbNote(collider, *v, notes.fileVoxel, notes.voxel));
    };
    if (const auto* v = std::get_if<VdbShape>(&c.shape); v && v->file.find("$F") != std::string::npos && !c.dynamic.enabled)
        return motion(Vec3d::Zero()), sequenceCollider(scene, where, c, *v);
    return std::visit(
        [&]<class S>(const S& shape) -> std::unique_ptr<Collider> {
            if (c.dynamic.enabled) {
                // The body of these mass properties, its collider made by `collider` from the motion that poses it. An
                // animated body's motion turns about its pivot, as a moving collider's (`centre` by default).
                const auto makeBody = [&](const MassProperties& props, const Vec3d& centre,
                                          const auto& collider) -> std::unique_ptr<Collider> {
                    std::shared_ptr<const Motion> animation;
                    if (c.dynamic.animatedUntil > 0.0) {
                        animation = std::make_shared<const Motion>(motion(centre));
                        if (warnings) animationWarnings(scene, where, c, *warnings);
                    }
                    BodySpec spec = bodyOf(c.dynamic, props, animation);
                    if (warnings) lockWarnings(scene, where, c.dynamic, spec.model, *warnings);
                    if (pivot && !animation) *pivot = spec.model.restCentre;
                    auto made = collider(Motion::dynamic(spec.frame, animation));
                    if (body) *body = std::move(spec);
                    return made;
                };
                if constexpr (requires { shape.massProperties(); }) {
                    return makeBody(shape.massProperties(), shape.middle(),
                                    [&](Motion m) { return analyticCollider(shape, c.boundary, c.friction, std::move(m)); });
                } else if constexpr (requires { S::kBodyFromFile; }) {
                    const std::string at = scene.file + ": " + where;
                    FieldNotes notes;
                    std::shared_ptr<const LevelSet> ls;
                    if constexpr (std::is_same_v<S, MeshShape>) {
                        if (shape.thickness > 0.0)
                            throw SceneError(at + "/thickness: a mesh body is a closed solid; leave thickness out");
                        notes.keepMesh = true;
                        ls = levelSetOf(scene, where, shape, true, false, &notes);
                    } else {
                        if (shape.file.find("$F") != std::string::npos)
                            throw SceneError(at + "/file: " + shape.file +
                                             ": a rigid body keeps its shape; a $F sequence of level sets cannot be one");
                        if (!shape.velocityGrid.empty())
                            throw SceneError(at + "/velocity_grid: a rigid body's surface moves with the body; leave it out");
                        ls = levelSetOf(scene, where, shape, true, false, &notes);
                        notes.mesh = levelSetSurface(*ls);
                        if (notes.mesh.triangles.empty())
                            throw SceneError(at + "/file: " + shape.file + ": grid \"" + shape.grid +
                                             "\" has no zero crossing to be a rigid body of");
                        if (const std::size_t open = notes.mesh.openEdges(); open > 0)
                            throw SceneError(at + "/file: " + shape.file + ": grid \"" + shape.grid +
                                             "\" has no closed surface to be a rigid body of (" + std::to_string(open) +
                                             " edges of its zero crossing border one triangle only: the surface runs into the "
                                             "edge of the grid's band or active voxels)");
                    }
                    keep(notes);
                    const MassProperties props =
                        polyhedronMassProperties(notes.mesh.points, notes.mesh.triangles,
                                                 notes.mesh.bounds().sizes().maxCoeff() / kMeshContactSamplesPerSide);
                    if (!(props.volume > 0.0))
                        throw SceneError(at + "/file: " + shape.file + ": the " + S::kType +
                                         " encloses no volume to be a rigid body of");
                    return makeBody(props, notes.centre, [&](Motion m) {
                        return std::make_unique<RigidCollider<LevelSetGeometry>>(LevelSetGeometry{ls}, c.boundary, c.friction,
                                                                                 std::move(m), false);
                    });
                } else {
                    throw SceneError(scene.file + ": " + where + "/dynamic: a " + S::kType +
                                     " collider cannot be a rigid body yet; the shapes that can: " + bodyShapeNames());
                }
            }
            if constexpr (kFromFile<S>) {
                FieldNotes notes;
                const auto ls = levelSetOf(scene, where, shape, true, c.inside, &notes);
                keep(notes);
                return std::make_unique<RigidCollider<LevelSetGeometry>>(LevelSetGeometry{ls}, c.boundary, c.friction,
                                                                         motion(notes.centre), c.inside);
            } else {
                return analyticCollider(shape, c.boundary, c.friction, motion(shape.middle()), c.inside);
            }
        },
        c.shape);
}

/// Where a set's particles go, in the frame they are sampled in, and the placement from there to the scene.
struct SetRegionIn {
    SetRegion region;
    Placement placement;
};

SetRegionIn regionOf(const SetEntry& set) {
    const SceneDesc& scene = set.scene;
    const std::string where = set.path("shape");
    return std::visit(
        [&]<class S>(const S& shape) -> SetRegionIn {
            if constexpr (kFromFile<S>) {
                if constexpr (std::is_same_v<S, VdbShape>) {
                    if (shape.file.find("$F") != std::string::npos)
                        throw SceneError(scene.file + ": " + where +
                                         "/file: a set is filled once; a $F sequence is for colliders");
                    if (!shape.velocityGrid.empty())
                        throw SceneError(scene.file + ": " + where + "/velocity_grid: a set's shape takes no velocity grid");
                }
                const auto ls = levelSetOf(scene, where, shape, false);
                const double volume = insideVolume(*ls);
                if (!(volume > 0.0))
                    throw SceneError(scene.file + ": " + where + "/file: " + besideScene(scene, shape.file) +
                                     ": encloses no volume (an inside-out mesh, or a level set with nothing inside)");
                return {LevelSetInside(ls, volume), shape.transform};
            } else if constexpr (std::is_same_v<S, PointsShape> || kOutlet<S>) {
                throw std::logic_error("regionOf: a point cloud or an outlet is no region");
            } else {
                return {SetRegion(shape), Placement{}};
            }
        },
        set.desc().shape);
}

/// A point cloud set: one particle per point, placed; each fills its pscale's cube (2 pscale a side, the
/// spacing of points made with radius pscale), or without radii the set's particles_per_cell.
SetSamples pointCloudSet(const SetEntry& set, const PointsShape& shape) {
    const SceneDesc& scene = set.scene;
    const ParticleSetDesc& d = set.desc();
    const std::string where = set.path("shape/file");
    PointCloudData cloud;
    std::vector<std::string> columns;
    std::vector<std::size_t> fieldOfColumn;
    for (std::size_t f = 0; f < d.materialFields.size(); ++f)
        if (d.materialFields[f].source == MaterialFieldDesc::Source::Attribute)
            columns.push_back(d.materialFields[f].attribute), fieldOfColumn.push_back(f);
    try {
        cloud = readPlyPoints(besideScene(scene, shape.file), columns);
    } catch (const PointFileMissingProperty& e) {
        throw SceneError(set.at("material_fields/" + std::to_string(fieldOfColumn.at(e.column)) + "/attribute") + ": " +
                         e.what());
    } catch (const PointFileError& e) {
        throw SceneError(scene.file + ": " + where + ": " + e.what());
    }
    if (d.count > 0 && (long long)cloud.x.size() != d.count)
        throw SceneError(set.at("count") + ": a point cloud gives one particle per point (" + std::to_string(cloud.x.size()) +
                         " in " + shape.file + "); leave count out");
    const Placement& t = shape.transform;
    SetSamples out;
    out.positions = std::move(cloud.x);
    out.columns = std::move(cloud.columns);
    for (Vec3d& x : out.positions) x = t.apply(x);
    const Mat3f turn = t.rotate.matrix().cast<float>();
    for (const Vec3f& v : cloud.v) out.velocities.push_back(turn * v);
    const double dx = scene.settings.dx, perCell = dx * dx * dx / d.particlesPerCell;
    if (!cloud.pscale.empty()) {
        for (std::size_t p = 0; p < cloud.pscale.size(); ++p) {
            const float r = cloud.pscale[p];
            if (!(r > 0.0f) || !std::isfinite(r))
                throw SceneError(scene.file + ": " + where + ": " + shape.file + ": point " + std::to_string(p) + " has pscale " +
                                 std::to_string(r) + " (a radius must be positive and finite)");
            out.volumes.push_back(float(std::pow(2.0 * double(r) * t.scale, 3)));
            out.volume += double(out.volumes.back());
        }
    } else {
        out.volume = double(out.positions.size()) * perCell;
    }
    // A point's own mass, or its density times its volume (the set's mass_scale applies to either).
    if (!cloud.mass.empty()) {
        out.masses = std::move(cloud.mass);
    } else if (!cloud.density.empty()) {
        for (std::size_t p = 0; p < cloud.density.size(); ++p)
            out.masses.push_back(cloud.density[p] * (out.volumes.empty() ? float(perCell) : out.volumes[p]));
    }
    for (std::size_t p = 0; p < out.masses.size(); ++p)
        if (!(out.masses[p] > 0.0f) || !std::isfinite(out.masses[p]))
            throw SceneError(scene.file + ": " + where + ": " + shape.file + ": point " + std::to_string(p) + " has mass " +
                             std::to_string(out.masses[p]) + " kg (its mass or density must be positive and finite)");
    return out;
}

}  // namespace

/// The set's shape sampled: positions, a point cloud's velocities, the volume. `region`, when given, is the set's
/// (regionOf), built before.
static SetSamples sampleSetShape(const SetEntry& set, const SamplePart& part, const SetRegionIn* region = nullptr) {
    const SceneDesc& scene = set.scene;
    const ParticleSetDesc& d = set.desc();
    if (const auto* points = std::get_if<PointsShape>(&d.shape)) {
        // A file is read whole; each part keeps its range of points.
        SetSamples all = pointCloudSet(set, *points);
        if (part.parts <= 1) return all;
        const std::pair<std::size_t, std::size_t> range = part.range(all.positions.size());  // captured below: no binding
        const std::size_t begin = range.first, end = range.second;
        auto cut = [&](auto& arr) {
            if (!arr.empty())
                arr = std::decay_t<decltype(arr)>(arr.begin() + std::ptrdiff_t(begin), arr.begin() + std::ptrdiff_t(end));
        };
        cut(all.positions), cut(all.velocities), cut(all.volumes), cut(all.masses);
        for (std::vector<float>& column : all.columns) cut(column);
        return all;
    }
    if (d.continuous || isOutlet(d.shape)) throw std::logic_error("sampleSetShape: a continuous source is a stream (streamOf)");
    const SetRegionIn r = region ? *region : regionOf(set);
    const double s = r.placement.scale;
    // Sampled where the file's cells are dx / scale, then placed: the same particles wherever the asset is put.
    SetSamples out;
    try {
        out.positions = sampleShape(r.region, scene.settings.dx / s, d.particlesPerCell, d.count, d.sampling, d.seed, part);
    } catch (const std::length_error& e) {
        throw SceneError(set.at("shape") + ": " + e.what() + "; split the set into shorter ones");
    } catch (const std::domain_error& e) {  // an exact count the shape cannot hold
        throw SceneError(set.at("shape") + ": " + e.what());
    }
    if (!r.placement.identity())
        for (Vec3d& x : out.positions) x = r.placement.apply(x);
    out.volume = shapeVolume(r.region) * s * s * s;
    return out;
}

/// The set's initial velocities beyond its constant one: a rigid spin about the pivot, and a VDB field.
static void addInitialVelocities(const SetEntry& set, SetSamples& out, const Comm& comm) {
    const ParticleSetDesc& d = set.desc();
    if (d.angularVelocity.isZero() && d.velocityFile.empty()) return;
    const std::size_t n = out.positions.size();
    if (out.velocities.empty()) out.velocities.assign(n, Vec3f::Zero());
    if (!d.angularVelocity.isZero()) {
        Vec3d pivot = d.pivot;
        if (!d.pivotGiven) {
            // The centre of every rank's samples: exact sums, the same bits however the set is split.
            ExactSum sum[3];
            for (const Vec3d& x : out.positions)
                for (int a = 0; a < 3; ++a) sum[a].add(x[a]);
            const long long all = comm.sum((long long)n);
            for (int a = 0; a < 3; ++a) {
                comm.sum(sum[a]);
                pivot[a] = sum[a].value() / double(std::max(all, 1LL));
            }
            pivot = derivedPivot(pivot, set.scene.settings.dx);
        }
        for (std::size_t p = 0; p < n; ++p) out.velocities[p] += d.angularVelocity.cross(out.positions[p] - pivot).cast<float>();
        out.pivot = pivot;
    }
    if (!d.velocityFile.empty()) {
        const std::string path = besideScene(set.scene, d.velocityFile);
        try {
            const auto field = vdbVectorField(path, d.velocityGrid);
            VectorField::Sampler sample(*field);
            for (std::size_t p = 0; p < n; ++p) out.velocities[p] += sample.value(out.positions[p]).cast<float>();
        } catch (const LevelSetError& e) {
            throw SceneError(set.at("velocity_field/file") + ": " + e.what());
        }
    }
}

SetSamples sampleSet(const SetEntry& set, const Comm& comm, const std::atomic<int>* stop) {
    SetSamples out = sampleSetShape(set, SamplePart{comm.rank(), comm.size(), stop});
    addInitialVelocities(set, out, comm);
    return out;
}

/// setExtent of a set whose region is built.
static void regionExtent(const SetRegionIn& r, double& volume, Vec3d& lo, Vec3d& hi) {
    const double s = r.placement.scale;
    volume = shapeVolume(r.region) * s * s * s;
    Vec3d a, b;
    std::visit([&](const auto& shape) { shape.bounds(a, b); }, r.region);
    lo = Vec3d::Constant(INFINITY), hi = Vec3d::Constant(-INFINITY);
    for (int c = 0; c < 8; ++c) {
        const Vec3d corner((c & 1) ? b[0] : a[0], (c & 2) ? b[1] : a[1], (c & 4) ? b[2] : a[2]);
        const Vec3d x = r.placement.apply(corner);
        lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
    }
}

struct SetCache::Impl {
    const SetCache& owner;
    const SceneDesc& scene;
    std::vector<std::optional<SetRegionIn>> regions;
    std::vector<std::optional<SetSamples>> samples;
    double keptBytes = 0.0;
    std::size_t built = 0;  ///< file sets' fields

    /// Set i's region: the one kept, or built (and kept while the fields kept stay under kKeptFieldBytes).
    SetRegionIn region(std::size_t i) {
        if (regions[i]) return *regions[i];
        const SetEntry set(scene, i);
        std::visit(
            [&]<class S>(const S& shape) {
                if constexpr (kFromFile<S>) {
                    owner.note("building the distance field of set " + std::to_string(i) + " '" + set.desc().name + "' from " +
                               shape.file);
                    ++built;
                }
            },
            set.desc().shape);
        SetRegionIn r = regionOf(set);
        const double bytes = setFieldBytes(set);
        if (keptBytes + bytes <= kKeptFieldBytes) regions[i] = r, keptBytes += bytes;
        return r;
    }
};

SetCache::SetCache(const SceneDesc& scene) : impl_(new Impl{*this, scene, {}, {}}) {
    impl_->regions.resize(scene.sets.size());
    impl_->samples.resize(scene.sets.size());
}
SetCache::~SetCache() = default;

const SceneDesc& SetCache::scene() const { return impl_->scene; }
std::size_t SetCache::fieldsBuilt() const { return impl_->built; }

void SetCache::extent(std::size_t i, double& volume, Vec3d& lo, Vec3d& hi) {
    const SetEntry set(impl_->scene, i);
    const ParticleSetDesc& d = set.desc();
    if (d.continuous || isOutlet(d.shape) || std::holds_alternative<PointsShape>(d.shape))
        setExtent(set, volume, lo, hi);
    else
        regionExtent(impl_->region(i), volume, lo, hi);
}

const SetSamples& SetCache::samples(std::size_t i) {
    std::optional<SetSamples>& kept = impl_->samples[i];
    return kept ? *kept : kept.emplace(samplesOf(impl_->scene, i));
}

SetSamples SetCache::samplesOf(const SceneDesc& variant, std::size_t i) {
    const SetEntry set(variant, i);
    // A point cloud has no region: its file is read as sampleSet reads it.
    std::optional<SetRegionIn> region;
    if (!std::holds_alternative<PointsShape>(set.desc().shape)) region = impl_->region(i);
    SetSamples out = sampleSetShape(set, SamplePart{}, region ? &*region : nullptr);
    addInitialVelocities(set, out, Comm::single());
    return out;
}

namespace {

/// The set's outlet (a disc or a rectangle) seen through the calls a stream needs.
template <class F>
auto withOutlet(const SetShape& shape, F&& f) {
    using Result = decltype(f(Disc{}));
    return std::visit(
        [&]<class S>(const S& s) -> Result {
            if constexpr (kOutlet<S>)
                return f(s);
            else
                throw std::logic_error("withOutlet: not an outlet");
        },
        shape);
}

}  // namespace

Emitter::Stream streamOf(const SetEntry& set) {
    const ParticleSetDesc& d = set.desc();
    const std::string where = set.at();
    const std::string type = std::visit([](const auto& s) { return std::string(s.kType); }, d.shape);
    if (!d.continuous)
        throw SceneError(where + "/shape: a " + type +
                         " is a surface with no volume: material flows in through it with \"emission\": \"continuous\"");
    if (!isOutlet(d.shape))
        throw SceneError(where +
                         "/emission: continuous emission needs a \"disc\" or \"rectangle\" shape to flow through (closed "
                         "shapes emit whole copies)");
    if (!d.angularVelocity.isZero() || !d.velocityFile.empty())
        throw SceneError(where + ": a continuous source flows at its velocity; it takes no angular_velocity or velocity_field");
    return withOutlet(d.shape, [&](const auto& outlet) {
        Emitter::Stream st;
        st.normal = outlet.unitNormal();
        st.speed = d.velocity.cast<double>().dot(st.normal);
        if (!(st.speed > 0.0))
            throw SceneError(where + "/velocity: a continuous source needs a velocity out through its " + type +
                             " (velocity . normal > 0), got " + std::to_string(st.speed) + " m/s");
        // The particle spacing that gives the set's particles per cell; one layer per spacing of flow, every other
        // layer shifted by half a spacing (a body-centred stacking; the outlet lays out its layers).
        st.spacing = set.scene.settings.dx / std::cbrt(d.particlesPerCell);
        Vec3d u, w;
        outlet.sides(u, w);
        for (int layer = 0; layer < 2; ++layer)
            for (const Eigen::Vector2d& p : outlet.lattice(layer, st.spacing))
                st.layers[layer].push_back(outlet.centre + p[0] * u + p[1] * w);
        if (st.layers[0].empty() || st.layers[1].empty())
            throw SceneError(where + "/shape: the " + type + " is narrower than one particle spacing (" +
                             std::to_string(st.spacing) + " m)");
        return st;
    });
}

void setExtent(const SetEntry& set, double& volume, Vec3d& lo, Vec3d& hi) {
    const ParticleSetDesc& d = set.desc();
    if (d.continuous || isOutlet(d.shape)) {
        // What flows in over the whole duration, and the column it would fill.
        const Emitter::Stream st = streamOf(set);
        const double length = st.speed * double(d.durationFrames) / set.scene.settings.fps;
        withOutlet(d.shape, [&](const auto& outlet) {
            volume = outlet.area() * length;
            const Vec3d r = Vec3d::Constant(outlet.reach()), end = outlet.centre + length * st.normal;
            lo = (outlet.centre - r).cwiseMin(end - r);
            hi = (outlet.centre + r).cwiseMax(end + r);
            return 0;
        });
        return;
    }
    if (const auto* points = std::get_if<PointsShape>(&d.shape)) {
        const SetSamples s = pointCloudSet(set, *points);
        volume = s.volume;
        lo = Vec3d::Constant(INFINITY), hi = Vec3d::Constant(-INFINITY);
        for (const Vec3d& x : s.positions) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
        return;
    }
    regionExtent(regionOf(set), volume, lo, hi);
}

namespace {

/// Above this share of a set's particles, an overlap or a start inside a collider is worth a word.
constexpr double kNoticeableShare = 0.01;
/// Above this share inside a collider, a set is not pushed out whole: it is crushed against the surface or falls
/// through the collider.
constexpr double kMostlyInside = 0.5;

/// The error of a set of which no particle fits its shape: the run refuses it, and so does validate.
[[noreturn]] void noParticleFits(const SetEntry& set) {
    std::ostringstream what;
    what << set.at("shape") << ": no particle fits in the shape at dx = " << set.scene.settings.dx
         << " m (particles lie about dx / cbrt(particles_per_cell) apart: a shape thinner than that holds none); make it larger "
            "or dx smaller";
    throw SceneError(what.str());
}

/// The scene's word when no set enters before its last frame: every frame it writes is empty.
void emptySceneWarning(const SceneDesc& scene, std::vector<std::string>& out) {
    const auto late = [&](const ParticleSetDesc& d) { return d.startFrame > scene.frames; };
    if (scene.sets.empty() || !std::all_of(scene.sets.begin(), scene.sets.end(), late)) return;
    out.push_back(scene.file + ": /sets: no set appears within the scene's " + std::to_string(scene.frames) +
                  " frames (simulation.frames): every frame written is empty; start a set earlier or raise simulation.frames");
}

/// Set i's word on when it enters: starting after the scene's last frame, it never appears.
void entryWarnings(const SetEntry& set, std::vector<std::string>& out) {
    const int start = set.desc().startFrame, frames = set.scene.frames;
    if (start <= frames) return;
    out.push_back(set.at("start_frame") + ": " + std::to_string(start) + " is after the scene's last frame (simulation.frames " +
                  std::to_string(frames) +
                  "; a set starting at F is in the files from file F on): the set never appears; give a start_frame of at most " +
                  std::to_string(frames) + ", or raise simulation.frames to " + std::to_string(start) + " or more");
}

/// Set i's word on a viscous liquid that would act as a solid: its relaxation time K / G (at a shear rate of 1/s
/// when flow_index is not 1) longer than a frame, so that the elasticity that keeps its step free of the viscosity
/// shows in the animation (materials/HerschelBulkley.h; docs/method.md, section 5).
void liquidWarnings(const SetEntry& set, std::vector<std::string>& out) {
    const ParticleSetDesc& d = set.desc();
    const auto* p = std::get_if<HerschelBulkley::Params>(&d.params);
    if (!p) return;
    const double shearModulus = double(p->shearModulus) * d.muScale, frame = 1.0 / set.scene.settings.fps;
    const double relaxation = double(p->viscosity) / shearModulus;
    if (!(relaxation > frame)) return;
    std::ostringstream s;
    s << set.at("material_params/viscosity") << ": " << p->viscosity << " over the shear modulus " << shearModulus
      << " Pa relaxes in " << relaxation << " s, longer than a frame (" << frame
      << " s): the liquid will flow as an elastic solid that creeps, not as a liquid; raise shear_modulus (the time step "
         "shrinks with its square root) or lower the viscosity";
    out.push_back(s.str());
}

/// Set i's word on its own sampling (n particles in all) and on each collider it starts inside of: `inside[c]` of
/// its particles lie inside collider c at its start.
/// `estimated`: the counts come from a coarser sampling of the set (it is too large to sample whole).
void setWarnings(const SetEntry& set, long long n, const std::vector<long long>& inside, std::vector<std::string>& out,
                 bool estimated = false) {
    const SceneDesc& scene = set.scene;
    const std::string where = set.at();
    if (n < kFewParticles)
        out.push_back(where + ": only " + std::to_string(n) +
                      " particles; so small a body is a few cells across (raise "
                      "particles_per_cell or use a smaller dx)");
    for (std::size_t c = 0; c < inside.size(); ++c) {
        if (double(inside[c]) <= kNoticeableShare * double(n)) continue;
        std::string what = where + "/shape: " + (estimated ? "about " : "") + std::to_string(inside[c]) + " of " +
                           std::to_string(n) + " particles start inside collider " + std::to_string(c);
        if (const auto* plane = std::get_if<Plane>(&scene.colliders[c].shape)) {
            std::ostringstream normal;
            normal << plane->normal[0] << ", " << plane->normal[1] << ", " << plane->normal[2];
            what += ", a plane whose solid is on the side its normal (" + normal.str() + ") points away from";
        }
        if (double(inside[c]) <= kMostlyInside * double(n)) {
            out.push_back(what + " (they are pushed out at the first substep); move the set or the collider");
            continue;
        }
        what +=
            ": a set mostly inside a collider is not pushed out whole (it is crushed against the surface, and the run may stop "
            "as its energy blows up, or it falls out through the collider's far side); move the set or the collider";
        if (std::holds_alternative<Plane>(scene.colliders[c].shape)) what += ", or turn the plane's normal towards the set";
        out.push_back(what);
    }
}

/// How many of `positions` lie inside each collider at the set's start.
std::vector<long long> countInside(const SetEntry& set, const std::vector<Vec3d>& positions,
                                   const std::vector<std::unique_ptr<Collider>>& colliders) {
    const double t0 = double(set.desc().startFrame) / set.scene.settings.fps;
    std::vector<long long> inside;
    for (const auto& c : colliders) {
        c->prepare(t0);  // a sequence loads the frames around t0
        long long k = 0;
        for (const Vec3d& x : positions) k += c->signedDistance(x, t0) < 0.0;
        inside.push_back(k);
    }
    return inside;
}

/// Each set's word on the other sets emitted at the same time into the same space: one line per set, naming the
/// first few it overlaps. Only pairs whose boxes meet are tested, so hundreds of sets answer in a blink (every
/// pair tested, 300 overlapping sets took 17 s and printed 14 MB), and a set's region is read only when another
/// set's box meets it: the one its sampling built, which the cache keeps (or built again past the cache's bound).
void overlapWarnings(SetCache& cache, const std::vector<std::vector<Vec3d>>& positions, std::vector<std::string>& out) {
    const SceneDesc& scene = cache.scene();
    constexpr std::size_t kNamedOverlaps = 3;
    const std::size_t n = scene.sets.size();
    std::vector<Eigen::AlignedBox3d> box(n);
    for (std::size_t i = 0; i < n; ++i)
        for (const Vec3d& x : positions[i]) box[i].extend(x);
    // inside[b]: the sets a whose region holds a noticeable share of b's particles, with how many, in order of a.
    std::vector<std::vector<std::pair<std::size_t, std::size_t>>> inside(n);
    for (std::size_t a = 0; a < n; ++a) {
        // A set given as points has no region to be inside of.
        if (positions[a].empty() || std::holds_alternative<PointsShape>(scene.sets[a].shape)) continue;
        // a's region reaches about half a particle spacing past its particles: a cell of margin covers it.
        Eigen::AlignedBox3d reach = box[a];
        reach.min().array() -= scene.settings.dx;
        reach.max().array() += scene.settings.dx;
        std::optional<SetRegionIn> region;
        for (std::size_t b = 0; b < n; ++b) {
            if (a == b || positions[b].empty() || scene.sets[a].startFrame != scene.sets[b].startFrame) continue;
            if (!reach.intersects(box[b])) continue;
            if (!region) region = cache.impl()->region(a);
            const Placement& t = region->placement;
            std::size_t count = 0;
            for (const Vec3d& x : positions[b]) {
                // Back into the frame a's region was sampled in.
                const Vec3d local = t.identity() ? x : Vec3d(t.rotate.matrix().transpose() * (x - t.translate) / t.scale);
                count += std::visit([&](const auto& r) { return r.contains(local); }, region->region);
            }
            if (double(count) > kNoticeableShare * double(positions[b].size())) inside[b].emplace_back(a, count);
        }
    }
    for (std::size_t b = 0; b < n; ++b) {
        if (inside[b].empty()) continue;
        std::ostringstream named;
        for (std::size_t k = 0; k < std::min(kNamedOverlaps, inside[b].size()); ++k) {
            const auto [a, count] = inside[b][k];
            named << (k > 0 ? "; " : "") << count << " of " << positions[b].size() << " particles lie inside set " << a << " (\""
                  << scene.sets[a].name << "\")";
        }
        const std::size_t overlaps = inside[b].size();
        out.push_back(
            SetEntry(scene, b).at("shape") + ": " + named.str() +
            (overlaps > kNamedOverlaps ? "; and inside " + std::to_string(overlaps - kNamedOverlaps) + " more sets"
                                       : std::string()) +
            ": " + (overlaps > 1 ? "they are" : "both are") +
            " emitted into the same space, which then holds both masses; move or shrink one, or start them at different "
            "frames");
    }
}

}  // namespace

std::vector<std::string> summarisedWarnings(const std::vector<std::string>& warnings) {
    // A warning's kind: its text with each run of digits made one '#'.
    const auto kind = [](const std::string& w) {
        std::string k;
        for (std::size_t i = 0; i < w.size(); ++i)
            if (!std::isdigit(static_cast<unsigned char>(w[i])))
                k += w[i];
            else if (k.empty() || k.back() != '#')
                k += '#';
        return k;
    };
    // "FILE: /json/path: what": the file and the path.
    const auto part = [](const std::string& w, int which) {
        const std::size_t a = w.find(": "), b = a == std::string::npos ? a : w.find(": ", a + 2);
        if (b == std::string::npos) return std::string();
        return which == 0 ? w.substr(0, a) : w.substr(a + 2, b - a - 2);
    };
    // The warnings of each kind past the first kRepeatsShown, by kind.
    std::map<std::string, std::vector<std::size_t>> rest;
    std::map<std::string, std::size_t> seen;
    for (std::size_t i = 0; i < warnings.size(); ++i) {
        const std::string k = kind(warnings[i]);
        if (++seen[k] > kRepeatsShown) rest[k].push_back(i);
    }
    // The first kRepeatsShown of each kind as they come, the last of them followed by the summary of the rest.
    constexpr std::size_t kPathsNamed = 8;  // then the last one
    std::vector<std::string> shown;
    seen.clear();
    for (std::size_t i = 0; i < warnings.size(); ++i) {
        const std::string k = kind(warnings[i]);
        const std::size_t n = ++seen[k];
        if (n > kRepeatsShown) continue;
        shown.push_back(warnings[i]);
        const auto more = rest.find(k);
        if (n < kRepeatsShown || more == rest.end()) continue;
        const std::vector<std::size_t>& r = more->second;
        std::string paths;
        for (std::size_t j = 0; j < r.size(); ++j) {
            if (j == kPathsNamed && j + 1 < r.size()) {
                paths += ", ... (" + std::to_string(r.size() - kPathsNamed - 1) + " more), ";
                j = r.size() - 1;
            } else if (j > 0) {
                paths += ", ";
            }
            paths += part(warnings[r[j]], 1);
        }
        shown.push_back(part(warnings[r.front()], 0) + ": the same as above for " + std::to_string(r.size()) + " more: " + paths);
    }
    return shown;
}

std::vector<std::string> sceneWarnings(const SceneDesc& scene, std::vector<std::string>* bodies, SetCache* given) {
    std::optional<SetCache> own;
    SetCache& cache = given ? *given : own.emplace(scene);
    std::vector<std::string> out;
    // Explicit MPM is stable for CFL numbers below about 1 (the stability sweep's bound, docs/method.md section 8).
    constexpr double kExplicitBound = 1.0;
    if (scene.settings.adaptive && scene.settings.cfl > kExplicitBound) {
        std::ostringstream s;
        s << scene.file << ": /simulation/cfl: " << scene.settings.cfl
          << " is past the explicit step's stability bound (about 1): the run is likely to stop with a blow-up (or, with "
             "retries, to halve its step until it is stable); use 0.5, the default, or less";
        out.push_back(s.str());
    }
    std::vector<std::unique_ptr<Collider>> colliders;
    for (std::size_t c = 0; c < scene.colliders.size(); ++c) {
        std::optional<BodySpec> body;
        colliders.push_back(colliderOf(ColliderEntry(scene, c), nullptr, &out, nullptr, &body, bodies));
        if (!body) continue;
        const RigidBodyModel& m = body->model;
        if (bodies) {
            // What the user cannot see elsewhere: the mass and inertia the shape gave (a file's, above all).
            const Eigen::SelfAdjointEigenSolver<Mat3d> principal(m.inertia);
            std::ostringstream s;
            s.precision(4);
            s << "collider " << c << " (" << scene.colliders[c].name << "): a rigid body of " << m.mass << " kg, centre of mass ("
              << m.restCentre[0] << ", " << m.restCentre[1] << ", " << m.restCentre[2] << ") m, principal moments of inertia "
              << principal.eigenvalues()[0] << ", " << principal.eigenvalues()[1] << ", " << principal.eigenvalues()[2]
              << " kg m^2";
            if (m.rollingResistance > 0.0) s << ", rolling resistance " << m.rollingResistance;
            bodies->push_back(s.str());
        }
    }
    emptySceneWarning(scene, out);
    std::vector<std::vector<Vec3d>> positions(scene.sets.size());
    for (std::size_t i = 0; i < scene.sets.size(); ++i) {
        const SetEntry set(scene, i);
        const ParticleSetDesc& d = set.desc();
        if (!d.body.empty() && scene.settings.contact != ContactModel::MultiField)
            out.push_back(set.at("body") + ": \"" + d.body +
                          "\" names a body, but simulation.contact is single_field, where all bodies share one velocity field "
                          "(set it to multi_field)");
        entryWarnings(set, out);
        liquidWarnings(set, out);
        if (d.continuous || isOutlet(d.shape)) continue;  // a stream enters over time
        double volume = 0.0;
        Vec3d lo, hi;
        cache.extent(i, volume, lo, hi);
        const double dx = scene.settings.dx,
                     expected = d.count > 0 ? double(d.count) : volume / (dx * dx * dx) * d.particlesPerCell;
        if (expected > kSampleUpTo) {
            // Too many to sample (and to pair with the other sets): a coarser sampling of the same shape gives the share
            // that starts inside a collider, which a set of a mistaken size is most likely to.
            if (std::holds_alternative<PointsShape>(d.shape)) continue;
            constexpr double kCoarseSample = 1e5;
            SceneDesc coarse = scene;
            ParticleSetDesc& c = coarse.sets[i];
            c.particlesPerCell *= kCoarseSample / expected;
            if (c.count > 0) c.count = (long long)kCoarseSample;
            const SetSamples coarseSamples = cache.samplesOf(coarse, i);
            // Its material fields, on the coarse samples: their files, grids and values at those points.
            if (!set.desc().materialFields.empty()) fieldParams(SetEntry(coarse, i), coarseSamples, Comm::single());
            const std::vector<Vec3d>& few = coarseSamples.positions;
            if (few.empty()) continue;
            std::vector<long long> inside = countInside(set, few, colliders);
            for (long long& k : inside) k = std::llround(double(k) * expected / double(few.size()));
            setWarnings(set, (long long)expected, inside, out, true);
            continue;
        }
        const SetSamples& samples = cache.samples(i);
        // Its material fields: their files, grids and every particle's values.
        if (!set.desc().materialFields.empty()) fieldParams(set, samples, Comm::single());
        positions[i] = samples.positions;
        if (positions[i].empty()) noParticleFits(set);
        setWarnings(set, (long long)positions[i].size(), countInside(set, positions[i], colliders), out);
    }
    overlapWarnings(cache, positions, out);
    return out;
}

std::vector<float> particleMasses(const ParticleSetDesc& d, float density, float volume, const SetSamples& samples,
                                  const std::vector<float>& densities) {
    std::vector<float> masses;
    if (!densities.empty()) {
        // A density field: each particle's mass from its own density.
        for (std::size_t p = 0; p < densities.size(); ++p)
            masses.push_back(
                float((samples.volumes.empty() ? double(volume) : double(samples.volumes[p])) * densities[p] * d.massScale));
    } else if (samples.masses.empty()) {
        for (float v : samples.volumes) masses.push_back(float(v * density * d.massScale));
    } else {
        for (float m : samples.masses) masses.push_back(float(m * d.massScale));
    }
    return masses;
}

SpeciesLayout speciesLayout(const SceneDesc& scene) {
    SpeciesLayout out;
    for (std::size_t i = 0; i < scene.sets.size(); ++i) {
        out.speciesOfSet.push_back(int(i));
        out.setOfSpecies.push_back(int(i));
        out.materialOfSpecies.push_back(materialIndex(scene.sets[i].params));
        out.setNames.push_back(scene.sets[i].name);
    }
    return out;
}

std::unique_ptr<Simulation> buildSimulation(const SceneDesc& scene, const Comm& comm, DerivedValues* derived,
                                            const SetupWatch& watch) {
    const SamplePart asked{0, 1, watch.stop};
    auto sim = std::make_unique<Simulation>(scene.settings);
    DerivedValues found;
    found.setPivot.resize(scene.sets.size());
    found.colliderPivot.resize(scene.colliders.size());
    // The colliders first: the sets' samples are checked against them.
    std::vector<std::unique_ptr<Collider>> colliders;
    std::vector<std::optional<BodySpec>> bodySpecs(scene.colliders.size());
    found.colliderVoxel.assign(scene.colliders.size(), 0.0);
    std::size_t saidNotes = 0;
    for (std::size_t i = 0; i < scene.colliders.size(); ++i) {
        asked.checkStop();
        std::visit(
            [&]<class S>(const S& s) {
                if constexpr (std::is_same_v<S, MeshShape> || std::is_same_v<S, VdbShape>)
                    watch.note("building the distance field of collider " + std::to_string(i) + " (" + s.file + ")");
            },
            scene.colliders[i].shape);
        colliders.push_back(colliderOf(ColliderEntry(scene, i), &found.colliderPivot[i], &found.warnings, &found.colliderVoxel[i],
                                       &bodySpecs[i], &found.notes));
        for (std::size_t n = saidNotes; n < found.notes.size(); ++n) watch.report(found.notes[n]);
        saidNotes = found.notes.size();
    }
    const SpeciesLayout layout = speciesLayout(scene);
    // Bodies, numbered in order of first appearance: a set's `body` name, or else its own name.
    std::vector<int> bodyOf;
    std::vector<std::string> bodies;
    for (const ParticleSetDesc& d : scene.sets) {
        const std::string& name = d.body.empty() ? d.name : d.body;
        const auto at = std::find(bodies.begin(), bodies.end(), name);
        bodyOf.push_back(int(at - bodies.begin()));
        if (at == bodies.end()) bodies.push_back(name);
    }
    emptySceneWarning(scene, found.warnings);
    for (std::size_t i = 0; i < scene.sets.size(); ++i) {
        const SetEntry set(scene, i);
        const ParticleSetDesc& d = set.desc();
        entryWarnings(set, found.warnings);
        liquidWarnings(set, found.warnings);
        AnyMaterialParams params = d.params;
        visitMaterialParams(params, [&]<class M>(typename M::Params& p) { M::scaleStiffness(p, d.lambdaScale, d.muScale); });
        auto addSpecies = [&, i](AnySpecies species) {
            if (sim->addSpecies(std::move(species), bodyOf[i]) != layout.speciesOfSet[i])
                throw std::logic_error("buildSimulation: species order differs from speciesLayout");
        };
        Emitter e;
        e.species = layout.speciesOfSet[i];
        e.set = uint16_t(i);
        if (d.continuous || isOutlet(d.shape)) {
            if (!d.materialFields.empty())
                throw SceneError(set.at("material_fields") +
                                 ": a stream enters as uniform material; parameters per particle need a sampled shape");
            addSpecies(makeSpecies(d.name, params));
            // A stream: each particle is one spacing cube of the material.
            e.continuous = true;
            e.stream = streamOf(set);
            e.velocity = d.velocity;
            // A layer carries one spacing of flow through the disc: its area times the spacing, shared by its points.
            const double perLayer = 0.5 * double(e.stream.layers[0].size() + e.stream.layers[1].size());
            e.volume = float(withOutlet(d.shape, [](const auto& o) { return o.area(); }) * e.stream.spacing / perLayer);
            const float density = std::visit([](const auto& p) { return p.density; }, params);
            e.mass = float(e.volume * density * d.massScale);
            e.startFrame = d.startFrame;
            e.durationFrames = d.durationFrames;
            sim->addEmitter(std::move(e));
            continue;
        }
        asked.checkStop();
        watch.note("sampling set " + std::to_string(i) + " '" + d.name + "'");
        SetSamples samples = sampleSet(set, comm, watch.stop);
        AnySpecies species = makeSpecies(d.name, params);
        std::vector<float> densities;
        if (!d.materialFields.empty()) {
            watch.note("material fields of set " + std::to_string(i) + " '" + d.name + "'");
            FieldParams fields = fieldParams(set, samples, comm);
            std::visit(
                [&](auto& sp) {
                    using Params = typename std::decay_t<decltype(sp)>::Params;
                    sp.params = std::get<Params>(fields.stiffest);
                    sp.perParticle = true;
                },
                species);
            e.local = std::move(fields.local);
            densities = std::move(fields.densities);
        }
        addSpecies(std::move(species));
        found.setPivot[i] = samples.pivot;
        e.positions = std::move(samples.positions);
        long long total = (long long)e.positions.size();
        if (comm.distributed()) {
            // This rank's part: where it starts among the set's samples, and how many there are in all.
            std::vector<long long> sizes;
            Bytes mine;
            put(mine, total);
            for (const Bytes& b : comm.allGather(mine)) sizes.push_back(ByteReader{b}.get<long long>());
            e.first = std::accumulate(sizes.begin(), sizes.begin() + comm.rank(), 0LL);
            e.total = total = std::accumulate(sizes.begin(), sizes.end(), 0LL);
        }
        if (total == 0) noParticleFits(set);
        std::vector<long long> inside = countInside(set, e.positions, colliders);
        for (long long& k : inside) k = comm.sum(k);
        setWarnings(set, total, inside, found.warnings);
        e.velocity = d.velocity;
        e.velocities = std::move(samples.velocities);
        // A rigid spin's velocity gradient, [w]x: the affine velocity APIC carries for it.
        const Vec3f w = d.angularVelocity.cast<float>();
        e.affine << 0.0f, -w[2], w[1], w[2], 0.0f, -w[0], -w[1], w[0], 0.0f;
        e.volume = float(samples.volume / double(total));
        const float density = std::visit([](const auto& p) { return p.density; }, params);
        e.mass = float(e.volume * density * d.massScale);
        e.masses = particleMasses(d, density, e.volume, samples, densities);
        e.volumes = std::move(samples.volumes);
        e.startFrame = d.startFrame;
        e.durationFrames = d.durationFrames;
        e.pauseFrames = d.pauseFrames;
        sim->addEmitter(std::move(e));
    }
    for (std::size_t i = 0; i < colliders.size(); ++i)
        if (bodySpecs[i])
            sim->addBody(std::move(colliders[i]), bodySpecs[i]->model, bodySpecs[i]->frame, bodySpecs[i]->initial);
        else
            sim->addCollider(std::move(colliders[i]));
    if (derived) *derived = std::move(found);
    return sim;
}

double setFieldBytes(const SetEntry& set) {
    const SceneDesc& scene = set.scene;
    const std::string where = set.path("shape");
    // Built as levelSetOf builds it for a set: in the file's coordinates (place false), a VDB file's band as it is.
    if (const auto* mesh = std::get_if<MeshShape>(&set.desc().shape)) {
        const MeshField f = meshField(scene, where, *mesh, false, false);
        return meshFieldBytes(f.mesh, f.voxel, meshBand(cellInField(scene, *mesh, false), f.voxel).width(*mesh));
    }
    if (const auto* vdb = std::get_if<VdbShape>(&set.desc().shape)) {
        if (vdb->file.find("$F") != std::string::npos) return 0.0;  // refused when the set is built
        try {
            return vdbFieldBytes(besideScene(scene, vdb->file), vdb->grid, 1.0, 0.0);
        } catch (const LevelSetError& e) {
            throw SceneError(scene.file + ": " + where + "/file: " + e.what());
        }
    }
    return 0.0;
}

double colliderFieldBytes(const ColliderEntry& collider) {
    const SceneDesc& scene = collider.scene;
    const ColliderDesc& c = collider.desc();
    const std::string where = collider.path();
    const double dx = scene.settings.dx;
    return std::visit(
        [&]<class S>(const S& shape) -> double {
            if constexpr (std::is_same_v<S, MeshShape>) {
                const MeshField f = meshField(scene, where, shape, true, c.inside);
                const double band = meshBand(dx, f.voxel).width(shape);
                refuseFieldTooLarge(scene, where, shape, f, band);
                return meshFieldBytes(f.mesh, f.voxel, band);
            } else if constexpr (std::is_same_v<S, VdbShape>) {
                try {
                    const std::string path = besideScene(scene, shape.file);
                    // A sequence holds the two frames around the time it is interpolated at.
                    constexpr double kSequenceFramesHeld = 2.0;
                    const bool sequence = shape.file.find("$F") != std::string::npos;
                    const std::string file = sequence ? sequenceFile(path, sequenceFrames(path).front()) : path;
                    return (sequence ? kSequenceFramesHeld : 1.0) *
                           vdbFieldBytes(file, shape.grid, shape.transform.scale, levelSetBand(dx), finestVdbVoxel(dx));
                } catch (const LevelSetError& e) {
                    throw SceneError(scene.file + ": " + where + "/file: " + e.what());
                }
            } else {
                return 0.0;  // a formula
            }
        },
        c.shape);
}

DerivedValues deriveValues(const SceneDesc& scene) {
    DerivedValues out;
    for (std::size_t i = 0; i < scene.sets.size(); ++i) {
        const ParticleSetDesc& d = scene.sets[i];
        out.setPivot.push_back(
            d.angularVelocity.isZero() || d.continuous || isOutlet(d.shape) ? std::nullopt : sampleSet(SetEntry(scene, i)).pivot);
    }
    for (std::size_t i = 0; i < scene.colliders.size(); ++i)
        colliderOf(ColliderEntry(scene, i), &out.colliderPivot.emplace_back(), nullptr, &out.colliderVoxel.emplace_back());
    return out;
}

namespace {
/// The object with `key` set to `value` where the reader writes it, before `next` (at the end if absent): the
/// scene a run writes reads back to the same text.
nlohmann::ordered_json withKey(const nlohmann::ordered_json& object, const char* key, const nlohmann::ordered_json& value,
                               const char* next) {
    nlohmann::ordered_json out = nlohmann::ordered_json::object();
    for (auto it = object.begin(); it != object.end(); ++it) {
        if (it.key() == next) out[key] = value;
        if (it.key() != key) out[it.key()] = it.value();
    }
    if (!out.contains(key)) out[key] = value;
    return out;
}
}  // namespace

std::string resolvedWithDerived(const SceneDesc& scene, const DerivedValues& derived) {
    nlohmann::ordered_json j = nlohmann::ordered_json::parse(scene.resolvedJson);
    const auto array = [](const Vec3d& v) { return nlohmann::ordered_json::array({v[0], v[1], v[2]}); };
    for (std::size_t i = 0; i < scene.sets.size() && i < derived.setPivot.size(); ++i)
        if (derived.setPivot[i] && !scene.sets[i].pivotGiven)
            j["sets"][i] = withKey(j["sets"][i], "pivot", array(*derived.setPivot[i]), "velocity_field");
    for (std::size_t i = 0; i < scene.colliders.size() && i < derived.colliderPivot.size(); ++i) {
        if (const auto* mesh = std::get_if<MeshShape>(&scene.colliders[i].shape);
            mesh && mesh->voxelSize <= 0.0 && i < derived.colliderVoxel.size() && derived.colliderVoxel[i] > 0.0)
            j["colliders"][i]["voxel_size"] = derived.colliderVoxel[i];
        const MotionDesc& m = scene.colliders[i].motion;
        // Moved by the material from the start: no pivot to state.
        if (scene.colliders[i].dynamic.enabled && scene.colliders[i].dynamic.animatedUntil <= 0.0) continue;
        nlohmann::ordered_json& motion = j["colliders"][i]["motion"];
        if (!m.pivotGiven) motion = withKey(motion, "pivot", array(derived.colliderPivot[i]), "keyframes");
        for (std::size_t k = 0; k < m.keyframes.size(); ++k)
            if (!m.keyframes[k].positionGiven)
                motion["keyframes"][k] = withKey(motion["keyframes"][k], "position", array(derived.colliderPivot[i]), "rotation");
    }
    return j.dump(2);
}

}  // namespace mpm
