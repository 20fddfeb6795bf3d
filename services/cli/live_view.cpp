#include "live_view.hpp"

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
}  // namespace

void LiveView::print(std::FILE* f) const {
  for (const auto& [id, s] : processes_) {
    const char* state = runtime::lifecycle_name(s.state());
    if (s.role() == "world") {
      char progress[32] = "tasks from coordinator";
      if (s.progress() >= 0.0) std::snprintf(progress, sizeof progress, "task %5.1f%%", 100.0 * s.progress());
      std::fprintf(f, "  %-18s %-11s tick %6llu  %s  grasp margin %7.2f N  late %llu  arms %s%s%s\n", id.c_str(),
                   state, static_cast<unsigned long long>(s.tick()), progress, s.grasp_margin(),
                   static_cast<unsigned long long>(s.late()), s.serving().c_str(), s.detail().empty() ? "" : "  ",
                   s.detail().c_str());
    } else if (s.role() == "robot") {
      std::fprintf(f, "  %-18s %-11s tick %6llu  |e_p| %9.3e m  step %5.0f us  wear %7.3f rad  rejected %llu  pid %lld%s%s%s\n",
                   id.c_str(), state, static_cast<unsigned long long>(s.tick()), s.tracking_error(),
                   s.latency_p99_us(), s.wear(),
                   static_cast<unsigned long long>(s.late()), static_cast<long long>(s.pid()),
                   standing(processes_, s), s.detail().empty() ? "" : "  ", s.detail().c_str());
    } else {
      std::fprintf(f, "  %-18s %-11s pid %lld%s%s%s%s\n", id.c_str(), state, static_cast<long long>(s.pid()),
                   s.serving().empty() ? "" : "  ", s.serving().c_str(), s.detail().empty() ? "" : "  ",
                   s.detail().c_str());
    }
  }
}

}  // namespace tandem::cli
