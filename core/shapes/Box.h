#pragma once
// Axis-aligned box [min, max). Fills a particle set; its signed distance is the exact one of a box
// (inside: minus the distance to the nearest face).
#include <algorithm>
#include <cmath>

#include "materials/Parameters.h"

namespace mpm {

struct Box {
    static constexpr const char* kType = "box";
    Vec3d min = Vec3d::Zero(), max = Vec3d::Zero();

    template <class V>
    static void keys(V& v, Box& s) {
        v.vec3(Key{.name = "min", .help = "lowest corner", .unit = "m", .required = true}, s.min);
        v.vec3(Key{.name = "max", .help = "highest corner", .unit = "m", .required = true}, s.max);
        v.check((s.max - s.min).minCoeff() > 0, "max", "must exceed min in every axis");
    }

    double signedDistance(const Vec3d& x) const {
        const Vec3d centre = 0.5 * (min + max), half = 0.5 * (max - min);
        const Vec3d q = (x - centre).cwiseAbs() - half;
        return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    bool contains(const Vec3d& x) const { return (x.array() >= min.array()).all() && (x.array() < max.array()).all(); }
    double volume() const { return (max - min).prod(); }
    void bounds(Vec3d& lo, Vec3d& hi) const {
        lo = min;
        hi = max;
    }
};

}  // namespace mpm
