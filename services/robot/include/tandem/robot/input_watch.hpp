// The robot's rules about its inputs, on the caller's clock (seconds): no DDS, no clock, no thread inside.
// tandem-robot feeds it the arrival of each sensor sample and plan, and asks it on each pass of its main loop
// (every ~10 ms) what to do: nothing, replace the sensor reader, or give up for want of input.
#pragma once

namespace tandem::robot {

class InputWatch {
 public:
  struct Rules {
    /// No sample for this long while the module's plan still comes: the reader is what is deaf (the world
    /// publishes every tick, every 50 ms while it waits in lockstep, at least every 100 ms paused for load).
    double renew_after_s = 1.0;
    /// The plan stream (a 20 ms heartbeat) counts as coming if heard within this.
    double plan_fresh_s = 0.5;
    /// A pass that comes this long after the previous one: the process itself stood still (SIGSTOP,
    /// starvation), and the silence meanwhile was its own, not its reader's.
    double self_stall_s = 0.2;
    /// No input at all for this long: give up (exit "no input").
    double timeout_s = 10.0;
    /// Before the robot has served a tick, its silence is start-up (the module may not tick yet), unless the plans
    /// say the world ticked this far past what it had when the reader was made: then the reader is deaf too (soak
    /// run 27: a restarted standby heard no sample for 20 s while its module ran, and gave up).
    long running_ticks = 200;
    /// ... and when that many renewals brought no sample, give up at the next one: a new process has a new
    /// participant (its transport ports too), where a new reader in the same participant may stay deaf.
    int deaf_renewals = 2;
    /// Before the first tick served, a reader that has not matched the world's writer while the plans say the module
    /// runs (module_runs) is given up after this long, for a new process (a new participant discovers anew): the
    /// lockstep soak hour (run 30) had three replacement robots whose reader never matched wait out the 20 s
    /// timeout, while each restarted one served within seconds. Discovery of a new participant on this machine
    /// takes 0.1-2 s, 3-4 s under a one-core hog (docs/soak.md); 6 s leaves room for that.
    double unmatched_s = 6.0;
    /// A robot that has answered a tick and then answers none for this long while samples keep coming is silent by
    /// its own rules (soak finding 84: a standby that had turned active answered nothing for 60 ms before its
    /// primary was killed, and the arm waited 1.3 s for it): said once per silence, with the reason.
    double silent_answer_s = 0.1;
  };
  enum class Action { None, RenewReader, GiveUp };

  InputWatch(Rules rules, double now) : r_(rules), last_input_(now), last_plan_(now), last_pass_(now), renewed_at_(now) {}

  void on_sample(double now) { last_input_ = now; }
  /// A command went out for a tick.
  void on_answer(double now) {
    last_answer_ = now;
    silence_said_ = false;
  }
  /// True once per silence: answered before, nothing answered for silent_answer_s, and a sample came within it.
  /// (Not on the first pass after the process itself stood still, a stall's silence: counted from the pass after.)
  bool silent_while_fed(double now) {
    if (passes_ > 0 && now - last_pass_ > r_.self_stall_s) return false;
    if (last_answer_ < 0.0 || silence_said_ || now - last_answer_ <= r_.silent_answer_s ||
        last_input_ <= last_answer_ || now - last_input_ > r_.silent_answer_s) {
      return false;
    }
    silence_said_ = true;
    return true;
  }
  double answer_age_s(double now) const { return last_answer_ < 0.0 ? -1.0 : now - last_answer_; }
  /// A plan heard; `heard_tick`: the newest world tick its supervisor had heard (-1: it does not say).
  void on_plan(double now, long heard_tick = -1) {
    last_plan_ = now;
    if (heard_tick > plan_tick_) plan_tick_ = heard_tick;
  }
  /// A new reader was made (renewing takes time: the next renewal counts from when it is done).
  void renewed(double now) {
    renewed_at_ = now;
    tick_at_renewal_ = plan_tick_;
  }
  /// The module ticks without this robot's reader: the plans' world tick went past running_ticks since the
  /// reader was made.
  bool module_runs() const { return plan_tick_ >= 0 && plan_tick_ > tick_at_renewal_ + r_.running_ticks; }

  /// One pass of the main loop. `active`: the robot has served a tick (before that, silence is start-up unless
  /// module_runs() and the reader has `matched` the world's writer: a reader that has not matched yet is still
  /// being discovered, which a busy machine makes slow, and renewing it would only start that again).
  Action on_pass(double now, bool active, bool matched = true) {
    // (The first pass has no previous one: whatever the robot waited for before its loop is not a stall.)
    if (passes_++ > 0 && now - last_pass_ > r_.self_stall_s) {
      if (now > last_input_) last_input_ = now;
      if (last_answer_ >= 0.0 && now > last_answer_) last_answer_ = now;  // (soak run 61: stalls said as silences)
      if (unmatched_since_ >= 0.0) unmatched_since_ += now - last_pass_;  // discovery stood still with the process
    }
    last_pass_ = now;
    const double silent = now - last_input_;
    if (silent > r_.timeout_s) return Action::GiveUp;
    if (!active && !matched && module_runs()) {
      if (unmatched_since_ < 0.0) unmatched_since_ = now;
      if (now - unmatched_since_ > r_.unmatched_s) {
        unmatched_gave_up_ = true;
        return Action::GiveUp;
      }
    } else {
      unmatched_since_ = -1.0;
    }
    if ((active || (module_runs() && matched)) && silent > r_.renew_after_s && now - last_plan_ < r_.plan_fresh_s &&
        now - renewed_at_ > 2.0 * r_.renew_after_s) {
      if (!active && last_input_ <= renewed_at_ && renewals_ >= r_.deaf_renewals) return Action::GiveUp;
      ++renewals_;
      renewed(now);
      return Action::RenewReader;
    }
    return Action::None;
  }

  double silent_s(double now) const { return now - last_input_; }
  int renewals() const { return renewals_; }
  /// The last GiveUp was for a reader that never matched while the module ran (unmatched_s).
  bool gave_up_unmatched() const { return unmatched_gave_up_; }
  const Rules& rules() const { return r_; }

 private:
  Rules r_;
  double last_input_, last_plan_, last_pass_, renewed_at_;
  double last_answer_ = -1.0;
  bool silence_said_ = false;
  int renewals_ = 0;
  long passes_ = 0;
  double unmatched_since_ = -1.0;
  bool unmatched_gave_up_ = false;
  long plan_tick_ = -1, tick_at_renewal_ = -1;
};

}  // namespace tandem::robot
