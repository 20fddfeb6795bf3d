#include "tandem/launcher/host_watch.hpp"

namespace tandem::launcher {

HostWatch::HostWatch(std::vector<std::string> hosts, double timeout_s) : timeout_(timeout_s) {
  for (auto& h : hosts) state_[std::move(h)] = State{};
}

bool HostWatch::heard(const std::string& host, double now) {
  const auto it = state_.find(host);
  if (it == state_.end()) return false;
  State& s = it->second;
  const bool back = s.lost;
  s.heard = true;
  s.lost = false;
  if (now > s.last) s.last = now;
  return back;
}

void HostWatch::restart_clock(double now) {
  for (auto& [name, s] : state_) {
    if (s.heard && !s.lost && now > s.last) s.last = now;
  }
}

std::vector<std::string> HostWatch::newly_lost(double now) {
  std::vector<std::string> out;
  for (auto& [name, s] : state_) {
    if (s.heard && !s.lost && now - s.last > timeout_) {
      s.lost = true;
      out.push_back(name);
    }
  }
  return out;
}

bool HostWatch::up(const std::string& host) const {
  const auto it = state_.find(host);
  return it != state_.end() && it->second.heard && !it->second.lost;
}

bool HostWatch::lost(const std::string& host) const {
  const auto it = state_.find(host);
  return it != state_.end() && it->second.lost;
}

std::vector<std::string> HostWatch::waiting() const {
  std::vector<std::string> out;
  for (const auto& [name, s] : state_) {
    if (!s.heard) out.push_back(name);
  }
  return out;
}

}  // namespace tandem::launcher
