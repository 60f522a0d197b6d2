#pragma once
// Half space below a plane through `point` with unit `normal` (thesis section 5): phi(x) = n . (x - p),
// positive on the side the normal points to. A collider shape only: it has no finite volume to fill.
#include <cmath>

#include "base/Parameters.h"

namespace mpm {

struct Plane {
    static constexpr const char* kType = "plane";
    Vec3d point = Vec3d::Zero();
    Vec3d normal = Vec3d::UnitY();

    /// Scene keys; the normal is normalised once read (see normalise()).
    template <class V>
    static void keys(V& v, Plane& s) {
        v.vec3(Key{.name = "point", .help = "a point on the plane", .unit = "m"}, s.point);
        v.vec3(Key{.name = "normal", .help = "the side material stays on (need not be unit length)"}, s.normal);
        v.check(s.normal.norm() >= kTiny, "normal", "must not be the zero vector");
        s.normal = s.normal.normalized();
    }

    /// The plane through p with normal n (any length but zero).
    static Plane through(const Vec3d& p, const Vec3d& n) { return Plane{p, n.normalized()}; }

    double signedDistance(const Vec3d& x) const { return normal.dot(x - point); }
    Vec3d middle() const { return point; }
    Vec3d normalAt(const Vec3d&) const { return normal; }
};

}  // namespace mpm
