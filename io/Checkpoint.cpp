#include "io/Checkpoint.h"

#include <blosc.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <thread>
#include <tuple>
#include <type_traits>

#include "base/Text.h"
#include "io/AtomicFile.h"

namespace fs = std::filesystem;

namespace mpm {

namespace {

using json = nlohmann::ordered_json;

constexpr char kMagic[8] = {'M', 'P', 'M', 'C', 'K', 'P', 'T', '1'};
constexpr char kTrailerMagic[8] = {'M', 'P', 'M', 'C', 'E', 'N', 'D', '1'};
/// Bytes per Blosc chunk: well under Blosc's 2 GB limit, large enough to compress well.
constexpr std::size_t kChunkBytes = std::size_t(64) << 20;
constexpr int kBloscLevel = 5;
/// Longest header accepted: a resolved scene and the stats rows of a long run fit many times over.
constexpr uint32_t kMaxHeaderBytes = 1u << 30;

/// A 64-bit FNV-1a style hash over 8-byte words: any flipped or missing byte changes it. It streams: the
/// bytes may come in pieces of any size and hash as if they came at once.
class Checksum {
public:
    void add(const char* p, std::size_t n) {
        while (pending_ > 0 && n > 0) {
            tail_[pending_++] = *p++;
            --n;
            if (pending_ == 8) word(tail_), pending_ = 0;
        }
        for (; n >= 8; p += 8, n -= 8) word(p);
        for (; n > 0; --n) tail_[pending_++] = *p++;
    }
    uint64_t value() const {
        uint64_t h = h_;
        for (std::size_t i = 0; i < pending_; ++i) h = (h ^ uint64_t(static_cast<unsigned char>(tail_[i]))) * kPrime;
        return h;
    }

private:
    static constexpr uint64_t kPrime = 1099511628211ull;
    void word(const char* p) {
        uint64_t w;
        std::memcpy(&w, p, 8);
        h_ = (h_ ^ w) * kPrime;
        h_ ^= h_ >> 29;
    }
    uint64_t h_ = 14695981039346656037ull;
    char tail_[8] = {};
    std::size_t pending_ = 0;
};

/// Writes to the atomic file's stream while hashing what it writes.
class Out {
public:
    explicit Out(std::ostream& os) : os_(os) {}
    void bytes(const void* p, std::size_t n) {
        sum_.add(static_cast<const char*>(p), n);
        os_.write(static_cast<const char*>(p), std::streamsize(n));
    }
    template <class T>
    void value(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes(&v, sizeof(T));
    }
    /// A per-particle array: element size, count, then Blosc chunks of (raw bytes, compressed bytes, data).
    template <class T>
    void array(const std::vector<T>& a) {
        // Eigen's fixed-size types are plain values without being trivially copyable in the language's sense.
        static_assert(std::is_trivially_destructible_v<T>, "per-particle attributes are plain values");
        value(uint32_t(sizeof(T)));
        value(uint64_t(a.size()));
        const char* src = reinterpret_cast<const char*>(a.data());
        std::size_t left = a.size() * sizeof(T);
        std::vector<char> packed;
        const int threads = int(std::min(4u, std::max(1u, std::thread::hardware_concurrency())));
        while (left > 0) {
            const std::size_t raw = std::min(left, kChunkBytes - kChunkBytes % sizeof(T));
            packed.resize(raw + BLOSC_MAX_OVERHEAD);
            const int c = blosc_compress_ctx(kBloscLevel, BLOSC_SHUFFLE, elementSize<T>(), raw, src, packed.data(), packed.size(),
                                             "lz4", 0, threads);
            if (c <= 0) throw std::runtime_error("checkpoint: Blosc could not compress an array");
            value(uint32_t(raw));
            value(uint32_t(c));
            bytes(packed.data(), std::size_t(c));
            src += raw;
            left -= raw;
        }
    }
    /// A length and the characters.
    void text(const std::string& t) {
        value(uint32_t(t.size()));
        bytes(t.data(), t.size());
    }
    uint64_t checksum() const { return sum_.value(); }

private:
    /// The shuffle works on the scalar a value is made of (a float of a Vec3f, a double of a Vec3d).
    template <class T>
    static std::size_t elementSize() {
        if constexpr (std::is_arithmetic_v<T>)
            return sizeof(T);
        else if constexpr (requires { typename T::Scalar; })
            return sizeof(typename T::Scalar);
        else
            return alignof(T);  // a material's parameters, particle by particle: floats
    }
    std::ostream& os_;
    Checksum sum_;
};

/// Reads a whole checkpoint's bytes with bounds checks: a short file is a named error, never a crash.
class In {
public:
    In(const char* p, std::size_t n, std::string path) : p_(p), end_(p + n), path_(std::move(path)) {}
    [[noreturn]] void fail(const std::string& what) const { throw CheckpointError(path_ + ": " + what); }
    void bytes(void* out, std::size_t n) {
        if (std::size_t(end_ - p_) < n) fail("truncated");
        std::memcpy(out, p_, n);
        p_ += n;
    }
    template <class T>
    T value() {
        T v;
        bytes(&v, sizeof(T));
        return v;
    }
    template <class T>
    void array(std::vector<T>& a) {
        const uint32_t elementSize = value<uint32_t>();
        // Older formats kept in float what this program keeps in double (formats 2 and 3 the elastic models' F,
        // formats 2-4 the plastic models' F_E, snow's J_P and water's J): read it as written and widen it.
        if constexpr (std::is_same_v<T, Mat3d>)
            if (elementSize == sizeof(Mat3f)) return widened<Mat3f>(a, [](const Mat3f& f) { return f.cast<double>(); });
        if constexpr (std::is_same_v<T, double>)
            if (elementSize == sizeof(float)) return widened<float>(a, [](float f) { return double(f); });
        if (elementSize != sizeof(T)) fail("an array's element size differs from this program's");
        elements(a);
    }
    template <class Narrow, class T, class Widen>
    void widened(std::vector<T>& a, Widen widen) {
        std::vector<Narrow> narrow;
        elements(narrow);
        a.resize(narrow.size());
        for (std::size_t i = 0; i < narrow.size(); ++i) a[i] = widen(narrow[i]);
    }
    /// An array's count and Blosc chunks, once its element size is known to be T's.
    template <class T>
    void elements(std::vector<T>& a) {
        const uint64_t count = value<uint64_t>();
        if (count > uint64_t(end_ - p_) * 1024)
            fail("an array claims more elements than the file can hold");  // Blosc ratio bound
        a.resize(count);
        char* dst = reinterpret_cast<char*>(a.data());
        std::size_t left = count * sizeof(T);
        while (left > 0) {
            const uint32_t raw = value<uint32_t>(), packed = value<uint32_t>();
            if (raw == 0 || raw > left || std::size_t(end_ - p_) < packed) fail("truncated or corrupt array chunk");
            std::size_t nbytes = 0, cbytes = 0, block = 0;
            blosc_cbuffer_sizes(p_, &nbytes, &cbytes, &block);
            if (nbytes != raw || cbytes != packed) fail("corrupt array chunk");
            if (blosc_decompress_ctx(p_, dst, raw, 1) != int(raw)) fail("an array chunk does not decompress");
            p_ += packed;
            dst += raw;
            left -= raw;
        }
    }
    std::string text(std::size_t n) {
        if (std::size_t(end_ - p_) < n) fail("truncated");
        std::string s(p_, n);
        p_ += n;
        return s;
    }
    bool atEnd() const { return p_ == end_; }

private:
    const char* p_;
    const char* end_;
    std::string path_;
};

/// Format 2 named a species' material by its position in the list of materials as it stood then; the list may
/// have grown anywhere since, so those positions are kept here, frozen.
std::string legacyMaterial(uint32_t position) {
    static const char* const kFormat2Order[] = {"water", "jelly", "rubber", "snow", "sand", "metal", "viscous"};
    return position < std::size(kFormat2Order) ? kFormat2Order[position] : "#" + std::to_string(position);
}

json headerOf(const CheckpointInfo& info) {
    json h = json::object();
    h["format"] = kCheckpointFormat;  // what this program writes, whatever the info read from an older file said
    h["program"] = info.program;
    h["scene_name"] = info.sceneName;
    h["frame"] = info.frame;
    h["time"] = info.time;
    h["mid_frame"] = info.midFrame;
    h["scene_hash"] = info.sceneHash;
    h["scene"] = info.sceneJson;
    h["stats_csv"] = info.statsCsv;
    if (info.parts > 1 || !info.set.empty()) {
        h["part"] = info.part;
        h["parts"] = info.parts;
        h["set"] = info.set;
    }
    return h;
}

CheckpointInfo infoOf(const json& h, const std::string& path) {
    try {
        CheckpointInfo info;
        info.format = h.at("format").get<int>();
        info.program = h.at("program").get<std::string>();
        info.sceneName = h.at("scene_name").get<std::string>();
        info.frame = h.at("frame").get<int>();
        info.time = h.at("time").get<double>();
        info.midFrame = h.at("mid_frame").get<bool>();
        info.sceneHash = h.at("scene_hash").get<std::string>();
        info.sceneJson = h.at("scene").get<std::string>();
        info.statsCsv = h.at("stats_csv").get<std::string>();
        info.part = h.value("part", 0);
        info.parts = h.value("parts", 1);
        info.set = h.value("set", std::string());
        if (info.parts < 1 || info.part < 0 || info.part >= info.parts)
            throw CheckpointError(path + ": header: part " + std::to_string(info.part) + " of " + std::to_string(info.parts) +
                                  " parts");
        return info;
    } catch (const json::exception& e) {
        throw CheckpointError(path + ": header: " + e.what());
    }
}

/// The file's bytes, its magic, header and trailer checked. Returns the header and where the payload starts.
struct Verified {
    std::vector<char> bytes;
    CheckpointInfo info;
    std::size_t payload = 0, payloadEnd = 0;
};

/// The header at the start of a checkpoint's bytes (the first `n` of them, at least the whole header).
/// Returns the header's info and where the payload starts.
std::pair<CheckpointInfo, std::size_t> parseHeader(const char* b, std::size_t n, std::size_t limit, const std::string& path) {
    if (n < sizeof(kMagic) + sizeof(uint32_t)) throw CheckpointError(path + ": truncated (" + std::to_string(n) + " bytes)");
    if (std::memcmp(b, kMagic, sizeof(kMagic)) != 0) throw CheckpointError(path + ": not a checkpoint of this program");
    uint32_t headerBytes;
    std::memcpy(&headerBytes, b + sizeof(kMagic), sizeof(headerBytes));
    const std::size_t headerAt = sizeof(kMagic) + sizeof(uint32_t);
    if (headerBytes > kMaxHeaderBytes || headerAt + headerBytes > limit) throw CheckpointError(path + ": corrupt header length");
    if (headerAt + headerBytes > n) throw CheckpointError(path + ": truncated header");
    json h;
    try {
        h = json::parse(b + headerAt, b + headerAt + headerBytes);
    } catch (const json::exception& e) {
        throw CheckpointError(path + ": header is not valid JSON: " + e.what());
    }
    CheckpointInfo info = infoOf(h, path);
    if (info.format < kOldestCheckpointFormat || info.format > kCheckpointFormat)
        throw CheckpointError(path + ": format " + std::to_string(info.format) + ", this program reads formats " +
                              std::to_string(kOldestCheckpointFormat) + " to " + std::to_string(kCheckpointFormat));
    return {info, headerAt + headerBytes};
}

Verified verify(std::vector<char> bytes, const std::string& path) {
    Verified v;
    v.bytes = std::move(bytes);
    const std::vector<char>& b = v.bytes;
    const std::size_t minimum = sizeof(kMagic) + sizeof(uint32_t) + sizeof(uint64_t) + sizeof(kTrailerMagic);
    if (b.size() < minimum) throw CheckpointError(path + ": truncated (" + std::to_string(b.size()) + " bytes)");
    if (std::memcmp(b.data(), kMagic, sizeof(kMagic)) != 0) throw CheckpointError(path + ": not a checkpoint of this program");
    if (std::memcmp(b.data() + b.size() - sizeof(kTrailerMagic), kTrailerMagic, sizeof(kTrailerMagic)) != 0)
        throw CheckpointError(path + ": truncated (no trailer)");
    const std::size_t sumAt = b.size() - sizeof(kTrailerMagic) - sizeof(uint64_t);
    uint64_t stored;
    std::memcpy(&stored, b.data() + sumAt, sizeof(stored));
    Checksum sum;
    sum.add(b.data(), sumAt);
    if (sum.value() != stored) throw CheckpointError(path + ": checksum mismatch (the file is corrupt)");
    std::tie(v.info, v.payload) = parseHeader(b.data(), sumAt, sumAt, path);
    v.payloadEnd = sumAt;
    return v;
}

}  // namespace

void encodeCheckpoint(std::ostream& os, const CheckpointInfo& info, const SimState& state) {
    {
        Out out(os);
        out.bytes(kMagic, sizeof(kMagic));
        const std::string header = headerOf(info).dump();
        out.value(uint32_t(header.size()));
        out.bytes(header.data(), header.size());
        state.forEachScalar([&](const auto& v) { out.value(v); });
        out.array(state.bounds.minStiffnessKey);
        out.array(state.streamFlow);
        out.array(state.streamLayers);
        out.value(uint32_t(state.species.size()));
        for (const AnySpecies& s : state.species)
            std::visit(
                [&](const auto& sp) {
                    using P = std::decay_t<decltype(sp.params)>;
                    static_assert(std::is_trivially_copyable_v<P>, "material parameters are plain values");
                    out.text(std::decay_t<decltype(sp)>::Material::kSceneName);
                    out.text(sp.name);
                    out.value(uint32_t(sizeof(P)));
                    out.bytes(&sp.params, sizeof(P));
                    uint32_t arrays = 0;
                    sp.forEachArray([&](const auto&) { ++arrays; });
                    out.value(arrays);
                    sp.forEachArray([&](const auto& a) { out.array(a); });
                },
                s);
        // The rigid bodies last, where there are any: a scene without them writes what earlier builds wrote.
        if (!state.bodies.empty()) {
            std::vector<double> bodies(state.bodies.size() * RigidBodyState::kDoubles);
            for (std::size_t k = 0; k < state.bodies.size(); ++k) state.bodies[k].write(&bodies[k * RigidBodyState::kDoubles]);
            out.array(bodies);
        }
        const uint64_t sum = out.checksum();
        os.write(reinterpret_cast<const char*>(&sum), sizeof(sum));
        os.write(kTrailerMagic, sizeof(kTrailerMagic));
    }
}

void writeCheckpoint(const std::string& path, const CheckpointInfo& info, const SimState& state) {
    writeAtomically(path, [&](std::ostream& os) { encodeCheckpoint(os, info, state); });
}

CheckpointInfo readCheckpointInfo(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw CheckpointError(path + ": cannot open: " + std::strerror(errno));
    std::error_code ec;
    const std::size_t size = std::size_t(fs::file_size(path, ec));
    if (ec) throw CheckpointError(path + ": cannot read its size: " + ec.message());
    char start[sizeof(kMagic) + sizeof(uint32_t)] = {};
    in.read(start, sizeof(start));
    uint32_t headerBytes = 0;
    if (in.gcount() == std::streamsize(sizeof(start))) std::memcpy(&headerBytes, start + sizeof(kMagic), sizeof(headerBytes));
    std::vector<char> b(sizeof(start) + std::min<std::size_t>(headerBytes, std::min<std::size_t>(size, kMaxHeaderBytes)));
    in.seekg(0);
    in.read(b.data(), std::streamsize(b.size()));
    return parseHeader(b.data(), std::size_t(in.gcount()), size, path).first;
}

static std::vector<char> fileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw CheckpointError(path + ": cannot open: " + std::strerror(errno));
    return std::vector<char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

Checkpoint readCheckpoint(const std::string& path) { return decodeCheckpoint(fileBytes(path), path); }

Checkpoint decodeCheckpoint(std::vector<char> bytes, const std::string& path) {
    const Verified v = verify(std::move(bytes), path);
    In in(v.bytes.data() + v.payload, v.payloadEnd - v.payload, path);
    Checkpoint c;
    c.info = v.info;
    SimState& s = c.state;
    s.forEachScalar([&](auto& x) { x = in.value<std::decay_t<decltype(x)>>(); });
    in.array(s.bounds.minStiffnessKey);
    in.array(s.streamFlow);
    in.array(s.streamLayers);
    if (s.streamFlow.size() != s.streamLayers.size()) in.fail("the emitters' progress is inconsistent");
    const uint32_t species = in.value<uint32_t>();
    if (species != s.bounds.minStiffnessKey.size()) in.fail("species count and step bounds disagree");
    for (uint32_t k = 0; k < species; ++k) {
        const std::string material = c.info.format >= 3 ? in.text(in.value<uint32_t>()) : legacyMaterial(in.value<uint32_t>());
        AnyMaterialParams params;
        if (!defaultMaterialParams(material, params))
            in.fail("material '" + material + "' of species " + std::to_string(k) + " is not one this program has");
        const std::string name = in.text(in.value<uint32_t>());
        const uint32_t paramBytes = in.value<uint32_t>();
        AnySpecies sp = makeSpecies(name, params);
        std::visit(
            [&](auto& sps) {
                using P = std::decay_t<decltype(sps.params)>;
                if (paramBytes != sizeof(P)) in.fail("parameters of species " + name + " have another size");
                in.bytes(&sps.params, sizeof(P));
                uint32_t arrays = 0;
                sps.forEachArray([&](const auto&) { ++arrays; });
                // One array more than the model keeps: the particles' own parameters (Species::local).
                const uint32_t stored = in.value<uint32_t>();
                sps.perParticle = stored == arrays + 1;
                if (stored != arrays && !sps.perParticle) in.fail("species " + name + " has another number of arrays");
                sps.forEachArray([&](auto& a) { in.array(a); });
                bool same = true;
                sps.forEachArray([&](const auto& a) { same = same && a.size() == sps.size(); });
                if (!same) in.fail("the arrays of species " + name + " differ in length");
            },
            sp);
        s.species.push_back(std::move(sp));
    }
    if (!in.atEnd()) {
        std::vector<double> bodies;
        in.array(bodies);
        if (bodies.size() % RigidBodyState::kDoubles != 0) in.fail("the rigid bodies' array has a partial body");
        s.bodies.resize(bodies.size() / RigidBodyState::kDoubles);
        for (std::size_t k = 0; k < s.bodies.size(); ++k) s.bodies[k].read(&bodies[k * RigidBodyState::kDoubles]);
    }
    if (!in.atEnd()) in.fail("unexpected bytes after the rigid bodies");
    return c;
}

namespace {
constexpr const char* kInside = "_inside";
}

std::string checkpointPath(const std::string& dir, const std::string& scene, int frame, bool inside) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%04d%s", inside ? frame + 1 : frame, inside ? kInside : "");
    return dir + "/" + scene + "_checkpoint_" + buf + ".mpmc";
}

