// The simulated hardware of one basic module as a component (no DDS, no clock of its own): both arms'
// dynamics, the object and the contacts (model::ModulePlant), the brakes, which robot each arm follows, the
// checks on incoming commands, late and braked arm-ticks, the windows after a change of owner, the report its
// supervisor plans from, and the overload rule. Times are passed in (steady clock, ns), so the same object runs
// in lockstep, in real time and in unit tests that drive it tick by tick. The process
// (services/world/main.cpp) adds the timing policy (deadlines, waits, re-publishing) and DDS.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tandem/model/plant.hpp"
#include "tandem/plan/plan.hpp"
#include "tandem/sim/module_setup.hpp"

namespace tandem::world {

/// Overload (real time): when an arm's commands keep arriving late (more than `max_late` of the last `window`
/// ticks, or `max_consecutive` in a row, counting commands that came after their deadline: silence is not
/// overload, the no-live-controller stop handles a robot that sends nothing), the world asks its supervisor to
/// stop the path (the report's `hold`, a ramp inside the friction bound), every tick an arm misses meanwhile is
/// served by the world's drive along the plan (never a stale torque on a moving object), and once the object is
/// still (speed below `still_speed` for `still_ticks`, or after `hold_max_s`) it brakes both arms, so that the
/// object is held still between two locked arms, and the module pauses (docs/failure-model.md, "Overload").
/// While paused for load the world sends each arm a sample only every `probe_every` ticks (so the paused
/// module sheds most of its load). Once `resume_probes` probes in a row were answered in time and the backoff
/// has passed, it tries the full rate for `trial_ticks` with the arms still braked, and releases them only if
/// the robots kept up (at most `trial_max_late` late ticks of each arm): probes alone cost a tenth of the load and pass
/// on a machine that cannot carry the module. The backoff doubles (up to `backoff_max_s`) when a module is paused for load
/// again within 10 s of its last release, so modules that come back into an overloaded machine retry less often,
/// and each module's backoff is stretched by up to 50% (from its name), so that paused modules do not all
/// come back at the same tick. Braking a moving object makes it slip, losing control of it drops it: the hold
/// ends in braking when the object is still, or after `hold_max_s` (a path that never stops).
struct OverloadRule {
  int window = 100;         ///< ticks in the sliding window
  int max_late = 10;        ///< more late arm-ticks of one arm in the window than this brake the module (10%)
  int max_consecutive = 10; ///< or this many late ticks in a row (a 10 ms stall of a robot)
  int probe_every = 10;     ///< while paused for load: a sample every this many ticks
  int resume_probes = 10;   ///< probes in a row answered in time before the trial
  int trial_ticks = 100;    ///< the trial: full-rate samples, arms still braked, before the release
  /// Late ticks of one arm allowed in the trial (else back to probes, longer backoff): half of max_late, so that
  /// a module released is not tripped again by the lateness its trial let through. Not the machine's floor: with 2
  /// of both arms' 200 ticks the bare floor alone failed 0.3-13% of trials on a 2-vCPU machine, and one module that
  /// ran without tripping was held paused for a minute by its trials (docs/benchmarks.md item 48).
  int trial_max_late = 5;
  double backoff_s = 0.5;   ///< first backoff after a pause for load [s]
  /// 4 s: a module paused at a hog's end is back within 2 x (1.5 x 4 s + 0.2 s of probes and trial) = 12.4 s even
  /// when its first trial after the hog fails (the soak's 20 s bound; with 8 s it took 20.7 s, CI soak 2026-11-26).
  /// A deployment that never fits is the governor's (whole modules parked), not a longer backoff's.
  double backoff_max_s = 4.0;
  double still_speed = 0.003;  ///< object speed under which it counts as still [m/s]
  int still_ticks = 5;
  double hold_max_s = 1.0;     ///< brake after this long even if the object still moves
  bool enabled = true;
};

struct WorldOptions {
  std::array<std::string, 2> arm_ids;    ///< "<module>/<robot>"
  std::array<std::string, 2> arm_names;  ///< "<robot>"
  bool realtime = false;
  bool continuous = false;
  OverloadRule overload;
  /// Test only (deployment key `test_no_brakes`): an arm whose controller is gone is neither driven nor braked:
  /// after brake_after_s it goes limp (zero torque), as an arm with no brakes and its drives off would, and
  /// drops what it holds. Used to show that the soak's checker catches a drop, and that the drop fails the module.
  bool brakes = true;
  /// A drop fails the module (kDropContactTicks, kDropSlideM). Off only in unit tests that drive the world with
  /// stand-in torques that hold nothing, to look at other bookkeeping.
  bool drop_is_failure = true;
};

/// One arm's sample for the tick (what the world publishes).
struct SampleOut {
  bool publish = true;  ///< false: a module paused for load sends no sample this tick (not a probe)
  double t = 0.0;
  model::JointVec q = model::JointVec::Zero(3), qd = model::JointVec::Zero(3);  ///< the arm's joint count
  model::Vec2 h = model::Vec2::Zero();
  bool braked = false;
  /// Torque the arm got over the last period; braked: the torque the brake takes to hold it (g + J^T h), so
  /// that a robot that takes the arm over starts from it (bumpless release).
  model::JointVec tau_applied = model::JointVec::Zero(3);
  /// Strength of the robot it came from (1-100); 0: none, or braked (the brake's holding torque); -1: the
  /// world's drive (a controlled stop along the plan, or a tick no robot answered in time).
  int32_t applied_from = 0;
};

/// What the supervisor plans from (WorldReport on the wire).
struct ReportOut {
  long tick = 0;
  std::array<bool, 2> braked{false, false};
  bool hold = false;  ///< overload, or an arm without a controller: stop the path (the brakes follow once still)
  long braked_since = -1, released_at = -1;
  double normal_min = 0.0;
  model::Vec3 object = model::Vec3::Zero();  ///< x, y, psi now
  bool failed = false;   ///< the object was dropped (or slid out of the grasp): both arms braked, the module out
  std::string failure;   ///< why, with the tick
  plan::SupervisorRank plan_rank{};  ///< the rank of the plan the world follows ({0, 0}: none yet)
  uint64_t plan_version = 0;         ///< and its version (a takeover checks that its replica has it)
};

/// A change of the robot an arm follows, and the worst tracking error and lowest normal force over the
/// kWindowTicks after it (from the old owner's last command on).
struct Switch {
  double gap_ms = 0.0;
  bool failover = false;  ///< to a weaker robot (the owner died or left); else a takeover by a stronger one
  double ep_max = 0.0;
  double hn_min = 0.0;
};

/// Real-time pacing of a world: absolute deadlines one period apart, from the monotonic clock (ns). The world is
/// the simulated plant: when its own process starts a tick more than half a period late (a scheduler stall of
/// 5-20 ms is common on a shared 2-core machine), catching up in a burst of ticks would give the robots no time
/// to answer any of them, and the arms would hold stale torques for the whole burst, a failure of the
/// simulator that a real plant never has. So such a tick re-anchors the clock at now: the robots always get at
/// least half a period, and simulated time slips (counted in `overruns`).
class TickClock {
 public:
  TickClock(int64_t period_ns, int64_t now_ns) : period_(period_ns), start_(now_ns) {}
  /// The tick starts at `now_ns`: returns how late it started; re-anchors after a stall.
  int64_t begin(int64_t now_ns) {
    const int64_t late = now_ns - start_;
    if (late > period_ / 2) {
      start_ = now_ns;
      ++overruns;
    }
    return late;
  }
  int64_t deadline() const { return start_ + period_; }
  void advance() { start_ += period_; }  ///< the next tick starts at this one's deadline
  unsigned long long overruns = 0;

