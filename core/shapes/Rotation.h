#pragma once
// A rotation as a scene writes it: {"axis": [x, y, z], "degrees": a}, about the shape's centre.
#include <cmath>

#include "base/Parameters.h"

namespace mpm {

struct Rotation {
    Vec3d axis = Vec3d::UnitY();
    double degrees = 0.0;

    template <class V>
    static void keys(V& v, Rotation& r) {
        v.vec3(Key{.name = "axis", .help = "rotation axis (any length but zero)"}, r.axis);
        v.number(Key{.name = "degrees",
                     .help = "rotation angle, right-handed about the axis",
                     .lo = -1e6,
                     .hi = 1e6,
                     .unit = "degrees"},
                 r.degrees);
        v.check(r.axis.norm() >= kTiny, "axis", "must not be the zero vector");
    }
    Mat3d matrix() const {
        return degrees == 0.0 ? Mat3d::Identity()
                              : Mat3d(Eigen::AngleAxisd(degrees * M_PI / 180.0, axis.normalized()).toRotationMatrix());
    }
};

}  // namespace mpm
