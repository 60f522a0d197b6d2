#pragma once
// A collider made of an analytic shape (core/shapes/): the shape's distance and normal are called inline
// for every node of a leaf, with one virtual call per leaf. The shapes are static, so the surface velocity
// is zero.
#include <cmath>
#include <sstream>

#include "core/Collider.h"

namespace mpm {

template <class Shape>
class ShapeCollider final : public Collider {
public:
    ShapeCollider(const Shape& shape, Boundary b, float friction) : Collider(b, friction), shape_(shape) {}

    const Shape& shape() const { return shape_; }
    double signedDistance(const Vec3d& x, double /*t*/) const override { return shape_.signedDistance(x); }
    Vec3d normal(const Vec3d& x, double /*t*/) const override { return shape_.normalAt(x); }
    Vec3d velocity(const Vec3d& /*x*/, double /*t*/) const override { return Vec3d::Zero(); }
    std::string describe() const override {
        std::ostringstream s;
        s << Shape::kType << " " << boundaryName(boundary()) << " friction " << friction();
        return s.str();
    }

    void applyToLeaf(const LeafView& leaf, const NodeBox& box, double dx, double t, ColliderContext*) const override {
        if (box.empty()) return;
        const double halfDiagonal = std::sqrt(3.0) * 0.5 * (kLeafDim - 1) * dx;
        const Vec3d centre = (leaf.origin.cast<double>() + Vec3d::Constant(0.5 * (kLeafDim - 1))) * dx;
        if (shape_.signedDistance(centre) > halfDiagonal) return;
        box.forEach([&](int n) {
            if (leaf.mass[n] == 0.0f) return;
            const Vec3d x = (leaf.origin + leafLocal(n)).cast<double>() * dx;
            if (shape_.signedDistance(x) > 0.0) return;
            Eigen::Map<Vec3f> v(leaf.momentum + 3 * n);
            v = respond(v, shape_.normalAt(x).template cast<float>(), velocity(x, t).template cast<float>(), boundary(),
                        friction());
        });
    }

private:
    Shape shape_;
};

}  // namespace mpm
