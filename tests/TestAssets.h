#pragma once
// Assets the tests write for themselves: meshes with known geometry.
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "base/Types.h"

namespace mpm::test {

/// An icosphere of radius r about c, subdivided `levels` times (20 * 4^levels triangles), as OBJ text.
inline std::string icosphereObj(const Vec3d& c, double r, int levels) {
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<Vec3d> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    for (Vec3d& p : v) p.normalize();
    std::vector<Eigen::Vector3i> f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (int l = 0; l < levels; ++l) {
        std::map<std::pair<int, int>, int> mid;
        auto middle = [&](int a, int b) {
            const auto key = std::minmax(a, b);
            const auto it = mid.find(key);
            if (it != mid.end()) return it->second;
            v.push_back((v[a] + v[b]).normalized());
            return mid[key] = int(v.size()) - 1;
        };
        std::vector<Eigen::Vector3i> g;
        for (const Eigen::Vector3i& tri : f) {
            const int ab = middle(tri[0], tri[1]), bc = middle(tri[1], tri[2]), ca = middle(tri[2], tri[0]);
            g.insert(g.end(), {{tri[0], ab, ca}, {tri[1], bc, ab}, {tri[2], ca, bc}, {ab, bc, ca}});
        }
        f = g;
    }
    std::ostringstream s;
    s.precision(17);
    for (const Vec3d& p : v) s << "v " << (c + r * p).transpose() << "\n";
    for (const Eigen::Vector3i& tri : f) s << "f " << tri[0] + 1 << " " << tri[1] + 1 << " " << tri[2] + 1 << "\n";
    return s.str();
}

/// A square cup: outer box [-a, a] x [0, h] x [-a, a] less the inner [-a + w, a - w] x [w, h + ...], as a
/// closed triangle mesh (outer walls and floor, inner walls and floor, and the rim).
inline std::string cupObj(double a, double h, double w) {
    std::vector<Vec3d> v;
    std::vector<Eigen::Vector3i> f;
    auto quad = [&](Vec3d p0, Vec3d p1, Vec3d p2, Vec3d p3) {
        const int i = int(v.size());
        v.insert(v.end(), {p0, p1, p2, p3});
        f.push_back({i, i + 1, i + 2});
        f.push_back({i, i + 2, i + 3});
    };
    const double b = a - w;
    // Outer box without top (normals out), inner box without top (normals into the cavity), rim.
    auto box = [&](double s, double y0, double y1, bool flip) {
        const Vec3d c[8] = {{-s, y0, -s}, {s, y0, -s}, {s, y0, s}, {-s, y0, s},
                            {-s, y1, -s}, {s, y1, -s}, {s, y1, s}, {-s, y1, s}};
        auto q = [&](int i0, int i1, int i2, int i3) {
            flip ? quad(c[i3], c[i2], c[i1], c[i0]) : quad(c[i0], c[i1], c[i2], c[i3]);
        };
        q(0, 1, 2, 3);  // floor, facing down
        q(0, 4, 5, 1);
        q(1, 5, 6, 2);
        q(2, 6, 7, 3);
        q(3, 7, 4, 0);
    };
    box(a, 0.0, h, false);
    box(b, w, h, true);
    // The rim joins the outer and inner top edges.
    quad({-a, h, -a}, {-b, h, -b}, {b, h, -b}, {a, h, -a});
    quad({a, h, -a}, {b, h, -b}, {b, h, b}, {a, h, a});
    quad({a, h, a}, {b, h, b}, {-b, h, b}, {-a, h, a});
    quad({-a, h, a}, {-b, h, b}, {-b, h, -b}, {-a, h, -a});
    std::ostringstream s;
    s.precision(17);
    for (const Vec3d& p : v) s << "v " << p.transpose() << "\n";
    for (const Eigen::Vector3i& t : f) s << "f " << t[0] + 1 << " " << t[1] + 1 << " " << t[2] + 1 << "\n";
    return s.str();
}

}  // namespace mpm::test