std::string checkpointPartPath(const std::string& dir, const std::string& scene, int frame, int part, bool inside) {
    char buf[64];
    const int number = inside ? frame + 1 : frame;
    const char* suffix = inside ? kInside : "";
    if (part < 0)
        std::snprintf(buf, sizeof(buf), "%04d%s_rank*", number, suffix);
    else
        std::snprintf(buf, sizeof(buf), "%04d%s_rank%03d", number, suffix, part);
    return dir + "/" + scene + "_checkpoint_" + buf + ".mpmc";
}

std::vector<std::string> CheckpointFiles::all() const {
    std::vector<std::string> out;
    if (!whole.empty()) out.push_back(whole);
    for (const auto& [k, p] : parts) out.push_back(p);
    return out;
}

std::vector<CheckpointFiles> listCheckpoints(const std::string& dir, const std::string& scene) {
    // Exactly this scene's: "<scene>_checkpoint_NNNN[_inside].mpmc" and its parts "..._NNNN[_inside]_rankRRR.mpmc".
    static const std::regex kName(R"(^([0-9]{4,})(_inside)?(_rank([0-9]{3,}))?\.mpmc$)");
    // Ordered by 2 x (frames done) + inside: after frame F (2F), inside frame F + 1 (2F + 1), after F + 1 (2F + 2).
    std::map<long long, CheckpointFiles, std::greater<long long>> byFrame;
    std::error_code ec;
    const std::string prefix = scene + "_checkpoint_";
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string name = e.path().filename().string();
        std::smatch m;
        if (name.compare(0, prefix.size(), prefix) != 0) continue;
        const std::string rest = name.substr(prefix.size());
        if (!std::regex_match(rest, m, kName) || m[1].length() > 9 || m[4].length() > 9) continue;
        const bool inside = m[2].matched;
        const int frame = std::stoi(m[1].str()) - (inside ? 1 : 0);
        if (frame < 0) continue;
        CheckpointFiles& f = byFrame[2LL * frame + (inside ? 1 : 0)];
        f.frame = frame;
        f.inside = inside;
        if (m[3].matched)
            f.parts.emplace_back(std::stoi(m[4].str()), e.path().string());
        else
            f.whole = e.path().string();
    }
    std::vector<CheckpointFiles> out;
    for (auto& [frame, f] : byFrame) {
        std::sort(f.parts.begin(), f.parts.end());
        out.push_back(std::move(f));
    }
    return out;
}

