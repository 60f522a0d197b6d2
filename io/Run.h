#pragma once
// A run of a scene into an output directory, safe with the user's data:
//  - one run per directory (io/DirectoryLock.h); temporary files of an earlier killed run are removed;
//  - a fresh run removes exactly this scene's frames and checkpoints, never another scene's;
//  - checkpoints every output.checkpoint_every frames (io/Checkpoint.h), the newest output.checkpoints_kept
//    kept; `resume` continues from the newest valid one, with the bits an uninterrupted run has;
//  - `--frames A:B` writes only frames A..B, deletes nothing, and starts from a checkpoint before A if any;
//  - a stop request (a signal) stops at the next substep boundary, writes a checkpoint and throws Interrupted.
#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include "core/Stability.h"  // Interrupted
#include "io/Checkpoint.h"
#include "io/DirectoryLock.h"
#include "io/Output.h"
#include "io/SceneBuilder.h"
#include "io/SceneDesc.h"

namespace mpm {

struct RunOptions {
    std::string outDir;        ///< empty: the scene's output.directory
    int firstFrame = 0;        ///< the frames written are firstFrame .. lastFrame
    int lastFrame = -1;        ///< -1: the scene's last frame
    bool framesGiven = false;  ///< --frames: write only those, delete nothing
    bool resume = false;       ///< continue from the newest valid checkpoint
    bool force = false;        ///< resume even when the scene changed since the checkpoint
};

/// What the front end is told while the run goes.
struct RunEvents {
    std::function<void(const std::string&)> note = [](const std::string&) {};
    std::function<void(const std::string&)> warning = [](const std::string&) {};
    /// After each frame: the frame, the last frame, its stats and the seconds its files took to write.
    std::function<void(int, int, const FrameStats&, double)> frameDone = [](int, int, const FrameStats&, double) {};
    /// A stop request (the signal flag) heeded during the set-up too: set while the sets are sampled, it ends the
    /// constructor with SetupInterrupted before any old output is touched. On ranks the set-up runs to its end
    /// (a rank that gave up alone would leave the others waiting), and the run stops at its first substep.
    const std::atomic<int>* stop = nullptr;
};

/// A stop asked for during the set-up: nothing was simulated, written or removed; `phase` says what was under way.
class SetupInterrupted : public Interrupted {
public:
    explicit SetupInterrupted(std::string phase) : phase(std::move(phase)) {}
    std::string phase;
};

class SceneRun {
public:
    /// Reads and checks the scene (SceneError), takes the directory (LockError, WriteError), cleans up after an
    /// earlier run and picks where to start (a checkpoint or frame 0).
    SceneRun(const std::string& scenePath, RunOptions options, RunEvents events);
    ~SceneRun();

    /// Simulates and writes the remaining frames. While *stop is nonzero the run stops at the next substep
    /// boundary, writes a checkpoint and throws Interrupted.
    void run(const std::atomic<int>* stop);

    const SceneDesc& scene() const { return scene_; }
    const Simulation& simulation() const { return *sim_; }
    const std::string& directory() const { return dir_; }
    int startFrame() const { return start_; }
    int lastFrame() const { return last_; }
    /// The checkpoint written last (empty when none was).
    const std::string& lastCheckpoint() const { return lastCheckpoint_; }

private:
    /// Runs f; an allocation that fails inside becomes an error saying what was being done, with the particle
    /// count and the scene's memory estimate against the machine's.
    template <class F>
    void guarded(const std::string& what, F&& f);
    void chooseStart();
    /// Spreads the simulation over the ranks (Simulation::distribute).
    void spread();
    /// Frame `frame`'s files (when `write`; else its stats row only): gathered, per rank, or one process's.
    void writeFrame(int frame, const FrameStats& stats, bool write);
    /// Reads frame `files.frame`'s checkpoint (whole, or this rank's parts of a set: then `share`), or warns
    /// why it cannot be used and returns false (every rank alike). `path` names it in notes.
    bool readCheckpointOf(const CheckpointFiles& files, Checkpoint& c, bool& share, std::string& path);
    /// Whether the directory holds any checkpoint file of this scene that --resume (or --frames A:B) could start
    /// from, usable or not; and the message when none is usable.
    bool anyCheckpointToResume() const;
    std::string nothingToResume() const;
    void saveCheckpoint();
    /// Refuses a scene whose name makes file names longer than the output directory's file system takes (exit 2).
    void refuseNamesTooLong() const;
    void refuseAnotherScenesDirectory() const;
    bool supersededCheckpoint(int frame) const;
    /// Rank 0's part of saveCheckpoint: the file, and the older ones removed.
    void writeCheckpointFiles(const SimState& state);
    /// output.rank_files = "per_rank" on several ranks: each rank writes its part of the set, nothing gathered.
    void saveCheckpointParts();
    /// After a checkpoint of `state` was written (whole: parts = 0, else as that many parts): removes what it replaces
    /// and what it makes old (a stopped run's checkpoint before it; those after frames beyond checkpoints_kept).
    void rotateCheckpoints(const SimState& state, int parts);
    CheckpointInfo checkpointInfo(const SimState& state, bool withStats) const;
    void removeStaleTemporaries();
    void removeOldOutputs();
    /// On several ranks: how the particles ended up spread, the re-cuts and the traffic (a note).
    void reportRanks();

    SceneDesc scene_;
    /// What the scene was estimated to need (for the message when an allocation fails: made before, as then
    /// there may be no memory to estimate it).
    double neededBytes_ = 0.0, machineBytes_ = 0.0;
    std::string machineHolder_ = "this machine has";  ///< what sets machineBytes_, in words
    RunOptions options_;
    RunEvents events_;
    std::string dir_;
    std::unique_ptr<DirectoryLock> lock_;
    std::unique_ptr<Simulation> sim_;
    /// The sets' samples this rank held after sampling, and how many the sets have in all (the closing note).
    long long heldSamples_ = 0, setSamples_ = 0;
    SpeciesLayout layout_;
    std::unique_ptr<FrameWriter> writer_;      ///< rank 0's (every process's, alone): frames and stats.csv
    std::unique_ptr<FrameWriter> partWriter_;  ///< each rank's part files (output.rank_files = "per_rank")
    std::string identity_, hash_, statsSoFar_, lastCheckpoint_;
    int start_ = 0, last_ = 0;
    bool restored_ = false;  ///< started from a checkpoint
};

}  // namespace mpm
