// Scene reading with nlohmann::json. A Node walks one JSON object, remembers its path for errors, records
// every value it hands out (defaults included) into the resolved scene, and rejects keys nobody read.
#include "io/Scene.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <set>
#include <sstream>

#include "io/Sampling.h"

namespace mpm {

using json = nlohmann::ordered_json;

namespace {

std::string joinNames(const std::vector<std::string>& v) {
    std::string out;
    for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + v[i];
    return out;
}

class Node {
public:
    Node(const json& in, json& out, std::string path, const std::string& file) : in_(in), out_(out), path_(std::move(path)), file_(file) {
        if (!in_.is_object()) fail("", "expected an object");
    }

    [[noreturn]] void fail(const std::string& key, const std::string& what) const {
        throw SceneError(file_ + ": " + (path_.empty() && key.empty() ? "/" : path_ + (key.empty() ? "" : "/" + key)) + ": " + what);
    }
    const std::string& path() const { return path_; }
    const std::string& file() const { return file_; }
    bool has(const char* key) const { return in_.contains(key); }

    double number(const char* key, double def, double lo, double hi, const char* unit = "") {
        double v = def;
        if (const json* j = take(key)) {
            if (!j->is_number()) fail(key, "expected a number, got " + j->dump());
            v = j->get<double>();
            if (!std::isfinite(v) || v < lo || v > hi) {
                std::ostringstream s;
                s << "value " << v << " out of range; allowed: " << lo << " to " << hi << (*unit ? " " : "") << unit;
                fail(key, s.str());
            }
        }
        out_[key] = v;
        return v;
    }
    long long integer(const char* key, long long def, long long lo, long long hi) {
        long long v = def;
        if (const json* j = take(key)) {
            if (!j->is_number_integer()) fail(key, "expected an integer, got " + j->dump());
            v = j->get<long long>();
            if (v < lo || v > hi) fail(key, "value " + std::to_string(v) + " out of range; allowed: " + std::to_string(lo) + " to " + std::to_string(hi));
        }
        out_[key] = v;
        return v;
    }
    bool boolean(const char* key, bool def) {
        bool v = def;
        if (const json* j = take(key)) {
            if (!j->is_boolean()) fail(key, "expected true or false, got " + j->dump());
            v = j->get<bool>();
        }
        out_[key] = v;
        return v;
    }
    std::string string(const char* key, const std::string& def) {
        std::string v = def;
        if (const json* j = take(key)) {
            if (!j->is_string()) fail(key, "expected a string, got " + j->dump());
            v = j->get<std::string>();
        }
        out_[key] = v;
        return v;
    }
    std::string choice(const char* key, const std::string& def, const std::vector<std::string>& allowed, const char* what = "value") {
        const std::string v = string(key, def);
        for (const std::string& a : allowed)
            if (a == v) return v;
        fail(key, std::string("unknown ") + what + " \"" + v + "\"; known: " + joinNames(allowed));
    }
    std::string required(const char* key) {
        if (!has(key)) fail(key, "missing required field");
        return string(key, "");
    }
    Vec3d vec3(const char* key, const Vec3d& def, bool require = false) {
        Vec3d v = def;
        if (require && !has(key)) fail(key, "missing required field (a list of 3 numbers)");
        if (const json* j = take(key)) {
            if (!j->is_array() || j->size() != 3) fail(key, "expected a list of 3 numbers, got " + j->dump());
            for (int i = 0; i < 3; ++i) {
                if (!(*j)[i].is_number()) fail(key, "expected a list of 3 numbers, got " + j->dump());
                v[i] = (*j)[i].get<double>();
                if (!std::isfinite(v[i])) fail(key, "non-finite component");
            }
        }
        out_[key] = {v[0], v[1], v[2]};
        return v;
    }
    Node child(const char* key) {
        static const json empty = json::object();
        const json* j = take(key);
        out_[key] = json::object();
        return Node(j ? *j : empty, out_[key], path_ + "/" + key, file_);
    }
    std::vector<Node> array(const char* key) {
        std::vector<Node> out;
        out_[key] = json::array();
        const json* j = take(key);
        if (!j) return out;
        if (!j->is_array()) fail(key, "expected a list of objects");
        for (std::size_t i = 0; i < j->size(); ++i) out_[key].push_back(json::object());
        for (std::size_t i = 0; i < j->size(); ++i)
            out.emplace_back((*j)[i], out_[key][i], path_ + "/" + key + "/" + std::to_string(i), file_);
        return out;
    }
    /// Unknown keys are errors: a typo must not silently fall back to a default.
    void finish() const {
        for (auto it = in_.begin(); it != in_.end(); ++it)
            if (!read_.count(it.key())) {
                std::vector<std::string> known(read_.begin(), read_.end());
                for (const std::string& k : extraKnown_) known.push_back(k);
                fail(it.key(), "unknown key; known here: " + joinNames(knownKeys_.empty() ? known : knownKeys_));
            }
    }
    /// Declares every key this object accepts, for the unknown-key message.
    void expect(std::vector<std::string> keys) { knownKeys_ = std::move(keys); }

private:
    const json* take(const char* key) {
        read_.insert(key);
        auto it = in_.find(key);
        return it == in_.end() ? nullptr : &*it;
    }
    const json& in_;
    json& out_;
    std::string path_;
    const std::string& file_;
    std::set<std::string> read_;
    std::vector<std::string> knownKeys_, extraKnown_;
};

constexpr double kHuge = 1e12;
constexpr double kTiny = 1e-12;

/// Defaults of the elastic presets (thesis Fig. 6.1): E and nu per model.
template <class M> struct ElasticDefaults;
template <> struct ElasticDefaults<FixedCorotated> { static constexpr double E = 1.4e5, nu = 0.2; };
template <> struct ElasticDefaults<NeoHookean> { static constexpr double E = 1.4e5, nu = 0.2; };
template <> struct ElasticDefaults<Snow> { static constexpr double E = 1.4e5, nu = 0.2; };
template <> struct ElasticDefaults<Sand> { static constexpr double E = 3.537e7, nu = 0.2; };

/// Reads density, Young's modulus and Poisson's ratio (plus the model's own keys) into a species.
template <class M>
AnySpecies elastic(Node& n, const ParticleSetDesc& set, float& density, std::vector<std::string> extraKeys,
                   const std::function<void(Node&, typename M::Params&)>& extra = {}) {
    std::vector<std::string> keys = {"density", "youngs_modulus", "poisson_ratio"};
    keys.insert(keys.end(), extraKeys.begin(), extraKeys.end());
    n.expect(keys);
    Species<M> s;
    typename M::Params& p = s.params;
    p.density = float(n.number("density", p.density, kTiny, kHuge, "kg/m^3"));
    const double E = n.number("youngs_modulus", ElasticDefaults<M>::E, 0.0, 1e15, "Pa");
    const double nu = n.number("poisson_ratio", ElasticDefaults<M>::nu, 0.0, 0.49);
    const Lame l = Lame::fromYoung(E, nu);
    p.mu = float(l.mu * set.muScale);
    p.lambda = float(l.lambda * set.lambdaScale);
    if (extra) extra(n, p);
    density = p.density;
    return AnySpecies(std::move(s));
}

/// A material preset reads its parameter overrides and builds a species for one particle set.
struct Preset {
    std::string name;
    std::function<AnySpecies(Node&, const ParticleSetDesc&, float& density)> make;
};

const std::vector<Preset>& presets() {
    static const std::vector<Preset> table = {
        {"water",
         [](Node& n, const ParticleSetDesc& set, float& density) {
             n.expect({"density", "bulk_modulus", "gamma", "tension"});
             Species<Water> s;
             Water::Params& p = s.params;
             p.density = float(n.number("density", p.density, kTiny, kHuge, "kg/m^3"));
             // lambda_scale scales the bulk modulus, water's only Lame-like parameter.
             p.bulkModulus = float(n.number("bulk_modulus", p.bulkModulus, 0.0, kHuge, "Pa") * set.lambdaScale);
             p.gamma = float(n.number("gamma", p.gamma, 1.0, 20.0));
             p.tension = n.boolean("tension", p.tension);
             density = p.density;
             return AnySpecies(std::move(s));
         }},
        {"jelly", [](Node& n, const ParticleSetDesc& set, float& density) { return elastic<FixedCorotated>(n, set, density, {}); }},
        {"rubber", [](Node& n, const ParticleSetDesc& set, float& density) { return elastic<NeoHookean>(n, set, density, {}); }},
        {"snow",
         [](Node& n, const ParticleSetDesc& set, float& density) {
             return elastic<Snow>(n, set, density, {"theta_c", "theta_s", "xi"}, [](Node& n, Snow::Params& p) {
                 p.thetaC = float(n.number("theta_c", p.thetaC, 0.0, 1.0));
                 p.thetaS = float(n.number("theta_s", p.thetaS, 0.0, 10.0));
                 p.xi = float(n.number("xi", p.xi, 0.0, 100.0));
             });
         }},
        {"sand",
         [](Node& n, const ParticleSetDesc& set, float& density) {
             return elastic<Sand>(n, set, density, {"h0", "h1", "h2", "h3", "volume_correction"}, [](Node& n, Sand::Params& p) {
                 p.h0 = float(n.number("h0", p.h0, 0.0, 89.0, "degrees"));
                 p.h1 = float(n.number("h1", p.h1, -89.0, 89.0, "degrees"));
                 p.h2 = float(n.number("h2", p.h2, 0.0, 1e3));
                 p.h3 = float(n.number("h3", p.h3, -89.0, 89.0, "degrees"));
                 p.volumeCorrection = n.boolean("volume_correction", p.volumeCorrection);
             });
         }},
    };
    return table;
}

ShapeDesc readShape(Node n) {
    ShapeDesc s;
    const std::string type = n.choice("type", "box", {"box", "sphere"}, "shape");
    if (type == "box") {
        n.expect({"type", "min", "max"});
        s.kind = ShapeDesc::Kind::Box;
        s.min = n.vec3("min", Vec3d::Zero(), true);
        s.max = n.vec3("max", Vec3d::Zero(), true);
        if ((s.max - s.min).minCoeff() <= 0) n.fail("max", "must exceed min in every axis");
    } else {
        n.expect({"type", "center", "radius"});
        s.kind = ShapeDesc::Kind::Sphere;
        s.centre = n.vec3("center", Vec3d::Zero(), true);
        if (!n.has("radius")) n.fail("radius", "missing required field");
        s.radius = n.number("radius", 0.0, kTiny, kHuge, "m");
    }
    n.finish();
    return s;
}

Boundary readBoundary(Node& n) {
    const std::string b = n.choice("boundary", "slip", {"sticky", "slip", "separate"}, "boundary");
    return b == "sticky" ? Boundary::Sticky : b == "slip" ? Boundary::Slip : Boundary::Separate;
}

}  // namespace

double ShapeDesc::volume() const {
    if (kind == Kind::Box) return (max - min).prod();
    return 4.0 / 3.0 * M_PI * radius * radius * radius;
}

bool ShapeDesc::contains(const Vec3d& x) const {
    if (kind == Kind::Box) return (x.array() >= min.array()).all() && (x.array() < max.array()).all();
    return (x - centre).squaredNorm() < radius * radius;
}

const std::vector<std::string>& materialPresetNames() {
    static const std::vector<std::string> names = [] {
        std::vector<std::string> v;
        for (const Preset& p : presets()) v.push_back(p.name);
        return v;
    }();
    return names;
}

SceneDesc loadScene(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw SceneError(path + ": cannot open the file");
    return parseScene(std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()), path);
}

