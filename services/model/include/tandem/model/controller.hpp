// Hybrid position/force controller of one robot (paper Sec. VII-VIII):
//   selection matrices in the contact frame (eq. 17), force error turned into a position error through
//   K_S^-1 (eq. 20-21 text), an LLC law per axis (sliding mode eq. 25-28, PD eq. 35-36, or a
//   chattering-free variant), and the inverse-dynamics VLLC (eq. 21-22).
// The step is noexcept and allocation-free; the law is sampled once per control period and held.
#pragma once

#include <memory>

#include "tandem/model/arm.hpp"
#include "tandem/model/manipulator.hpp"
#include "tandem/model/reference.hpp"
#include "tandem/model/types.hpp"

namespace tandem::model {

enum class LawType {
  SlidingMode,    ///< eq. (27)-(28): K sgn(s), first order, sampled and held
  BoundaryLayer,  ///< K sat(s / Phi): continuous inside a layer of width Phi (ref. [15])
  SuperTwisting,  ///< k1 |s|^1/2 sgn(s) + v, v' = k2 sgn(s): second-order sliding mode (refs. [16], [17])
  PD,             ///< eq. (35)-(36)
};

/// Gains of the LLC laws. Position gains are per contact-frame axis (tangent, approach, orientation) and
/// act on the axes selected by Sigma_p; the force gains act on the axis selected by Sigma_h (eq. 17: the
/// approach axis). Table II / III values are the defaults.
struct LawGains {
  LawType type = LawType::SlidingMode;
  Vec3 K_p{10.0, 10.0, 10.0};      ///< SM / boundary-layer gain K_p of eq. (27); super-twisting bound L
  double K_h = 1.0;                ///< K_h of eq. (28)
  Vec3 m_p{5.0, 5.0, 5.0};         ///< sliding-surface slope m_p of eq. (25) [1/s]
  double m_h = 5.0;                ///< m_h of eq. (26) [1/s]
  Vec3 phi_p{0.05, 0.05, 0.05};    ///< boundary-layer width on s_p [m/s]
  double phi_h = 0.05;             ///< boundary-layer width on s_h [m/s]
  Vec3 kp_p{400.0, 450.0, 350.0};  ///< K_P,p of eq. (35)
  Vec3 kd_p{35.0, 35.0, 35.0};     ///< K_D,p of eq. (35)
  double kp_h = 40.0;              ///< K_P,h of eq. (36) (Table II, second row: the approach axis)
  double kd_h = 4.0;               ///< K_D,h of eq. (36)

