#pragma once
// What a solid's shape says about it as a rigid body (core/RigidBody.h): its volume, its centroid and its inertia
// tensor about the centroid per unit density, in world axes as the scene places it. A shape that can be a body's
// gives these in closed form (massProperties()), and the points of its surface that test its contact with fixed
// colliders, each with the radius of the ball around it that the surface holds (a sphere: its centre and radius).
#include <vector>

#include "base/Types.h"

namespace mpm {

struct MassProperties {
    double volume = 0.0;               ///< [m^3]
    Vec3d centre = Vec3d::Zero();      ///< centroid [m]
    Mat3d inertia = Mat3d::Zero();     ///< about the centroid, per unit density [m^5]
    std::vector<Vec3d> contactPoints;  ///< on the surface as placed, or inside it by their radius [m]
    std::vector<double> contactRadii;  ///< per point: the surface lies this far beyond it (a sphere's radius) [m]
};

/// Points on a box's surface as placed: corners, and a grid of kPerEdge points along each edge and on each face.
inline std::vector<Vec3d> boxSurfacePoints(const Vec3d& centre, const Vec3d& half, const Mat3d& R) {
    constexpr int kPerEdge = 5;  // 4 intervals: a box on a curved collider touches within a quarter of its face
    std::vector<Vec3d> out;
    for (int i = 0; i < kPerEdge; ++i)
        for (int j = 0; j < kPerEdge; ++j)
            for (int k = 0; k < kPerEdge; ++k) {
                const Vec3d u(i, j, k);
                const bool onFace = i == 0 || j == 0 || k == 0 || i == kPerEdge - 1 || j == kPerEdge - 1 || k == kPerEdge - 1;
                if (onFace) out.push_back(centre + R * (half.cwiseProduct(u * (2.0 / (kPerEdge - 1)) - Vec3d::Ones())));
            }
    return out;
}

}  // namespace mpm
