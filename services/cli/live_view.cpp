#include "live_view.hpp"

#include <algorithm>
#include <set>

#include "tandem/runtime/status.hpp"

namespace tandem::cli {

namespace {
// Whether robot `id` is the one its arm follows (the world's owners).
const char* standing(const std::map<std::string, msg::ProcessStatus>& all, const msg::ProcessStatus& robot) {
  const auto w = all.find(robot.module_id() + "/world");
  if (w == all.end() || w->second.owners().empty() || robot.state() >= 3) return "";
  for (const auto& o : w->second.owners()) {
    if (o.state() == msg::ARM_SERVED && o.robot() == robot.process_id()) return "  SERVING";
  }
  return "  standby";
}
// Multi-host: " on <host>" (the pids are per host).
std::string where(const msg::ProcessStatus& s) { return s.host().empty() ? "" : " on " + s.host(); }
}  // namespace

bool LiveView::has_launcher() const {
  for (const auto& [id, s] : processes_) {
    if (s.role() == "launcher") return true;
  }
  return false;
}

std::vector<std::string> LiveView::missing() const {
  std::vector<std::string> out;
  for (const auto& [id, s] : processes_) {
    if (s.role() != "launcher") continue;
    for (const auto& label : s.runs()) {  // the labels of the processes it runs
      if (!label.empty() && processes_.count(label) == 0) out.push_back(label);
    }
  }
  return out;
}

void LiveView::print(std::FILE* f, Rows rows, std::chrono::steady_clock::time_point now) const {
  std::set<std::string> run;  // what the launchers run now (empty: no launcher heard, nothing is left out)
  for (const auto& [id, s] : processes_) {
    if (s.role() == "launcher") run.insert(s.runs().begin(), s.runs().end());
  }
  size_t gone = 0;
  for (const auto& [id, s] : processes_) {
    const auto h = heard_.find(id);
    const bool silent = h != heard_.end() && now - h->second > kGoneAfter;
    // Only the roles a launcher starts (agents, recorders and tools started otherwise are not in its list).
    const bool launched = s.role() == "world" || s.role() == "robot" || s.role() == "supervisor" || s.role() == "coordinator";
    if (rows != Rows::All && !run.empty() && launched && run.count(id) == 0 && (rows == Rows::Run || silent)) {
      ++gone;
      continue;
    }
    const char* state = runtime::lifecycle_name(s.state());
    if (s.role() == "world") {
      char progress[32] = "tasks from coordinator";
      if (s.progress() >= 0.0) std::snprintf(progress, sizeof progress, "task %5.1f%%", 100.0 * s.progress());
      std::fprintf(f, "  %-18s %-11s tick %6llu  %s  grasp margin %7.2f N  late %llu%s  arms %s%s%s\n", id.c_str(),
                   state, static_cast<unsigned long long>(s.tick()), progress, s.grasp_margin(),
                   static_cast<unsigned long long>(s.late()), where(s).c_str(), runtime::owners_text(s.owners()).c_str(),
                   s.detail().empty() ? "" : "  ",
                   s.detail().c_str());
    } else if (s.role() == "robot") {
      std::fprintf(f, "  %-18s %-11s tick %6llu  |e_p| %9.3e m  step %5.0f us  wear %7.3f rad  rejected %llu  pid %lld%s%s%s%s\n",
                   id.c_str(), state, static_cast<unsigned long long>(s.tick()), s.tracking_error(),
                   s.latency_p99_us(), s.wear(),
                   static_cast<unsigned long long>(s.late()), static_cast<long long>(s.pid()),
                   where(s).c_str(), standing(processes_, s), s.detail().empty() ? "" : "  ", s.detail().c_str());
    } else if (s.role() == "launcher") {
      const size_t n = s.runs().size();
      std::fprintf(f, "  %-18s %-11s pid %lld  runs %zu process(es)%s%s\n", id.c_str(), state,
                   static_cast<long long>(s.pid()), n, s.detail().empty() ? "" : "  ", s.detail().c_str());
    } else {
      std::fprintf(f, "  %-18s %-11s pid %lld%s%s%s%s%s\n", id.c_str(), state, static_cast<long long>(s.pid()),
                   where(s).c_str(), s.serving() == msg::ROLE_NONE ? "" : "  ", runtime::role_name(s.serving()), s.detail().empty() ? "" : "  ",
                   s.detail().c_str());
    }
  }
  if (gone > 0) std::fprintf(f, "  (%zu process(es) that exited and are not run any more: not shown)\n", gone);
}

}  // namespace tandem::cli
