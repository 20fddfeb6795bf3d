// Plant of one basic module: two arms (eq. 2-3), the rigid object (eq. 13) and the two contacts
// (virtual spring of eq. 19 along the contact normal, stick-slip friction along the face), integrated
// with fixed-step RK4 and the control torque held over the control period.
#pragma once

#include <array>

#include "tandem/model/arm.hpp"
#include "tandem/model/disturbance.hpp"
#include "tandem/model/manipulator.hpp"
#include "tandem/model/types.hpp"

#include <memory>

namespace tandem::model {

/// Rigid box held at two opposite faces. Face j (j = 0 left, 1 right) lies at half_width from the centre.
struct ObjectParams {
  double mass = 2.0;         ///< M [kg]
  double half_width = 0.3;   ///< distance from the centre to each grasped face; equals the virtual stick [m]
  double half_height = 0.1;  ///< used for the default inertia of a uniform box [m]
  double inertia = 0.0;      ///< I_C [kg m^2]; 0 means M (w^2 + h^2) / 3 of a uniform box
  double mu_s = 0.5;         ///< static friction coefficient of the contacts
  double mu_k = 0.4;         ///< kinetic friction coefficient (<= mu_s)
  double effective_inertia() const noexcept {
    return inertia > 0.0 ? inertia : mass * (half_width * half_width + half_height * half_height) / 3.0;
  }
};

/// Point contacts between the end-effector tips and the object faces.
struct ContactParams {
  double k_normal = 1.0e4;   ///< K_S of eq. (19) along the normal [N/m]
  double d_normal = 50.0;    ///< contact damping along the normal [N s/m]
  double k_tangent = 1.0e5;  ///< stiffness of the sticking contact along the face [N/m]
  double d_tangent = 300.0;  ///< damping of the sticking contact along the face [N s/m]
};

struct ModuleParams {
  /// The identified 3R's parameters of each arm (used when `models[j]` is empty).
  std::array<ArmParams, 2> arms{};
  /// Each arm's model, of any type (manipulator.hpp); empty: the Planar3R of `arms[j]`. Shared and immutable: the
  /// world, the robots and the supervisor of one module hold the same models.
  std::array<std::shared_ptr<const Manipulator>, 2> models{};
  ObjectParams object{};
  ContactParams contact{};
  std::array<Disturbance, 2> disturbance{};  ///< eq. (37), per arm
  double g0 = 9.81;
};

/// Arm j's model: `models[j]`, or a Planar3R of `arms[j]` if that is empty.
std::shared_ptr<const Manipulator> arm_model(const ModuleParams& p, int j);

/// Both arms' joint torques (or forces) of one period, each of its arm's joint count.
using ArmEfforts = std::array<JointVec, 2>;

/// Continuous state of the module. The object angle psi is counter-clockwise positive (a clockwise
/// rotation by a of the grasp increases both arms' phi by a and decreases psi by a).
struct ModuleState {
  std::array<JointVec, 2> q{JointVec::Zero(3), JointVec::Zero(3)};  ///< each of its arm's joint count
  std::array<JointVec, 2> qd{JointVec::Zero(3), JointVec::Zero(3)};
  Vec2 c = Vec2::Zero();   ///< object centre [m]
  double psi = 0.0;        ///< object orientation [rad]
  Vec2 cd = Vec2::Zero();  ///< object velocity
  double psid = 0.0;
};

/// What the contacts do at one instant.
struct ContactReading {
  std::array<Vec2, 2> h{Vec2::Zero(), Vec2::Zero()};  ///< force each end-effector exerts on the object (paper's h)
  std::array<double, 2> normal{0.0, 0.0};             ///< normal (squeeze) force magnitude [N]
  std::array<double, 2> tangential{0.0, 0.0};         ///< force along the face on the object [N]
  std::array<double, 2> penetration{0.0, 0.0};        ///< spring deflection [m]
  std::array<bool, 2> in_contact{false, false};
  Vec2 force_on_object = Vec2::Zero();  ///< sum of contact forces (no gravity)
  double torque_on_object = 0.0;        ///< counter-clockwise
};

/// Counters the plant keeps (slip and contact loss per RK4 substep, saturation per control period).
struct PlantCounters {
  long slip_events = 0;          ///< substeps in which a contact exceeded mu_s N and slid
  double slip_distance = 0.0;    ///< accumulated sliding along the faces [m]
  long contact_lost = 0;         ///< substeps with a contact carrying no normal force
  long torque_saturated = 0;     ///< control periods in which a commanded torque hit tau_max
  long joint_limit = 0;          ///< control periods that ended with a joint outside [q_min, q_max]
};

class ModulePlant {
 public:
  explicit ModulePlant(const ModuleParams& params);

