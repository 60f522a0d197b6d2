#include "io/Output.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include <nlohmann/json.hpp>

#include "io/AtomicFile.h"
#include "io/PlyWriter.h"

namespace mpm {

namespace {
/// The surface grids: one of all species, or one per material or per set.
std::vector<SurfaceGroup> surfaceGroups(const std::string& grouping, const SpeciesLayout& layout) {
    std::vector<SurfaceGroup> groups;
    const std::size_t species = layout.setOfSpecies.size();
    if (grouping == "all") {
        SurfaceGroup g{"surface", {}};
        for (std::size_t s = 0; s < species; ++s) g.species.push_back(int(s));
        return {g};
    }
    for (std::size_t s = 0; s < species; ++s) {
        const std::string key =
            grouping == "set" ? layout.setNames[layout.setOfSpecies[s]] : materialSceneNames()[layout.materialOfSpecies[s]];
        auto it =
            std::find_if(groups.begin(), groups.end(), [&](const SurfaceGroup& g) { return g.gridName == "surface_" + key; });
        if (it == groups.end())
            groups.push_back(SurfaceGroup{"surface_" + key, {int(s)}});
        else
            it->species.push_back(int(s));
    }
    return groups;
}
}  // namespace

FrameWriter::FrameWriter(const SceneDesc& scene, const SpeciesLayout& layout, const std::string& directory, int part)
    : name_(scene.name),
      output_(scene.output),
      layout_(layout),
      surfaces_(surfaceGroups(scene.output.surfaceGroup, layout)),
      attributes_(PointAttributes::of(scene.output.attributes)),
      dir_(directory),
      part_(part) {
    configure(scene);
}

FrameWriter FrameWriter::partWriter(const SceneDesc& scene, const SpeciesLayout& layout, const std::string& directory, int part) {
    return FrameWriter(scene, layout, directory, part);
}

void FrameWriter::configure(const SceneDesc& scene) {
    for (std::size_t i = 0; i < scene.colliders.size(); ++i)
        if (scene.colliders[i].dynamic.enabled) bodyColliders_.push_back(int(i)), bodyNames_.push_back(scene.colliders[i].name);
    bodies_ = bodyColliders_.size();
    for (const ParticleSetDesc& d : scene.sets) attributes_.setColours.push_back(d.colour);
    // The surface resolves the particle spacing of the first set; the sphere radius is a multiple of it.
    const double particlesPerCell = scene.sets.empty() ? 8.0 : scene.sets.front().particlesPerCell;
    particleSpacing_ = scene.settings.dx / std::cbrt(particlesPerCell);
}

std::map<int, std::string> statsRows(const std::string& csv) {
    std::map<int, std::string> rows;
    std::istringstream in(csv);
    std::string line;
    std::getline(in, line);  // the header
    while (std::getline(in, line)) {
        try {
            rows[std::stoi(line.substr(0, line.find(',')))] = line;
        } catch (const std::exception&) {
            // Not a row of ours: nothing to keep.
        }
    }
    return rows;
}

std::string bodiesCsv(const std::string& statsCsv, const std::vector<int>& colliders, const std::vector<std::string>& names) {
    std::string out = "frame,time,body,collider,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz,name\n";
    const std::size_t numbers = RigidBodyState::kDoubles * colliders.size();
    std::istringstream in(statsCsv);
    std::string line;
    std::getline(in, line);  // the header
    while (std::getline(in, line)) {
        // The bodies' numbers end the row (no quoted field among them); frame and time lead it.
        std::vector<std::string> tail(numbers);
        std::size_t end = line.size();
        bool whole = true;
        for (std::size_t n = numbers; n-- > 0 && whole;) {
            const std::size_t comma = end > 0 ? line.rfind(',', end - 1) : std::string::npos;
            if (comma == std::string::npos)
                whole = false;
            else
                tail[n] = line.substr(comma + 1, end - comma - 1), end = comma;
        }
        const std::size_t first = line.find(','), second = line.find(',', first + 1);
        if (!whole || second == std::string::npos) continue;
        const std::string lead = line.substr(0, second);
        for (std::size_t k = 0; k < colliders.size(); ++k) {
            out += lead + "," + std::to_string(k) + "," + std::to_string(colliders[k]);
            for (std::size_t c = 0; c < RigidBodyState::kDoubles; ++c) out += "," + tail[k * RigidBodyState::kDoubles + c];
            out += "," + csvField(names[k]) + "\n";
        }
    }
    return out;
}

void FrameWriter::writeStats() {
    std::string text = csv_;
    if (!kept_.empty()) {
        std::map<int, std::string> rows = statsRows(csv_);
        for (const auto& [frame, row] : kept_) rows[frame] = row;
        text = FrameStats::csvHeader(bodies_) + "\n";
        for (const auto& [frame, row] : rows) text += row + "\n";
    }
    writeTextAtomically(dir_ + "/stats.csv", text);
    if (bodies_ > 0) writeTextAtomically(dir_ + "/bodies.csv", bodiesCsv(text, bodyColliders_, bodyNames_));
}

FrameWriter::FrameWriter(const SceneDesc& scene, const SpeciesLayout& layout, const std::string& directory,
                         const std::string& statsSoFar, std::map<int, std::string> kept)
    : FrameWriter(scene, layout, directory, -1) {
    kept_ = std::move(kept);
    std::error_code ec;
    std::filesystem::create_directories(dir_, ec);
    if (ec) throw WriteError(dir_, "cannot create the output directory: " + ec.message());
    csv_ = statsSoFar.empty() ? FrameStats::csvHeader(bodies_) + "\n" : statsSoFar;
    writeStats();
    // The resolved scene, and where it came from (the render tool finds the colliders' meshes through it).
    writeTextAtomically(dir_ + "/scene.json", withSceneFile(scene.resolvedJson, scene.file) + "\n");
}

std::string withSceneFile(const std::string& resolvedJson, const std::string& file) {
    nlohmann::ordered_json resolved = nlohmann::ordered_json::parse(resolvedJson);
    std::error_code absError;
    const std::filesystem::path source = std::filesystem::absolute(file, absError);
    resolved["scene_file"] = absError ? file : source.lexically_normal().string();
    return resolved.dump(2);
}

std::string FrameWriter::framePath(int frame, const char* suffix, const char* ext) const {
    char buf[48];
    if (part_ >= 0)
        std::snprintf(buf, sizeof(buf), "%04d_rank%03d", frame, part_);
    else
        std::snprintf(buf, sizeof(buf), "%04d", frame);
    return dir_ + "/" + name_ + "_" + suffix + buf + ext;
}

void FrameWriter::recordStats(const FrameStats& stats) {
    csv_ += stats.csvRow() + "\n";
    writeStats();
}

void FrameWriter::writeFrame(int frame, const Simulation& sim, const FrameStats& stats) {
    writeFrame(frame, sim.species(), sim.settings().dx, stats);
}

void FrameWriter::writeFrame(int frame, const std::vector<AnySpecies>& species, double dx, const FrameStats& stats) {
    const auto start = std::chrono::steady_clock::now();
    const OutputDesc& o = output_;
    VdbFrameRequest r;
    r.volumePath = framePath(frame);
    if (o.splitFiles) r.pointsPath = framePath(frame, "points_");
    r.points = o.points;
    r.surface = o.surface;
    r.density = o.density;
    r.velocity = o.velocity;
    r.pointVoxelSize = dx;
    r.surfaceVoxelSize = particleSpacing_;
    r.surfaceRadius = o.surfaceRadius * particleSpacing_;
    r.surfaceDilate = o.surfaceDilate;  // voxels: the surface voxel is the particle spacing
    r.surfaceErode = o.surfaceErode;
    r.surfaceSmooth = o.surfaceSmooth;
    r.surfaces = surfaces_;
    r.materialNames = materialSceneNames();
    r.setNames = layout_.setNames;
    // The bodies go into the whole frame, or rank 0's part of it.
    if (part_ <= 0 && stats.bodies.size() == bodyColliders_.size())
        for (std::size_t k = 0; k < stats.bodies.size(); ++k) {
            const RigidBodyState& b = stats.bodies[k];
            const Eigen::Quaterniond& q = b.orientation;
            r.bodies.x.push_back(b.centre);
            r.bodies.orient.push_back({float(q.x()), float(q.y()), float(q.z()), float(q.w())});
            r.bodies.v.push_back(b.velocity.cast<float>());
            r.bodies.w.push_back(b.spin.cast<float>());
            r.bodies.collider.push_back(bodyColliders_[k]);
            r.bodies.name.push_back(bodyNames_[k]);
        }
    const PointCloud cloud = gatherPoints(species, layout_.materialOfSpecies, attributes_);
    if (o.points || o.surface || o.density || o.velocity) writeVdbFrame(r, cloud);
    if (o.ply) writePly(framePath(frame, "", ".ply"), cloud, materialSceneNames());
    lastWrite_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (part_ < 0) recordStats(stats);
}

}  // namespace mpm
