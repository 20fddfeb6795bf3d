#include "tandem/coordinator/task_queue.hpp"

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <set>
#include <tuple>
#include <utility>

namespace tandem::coordinator {

bool Snapshot::well_formed() const {
  if (running.size() != running_on.size() || running.size() != running_id.size() || modules.size() > kMaxModules) {
    return false;
  }
  for (const uint8_t b : done_by) {
    if (b > modules.size()) return false;
  }
  return done_total >= done_count();
}

size_t Snapshot::done_count() const {
  return static_cast<size_t>(std::count_if(done_by.begin(), done_by.end(), [](uint8_t b) { return b != 0; }));
}

size_t Snapshot::payload_bytes() const {
  size_t n = 16 + done_by.size();
  for (const auto& m : modules) n += m.size() + 4;
  for (size_t i = 0; i < running.size(); ++i) n += running[i].size() + running_on[i].size() + 16;
  return n;
}

TaskQueue::TaskQueue(std::vector<std::string> tasks, Balance balance)
    : names_(std::move(tasks)), balance_(balance), done_by_(names_.size(), 0) {
  for (size_t t = 0; t < names_.size(); ++t) pending_.push_back(t);
}

uint8_t TaskQueue::module_index(const std::string& module) {
  const auto it = std::find(module_names_.begin(), module_names_.end(), module);
  if (it != module_names_.end()) return static_cast<uint8_t>(it - module_names_.begin() + 1);
  if (module_names_.size() >= Snapshot::kMaxModules) return 0;
  module_names_.push_back(module);
  return static_cast<uint8_t>(module_names_.size());
}

// The module is idle after the task it reports (left: it finished its task before leaving).
bool TaskQueue::finished_state(uint8_t state) {
  return state == static_cast<uint8_t>(ModuleState::Idle) ||
         state == static_cast<uint8_t>(ModuleState::Done) || state == static_cast<uint8_t>(ModuleState::Left);
}

std::optional<size_t> TaskQueue::find_task(const std::string& name) const {
  const auto it = std::find(names_.begin(), names_.end(), name);
  if (it == names_.end()) return std::nullopt;
  return static_cast<size_t>(it - names_.begin());
}

size_t TaskQueue::tasks_of(const std::string& module) const {
  const auto it = done_of_.find(module);
  return it == done_of_.end() ? 0 : it->second;
}

void TaskQueue::finish(const std::string& name, Module& m, std::vector<Event>& events) {
  ++done_total_;
  uint8_t& by = done_by_[m.running_task];
  if (by == 0) {
    ++done_count_;
    by = module_index(name);
    if (by == 0) by = 1;  // past 255 modules: credited to the first (counts stay right)
    ++done_of_[name];
  }
  events.push_back({EventKind::Finished, name, names_[m.running_task], m.running_id, done_count()});
  for (auto a = abandoned_.begin(); a != abandoned_.end();) {  // done: nothing left to reclaim of it
    a = a->second.task == m.running_task ? abandoned_.erase(a) : std::next(a);
  }
  m.running_id = 0;
  ++revision_;
}

void TaskQueue::requeue(Module& m) {
  pending_.push_front(m.running_task);
  m.running_id = 0;
  ++revision_;
}

std::vector<Event> TaskQueue::report(const ModuleReport& r, double now) {
  std::vector<Event> events;
  if (r.module.empty() || r.state > static_cast<uint8_t>(ModuleState::Failed)) {
    ++rejected_;
    return events;
  }
  if (r.task_id >= next_id_) {  // never hand out an id a supervisor already had (it would ignore it)
    next_id_ = r.task_id + 1;
    ++revision_;
  }
  auto it = modules_.find(r.module);
  if (r.state == static_cast<uint8_t>(ModuleState::Left)) {
    left_[r.module] = r.task_id;
    if (it == modules_.end()) return events;
    Module& m = it->second;
    if (m.running_id != 0 && r.task_id == m.running_id) finish(r.module, m, events);
    Event e{EventKind::Left, r.module, "", 0, 0};
    if (m.running_id != 0) {
      e.task = names_[m.running_task];
      e.id = m.running_id;
      requeue(m);
    }
    events.push_back(e);
    modules_.erase(it);
    return events;
  }
  left_.erase(r.module);
  if (it == modules_.end()) {
    it = modules_.emplace(r.module, Module{}).first;
    events.push_back({EventKind::Joined, r.module, "", 0, 0});
  }
  Module& m = it->second;
  if (m.lost) {
    m.lost = false;
    events.push_back({EventKind::Rejoined, r.module, "", 0, 0});
  }
  m.heard = true;
  m.last_heard = now;
  // A module lost for a while (its supervisor silent while its world restarted: a soak-small hour, twice in one
  // minute) may still run, or have finished, the task taken from it. If that task was not handed to anyone since, it
  // stays where it is: handed again to the same module under a new id, the supervisor (still busy with the old id)
  // dropped the new one, its "done" of the old one was ignored, and the module stood idle with a task in flight
  // for 30 s.
  // Only a module that says it is busy with it (running, paused, draining) gets it back: one that reports the old
  // id idle or done may not have run it at all (a supervisor whose world restarted said "idle" with the task in
  // hand, not started yet), and is never credited with it unseen; an assignment it drops is sent again (untaken()).
  const bool busy = r.state == static_cast<uint8_t>(ModuleState::Running) ||
                    r.state == static_cast<uint8_t>(ModuleState::Paused) ||
                    r.state == static_cast<uint8_t>(ModuleState::Draining);
  if (m.running_id == 0 && busy) {
    if (const auto a = abandoned_.find(r.task_id); a != abandoned_.end() && a->second.module == r.module && a->second.lost) {
      if (const auto pos = std::find(pending_.begin(), pending_.end(), a->second.task); pos != pending_.end()) {
        pending_.erase(pos);
        m.running_id = r.task_id;
        m.running_task = a->second.task;
        events.push_back({EventKind::Reclaimed, r.module, names_[a->second.task], r.task_id, 0});
        abandoned_.erase(a);
        ++revision_;
      }
    }
  }
  const bool newly_failed = r.state == static_cast<uint8_t>(ModuleState::Failed) && m.state != r.state;
  m.state = r.state;
  m.reported = r.task_id;
  if (newly_failed) {
    // A drop: the task in flight was not done (its object was not held throughout). It goes back to the front of
    // the queue, a late "done" from this module for it is ignored, and the module is not free while failed.
    Event e{EventKind::Failed, r.module, "", 0, 0};
    if (m.running_id != 0) {
      e.task = names_[m.running_task];
      e.id = m.running_id;
      abandoned_[m.running_id] = Abandoned{m.running_task, r.module, false};
      requeue(m);
    }
    events.push_back(e);
    return events;
  }
  if (m.running_id != 0 && r.task_id > m.running_id) {
    // The module took a newer id than the one in flight on it: another coordinator gave it that while this one
    // stood still (a soak-small hour: the stalled primary held id 452 in flight on m1, which its successor had seen
    // finished before it gave m1 id 454; m1 was never free again for this one, and took no task for 100 s). Whether
    // the old id was finished is not known here: it goes back to the front of the queue (never counted without a
    // report of it), as a takeover's reconcile does.
    events.push_back({EventKind::Requeued, r.module, names_[m.running_task], m.running_id, 0});
    requeue(m);
  }
  const bool untaken = m.running_id != 0 && r.task_id < m.running_id && finished_state(r.state) &&
                       r.state != static_cast<uint8_t>(ModuleState::Left);
  if (!untaken) {
    m.untaken_since = -1.0;
  } else if (m.untaken_since < 0.0) {
    m.untaken_since = now;
  }
  if (!finished_state(r.state)) return events;
  if (m.running_id != 0 && r.task_id == m.running_id) {
    finish(r.module, m, events);
  } else if (const auto a = abandoned_.find(r.task_id);
             a != abandoned_.end() && a->second.module == r.module && !a->second.said) {
    events.push_back({EventKind::LateDoneIgnored, r.module, names_[a->second.task], r.task_id, 0});
    a->second.said = true;  // said once; kept for a lost module, which may still turn out to run it (reclaim)
    if (!a->second.lost) abandoned_.erase(a);
  }
  return events;
}

void TaskQueue::forgive_silence(double now) {
  for (auto& [name, m] : modules_) {
    if (!m.lost) m.last_heard = std::max(m.last_heard, now);
  }
}

std::vector<Event> TaskQueue::expire(double now) {
  std::vector<Event> events;
  for (auto& [name, m] : modules_) {
    if (m.lost || now - m.last_heard <= kModuleLostS) continue;
    m.lost = true;
    Event e{EventKind::Lost, name, "", 0, 0};
    if (m.running_id != 0) {
      e.task = names_[m.running_task];
      e.id = m.running_id;
      abandoned_[m.running_id] = Abandoned{m.running_task, name, true};
      requeue(m);
    }
    events.push_back(e);
  }
  return events;
}

std::optional<Assignment> TaskQueue::assign_next(const std::function<double(const std::string&)>& wear) {
  if (pending_.empty()) return std::nullopt;
  const std::string* best = nullptr;
  double best_wear = 0.0;
  size_t best_tasks = 0;
  for (const auto& [name, m] : modules_) {  // by name: ties go to the first
    const bool free = m.heard && !m.lost && m.running_id == 0 &&
                      (m.state == static_cast<uint8_t>(ModuleState::Idle) ||
                       m.state == static_cast<uint8_t>(ModuleState::Done));
    if (!free) continue;
    const double w = wear(name);
    const size_t n = tasks_of(name);
    const bool better = balance_ == Balance::RoundRobin
                            ? n < best_tasks
                            : (w < best_wear || (w == best_wear && n < best_tasks));
    if (best == nullptr || better) {
      best = &name;
      best_wear = w;
      best_tasks = n;
    }
  }
  if (best == nullptr) return std::nullopt;
  Module& m = modules_.at(*best);
  m.running_task = pending_.front();
  pending_.pop_front();
  m.running_id = next_id_++;
  ++revision_;
  return Assignment{*best, m.running_id, m.running_task, best_wear};
}

std::vector<Assignment> TaskQueue::untaken(double now) {
  std::vector<Assignment> out;
  for (auto& [name, m] : modules_) {
    if (m.running_id == 0 || m.lost || !m.heard || m.untaken_since < 0.0 || now - m.untaken_since < kUntakenS) continue;
    out.push_back({name, m.running_id, m.running_task, 0.0});
    m.untaken_since = now;  // again in kUntakenS if it still does not take it
  }
  return out;
}

void TaskQueue::restore(const Snapshot& s, double now) {
  std::fill(done_by_.begin(), done_by_.end(), 0);
  module_names_.clear();
  done_of_.clear();
  done_count_ = 0;
  pending_.clear();
  abandoned_.clear();
  for (auto& entry : modules_) entry.second.running_id = 0;
  std::vector<bool> placed(names_.size(), false);
  for (size_t t = 0; t < std::min(s.done_by.size(), names_.size()); ++t) {
    const uint8_t b = s.done_by[t];
    if (b == 0 || b > s.modules.size()) continue;
    const std::string& module = s.modules[b - 1];
    done_by_[t] = module_index(module);
    if (done_by_[t] == 0) done_by_[t] = 1;
    ++done_of_[module];
    ++done_count_;
    placed[t] = true;
  }
  done_total_ = std::max<uint64_t>(s.done_total, done_count_);
  const size_t n_running = std::min({s.running.size(), s.running_on.size(), s.running_id.size()});
  for (size_t i = 0; i < n_running; ++i) {
    const auto t = find_task(s.running[i]);
    if (!t || placed[*t] || s.running_id[i] == 0) continue;
    auto it = modules_.find(s.running_on[i]);
    if (it == modules_.end()) {
      // Not heard by this standby: a module that left (reconcile() looks at what it reported last) or one
      // that has not reported yet (it is lost if it stays silent).
      Module m;
      m.last_heard = now;
      if (const auto l = left_.find(s.running_on[i]); l != left_.end()) {
        m.heard = true;
        m.state = static_cast<uint8_t>(ModuleState::Left);
        m.reported = l->second;
      }
      it = modules_.emplace(s.running_on[i], m).first;
    }
    if (it->second.running_id != 0) continue;  // a second task on one module: it stays pending
    it->second.running_id = s.running_id[i];
    it->second.running_task = *t;
    next_id_ = std::max(next_id_, s.running_id[i] + 1);
    placed[*t] = true;
  }
  for (size_t t = 0; t < names_.size(); ++t) {
    if (!placed[t]) pending_.push_back(t);
  }
  next_id_ = std::max(next_id_, s.next_task_id);
  ++revision_;
}

TaskQueue::Reconciled TaskQueue::reconcile(double now) {
  Reconciled out;
  out.events = expire(now);
  for (auto it = modules_.begin(); it != modules_.end();) {
    const std::string& name = it->first;
    Module& m = it->second;
    const bool left = m.heard && m.state == static_cast<uint8_t>(ModuleState::Left);
    if (m.running_id != 0) {
      if (m.heard && m.reported == m.running_id && finished_state(m.state)) {
        finish(name, m, out.events);
      } else if (left || (m.heard && m.reported > m.running_id) ||
                 (m.heard && m.state == static_cast<uint8_t>(ModuleState::Failed))) {
        out.events.push_back({EventKind::Requeued, name, names_[m.running_task], m.running_id, 0});
        requeue(m);
      } else if (!m.heard || m.reported < m.running_id) {
        out.resend.push_back({name, m.running_id, m.running_task, 0.0});
      }  // else the module runs it (running, paused or draining)
    }
    it = left ? modules_.erase(it) : std::next(it);
  }
  return out;
}

Snapshot TaskQueue::snapshot() const {
  Snapshot s;
  s.next_task_id = next_id_;
  s.modules = module_names_;
  s.done_by = done_by_;
  s.done_total = done_total_;
  std::vector<std::tuple<uint64_t, size_t, std::string>> running;
  for (const auto& [name, m] : modules_) {
    if (m.running_id != 0) running.emplace_back(m.running_id, m.running_task, name);
  }
  std::sort(running.begin(), running.end());
  for (const auto& [id, task, module] : running) {
    s.running.push_back(names_[task]);
    s.running_on.push_back(module);
    s.running_id.push_back(id);
  }
  return s;
}

std::string TaskQueue::describe(const Event& e) const {
  const std::string task = e.task.empty() ? "" : "task " + e.task + " (id " + std::to_string(e.id) + ")";
  const std::string back = e.task.empty() ? "" : "; " + task + " back to the front of the queue";
  char lost_after[32];
  std::snprintf(lost_after, sizeof lost_after, "%.1f s", kModuleLostS);
  switch (e.kind) {
    case EventKind::Joined:
      return "module " + e.module + " joined";
    case EventKind::Rejoined:
      return e.module + " is heard again; it takes new tasks only";
    case EventKind::Finished:
      return e.module + " finished " + task + "; " + std::to_string(e.done) + "/" +
             std::to_string(names_.size()) + " done";
    case EventKind::LateDoneIgnored:
      return e.module + " reports " + task + " done, but it was taken from " + e.module +
             " (lost, or its object dropped) and handed on: ignored";
    case EventKind::Reclaimed:
      return e.module + " is heard again with " + task + ", which was not handed on: it stays with " + e.module;
    case EventKind::Lost:
      return e.module + " lost (not heard for " + lost_after + ")" + back;
    case EventKind::Left:
      return e.module + " left" + back;
    case EventKind::Requeued:
      return e.module + " no longer runs " + task + "; it goes back to the front of the queue";
    case EventKind::Failed:
      return e.module + " failed (its object was dropped): it takes no task until it is cleared" + back;
  }
  return "";
}


size_t TaskQueue::running_count() const {
  return static_cast<size_t>(std::count_if(modules_.begin(), modules_.end(),
                                           [](const auto& e) { return e.second.running_id != 0; }));
}

std::vector<std::string> TaskQueue::pending() const {
  std::vector<std::string> out;
  for (size_t t : pending_) out.push_back(names_[t]);
  return out;
}

size_t TaskQueue::lost_count() const {
  return static_cast<size_t>(
      std::count_if(modules_.begin(), modules_.end(), [](const auto& e) { return e.second.lost; }));
}

std::map<std::string, std::vector<std::string>> TaskQueue::done_by_module() const {
  std::map<std::string, std::vector<std::string>> out;
  for (const auto& entry : modules_) out[entry.first];
  for (size_t t = 0; t < done_by_.size(); ++t) {
    if (done_by_[t] != 0) out[module_names_[done_by_[t] - 1]].push_back(names_[t]);
  }
  return out;
}

}  // namespace tandem::coordinator
