#pragma once
// A flat disc, the mouth of a continuous source (a faucet, a hopper's outlet): material enters through it
// along its normal at the set's velocity (io/SceneBuilder.cpp makes the stream; core/Simulation.h emits it).
#include <cmath>
#include <vector>

#include "base/Parameters.h"

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
    /// Two in-plane directions, u and w = normal x u.
    void sides(Vec3d& u, Vec3d& w) const {
        u = unitNormal().unitOrthogonal();
        w = unitNormal().cross(u);
    }
    /// The largest in-plane distance from the centre to the outline.
    double reach() const { return radius; }
    /// A layer of a stream's body-centred stacking, as in-plane offsets (s, t) along (u, w): the square lattice of
    /// `spacing` inside the disc, shifted by half a spacing both ways in layer 1.
    std::vector<Eigen::Vector2d> lattice(int layer, double spacing) const {
        const int n = int(std::ceil(radius / spacing)) + 1;
        const double shift = 0.5 * layer;
        std::vector<Eigen::Vector2d> out;
        for (int a = -n; a <= n; ++a)
            for (int b = -n; b <= n; ++b) {
                const double s = (a + shift) * spacing, t = (b + shift) * spacing;
                if (s * s + t * t < radius * radius) out.emplace_back(s, t);
            }
        return out;
    }
};

}  // namespace mpm
