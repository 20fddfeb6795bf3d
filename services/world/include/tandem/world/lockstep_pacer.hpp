// The lockstep world's waits, on the caller's clock (seconds): no DDS, no clock, no thread inside.
// tandem-world asks it, tick by tick, whether to wait for the leader's plan lease (WorldCore::plan_lease_ok), what
// to do on each pass of that wait (nothing, send the latest report again, or give the lease up), when to publish
// the tick's samples again while the commands do not come, and whether the tick held the module long enough to
// be said (with what it waited for). Real time has none of this (its deadline is the clock's).
#pragma once

#include <array>
#include <cstdint>
#include <optional>

namespace tandem::world {

class LockstepPacer {
 public:
  struct Rules {
    /// A lease the leader does not renew within this is not waited for again until it changes (none alive, or all
    /// stalled). Waiting costs the plant nothing (it stands still in lockstep); going on does: a leader stalled right
    /// after writing a change, whose lease lapsed at 0.8 s, came back with that change hundreds of ticks in the
    /// world's past, the references jumped and the object was dropped (soak finding 58). 3 s is above the
    /// supervisors' stalls seen in lockstep soaks (up to 1.2 s each, in turn) and the nemesis's (up to 2 s; a live
    /// standby takes over a stalled leader within 50 ms anyway), and below the robots' 10 s without input. The
    /// tick's samples go out again meanwhile (republish_s), so that no robot takes the wait for a deaf reader.
    double lease_wait_s = 3.0;
    /// While waiting for the lease: the latest report again this often, so that the supervisors see the world
    /// alive and a standby takes over from a leader that fell silent instead of waiting with the world.
    double report_resend_s = 0.02;
    /// While waiting for the tick's commands: its samples again this often, for a robot that joined (or
    /// restarted) after they went out.
    double republish_s = 0.05;
    /// A tick that held the module this long is said (below it: scheduling noise on 2 cores).
    double long_tick_s = 0.3;
    /// Tick 0 waits this long at most for the first answers of every robot of each arm (start_answers_in).
    double start_answers_s = 2.0;
  };
  enum class LeaseAction { Wait, ResendReport, Lapsed };
  /// A tick that held the module long, split by what it waited for.
  struct LongTick {
    double total_s = 0.0;
    double lease_s = 0.0;       ///< for the leader's plan (the lease)
    double own_s = 0.0;         ///< this world's own work: stepping, writing samples and the report
    double commands_s = 0.0;    ///< for the robots' commands (republishing included)
  };

  explicit LockstepPacer(Rules rules) : r_(rules) {}
  LockstepPacer() : LockstepPacer(Rules{}) {}

  /// The start of a tick.
  void tick_begin(double now) {
    tick_start_ = now;
    lease_s_ = 0.0;
    commands_start_ = now;
    commands_s_ = -1.0;
  }

  // ---- the plan lease -------------------------------------------------------------------------------------
  /// Whether the tick waits for the leader: the core's lease does not cover it, and that lease has not lapsed.
  bool lease_wait_needed(bool lease_ok, long lease) const { return !lease_ok && lease != lapsed_lease_; }
  void lease_wait_begin(double now) {
    wait_start_ = now;
    resent_ = 0;
    ++lease_waits_;
  }
  /// One pass of the wait for `lease` (the caller leaves once the core's lease covers the tick). `reported`: a
  /// report went out before (there is one to send again).
  LeaseAction lease_wait_pass(double now, long lease, bool reported) {
    const double waited = now - wait_start_;
    if (waited > r_.lease_wait_s) {
      lapsed_lease_ = lease;
      return LeaseAction::Lapsed;
    }
    if (reported && waited > r_.report_resend_s * static_cast<double>(resent_ + 1)) {
      ++resent_;
      return LeaseAction::ResendReport;
    }
    return LeaseAction::Wait;
  }
  void lease_wait_end(double now) {
    lease_s_ = now - wait_start_;
    lease_wait_total_s_ += lease_s_;
  }