 private:
  int64_t period_, start_;
};

class WorldCore {
 public:
  static constexpr long kReportEvery = 10;
  static constexpr long kWindowTicks = 300;
  static constexpr size_t kMaxSwitches = 512;

  WorldCore(const sim::ModuleSetup& m, const WorldOptions& o);
  /// Log lines ("m1/left braked (...)"), for the process to print.
  void set_log(std::function<void(const std::string&)> log) { log_ = std::move(log); }

  /// A plan heard on the wire: followed as the robots follow it (plan::PlanFollower, checked at this tick).
  /// The rank of the plan followed ({0, 0} before any): sent with every sample, so that a robot that missed its
  /// leader's plans can tell (robot::RobotCore::cut_off).
  plan::SupervisorRank plan_rank() const { return follower_.has_plan() ? follower_.rank() : plan::SupervisorRank{}; }
  plan::PlanFollower::Offer offer_plan(const plan::PlanData& p, std::string* why = nullptr) {
    const plan::SupervisorRank before = follower_.rank();
    const plan::PlanFollower::Offer o = follower_.offer(p, why, k_);
    if (o == plan::PlanFollower::Offer::Adopted) plan_since_ = k_;
    // The lease: the newest tick the followed leader had heard (its heartbeats count too; a new rank starts anew).
    const plan::SupervisorRank r = p.rank();
    const bool followed = o != plan::PlanFollower::Offer::Rejected && follower_.has_plan() &&
                          r.epoch == follower_.rank().epoch && r.strength == follower_.rank().strength;
    if (followed) {
      const bool new_rank = before.epoch != r.epoch || before.strength != r.strength;
      lease_tick_ = new_rank ? p.heard_tick : std::max(lease_tick_, static_cast<long>(p.heard_tick));
    }
    return o;
  }
  static_assert(kReportEvery <= plan::kPlanLeaseTicks, "the lease must cover a report period, or lockstep deadlocks");
  /// Lockstep: whether tick k may run. No further than plan::kPlanLeaseTicks past the newest tick the followed
  /// leader had heard when it published (PlanData::heard_tick), so that its changes (scheduled kLeadTicks after
  /// that tick) never land in the world's past. Always true before a plan is followed, or for a plan that does
  /// not say what it heard (heard_tick < 0).
  bool plan_lease_ok(long k) const { return !follower_.has_plan() || lease_tick_ < 0 || k <= lease_tick_ + plan::kPlanLeaseTicks; }
  long plan_lease() const { return lease_tick_; }
  /// The version of the plan followed (0 before any), and the tick at which it was adopted: sent with every sample
  /// too, so that a robot with an older version of the same plan can tell (robot::RobotCore::world_plan).
  uint64_t plan_version() const { return follower_.has_plan() ? follower_.version() : 0; }
  const plan::PlanFollower& follower() const { return follower_; }  ///< the plan as this world follows it
  long plan_since() const { return plan_since_; }

