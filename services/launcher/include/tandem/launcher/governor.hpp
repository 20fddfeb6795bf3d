// Load shedding by whole modules, as a component (no processes, no DDS, no clock: times in seconds are passed
// in). A transient overload (a hog of a few seconds) is handled inside each module: its world holds the object,
// brakes and resumes (docs/failure-model.md, "Overload"). A load that does not fit for longer pauses every
// module in turn and nothing gets done, so the governor parks whole modules instead: the fewest needed, the
// lowest priority first (the last in the deployment file), and brings them back when the machine has been calm.
//
// The rule (docs/failure-model.md, "Shedding whole modules"):
// - overloaded: over the last `window_s`, the running modules spent more than `share` of their time paused for
//   load: time-weighted (a world's state holds from one status heard to the next, however often each comes), and
//   a release shorter than `short_release_s` between two pauses counts as paused (a module that pauses, tries,
//   runs a few hundred ticks and pauses again is overloaded all along: soak finding 78);
// - then park one module, the last running one in file order, and decide nothing for `settle_s` (its load
//   leaves, the others resume);
// - calm: no running module paused for load for `calm_s`: unpark the first parked one in file order. A module
//   parked again within `calm_s` of its return doubles the calm it needs (up to `calm_max_s`);
// - at start-up, admission: modules beyond what the calibrated estimate fits start parked (admit()).
// Unit tests: tests/unit/test_components.cpp ("governor: ...").
#pragma once

#include <deque>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace tandem::launcher {

struct GovernorRule {
  double window_s = 20.0;
  double share = 0.5;
  double short_release_s = 3.0;
  double settle_s = 10.0;
  double calm_s = 30.0;
  double calm_max_s = 240.0;
  /// With no module running this long (the others failed, unplugged or stopped, and not back: a killed world's
  /// module is plugged back within seconds), a parked one comes back whatever the calm.
  double none_running_s = 5.0;
  bool enabled = true;
};

class Governor {
 public:
  /// `modules` in priority order, highest first (the deployment file's order).
  Governor(std::vector<std::string> modules, GovernorRule rule = {});

  /// At start-up: the first `fit` modules run, the rest start parked. Returns the parked ones.
  std::vector<std::string> admit(size_t fit, double now);
  /// A module whose processes run is (not) paused for load now, as its world's status says.
  void on_load(const std::string& module, bool paused_for_load, double now);
  /// A module left the governor's hands (unplugged, failed, stopped by a person) or came back (plugged).
  void set_available(const std::string& module, bool available);

  struct Decision {
    enum class Kind { None, Park, Unpark } kind = Kind::None;
    std::string module;
    std::string why;
  };
  /// At most one decision per call.
  Decision decide(double now);

  bool parked(const std::string& module) const { return parked_.count(module) != 0; }
  const std::set<std::string>& parked_set() const { return parked_; }
  /// Share of the running modules' time paused for load over the window ending at `now`.
  double paused_share(double now) const;

 private:
  /// Takes `module` out of the parked set (the decision to bring it back, with `why`).
  Decision unpark(const std::string& module, const std::string& why, double now);
  struct Sample {
    double t;
    std::string module;
    bool paused;
  };
  std::vector<std::string> order_;
  GovernorRule rule_;
  std::set<std::string> parked_, unavailable_;
  std::map<std::string, bool> paused_now_;
  std::map<std::string, double> returned_at_;   // unparked when
  std::map<std::string, double> calm_needed_;   // per module: the calm its next return needs
  std::deque<Sample> samples_;
  double last_decision_ = -1e300;
  double last_paused_ = -1e300;  // last time any running module was paused for load
  double none_running_since_ = -1.0;  // since when no module runs (-1: one does)
};

}  // namespace tandem::launcher
