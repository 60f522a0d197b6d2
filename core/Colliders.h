#pragma once
// The colliders a scene can hold, one shape each (core/shapes/Shapes.h), and shorthands for code that
// builds them directly (tests, benchmarks).
#include <memory>

#include "core/ShapeCollider.h"
#include "core/shapes/Shapes.h"

namespace mpm {

/// A collider for any shape of the collider list.
inline std::unique_ptr<Collider> makeCollider(const ColliderShape& shape, Boundary b, float friction) {
    return std::visit(
        [&]<class S>(const S& s) -> std::unique_ptr<Collider> { return std::make_unique<ShapeCollider<S>>(s, b, friction); },
        shape);
}

inline std::unique_ptr<Collider> planeCollider(const Vec3d& point, const Vec3d& normal, Boundary b, float friction) {
    return std::make_unique<ShapeCollider<Plane>>(Plane::through(point, normal), b, friction);
}

inline std::unique_ptr<Collider> sphereCollider(const Vec3d& centre, double radius, Boundary b, float friction) {
    return std::make_unique<ShapeCollider<Sphere>>(Sphere{centre, radius}, b, friction);
}

}  // namespace mpm
