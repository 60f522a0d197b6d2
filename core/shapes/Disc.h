#pragma once
// A flat disc, the mouth of a continuous source (a faucet, a hopper's outlet): material enters through it
// along its normal at the set's velocity (io/SceneBuilder.cpp makes the stream; core/Simulation.h emits it).
#include <cmath>

#include "materials/Parameters.h"

namespace mpm {

struct Disc {
    static constexpr const char* kType = "disc";
    Vec3d centre = Vec3d::Zero();
    Vec3d normal = Vec3d::UnitY();  ///< the side material flows out to (need not be unit length)
    double radius = 0.0;

    template <class V>
    static void keys(V& v, Disc& s) {
        v.vec3(Key{.name = "center", .help = "centre", .unit = "m", .required = true}, s.centre);
        v.vec3(Key{.name = "normal", .help = "the direction material flows out of it"}, s.normal);
        v.number(Key{.name = "radius", .help = "radius", .lo = kTiny, .hi = kHuge, .unit = "m", .required = true}, s.radius);
        v.check(s.normal.norm() >= kTiny, "normal", "must not be the zero vector");
    }

    double area() const { return M_PI * radius * radius; }
    Vec3d unitNormal() const { return normal.normalized(); }
};

}  // namespace mpm
