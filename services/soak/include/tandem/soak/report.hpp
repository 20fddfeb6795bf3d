// The soak report: a directory with summary.md, summary.txt (key=value), index.html and SVG plots.
#pragma once

#include <string>
#include <vector>

#include "tandem/soak/checker.hpp"
#include "tandem/soak/history.hpp"

namespace tandem::soak {

struct RunInfo {
  std::string deployment, deployment_file, command, faults_source, machine, timing;
  uint64_t seed = 0;
  double wall_s = 0.0;
  int modules = 0, processes_seen = 0;
};

/// A process's share of a core over the last `window_s` of its samples (from cpu_s), for the processes that lived
/// that long: the busiest first. A listener wedged on a removed segment spins (soak finding 71); this shows it.
struct CpuShare {
  std::string label;
  long long pid = 0;
  double share = 0.0;  ///< of one core, over its last window
  double first_share = 0.0;  ///< the same over its first window
};
std::vector<CpuShare> cpu_shares(const std::vector<RssSample>& samples, double window_s);

/// Writes the report into `dir` (created if missing). Returns the path of summary.md. Throws std::runtime_error
/// if a file cannot be written.
std::string write_report(const std::string& dir, const RunInfo& info, const History& h, const Bounds& b,
                         const Verdict& v);

/// The summary as plain text (what `tandem soak` prints at the end).
std::string summary_text(const RunInfo& info, const History& h, const Bounds& b, const Verdict& v);

}  // namespace tandem::soak
