#pragma once
// The mass properties of a closed triangle mesh (a solid polyhedron) as a rigid body's (core/RigidBody.h): the mesh is
// cut into tetrahedra from a reference point, one per triangle, and their volumes, first moments and covariances
// C = integral of x x^T dV summed; each is the canonical tetrahedron's covariance mapped by A = [a b c]:
//   C_tet = det(A) A C' A^T,  C' = (1/120) [[2 1 1] [1 2 1] [1 1 2]]
// (Blow and Binstock 2004, "How to find the inertia tensor (or other mass properties) of a 3D solid body represented
// by a triangle mesh"). Triangles wound clockwise seen from outside give a negative volume: the sums then change sign.
// Inertia about the centroid per unit density: I = tr(C_c) Id - C_c with C_c = C - V c c^T.
// Contact samples: every vertex, and points on each triangle no farther apart than `spacing`, all of radius 0.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/shapes/MassProperties.h"

namespace mpm {

inline MassProperties polyhedronMassProperties(const std::vector<Vec3d>& points, const std::vector<Eigen::Vector3i>& triangles,
                                               double spacing) {
    MassProperties m;
    if (points.empty()) return m;
    // Sums about a point of the mesh keep their precision far from the origin.
    Eigen::AlignedBox3d box;
    for (const Vec3d& p : points) box.extend(p);
    const Vec3d origin = box.center();
    Mat3d canonical;
    canonical << 2, 1, 1, 1, 2, 1, 1, 1, 2;
    canonical /= 120.0;
    double volume = 0.0;
    Vec3d moment = Vec3d::Zero();
    Mat3d covariance = Mat3d::Zero();
    for (const Eigen::Vector3i& t : triangles) {
        Mat3d A;
        A.col(0) = points[std::size_t(t[0])] - origin;
        A.col(1) = points[std::size_t(t[1])] - origin;
        A.col(2) = points[std::size_t(t[2])] - origin;
        const double det = A.determinant();
        volume += det / 6.0;
        moment += det / 24.0 * (A.col(0) + A.col(1) + A.col(2));
        covariance += det * A * canonical * A.transpose();
    }
    if (volume < 0.0) volume = -volume, moment = -moment, covariance = -covariance;
    m.volume = volume;
    const Vec3d centroid = volume > 0.0 ? Vec3d(moment / volume) : Vec3d::Zero();
    const Mat3d central = covariance - volume * centroid * centroid.transpose();
    m.inertia = central.trace() * Mat3d::Identity() - central;
    m.centre = origin + centroid;
    // The vertices, and each triangle's points on a barycentric lattice of n intervals per edge, n from its longest edge.
    m.contactPoints = points;
    for (const Eigen::Vector3i& t : triangles) {
        const Vec3d &a = points[std::size_t(t[0])], &b = points[std::size_t(t[1])], &c = points[std::size_t(t[2])];
        const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
        const int n = spacing > 0.0 ? int(std::ceil(longest / spacing)) : 1;
        for (int i = 0; i <= n; ++i)
            for (int j = 0; i + j <= n; ++j) {
                const int k = n - i - j;
                if (i == n || j == n || k == n) continue;  // the corners: vertices already
                m.contactPoints.push_back((double(i) * a + double(j) * b + double(k) * c) / double(n));
            }
    }
    m.contactRadii.assign(m.contactPoints.size(), 0.0);
    return m;
}

}  // namespace mpm
