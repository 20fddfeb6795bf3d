// The module's plan: what decides every reference of a module (docs/architecture.md, "Per-tick data flow").
// The supervisor makes it (ModulePlan: tasks, pause/resume/brake retargets of the time scale, drain) and
// publishes it when it changes; every robot and the world follow it (PlanFollower) and evaluate eq. (15) for
// any tick themselves, so the supervisor is off the per-tick path. Plain data and logic, no DDS.
#pragma once

#include <cstdint>
#include <string>
#include <cmath>
#include <vector>

#include "tandem/model/reference.hpp"
#include "tandem/sim/module_setup.hpp"

namespace tandem::plan {

/// Rank of a supervisor and of the plans it publishes: the latest epoch it led (0 until it first takes over;
/// a takeover starts the epoch after the highest one heard), then its strength. The highest rank leads: a
/// supervisor that was only stalled comes back with its old epoch, below the one that took over from it.
struct SupervisorRank {
  uint64_t epoch = 0;
  int32_t strength = 0;
  bool outranks(const SupervisorRank& o) const { return epoch != o.epoch ? epoch > o.epoch : strength > o.strength; }
};

inline constexpr int kPrimaryStrength = 100;

/// A supervisor strength on the wire is in [1, kPrimaryStrength]; an epoch below 2^32.
inline bool valid_rank(int64_t strength, uint64_t epoch) {
  return strength >= 1 && strength <= kPrimaryStrength && epoch < (1ULL << 32);
}

/// True if every value is finite.
template <class Array>
bool all_finite(const Array& a) {
  for (double v : a) {
    if (!(v == v) || v > 1e300 || v < -1e300) return false;
  }
  return true;
}

/// Task state of a module as the coordinator sees it (TaskState.state on the wire).
/// Failed: the world reports the module's object dropped (or slid out of the grasp): its task is not done.
enum class TaskStateCode : uint8_t { Idle = 0, Running = 1, Done = 2, Paused = 3, Draining = 4, Left = 5, Failed = 6 };

/// The state's name as status and logs show it ("failed (object dropped)" for Failed); "unknown" past Failed.
inline const char* task_state_name(uint8_t state) {
  static const char* const names[] = {"idle", "running", "done", "paused", "draining", "left", "failed (object dropped)"};
  return state <= static_cast<uint8_t>(TaskStateCode::Failed) ? names[state] : "unknown";
}

/// The plan as it travels (SupervisorPlan on the wire; services/runtime converts).
/// Lockstep: the world runs at most this many ticks past the newest world tick the leader it follows had heard
/// when it published its plan (PlanData::heard_tick), and the leader publishes at every world report (every
/// world::WorldCore::kReportEvery ticks, which must not exceed this, or the world would wait for a report it has
/// not sent). A change the leader schedules supervisor::SupervisorCore::kLeadTicks (20) after the tick it heard
/// then never lands in the world's past: without this, a leader hundreds of ticks behind a lockstep world started a
/// task where the path had already moved on, the references jumped about 20 mm and the object was dropped (soak
/// run 26, docs/soak.md).
constexpr long kPlanLeaseTicks = 10;

struct PlanData {
  std::string supervisor_id;
  int32_t strength = kPrimaryStrength;
  uint64_t epoch = 0;
  uint64_t version = 0;
  uint64_t task_id = 0;
  uint64_t tasks_done = 0;
  bool running = false;
  int64_t start_tick = 0;
  double tau_start = 0.0;
  double rest[3] = {0.0, 0.0, 0.0};
  double path_start[3] = {0.0, 0.0, 0.0};
  std::vector<double> waypoints;  ///< (x, y, phi_E, duration) per waypoint
  std::vector<double> breaks;     ///< time scale: (t0, tau0, r0, r1, ramp) per retarget
  bool pause_requested = false;
  bool draining = false;
  uint8_t state = 0;
  int64_t heard_tick = -1;        ///< the newest world tick its supervisor had heard when it published
  SupervisorRank rank() const { return {epoch, strength}; }
};

/// The object's planned pose as a function of the tick: the scenario's path, or (continuous) a chain of
/// assigned tasks, each starting where the previous left the object, all sampled through one time scale.
class ModulePlan {
 public:
  ModulePlan(const sim::ModuleSetup& m, bool continuous);
  model::PoseSample sample(long k) const;
  /// eq. (15) for arm j at tick k with the grasp force (eq. 16).
  model::ArmReference reference(int j, long k) const {
    return model::arm_reference(j, sample(k), m_->geometry, m_->reference_force);
  }
  /// Starts a task at tick `start` from the current rest pose.
  void assign(uint64_t id, const std::vector<double>& waypoints, long start);
  /// True once the running task's motion is over at tick `k` (then the object rests at its end).
  bool finish_if_done(long k);
  /// Scenario mode: the path's motion is over by tick k.
  bool motion_over(long k) const;
  /// From tick `from` on the path runs at `rate` (0 paused, 1 normal), reached over `ramp` seconds.
  /// `from` is raised to the latest retarget's tick if it is earlier (a retarget never rewrites the past).
  void set_rate(long from, double rate, double ramp);
  /// A paused module whose arms were braked (for load) while the path still ran: from tick `from` the path
  /// stands at the path time, within `window_s` behind its present one, whose pose is nearest to where the
  /// object actually is (x, y), so that the robots resume from the object instead of chasing the plan.
  /// Returns the jump in path time [s] (0: nothing changed).
  /// Only if that brings the pose at least `min_gain` [m] closer to the object (a smaller jump of the live arm's
  /// reference is worse than the offset it removes).
  double rebase_to(long from, const model::Vec2& object_xy, double window_s = 3.0, double min_gain = 0.0);
  double target_rate() const { return scale_.target(); }
  bool paused_at(long k) const { return scale_.target() == 0.0 && scale_.settled(time(k)); }
  bool running() const { return running_; }
  uint64_t task_id() const { return task_id_; }
  uint64_t done() const { return done_; }
  uint64_t version() const { return version_; }
  /// Raises the version to at least `v` (a takeover that continues a plan this replica only saw in the world's
  /// reports: its plan must not count as older than the one the followers hold, see PlanFollower).
  void raise_version(uint64_t v) { version_ = v > version_ ? v : version_; }
  /// The plan's content (the latest 64 retargets of the time scale); rank, flags and ids are the caller's.
  void export_to(PlanData& p) const;
  /// Adopts a published plan; false (and nothing changed) if it is malformed (see `check`).
  bool import_from(const PlanData& p);
  /// Why a plan cannot be followed ("" if it can): non-finite numbers, a waypoint list that is not
  /// (x, y, phi, duration > 0) groups, a start tick or path time out of range, a state out of range,
  /// a bad rank, or time-scale retargets that are not finite, ordered and with ramps >= 0.
  static std::string check(const PlanData& p);