SceneDesc parseScene(const std::string& text, const std::string& path) {
    SceneDesc scene;
    scene.file = path;
    scene.name = std::filesystem::path(path).stem().string();
    json doc;
    try {
        doc = json::parse(text);
    } catch (const json::parse_error& e) {
        throw SceneError(path + ": not valid JSON: " + e.what());
    }
    json resolved = json::object();
    Node root(doc, resolved, "", path);
    root.expect({"simulation", "output", "sets", "colliders"});

    // Simulation settings.
    {
        Node n = root.child("simulation");
        n.expect({"frames", "fps", "substeps", "dx", "gravity", "interpolation", "transfer", "force", "cfl", "adaptive",
                  "max_displacement", "threads", "energy_growth_limit", "cell_crossing_check", "step_collapse_limit",
                  "retries"});
        SimulationSettings& s = scene.settings;
        scene.frames = int(n.integer("frames", scene.frames, 1, 1000000));
        s.fps = n.number("fps", s.fps, 1e-3, 1e6, "frames per second");
        s.substepsPerFrame = int(n.integer("substeps", s.substepsPerFrame, 1, 1000000));
        s.dx = n.number("dx", s.dx, 1e-6, 1e6, "m");
        s.gravity = n.vec3("gravity", s.gravity);
        s.transfer.interpolation = n.choice("interpolation", "quadratic", {"quadratic", "cubic"}, "interpolation") == "cubic"
                                       ? Interpolation::Cubic : Interpolation::Quadratic;
        s.transfer.transfer = n.choice("transfer", "apic", {"apic", "pic"}, "transfer") == "pic" ? TransferScheme::PIC : TransferScheme::APIC;
        s.transfer.force = n.choice("force", "standard", {"standard", "mls"}, "force") == "mls" ? ForceScheme::MLS : ForceScheme::Standard;
        s.cfl = n.number("cfl", s.cfl, 1e-3, 10.0);
        s.adaptive = n.boolean("adaptive", s.adaptive);
        s.maxDisplacement = n.number("max_displacement", s.maxDisplacement, 0.0, 100.0, "cells per substep (0 = off)");
        scene.threads = int(n.integer("threads", 0, 0, 4096));
        s.stability.energyGrowth = n.number("energy_growth_limit", s.stability.energyGrowth, 0.0, 1e6,
                                            "(fraction of the largest kinetic + stored energy; 0 = off)");
        s.stability.cellCrossing = n.boolean("cell_crossing_check", s.stability.cellCrossing);
        s.stability.stepCollapse = n.number("step_collapse_limit", s.stability.stepCollapse, 0.0, 1e12,
                                            "(largest factor by which the CFL step may shrink in one substep; 0 = off)");
        s.stability.retries = int(n.integer("retries", s.stability.retries, 0, 10));
        n.finish();
    }
    // Output.
    {
        Node n = root.child("output");
        n.expect({"directory", "points", "surface", "density", "velocity", "split_files", "ply", "surface_radius", "surface_group"});
        OutputDesc& o = scene.output;
        o.directory = n.string("directory", "out/" + scene.name);
        o.points = n.boolean("points", o.points);
        o.surface = n.boolean("surface", o.surface);
        o.density = n.boolean("density", o.density);
        o.velocity = n.boolean("velocity", o.velocity);
        o.splitFiles = n.boolean("split_files", o.splitFiles);
        o.ply = n.boolean("ply", o.ply);
        o.surfaceRadius = n.number("surface_radius", o.surfaceRadius, 0.5, 10.0, "particle spacings");
        o.surfaceGroup = n.choice("surface_group", o.surfaceGroup, {"all", "material", "set"}, "surface grouping");
        n.finish();
    }
    // Particle sets, each becoming one species with its own parameters.
    std::vector<Node> sets = root.array("sets");
    if (sets.empty()) root.fail("sets", "a scene needs at least one particle set");
    for (std::size_t i = 0; i < sets.size(); ++i) {
        Node& n = sets[i];
        n.expect({"name", "material", "material_params", "shape", "velocity", "particles_per_cell", "count", "sampling",
                  "start_frame", "duration", "pause", "lambda_scale", "mu_scale", "mass_scale", "seed"});
        ParticleSetDesc d;
        d.name = n.string("name", "set" + std::to_string(i));
        for (const ParticleSetDesc& other : scene.sets)
            if (other.name == d.name) n.fail("name", "duplicate set name \"" + d.name + "\"");
        d.material = n.choice("material", "water", materialPresetNames(), "material");
        d.shape = readShape(n.child("shape"));
        d.velocity = n.vec3("velocity", Vec3d::Zero()).cast<float>();
        d.particlesPerCell = n.number("particles_per_cell", d.particlesPerCell, 1e-3, 1000.0);
        d.count = n.integer("count", 0, 0, 2000000000LL);
        const std::string sampling = n.choice("sampling", "poisson", {"poisson", "grid", "lattice"}, "sampling");
        d.sampling = sampling == "grid" ? Sampling::Grid : sampling == "lattice" ? Sampling::Lattice : Sampling::Poisson;
        d.startFrame = int(n.integer("start_frame", 0, 0, 100000000));
        d.durationFrames = int(n.integer("duration", 1, 1, 100000000));
        d.pauseFrames = int(n.integer("pause", 0, 0, 100000000));
        d.lambdaScale = n.number("lambda_scale", 1.0, 0.0, 1e6);
        d.muScale = n.number("mu_scale", 1.0, 0.0, 1e6);
        d.massScale = n.number("mass_scale", 1.0, 1e-6, 1e6);
        d.seed = unsigned(n.integer("seed", static_cast<long long>(i + 1), 0, 4294967295LL));
        Node params = n.child("material_params");
        for (const Preset& p : presets())
            if (p.name == d.material) {
                float density = 0.0f;
                AnySpecies sp = p.make(params, d, density);
                std::visit([&](auto& s) { s.name = d.name; }, sp);
                scene.speciesPrototypes.push_back(std::move(sp));
                scene.densityOfSet.push_back(density);
            }
        params.finish();
        scene.speciesOfSet.push_back(int(scene.sets.size()));
        scene.materialNames.push_back(d.material);
        n.finish();
        scene.sets.push_back(d);
    }
    // Colliders.
    for (Node& n : root.array("colliders")) {
        const std::string type = n.choice("type", "plane", {"plane", "sphere"}, "collider");
        const Boundary b = readBoundary(n);
        const float mu = float(n.number("friction", 0.0, 0.0, 100.0));
        if (type == "plane") {
            n.expect({"type", "boundary", "friction", "point", "normal"});
            const Vec3d point = n.vec3("point", Vec3d::Zero());
            const Vec3d normal = n.vec3("normal", Vec3d::UnitY());
            if (normal.norm() < kTiny) n.fail("normal", "must not be the zero vector");
            scene.colliders.push_back(std::make_unique<PlaneCollider>(point, normal, b, mu));
        } else {
            n.expect({"type", "boundary", "friction", "center", "radius"});
            const Vec3d c = n.vec3("center", Vec3d::Zero(), true);
            if (!n.has("radius")) n.fail("radius", "missing required field");
            const double r = n.number("radius", 0.0, kTiny, kHuge, "m");
            scene.colliders.push_back(std::make_unique<SphereCollider>(c, r, b, mu));
        }
        n.finish();
    }
    root.finish();
    scene.resolvedJson = resolved.dump(2);
    return scene;
}

