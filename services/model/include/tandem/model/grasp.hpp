// Two-robot grasp: virtual sticks (eq. 6-7), symmetric formulation and grasp matrix (eq. 8-10, 18),
// absolute and relative pose (eq. 11-12), and the safe-grasp force and condition (eq. 14, 16).
#pragma once

#include <Eigen/Core>

#include "tandem/model/types.hpp"

namespace tandem::model {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Mat6x12 = Eigen::Matrix<double, 6, 12>;
using Mat12x6 = Eigen::Matrix<double, 12, 6>;

/// Skew-symmetric matrix S(r) with S(r) f = r x f.
Mat3 skew(const Vec3& r) noexcept;

/// W_j of eq. (8): maps the generalized force h_j = [f; mu] on the j-th end-effector to the tip of its
/// virtual stick r_j. (The cross-product block is written so that the stick-tip moment is mu - r x f,
/// exactly as printed in eq. 8.)
Mat6 stick_transform(const Vec3& r) noexcept;

/// Grasp matrix W = [W_1 W_2] of eq. (9).
Mat6x12 grasp_matrix(const Vec3& r1, const Vec3& r2) noexcept;

/// Moore-Penrose pseudo-inverse W^+ = W^T (W W^T)^-1 of eq. (10) (W has full row rank).
Mat12x6 grasp_pseudo_inverse(const Mat6x12& W) noexcept;

/// Basis V of the null space of W (internal forces h_I of eq. 10): W V = 0, V^T V = I.
Mat12x6 grasp_null_space(const Mat6x12& W) noexcept;

/// Planar force-only grasp matrix of eq. (18): W = [I2 I2] and W^+ = [I2/2; I2/2].
Eigen::Matrix<double, 2, 4> planar_grasp_matrix() noexcept;
Eigen::Matrix<double, 4, 2> planar_grasp_pseudo_inverse() noexcept;

/// Safe-grasp force of eq. (16): h_sg = M g / (2 mu_s), the normal force each end-effector must apply so
/// that static friction at the two contacts carries the object's weight.
double safe_grasp_force(double mass, double mu_s, double g0) noexcept;

/// Largest deceleration of the held object that keeps eq. (14) at both contacts, from a grasp squeezed with
/// h_ref >= h_sg on each side (docs/failure-model.md, "Stops"). Along the approach axis the inertial force M a
/// is taken by the two normal forces; in the worst case one contact keeps h_ref (a force-controlled arm) and
/// the other alone gives way, so h_ref - M a >= h_sg. Along the faces friction must carry the weight and the
/// inertial force, M (g + a) <= 2 mu_s h_ref. With h_sg = M g / (2 mu_s) both give the same bound when
/// mu_s = 1/2 and the tighter one in general: a_max = min((h_ref - h_sg) / M, 2 mu_s h_ref / M - g).
double stop_deceleration_bound(double h_ref, double h_sg, double mass, double mu_s, double g0) noexcept;

/// Safe-grasp condition of eq. (14) for one contact: normal force at or above h_sg.
inline bool safe_grasp_holds(double normal_force, double h_sg) noexcept { return normal_force >= h_sg; }

/// Virtual stick r_j (eq. 6) of length `length` along the tool axis of an end-effector with orientation phi.
inline Vec2 virtual_stick(double length, double phi) noexcept { return length * approach_axis(phi); }

/// Pose [p_S; phi_S] of the tip of the j-th virtual stick, eq. (6)-(7).
inline Vec3 stick_tip(const Vec3& x_ee, double stick_length) noexcept {
  const Vec2 tip = x_ee.head<2>() + virtual_stick(stick_length, x_ee(2));
  return {tip(0), tip(1), x_ee(2)};
}

/// Absolute pose of eq. (11): [p_E; phi_E] = mean of the two stick tips.
Vec3 absolute_pose(const Vec3& tip1, const Vec3& tip2) noexcept;

/// Relative pose of eq. (12): [p_I; phi_I] = tip2 - tip1. Angles are not wrapped: with robot 1 at
/// phi = pi/2 and robot 2 at -pi/2, phi_I = -pi (the paper's pi modulo 2 pi) and phi_E = 0.
Vec3 relative_pose(const Vec3& tip1, const Vec3& tip2) noexcept;

}  // namespace tandem::model
