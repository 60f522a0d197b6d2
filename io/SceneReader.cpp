// Scene reading with nlohmann::json. A JsonKeys walks one JSON object as a key visitor (materials/
// Parameters.h): it remembers its path for errors, records every value it hands out (defaults included)
// into the resolved scene, and rejects keys nobody asked for.
#include "io/SceneReader.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include "base/Text.h"
#include "io/SceneKeys.h"

namespace mpm {

using json = nlohmann::ordered_json;

namespace {

/// A default as the resolved scene writes it: a float's shortest decimal (0.15, not the 0.15000000596046448 its
/// double holds), so that scene.json shows the values a user would write.
template <class T>
double asWritten(T value) {
    if constexpr (std::is_same_v<T, float>)
        return shortestDecimal(value);
    else
        return double(value);
}

std::string formatNumber(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

/// Deepest nesting of objects and lists a scene may have: scenes use 4 levels, and a limit keeps a hostile
/// file from exhausting the stack of anything that walks the tree.
constexpr int kMaxNesting = 64;
/// Largest scene file read: scenes are a few kilobytes.
constexpr std::uintmax_t kMaxSceneBytes = std::uintmax_t(64) << 20;
/// A value quoted in an error message is cut to this many characters.
constexpr std::size_t kMaxQuoted = 80;

/// A JSON value as the user wrote it, cut short for messages.
std::string quoted(const json& j) {
    std::string s = j.dump(-1, ' ', false, json::error_handler_t::replace);
    return s.size() > kMaxQuoted ? s.substr(0, kMaxQuoted) + "..." : s;
}

/// nlohmann's messages start with "[json.exception.parse_error.101] "; the user needs what follows.
std::string withoutPrefix(const std::string& what) {
    const std::size_t close = what.find("] ");
    return what.rfind("[json.exception.", 0) == 0 && close != std::string::npos ? what.substr(close + 2) : what;
}

class JsonKeys {
public:
    JsonKeys(const json& in, json& out, std::string path, const std::string& file)
        : in_(in), out_(out), path_(std::move(path)), file_(file) {
        if (!in_.is_object()) fail("", "expected an object");
    }

    [[noreturn]] void fail(std::string_view key, const std::string& what) const {
        // An unknown key is the user's text: cut short like any quoted value (a 50 MB key made 50 MB of message).
        const std::string name = key.size() > kMaxQuoted ? std::string(key.substr(0, kMaxQuoted)) + "..." : std::string(key);
        const std::string where = path_.empty() && key.empty() ? "/" : path_ + (key.empty() ? "" : "/" + name);
        throw SceneError(file_ + ": " + where + ": " + what);
    }
    const std::string& path() const { return path_; }
    bool has(std::string_view key) const { return in_.contains(key); }
    /// What it has read so far, defaults filled in.
    const json& resolved() const { return out_; }

    // The key visitor (base/Parameters.h).
    template <class T>
    void number(const Key& k, T& value) {
        double v = asWritten(value);
        if (const json* j = take(k)) {
            if (!j->is_number()) fail(k.name, "expected a number, got " + quoted(*j));
            v = j->get<double>();
            if (!std::isfinite(v) || v < k.lo || v > k.hi)
                fail(k.name, "value " + quoted(*j) + " out of range; allowed: " + formatNumber(k.lo) + " to " +
                                 formatNumber(k.hi) + (k.unit.empty() ? "" : " " + std::string(k.unit)));
        }
        out_[std::string(k.name)] = v;
        value = T(v);
    }
    template <class T>
    void integer(const Key& k, T& value) {
        long long v = static_cast<long long>(value);
        if (const json* j = take(k)) {
            // 1e6 is an integer too; 2^63 and more is out of range, and said so with its real value.
            const bool whole =
                j->is_number_float() && std::isfinite(j->get<double>()) && std::floor(j->get<double>()) == j->get<double>();
            if (!j->is_number_integer() && !whole) fail(k.name, "expected an integer, got " + quoted(*j));
            const double d = j->is_number_unsigned()  ? double(j->get<uint64_t>())
                             : j->is_number_integer() ? double(j->get<long long>())
                                                      : j->get<double>();
            if (d < k.lo || d > k.hi)
                fail(k.name, "value " + quoted(*j) + " out of range; allowed: " + std::to_string((long long)k.lo) + " to " +
                                 std::to_string((long long)k.hi));
            v = j->is_number_float() ? (long long)d : j->get<long long>();
        }
        out_[std::string(k.name)] = v;
        value = T(v);
    }
    void flag(const Key& k, bool& value) {
        if (const json* j = take(k)) {
            if (!j->is_boolean()) fail(k.name, "expected true or false, got " + quoted(*j));
            value = j->get<bool>();
        }
        out_[std::string(k.name)] = value;
    }
    template <class T>
    void vec3(const Key& k, Eigen::Matrix<T, 3, 1>& value) {
        Vec3d v(asWritten(value[0]), asWritten(value[1]), asWritten(value[2]));
        if (k.derived && !given(k.name)) {
            take(k);
            return;
        }
        if (const json* j = take(k)) {
            if (!j->is_array() || j->size() != 3) fail(k.name, "expected a list of 3 numbers, got " + quoted(*j));
            for (int i = 0; i < 3; ++i) {
                if (!(*j)[i].is_number()) fail(k.name, "expected a list of 3 numbers, got " + quoted(*j));
                v[i] = (*j)[i].template get<double>();
                if (!std::isfinite(v[i])) fail(k.name, "non-finite component");
            }
        }
        out_[std::string(k.name)] = {v[0], v[1], v[2]};
        value = v.cast<T>();
    }
    void text(const Key& k, std::string& value) {
        if (const json* j = take(k)) {
            if (!j->is_string()) fail(k.name, "expected a string, got " + quoted(*j));
            value = j->get<std::string>();
        }
        out_[std::string(k.name)] = value;
    }
    void choice(const Key& k, std::string& value, const std::vector<std::string>& allowed) {
        text(k, value);
        for (const std::string& a : allowed)
            if (a == value) return;
        fail(k.name, "unknown " + std::string(k.noun) + " \"" + value + "\"; known: " + joinNames(allowed));
    }
    void choices(const Key& k, std::vector<std::string>& values, const std::vector<std::string>& allowed) {
        if (const json* j = take(k)) {
            if (!j->is_array()) fail(k.name, "expected a list of names, got " + quoted(*j) + "; known: " + joinNames(allowed));
            values.clear();
            for (std::size_t i = 0; i < j->size(); ++i) {
                const json& item = (*j)[i];
                const std::string at = std::string(k.name) + "/" + std::to_string(i);
                if (!item.is_string() || std::find(allowed.begin(), allowed.end(), item.get<std::string>()) == allowed.end())
                    fail(at, "unknown " + std::string(k.noun) + " " + quoted(item) + "; known: " + joinNames(allowed));
                // A name twice is a slip (a list edited by hand, or a typo for another name): say so, not drop it.
                if (std::find(values.begin(), values.end(), item.get<std::string>()) != values.end())
                    fail(at, std::string(k.noun) + " " + quoted(item) + " is already in the list");
                values.push_back(item.get<std::string>());
            }
        }
        out_[std::string(k.name)] = values;
    }
    template <class E>
    void choice(const Key& k, E& value, std::span<const Named<E>> names) {
        std::string name;
        std::vector<std::string> allowed;
        for (const Named<E>& n : names) {
            allowed.push_back(n.name);
            if (n.value == value) name = n.name;
        }
        choice(k, name, allowed);
        for (const Named<E>& n : names)
            if (name == n.name) value = n.value;
    }
    void check(bool ok, std::string_view key, const std::string& problem) const {
        if (!ok) fail(key, problem);
    }
    bool given(std::string_view key) const { return in_.contains(key); }
    template <class F>
    void object(const Key& k, F&& f) {
        if (k.derived && !given(k.name)) {
            // Read for its defaults, left out of the resolved scene.
            static const json empty = json::object();
            json unused = json::object();
            take(k);
            JsonKeys c(empty, unused, path_ + "/" + std::string(k.name), file_);
            f(c);
            return;
        }
        JsonKeys c = child(std::string(k.name).c_str());
        f(c);
        c.finish();
    }
    template <class T, class F>
    void list(const Key& k, std::vector<T>& items, F&& f) {
        items.clear();
        for (JsonKeys& n : array(std::string(k.name).c_str())) {
            T item;
            f(n, item);
            n.finish();
            items.push_back(std::move(item));
        }
    }

    // Structure.
    JsonKeys child(const char* key) {
        static const json empty = json::object();
        const json* j = take(Key{.name = key});
        out_[key] = json::object();
        return JsonKeys(j ? *j : empty, out_[key], path_ + "/" + key, file_);
    }
    std::vector<JsonKeys> array(const char* key) {
        std::vector<JsonKeys> items;
        out_[key] = json::array();
        const json* j = take(Key{.name = key});
        if (!j) return items;
        if (!j->is_array()) fail(key, "expected a list of objects");
        for (std::size_t i = 0; i < j->size(); ++i) out_[key].push_back(json::object());
        for (std::size_t i = 0; i < j->size(); ++i)
            items.emplace_back((*j)[i], out_[key][i], path_ + "/" + key + "/" + std::to_string(i), file_);
        return items;
    }
    /// Unknown keys are errors: a typo must not silently fall back to a default.
    void finish() const {
        for (auto it = in_.begin(); it != in_.end(); ++it)
            if (!read_.count(it.key())) fail(it.key(), "unknown key; known here: " + joinNames(known_));
    }

private:
    const json* take(const Key& k) {
        const std::string key(k.name);
        if (read_.insert(key).second) known_.push_back(key);
        auto it = in_.find(key);
        if (it == in_.end() && k.required) fail(k.name, "missing required field");
        return it == in_.end() ? nullptr : &*it;
    }
    const json& in_;
    json& out_;
    std::string path_;
    const std::string& file_;
    std::set<std::string> read_;
    std::vector<std::string> known_;  ///< in the order asked for
};

/// A `type` key choosing one alternative of a shape list, then that shape's keys.
template <class Shape>
void readShape(JsonKeys& n, Shape& shape, const char* defaultType, const char* noun) {
    std::string type = defaultType;
    n.choice(Key{.name = "type", .noun = noun}, type, shapeTypeNames(&shape));
    shapeOfType(type, shape);
    std::visit([&]<class S>(S& s) { S::keys(n, s); }, shape);
}

void readSet(JsonKeys& n, std::size_t index, SceneDesc& scene) {
    ParticleSetDesc d;
    d.name = "set" + std::to_string(index);
    d.seed = unsigned(index + 1);
    setKeys(n, d);
    for (const ParticleSetDesc& other : scene.sets)
        if (other.name == d.name) n.fail("name", "duplicate set name \"" + d.name + "\"");
    {
        JsonKeys shape = n.child("shape");
        readShape(shape, d.shape, Box::kType, "shape");
        shape.finish();
    }
    JsonKeys params = n.child("material_params");
    defaultMaterialParams(d.material, d.params);
    visitMaterialParams(d.params, [&]<class M>(typename M::Params& p) { M::keys(params, p); });
    params.finish();
    for (auto it = params.resolved().begin(); it != params.resolved().end(); ++it)
        if (params.has(it.key()) && it.value().is_number()) d.materialNumbers.emplace_back(it.key(), it.value().get<double>());
    n.finish();
    scene.sets.push_back(std::move(d));
}

void readCollider(JsonKeys& n, SceneDesc& scene) {
    ColliderDesc c;
    c.name = "collider" + std::to_string(scene.colliders.size());
    std::string type = Plane::kType;
    n.choice(Key{.name = "type", .noun = "collider"}, type, shapeTypeNames(&c.shape));
    shapeOfType(type, c.shape);
    colliderKeys(n, c);
    for (std::size_t k = 0; k < scene.colliders.size(); ++k)
        if (scene.colliders[k].name == c.name)
            n.fail("name", "duplicate collider name \"" + c.name + "\": collider " + std::to_string(k) + " has it" +
                               (n.has("name") ? "" : " (it is this collider's default name: give this one a name)"));
    std::visit([&]<class S>(S& s) { S::keys(n, s); }, c.shape);
    n.finish();
    scene.colliders.push_back(std::move(c));
}

}  // namespace

SceneDesc loadScene(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (ec || !fs::exists(st))
        throw SceneError(path + ": cannot open the file: " + (ec ? ec.message() : "No such file or directory"));
    if (fs::is_directory(st)) throw SceneError(path + ": is a directory, not a scene file");
    if (!fs::is_regular_file(st)) throw SceneError(path + ": not a regular file");
    const std::uintmax_t size = fs::file_size(path, ec);
    if (!ec && size > kMaxSceneBytes)
        throw SceneError(path + ": " + std::to_string(size) + " bytes; a scene file may have at most " +
                         std::to_string(kMaxSceneBytes));
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(path + ": cannot open the file: " + std::strerror(errno));
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw SceneError(path + ": cannot read the file: " + std::strerror(errno));
    return parseScene(text, path);
}

SceneDesc parseScene(const std::string& text, const std::string& path) {
    SceneDesc scene;
    scene.file = path;
    scene.name = std::filesystem::path(path).stem().string();
    json doc;
    try {
        // The nesting limit is enforced while parsing, before a hostile depth can be built.
        doc = json::parse(text, [&](int depth, json::parse_event_t event, json&) {
            if ((event == json::parse_event_t::object_start || event == json::parse_event_t::array_start) && depth >= kMaxNesting)
                throw SceneError(path + ": objects and lists nested deeper than " + std::to_string(kMaxNesting) + " levels");
            return true;
        });
    } catch (const json::parse_error& e) {
        throw SceneError(path + ": not valid JSON: " + withoutPrefix(e.what()));
    } catch (const json::out_of_range& e) {
        throw SceneError(path + ": not valid JSON: a number is out of range (at most about 1.8e308): " + withoutPrefix(e.what()));
    } catch (const json::exception& e) {
        throw SceneError(path + ": not valid JSON: " + withoutPrefix(e.what()));
    }
    // The scene a run wrote (its scene.json) names the file it was resolved from: its assets are found beside that
    // file and its frames keep that scene's name, so it runs again as it is, from anywhere.
    if (doc.is_object() && doc.contains("scene_file")) {
        const json& source = doc["scene_file"];
        if (!source.is_string() || source.get<std::string>().empty())
            throw SceneError(path + ": /scene_file: expected the path of the scene this one was resolved from, got " +
                             quoted(source));
        scene.file = source.get<std::string>();
        scene.name = std::filesystem::path(scene.file).stem().string();
        doc.erase("scene_file");
    }
    json resolved = json::object();
    JsonKeys root(doc, resolved, "", path);
    {
        JsonKeys n = root.child("simulation");
        simulationKeys(n, scene);
        n.finish();
    }
    {
        JsonKeys n = root.child("output");
        scene.output.directory = "out/" + scene.name;
        outputKeys(n, scene.output);
        n.finish();
    }
    // Particle sets, each becoming one species with its own parameters.
    std::vector<JsonKeys> sets = root.array("sets");
    if (sets.empty()) root.fail("sets", "a scene needs at least one particle set");
    for (std::size_t i = 0; i < sets.size(); ++i) readSet(sets[i], i, scene);
    for (JsonKeys& n : root.array("colliders")) readCollider(n, scene);
    root.finish();
    scene.resolvedJson = resolved.dump(2);
    return scene;
}

}  // namespace mpm