std::unique_ptr<Simulation> buildSimulation(SceneDesc& scene) {
    auto sim = std::make_unique<Simulation>(scene.settings);
    for (std::size_t i = 0; i < scene.sets.size(); ++i) {
        const ParticleSetDesc& d = scene.sets[i];
        const int species = sim->addSpecies(scene.speciesPrototypes[i]);
        Emitter e;
        e.species = species;
        e.set = uint16_t(i);
        e.positions = sampleShape(d.shape, scene.settings.dx, d.particlesPerCell, d.count, d.sampling, d.seed);
        if (e.positions.empty())
            throw SceneError(scene.file + ": /sets/" + std::to_string(i) + "/shape: no particle fits in the shape at dx = " +
                             std::to_string(scene.settings.dx));
        e.velocity = d.velocity;
        e.volume = float(d.shape.volume() / double(e.positions.size()));
        e.mass = float(e.volume * scene.densityOfSet[i] * d.massScale);
        e.startFrame = d.startFrame;
        e.durationFrames = d.durationFrames;
        e.pauseFrames = d.pauseFrames;
        sim->addEmitter(std::move(e));
    }
    for (auto& c : scene.colliders) sim->addCollider(std::move(c));
    scene.colliders.clear();
    return sim;
}

}  // namespace mpm