  /// Starts tick k at `now_ns`: applies pending releases, measures the tracking error (the plan's eq. 15 as
  /// the robots evaluate it) and the contact forces, and fills both arms' samples.
  void begin_tick(long k, int64_t now_ns, std::array<SampleOut, 2>& out);
  /// True when the report is due (every kReportEvery ticks, at once after a brake change, the last tick).
  bool report_due(long steps) const { return report_now_ || k_ % kReportEvery == 0 || k_ + 1 == steps; }
  ReportOut take_report();

  /// Failover by ticks (no liveliness lease): a robot that serves an arm and answers no tick for this many
  /// ticks while a weaker one of the arm answers is given up for it (real time); in lockstep after this long of
  /// waiting. A tick it misses meanwhile is served by the standby's answer (counted in `covered`).
  static constexpr long kFailoverTicks = 10;
  static constexpr double kFailoverLockstepS = 0.02;
  /// Real time: a start brake still on after this many ticks is reported as a braking (the path holds).
  static constexpr long kStartGraceTicks = 20;
  /// Real time: an arm braked for want of a live controller is released only after a robot answered this many
  /// ticks in a row (its commands are not applied meanwhile). The supervisor's hold and the path rebased to the
  /// braked object (a report at the brake, the plan 20 ticks ahead) are then in effect: releasing at the first
  /// answer applied a command computed against a path that had moved on, and the object slipped (found by
  /// tandem soak).
  static constexpr int kReleaseTrialTicks = 100;
  /// Lockstep: the same trial, this many ticks in a row, with the world waiting for the robot's answers meanwhile
  /// (ArmLink::trial). Its first answer to a braked arm comes from a law it has just reset (a fresh robot, or one
  /// that missed ticks); from its second on it continues from the brake's holding torque that the samples carry
  /// (RobotCore::on_sample), so the release is bumpless. Releasing on a first (late) answer slipped the object 3-4
  /// ticks later (lockstep soak run 37, m4 and m1, finding 68).
  static constexpr int kLockstepReleaseTicks = 10;
  /// A robot stronger than the one an arm follows (a primary back after a stall, restarted or plugged as
  /// primary) takes the arm over only after it has answered this many ticks in a row (in shadow meanwhile):
  /// its law's memory is then warm again. Taking over on its first answer after a 1 s stall applied a command
  /// from a stale integrator, and the object slipped (found by tandem soak).
  static constexpr int kTakeoverTicks = 50;
  /// Real time: an arm that got no command in time for more than this many ticks in a row is driven by the
  /// world (the drive's torque, not the stale one) until a command comes in time again. While the world holds
  /// for load or stops an arm without a controller, every missed tick is driven.
  static constexpr int kDriveAfterMisses = 3;
  /// The world's drive: computed torque (eq. 21-22 with the plant's own model, exact here) and a PD on the
  /// whole pose (x, y, phi) towards the plan's eq. (15) reference, which carries the grasp preload: w = 50
  /// rad/s, critically damped. Bumpless: it keeps the offset from the plan that the arm had when the drive took
  /// it, along the contact face and in orientation (a robot's law may leave one: its orientation loop is soft),
  /// but not along the approach axis (that offset is squeeze the grasp would lose); and its correction is bounded
  /// by kDriveFeedbackShare of the stop's deceleration bound (eq. 14, model::stop_deceleration_bound) in the plane,
  /// and by that over the longer stick in rotation. Without both, an arm 0.1 rad off in orientation got 3000 N m
  /// on joint 1 at the stop's first tick and the object was dropped (lockstep soak run 43, finding 73).
  static constexpr double kDriveKp = 2500.0, kDriveKd = 100.0;
  static constexpr double kDriveFeedbackShare = 0.5;
  /// A stop of an arm without a controller brakes it once the object is still, or after this long.
  static constexpr double kStopMaxS = 10.0;
  /// The plan counts as stopped when it is paused and settled, or slower than the still speed now and within
  /// kPlanRestM of where it is kPlanRestLookTicks on.
  static constexpr long kPlanRestLookTicks = 200;
  static constexpr double kPlanRestM = 1e-4;
  bool plan_at_rest(long k, double still_speed) const;
  /// A drop (docs/failure-model.md, "A drop is a failure"): a contact that carries no force for this many ticks
  /// in a row, or the contacts sliding more than kDropSlideM along the faces since the start. Then the world
  /// brakes both arms for good, reports the module failed, and no robot releases them.
  static constexpr long kDropContactTicks = 10;
  static constexpr double kDropSlideM = 2e-3;

