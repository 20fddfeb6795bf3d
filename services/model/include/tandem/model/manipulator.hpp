// Manipulator model interface (issue "heterogeneous modules"): one planar arm of any supported type seen
// through the quantities the controller and the plant need (paper eq. 1-3 for the 3R; the same structure for
// any serial arm, "provided that the specific model of each manipulator is considered", Sec. I):
//   forward kinematics x = k(q) with x = [px, py, phi], the analytic Jacobian J(q) and J'(q, q'),
//   the joint-space inertia B(q), Coriolis C(q, q') with B' - 2C skew, gravity g(q) = dU/dq and friction.
//
// Types:
//   - Planar3R: the identified SMART3-S2 (lumped gammas of model-parameters.md), the functions of arm.hpp.
//   - PlanarChain: a serial chain of up to kMaxJoints rigid bodies joined by revolute or prismatic joints,
//     with its dynamics from the bodies' masses and inertias. It gives the cartesian PPR (two prismatic
//     joints and a wrist) and the redundant planar 4R.
//
// Style: a const model (the parameters; Pinocchio's Model) and the state passed in (its Data is the caller's
// q, q'). Joint-space values use Eigen types with a fixed maximum size, so nothing here allocates.
// Conventions as in arm.hpp: x right, y up, gravity along -y, angles clockwise from +y.
#pragma once

#include <array>
#include <memory>
#include <string>

#include "tandem/model/arm.hpp"
#include "tandem/model/types.hpp"

namespace tandem::model {


enum class ArmKind { Planar3R, CartesianPPR, Planar4R };
enum class JointType { Revolute, Prismatic };

/// The scenario's name of a kind ("planar_3r", "cartesian_ppr", "planar_4r").
const char* arm_kind_name(ArmKind k) noexcept;
/// Parses a scenario's kind name; false if unknown.
bool parse_arm_kind(const std::string& name, ArmKind& out) noexcept;

/// What every type has: joint types, friction (eq. 3 per joint: viscous Fv and smoothed Coulomb Fs),
/// limits (rad or m; N m or N), the base and gravity.
struct JointSpace {
  int dof = 3;
  std::array<JointType, kMaxJoints> type{JointType::Revolute, JointType::Revolute, JointType::Revolute,
                                         JointType::Revolute};
  std::array<double, kMaxJoints> viscous{};  ///< [N m s/rad] or [N s/m]
  std::array<double, kMaxJoints> coulomb{};  ///< [N m] or [N]
  double coulomb_band = 0.01;                ///< band of Fs tanh(q'/band) [rad/s or m/s]
  std::array<double, kMaxJoints> q_min{};
  std::array<double, kMaxJoints> q_max{};
  std::array<double, kMaxJoints> effort_max{};  ///< torque [N m] or force [N] limits
  Vec2 base{0.0, 0.0};                          ///< position of the first joint in the world frame [m]
  double g0 = 9.81;
  /// The posture the inverse kinematics starts from (and stays near, for a redundant arm), and the rest posture
  /// of a redundant arm's null-space task (NullSpace::q_rest) [rad or m]. The 3R's closed form ignores it.
  std::array<double, kMaxJoints> home{};
};

class Manipulator {
 public:
  virtual ~Manipulator() = default;
  Manipulator(const Manipulator&) = delete;
  Manipulator& operator=(const Manipulator&) = delete;

  virtual ArmKind kind() const noexcept = 0;
  const JointSpace& joints() const noexcept { return joints_; }
  int dof() const noexcept { return joints_.dof; }

  /// [px, py, phi] of the end-effector in the world frame.
  virtual Vec3 forward_kinematics(const JointVec& q) const noexcept = 0;
  /// Analytic Jacobian: x' = J(q) q'.
  virtual TaskJacobian jacobian(const JointVec& q) const noexcept = 0;
  /// J'(q, q') along the motion.
  virtual TaskJacobian jacobian_dot(const JointVec& q, const JointVec& qd) const noexcept = 0;
  /// B(q), symmetric positive definite.
  virtual JointMat inertia(const JointVec& q) const noexcept = 0;
  /// C(q, q') with B' - 2C skew-symmetric.
  virtual JointMat coriolis(const JointVec& q, const JointVec& qd) const noexcept = 0;
  /// g(q) = dU/dq.
  virtual JointVec gravity(const JointVec& q) const noexcept = 0;
  /// U(q), whose gradient is gravity().
  virtual double potential_energy(const JointVec& q) const noexcept = 0;

