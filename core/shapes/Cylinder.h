#pragma once
// Solid cylinder of a radius and a height about an axis through its centre, or a tube (an inner radius). With
// y = (x - c) . a along the unit axis and r the distance from it, d = (r - radius, |y| - height/2) and
//   phi = min(max(d_0, d_1), 0) + |max(d, 0)|,
// the exact signed distance (negative inside). A tube is the same rectangle in the (r, y) plane, centred on the
// wall's mid radius: d_0 = |r - (radius + inner) / 2| - (radius - inner) / 2. Fills a particle set (a can's wall, a
// pipe) or collides (a drum with "inside").
#include <algorithm>
#include <cmath>

#include "base/Parameters.h"
#include "core/shapes/MassProperties.h"

namespace mpm {

struct Cylinder {
    static constexpr const char* kType = "cylinder";
    Vec3d centre = Vec3d::Zero();
    Vec3d axis = Vec3d::UnitY();  ///< unit length once read
    double radius = 0.0, height = 0.0;
    double inner = 0.0;  ///< a tube's inner radius; 0: solid

    template <class V>
    static void keys(V& v, Cylinder& s) {
        v.vec3(Key{.name = "center", .help = "centre", .unit = "m", .required = true}, s.centre);
        v.vec3(Key{.name = "axis", .help = "axis direction (any length but zero)"}, s.axis);
        v.number(Key{.name = "radius", .help = "radius", .lo = kTiny, .hi = kHuge, .unit = "m", .required = true}, s.radius);
        v.number(Key{.name = "height", .help = "length along the axis", .lo = kTiny, .hi = kHuge, .unit = "m", .required = true},
                 s.height);
        v.number(Key{.name = "inner_radius",
                     .help = "a tube's inner radius (0: a solid cylinder)",
                     .lo = 0.0,
                     .hi = kHuge,
                     .unit = "m"},
                 s.inner);
        v.check(s.inner < s.radius, "inner_radius", "must be smaller than radius");
        v.check(s.axis.norm() >= kTiny, "axis", "must not be the zero vector");
        if (s.axis.norm() >= kTiny) s.axis.normalize();
    }

    /// Axial and radial coordinates of x, and the radial unit vector (any one on the axis itself).
    void split(const Vec3d& x, double& y, double& r, Vec3d& radial) const {
        const Vec3d d = x - centre;
        y = d.dot(axis);
        const Vec3d q = d - y * axis;
        r = q.norm();
        radial = r > 0.0 ? Vec3d(q / r) : axis.unitOrthogonal();
    }
    /// The distance past the wall along the radius (d_0 above), and the outward radial direction there.
    double radialExcess(double r, Vec3d& radial) const {
        if (inner <= 0.0) return r - radius;
        const double mid = 0.5 * (radius + inner);
        if (r < mid) radial = -radial;  // nearer the bore: out is towards the axis
        return std::fabs(r - mid) - 0.5 * (radius - inner);
    }
    double signedDistance(const Vec3d& x) const {
        double y, r;
        Vec3d radial;
        split(x, y, r, radial);
        const double a = radialExcess(r, radial), b = std::fabs(y) - 0.5 * height;
        return std::min(std::max(a, b), 0.0) + std::hypot(std::max(a, 0.0), std::max(b, 0.0));
    }
    Vec3d normalAt(const Vec3d& x) const {
        double y, r;
        Vec3d radial;
        split(x, y, r, radial);
        const double a = radialExcess(r, radial), b = std::fabs(y) - 0.5 * height;
        const Vec3d cap = (y >= 0.0 ? 1.0 : -1.0) * axis;
        if (a > 0.0 && b > 0.0) return (a * radial + b * cap).normalized();  // nearest the rim
        return a > b ? radial : cap;
    }
    bool contains(const Vec3d& x) const {
        double y, r;
        Vec3d radial;
        split(x, y, r, radial);
        return r < radius && r > inner && std::fabs(y) < 0.5 * height;
    }
    double volume() const { return M_PI * (radius * radius - inner * inner) * height; }
    /// As a rigid body: V (r^2 + r_i^2) / 2 about the axis, V (3 (r^2 + r_i^2) + h^2) / 12 about any line across it
    /// through the centre (r_i = 0 for a solid one).
    MassProperties massProperties() const {
        const double r2 = radius * radius + inner * inner;
        const double along = 0.5 * volume() * r2, across = volume() * (3.0 * r2 + height * height) / 12.0;
        const Mat3d aa = axis * axis.transpose();
        // Contact points: balls of its radius along the axis, which roll on a wall exactly (where the height allows
        // them inside), and the rims (a tube's inner ones too) and a solid one's caps' centres, for the caps and edges.
        constexpr int kAround = 64;  // a rim rests on a wall as a 64-gon: within r (1 - cos(pi / 64)) = 1.2e-3 r
        constexpr int kAlong = 5;
        std::vector<Vec3d> points;
        std::vector<double> radii;
        if (height >= 2.0 * radius)
            for (int k = 0; k < kAlong; ++k) {
                points.push_back(centre + (-0.5 + double(k) / (kAlong - 1)) * (height - 2.0 * radius) * axis);
                radii.push_back(radius);
            }
        const Vec3d u = axis.unitOrthogonal(), w = axis.cross(u);
        for (int k = 0; k < kAround; ++k) {
            const double a = 2.0 * M_PI * k / kAround;
            for (double s : {-0.5, 0.5})
                for (double rim : {radius, inner})
                    if (rim > 0.0) points.push_back(centre + s * height * axis + rim * (std::cos(a) * u + std::sin(a) * w));
        }
        if (inner <= 0.0)
            for (double s : {-0.5, 0.5}) points.push_back(centre + s * height * axis);
        radii.resize(points.size(), 0.0);
        return {volume(), centre, across * (Mat3d::Identity() - aa) + along * aa, std::move(points), std::move(radii)};
    }
    void bounds(Vec3d& lo, Vec3d& hi) const {
        Vec3d e;
        for (int i = 0; i < 3; ++i)
            e[i] = 0.5 * height * std::fabs(axis[i]) + radius * std::sqrt(std::max(0.0, 1.0 - axis[i] * axis[i]));
        lo = centre - e;
        hi = centre + e;
    }
    Vec3d middle() const { return centre; }
};

}  // namespace mpm