  enum class Verdict { Applied, Shadow, Rejected, Stale };
  /// A torque command for arm j from the robot of strength `strength` (100: the primary, "<arm>"; a standby
  /// "<arm>@<strength>"), arrived at `at_ns`. The arm follows the strongest robot that answers: a stronger one
  /// takes over at once, a weaker one's answer is kept as the tick's Shadow (used if the owner misses the
  /// tick, followed if the owner stays silent kFailoverTicks or leaves). Real time: `late` is true if it
  /// arrived after the tick's deadline. Rejected: not finite, over tau_max, a strength outside [1, 100] (never
  /// applied); Stale: for an earlier tick, too late, a second one for this tick, or a robot's last word
  /// (`leaving`: it stops; if it served the arm, the next one is followed at once).
  Verdict on_command(int j, long tick, const model::JointVec& tau, int32_t strength, int64_t at_ns, bool late,
                     bool leaving = false);
  bool have(int j) const { return have_[static_cast<size_t>(j)]; }
  /// The world stood still (its tick started far too late): every robot is taken as heard now, so that its
  /// silence during the world's own stall does not brake the arms (a 0.4 s stall of a world braked both arms
  /// of a healthy module, and the release made the object slip; found by tandem soak).
  void forgive_silence(int64_t now_ns) {
    for (ArmLink& L : link_) {
      if (L.last_tick >= 0) L.heard = now_ns;
    }
  }
  /// Lockstep: every arm the world waits for has its command.
  bool lockstep_done() const;
  /// Lockstep: the tick has waited `waited_s` for commands; brakes an arm whose robot fell silent (after
  /// `brake_after_s`). False if an arm that never answered has still not answered after `timeout_s`.
  bool lockstep_waited(double waited_s, double timeout_s, int64_t now_ns);
  /// Ends the tick at `now_ns`: counts late and braked arm-ticks, brakes an arm with no live controller, and
  /// applies the overload rule. False (lockstep) if a robot never answered: the run stops.
  bool end_tick(int64_t now_ns);
  /// Steps the plant over the period with the torques applied (held from the last applied command).
  void step();

