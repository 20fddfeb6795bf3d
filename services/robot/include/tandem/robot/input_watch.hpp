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
  };
  enum class Action { None, RenewReader, GiveUp };

  InputWatch(Rules rules, double now) : r_(rules), last_input_(now), last_plan_(now), last_pass_(now), renewed_at_(now) {}

  void on_sample(double now) { last_input_ = now; }
  void on_plan(double now) { last_plan_ = now; }
  /// A new reader was made (renewing takes time: the next renewal counts from when it is done).
  void renewed(double now) { renewed_at_ = now; }

  /// One pass of the main loop. `active`: the robot has served a tick (before that, silence is start-up).
  Action on_pass(double now, bool active) {
    // (The first pass has no previous one: whatever the robot waited for before its loop is not a stall.)
    if (passes_++ > 0 && now - last_pass_ > r_.self_stall_s && now > last_input_) last_input_ = now;
    last_pass_ = now;
    const double silent = now - last_input_;
    if (silent > r_.timeout_s) return Action::GiveUp;
    if (active && silent > r_.renew_after_s && now - last_plan_ < r_.plan_fresh_s &&
        now - renewed_at_ > 2.0 * r_.renew_after_s) {
      ++renewals_;
      renewed_at_ = now;
      return Action::RenewReader;
    }
    return Action::None;
  }

  double silent_s(double now) const { return now - last_input_; }
  int renewals() const { return renewals_; }
  const Rules& rules() const { return r_; }

 private:
  Rules r_;
  double last_input_, last_plan_, last_pass_, renewed_at_;
  int renewals_ = 0;
  long passes_ = 0;
};

}  // namespace tandem::robot
