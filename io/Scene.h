#pragma once
// Scene files (JSON): simulation settings, material presets with overrides, particle sets, colliders and
// output. Every field is checked; an error names the file, the JSON path and what is allowed, and unknown
// keys are errors. docs/scene-format.md and `mpm validate --explain` list every field and its default.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/Simulation.h"

namespace mpm {

/// A scene that cannot be used as written. what() reads "FILE: /json/path: problem".
class SceneError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

enum class Sampling { Poisson, Grid, Lattice };

struct ShapeDesc {
    enum class Kind { Box, Sphere } kind = Kind::Box;
    Vec3d min = Vec3d::Zero(), max = Vec3d::Zero();  ///< box
    Vec3d centre = Vec3d::Zero();                    ///< sphere
    double radius = 0.0;
    double volume() const;
    bool contains(const Vec3d& x) const;
};

struct ParticleSetDesc {
    std::string name;
    std::string material;
    ShapeDesc shape;
    Vec3f velocity = Vec3f::Zero();
    double particlesPerCell = 8.0;  ///< used unless count > 0
    long long count = 0;
    Sampling sampling = Sampling::Poisson;
    int startFrame = 0, durationFrames = 1, pauseFrames = 0;
    double lambdaScale = 1.0, muScale = 1.0, massScale = 1.0;
    unsigned seed = 1;
};

struct OutputDesc {
    std::string directory = "out";
    bool points = true;         ///< VDB PointDataGrid "points"
    bool surface = true;        ///< narrow-band level set "surface"
    bool density = false;       ///< fog volume "density"
    bool velocity = false;      ///< vector grid "vel"
    bool splitFiles = false;    ///< points in <scene>_points_NNNN.vdb, volumes in <scene>_NNNN.vdb
    bool ply = false;           ///< binary PLY per frame (Blender reads it)
    double surfaceRadius = 1.0; ///< sphere radius in particle spacings
    std::string surfaceGroup = "all";  ///< all | material | set: one surface grid per group
};

struct SceneDesc {
    std::string file;    ///< path it was read from
    std::string name;    ///< file stem, used in output names
    SimulationSettings settings;
    int frames = 48;
    int threads = 0;     ///< 0 = all cores
    OutputDesc output;
    std::vector<ParticleSetDesc> sets;
    std::vector<std::string> materialNames;           ///< preset names used, in species order
    std::vector<std::unique_ptr<Collider>> colliders;
    std::string resolvedJson;  ///< the scene with every default filled in
    /// Builds the species for set i with its material, overrides and lambda/mu scales.
    std::vector<AnySpecies> speciesPrototypes;
    std::vector<int> speciesOfSet;
    std::vector<float> densityOfSet;
};

/// Reads and checks a scene file. Throws SceneError.
SceneDesc loadScene(const std::string& path);
/// The same for scene text in memory; `path` names it in errors and gives the scene its name.
SceneDesc parseScene(const std::string& text, const std::string& path);

/// Builds a ready-to-run simulation: species, sampled particle sets (as emitters) and colliders.
std::unique_ptr<Simulation> buildSimulation(SceneDesc& scene);

/// Every field with its default and allowed values, as Markdown.
std::string explainSceneFormat();

/// Material preset names, in the order listed in errors.
const std::vector<std::string>& materialPresetNames();

}  // namespace mpm
