#pragma once
// Solid ball: phi(x) = |x - c| - r (thesis section 5). Fills a particle set or collides.
#include <cmath>

#include "base/Parameters.h"
#include "core/shapes/MassProperties.h"

namespace mpm {

struct Sphere {
    static constexpr const char* kType = "sphere";
    Vec3d centre = Vec3d::Zero();
    double radius = 0.0;

    template <class V>
    static void keys(V& v, Sphere& s) {
        v.vec3(Key{.name = "center", .help = "centre", .unit = "m", .required = true}, s.centre);
        v.number(Key{.name = "radius", .help = "radius", .lo = kTiny, .hi = kHuge, .unit = "m", .required = true}, s.radius);
    }

    double signedDistance(const Vec3d& x) const { return (x - centre).norm() - radius; }
    /// Outward unit normal; at the centre, where it has none, +Y.
    Vec3d normalAt(const Vec3d& x) const {
        const Vec3d d = x - centre;
        const double len = d.norm();
        return len > 0.0 ? Vec3d(d / len) : Vec3d::UnitY();
    }
    bool contains(const Vec3d& x) const { return (x - centre).squaredNorm() < radius * radius; }
    double volume() const { return 4.0 / 3.0 * M_PI * radius * radius * radius; }
    /// As a rigid body: I = 2/5 V r^2 on every axis.
    MassProperties massProperties() const {
        return {volume(), centre, 0.4 * volume() * radius * radius * Mat3d::Identity(), {centre}, {radius}};
    }
    Vec3d middle() const { return centre; }
    void bounds(Vec3d& lo, Vec3d& hi) const {
        lo = centre - Vec3d::Constant(radius);
        hi = centre + Vec3d::Constant(radius);
    }
};

}  // namespace mpm
