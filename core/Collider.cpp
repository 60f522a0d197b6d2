#include "core/Collider.h"

#include <cmath>

namespace mpm {

const char* boundaryName(Boundary b) {
    switch (b) {
        case Boundary::Sticky:
            return "sticky";
        case Boundary::Slip:
            return "slip";
        case Boundary::Separate:
            return "separate";
    }
    return "?";
}

Vec3f Collider::respond(const Vec3f& v, const Vec3f& n, const Vec3f& vc, Boundary boundary, float friction) {
    if (boundary == Boundary::Sticky) return vc;
    const Vec3f rel = v - vc;
    const float vn = rel.dot(n);
    Vec3f tangential = rel - vn * n;
    // A node moving away from the surface is in no compressive contact, so it carries no friction: `separate`
    // lets it go, `slip` only holds it on the surface (a tensile normal impulse, which Coulomb's law does not scale).
    if (vn >= 0.0f) return boundary == Boundary::Separate ? v : Vec3f(vc + tangential);
    // Coulomb: the tangential change is bounded by mu times the normal change |vn|.
    const float vt = tangential.norm();
    const float maxFriction = friction * std::fabs(vn);
    if (vt <= maxFriction)
        tangential.setZero();
    else
        tangential *= 1.0f - maxFriction / vt;
    return vc + tangential;
}

}  // namespace mpm
