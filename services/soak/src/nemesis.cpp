#include "tandem/soak/nemesis.hpp"

#include <cmath>
#include <utility>

namespace tandem::soak {

Nemesis::Nemesis(const Schedule& schedule, std::vector<std::string> modules, History& history, NemesisActions& actions)
    : sched_(schedule), modules_(std::move(modules)), h_(history), act_(actions) {}

void Nemesis::on_status(const std::string& label, const ProcessView& p) {
  ProcessView& old = procs_[label];
  if (p.role == "world" && p.state == 2 && (old.pid != p.pid || old.state != p.state)) {
    module_started_[p.module] = p.last_t;
    ticks_.erase(p.module);  // a new world counts from 0: the old one's tick is no mark for a fault on it
  }
  old = p;
}

void Nemesis::on_owners(const std::string& module, std::map<std::string, std::string> owners) {
  owners_[module] = std::move(owners);
}

void Nemesis::step(double t) {
  while (next_fault_ < sched_.faults.size() && sched_.faults[next_fault_].at_s <= t && !stopping_) {
    const Fault& f = sched_.faults[next_fault_++];
    if (f.kind != FaultKind::Hog && f.label.empty() && candidates(f.target, t, f.kind).empty()) {
      waiting_.push_back(&f);
    } else {
      fire(f, t);
    }
  }
  for (auto it = waiting_.begin(); it != waiting_.end() && !stopping_;) {
    const Fault& f = **it;
    if (t - f.at_s >= kTargetWaitS) {
      fire(f, t);  // recorded as skipped if there is still no target
      last_waited_ = t;
      it = waiting_.erase(it);
    } else if (t - last_fired_ >= kWaitedGapS && !candidates(f.target, t, f.kind).empty()) {
      fire(f, t);
      last_waited_ = t;
      waiting_.erase(it);
      break;  // one at a time
    } else {
      ++it;
    }
  }
  for (size_t i = 0; i < pending_.size();) {
    if (pending_[i].at <= t) {
      auto fn = std::move(pending_[i].fn);
      pending_.erase(pending_.begin() + static_cast<long>(i));
      fn(t);
    } else {
      ++i;
    }
  }
}

bool Nemesis::over(double t) const {
  // A fault due before the end that no step has taken yet is not over either (over() may be asked before step()).
  if (t < sched_.duration_s || !waiting_.empty() || next_fault_ < sched_.faults.size()) return false;
  return last_waited_ < sched_.duration_s || t - last_waited_ >= kTailS;
}

void Nemesis::hog_ended(long long pid, int exit_code, double t) {
  const auto it = hogs_.find(pid);
  if (it == hogs_.end()) return;
  if (exit_code == 127) h_.faults[it->second].note = "the hog could not start";
  h_.faults[it->second].end_t = t;
  hogs_.erase(it);
}

void Nemesis::calm(double t) {
  stopping_ = true;
  for (const auto& [pid, label] : stalled_) act_.resume(pid);
  stalled_.clear();
  for (const auto& [pid, index] : hogs_) {
    act_.end_hog(pid);
    if (h_.faults[index].end_t < 0) h_.faults[index].end_t = t;
  }
  hogs_.clear();
}

bool Nemesis::live(const ProcessView& p, double t) const {
  return p.state <= 2 && t - p.last_t < kSilentS && act_.alive(p.pid) && stalled_.count(p.pid) == 0;
}

std::set<std::string> Nemesis::owners_now() const {
  std::set<std::string> o;
  for (const auto& [module, arms] : owners_) {
    for (const auto& [arm, label] : arms) o.insert(label);
  }
  return o;
}

std::vector<std::string> Nemesis::modules_up(double t) const {
  std::vector<std::string> out;
  for (const auto& m : modules_) {
    const auto it = procs_.find(m + "/world");
    if (it != procs_.end() && it->second.state == 2 && live(it->second, t) && out_.count(m) == 0) out.push_back(m);
  }
  return out;
}

bool Nemesis::settling(const std::string& module, double t) const {
  const auto it = module_started_.find(module);
  return it != module_started_.end() && t - it->second < kSettleS;
}

std::vector<std::string> Nemesis::candidates(Target target, double t, FaultKind kind) const {
  std::vector<std::string> c;
  if (target == Target::World || target == Target::Module) {
    const auto up = modules_up(t);
    const bool takes_out = !(target == Target::World && kind == FaultKind::Stall);
    // One module always runs, unless the launcher holds the others back for load (they come back when calm).
    const bool others_parked = up.size() == 1 && !parked_.empty() && parked_.count(up.front()) == 0;
    if (up.empty() || (takes_out && up.size() < 2 && !others_parked)) return c;
    for (const auto& m : up) {
      if (!settling(m, t)) c.push_back(target == Target::World ? m + "/world" : m);
    }
    return c;
  }
  const auto owners = owners_now();
  for (const auto& [label, p] : procs_) {
    if (!live(p, t) || out_.count(p.module) != 0 || settling(p.module, t)) continue;
    if (target == Target::Robot && p.role == "robot" && owners.count(label)) c.push_back(label);
    if (target == Target::Standby && p.role == "robot" && !owners.count(label) && p.state == 2) c.push_back(label);
    if (target == Target::Supervisor && p.role == "supervisor" && p.serving == "primary") c.push_back(label);
    if (target == Target::Coordinator && p.role == "coordinator" && p.serving == "primary") c.push_back(label);
  }
  return c;
}

bool Nemesis::keeps_up(const ProcessView& p, double t) const {
  if (tick_rate_ <= 0.0) return true;
  if (const auto r = resumed_.find(p.pid); r != resumed_.end() && p.last_t < r->second) return false;
  const auto world = ticks_.find(p.module);
  if (p.tick < 0 || world == ticks_.end()) return true;
  const double now_tick = static_cast<double>(p.tick) + std::max(0.0, t - p.last_t) * tick_rate_;
  return static_cast<double>(world->second) - now_tick <= static_cast<double>(kWarmLagTicks);
}

int Nemesis::live_robots_of(const std::string& arm, const std::string& except, double t) const {
  int n = 0;
  for (const auto& [label, p] : procs_) {
    if (label == except) continue;
    // Active only: a robot still starting (inactive) cannot take the arm over yet, nor one behind the world's plan
    // (soak run 60: a standby that missed a new leader's plan for 2 s counted as one, and its arm's primary was killed),
    // nor one that lags the world's ticks (kWarmLagTicks).
    if (p.role == "robot" && p.state == 2 && !p.behind && keeps_up(p, t) && live(p, t) &&
        (label == arm || label.rfind(arm + "@", 0) == 0)) {
      ++n;
    }
  }
  return n;
}

int Nemesis::warm_standbys_of(const std::string& module, const std::string& except, double t) const {
  int n = 0;
  for (const auto& [label, p] : procs_) {
    n += p.role == "supervisor" && p.module == module && label != except && p.state == 2 && p.serving == "standby" &&
         p.replica && live(p, t);
  }
  return n;
}

int Nemesis::standby_coordinators(const std::string& except, double t) const {
  int n = 0;
  for (const auto& [label, p] : procs_) {
    n += p.role == "coordinator" && label != except && p.state == 2 && p.serving == "standby" && live(p, t);
  }
  return n;
}

void Nemesis::fire(const Fault& f, double t) {
  FaultRecord r;
  r.fault = f;
  r.t = t;
  last_fired_ = t;
  if (t - f.at_s > 0.5) r.note = "waited " + std::to_string(std::lround(t - f.at_s)) + " s for a target";
  const size_t index = h_.faults.size();
  if (f.kind == FaultKind::Hog) {
    hog(f, r, index);
    h_.faults.push_back(r);
    return;
  }
  std::string target = f.label;
  if (target.empty()) {
    const auto c = candidates(f.target, t, f.kind);
    if (c.empty()) {
      r.skipped = true;
      r.note = "no live " + std::string(name(f.target)) + " within " + std::to_string(std::lround(kTargetWaitS)) + " s";
      h_.faults.push_back(r);
      return;
    }
    target = c[f.pick % c.size()];
  }
  r.label = target;
  const bool is_module =
      f.kind == FaultKind::Unplug && (f.target == Target::Module || target.find('/') == std::string::npos);
  if (is_module) r.fault.target = Target::Module;
  r.module = is_module ? target : (target.rfind("coordinator", 0) == 0 ? "" : target.substr(0, target.find('/')));
  if (!is_module) {
    const auto it = procs_.find(target);
    if (it == procs_.end() || !act_.alive(it->second.pid)) {
      r.skipped = true;
      r.note = "no running process " + target;
      h_.faults.push_back(r);
      return;
    }
    r.pid = it->second.pid;
    if (r.fault.target == Target::None) {  // a fixed fault naming a process: its role decides the kind
      const std::string& role = it->second.role;
      r.fault.target = role == "world"         ? Target::World
                       : role == "supervisor"  ? Target::Supervisor
                       : role == "coordinator" ? Target::Coordinator
                       : owners_now().count(target) ? Target::Robot
                                                    : Target::Standby;
    }
    if (it->second.role == "robot") r.had_standby = live_robots_of(target.substr(0, target.find('@')), target, t) > 0;
    if (it->second.role == "supervisor") r.had_standby = warm_standbys_of(r.module, target, t) > 0;
    if (it->second.role == "coordinator") r.had_standby = standby_coordinators(target, t) > 0;
    if (const auto tk = ticks_.find(r.module); tk != ticks_.end()) r.module_tick = tk->second;
  } else {
    const auto it = procs_.find(target + "/world");
    r.pid = it != procs_.end() ? it->second.pid : 0;
  }
  switch (f.kind) {
    case FaultKind::Kill:
      act_.kill(r.pid);
      if (r.fault.target == Target::World) {
        out_.insert(r.module);
        replug_module(r.module, index, t + f.duration_s, t + f.duration_s + 60.0);
      }
      break;
    case FaultKind::Stall: {
      const long long pid = r.pid;
      act_.stop(pid);
      stalled_[pid] = target;
      later(t + f.duration_s, [this, pid, index](double now) {
        if (stalled_.erase(pid)) {
          act_.resume(pid);
          resumed_[pid] = now;
        }
        h_.faults[index].end_t = now;
      });
      break;
    }
    case FaultKind::Unplug:
      if (is_module) {
        out_.insert(target);
        act_.request(NemesisActions::Live::UnplugModule, target, false, nullptr);
        replug_module(target, index, t + f.duration_s, t + f.duration_s + 90.0);
      } else {
        const std::string arm = target.substr(0, target.find('@'));
        const bool primary = target.find('@') == std::string::npos;
        act_.request(NemesisActions::Live::UnplugRobot, target, false, nullptr);
        later(t + f.duration_s,
              [this, arm, primary, index](double now) { replug_robot(arm, primary, index, now + 30.0); });
      }
      break;
    case FaultKind::Hog:
      break;
  }
  h_.faults.push_back(r);
}

void Nemesis::hog(const Fault& f, FaultRecord& r, size_t index) {
  const long long pid = act_.start_hog(f.cores, f.duration_s);
  if (pid <= 0) {
    r.skipped = true;
    r.note = "the hog could not be started";
    return;
  }
  r.pid = pid;
  r.label = std::to_string(f.cores) + " core(s)";
  hogs_[pid] = index;
}

void Nemesis::replug_module(const std::string& module, size_t index, double at, double give_up) {
  later(at, [this, module, index, give_up](double) {
    act_.request(NemesisActions::Live::PlugModule, module, false, [this, module, index, give_up](bool ok, const std::string& why, double now) {
      // "running already": an earlier attempt whose answer was lost plugged it in.
      if (ok || why.find("running already") != std::string::npos) {
        h_.faults[index].end_t = now;
        out_.erase(module);
      } else if (now < give_up && !stopping_) {
        replug_module(module, index, now + 1.0, give_up);
      } else {
        h_.faults[index].note = "could not plug " + module + " in again: " + why;
        out_.erase(module);
      }
    });
  });
}

void Nemesis::replug_robot(const std::string& arm, bool primary, size_t index, double give_up) {
  if (stopping_) return;
  act_.request(NemesisActions::Live::PlugRobot, arm, !primary,
               [this, arm, primary, index, give_up](bool ok, const std::string& why, double now) {
                 if (ok) {
                   h_.faults[index].end_t = now;
                 } else if (primary && why.find("primary already") != std::string::npos) {
                   replug_robot(arm, false, index, give_up);  // a restarted robot took the primary's place
                 } else if (now < give_up && !stopping_) {
                   later(now + 1.0, [this, arm, primary, index, give_up](double) { replug_robot(arm, primary, index, give_up); });
                 } else {
                   h_.faults[index].note = "could not plug a robot into " + arm + " again: " + why;
                 }
               });
}

}  // namespace tandem::soak
