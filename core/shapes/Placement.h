#pragma once
// Where a file-based shape goes in the scene: {"translate": [x, y, z], "rotate": {"axis", "degrees"},
// "scale": s}, applied to the file's coordinates as x = translate + R (s x_file), so an asset is placed
// without editing it. Scale is uniform: a signed distance scales with it and stays one.
#include "core/shapes/Rotation.h"

namespace mpm {

struct Placement {
    Vec3d translate = Vec3d::Zero();
    Rotation rotate;
    double scale = 1.0;

    template <class V>
    static void keys(V& v, Placement& p) {
        v.vec3(Key{.name = "translate", .help = "offset added last", .unit = "m"}, p.translate);
        v.object(Key{.name = "rotate", .help = "turn about the file's origin, after scaling"},
                 [&](auto& r) { Rotation::keys(r, p.rotate); });
        v.number(Key{.name = "scale", .help = "uniform scale about the file's origin, first", .lo = 1e-6, .hi = 1e6}, p.scale);
    }
    bool identity() const { return translate.isZero() && rotate.degrees == 0.0 && scale == 1.0; }
    Vec3d apply(const Vec3d& x) const { return translate + rotate.matrix() * (scale * x); }
};

}  // namespace mpm