std::vector<std::string> completeSet(const CheckpointFiles& files) {
    if (files.parts.empty()) throw CheckpointError("frame " + std::to_string(files.frame) + ": no checkpoint parts");
    const std::string& first = files.parts.front().second;
    if (files.parts.front().first != 0) throw CheckpointError(first + ": part 0 of its set is missing");
    const CheckpointInfo zero = readCheckpointInfo(first);
    if (zero.set.empty() || zero.part != 0) throw CheckpointError(first + ": not part 0 of a set of checkpoint parts");
    std::vector<std::string> paths;
    for (const auto& [k, path] : files.parts) {
        if (k >= zero.parts) break;  // left by an earlier set of more parts
        if (k != int(paths.size())) break;
        const CheckpointInfo info = readCheckpointInfo(path);
        if (info.set != zero.set || info.parts != zero.parts || info.part != k || info.frame != zero.frame)
            throw CheckpointError(path + ": of another set of parts than " + first + " (an interrupted write)");
        paths.push_back(path);
    }
    if (int(paths.size()) != zero.parts)
        throw CheckpointError(first + ": " + std::to_string(paths.size()) + " of its set's " + std::to_string(zero.parts) +
                              " parts are present (part " + std::to_string(paths.size()) + " is missing)");
    return paths;
}

