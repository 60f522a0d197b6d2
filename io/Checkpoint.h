#pragma once
// Checkpoints: the whole simulation state (core/SimState.h) in one Blosc-compressed file beside the frames,
// written atomically, with a format version, the program version, the frame, the resolved scene and its
// hash, the stats rows so far and a checksum over everything. A run resumed from one continues with the
// same bits an uninterrupted run has, at any thread count.
//
// Layout: "MPMCKPT1", u32 header length, the header (JSON text), the payload (the state's scalars, then per
// species its material, name, parameters and every per-particle array, each array as Blosc chunks), then a
// trailer: u64 checksum of everything before it and "MPMCEND1".
#include <cstdint>
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
    std::string program;     ///< program name and version that wrote it
    std::string sceneName;
    int frame = 0;           ///< frames completed (the next frame written is frame + 1)
    double time = 0.0;
    bool midFrame = false;   ///< written on an interruption inside frame + 1
    std::string sceneHash;   ///< of the scene's identity (sceneIdentity)
    std::string sceneJson;   ///< that identity, to name what changed
    std::string statsCsv;    ///< stats.csv as it was when the checkpoint was written
};

struct Checkpoint {
    CheckpointInfo info;
    SimState state;
};

/// The current checkpoint format.
inline constexpr int kCheckpointFormat = 2;  ///< 2: continuous emitters' progress

/// Writes `state` atomically to path (io/AtomicFile.h). Throws WriteError.
void writeCheckpoint(const std::string& path, const CheckpointInfo& info, const SimState& state);
/// Reads and verifies a whole checkpoint. Throws CheckpointError naming the file and what is wrong.
Checkpoint readCheckpoint(const std::string& path);
/// Reads and verifies only the header (cheap): for listing.
CheckpointInfo readCheckpointInfo(const std::string& path);

/// "<dir>/<scene>_checkpoint_NNNN.mpmc".
std::string checkpointPath(const std::string& dir, const std::string& scene, int frame);
/// The checkpoints of exactly this scene in dir, as (frame, path), newest first.
std::vector<std::pair<int, std::string>> listCheckpoints(const std::string& dir, const std::string& scene);

/// The part of a resolved scene that decides the results: everything but `output` and `simulation/threads`,
/// as canonical JSON text; and its hash.
std::string sceneIdentity(const std::string& resolvedJson);
std::string sceneHash(const std::string& identity);
/// The JSON paths at which two identities differ ("/sets/0/velocity: [0,0,0] -> [1,0,0]"), at most `limit`.
std::vector<std::string> sceneDifferences(const std::string& before, const std::string& after, std::size_t limit = 8);

}  // namespace mpm
