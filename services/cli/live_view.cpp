#include "live_view.hpp"

#include <algorithm>

#include "tandem/runtime/status.hpp"

namespace tandem::cli {

namespace {
// Whether robot `id` is the one its arm follows, from the world's "left=m1/left@50,right=m1/right".
const char* standing(const std::map<std::string, msg::ProcessStatus>& all, const msg::ProcessStatus& robot) {
  const auto w = all.find(robot.module_id() + "/world");
  if (w == all.end() || w->second.serving().empty() || robot.state() >= 3) return "";
  const std::string serving = "," + w->second.serving() + ",";
  return serving.find("=" + robot.process_id() + ",") != std::string::npos ? "  SERVING" : "  standby";
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
    // The launcher's `serving` lists the labels of the processes it runs, comma-separated.
    size_t from = 0;
    const std::string& list = s.serving();
    while (from < list.size()) {
      size_t to = list.find(',', from);
      if (to == std::string::npos) to = list.size();
      const std::string label = list.substr(from, to - from);
      if (!label.empty() && processes_.count(label) == 0) out.push_back(label);
      from = to + 1;
    }
  }
  return out;
}

void LiveView::print(std::FILE* f) const {
  for (const auto& [id, s] : processes_) {
    const char* state = runtime::lifecycle_name(s.state());
    if (s.role() == "world") {
      char progress[32] = "tasks from coordinator";
      if (s.progress() >= 0.0) std::snprintf(progress, sizeof progress, "task %5.1f%%", 100.0 * s.progress());
      std::fprintf(f, "  %-18s %-11s tick %6llu  %s  grasp margin %7.2f N  late %llu%s  arms %s%s%s\n", id.c_str(),
                   state, static_cast<unsigned long long>(s.tick()), progress, s.grasp_margin(),
                   static_cast<unsigned long long>(s.late()), where(s).c_str(), s.serving().c_str(),
                   s.detail().empty() ? "" : "  ",
                   s.detail().c_str());
    } else if (s.role() == "robot") {
      std::fprintf(f, "  %-18s %-11s tick %6llu  |e_p| %9.3e m  step %5.0f us  wear %7.3f rad  rejected %llu  pid %lld%s%s%s%s\n",
                   id.c_str(), state, static_cast<unsigned long long>(s.tick()), s.tracking_error(),
                   s.latency_p99_us(), s.wear(),
                   static_cast<unsigned long long>(s.late()), static_cast<long long>(s.pid()),
                   where(s).c_str(), standing(processes_, s), s.detail().empty() ? "" : "  ", s.detail().c_str());
    } else if (s.role() == "launcher") {
      const size_t n = s.serving().empty() ? 0 : 1 + static_cast<size_t>(std::count(s.serving().begin(), s.serving().end(), ','));
      std::fprintf(f, "  %-18s %-11s pid %lld  runs %zu process(es)%s%s\n", id.c_str(), state,
                   static_cast<long long>(s.pid()), n, s.detail().empty() ? "" : "  ", s.detail().c_str());
    } else {
      std::fprintf(f, "  %-18s %-11s pid %lld%s%s%s%s%s\n", id.c_str(), state, static_cast<long long>(s.pid()),
                   where(s).c_str(), s.serving().empty() ? "" : "  ", s.serving().c_str(), s.detail().empty() ? "" : "  ",
                   s.detail().c_str());
    }
  }
}

}  // namespace tandem::cli
