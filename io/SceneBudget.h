#pragma once
// Budgets before work: what a scene will cost, estimated from its description alone, so that a scene that
// cannot run here (more memory than the machine has, more substeps per frame than allowed, positions
// outside the grid's integer range) fails validation with the estimate and what to change, instead of
// stalling or crashing hours later.
#include <string>
#include <vector>

#include "io/SceneDesc.h"

namespace mpm {

struct SetBudget {
    std::string name;
    long long particles = 0;  ///< per emission
    bool estimated = false;   ///< from the shape's volume, not counted by sampling
    long long emissions = 0;  ///< within the scene's frames
    double mass = 0.0;        ///< per emission [kg]
    double volume = 0.0;      ///< per emission [m^3]
};

struct SceneBudget {
    std::vector<SetBudget> sets;
    double peakParticles = 0.0;                      ///< once every emission is done
    double memoryBytes = 0.0;                        ///< peak, estimated, the colliders' and sets' fields included
    double colliderBytes = 0.0;                      ///< the distance fields of the colliders read from files
    double setFieldBytes = 0.0;                      ///< the largest of a set read from a file (one is held at a time)
    double machineBytes = 0.0;                       ///< the memory this process may use (io/SceneBudget.h, memoryLimit)
    std::string machineHolder = "this machine has";  ///< what sets it, in words
    double substepsPerFrame = 0.0;                   ///< at the start
    double dt = 0.0;                                 ///< the first step
    std::string stepCause;                           ///< what bounds it
    std::string stiffening;             ///< the first set whose material stiffens as it deforms, in words: the step will shorten
    double particleSubsteps = 0.0;      ///< the work of the whole run: each particle's substeps, at the first step's rate
    double runSeconds = 0.0;            ///< the run's expected length on this machine (io/RunEstimate.h); 0: not estimated
    std::string runBasis;               ///< what runSeconds comes from, in words
    std::vector<std::string> problems;  ///< each "/json/path: what is wrong; what to change"
};

/// What memory this process may use: the machine's, or less where a control group caps it (a container, a batch
/// job's slot), and the words that say which.
struct MemoryLimit {
    double bytes = 0.0;
    std::string holder;  ///< "this machine has" or "its control group <path> allows"
};
MemoryLimit memoryLimit();
/// The smallest memory limit of the control group a /proc/<pid>/cgroup text names and of every group above it,
/// read under `root` (/sys/fs/cgroup): cgroup v2's memory.max, or v1's memory/memory.limit_in_bytes. Infinite where
/// none is set; `where` receives the group that sets it.
double cgroupMemoryLimit(const std::string& procCgroup, const std::string& root, std::string& where);
/// The memory this process may use [bytes]: memoryLimit().bytes.
double machineMemoryBytes();
/// Address space this process may still map under its limit (ulimit -v) [bytes]; infinite without a limit.
double addressSpaceLeft();

/// Estimates the scene's cost. With countExactly, sets of up to a few million particles are sampled to count
/// them exactly (validate does; a run, which samples them anyway, does not). On `ranks` processes the memory
/// is rank 0's: its share of the particles and, while it writes a frame or a checkpoint, all of them gathered.
/// `cache`, if given, is the scene's (validate shares its samples and fields with sceneWarnings).
class SetCache;
SceneBudget estimateBudget(const SceneDesc& scene, bool countExactly, int ranks = 1, SetCache* cache = nullptr);
/// The estimate in words, one line per item, for `mpm validate`.
std::string describeBudget(const SceneBudget& budget);
/// Throws SceneError ("FILE: /path: problem") when the budget has problems.
void checkBudget(const SceneDesc& scene, const SceneBudget& budget);

}  // namespace mpm
