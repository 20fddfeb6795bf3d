#include "tandem/launcher/cpu_plan.hpp"

#include <sched.h>

#include <algorithm>

namespace tandem::launcher {

int CpuPlan::cpu_of(const std::string& module) {
  if (cpus_.empty()) return -1;
  const auto it = given_.find(module);
  if (it != given_.end()) return cpus_[static_cast<size_t>(it->second)];
  const auto least = std::min_element(count_.begin(), count_.end());
  const int index = static_cast<int>(least - count_.begin());
  ++*least;
  given_[module] = index;
  return cpus_[static_cast<size_t>(index)];
}

int CpuPlan::modules_on(int cpu) const {
  const auto it = std::find(cpus_.begin(), cpus_.end(), cpu);
  return it == cpus_.end() ? 0 : count_[static_cast<size_t>(it - cpus_.begin())];
}

std::vector<int> allowed_cpus() {
  std::vector<int> out;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof set, &set) != 0) return out;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &set)) out.push_back(c);
  }
  return out;
}

}  // namespace tandem::launcher
