// The launcher's restart policy as a component (no processes, no clock: times in seconds are passed in), as
// Erlang/OTP supervisors do it: a child that exits is restarted by policy (never, on-failure, always) after a
// backoff that doubles with each restart inside the window (up to a cap), and given up on after `limit` restarts within
// `window` seconds (the intensity limit). services/cli/up_run.cpp asks it; tests/unit drive it.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace tandem::launcher {

struct RestartRule {
  std::string policy = "never";  ///< never | on-failure | always
  int limit = 3;                 ///< restarts within `window` before giving up
  double window = 30.0;          ///< [s]
  double backoff = 0.2;          ///< first delay [s], doubled per restart inside the window
  /// The doubling stops here [s] (or at `backoff` if that is larger). Uncapped, the eighth restart of an arm
  /// within a minute waited 25.6 s, and a soak hour's "replacement robot within 10 s" failed by the policy's own
  /// delay while a standby-less arm stayed braked; crash loops are still ended by `limit`.
  double max_backoff = 2.0;
};

struct RestartDecision {
  enum class Kind { None, Restart, GiveUp } kind = Kind::None;
  double delay = 0.0;   ///< Restart: seconds until the new start
  int count = 0;        ///< Restart: this restart's number within the window; GiveUp: restarts within it
};

/// Ownership strength for a new standby of a slot whose live processes have `live` strengths (the primary is
/// 100, standbys 1-50): one below the weakest live one, so that it never takes over from a warm standby. When
/// that would fall below 1 (about a thousand restarts an hour in a soak walked the strengths down by one each),
/// the strongest of 1-50 that no live process has: above the owner it takes the slot over after its warm-up
/// (a takeover, as a primary's return). 0 only with all of 1-50 in use.
int next_standby_strength(const std::vector<int>& live);

class RestartPolicy {
 public:
  /// A child of slot `key` (an arm, a module's supervisor slot, "coordinator") exited with `exit_status` at
  /// time `now` [s]. None: the policy does not restart it (never, or on-failure after a clean exit).
  RestartDecision on_exit(const std::string& key, int exit_status, const RestartRule& rule, double now);
  /// Restarts of `key` still inside the window at `now`.
  int recent(const std::string& key, const RestartRule& rule, double now) const;

 private:
  std::map<std::string, std::vector<double>> history_;
};

}  // namespace tandem::launcher
