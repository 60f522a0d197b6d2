#pragma once
// Everything a run writes into its output directory: per-frame VDB (and optionally PLY) files,
// stats.csv (one row per frame) and scene.json (the resolved scene). All files are written atomically.
#include <string>
#include <vector>

#include "core/Diagnostics.h"
#include "core/Simulation.h"
#include "io/Scene.h"

namespace mpm {

class FrameWriter {
public:
    /// Creates the directory. Frames of an earlier run of the same scene are removed (and reported in
    /// removedFiles()), so old and new frames never mix.
    FrameWriter(const SceneDesc& scene, const std::string& directory);

    /// Writes frame files for the current state and appends the stats row.
    void writeFrame(int frame, const Simulation& sim, const FrameStats& stats);
    /// Bookkeeping rows only (frames outside the requested output range).
    void recordStats(const FrameStats& stats);

    const std::string& directory() const { return dir_; }
    int removedFiles() const { return removed_; }
    std::string framePath(int frame, const char* suffix = "", const char* ext = ".vdb") const;
    double lastWriteSeconds() const { return lastWrite_; }

private:
    const SceneDesc& scene_;
    std::string dir_;
    std::string csv_;
    int removed_ = 0;
    double lastWrite_ = 0;
};

}  // namespace mpm
