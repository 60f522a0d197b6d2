#include "io/PlyWriter.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <vector>

#include "io/AtomicFile.h"

namespace mpm {

namespace {

/// Linear RGB to the 8-bit sRGB that vertex colours hold (IEC 61966-2-1 transfer function).
uint8_t srgb8(float linear) {
    const float c = std::clamp(linear, 0.0f, 1.0f);
    const float s = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
    return uint8_t(std::lround(255.0f * s));
}

/// A record built property by property, in the order the header declares them.
struct Record {
    std::vector<char> bytes;
    template <class T>
    void put(T value) {
        const char* p = reinterpret_cast<const char*>(&value);
        bytes.insert(bytes.end(), p, p + sizeof(T));
    }
};

}  // namespace

void writePly(const std::string& path, const PointCloud& f, const std::vector<std::string>& materialNames) {
    const std::size_t n = f.size();
    const bool colour = f.Cd.size() == n && n > 0, pscale = f.pscale.size() == n && n > 0;
    const bool J = f.J.size() == n && n > 0, Jp = f.Jp.size() == n && n > 0, stress = f.stressNorm.size() == n && n > 0,
               F = f.F.size() == n && n > 0, plastic = f.plasticStrain.size() == n && n > 0;
    std::string names;
    for (const std::string& m : materialNames) names += " " + m;
    std::string header = "ply\nformat binary_little_endian 1.0\ncomment sparse-mpm particles, SI units, Y up\n" +
                         (names.empty() ? std::string() : "comment material_names" + names + "\n") + "element vertex " +
                         std::to_string(n) +
                         "\nproperty double x\nproperty double y\nproperty double z\nproperty float vx\nproperty float vy\n"
                         "property float vz\nproperty int id\nproperty int material\nproperty int set\n";
    if (pscale) header += "property float pscale\n";
    if (colour) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    if (J) header += "property float J\n";
    if (Jp) header += "property float Jp\n";
    if (stress) header += "property float stress_norm\n";
    if (plastic) header += "property float plastic_strain\n";
    const auto written = [&](const std::vector<float>& column) { return column.size() == n && n > 0; };
    for (const auto& [name, values] : f.parameters)
        if (written(values)) header += "property float " + name + "\n";
    if (F)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) header += "property float F" + std::to_string(r) + std::to_string(c) + "\n";
    header += "end_header\n";
    writeAtomically(path, [&](std::ostream& out) {
        out << header;
        Record rec;
        for (std::size_t i = 0; i < n; ++i) {
            rec.bytes.clear();
            for (int a = 0; a < 3; ++a) rec.put<double>(f.x[i][a]);
            for (int a = 0; a < 3; ++a) rec.put<float>(f.v[i][a]);
            rec.put<int32_t>(f.id[i]);
            rec.put<int32_t>(f.material[i]);
            rec.put<int32_t>(f.set[i]);
            if (pscale) rec.put<float>(f.pscale[i]);
            if (colour)
                for (int a = 0; a < 3; ++a) rec.put<uint8_t>(srgb8(f.Cd[i][a]));
            if (J) rec.put<float>(f.J[i]);
            if (Jp) rec.put<float>(f.Jp[i]);
            if (stress) rec.put<float>(f.stressNorm[i]);
            if (plastic) rec.put<float>(f.plasticStrain[i]);
            for (const auto& [name, values] : f.parameters)
                if (written(values)) rec.put<float>(values[i]);
            if (F)
                for (int r = 0; r < 3; ++r)
                    for (int c = 0; c < 3; ++c) rec.put<float>(f.F[i](r, c));
            out.write(rec.bytes.data(), std::streamsize(rec.bytes.size()));
        }
    });
}

}  // namespace mpm