void appendSpecies(SimState& a, SimState&& b) {
    if (a.species.size() != b.species.size()) throw CheckpointError("checkpoint parts hold different species");
    for (std::size_t s = 0; s < a.species.size(); ++s) {
        if (a.species[s].index() != b.species[s].index()) throw CheckpointError("checkpoint parts hold different materials");
        std::visit(
            [&](auto& to) {
                auto& from = std::get<std::decay_t<decltype(to)>>(b.species[s]);
                // Both are the same species type: their arrays come in the same order and types.
                std::vector<void*> src;
                from.forEachArray([&](auto& arr) { src.push_back(&arr); });
                std::size_t k = 0;
                to.forEachArray([&](auto& dst) {
                    auto& arr = *static_cast<std::decay_t<decltype(dst)>*>(src[k++]);
                    dst.insert(dst.end(), arr.begin(), arr.end());
                    std::decay_t<decltype(dst)>().swap(arr);  // b's memory goes back as it is taken
                });
            },
            a.species[s]);
    }
}

namespace {
/// A number that is a float exactly is written as the float's shortest decimal: resolved scenes of earlier versions
/// wrote a float default as its double (0.15000000596046448), today's as 0.15; both are the same scene.
void floatsAsWritten(json& j) {
    if (j.is_structured()) {
        for (json& e : j) floatsAsWritten(e);
    } else if (j.is_number_float()) {
        const double v = j.get<double>();
        const float f = float(v);
        if (std::isfinite(f) && double(f) == v) j = shortestDecimal(f);
    }
}
}  // namespace

