#pragma once
// A flat rectangle, the mouth of a continuous source (a hopper's slot, a spillway, a wide tap): material enters
// through it along its normal at the set's velocity, like a Disc. Its sides run along `axis` (projected into
// the plane) and along normal x axis.
#include <algorithm>
#include <cmath>
#include <vector>

#include "base/Parameters.h"

namespace mpm {

struct Rectangle {
    static constexpr const char* kType = "rectangle";
    Vec3d centre = Vec3d::Zero();
    Vec3d normal = Vec3d::UnitY();  ///< the side material flows out to (need not be unit length)
    Vec3d axis = Vec3d::UnitX();    ///< the direction of the width side; its part along the normal is ignored
    double width = 0.0, height = 0.0;

    template <class V>
    static void keys(V& v, Rectangle& s) {
        v.vec3(Key{.name = "center", .help = "centre", .unit = "m", .required = true}, s.centre);
        v.vec3(Key{.name = "normal", .help = "the direction material flows out of it"}, s.normal);
        v.check(s.normal.norm() >= kTiny, "normal", "must not be the zero vector");
        // Decided before the axis is read, so that the resolved scene states the axis taken.
        if (!v.given("axis") && s.normal.norm() >= kTiny && std::abs(s.normal.normalized().x()) > 0.9) s.axis = Vec3d::UnitZ();
        v.vec3(Key{.name = "axis", .help = "the direction of the width side", .byDefault = "X, or Z for a normal along X"},
               s.axis);
        v.number(Key{.name = "width", .help = "side along axis", .lo = kTiny, .hi = kHuge, .unit = "m", .required = true},
                 s.width);
        v.number(
            Key{.name = "height", .help = "side along normal x axis", .lo = kTiny, .hi = kHuge, .unit = "m", .required = true},
            s.height);
        v.check(
            (s.axis - s.axis.dot(s.normal.normalized()) * s.normal.normalized()).norm() >= kTiny * std::max(1.0, s.axis.norm()),
            "axis", "must not be parallel to the normal");
    }

    double area() const { return width * height; }
    Vec3d unitNormal() const { return normal.normalized(); }
    /// The in-plane directions of the sides: u along the width, w along the height.
    void sides(Vec3d& u, Vec3d& w) const {
        const Vec3d n = unitNormal();
        u = (axis - axis.dot(n) * n).normalized();
        w = n.cross(u);
    }
    /// The largest in-plane distance from the centre to the outline.
    double reach() const { return 0.5 * std::hypot(width, height); }
    /// A layer of a stream's body-centred stacking, as in-plane offsets (s, t) along (u, w): each side cut into
    /// cells of about `spacing`, one point per cell, a quarter cell in from its corner in layer 0 and three
    /// quarters in layer 1, so both layers hold the same whole number of points and cover the outline evenly.
    std::vector<Eigen::Vector2d> lattice(int layer, double spacing) const {
        const int nu = std::max(1, int(std::lround(width / spacing))), nt = std::max(1, int(std::lround(height / spacing)));
        const double su = width / nu, st = height / nt, at = layer == 0 ? 0.25 : 0.75;
        std::vector<Eigen::Vector2d> out;
        for (int a = 0; a < nu; ++a)
            for (int b = 0; b < nt; ++b) out.emplace_back((a + at) * su - 0.5 * width, (b + at) * st - 0.5 * height);
        return out;
    }
};

}  // namespace mpm
