#pragma once
// Fixed-size math types shared by every module. Eigen only: this header must stay cheap to include,
// so nothing from OpenVDB or oneTBB appears here.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cstdint>

namespace mpm {

using Vec3f = Eigen::Vector3f;
using Vec3d = Eigen::Vector3d;
using Vec3i = Eigen::Vector3i;
using Mat3f = Eigen::Matrix3f;
using Mat3d = Eigen::Matrix3d;
template <class T>
using Mat3T = Eigen::Matrix<T, 3, 3>;
template <class T>
using Vec3T = Eigen::Matrix<T, 3, 1>;

}  // namespace mpm
