// The bounds of one module's drain (an unplug), as a component (no DDS, no clock: times in seconds are passed in).
// The launcher asks the module's leading supervisor to drain; the leader acknowledges by its task state (draining
// or left) and leaves once its task is over. `DrainWatch::step`, called every launcher loop, says what to do:
// - re-send the request every second until acknowledged (a leader whose control reader missed the one request kept
//   taking tasks, and the module never left: soak);
// - past kDeafLeader unacknowledged, stop the leader when a standby supervisor runs (a restarted leader never heard
//   the drain nor the coordinator's next task, while its standby logged "drain requested": soak-small hour);
// - say once, after kWarnAfter, that it is still asking;
// - past kTimeout, acknowledged or not, stop the module with its task unfinished (a task that cannot end, an arm
//   braked with no robot left, would keep the module and its slot forever): its task goes back to the queue.
// services/cli/up_run.cpp carries the steps out; tests/unit/test_launcher_rules.cpp drives it.
#pragma once

namespace tandem::launcher {

struct DrainStep {
  bool force = false;        ///< stop the module now, its task unfinished (nothing else applies)
  bool stop_leader = false;  ///< stop the leader (if a standby supervisor runs; then call leader_stopped())
  bool warn = false;         ///< say that the drain is still not acknowledged
  bool resend = false;       ///< send the drain request again
};

class DrainWatch {
 public:
  static constexpr double kResendEvery = 1.0;  ///< [s]
  static constexpr double kDeafLeader = 5.0;   ///< [s] unacknowledged: the leader does not hear the launcher
  static constexpr double kWarnAfter = 10.0;   ///< [s]
  static constexpr double kTimeout = 30.0;     ///< [s] a task lasts a few seconds, a restart a few more
  /// [s] a module paused for load this long (counted from the pause, which may have begun before the drain) while it
  /// drains is stopped at once (Supervisor::resend_drains): its task
  /// cannot end while it is paused, and its processes load the machine the others share (finding 78 of docs/soak.md).
  static constexpr double kPausedForLoad = 2.0;

  /// The drain was (re)requested at `now` [s].
  void start(double now);
  bool active() const { return first_ >= 0.0; }
  /// What to do at `now`; `acked`: the leader's task state is draining or left. Once `force` is returned the
  /// watch is over (inactive).
  DrainStep step(double now, bool acked);
  /// The deaf leader was stopped (a standby supervisor ran): not asked again in this drain.
  void leader_stopped() { leader_stopped_ = true; }

 private:
  double first_ = -1.0, sent_ = -1.0;
  bool warned_ = false, leader_stopped_ = false;
};

}  // namespace tandem::launcher