  /// Per-axis values for a selection: position gain where selected, force gain elsewhere.
  static Vec3 pick(const Vec3& selection_p, const Vec3& pos, double force) noexcept {
    Vec3 v;
    for (int i = 0; i < 3; ++i) v(i) = selection_p(i) > 0.5 ? pos(i) : force;
    return v;
  }
};

/// Which parts of the model the VLLC (eq. 22) compensates in n^ (eq. 24: n~ = n^ - n is the uncertainty).
struct Compensation {
  bool coriolis = true;
  bool gravity = true;
  bool viscous = true;
  bool coulomb = true;
  double coulomb_band = 0.01;  ///< band of the controller's tanh(q'/band) estimate [rad/s]
  bool contact_force = true;   ///< the J^T h term of eq. (22), from the force sensor
};

/// Redundancy resolution of an arm with more joints than task coordinates (the planar 4R): the joint
/// acceleration y = J^+ (y~ - J' q') + (I - J^+ J) z of eq. (21) with the minimum-norm inverse J^+ = J^T (J J^T)^-1,
/// and in the null space a damped pull to a rest posture, z = -k_damping q' - k_posture (q - q_rest). J y is the
/// same as without z, so the task-space loop of eq. (25)-(28) is untouched; z only damps the self-motion that the
/// task leaves free and holds the arm near its posture (docs/controller.md, "Redundant arms").
struct NullSpace {
  double k_posture = 16.0;  ///< [1/s^2]
  double k_damping = 8.0;   ///< [1/s]
  /// The rest posture; empty (size 0): the first step's q. Set it (from the scenario) wherever controllers hand
  /// over: with the default, a standby or a restarted robot latches its own first q, and its null-space term starts
  /// from another posture than the one it takes over from (a torque step in the self-motion only; the end-effector
  /// is not disturbed). reset() keeps it.
  JointVec q_rest = JointVec::Zero(0);
};

struct HybridParams {
  Vec3 selection_p{1.0, 0.0, 1.0};  ///< diagonal of Sigma_p (eq. 17); Sigma_h = I - Sigma_p
  double contact_stiffness = 1.0e4; ///< K_S of eq. (19) used to scale the force error [N/m]
  bool feedforward_position = false;///< add Sigma_p x_d'' to y~ (not in eq. 21; see docs/controller.md)
  bool feedforward_force = true;    ///< add Sigma_h x_e'' (the planned motion of the contact surface)
  LawGains law{};
  Compensation comp{};
  double period = 1.0e-3;           ///< control period T [s]
  NullSpace null_space{};           ///< used only by arms with more than 3 joints
};

/// What the robot reads from its arm each period (joint space of the arm's type: 3 joints by default).
struct ArmSensors {
  JointVec q = JointVec::Zero(3);
  JointVec qd = JointVec::Zero(3);
  Vec2 h = Vec2::Zero();  ///< force the end-effector exerts on the object (force sensor) [N]
};

/// Diagnostics of one step (all in the world frame unless said otherwise).
struct ControlOutput {
  JointVec tau = JointVec::Zero(3);  ///< joint torques [N m] or forces [N]
  Vec3 e_p = Vec3::Zero();        ///< x_d - x (the paper's e_p, unselected)
  Vec3 e_c = Vec3::Zero();        ///< combined error in the contact frame (Sigma_p e_p + Sigma_h K_S^-1 e_h)
  Vec3 s = Vec3::Zero();          ///< sliding variables in the contact frame (eq. 25-26)
  double normal_force = 0.0;      ///< measured squeeze h_n = a . h [N]
  double e_h = 0.0;               ///< h_ref - h_n [N]
};

class HybridController {
 public:
  /// The identified 3R (or any ArmParams arm).
  HybridController(const ArmParams& arm, const HybridParams& params);
  /// Any manipulator type (manipulator.hpp); shared, immutable. std::invalid_argument for an arm of fewer than 3
  /// joints or a null_space.q_rest of the wrong size. step() with sensors of another size gives a NaN torque.
  HybridController(std::shared_ptr<const Manipulator> arm, const HybridParams& params);
  /// Clears the law's memory (force history, super-twisting integrator).
  void reset() noexcept;
  /// One control period: sensors at t_k and the reference for t_k in, torque for [t_k, t_k+1) out.
  ControlOutput step(const ArmSensors& in, const ArmReference& ref) noexcept;
  /// Bumpless transfer for a controller in shadow (a standby): the torque applied over the last period was
  /// `delta_tau` above this controller's own output of its last step. The super-twisting integral is shifted by
  /// the matching law output (u = R^T J B^-1 tau, eq. 20-22), so that this controller's next outputs continue
  /// from what the arm actually got: a standby that joined late (or a primary back from a stall) then takes
  /// over without a torque step. The other laws have no memory: nothing to shift.
  void track(const JointVec& delta_tau) noexcept;
  const HybridParams& params() const noexcept { return params_; }
  const Manipulator& arm() const noexcept { return *arm_; }

 private:
  /// y of eq. (21): J^-1 (y~ - J' q') for a square J; for a redundant arm the minimum-norm solution plus the
  /// null-space task (NullSpace).
  JointVec joint_acceleration(const TaskJacobian& J, const Vec3& task, const ArmSensors& in) noexcept;

  std::shared_ptr<const Manipulator> arm_;
  HybridParams params_;
  double prev_normal_force_ = 0.0;
  bool has_prev_ = false;
  Vec3 twisting_v_ = Vec3::Zero();
  TaskJacobian tau_to_u_ = TaskJacobian::Zero(3, 3);  ///< R^T J B^-1 of the last step (law output per torque)
  JointVec q_rest_ = JointVec::Zero(0);
};

/// Gains that satisfy the reaching conditions (eq. 33-34) for one arm, per contact-frame axis:
///   K_i >= sum_j |(R^T J)_ij| eta_j + eta_margin + |x_d,i''| (if not fed forward) + m |e_i'|.
/// J is sampled along the planned trajectory by the caller; this takes the worst case of one sample. J_contact is
/// R^T J (3 x n, any arm type) and eta_bound the per-joint disturbance bound (n entries).
Vec3 reaching_gain_bound(const TaskJacobian& J_contact, const JointVec& eta_bound, const Vec3& xdd_contact,
                         const Vec3& m, const Vec3& ed_bound, double eta_margin) noexcept;

/// Contact-frame rotation (tangent, approach, orientation) built from the reference orientation phi.
Mat3 contact_frame(double phi) noexcept;

}  // namespace tandem::model
