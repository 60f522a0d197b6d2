#include "io/PointFile.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace mpm {

namespace {

enum class Format { Ascii, LittleEndian, BigEndian };

/// A PLY scalar type: its size in bytes and how to read one as a double.
struct Scalar {
    int bytes = 0;
    bool isFloat = false, isSigned = false;
};

bool scalarOf(const std::string& name, Scalar& s) {
    // PLY's names and their sized aliases (int8, uint8, ..., float32, float64).
    static const std::pair<const char*, Scalar> kTypes[] = {
        {"char", {1, false, true}},  {"int8", {1, false, true}},   {"uchar", {1, false, false}},  {"uint8", {1, false, false}},
        {"short", {2, false, true}}, {"int16", {2, false, true}},  {"ushort", {2, false, false}}, {"uint16", {2, false, false}},
        {"int", {4, false, true}},   {"int32", {4, false, true}},  {"uint", {4, false, false}},   {"uint32", {4, false, false}},
        {"float", {4, true, true}},  {"float32", {4, true, true}}, {"double", {8, true, true}},   {"float64", {8, true, true}}};
    for (const auto& [n, t] : kTypes)
        if (name == n) return s = t, true;
    return false;
}

struct Property {
    std::string name;
    Scalar type;
    bool list = false;
    Scalar count;  ///< of a list: the type of its length
};

struct Element {
    std::string name;
    long long count = 0;
    std::vector<Property> properties;
};

double decode(const unsigned char* p, const Scalar& t, bool swap) {
    unsigned char b[8];
    std::memcpy(b, p, std::size_t(t.bytes));
    if (swap) std::reverse(b, b + t.bytes);
    if (t.isFloat) {
        if (t.bytes == 4) {
            float f;
            std::memcpy(&f, b, 4);
            return f;
        }
        double d;
        std::memcpy(&d, b, 8);
        return d;
    }
    switch (t.bytes) {
        case 1:
            return t.isSigned ? double(int8_t(b[0])) : double(b[0]);
        case 2: {
            uint16_t u;
            std::memcpy(&u, b, 2);
            return t.isSigned ? double(int16_t(u)) : double(u);
        }
        default: {
            uint32_t u;
            std::memcpy(&u, b, 4);
            return t.isSigned ? double(int32_t(u)) : double(u);
        }
    }
}

/// Which property fills which output channel: x, y, z, vx, vy, vz, pscale, mass, density (-1: none).
struct Channels {
    int x = -1, y = -1, z = -1, vx = -1, vy = -1, vz = -1, pscale = -1, mass = -1, density = -1;
};

Channels channelsOf(const Element& e) {
    Channels c;
    for (int i = 0; i < int(e.properties.size()); ++i) {
        const std::string& n = e.properties[std::size_t(i)].name;
        if (e.properties[std::size_t(i)].list) continue;
        if (n == "x")
            c.x = i;
        else if (n == "y")
            c.y = i;
        else if (n == "z")
            c.z = i;
        else if (n == "vx" || n == "v.x" || n == "velocity_x")
            c.vx = i;
        else if (n == "vy" || n == "v.y" || n == "velocity_y")
            c.vy = i;
        else if (n == "vz" || n == "v.z" || n == "velocity_z")
            c.vz = i;
        else if (n == "pscale" || n == "radius")
            c.pscale = i;
        else if (n == "mass")
            c.mass = i;
        else if (n == "density")
            c.density = i;
    }
    return c;
}

}  // namespace

