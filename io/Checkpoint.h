#pragma once
// Checkpoints: the whole simulation state (core/SimState.h) in one Blosc-compressed file beside the frames,
// written atomically, with a format version, the program version, the frame, the resolved scene and its
// hash, the stats rows so far and a checksum over everything. A run resumed from one continues with the
// same bits an uninterrupted run has, at any thread count.
//
// Layout: "MPMCKPT1", u32 header length, the header (JSON text), the payload (the state's scalars, then per
// species its material, name, parameters and every per-particle array, each array as Blosc chunks), then a
// trailer: u64 checksum of everything before it and "MPMCEND1".
//
// On several ranks with output.rank_files = "per_rank" a checkpoint is a set of parts, one a rank
// ("<scene>_checkpoint_NNNN_rankRRR.mpmc"), each a file of the layout above holding the run's scalars and that
// rank's particles, its header naming the part, the number of parts and the set (a random id shared by the
// parts written together). A set is usable only whole: every part present, of the same set, each verified.
// Nothing passes through one rank, so a run beyond one machine's memory can checkpoint; any rank count
// reads it (docs/distributed.md).
#include <cstdint>
#include <iosfwd>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/SimState.h"

namespace mpm {

/// A checkpoint that cannot be used: missing, truncated, corrupt, or of another format.
class CheckpointError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct CheckpointInfo {
    int format = 0;
    std::string program;  ///< program name and version that wrote it
    std::string sceneName;
    int frame = 0;  ///< frames completed (the next frame written is frame + 1)
    double time = 0.0;
    bool midFrame = false;  ///< written on an interruption inside frame + 1
    std::string sceneHash;  ///< of the scene's identity (sceneIdentity)
    std::string sceneJson;  ///< that identity, to name what changed
    std::string statsCsv;   ///< stats.csv as it was when the checkpoint was written (a set: in part 0 alone)
    int part = 0;           ///< of a set of parts: which one (rank order)
    int parts = 1;          ///< 1: a whole checkpoint
    std::string set;        ///< the set's id (empty for a whole checkpoint)
};

struct Checkpoint {
    CheckpointInfo info;
    SimState state;
};

/// The current checkpoint format, and the oldest this program still reads.
inline constexpr int kCheckpointFormat =
    5;  ///< 3: a species' material by its scene name; 4: elastic F in double; 5: plastic F_E, J_P and water's J in double
inline constexpr int kOldestCheckpointFormat = 2;  ///< 2: continuous emitters' progress; materials by list position

/// Writes `state` atomically to path (io/AtomicFile.h). Throws WriteError.
void writeCheckpoint(const std::string& path, const CheckpointInfo& info, const SimState& state);
/// Reads and verifies a whole checkpoint. Throws CheckpointError naming the file and what is wrong.
Checkpoint readCheckpoint(const std::string& path);
/// The same in memory: a checkpoint's bytes, and the name its errors give (parts' ranks pass the run's
/// scalars to ranks that read no part this way, as a checkpoint without particles).
void encodeCheckpoint(std::ostream& os, const CheckpointInfo& info, const SimState& state);
Checkpoint decodeCheckpoint(std::vector<char> bytes, const std::string& name);
/// Reads only the header (cheap: the payload and its checksum are not read, readCheckpoint verifies them).
CheckpointInfo readCheckpointInfo(const std::string& path);

/// "<dir>/<scene>_checkpoint_NNNN.mpmc", the state after frame NNNN; `inside`: the state of a run stopped inside
/// frame + 1, "<dir>/<scene>_checkpoint_MMMM_inside.mpmc" with MMMM = frame + 1, so that it never replaces the
/// checkpoint written after frame `frame`.
std::string checkpointPath(const std::string& dir, const std::string& scene, int frame, bool inside = false);
/// Part `part` of a set: "<dir>/<scene>_checkpoint_NNNN[_inside]_rankRRR.mpmc"; part -1: the set as a pattern,
/// "..._NNNN_rank*.mpmc" (for messages).
std::string checkpointPartPath(const std::string& dir, const std::string& scene, int frame, int part, bool inside = false);

/// The files of one frame's checkpoint: a whole one, or the part files found (by part number; not yet checked
/// to be one complete set).
struct CheckpointFiles {
    int frame = 0;        ///< the frames done when it was written
    bool inside = false;  ///< written inside frame + 1 (a stopped run): newer than frame's own, older than frame + 1's
    std::string whole;    ///< empty when the frame has none
    std::vector<std::pair<int, std::string>> parts;  ///< (part, path), by part
    /// Every file, whole and parts.
    std::vector<std::string> all() const;
};
/// The checkpoints of exactly this scene in dir, newest first (one stopped inside a frame between that frame's
/// and the one before).
std::vector<CheckpointFiles> listCheckpoints(const std::string& dir, const std::string& scene);
/// The paths of a complete set among `files.parts` (part 0 .. N-1 of one set, N from their headers), or a
/// CheckpointError saying what is missing or mixed. Reads headers only.
std::vector<std::string> completeSet(const CheckpointFiles& files);
/// Appends b's particles to a's, species by species (a and b of one run: same species in the same order).
void appendSpecies(SimState& a, SimState&& b);

/// The part of a resolved scene that decides the results: everything but `output` and `simulation/threads`,
/// as canonical JSON text; and its hash.
std::string sceneIdentity(const std::string& resolvedJson);
std::string sceneHash(const std::string& identity);
/// The JSON paths at which two identities differ ("/sets/0/velocity: [0,0,0] -> [1,0,0]"), at most `limit`.
std::vector<std::string> sceneDifferences(const std::string& before, const std::string& after, std::size_t limit = 8);

}  // namespace mpm