  /// Sets the state and pre-loads the sticking contacts so that each face carries half the weight:
  /// the object starts in static equilibrium when it is level (psi = 0) and both arms press with the
  /// same normal force. (A tilted start is not in equilibrium: the pre-load is along the faces.)
  void reset(const ModuleState& state);

  /// Advances by dt with `substeps` RK4 steps, the torques held constant (zero-order hold); t is the time
  /// at the start of the period (for the disturbance). Efforts are clipped to each arm's limits; an effort
  /// vector of the wrong size counts as zero effort.
  void step(const ArmEfforts& tau, double t, double dt, int substeps) noexcept;
  /// The same for two 3-joint arms.
  void step(const std::array<Vec3, 2>& tau, double t, double dt, int substeps) noexcept;

  /// Brakes of arm j (an arm without a live controller): an ideal lock, the joints stop at once and are
  /// held where they are (q' = 0, q'' = 0) until released; the contacts and the object stay dynamic.
  /// Brakes of arm j: while on, its joints decelerate as qdd = -qd / kBrakeTimeConstant whatever the
  /// torques (the brake takes them), and stay locked once at rest.
  void set_brake(int j, bool on) noexcept;
  static constexpr double kBrakeTimeConstant = 0.05;  ///< T_b [s]: 95% of the speed gone in 0.15 s
  bool braked(int j) const noexcept { return braked_[static_cast<size_t>(j)]; }

  const ModuleState& state() const noexcept { return state_; }
  const ModuleParams& params() const noexcept { return params_; }
  const PlantCounters& counters() const noexcept { return counters_; }
  /// Contact forces at the current state.
  ContactReading contacts() const noexcept { return contact_forces(state_); }
  /// End-effector pose [px, py, phi] of arm j.
  Vec3 end_effector(int j) const noexcept;
  /// Arm j's model.
  const Manipulator& arm(int j) const noexcept { return *models_[static_cast<size_t>(j)]; }
  /// Arm j's identified-3R parameters if it is a Planar3R (its fixed-size fast path), else null.
  const ArmParams* planar3r(int j) const noexcept { return p3r_[static_cast<size_t>(j)]; }
  /// Total mechanical energy of arms and object (kinetic + gravity potential, contact springs excluded).
  double mechanical_energy() const noexcept;

 private:
  // [q_0 (4 slots), q_1 (4), q_0' (4), q_1' (4), c (2), psi, c' (2), psi']: slots past an arm's joint count stay 0.
  static constexpr int kSlots = kMaxJoints;
  static constexpr int kObject = 4 * kSlots;
  using StateVec = Eigen::Matrix<double, kObject + 6, 1>;
  /// Where arm j's joints (and rates) start in the state vector.
  static Eigen::Index slot_q(int j) noexcept { return static_cast<Eigen::Index>(kSlots) * j; }
  static Eigen::Index slot_qd(int j) noexcept { return static_cast<Eigen::Index>(kSlots) * (2 + j); }
  StateVec pack(const ModuleState& s) const noexcept;
  void unpack(const StateVec& v, ModuleState& s) const noexcept;
  /// Arm j's tip position and velocity at (q, q').
  Vec2 tip(int j, const JointVec& q, const JointVec& qd, Vec2* v) const noexcept;
  ContactReading contact_forces(const ModuleState& s) const noexcept;
  StateVec derivative(const StateVec& x, const ArmEfforts& tau, double t) const noexcept;
  void update_anchors() noexcept;

  ModuleParams params_;
  std::array<std::shared_ptr<const Manipulator>, 2> models_;
  /// The identified 3R's parameters of an arm that is a Planar3R (its fixed-size fast path), else null.
  std::array<const ArmParams*, 2> p3r_{nullptr, nullptr};
  ModuleState state_;
  std::array<double, 2> anchor_{0.0, 0.0};  ///< rest position of each sticking contact along its face
  PlantCounters counters_;
  std::array<bool, 2> braked_{false, false};
};

}  // namespace tandem::model
