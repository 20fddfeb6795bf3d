// The soak's checker: judges a recorded History against the invariants (docs/soak.md) and measures every
// recovery. Pure: no DDS, no clock, no processes, so it is unit-tested on made-up histories.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "tandem/soak/history.hpp"

namespace tandem::soak {

/// The bounds the checker holds the run to (documented in docs/soak.md, printed in the report).
struct Bounds {
  /// Kill/unplug of the robot serving an arm, with a standby: the arm is served again. The world fails over after
  /// 10 silent ticks (10 ms); the observer sees it in the world's next report (every 10 ticks). Five soak-small hours
  /// (2026-11-25/26) measured p50 20 ms and max 40-160 ms over 1050 kills and 166 unplugs with a standby.
  /// Lockstep: judged in the module's time (ticks), as the plant stands still while its world waits (lockstep soak
  /// run 27: 1.0 s on the wall clock for worlds that failed over within 20-36 ms and 50 ticks).
  double failover_s = 0.2;
  double restart_s = 10.0;       ///< a killed robot's replacement is up (restart policy with backoff)
  double supervisor_s = 2.0;     ///< kill of the serving supervisor with a warm standby: another one serves
  /// ... with no standby that held the leader's plan (none, or one restarted and not yet a replica: it must not
  /// lead a moved object, docs/failure-model.md): the standby finds the plan lost after 6 s and the module
  /// restarts from its initial grasp, as after a world kill (soak run 13: 6.2 s).
  double supervisor_cold_s = 15.0;
  double coordinator_s = 5.0;    ///< kill of the serving coordinator: another one serves
  /// ... with no active standby coordinator (all just restarted): a new one is started after the restart backoff
  /// (up to 1.6 s), starts, and takes the queue over (lockstep soak run 27: 5.1 s, two standbys started 0.7 and
  /// 2.2 s after the kill).
  double coordinator_cold_s = 10.0;
  double module_back_s = 15.0;   ///< kill world / unplug module: the module runs again after it is plugged in
  double replan_s = 10.0;        ///< kill world: its running task is running or done elsewhere (or by it again)
  double stall_extra_s = 2.0;    ///< a stalled process is heard again within its stall plus this
  double hog_s = 20.0;           ///< after a hog ends, no module is paused for load any more
  double startup_grace_s = 1.0;  ///< normal force is not judged in a world's first second (the grasp builds up)
  double brake_grace_s = 0.5;    ///< nor while an arm is braked or held and this long after
  double task_lost_s = 60.0;     ///< a task assigned this long before the stop must be done or running at the end
  double progress_s = 45.0;      ///< the deployment, and every module in service, does a task at least this often
  double rss_slope_mib_per_min = 1.0;  ///< resident memory growth of a long-lived process
  /// Judged only for processes that lived this long, over the later half of their life (so over 60 s at least):
  /// in a shorter window start-up growth (discovering the others, first allocations) cannot be told from a leak
  /// (a 75 s CI soak saw its launcher grow 1.8 MiB in 38 s, an hour-long one did not).
  double rss_min_life_s = 120.0;
  double rss_window_s = 1800.0;  ///< ... and over at most its last half hour (anonymous memory, RssAnon)
  double log_growth_ratio = 3.0; ///< the log's rate in the last third over the first third
};

struct Violation {
  double t = 0.0;
  std::string invariant;
  int fault = 0;                 ///< the fault it follows (index), 0 if none
  std::string text;
};

struct InvariantResult {
  std::string name;
  std::string description;
  bool ok = true;
  int checked = 0;               ///< how many things it judged
};

struct Recovery {
  int fault = 0;
  std::string kind;              ///< "kill robot", "restart robot", ...
  double seconds = 0.0;
};

struct Verdict {
  std::vector<InvariantResult> invariants;
  std::vector<Violation> violations;
  std::vector<Recovery> recoveries;
  std::map<std::string, int> faults_by_kind;  ///< carried out (skipped ones not counted)
  /// Recoveries not judged because the fault's module was parked for load before they were due (its return is the
  /// governor's): per recovery kind ("kill robot", "hog: paused modules resume", ...), how many.
  std::map<std::string, int> left_to_governor;
  int skipped = 0;
  std::map<std::string, double> rss_slope;    ///< per process label judged [MiB/min]
  std::map<std::string, int> incidents;       ///< per module: buckets in which its object slipped or lost contact
  uint64_t slip_events = 0;                   ///< slip events counted over every world instance
  bool ok() const { return violations.empty(); }
};

Verdict check(const History& h, const Bounds& b);

/// Least-squares slope of y over x (0 with fewer than 2 points).
double slope(const std::vector<std::pair<double, double>>& xy);
/// Percentile (0..1) of values, linear between order statistics; 0 for none.
double percentile(std::vector<double> v, double p);

}  // namespace tandem::soak
