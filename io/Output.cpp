#include "io/Output.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <regex>

#include "io/AtomicFile.h"
#include "io/PlyWriter.h"
#include "io/VdbWriter.h"

namespace fs = std::filesystem;

namespace mpm {

FrameWriter::FrameWriter(const SceneDesc& scene, const std::string& directory) : scene_(scene), dir_(directory) {
    fs::create_directories(dir_);
    // Files of an earlier run of this scene: <scene>_NNNN.vdb, <scene>_points_NNNN.vdb, <scene>_NNNN.ply, ...
    const std::regex old("^" + std::regex_replace(scene.name, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                         R"(_(points_)?[A-Za-z0-9_]*\d{4}\.(vdb|ply)$)");
    for (const auto& e : fs::directory_iterator(dir_))
        if (e.is_regular_file() && std::regex_match(e.path().filename().string(), old)) {
            fs::remove(e.path());
            ++removed_;
        }
    csv_ = FrameStats::csvHeader() + "\n";
    writeTextAtomically(dir_ + "/stats.csv", csv_);
    writeTextAtomically(dir_ + "/scene.json", scene.resolvedJson + "\n");
}

std::string FrameWriter::framePath(int frame, const char* suffix, const char* ext) const {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%04d", frame);
    return dir_ + "/" + scene_.name + "_" + suffix + buf + ext;
}

void FrameWriter::recordStats(const FrameStats& stats) {
    csv_ += stats.csvRow() + "\n";
    writeTextAtomically(dir_ + "/stats.csv", csv_);
}

void FrameWriter::writeFrame(int frame, const Simulation& sim, const FrameStats& stats) {
    const auto start = std::chrono::steady_clock::now();
    const OutputDesc& o = scene_.output;
    const std::vector<AnySpecies>& species = sim.species();
    VdbFrameRequest r;
    r.volumePath = framePath(frame);
    if (o.splitFiles) r.pointsPath = framePath(frame, "points_");
    r.points = o.points;
    r.surface = o.surface;
    r.density = o.density;
    r.velocity = o.velocity;
    r.pointVoxelSize = sim.settings().dx;
    // The surface resolves the particle spacing; the sphere radius is a multiple of it.
    double particlesPerCell = 8.0;
    if (!scene_.sets.empty()) particlesPerCell = scene_.sets.front().particlesPerCell;
    const double spacing = sim.settings().dx / std::cbrt(particlesPerCell);
    r.surfaceVoxelSize = spacing;
    r.surfaceRadius = o.surfaceRadius * spacing;
    for (std::size_t s = 0; s < species.size(); ++s) {
        const std::string& mat = scene_.materialNames[s];
        int index = 0;
        for (std::size_t m = 0; m < materialPresetNames().size(); ++m)
            if (materialPresetNames()[m] == mat) index = int(m);
        r.materialOfSpecies.push_back(index);
    }
    r.materialNames = materialPresetNames();
    for (const ParticleSetDesc& d : scene_.sets) r.setNames.push_back(d.name);
    if (o.surfaceGroup == "all") {
        SurfaceGroup g{"surface", {}};
        for (std::size_t s = 0; s < species.size(); ++s) g.species.push_back(int(s));
        r.surfaces.push_back(g);
    } else {
        for (std::size_t s = 0; s < species.size(); ++s) {
            const std::string key = o.surfaceGroup == "set" ? scene_.sets[s].name : scene_.materialNames[s];
            auto it = std::find_if(r.surfaces.begin(), r.surfaces.end(), [&](const SurfaceGroup& g) { return g.gridName == "surface_" + key; });
            if (it == r.surfaces.end()) r.surfaces.push_back(SurfaceGroup{"surface_" + key, {int(s)}});
            else it->species.push_back(int(s));
        }
    }
    if (o.points || o.surface || o.density || o.velocity) writeVdbFrame(r, species);
    if (o.ply) writePly(framePath(frame, "", ".ply"), species);
    lastWrite_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    recordStats(stats);
}

}  // namespace mpm
