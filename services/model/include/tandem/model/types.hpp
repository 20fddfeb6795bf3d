// Fixed-size Eigen types used across the model layer. Nothing here allocates.
#pragma once

#include <Eigen/Core>
#include <Eigen/Dense>

namespace tandem::model {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;

/// The most joints an arm of any type has (manipulator.hpp).
inline constexpr int kMaxJoints = 4;
/// Joint-space vector of 1..kMaxJoints entries (stack storage).
using JointVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxJoints, 1>;
/// Joint-space square matrix (stack storage).
using JointMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxJoints, kMaxJoints>;
/// Task Jacobian: 3 task coordinates [px, py, phi] by n joints (stack storage).
using TaskJacobian = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxJoints>;

inline constexpr double kPi = 3.14159265358979323846;

/// Unit vector of the tool (approach) axis for an orientation phi measured from the y-axis,
/// clockwise positive (paper Sec. III): phi = 0 points along +y, phi = pi/2 along +x.
inline Vec2 approach_axis(double phi) { return {std::sin(phi), std::cos(phi)}; }

/// Wraps an angle to (-pi, pi].
inline double wrap_angle(double a) {
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

}  // namespace tandem::model
