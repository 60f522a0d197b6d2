#include "core/Collider.h"

#include <cmath>
#include <sstream>

#include "sparse/SparseGrid.h"

namespace mpm {

const char* boundaryName(Boundary b) {
    switch (b) {
        case Boundary::Sticky: return "sticky";
        case Boundary::Slip: return "slip";
        case Boundary::Separate: return "separate";
    }
    return "?";
}

Vec3f Collider::respond(const Vec3f& v, const Vec3f& n, const Vec3f& vc, Boundary boundary, float friction) {
    if (boundary == Boundary::Sticky) return vc;
    const Vec3f rel = v - vc;
    const float vn = rel.dot(n);
    if (boundary == Boundary::Separate && vn >= 0.0f) return v;  // leaving the object: no contact
    Vec3f tangential = rel - vn * n;
    // Coulomb: the tangential change is bounded by mu times the normal change |vn|.
    const float vt = tangential.norm();
    const float maxFriction = friction * std::fabs(vn);
    if (vt <= maxFriction) tangential.setZero();
    else tangential *= 1.0f - maxFriction / vt;
    return vc + tangential;
}

void Collider::applyToLeaf(const LeafView& leaf, const NodeBox& box, double dx, double time) const {
    if (box.empty()) return;
    const double halfDiagonal = std::sqrt(3.0) * 0.5 * (kLeafDim - 1) * dx;
    const Vec3d centre = (leaf.origin.cast<double>() + Vec3d::Constant(0.5 * (kLeafDim - 1))) * dx;
    if (signedDistance(centre) > halfDiagonal) return;
    box.forEach([&](int n) {
        if (leaf.mass[n] == 0.0f) return;
        const Vec3d x = (leaf.origin + Vec3i(n >> (2 * kLeafLog2), (n >> kLeafLog2) & (kLeafDim - 1), n & (kLeafDim - 1)))
                            .cast<double>() * dx;
        if (signedDistance(x) > 0.0) return;
        Eigen::Map<Vec3f> v(leaf.momentum + 3 * n);
        v = respond(v, normal(x).cast<float>(), velocity(x, time).cast<float>(), boundary(), friction());
    });
}

PlaneCollider::PlaneCollider(const Vec3d& point, const Vec3d& normal, Boundary b, float friction)
    : Collider(b, friction), point_(point), normal_(normal.normalized()) {}

std::string PlaneCollider::describe() const {
    std::ostringstream s;
    s << "plane point (" << point_.transpose() << ") normal (" << normal_.transpose() << ") " << boundaryName(boundary())
      << " friction " << friction();
    return s.str();
}

SphereCollider::SphereCollider(const Vec3d& centre, double radius, Boundary b, float friction)
    : Collider(b, friction), centre_(centre), radius_(radius) {}

Vec3d SphereCollider::normal(const Vec3d& x) const {
    const Vec3d d = x - centre_;
    const double len = d.norm();
    return len > 0.0 ? Vec3d(d / len) : Vec3d::UnitY();
}

std::string SphereCollider::describe() const {
    std::ostringstream s;
    s << "sphere centre (" << centre_.transpose() << ") radius " << radius_ << " " << boundaryName(boundary())
      << " friction " << friction();
    return s.str();
}

}  // namespace mpm