std::string sceneIdentity(const std::string& resolvedJson) {
    json j = json::parse(resolvedJson);
    floatsAsWritten(j);
    j.erase("output");
    // None changes a frame already simulated: how many threads, when ranks re-cut their leaves, and how many frames
    // follow (a run extended by raising `frames` resumes from its last checkpoint).
    if (j.contains("simulation") && j["simulation"].is_object())
        j["simulation"].erase("threads"), j["simulation"].erase("rebalance_imbalance"), j["simulation"].erase("frames");
    return j.dump();
}

std::string sceneHash(const std::string& identity) {
    Checksum sum;
    sum.add(identity.data(), identity.size());
    char buf[24];
    std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(sum.value()));
    return buf;
}

namespace {
void diff(const json& a, const json& b, const std::string& path, std::vector<std::string>& out, std::size_t limit) {
    if (out.size() >= limit || a == b) return;
    if (a.is_object() && b.is_object()) {
        for (auto it = a.begin(); it != a.end(); ++it) {
            if (b.contains(it.key()))
                diff(it.value(), b.at(it.key()), path + "/" + it.key(), out, limit);
            else if (out.size() < limit)
                out.push_back(path + "/" + it.key() + ": removed");
        }
        for (auto it = b.begin(); it != b.end(); ++it)
            if (!a.contains(it.key()) && out.size() < limit) out.push_back(path + "/" + it.key() + ": added");
        return;
    }
    const auto primitive = [](const json& v) {
        return std::all_of(v.begin(), v.end(), [](const json& e) { return e.is_primitive(); });
    };
    if (a.is_array() && b.is_array() && a.size() == b.size() && !(primitive(a) && primitive(b))) {
        for (std::size_t i = 0; i < a.size(); ++i) diff(a[i], b[i], path + "/" + std::to_string(i), out, limit);
        return;
    }
    out.push_back((path.empty() ? "/" : path) + ": " + a.dump() + " -> " + b.dump());
}
}  // namespace

std::vector<std::string> sceneDifferences(const std::string& before, const std::string& after, std::size_t limit) {
    std::vector<std::string> out;
    diff(json::parse(before), json::parse(after), "", out, limit);
    return out;
}

}  // namespace mpm
