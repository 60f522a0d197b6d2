#pragma once
// Everything a run writes into its output directory: per-frame VDB (and optionally PLY) files,
// stats.csv (one row per frame) and scene.json (the resolved scene). All files are written atomically.
#include <map>
#include <string>
#include <vector>

#include "core/Diagnostics.h"
#include "core/Simulation.h"
#include "io/SceneBuilder.h"
#include "io/SceneDesc.h"
#include "io/VdbWriter.h"

namespace mpm {

class FrameWriter {
public:
    /// Writes scene.json and stats.csv (starting from statsSoFar, a resumed run's rows, or the header alone) into
    /// the directory, made if need be. Removes nothing: clearing an earlier run is the caller's decision (io/Run.h).
    /// Keeps its own copy of what it needs of the scene.
    /// `kept`: rows of an earlier stats.csv (by frame) that stay as they are, in the file beside the rows written
    /// (a run of part of a scene, --frames, replaces only its own frames' rows).
    FrameWriter(const SceneDesc& scene, const SpeciesLayout& layout, const std::string& directory,
                const std::string& statsSoFar = "", std::map<int, std::string> kept = {});
    /// A writer of rank `part`'s part files (output.rank_files = "per_rank"): frames only, no stats.csv or
    /// scene.json (rank 0's ordinary writer keeps those).
    static FrameWriter partWriter(const SceneDesc& scene, const SpeciesLayout& layout, const std::string& directory, int part);

    /// Writes frame files for the current state and appends the stats row (a part writer: the files only).
    void writeFrame(int frame, const Simulation& sim, const FrameStats& stats);
    /// The same for particles given apart (a run on several ranks gathers them first); dx is the grid's.
    void writeFrame(int frame, const std::vector<AnySpecies>& species, double dx, const FrameStats& stats);
    /// Bookkeeping rows only (frames outside the requested output range).
    void recordStats(const FrameStats& stats);

    const std::string& directory() const { return dir_; }
    /// stats.csv as written so far (a checkpoint keeps it).
    const std::string& statsCsv() const { return csv_; }
    std::string framePath(int frame, const char* suffix = "", const char* ext = ".vdb") const;
    double lastWriteSeconds() const { return lastWrite_; }

private:
    std::string name_;
    OutputDesc output_;
    SpeciesLayout layout_;
    std::vector<SurfaceGroup> surfaces_;
    PointAttributes attributes_;          ///< Cd per set and the extra attributes asked for
    double particleSpacing_ = 0.0;        ///< what the surface resolves
    std::size_t bodies_ = 0;              ///< dynamic colliders: their columns in stats.csv
    std::vector<int> bodyColliders_;      ///< each body's collider, by its index in the scene's list
    std::vector<std::string> bodyNames_;  ///< and its name
    std::string dir_;
    std::string csv_;
    std::map<int, std::string> kept_;
    double lastWrite_ = 0;
    int part_ = -1;  ///< the rank whose part files this writes; -1: whole frames
    FrameWriter(const SceneDesc& scene, const SpeciesLayout& layout, const std::string& directory, int part);
    void configure(const SceneDesc& scene);
    /// Writes stats.csv: the rows written, with the kept rows in place of theirs and after them; and, where the scene
    /// has rigid bodies, bodies.csv from the same rows.
    void writeStats();
};

/// bodies.csv made from stats.csv's text: for each frame row and body k, "frame,time,body,collider," and the 13
/// numbers of its body<k>_* columns (x, y, z, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz), then its name; `colliders[k]`
/// is body k's index in the scene's collider list, `names[k]` its collider's name.
std::string bodiesCsv(const std::string& statsCsv, const std::vector<int>& colliders, const std::vector<std::string>& names);

/// A resolved scene's JSON (every default stated) with `scene_file`, the absolute path of the scene `file` it came
/// from, as a run's scene.json and `mpm validate --print-scene` give it: run from anywhere, it finds its assets
/// beside that file and names its frames after it. Not part of the scene's identity.
std::string withSceneFile(const std::string& resolvedJson, const std::string& file);

/// The rows of a stats.csv by frame, the header left out (an empty map for a missing or empty file).
std::map<int, std::string> statsRows(const std::string& csv);

}  // namespace mpm