  const model::ModulePlant& plant() const { return plant_; }
  /// Who arm j follows now: the robot it follows (label and strength), or why none (stopping, braked).
  struct Owner {
    enum class State { Served, Stopping, Braked, BrakedLoad } state = State::Braked;
    std::string robot;     ///< Served: the robot's process label
    int32_t strength = 0;  ///< Served: its strength
    /// Served after a change of owner: ticks from the previous owner's last command to the tick this one was
    /// followed (the module's time without its owner); -1 before any change.
    long handover_ticks = -1;
  };
  Owner owner(int j) const;
  const std::string& arm_name(int j) const;
  std::string serving_text() const;  ///< for people: "left=m1/left@50,right=braked"
  bool braked(int j) const { return link_[static_cast<size_t>(j)].braked; }
  /// The arm has no live controller and the world drives it to rest along the plan (then brakes it).
  bool stopping(int j) const { return link_[static_cast<size_t>(j)].stopping; }
  /// The world's drive for arm j this tick: computed torque towards the plan's reference (see kDriveKp). Not a
  /// pure query: the first call of a run of driven ticks takes the arm's offset from the plan.
  model::JointVec drive_torque(int j);
  /// The drive's task acceleration: the plan's, plus the bounded PD on the error from the plan plus the offset.
  model::Vec3 drive_acceleration(int j, const model::ArmReference& ref, const model::Vec3& x, const model::Vec3& xd);
  /// Torque a brake takes to hold arm j still now: g(q) + J^T h.
  model::JointVec holding_torque(int j) const;
  bool paused_for_load() const { return load_paused_ || load_pending_; }
  /// The last `ticks` ticks of the flight recorder, one line each (for the log, when the module fails).
  std::string flight_record(long ticks) const;
  bool failed() const { return failed_; }
  const std::string& failure() const { return failure_; }
  /// The world's status line: why the module does not run as it should ("failed: object dropped (...)", "paused for
  /// load ...", "stopping: ...", "arm braked: ..."), or "" when it does. The first that holds, in that order.
  std::string status_detail() const {
    if (failed_) return "failed: object dropped (" + failure_ + ")";
    if (paused_for_load()) return "paused for load (overload: commands late)";
    if (stopping(0) || stopping(1)) return "stopping: an arm has no live controller";
    if (braked(0) || braked(1)) return "arm braked: no live controller";
    return "";
  }
  bool answered_once() const { return link_[0].last_tick >= 0 && link_[1].last_tick >= 0; }
  bool serving_changed() { const bool c = serving_changed_; serving_changed_ = false; return c; }
  double tracking_error() const { return std::max(ep_[0], ep_[1]); }
  double normal_min_since_status();  ///< lowest normal force since the last call

  unsigned long long late = 0, timeouts = 0, rejected = 0, stale = 0, braked_ticks = 0, failovers = 0,
                     load_pauses = 0, load_paused_ticks = 0, covered = 0,
                     driven = 0,  ///< arm-ticks the world's drive served (no command in time)
                     stops = 0;   ///< arms brought to rest by the drive (no live controller)
  double failover_max_ms = 0.0, failover_last_ms = 0.0;
  /// Strength of the robot whose torque each arm got last (the owner, or a standby covering a missed tick).
  std::array<int32_t, 2> applied_from_{0, 0};
  std::vector<Switch> switches;

 private:
  struct TrialAnswer {
    int32_t strength = 0;
    long last = -2;
    int run = 0;
  };
  struct ArmLink {
    std::string owner;
    int32_t strength = 0;
    long handover_ticks = -1; // the last change of owner: ticks from the old owner's last command
    long last_tick = -1;      // tick of the last applied command
    int64_t last_at = 0;      // when it was applied
    bool braked = false;
    bool trial = false;       // lockstep: a robot answered while braked: wait for its answers (the release trial)
    bool start_brake = false; // real time: braked from power-on until its robot first answers a tick in time
    int release_run = 0;      // ticks in a row a robot answered while the arm was braked (the release trial)
    /// While braked or driven: the robots (by strength) that answered, the newest tick each answered, and how many
    /// ticks in a row up to it.
    std::array<TrialAnswer, 4> trial_answers{};
    int32_t challenger = 0;   // a robot stronger than the owner that answers (it takes over after a warm-up)
    long challenger_tick = -1;
    int challenger_run = 0;
    bool owner_gone = false;  // the robot it follows said it leaves: follow the next one at once
    int64_t heard = 0;        // last valid command of any tick: a controller is alive
    std::array<bool, 256> late_ring{};  // real time: the last OverloadRule::window ticks, late or not
    int late_count = 0;
    int late_run = 0;         // late ticks in a row
    int miss_run = 0;         // ticks in a row without a command applied in time
    bool stopping = false;    // no live controller: the world drives it to rest along the plan, then brakes
    long stop_tick = -1;      // the tick the stop began
  };
  void begin_stop(int j, const std::string& why, int64_t now_ns);
  bool holding() const { return load_pending_ || link_[0].stopping || link_[1].stopping; }
  void set_brake(int j, bool on, const std::string& why);
  void mark_late(ArmLink& L, long tick);
  void apply(int j, const model::JointVec& tau, int32_t strength, int64_t at_ns, int64_t decided_ns);
  struct Fallback {
    bool has = false;
    model::JointVec tau = model::JointVec::Zero(3);
    int32_t strength = 0;
    int64_t at_ns = 0;
  };
  std::array<Fallback, 2> fallback_{};  // this tick's answer of the strongest weaker robot, per arm
  std::string robot_name(int j, int32_t strength) const;
  void log(const std::string& s) const { if (log_) log_(s); }

