// Real time: the world's first tick waits for both arms' first commands, as every lockstep tick does, so that a fresh
// module does not start on its start brakes and release them one by one while the grasp builds up (soak finding 54:
// robots that answered 0.4 s late on a busy machine, a brake, a release, and a drop). Meanwhile the tick's samples go
// out again every 50 ms and its report every 20 ms, for a robot or a supervisor that matched late. Bounded: past
// bound_s the clock starts all the same, and the start brakes hold an arm whose robot has not answered yet. The
// caller's clock (seconds) and the caller's view of the arms: no DDS, no clock, no thread inside.
#pragma once

namespace tandem::world {

class StartWait {
 public:
  struct Rules {
    double bound_s = 5.0;
    double republish_s = 0.05;
    double report_resend_s = 0.02;
  };
  enum class Action { Go, GiveUp, Wait, Republish, ResendReport };

  StartWait(double now, Rules r) : r_(r), start_(now), samples_at_(now), report_at_(now) {}
  explicit StartWait(double now) : StartWait(now, Rules{}) {}

  /// One pass: `answered` is true once both arms have the first tick's command. Go: both answered; GiveUp: the
  /// bound passed; else what is due (samples first, then the report), or Wait.
  Action pass(double now, bool answered) {
    if (answered) return Action::Go;
    if (now - start_ >= r_.bound_s) return Action::GiveUp;
    if (now - samples_at_ >= r_.republish_s) {
      samples_at_ = now;
      return Action::Republish;
    }
    if (now - report_at_ >= r_.report_resend_s) {
      report_at_ = now;
      return Action::ResendReport;
    }
    return Action::Wait;
  }
  double waited(double now) const { return now - start_; }
  const Rules& rules() const { return r_; }

 private:
  Rules r_;
  double start_, samples_at_, report_at_;
};

}  // namespace tandem::world
