#pragma once
// From a scene description to a ready-to-run Simulation: one species per particle set (its material with
// the set's Lame scales), the set sampled in its shape as an emitter, and the colliders.
#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/Comm.h"
#include "core/Simulation.h"
#include "io/SceneDesc.h"

namespace mpm {

/// Which species each set became and what each species is, for the writers. The builder makes species s
/// from set s; this says so explicitly instead of every reader of the output assuming it.
struct SpeciesLayout {
    std::vector<int> speciesOfSet;
    std::vector<int> setOfSpecies;
    std::vector<int> materialOfSpecies;  ///< index into materialSceneNames()
    std::vector<std::string> setNames;   ///< by set index
};

SpeciesLayout speciesLayout(const SceneDesc& scene);

/// A file named by a scene, relative to the scene file's folder unless absolute.
std::string besideScene(const SceneDesc& scene, const std::string& file);

/// Set `i`'s particles: positions in the scene (a file's shape is sampled in the file's own coordinates and
/// then placed by its transform, so moving an asset moves its particles exactly) and the volume they fill.
/// Reads the set's file, if it has one; errors name the scene, the key and the file.
struct SetSamples {
    std::vector<Vec3d> positions;
    std::vector<Vec3f> velocities;  ///< a point cloud's, when its file has them
    double volume = 0.0;            ///< of the whole set
    std::vector<float> volumes;     ///< per particle, a point cloud's with radii; empty: volume shared evenly
    std::vector<float> masses;      ///< per particle, a point cloud's with masses or densities; empty: density x volume
    std::optional<Vec3d> pivot;     ///< a spinning set's centre of spin (its centroid unless the scene gives one)
    /// A point cloud's vertex properties that the set's `attribute` material fields name, in their order.
    std::vector<std::vector<float>> columns;
};
/// The masses of a set's samples particle by particle, by the set's rule: a point cloud's own (masses or densities),
/// each particle's density from a density field (`densities`), or `density` times a point cloud's volumes; all times
/// the set's mass_scale. Empty: every particle has `volume` times `density` times mass_scale.
std::vector<float> particleMasses(const ParticleSetDesc& d, float density, float volume, const SetSamples& samples,
                                  const std::vector<float>& densities = {});
/// With several ranks each gets its part of the samples (in rank order, the whole set's order; `volume`
/// stays the whole set's): a Poisson-disk set given by its density samples only its part's tiles.
/// Collective on `comm`.
/// A nonzero *stop gives up the sampling (Interrupted) within milliseconds.
SetSamples sampleSet(const SetEntry& set, const Comm& comm = Comm::single(), const std::atomic<int>* stop = nullptr);

/// A continuous set's stream: the layers that enter through its disc (throws SceneError for a set that cannot
/// be one: not a disc, no velocity out through it).
Emitter::Stream streamOf(const SetEntry& set);

/// The set's volume and its bounds in the scene, without sampling it (reads its file, if it has one).
void setExtent(const SetEntry& set, double& volume, Vec3d& lo, Vec3d& hi);

/// What validate reads of each set more than once (its extent and samples for the budget, again for the warnings, and
/// its region for the overlap test), computed once: a mesh or VDB set's distance field is the costly part (two
/// overlapping 0.4M-particle mesh sets took 22 s to validate, building each field five times). Fields are kept
/// while those kept take at most kKeptFieldBytes in all (setFieldBytes); past that a field is built again where it
/// is needed, so validate holds no more than that beyond one field at a time, as the run's set-up does.
class SetCache {
public:
    static constexpr double kKeptFieldBytes = 1 << 30;
    explicit SetCache(const SceneDesc& scene);
    ~SetCache();
    SetCache(const SetCache&) = delete;
    SetCache& operator=(const SetCache&) = delete;
    const SceneDesc& scene() const;
    /// setExtent of set i.
    void extent(std::size_t i, double& volume, Vec3d& lo, Vec3d& hi);
    /// sampleSet of set i, one process's whole set.
    const SetSamples& samples(std::size_t i);
    /// Set i of `variant`, a copy of the cache's scene with other particle counts (the same shapes), sampled in the
    /// region of the cache's set i.
    SetSamples samplesOf(const SceneDesc& variant, std::size_t i);
    /// How many distance fields of file sets it has built.
    std::size_t fieldsBuilt() const;
    /// Called as each file set's distance field is about to be built (the slow part: validate says what it does).
    std::function<void(const std::string&)> note = [](const std::string&) {};