PointCloudData readPlyPoints(const std::string& path, const std::vector<std::string>& columns) {
    if (!std::filesystem::is_regular_file(path)) throw PointFileError(path + ": no such point file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw PointFileError(path + ": cannot open the file");
    std::string line;
    if (!std::getline(in, line) || line.substr(0, 3) != "ply")
        throw PointFileError(path + ": not a PLY file (it does not start with \"ply\")");
    Format format = Format::Ascii;
    std::vector<Element> elements;
    bool ended = false;
    int lineNo = 1;
    while (!ended && std::getline(in, line)) {
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream words(line);
        std::string key;
        words >> key;
        auto bad = [&](const std::string& what) {
            return PointFileError(path + ": header line " + std::to_string(lineNo) + ": " + what + " (\"" + line + "\")");
        };
        if (key == "format") {
            std::string f;
            words >> f;
            if (f == "ascii")
                format = Format::Ascii;
            else if (f == "binary_little_endian")
                format = Format::LittleEndian;
            else if (f == "binary_big_endian")
                format = Format::BigEndian;
            else
                throw bad("unknown format; allowed: ascii, binary_little_endian, binary_big_endian");
        } else if (key == "element") {
            Element e;
            if (!(words >> e.name >> e.count) || e.count < 0) throw bad("an element needs a name and a count");
            elements.push_back(e);
        } else if (key == "property") {
            if (elements.empty()) throw bad("a property before any element");
            Property p;
            std::string type;
            words >> type;
            if (type == "list") {
                std::string countType, itemType;
                words >> countType >> itemType >> p.name;
                if (!scalarOf(countType, p.count) || !scalarOf(itemType, p.type)) throw bad("unknown list type");
                p.list = true;
            } else {
                words >> p.name;
                if (!scalarOf(type, p.type)) throw bad("unknown type \"" + type + "\"");
            }
            elements.back().properties.push_back(p);
        } else if (key == "end_header") {
            ended = true;
        } else if (key != "comment" && key != "obj_info" && !key.empty()) {
            throw bad("unknown header keyword \"" + key + "\"");
        }
    }
    if (!ended) throw PointFileError(path + ": the header has no end_header");
    const auto vertex = std::find_if(elements.begin(), elements.end(), [](const Element& e) { return e.name == "vertex"; });
    if (vertex == elements.end()) throw PointFileError(path + ": no \"vertex\" element");
    const Channels ch = channelsOf(*vertex);
    if (ch.x < 0 || ch.y < 0 || ch.z < 0) {
        std::string names;
        for (const Property& p : vertex->properties) names += (names.empty() ? "" : ", ") + p.name;
        throw PointFileError(path + ": the vertices have no x, y, z properties (they have: " + (names.empty() ? "none" : names) +
                             ")");
    }
    if (vertex->count == 0) throw PointFileError(path + ": the file holds no points");
    std::vector<std::size_t> asked;
    for (const std::string& name : columns) {
        const auto at = std::find_if(vertex->properties.begin(), vertex->properties.end(),
                                     [&](const Property& p) { return p.name == name && !p.list; });
        if (at == vertex->properties.end()) {
            std::string names;
            for (const Property& p : vertex->properties) names += (names.empty() ? "" : ", ") + p.name;
            throw PointFileMissingProperty(path + ": the vertices have no property \"" + name + "\" (they have: " + names + ")",
                                           asked.size());
        }
        asked.push_back(std::size_t(at - vertex->properties.begin()));
    }
    const bool velocity = ch.vx >= 0 && ch.vy >= 0 && ch.vz >= 0;
    const bool swap = format == Format::BigEndian;  // this machine is little-endian (x86-64)

    PointCloudData out;
    out.columns.resize(asked.size());
    std::vector<double> values;
    auto take = [&](const Element& e, const std::vector<double>& vals) {
        if (&e != &*vertex) return;
        out.x.emplace_back(vals[std::size_t(ch.x)], vals[std::size_t(ch.y)], vals[std::size_t(ch.z)]);
        if (velocity)
            out.v.emplace_back(float(vals[std::size_t(ch.vx)]), float(vals[std::size_t(ch.vy)]), float(vals[std::size_t(ch.vz)]));
        if (ch.pscale >= 0) out.pscale.push_back(float(vals[std::size_t(ch.pscale)]));
        if (ch.mass >= 0) out.mass.push_back(float(vals[std::size_t(ch.mass)]));
        if (ch.density >= 0) out.density.push_back(float(vals[std::size_t(ch.density)]));
        for (std::size_t c = 0; c < asked.size(); ++c) out.columns[c].push_back(float(vals[asked[c]]));
    };
    auto truncated = [&](const Element& e, long long i) {
        return PointFileError(path + ": the body ends in element \"" + e.name + "\" " + std::to_string(i) + " of " +
                              std::to_string(e.count) + " (a truncated or damaged file)");
    };
    // The elements in file order: those before the vertices are read and dropped.
    for (const Element& e : elements) {
        values.assign(e.properties.size(), 0.0);
        for (long long i = 0; i < e.count; ++i) {
            if (format == Format::Ascii) {
                for (std::size_t k = 0; k < e.properties.size(); ++k) {
                    const Property& p = e.properties[k];
                    double v;
                    if (!(in >> v)) throw truncated(e, i);
                    if (p.list)
                        for (long long n = (long long)v; n > 0; --n)
                            if (!(in >> v)) throw truncated(e, i);
                    values[k] = v;
                }
            } else {
                unsigned char buf[8];
                for (std::size_t k = 0; k < e.properties.size(); ++k) {
                    const Property& p = e.properties[k];
                    if (p.list) {
                        if (!in.read(reinterpret_cast<char*>(buf), p.count.bytes)) throw truncated(e, i);
                        const double n = decode(buf, p.count, swap);
                        in.ignore(std::streamsize(n) * p.type.bytes);
                        if (!in) throw truncated(e, i);
                        continue;
                    }
                    if (!in.read(reinterpret_cast<char*>(buf), p.type.bytes)) throw truncated(e, i);
                    values[k] = decode(buf, p.type, swap);
                }
            }
            take(e, values);
        }
        if (&e == &*vertex) break;  // what follows (faces, edges) is not needed
    }
    for (const Vec3d& x : out.x)
        if (!x.allFinite()) throw PointFileError(path + ": a point has a non-finite position");
    return out;
}

}  // namespace mpm
