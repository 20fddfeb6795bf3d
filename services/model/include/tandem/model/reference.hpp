// Supervisor's reference generation: a time-parametrised object path and eq. (15), which turns the
// desired absolute pose of the object into a pose reference for each end-effector.
#pragma once

#include <vector>

#include "tandem/model/types.hpp"

namespace tandem::model {

/// Pose, velocity and acceleration of [px, py, phi] at one instant.
struct PoseSample {
  Vec3 pose = Vec3::Zero();
  Vec3 vel = Vec3::Zero();
  Vec3 acc = Vec3::Zero();
};

/// Piecewise quintic path of the object's absolute pose [p_E; phi_E] (eq. 11): rest-to-rest segments,
/// each with zero velocity and acceleration at its ends, so the reference is C^2 (Theorem 1's assumption).
class ObjectPath {
 public:
  struct Segment {
    Vec3 to = Vec3::Zero();
    double duration = 1.0;
  };
  ObjectPath() = default;
  /// start: pose at t = 0; holds there for `hold` seconds, then runs the segments in order.
  ObjectPath(const Vec3& start, double hold, std::vector<Segment> segments);
  PoseSample sample(double t) const noexcept;
  double motion_end() const noexcept;  ///< time at which the last segment ends

 private:
  Vec3 start_ = Vec3::Zero();
  double hold_ = 0.0;
  std::vector<Segment> segments_;
};

/// Time scaling of a path, for pausing and resuming a module without a jump in the reference: the path is
/// sampled at tau(t), whose rate r = dtau/dt moves between 0 (paused) and 1 (normal) along a cubic Hermite
/// ramp r0 + (r1 - r0)(3u^2 - 2u^3) + r0' T (u^3 - 2u^2 + u), u = (t - t0)/T, r0' the rate's slope where the
/// retarget cuts in (bounded so that r stays in [0, 1] and does not pass r1): r and dr/dt are continuous at the
/// ramp's ends, and so is the path's acceleration, even for a stop that cuts into a resume.
/// tau is integrated in closed form (no drift), and every retarget is kept, so a time before the latest
/// retarget samples exactly as it did before it (a supervisor answering a repeated tick gives the same).
class TimeScale {
 public:
  struct Sample {
    double tau = 0.0;       ///< path time
    double rate = 1.0;      ///< dtau/dt
    double rate_dot = 0.0;  ///< d2tau/dt2
  };
  TimeScale() = default;
  /// From time t0 on (t0 not before the latest retarget), the rate moves to `rate` over `ramp` seconds
  /// (ramp 0: at once).
  void retarget(double t0, double rate, double ramp);
  Sample at(double t) const noexcept;
  /// From time t0 on (t0 not before the latest retarget) the path stands paused at path time tau0: a jump in
  /// path time, for a module whose arms were braked while the path still ran (the object stopped behind its
  /// plan); the next retarget resumes from tau0.
  void rebase(double t0, double tau0) { breaks_.push_back({t0, tau0, 0.0, 0.0, 0.0, 0.0}); }
  double target() const noexcept { return breaks_.empty() ? 1.0 : breaks_.back().r1; }
  /// True once the latest ramp is over at time t.
  bool settled(double t) const noexcept {
    return breaks_.empty() || t >= breaks_.back().t0 + breaks_.back().ramp;
  }
  /// The latest `max` retargets as numbers, five per retarget (t0, tau0, r0, r1, ramp): what a standby
  /// supervisor needs to sample the same path times. Older ones only matter for times before the oldest
  /// kept, which a supervisor never samples again.
  std::vector<double> export_breaks(size_t max) const;
  /// Replaces the retargets with exported ones; false (and nothing changed) unless the size is a multiple
  /// of five, every number is finite, the t0 do not decrease and every ramp is >= 0.
  bool restore(const std::vector<double>& flat);

 private:
  struct Break {
    double t0, tau0, r0, r1, ramp;
    double rd0;  ///< the rate's slope at t0 (from the breaks before; not exported: restore recomputes it)
  };
  static Break next_break(double t0, const Sample& s, double rate, double ramp) noexcept;
  std::vector<Break> breaks_;
};

/// The path sampled through a time scale: pose p(tau), velocity p'(tau) r, acceleration p''(tau) r^2 + p'(tau) r'.
PoseSample sample_scaled(const ObjectPath& path, const TimeScale::Sample& s, double tau_offset = 0.0) noexcept;

/// How the supervisor places the two end-effectors around the object (eq. 15).
struct GraspGeometry {
  double stick_length[2] = {0.3, 0.3};  ///< |r_j| [m]
  double phi_I = -kPi;                  ///< relative orientation phi_S2 - phi_S1 (the paper's pi, mod 2 pi)
  Vec2 p_I = Vec2::Zero();              ///< relative position of the stick tips (0: both at the centre)
  /// Extra push of each end-effector into the object along its approach axis [m]; the supervisor sets it
  /// to h_ref / K_S so that a position-controlled arm holds the grasp force at the planned object pose.
  double preload = 0.0;
};

/// Reference of one arm for one control period: pose, its derivatives and the grasp force.
struct ArmReference {
  Vec3 x = Vec3::Zero();    ///< x_d [px, py, phi]
  Vec3 xd = Vec3::Zero();   ///< x_d'
  Vec3 xdd = Vec3::Zero();  ///< x_d''
  double force = 0.0;       ///< normal grasp force reference h_ref [N]
};

/// eq. (15) for arm j (0 or 1): x_d,j = [p_Ed - r_j -/+ p_Id/2; phi_Ed -/+ phi_Id/2], with the sign
/// "-" for j = 0 and "+" for j = 1 so that eq. (12) holds (p_I = p_S2 - p_S1). The stick r_j rotates
/// with the reference orientation, and its derivatives are propagated exactly.
ArmReference arm_reference(int j, const PoseSample& object, const GraspGeometry& g, double force) noexcept;

}  // namespace tandem::model
