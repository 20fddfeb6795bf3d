// The supervisor of one basic module as a component (no DDS, no clock of its own): it makes the module's plan
// (plan::ModulePlan) from the world's reports, the coordinator's tasks and the launcher's requests, and holds
// the leadership rules of hot standby supervisors: rank (epoch, strength), takeover after the leader's
// silence, step-down to a higher rank, and the stall rule. Times are passed in (steady clock, ns). The
// process (services/supervisor/main.cpp) feeds it from DDS and publishes what it asks for; unit tests drive it
// call by call (tests/unit/test_components.cpp). docs/architecture.md, "Hot standby (supervisors)".
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tandem/plan/plan.hpp"
#include "tandem/sim/module_setup.hpp"

namespace tandem::supervisor {

struct SupervisorOptions {
  std::string self_id;      ///< "m1/supervisor", a standby "m1/supervisor@50"
  int32_t strength = plan::kPrimaryStrength;
  bool continuous = false;  ///< tasks from the coordinator (else the scenario's task)
  double transient_s = 0.1; ///< start-up interval excluded from the grasp watch
  /// Lockstep: the leader publishes its plan (with the newest world tick it has heard, PlanData::heard_tick) at
  /// every report that advances that tick, besides every change and the 20 ms heartbeat, and a standby counts a
  /// silent leader by lease_every / 2 ticks. The world runs no further than plan::kPlanLeaseTicks (this value)
  /// past it (world::WorldCore::plan_lease_ok), so that a change the leader schedules kLeadTicks after the tick it
  /// heard never lands in the world's past. 0: off (real time).
  long lease_every = 0;
};

/// The world's report (WorldReport on the wire).
struct ReportIn {
  long tick = 0;
  std::array<bool, 2> braked{false, false};
  bool hold = false;
  long braked_since = -1, released_at = -1;
  double normal_min = 0.0;
  model::Vec2 object_xy = model::Vec2::Zero();
  bool object_known = false;  ///< object_xy is the world's measurement (always on the wire; tests may leave it out)
  bool failed = false;  ///< the world reports the object dropped: the module is failed (TaskStateCode::Failed)
  plan::SupervisorRank world_rank{};  ///< the rank of the plan the world follows ({0, 0}: none yet)
  uint64_t world_plan_version = 0;    ///< the version of that plan
};

/// The module's task state for the coordinator (TaskState on the wire).
struct StateOut {
  uint64_t task_id = 0;
  uint8_t state = 0;
  uint64_t tasks_done = 0;
  uint64_t tick = 0;
};

class SupervisorCore {
 public:
  /// A standby's status detail once it holds a leader's plan (a warm replica: a takeover continues that plan), and
  /// before (a takeover finds the plan lost unless the object rests where the initial plan has it). Observers
  /// (tandem soak) tell the two apart by them.
  static constexpr const char* kReplicaDetail = "standby: a replica of the leader's plan";
  static constexpr const char* kColdDetail = "standby: no leader's plan heard yet";

  static constexpr double kPauseRamp = 0.3;   ///< requested pause / resume [s]
  /// Every stop of the path (overload hold, an arm without a controller, an arm braked) ramps the rate to 0
  /// over at least this long, longer when the path is fast: the ramp's peak deceleration (1.5 v / T from a steady
  /// rate; a stop that cuts into a resume is tried on a copy of the plan) stays within kStopMargin of the friction
  /// bound (model::stop_deceleration_bound, docs/failure-model.md).
  static constexpr double kHoldRamp = 0.15;
  static constexpr double kStopMargin = 0.25;
  /// A rebase moves the path back to the braked object only if that brings the reference this much closer.
  static constexpr double kRebaseMin = 5e-4;
  static constexpr long kHoldLeadTicks = 5;
  static constexpr long kLeadTicks = 20;      ///< a change applies this many ticks after the newest heard
  /// Real time: a task starts this many ticks after the tick the world is estimated to be at now (the newest heard
  /// plus the wall time since it was heard), so that a plan that reaches the followers up to this late still starts
  /// the path in their future. Soak run 53: a supervisor of a module just plugged in made the plan of its first task
  /// at heard tick 60, and the world and robots got it at tick 495 (a busy start-up): the references jumped 6.7 mm
  /// and the object slid out of the grasp. Lockstep needs none: the world waits for the plan's lease.
  static constexpr long kTaskLeadTicks = 250;
  static constexpr long kReleaseSettleTicks = 200;
  static constexpr int64_t kHeartbeatNs = 20'000'000;
  static constexpr int64_t kTakeOverAfterNs = 50'000'000;
  static constexpr long kTakeOverTicks = 20;
  /// A world that has not ticked yet (its first tick waits up to 5 s for the robots' first commands, reporting tick
  /// 0 every 20 ms) gives no silence in ticks: a leader silent this long in wall time, with the world's reports
  /// flowing, is silent (the CI soak loop, 2026-11-27: a standby took 5.0 s over a leader killed during a restarted
  /// module's start wait, bound 2 s).
  static constexpr int64_t kTakeOverAtStartNs = 200'000'000;
  /// A leader whose world follows a higher-ranked plan for this many ticks never heard that plan: it steps down.
  static constexpr long kOutrankedTicks = 500;

