#pragma once
// The colliders a scene can hold: an analytic shape (core/shapes/) or a level set (core/LevelSetGeometry.h),
// posed by a motion, and shorthands for code that builds them directly (tests, benchmarks).
#include <memory>

#include "core/RigidCollider.h"
#include "core/shapes/Shapes.h"

namespace mpm {

/// A collider of an analytic shape.
template <class S>
std::unique_ptr<Collider> analyticCollider(const S& shape, Boundary b, float friction, Motion motion = Motion(),
                                           bool inside = false) {
    return std::make_unique<RigidCollider<AnalyticGeometry<S>>>(AnalyticGeometry<S>{shape}, b, friction, std::move(motion),
                                                                inside);
}

inline std::unique_ptr<Collider> planeCollider(const Vec3d& point, const Vec3d& normal, Boundary b, float friction) {
    return analyticCollider(Plane::through(point, normal), b, friction);
}

inline std::unique_ptr<Collider> sphereCollider(const Vec3d& centre, double radius, Boundary b, float friction) {
    return analyticCollider(Sphere{centre, radius}, b, friction);
}

}  // namespace mpm