  // ---- the commands ---------------------------------------------------------------------------------------
  /// The tick's samples went out: the wait for its commands starts.
  void commands_begin(double now) {
    commands_start_ = now;
    republished_ = 0;
  }
  double commands_waited(double now) const { return now - commands_start_; }
  /// The tick's commands are in (or given up on): what follows is the world's own work again.
  void commands_end(double now) { commands_s_ = now - commands_start_; }
  /// Whether to publish the tick's samples again now.
  bool republish_due(double now) {
    if (commands_waited(now) <= r_.republish_s * static_cast<double>(republished_ + 1)) return false;
    ++republished_;
    return true;
  }

  // ---- tick 0: every robot of each arm ---------------------------------------------------------------------
  /// Tick 0 waits for the first answers of each arm's primary and its `standbys`, not only for the first robot
  /// heard: then every robot of an arm computes every tick from tick 0 on the same samples, and the strongest
  /// serves from the first tick (WorldCore: a stronger robot's answer in the first ticks takes the arm). Without
  /// it, which robot served and from which tick a standby ran in shadow depended on discovery order, and so did
  /// the run (a standby whose first sample was tick 1424 served after a failover with another controller memory
  /// than the embedded run's; a standby heard first kept its primary in shadow for the whole run).
  void start_expect(int standbys) { start_expected_ = 1 + (standbys < 0 ? 0 : standbys); }
  /// An answer to tick 0 for arm `arm` (0 or 1) from the robot of `strength`.
  void start_heard(int arm, int32_t strength) {
    if (arm < 0 || arm > 1) return;
    StartArm& a = start_[static_cast<size_t>(arm)];
    for (int i = 0; i < a.n; ++i) {
      if (a.strengths[static_cast<size_t>(i)] == strength) return;
    }
    if (a.n < static_cast<int>(a.strengths.size())) a.strengths[static_cast<size_t>(a.n++)] = strength;
  }
  /// Whether tick 0 may end; asked once each arm has an answer (`now`: the caller's clock): every arm heard from
  /// `standbys` + 1 robots, or start_answers_s passed since the first time it was asked (start_short() then says
  /// so). Counted from the first answers, not from the samples: robots answer only once they have the plan, which
  /// may take a while on a busy machine (finding 54: 0.3-0.5 s), and the standbys then come about as late.
  bool start_answers_in(double now) {
    if (start_[0].n >= start_expected_ && start_[1].n >= start_expected_) return true;
    if (start_first_ < 0.0) start_first_ = now;
    if (now - start_first_ <= r_.start_answers_s) return false;
    start_short_ = true;
    return true;
  }
  /// Tick 0 went on without some robot's answer.
  bool start_short() const { return start_short_; }
  /// The robots heard at tick 0 for arm `arm`.
  int start_heard_count(int arm) const { return start_[static_cast<size_t>(arm)].n; }

  /// The end of the tick (after its step): the account if it held the module longer than long_tick_s.
  std::optional<LongTick> tick_end(double now) const {
    const double total = now - tick_start_;
    if (total <= r_.long_tick_s) return std::nullopt;
    LongTick t;
    t.total_s = total;
    t.lease_s = lease_s_;
    t.commands_s = commands_s_ >= 0.0 ? commands_s_ : now - commands_start_;
    t.own_s = total - t.lease_s - t.commands_s;
    if (t.own_s < 0.0) t.own_s = 0.0;
    return t;
  }

  long lease_waits() const { return lease_waits_; }
  double lease_wait_s() const { return lease_wait_total_s_; }
  const Rules& rules() const { return r_; }

 private:
  Rules r_;
  double tick_start_ = 0.0, wait_start_ = 0.0, commands_start_ = 0.0, commands_s_ = -1.0, lease_s_ = 0.0,
         lease_wait_total_s_ = 0.0;
  long lapsed_lease_ = -2;  // none (a lease is a tick >= -1)
  long lease_waits_ = 0;
  int resent_ = 0, republished_ = 0;
  struct StartArm {
    std::array<int32_t, 8> strengths{};
    int n = 0;
  };
  std::array<StartArm, 2> start_{};
  int start_expected_ = 1;
  double start_first_ = -1.0;  // when tick 0 first had an answer on each arm
  bool start_short_ = false;
};

}  // namespace tandem::world
