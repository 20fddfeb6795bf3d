#include "tandem/launcher/governor.hpp"

#include <algorithm>
#include <cstdio>
#include <utility>

namespace tandem::launcher {

Governor::Governor(std::vector<std::string> modules, GovernorRule rule) : order_(std::move(modules)), rule_(rule) {}

std::vector<std::string> Governor::admit(size_t fit, double now) {
  std::vector<std::string> out;
  fit = std::max<size_t>(fit, 1);  // one module always runs
  for (size_t i = fit; i < order_.size(); ++i) {
    parked_.insert(order_[i]);
    out.push_back(order_[i]);
  }
  if (!out.empty()) last_decision_ = now;
  return out;
}

void Governor::set_available(const std::string& module, bool available) {
  if (available) {
    unavailable_.erase(module);
  } else {
    unavailable_.insert(module);
    parked_.erase(module);
    paused_now_.erase(module);
  }
  // Its samples go either way: a module that comes back starts afresh (an old "paused" would otherwise hold from
  // before it left until its new world's first status).
  samples_.erase(std::remove_if(samples_.begin(), samples_.end(), [&](const Sample& s) { return s.module == module; }),
                 samples_.end());
}

void Governor::on_load(const std::string& module, bool paused_for_load, double now) {
  if (parked_.count(module) || unavailable_.count(module)) return;
  paused_now_[module] = paused_for_load;
  samples_.push_back({now, module, paused_for_load});
  if (paused_for_load) last_paused_ = now;
  // Kept a window and a short release back: a module's state at the window's start is its last sample before it.
  while (!samples_.empty() && samples_.front().t < now - rule_.window_s - rule_.short_release_s - 5.0) samples_.pop_front();
}

double Governor::paused_share(double now) const {
  const double from = now - rule_.window_s;
  double covered = 0.0, paused = 0.0;
  for (const std::string& m : order_) {
    if (parked_.count(m) || unavailable_.count(m)) continue;
    // The module's state as a step function of time: each sample holds until the next one (the last until now).
    std::vector<std::pair<double, bool>> steps;
    for (const Sample& s : samples_) {
      if (s.module != m) continue;
      if (!steps.empty() && steps.back().second == s.paused) continue;
      steps.emplace_back(s.t, s.paused);
    }
    for (size_t i = 0; i < steps.size(); ++i) {
      const double a = steps[i].first, b = i + 1 < steps.size() ? steps[i + 1].first : now;
      // A short release between two pauses counts as paused; the release going on now does not (yet).
      const bool as_paused = steps[i].second || (i > 0 && i + 1 < steps.size() && b - a < rule_.short_release_s);
      const double lo = std::max(a, from), hi = std::min(b, now);
      if (hi <= lo) continue;
      covered += hi - lo;
      if (as_paused) paused += hi - lo;
    }
  }
  return covered <= 0.0 ? 0.0 : paused / covered;
}

Governor::Decision Governor::unpark(const std::string& module, const std::string& why, double now) {
  parked_.erase(module);
  returned_at_[module] = now;
  samples_.clear();
  last_decision_ = now;
  return Decision{Decision::Kind::Unpark, module, why};
}

Governor::Decision Governor::decide(double now) {
  Decision d;
  if (!rule_.enabled) return d;
  std::vector<std::string> running;
  for (const std::string& m : order_) {
    if (!parked_.count(m) && !unavailable_.count(m)) running.push_back(m);
  }
  // One module always runs: with none running for none_running_s (the others failed, unplugged or stopped, and not
  // back), a parked one comes back, whatever the calm and the settling time. Not at once: a killed world's module is
  // plugged back within seconds, and a park undone at once restarted a module into the next fault (the CI soak).
  if (running.empty()) {
    if (none_running_since_ < 0.0) none_running_since_ = now;
    if (now - none_running_since_ < rule_.none_running_s) return d;
    for (const std::string& m : order_) {
      if (!parked_.count(m) || unavailable_.count(m)) continue;
      char why[96];
      std::snprintf(why, sizeof why, "no module has run for %.0f s: one always does", now - none_running_since_);
      none_running_since_ = -1.0;
      return unpark(m, why, now);
    }
    return d;
  }
  none_running_since_ = -1.0;
  if (now - last_decision_ < rule_.settle_s) return d;
  // Enough history since the last decision to judge the window: the oldest sample is most of a window old.
  const bool judged = !samples_.empty() && samples_.front().t <= now - 0.8 * rule_.window_s &&
                      samples_.front().t >= last_decision_;
  const double share = paused_share(now);
  if (judged && share > rule_.share && running.size() > 1) {
    d.kind = Decision::Kind::Park;
    d.module = running.back();
    char why[160];
    std::snprintf(why, sizeof why, "overload: the running modules were paused for load %.0f%% of the last %.0f s", 100.0 * share,
                  rule_.window_s);
    d.why = why;
    double& calm = calm_needed_[d.module];
    if (calm <= 0.0) calm = rule_.calm_s;
    const auto back = returned_at_.find(d.module);
    if (back != returned_at_.end() && now - back->second < calm + rule_.window_s) calm = std::min(2.0 * calm, rule_.calm_max_s);
    parked_.insert(d.module);
    paused_now_.erase(d.module);
    samples_.clear();
    last_decision_ = now;
    return d;
  }
  if (parked_.empty()) return d;
  for (const std::string& m : order_) {
    if (!parked_.count(m) || unavailable_.count(m)) continue;
    double calm = calm_needed_[m];
    if (calm <= 0.0) calm = calm_needed_[m] = rule_.calm_s;
    const double quiet = now - std::max(last_paused_, last_decision_);
    if (quiet < calm) return d;
    char why[128];
    std::snprintf(why, sizeof why, "calm: no module paused for load for %.0f s", quiet);
    return unpark(m, why, now);
  }
  return d;
}

}  // namespace tandem::launcher