  /// Fv q' + Fs tanh(q'/band); band <= 0 gives Fs sgn(q').
  JointVec friction(const JointVec& qd, double band) const noexcept;
  /// n(q, q') = C q' + friction (the joints' band) + g (eq. 3).
  JointVec nonlinear_terms(const JointVec& q, const JointVec& qd) const noexcept;
  /// q'' = B^-1 (tau - n - J^T h), h = [fx, fy, mu] exerted by the end-effector (eq. 2).
  JointVec forward_dynamics(const JointVec& q, const JointVec& qd, const JointVec& tau,
                            const Vec3& h) const noexcept;
  double kinetic_energy(const JointVec& q, const JointVec& qd) const noexcept;
  /// True if every joint is within [q_min, q_max].
  bool within_limits(const JointVec& q) const noexcept;
  /// The home posture as a joint vector (JointSpace::home).
  JointVec home() const noexcept;
  /// Joint values that put the end-effector at x = [px, py, phi]. The common part: Newton steps from `seed` with
  /// the minimum-norm inverse of J (a redundant arm ends near the seed, so a path solved sample by sample, each
  /// from the previous one, stays on one branch). `branch` picks a 3R's elbow (the sign of q2, closed form); other
  /// types ignore it. False if x is out of reach or only beyond a joint limit (then q is left unchanged).
  virtual bool inverse_kinematics(const Vec3& x, const JointVec& seed, double branch, JointVec& q) const noexcept;

 protected:
  explicit Manipulator(const JointSpace& joints) : joints_(joints) {}
  JointSpace joints_;
};

/// The identified SMART3-S2 and any arm with its lumped structure: the functions of arm.hpp.
class Planar3R final : public Manipulator {
 public:
  explicit Planar3R(const ArmParams& p);
  ArmKind kind() const noexcept override { return ArmKind::Planar3R; }
  const ArmParams& params() const noexcept { return p_; }
  Vec3 forward_kinematics(const JointVec& q) const noexcept override;
  TaskJacobian jacobian(const JointVec& q) const noexcept override;
  TaskJacobian jacobian_dot(const JointVec& q, const JointVec& qd) const noexcept override;
  JointMat inertia(const JointVec& q) const noexcept override;
  JointMat coriolis(const JointVec& q, const JointVec& qd) const noexcept override;
  JointVec gravity(const JointVec& q) const noexcept override;
  double potential_energy(const JointVec& q) const noexcept override;
  /// The closed form of arm.hpp (eq. 1 inverted); the seed is not used.
  bool inverse_kinematics(const Vec3& x, const JointVec& seed, double branch, JointVec& q) const noexcept override;

 private:
  ArmParams p_;
};

/// One rigid body of a planar chain and the joint that moves it relative to the previous body.
struct ChainBody {
  JointType joint = JointType::Revolute;
  /// Prismatic: the sliding direction, an angle clockwise from the previous body's +y axis (pi/2 = along +x
  /// for a first joint). Revolute: a constant offset added to q.
  double axis = 0.0;
  double length = 0.0;   ///< from this body's joint to the next joint (or the tool tip) along the body [m]
  double com = 0.0;      ///< centre of mass along the body from its joint [m]
  double mass = 0.0;     ///< [kg]
  double inertia = 0.0;  ///< about the centre of mass [kg m^2]
};

struct ChainParams {
  ArmKind kind = ArmKind::Planar4R;
  std::array<ChainBody, kMaxJoints> bodies{};
  JointSpace joints{};
};

/// A serial planar chain: B = sum_k m_k Jc_k^T Jc_k + I_k w_k w_k^T, C = sum_k m_k Jc_k^T Jc_k' (the planar
/// bodies' angular Jacobians w_k are constant), g = g0 sum_k m_k (Jc_k)_y^T, where Jc_k is the Jacobian of
/// body k's centre of mass (docs/model.md, "Manipulator types").
class PlanarChain final : public Manipulator {
 public:
  explicit PlanarChain(const ChainParams& p);
  ArmKind kind() const noexcept override { return p_.kind; }
  const ChainParams& params() const noexcept { return p_; }
  Vec3 forward_kinematics(const JointVec& q) const noexcept override;
  TaskJacobian jacobian(const JointVec& q) const noexcept override;
  TaskJacobian jacobian_dot(const JointVec& q, const JointVec& qd) const noexcept override;
  JointMat inertia(const JointVec& q) const noexcept override;
  JointMat coriolis(const JointVec& q, const JointVec& qd) const noexcept override;
  JointVec gravity(const JointVec& q) const noexcept override;
  double potential_energy(const JointVec& q) const noexcept override;
  /// Centre of mass of body k in the world frame (for tests and plots).
  Vec2 body_com(const JointVec& q, int k) const noexcept;

 private:
  ChainParams p_;
};

/// Default parameters of the cartesian PPR: an x carriage, a y column and a wrist link of the SMART3-S2's
/// third link's length; joint limits in metres around the base.
ChainParams cartesian_ppr();
/// Default parameters of the redundant planar 4R: four links of the SMART3-S2's reach (1.65 m in all).
ChainParams planar_4r();

/// A model of the given parameters' kind.
std::unique_ptr<Manipulator> make_manipulator(const ArmParams& p);
std::unique_ptr<Manipulator> make_manipulator(const ChainParams& p);

/// A Planar3R's joint space from its ArmParams (friction, limits, base, g0).
JointSpace joint_space(const ArmParams& p);

}  // namespace tandem::model