    struct Impl;  ///< defined in io/SceneBuilder.cpp, whose passes read the regions kept
    Impl* impl() { return impl_.get(); }

private:
    std::unique_ptr<Impl> impl_;
};

/// Sets expected to hold more particles than this are not sampled by validate (to count them, or to look for
/// overlaps): it answers in seconds whatever the scene's size.
inline constexpr double kSampleUpTo = 2e6;
/// What in the scene is legal but likely a mistake, each "FILE: /json/path: what; what to do": a set of fewer
/// than kFewParticles particles, a set starting partly inside a collider, two sets that overlap. Samples the
/// sets (up to kSampleUpTo particles) and builds the colliders (mpm validate prints these; with --strict they fail it).
inline constexpr long long kFewParticles = 100;
/// `bodies`, if given, receives a line per rigid body (its mass, centre of mass and principal moments of inertia) and
/// per VDB collider whose field was remade at a coarser voxel (which voxel, and why).
/// `cache`, if given, is the scene's (its samples and fields are shared with estimateBudget's).
std::vector<std::string> sceneWarnings(const SceneDesc& scene, std::vector<std::string>* bodies = nullptr,
                                       SetCache* cache = nullptr);

/// Warnings as they are printed: where more than kRepeatsShown say the same thing of different parts of the scene
/// (their texts equal once every number in them is left out: 300 copies of one set give 300 "only 50 particles"), the
/// first kRepeatsShown in full, the last of them followed by one line naming the rest by their JSON paths.
inline constexpr std::size_t kRepeatsShown = 3;
std::vector<std::string> summarisedWarnings(const std::vector<std::string>& warnings);

/// The values the builder derives for keys a scene leaves to it (Key::derived): each collider's pivot (its
/// centre) and so its keyframes' positions, a mesh collider's voxel, and each spinning set's pivot (its centroid).
struct DerivedValues {
    std::vector<Vec3d> colliderPivot;            ///< by collider
    std::vector<double> colliderVoxel;           ///< by collider: its distance field's voxel (0: an analytic shape)
    std::vector<std::optional<Vec3d>> setPivot;  ///< by set; none for a set that does not spin
    /// What sceneWarnings would say of a set's start and a mesh collider's walls, found on the way (not the pairwise
    /// overlap of sets): a run prints them.
    std::vector<std::string> warnings;
    /// What is worth a line but is no warning: a VDB collider's field remade at a coarser voxel (SetupWatch::report
    /// says each as it is found).
    std::vector<std::string> notes;
};

/// Builds the simulation the scene describes. Throws SceneError when a set's shape holds no particle. On
/// several ranks each emitter holds its rank's part of the set's samples (Simulation::distribute then cuts
/// the leaves from every rank's counts); collective on `comm`. `derived`, if given, receives what it derived.
/// What building a simulation says and heeds as it goes (mpm run): a note as each file collider's distance field
/// and each set's sampling starts, and a stop request (the run's signal flag), looked at between them and while a
/// set is sampled, that gives the building up with Interrupted: Ctrl-C during the set-up of millions of particles
/// acts at once, and nothing has been simulated or written yet.
struct SetupWatch {
    std::function<void(const std::string&)> note = [](const std::string&) {};
    /// What building found that is worth a line but is not a phase (a VDB collider's field remade), said as it is found.
    std::function<void(const std::string&)> report = [](const std::string&) {};
    const std::atomic<int>* stop = nullptr;
};
std::unique_ptr<Simulation> buildSimulation(const SceneDesc& scene, const Comm& comm = Comm::single(),
                                            DerivedValues* derived = nullptr, const SetupWatch& watch = {});

/// The distance field a set read from a file holds while it is sampled [bytes], known before it is built: a mesh's
/// from the mesh (read, not converted), a VDB file's from its grid's metadata; 0 for a shape with a formula.
double setFieldBytes(const SetEntry& set);
/// About how many bytes the collider's distance field takes while it is built and used: a mesh's from its surface at
/// the voxel the builder picks (io/LevelSets.h, meshFieldBytes), a VDB file's from its grid's metadata (vdbFieldBytes);
/// 0 for a shape with a formula. Reads the collider's file; a mesh whose field could not fit this machine is refused.
double colliderFieldBytes(const ColliderEntry& collider);

/// What buildSimulation would derive, without building it: the colliders are made and the spinning sets sampled.
DerivedValues deriveValues(const SceneDesc& scene);

/// The scene's resolved JSON with the derived values written in: the scene as it runs, every default stated.
/// Running it gives the same bits as the scene it came from.
std::string resolvedWithDerived(const SceneDesc& scene, const DerivedValues& derived);

}  // namespace mpm