  const sim::ModuleSetup& m_;
  WorldOptions o_;
  model::ModulePlant plant_;
  plan::PlanFollower follower_;
  long plan_since_ = 0;  ///< the tick at which the plan's current version was adopted
  long lease_tick_ = -1;  ///< the newest world tick the followed leader had heard (plan_lease_ok)
  std::function<void(const std::string&)> log_;
  std::array<ArmLink, 2> link_{};
  std::array<bool, 2> have_{false, false};
  std::array<bool, 2> expect_{true, true};  // a sample went out this tick: a command is due
  model::ArmEfforts tau_{model::JointVec::Zero(3), model::JointVec::Zero(3)};  // sized to the arms in the constructor
  model::ContactReading contact_{};  // the contacts at the start of the tick (the plant does not move until step)
  std::array<double, 2> ep_{0.0, 0.0};
  std::array<double, 2> ephi_{0.0, 0.0};  ///< orientation error from the plan [rad] (the flight record)
  std::array<model::Vec3, 2> drive_offset_{model::Vec3::Zero(), model::Vec3::Zero()};  ///< x - x_ref at the drive's start
  std::array<long, 2> drive_tick_{-2, -2};  ///< the last tick the drive served each arm
  double drive_acc_max_ = 0.0;  ///< the drive's largest correction at a stick tip [m/s^2] (kDriveFeedbackShare)
  long k_ = 0;
  double t_ = 0.0;
  double brake_after_s_;
  // The last 256 ticks' tracking error per arm and lowest normal force, and the open windows after a switch.
  struct TickRecord {
    std::array<double, 2> ep{0.0, 0.0};
    std::array<double, 2> ephi{0.0, 0.0};
    double hn_min = 0.0;
    // The flight recorder a drop prints (fail()): what each contact carried and what each arm got.
    std::array<double, 2> hn{0.0, 0.0}, ht{0.0, 0.0};  ///< normal and tangential force per contact [N]
    model::ArmEfforts tau{model::JointVec::Zero(3), model::JointVec::Zero(3)};  ///< the torque applied
    std::array<int32_t, 2> from{0, 0};  ///< whose torque: a robot's strength, 0 the brake, -1 the world's drive
    std::array<char, 2> how{'.', '.'};  ///< c: its command came, l: late or missing, b: braked, s: stopping
  };
  static constexpr size_t kHistory = 256;
  static constexpr long kFlightTicks = 60;  ///< ticks of the flight record a drop prints
  std::array<TickRecord, kHistory> history_{};
  struct Window {
    int arm;
    long end;
    size_t index;
  };
  std::vector<Window> windows_;
  // Report state.
  long braked_since_ = -1, released_at_ = -1;
  double report_normal_min_ = 1e300, status_normal_min_ = 1e300;
  bool report_now_ = true;
  bool serving_changed_ = true;
  // Overload state.
  bool load_pending_ = false;  // holding: the path stops, the brakes follow once the object is still
  long load_pending_tick_ = 0;  // the tick the hold began (its bound counts ticks: a starved world's wall clock
                                // runs on while its object does not move)
  int still_count_ = 0;
  std::string load_why_;
  bool load_paused_ = false;
  int good_probes_ = 0;
  int trial_ticks_ = -1;  // >= 0: in the full-rate trial before a release
  std::array<int, 2> trial_late_{0, 0};  // per arm
  int64_t load_until_ns_ = 0, load_released_ns_ = 0;
  double backoff_s_;
  long slips_seen_ = 0, slip_logged_ = -1000;
  // Drop detection.
  bool failed_ = false;
  std::string failure_;
  long contact_lost_seen_ = 0, no_contact_run_ = 0;
  void fail(const std::string& why);
  double jitter_ = 0.0;  // in [0, 1): stretches this module's backoff
};

}  // namespace tandem::world
