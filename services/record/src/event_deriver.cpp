#include "tandem/record/event_deriver.hpp"

namespace tandem::record {

const char* lifecycle_state_name(int state) {
  static const char* const kNames[] = {"unconfigured", "inactive", "active", "finalized", "error"};
  return state >= 0 && state < 5 ? kNames[state] : "?";
}

std::string EventDeriver::owners_text(const std::vector<ArmOwnerView>& owners) {
  std::string out;
  for (const auto& o : owners) out += (out.empty() ? "" : ",") + o.arm + "=" + o.text;
  return out;
}

std::vector<DerivedEvent> EventDeriver::on_status(const std::string& process, const std::string& module, int state,
                                                  const std::string& detail, uint64_t tick) {
  std::vector<DerivedEvent> out;
  const auto [it, first] = states_.emplace(process, state);
  if (!first && it->second == state) return out;
  out.push_back({"lifecycle", module, process,
                 std::string(first ? "(new)" : lifecycle_state_name(it->second)) + " -> " + lifecycle_state_name(state) +
                     (detail.empty() ? "" : ": " + detail),
                 tick});
  it->second = state;
  return out;
}

std::vector<DerivedEvent> EventDeriver::on_world(const std::string& module, const WorldView& w) {
  std::vector<DerivedEvent> out;
  const std::string text = owners_text(w.owners);
  const auto [it, first] = worlds_.emplace(module, WorldPrev{});
  WorldPrev& prev = it->second;
  if (!first) {
    for (size_t j = 0; j < 2; ++j) {
      if (w.braked[j] != prev.braked[j]) out.push_back({w.braked[j] ? "brake" : "release", module, "arm " + std::to_string(j), "", w.tick});
    }
    if (w.load_paused != prev.load_paused) {
      out.push_back({w.load_paused ? "load_pause" : "load_resume", module, module, "", w.tick});
    }
    for (const auto& o : w.owners) {
      const auto b = prev.strength.find(o.arm);
      const int s = o.served ? o.strength : 0;
      if (b == prev.strength.end() || b->second == s || b->second == 0 || s == 0) continue;
      out.push_back({s < b->second ? "failover" : "takeover", module, module + "/" + o.arm, prev.owners + " -> " + text, w.tick});
    }
  }
  // A dropped object fails the module for good (it stays failed until cleared): one event, also for a recorder
  // that joins after the drop (its first report says failed).
  if (w.failed && !prev.failed) out.push_back({"module_failed", module, module, w.failure, w.tick});
  prev.braked = w.braked;
  prev.load_paused = w.load_paused;
  prev.failed = w.failed;
  prev.owners = text;
  for (const auto& o : w.owners) prev.strength[o.arm] = o.served ? o.strength : 0;
  return out;
}

std::vector<DerivedEvent> EventDeriver::on_assignment(uint64_t task_id, const std::string& module, const std::string& name) {
  std::vector<DerivedEvent> out;
  if (tasks_seen_.insert(task_id).second) out.push_back({"task_assigned", module, name, "task " + std::to_string(task_id), 0});
  return out;
}

std::vector<DerivedEvent> EventDeriver::on_task_state(const std::string& module, uint64_t task_id, uint64_t tasks_done,
                                                      uint64_t tick) {
  std::vector<DerivedEvent> out;
  uint64_t& done = tasks_done_[module];
  if (tasks_done > done) {
    out.push_back({"task_done", module, "task " + std::to_string(task_id),
                   std::to_string(tasks_done) + " done by " + module, tick});
    done = tasks_done;
  }
  return out;
}

std::vector<DerivedEvent> EventDeriver::on_control(const std::string& command, const std::string& target,
                                                   const std::string& option) {
  return {{"control", "", target, command + (option.empty() ? "" : " " + option), 0}};
}

}  // namespace tandem::record
