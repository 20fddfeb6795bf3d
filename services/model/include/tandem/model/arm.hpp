// Planar three-joint arm: kinematics (paper eq. 1), analytic Jacobian and its derivative,
// dynamics B(q), C(q,q'), g(q) and friction (eq. 2-3) of the identified COMAU SMART3-S2.
//
// Conventions (docs/model.md):
//  - World frame: x to the right, y up, gravity along -y.
//  - Joint angles clockwise positive; q1 measured from the +y axis (paper Sec. III).
//  - Task coordinates x = [px, py, phi] of the end-effector in the world frame (the arm's base offset is
//    added), phi = q1 + q2 + q3.
//  - Gravity torque g(q) = dU/dq with U the potential energy for y up; this is the negative of the
//    published formula (whose q = 0 is a hanging pose), see docs/model.md "Sign of gravity".
#pragma once

#include <array>

#include "tandem/model/types.hpp"

namespace tandem::model {

/// Constant parameters of one arm (Pinocchio-style "Model"): identified lumped dynamics, geometry, limits.
/// Any planar 3R arm with the same structure of B(q) can be described by this struct.
struct ArmParams {
  /// Lumped inertial parameters gamma_1..gamma_6 (model-parameters.md Sec. 1); gamma_4 includes g0.
  std::array<double, 6> gamma{0.2973, 10.066, 87.9151, 57.0347, 9.2148, 0.3163};
  Vec3 link_length{0.65, 0.6576, 0.34};    ///< l1, l2, l3 [m]
  Vec3 viscous{190.4790, 20.9745, 4.6565};  ///< diag(Fv) [N m s/rad]
  Vec3 coulomb{66.3430, 14.7050, 8.2911};   ///< diag(Fs) [N m]
  /// Velocity band of the smoothed Coulomb term Fs tanh(q'/band) [rad/s] (eq. 3 smoothed).
  double coulomb_band = 0.01;
  double g0 = 9.81;               ///< gravity [m/s^2]
  Vec2 base{0.0, 0.0};            ///< position of joint 1 in the world frame [m]
  Vec3 q_min{-kPi, -kPi, -kPi};   ///< joint limits [rad]
  Vec3 q_max{kPi, kPi, kPi};
  Vec3 tau_max{3000.0, 1500.0, 500.0};  ///< actuator torque limits [N m]
};

/// The identified COMAU SMART3-S2 (Calanca et al. 2011, the paper's ref. [21]).
ArmParams smart3s2();

/// Direct kinematics, eq. (1) plus the base offset: returns [px, py, phi] in the world frame.
Vec3 forward_kinematics(const ArmParams& p, const Vec3& q) noexcept;

/// Analytic Jacobian of eq. (1): x' = J(q) q'.
Mat3 jacobian(const ArmParams& p, const Vec3& q) noexcept;

/// Time derivative of the analytic Jacobian along the motion q'.
Mat3 jacobian_dot(const ArmParams& p, const Vec3& q, const Vec3& qd) noexcept;

/// Inertia matrix B(q) of eq. (2) (symmetric positive definite).
Mat3 inertia(const ArmParams& p, const Vec3& q) noexcept;

/// Partial derivatives dB/dq_k, k = 0..2.
std::array<Mat3, 3> inertia_partials(const ArmParams& p, const Vec3& q) noexcept;

/// Coriolis/centripetal matrix C(q, q') from the Christoffel symbols of B, so that B' - 2C is skew.
Mat3 coriolis(const ArmParams& p, const Vec3& q, const Vec3& qd) noexcept;

/// Gravity torque g(q) = dU/dq for y up (see file comment).
Vec3 gravity(const ArmParams& p, const Vec3& q) noexcept;

/// Potential energy U(q) whose gradient is gravity(); zero reference at the horizontal pose.
double potential_energy(const ArmParams& p, const Vec3& q) noexcept;

/// Friction torque Fv q' + Fs tanh(q'/band) (eq. 3, Coulomb term smoothed with the given band).
/// A band <= 0 gives the discontinuous Fs sgn(q').
Vec3 friction(const ArmParams& p, const Vec3& qd, double band) noexcept;

/// n(q, q') of eq. (3) with the plant's friction band.
Vec3 nonlinear_terms(const ArmParams& p, const Vec3& q, const Vec3& qd) noexcept;

/// Forward dynamics of eq. (2): q'' = B^-1 (tau - n(q, q') - J^T h), where h = [fx, fy, mu] is the
/// generalized force the end-effector exerts on the environment.
Vec3 forward_dynamics(const ArmParams& p, const Vec3& q, const Vec3& qd, const Vec3& tau,
                      const Vec3& h) noexcept;

/// Kinetic energy q'^T B q' / 2.
double kinetic_energy(const ArmParams& p, const Vec3& q, const Vec3& qd) noexcept;

/// Closed-form inverse kinematics of eq. (1): joint angles placing the end-effector at x (world frame).
/// elbow_sign = +1 or -1 picks the elbow branch (sign of q2). Returns false if x is out of reach.
bool inverse_kinematics(const ArmParams& p, const Vec3& x, double elbow_sign, Vec3& q) noexcept;
/// The same into a joint vector (a module state's; it gets 3 entries).
bool inverse_kinematics(const ArmParams& p, const Vec3& x, double elbow_sign, JointVec& q) noexcept;

}  // namespace tandem::model
