#include "tandem/launcher/restart_policy.hpp"

#include <algorithm>
#include <cmath>

namespace tandem::launcher {

RestartDecision RestartPolicy::on_exit(const std::string& key, int exit_status, const RestartRule& rule, double now) {
  RestartDecision d;
  const bool wanted = rule.policy == "always" || (rule.policy == "on-failure" && exit_status != 0);
  if (!wanted) return d;
  std::vector<double>& hist = history_[key];
  hist.erase(std::remove_if(hist.begin(), hist.end(), [&](double t) { return now - t > rule.window; }), hist.end());
  if (static_cast<int>(hist.size()) >= rule.limit) {
    d.kind = RestartDecision::Kind::GiveUp;
    d.count = static_cast<int>(hist.size());
    return d;
  }
  d.kind = RestartDecision::Kind::Restart;
  d.delay = std::min(rule.backoff * std::pow(2.0, static_cast<double>(hist.size())), std::max(rule.backoff, rule.max_backoff));
  hist.push_back(now);
  d.count = static_cast<int>(hist.size());
  return d;
}

int RestartPolicy::recent(const std::string& key, const RestartRule& rule, double now) const {
  const auto it = history_.find(key);
  if (it == history_.end()) return 0;
  return static_cast<int>(std::count_if(it->second.begin(), it->second.end(), [&](double t) { return now - t <= rule.window; }));
}

int next_standby_strength(const std::vector<int>& live) {
  int lowest = 51;
  for (const int s : live) lowest = std::min(lowest, s);
  if (lowest - 1 >= 1) return lowest - 1;
  for (int s = 50; s >= 1; --s) {
    if (std::find(live.begin(), live.end(), s) == live.end()) return s;
  }
  return 0;
}

}  // namespace tandem::launcher