  static constexpr int64_t kTakeOverAloneNs = 6'000'000'000;
  static constexpr double kAloneMatch = 2e-3;  ///< [m] object vs the initial plan for a takeover with no leader heard
  /// [m] Object vs this replica's plan at the world's tick, for a takeover from a silent leader (besides the version
  /// check, behind_world): a replica further off missed the leader's newest plan (a soak on a busy machine: a standby took over with a plan version behind,
  /// the references jumped 10-122 mm and the object was dropped). It does not lead then; if that lasts
  /// kTakeOverAloneNs the module has lost its plan (no_plan(): the launcher restarts the module).
  static constexpr double kReplicaMatch = 5e-3;
  /// [m/s] The object's speed over the last reports vs this replica's plan speed then, for any takeover (from a
  /// silent leader, or with none heard). A replica within kReplicaMatch of a moving object can still be a plan
  /// behind: the lockstep soak hour (finding 53) saw a standby at rest on the initial plan take over while the
  /// leader's first task had the object moving 3 mm on; the references jumped back and the object was dropped. 20
  /// mm/s is a speed step the grasp absorbs (about 2 m/s^2 over 10 ms, under the stop bound of about 4.9 m/s^2).
  static constexpr double kReplicaSpeedMatch = 0.02;
  /// The object's speed is measured over about this many ticks of reports (at least 10, at most 200 back).
  static constexpr long kSpeedWindowTicks = 50;
  static constexpr long kOthersRecentTicks = 100;
  /// The object counts as at rest when no report has moved it more than kStillStepM for kStillTicks.
  static constexpr double kStillStepM = 5e-5;
  static constexpr long kStillTicks = 100;
  static constexpr int64_t kSuspectMaxNs = 200'000'000;

  SupervisorCore(const sim::ModuleSetup& m, const SupervisorOptions& o, int64_t now_ns);
  void set_log(std::function<void(const std::string&)> log) { log_ = std::move(log); }

  // Inputs.
  void on_report(const ReportIn& r, int64_t now_ns);
  /// What the launcher asks of a module's supervisor (ControlRequest pause, resume, drain).
  enum class Request { Pause, Resume, Drain };
  void on_request(Request r);
  void on_assignment(uint64_t id, const std::string& name, const std::vector<double>& waypoints);
  /// Another supervisor's plan (its own are not to be passed).
  void on_plan(const plan::PlanData& p, int64_t now_ns);
  /// Decides: leadership first (takeover, step-down, the stall rule), then the plan (pause, hold, rebase,
  /// resume, tasks, task end), then what to publish.
  void update(int64_t now_ns);

  // Outputs, taken by the process after update().
  std::optional<plan::PlanData> take_plan();  ///< the plan to publish (a change, or the 20 ms heartbeat)
  std::optional<StateOut> take_state();       ///< the task state to publish (a change, or every 100 ms)
  std::optional<std::string> take_detail();   ///< a new status line ("running", "paused (for load)", ...)

  bool active() const { return active_; }
  bool leaving() const { return leaving_; }       ///< the module left (drained, or the leader drained it)
  bool world_done() const { return world_done_; } ///< scenario mode: the world reported its last tick
  /// A standby that cannot lead: it never heard a leader and the object is not where its initial plan has it, or
  /// the leader is silent and this replica has been off the object for kTakeOverAloneNs. The module has lost its
  /// plan (the process exits, the launcher restarts the module).
  bool no_plan() const { return alone_refused_; }
  /// A standby that cannot hear the module's leader: its replica is stale (or it never heard a leader) while the
  /// plan the world follows kept changing, so a leader lives. The process exits 6; the launcher restarts this
  /// supervisor alone, with a fresh participant (not the module, as no_plan does).
  bool deaf() const { return deaf_; }
  long heard_tick() const { return heard_tick_; }
  plan::SupervisorRank rank() const { return rank_; }
  const plan::ModulePlan& plan() const { return plan_; }
  plan::TaskStateCode state() const;
  /// The ramp of a stop that begins at tick `from` (kHoldRamp or longer, see there).
  double stop_ramp(long from) const;

