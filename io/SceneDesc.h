#pragma once
// A scene as plain data: what the scene file says, with every default filled in, and nothing live. The
// reader (io/SceneReader.h) makes one from JSON; the builder (io/SceneBuilder.h) makes a Simulation from it.
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/Settings.h"
#include "core/Species.h"
#include "core/shapes/Shapes.h"

namespace mpm {

/// A scene that cannot be used as written. what() reads "FILE: /json/path: problem".
class SceneError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

enum class Sampling { Poisson, Grid, Lattice };

/// One material parameter given particle by particle: a linear ramp, a VDB scalar grid sampled where each
/// particle is seeded, or a column of a point cloud's PLY file.
struct MaterialFieldDesc {
    enum class Source { Ramp, Vdb, Attribute };
    std::string param;  ///< a number key of the set's material_params ("youngs_modulus")
    Source source = Source::Ramp;
    Vec3d from = Vec3d::Zero(), to = Vec3d::UnitX();  ///< ramp: the value goes from fromValue at `from` to toValue at `to`
    double fromValue = 0.0, toValue = 0.0;
    std::string file, grid;  ///< vdb: the file (beside the scene) and its float grid (default: param)
    std::string attribute;   ///< attribute: the PLY vertex property (default: param)
};

struct ParticleSetDesc {
    std::string name;
    std::string material = "water";  ///< scene name of the material (materials/Materials.h)
    std::string body;                ///< multi_field contact: sets sharing a body name share a velocity field (empty: its own)
    AnyMaterialParams params;        ///< its parameters, overrides applied; the Lame scales below come on top
    /// The material_params numbers the scene gives (youngs_modulus with poisson_ratio: a field's particle parameters
    /// are made from them and the defaults, as `params` was, with the field's value in place of one).
    std::vector<std::pair<std::string, double>> materialNumbers;
    std::vector<MaterialFieldDesc> materialFields;  ///< parameters given per particle
    SetShape shape;
    Vec3f velocity = Vec3f::Zero();
    Vec3f colour = Vec3f::Ones();           ///< Cd of its points (linear RGB); the material's unless given
    Vec3d angularVelocity = Vec3d::Zero();  ///< an initial rigid spin about the pivot [rad/s]
    Vec3d pivot = Vec3d::Zero();
    bool pivotGiven = false;   ///< else: the centroid of the set's particles
    std::string velocityFile;  ///< a VDB whose vector grid adds an initial velocity field
    std::string velocityGrid = "vel";
    double particlesPerCell = 8.0;  ///< used unless count > 0
    long long count = 0;
    Sampling sampling = Sampling::Poisson;
    int startFrame = 0, durationFrames = 1, pauseFrames = 0;
    bool continuous = false;  ///< material enters through the shape (a disc or rectangle) during the duration, not as copies
    double lambdaScale = 1.0, muScale = 1.0, massScale = 1.0;
    unsigned seed = 1;
};

/// One pose of a keyframed motion (core/Motion.h).
struct KeyframeDesc {
    double frame = 0.0;
    Vec3d position = Vec3d::Zero();  ///< of the pivot
    bool positionGiven = false;      ///< else: where the pivot is at rest
    Rotation rotation;
};

struct MotionDesc {
    Vec3d velocity = Vec3d::Zero(), angularVelocity = Vec3d::Zero();
    Vec3d pivot = Vec3d::Zero();
    bool pivotGiven = false;  ///< else: the collider's centre
    std::vector<KeyframeDesc> keyframes;
};

/// A collider the material moves (core/RigidBody.h).
struct DynamicDesc {
    bool enabled = false;  ///< the scene gave "dynamic"
    double density = 1000.0;
    double mass = 0.0;  ///< > 0: replaces density times the shape's volume
    Vec3d velocity = Vec3d::Zero(), angularVelocity = Vec3d::Zero();
    std::string lockTranslation = "none", lockRotation = "none";  ///< world axes held still: none, x, y, z, xy, ...
    double restitution = 0.0;                                     ///< of its contacts with colliders and other bodies
    double rollingResistance = 0.0;                               ///< the couple against rolling, over normal force and lever
    double animatedUntil = 0.0;                                   ///< > 0: it follows the collider's motion until then [s]
};

struct ColliderDesc {
    std::string name;  ///< unique among the colliders
    ColliderShape shape;
    Boundary boundary = Boundary::Separate;
    float friction = 0.0f;
    bool inside = false;  ///< material stays inside it (a tank, a glass, a drum)
    MotionDesc motion;
    DynamicDesc dynamic;
};

struct OutputDesc {
    std::string directory = "out";
    bool points = true;          ///< VDB PointDataGrid "points"
    bool surface = true;         ///< narrow-band level set "surface"
    bool density = false;        ///< fog volume "density"
    bool velocity = false;       ///< vector grid "vel"
    bool splitFiles = false;     ///< points in <scene>_points_NNNN.vdb, volumes in <scene>_NNNN.vdb
    bool ply = false;            ///< binary PLY per frame (Blender reads it)
    bool initialFrame = false;   ///< also write the initial state as file 0000 (file N is the end of frame N)
    double surfaceRadius = 1.0;  ///< sphere radius in particle spacings
    /// Closing of the surface, in particle spacings (voxels), and Gaussian passes between; the defaults are
    /// measured in tests/test_surface.cpp (no hole in a disordered bulk, a flat pool, a ball's area, thin sheets).
    double surfaceDilate = 2.0, surfaceErode = 2.0;
    int surfaceSmooth = 1;
    std::string surfaceGroup = "all";     ///< all | material | set: one surface grid per group
    std::vector<std::string> attributes;  ///< extra point attributes (io/PointCloud.h PointAttributes::names)
    int checkpointEvery = 1;              ///< frames between checkpoints; 0 = none
    int checkpointsKept = 2;
    /// On several ranks: "gathered" (rank 0 writes each frame as one process does) or "per_rank" (each rank
    /// writes its own particles into part files <scene>_NNNN_rankRRR.vdb, nothing gathered).
    std::string rankFiles = "gathered";
};

struct SceneDesc {
    std::string file;  ///< path it was read from
    std::string name;  ///< file stem, used in output names
    SimulationSettings settings;
    int frames = 48;
    int threads = 0;  ///< 0 = all cores
    OutputDesc output;
    std::vector<ParticleSetDesc> sets;
    std::vector<ColliderDesc> colliders;
    std::string resolvedJson;  ///< the scene with every default filled in
};

/// One entry of a scene's list `kList` ("sets" or "colliders"), as set-up code passes it around: the entry, and
/// where its keys are in the scene file, for messages ("FILE: /sets/2/shape: what is wrong").
template <const char* kList>
struct SceneEntry {
    SceneEntry(const SceneDesc& s, std::size_t i) : scene(s), index(i) {}
    const SceneDesc& scene;
    std::size_t index;
    /// The JSON path of one of its keys ("/sets/2/shape/file"), or of the entry itself.
    std::string path(const std::string& key = {}) const {
        return "/" + std::string(kList) + "/" + std::to_string(index) + (key.empty() ? "" : "/" + key);
    }
    /// The scene file and that path, as a message starts: "FILE: /sets/2/shape".
    std::string at(const std::string& key = {}) const { return scene.file + ": " + path(key); }
};
inline constexpr char kSetsList[] = "sets";
inline constexpr char kCollidersList[] = "colliders";
/// A particle set of a scene.
struct SetEntry : SceneEntry<kSetsList> {
    using SceneEntry::SceneEntry;
    const ParticleSetDesc& desc() const { return scene.sets[index]; }
};
/// A collider of a scene.
struct ColliderEntry : SceneEntry<kCollidersList> {
    using SceneEntry::SceneEntry;
    const ColliderDesc& desc() const { return scene.colliders[index]; }
};

}  // namespace mpm
