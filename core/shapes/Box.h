#pragma once
// Box: axis-aligned as [min, max), or given by its centre, edge lengths and a rotation about the centre.
// Its signed distance is the exact one of a box: with q = |R^T (x - c)| - half, phi = |max(q, 0)| + min(max_i q_i, 0)
// (negative inside, minus the distance to the nearest face). Fills a particle set or collides.
#include <algorithm>
#include <cmath>

#include "base/Parameters.h"
#include "core/shapes/MassProperties.h"
#include "core/shapes/Rotation.h"

namespace mpm {

struct Box {
    static constexpr const char* kType = "box";
    Vec3d min = Vec3d::Zero(), max = Vec3d::Zero();
    Mat3d R = Mat3d::Identity();  ///< about the centre; identity for a box given by min and max
    bool rotated = false;

    template <class V>
    static void keys(V& v, Box& s) {
        // Either corners, or centre and size (and a rotation).
        const bool corners = !v.given("center") && !v.given("size");
        Vec3d centre = 0.5 * (s.min + s.max), size = s.max - s.min;
        Rotation rotation;
        // The resolved scene states the form given: the other one's keys are derived from it.
        v.vec3(Key{.name = "min",
                   .help = "lowest corner (or give center and size)",
                   .unit = "m",
                   .required = corners,
                   .derived = !corners},
               s.min);
        v.vec3(Key{.name = "max", .help = "highest corner", .unit = "m", .required = corners, .derived = !corners}, s.max);
        v.vec3(Key{.name = "center",
                   .help = "centre, instead of min and max",
                   .unit = "m",
                   .byDefault = "from min and max",
                   .derived = corners},
               centre);
        v.vec3(Key{.name = "size",
                   .help = "edge lengths, with center",
                   .unit = "m",
                   .byDefault = "from min and max",
                   .derived = corners},
               size);
        v.object(Key{.name = "rotation", .help = "turn about the centre, with center and size", .derived = corners},
                 [&](auto& r) { Rotation::keys(r, rotation); });
        v.check(!(v.given("center") != v.given("size")), v.given("center") ? "size" : "center", "give center and size together");
        v.check(!v.given("rotation") || !corners, "rotation", "a rotated box is given by center and size");
        if (!corners) {
            s.min = centre - 0.5 * size;
            s.max = centre + 0.5 * size;
            s.R = rotation.matrix();
            s.rotated = rotation.degrees != 0.0;
        }
        v.check((s.max - s.min).minCoeff() > 0, corners ? "max" : "size",
                corners ? "must exceed min in every axis" : "must be positive in every axis");
    }

    Vec3d middle() const { return 0.5 * (min + max); }
    /// x in the box's own frame, where it is [min, max).
    Vec3d local(const Vec3d& x) const { return rotated ? Vec3d(R.transpose() * (x - middle()) + middle()) : x; }
    double signedDistance(const Vec3d& x) const {
        const Vec3d q = (local(x) - middle()).cwiseAbs() - 0.5 * (max - min);
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    /// Outward normal: of the nearest face inside, of the nearest point outside.
    Vec3d normalAt(const Vec3d& x) const {
        const Vec3d d = local(x) - middle(), q = d.cwiseAbs() - 0.5 * (max - min);
        Vec3d n = Vec3d::Zero();
        if (q.maxCoeff() > 0.0) {
            for (int a = 0; a < 3; ++a) n[a] = q[a] > 0.0 ? std::copysign(q[a], d[a]) : 0.0;
            n.normalize();
        } else {
            int a = 0;
            q.maxCoeff(&a);
            n[a] = d[a] >= 0.0 ? 1.0 : -1.0;
        }
        return rotated ? Vec3d(R * n) : n;
    }
    bool contains(const Vec3d& x) const {
        const Vec3d p = local(x);
        return (p.array() >= min.array()).all() && (p.array() < max.array()).all();
    }
    double volume() const { return (max - min).prod(); }
    /// As a rigid body: with edges a, b, c, I = V/12 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2) in the box's axes.
    MassProperties massProperties() const {
        const Vec3d e2 = (max - min).cwiseAbs2();
        const Vec3d d(e2[1] + e2[2], e2[0] + e2[2], e2[0] + e2[1]);
        const Mat3d own = volume() / 12.0 * d.asDiagonal().toDenseMatrix();
        std::vector<Vec3d> points = boxSurfacePoints(middle(), 0.5 * (max - min), R);
        const std::size_t n = points.size();
        return {volume(), middle(), R * own * R.transpose(), std::move(points), std::vector<double>(n, 0.0)};
    }
    void bounds(Vec3d& lo, Vec3d& hi) const {
        if (!rotated) {
            lo = min;
            hi = max;
            return;
        }
        const Vec3d e = R.cwiseAbs() * (0.5 * (max - min));
        lo = middle() - e;
        hi = middle() + e;
    }
};

}  // namespace mpm