 private:
  void log(const std::string& s) const { if (log_) log_(s); }
  bool adopt(const plan::PlanData& p, bool from_new_leader);
  void publish_state(bool force, int64_t now_ns);
  void publish_plan(plan::TaskStateCode st, int64_t now_ns);
  /// The world follows a plan this replica lacks: the same rank's newer version (WorldReport.plan_version). (A world
  /// that follows a higher rank is judged by the object's position: a leader that missed a takeover retakes.) A replica checked by the object's position alone can be a version behind
  /// at a task's start, when the object has not moved yet.
  bool behind_world() const;
  /// Records a takeover older than this one's plan (stale_taker_*); true if it is a new one (to be logged).
  bool note_stale_taker(const plan::PlanData& p);
  struct WorldPlan {
    plan::SupervisorRank rank{};
    uint64_t version = 0;
  };
  /// The plan the world follows is not `since` any more: a leader publishes, whether or not this one hears it.
  bool world_moved_on(const WorldPlan& since) const;
  std::string world_plan_text() const;
  /// |object speed - this replica's plan speed| [m/s] over the reports of about the last kSpeedWindowTicks (the
  /// object's mean velocity vs the plan's velocity at the window's middle); nullopt when no report 10-200 ticks back.
  std::optional<double> replica_speed_off() const;
  /// No lead after kTakeOverAloneNs: deaf (the world's plan changed since `since`: exit 6) or the plan is lost (exit 5).
  void give_up(const WorldPlan& since, const std::string& changed, const std::string& lost);

  const sim::ModuleSetup& m_;
  SupervisorOptions o_;
  std::function<void(const std::string&)> log_;
  plan::ModulePlan plan_;
  bool active_;
  plan::SupervisorRank rank_;
  bool pause_requested_ = false, draining_ = false, leaving_ = false, world_done_ = false, failed_ = false;
  std::array<bool, 2> braked_{false, false};
  bool hold_ = false;
  long braked_since_ = -1, released_at_ = -1, heard_tick_ = -1, rebased_for_ = -1, low_force_reported_ = -1;
  model::Vec2 object_xy_ = model::Vec2::Zero();
  struct Assignment {
    uint64_t id;
    std::string name;
    std::vector<double> waypoints;
  };
  std::vector<Assignment> assignments_;
  // Leadership.
  int64_t t_start_, last_report_, last_stronger_;
  long stronger_tick_ = -1, others_newest_ = -1, suspect_from_ = -1;
  long outranked_since_ = -1;  ///< leading: the first tick of the world's report that outranks this one (-1: none)
  int64_t suspect_since_ = 0;
  int64_t last_update_ns_ = 0;  // the previous update(): a standby that stood still does not take over at once
  bool heard_stronger_ = false, stronger_now_ = false, alone_refused_ = false;
  bool object_known_ = false;
  long still_since_ = 0;  ///< the tick of the last report that found the object moved
  /// The object's positions at the last reports (a ring; trail_n_ of them are valid), for replica_speed_off().
  static constexpr size_t kTrail = 32;
  std::array<std::pair<long, model::Vec2>, kTrail> trail_{};
  size_t trail_n_ = 0, trail_next_ = 0;
  int64_t stale_since_ = -1;  ///< the leader is silent and this replica is off the object since then (ns), or -1
  uint64_t max_epoch_ = 0;
  plan::SupervisorRank followed_{0, plan::kPrimaryStrength};
  plan::SupervisorRank world_rank_{};  ///< the rank of the plan the world follows, from its last report ({0, 0}: none)
  uint64_t world_version_ = 0;         ///< and that plan's version
  WorldPlan first_world_{}, stale_world_{};  ///< the world's plan at its first report, and when this replica went stale
  bool first_world_heard_ = false;
  bool deaf_ = false;
  // A takeover's confirmation: a new leader plans nothing until the world follows its rank (confirmed_); the world
  // refuses a takeover older than the plan it holds (refused_since_: the first tick of a report that says so).
  bool confirmed_ = true;
  long unconfirmed_since_ = -1;  ///< the first tick of a report while unconfirmed (-1: none yet)
  bool refused_said_ = false;
  // Leading: the rank of a takeover older than this leader's plan, and the tick it was first heard (-1: none).
  plan::SupervisorRank stale_taker_{};
  uint64_t stale_taker_version_ = 0;
  long stale_taker_tick_ = -1;
  std::optional<plan::PlanData> latest_plan_;
  // Publishing.
  plan::TaskStateCode reported_ = plan::TaskStateCode::Idle;
  int64_t last_state_sent_;
  uint64_t plan_sent_version_ = ~0ULL;
  long plan_sent_heard_ = -1;  ///< heard_tick_ of the plan last published
  bool plan_sent_pause_ = false, plan_sent_drain_ = false;
  uint8_t plan_sent_state_ = 255;
  int64_t plan_sent_at_ = -(1LL << 62);
  std::optional<plan::PlanData> out_plan_;
  std::optional<StateOut> out_state_;
  std::optional<std::string> out_detail_;
  bool replica_ = false;  ///< a standby that has adopted a leader's plan (its status says so: kReplicaDetail)
};

}  // namespace tandem::supervisor
