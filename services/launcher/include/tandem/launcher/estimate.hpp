// The real-time capacity estimate of a deployment (docs/benchmarks.md, "Capacity"): what it needs against what the
// machine has, calibrated on this machine (capacity.hpp: a cross-process wake-up; here a plant step and a law step of
// its first module), with a warning when it does not fit, and the admission that follows from it (the modules, in
// file order, that fit; the others start parked: docs/failure-model.md, "Shedding whole modules"). In lockstep there
// is no real-time load. `tandem up` (services/cli/up_run.cpp) prints it and `tandem up --check` too.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tandem/launcher/capacity.hpp"
#include "tandem/sim/module_setup.hpp"

namespace tandem::launcher {

/// User + system CPU seconds of process `pid` so far (/proc/<pid>/stat), -1 if it cannot be read: what a start costs
/// (`tandem up` sums it per role from a process's start to its first active status).
double process_cpu_s(int pid);

/// The plant step and control-law step of a module, timed here (thread CPU time, the median of a few batches).
void time_model(const sim::ModuleSetup& ms, Calibration& c);

/// What the estimate needs of a deployment.
struct LoadSpec {
  bool realtime = false;          ///< timing: realtime
  bool overload_brake = true;
  bool simple_discovery = true;   ///< discovery: simple
  /// cpu_affinity: module (a module's processes on one CPU): the wake-up is calibrated on one CPU too
  bool pinned = false;
  std::vector<int> standbys;      ///< per module of the file: its standby robots per arm
  /// The first module, built from its scenario (timed; nothing or an exception: the model's share is left out).
  std::function<std::optional<sim::ModuleSetup>()> first_module;
};

struct Capacity {
  std::string text;
  double per_module = 0.0, per_standby = 0.0, usable = 0.0;
  bool realtime = false;
  /// Cores a module needs with its standby robots (per arm).
  double of(int standby) const { return per_module + 2.0 * standby * per_standby; }
};

/// Calibrates here (about 0.3 s) and estimates; lockstep: no real-time load, nothing measured.
Capacity capacity_estimate(const LoadSpec& d);

/// Admission: `modules` (name, standby robots per arm) in priority order; the first ones that fit in the usable
/// cores run, the rest start parked. With several hosts every module is admitted (the estimate is of this machine).
struct Admission {
  std::vector<std::string> order;
  size_t fit = 0;
};
Admission admission(const Capacity& cap, const std::vector<std::pair<std::string, int>>& modules, bool multi_host);

}  // namespace tandem::launcher