 private:
  double time(long k) const { return static_cast<double>(k) * m_->period; }
  void build_path(const model::Vec3& from, const std::vector<double>& waypoints);
  const sim::ModuleSetup* m_;
  bool continuous_;
  model::TimeScale scale_;
  model::Vec3 rest_ = model::Vec3::Zero(), end_pose_ = model::Vec3::Zero(), path_start_ = model::Vec3::Zero();
  model::ObjectPath path_;
  std::vector<double> waypoints_;
  uint64_t task_id_ = 0, done_ = 0, version_ = 0;
  long start_ = 0;
  long last_retarget_ = 0;
  double tau_start_ = 0.0;
  bool running_ = false;
};

/// A robot's or the world's copy of the module's plan: keeps the highest-ranked plan heard (epoch, then
/// strength), and within one rank the newest version, so a stalled former leader's plan never replaces its
/// successor's. Until a plan is heard, the follower holds the plan every supervisor starts from.
class PlanFollower {
 public:
  PlanFollower(const sim::ModuleSetup& m, bool continuous) : m_(&m), plan_(m, continuous) {}
  enum class Offer { Adopted, Ignored, Rejected };
  /// A plan of a new rank (a takeover) whose object pose at the follower's current tick is this far from the
  /// pose of the plan it follows is reported (`jump()`), and adopted all the same. It is never refused: the
  /// followers of a module (the world, each robot) must all follow the same plan, and their views of "now"
  /// differ (a robot back from a stall is hundreds of ticks behind, and may have missed versions), so a refusal
  /// by some of them splits the module: found by the heavy-fault soak, where a robot back from a 0.34 s stall
  /// refused its leader's next task, drove against its partner, and the object was dropped. Continuity is the
  /// supervisors' duty: standbys are replicas, and one that never heard a leader does not lead a moved object.
  static constexpr double kMaxJump = 1e-3;  ///< [m] on the object's (x, y); [rad] on its angle
  /// One refusal all followers make alike, from the plans alone: a takeover plan (a higher rank) whose version
  /// is older than the plan followed. Versions continue across takeovers (a standby's replica carries the
  /// leader's version), so such a plan comes from a standby that missed the leader's newest plan: following it
  /// would move the object back to where that older plan has it. Found by a soak-small hour (m2 at 2778 s): a
  /// standby took over with version 4 while the live leader had just started a task in version 5, the takeover
  /// reached the world 320 ticks later, the references jumped 9.99 mm and the object slid out. The leader
  /// that made the newer plan retakes (supervisor::SupervisorCore), and the stale one steps down to it.
  /// Ignored: lower rank, an old version of the current rank, or an older takeover (then `why` says so, once per
  /// plan). Rejected: malformed (`why` says how). With
  /// `now_tick` >= 0, a takeover plan's jump at that tick is measured (`jump()`, and `why` when over kMaxJump).
  Offer offer(const PlanData& p, std::string* why = nullptr, long now_tick = -1);
  /// The world is the arbiter: a follower that refused an older takeover which the world follows all the same (the
  /// world had not heard the newer version this follower holds) adopts it, so that the module follows one plan. True
  /// if the last plan refused is of rank `r` and version `version` and was adopted now.
  bool adopt_refused(const SupervisorRank& r, uint64_t version, long now_tick = -1);
  /// The jump of the last plan of a new rank adopted, at the follower's tick then [m] (0: none measured).
  double jump() const { return jump_; }
  bool has_plan() const { return have_; }
  /// The object's reference at tick k: the plan's, plus what is left of a blend (below).
  model::PoseSample sample(long k) const;
  model::ArmReference reference(int j, long k) const;
  /// The plan followed, without a blend (what its supervisor made).
  const ModulePlan& plan() const { return plan_; }
  /// Bumpless adoption. A plan (a version or a takeover) that reaches this follower after the tick its change was
  /// scheduled for would move the reference at once (soak finding 86: a stop version 167 ticks late jumped both arms'
  /// references 6.66 mm and the object slid 2.1 mm). Adopted all the same, but the reference starts where the
  /// previous plan had it, in pose and velocity, and blends into the new plan (a quintic, zero acceleration at both
  /// ends) over the shortest time whose peak acceleration of the difference, at the faster stick tip, stays within
  /// kBlendShare of the friction bound (model::stop_deceleration_bound, eq. 14): a stop ramp takes kStopMargin of it
  /// (supervisor::SupervisorCore), so a blend on top of a stop stays within half of it. After the blend every follower
  /// is on the plan as made. A change under kBlendMin (a version whose change is still ahead) is no blend, nor is a
  /// plan that reaches a follower behind the world tick its supervisor had heard (a robot back from a stall or just
  /// joined, which skips to the newest tick: a blend anchored in its past would leave it off the module's plan).
  static constexpr double kBlendShare = 0.25;
  /// A follower up to this many ticks behind the world tick the supervisor had heard is no stalled one: it blends
  /// like the others, anchored at its own tick (the anchors differ by these few ticks: 0.1-0.3 N of normal force for
  /// their duration, measured in tests/unit/test_stops.cpp). A robot back from a stall is hundreds of ticks behind.
  static constexpr long kBehindGraceTicks = 10;
  static constexpr double kBlendMin = 1e-7;  ///< [m], [m/s] (and the same in rad, rad/s)
  /// True while a blend moves the reference off the plan at tick k.
  bool blending(long k) const { return blend_from_ >= 0 && k >= blend_from_ && k < blend_from_ + blend_ticks_; }
  long blend_ticks() const { return blend_ticks_; }
  SupervisorRank rank() const { return rank_; }
  uint64_t version() const { return version_; }

 private:
  /// Starts a blend at `now_tick` from `from` (the reference before) to the plan now held; returns its length [s].
  double start_blend(const model::PoseSample& from, long now_tick);
  double stop_blend();  ///< no blend (returns 0)
  const sim::ModuleSetup* m_;
  ModulePlan plan_;
  long blend_from_ = -1, blend_ticks_ = 0;
  model::Vec3 blend_dp_ = model::Vec3::Zero(), blend_dv_ = model::Vec3::Zero();  ///< before minus after, at blend_from_
  bool have_ = false;
  SupervisorRank rank_{};
  uint64_t version_ = 0;
  double jump_ = 0.0;
  SupervisorRank refused_rank_{};  ///< the last older takeover refused (said once)
  uint64_t refused_version_ = 0;
  PlanData refused_;  ///< that plan (valid while refused_rank_.strength != 0)
};

}  // namespace tandem::plan
