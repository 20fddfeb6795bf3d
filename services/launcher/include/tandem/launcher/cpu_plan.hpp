// Which CPU a module's per-tick processes (its world and every robot of it, standbys included) run on in real
// time (deployment key `cpu_affinity: module`, opt-in, docs/architecture.md "Real-time timing"). A module's processes wake
// each other twice per arm per tick; on one CPU a wake-up needs no inter-processor interrupt, which on the 2-vCPU
// virtual machines measured is what made SCHED_FIFO late (docs/benchmarks.md item 48). The plan is a rule, no
// system call: `tandem up` gives it the CPUs it may use (sched_getaffinity) and asks per module.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace tandem::launcher {

class CpuPlan {
 public:
  /// `cpus`: the CPUs the deployment may use, in order; empty: no pinning (cpu_of gives -1).
  explicit CpuPlan(std::vector<int> cpus) : cpus_(std::move(cpus)), count_(cpus_.size(), 0) {}
  /// The module's CPU: the one it was given before (a restarted robot joins its world), else the CPU with the
  /// fewest modules so far (the first of them on a tie), so modules in file order go round the CPUs.
  int cpu_of(const std::string& module);
  /// Whether it pins at all (CPUs were given).
  bool active() const { return !cpus_.empty(); }
  /// Modules given CPU `cpu` so far.
  int modules_on(int cpu) const;

 private:
  std::vector<int> cpus_;
  std::vector<int> count_;
  std::map<std::string, int> given_;  ///< module -> index into cpus_
};

/// The CPUs this process may run on (sched_getaffinity), in increasing order; empty if it cannot be read.
std::vector<int> allowed_cpus();

}  // namespace tandem::launcher
