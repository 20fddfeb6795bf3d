#include "live_view.hpp"

#include "tandem/runtime/status.hpp"

namespace tandem::cli {

void LiveView::print(std::FILE* f) const {
  for (const auto& [id, s] : processes_) {
    const char* state = runtime::lifecycle_name(s.state());
    if (s.role() == "world") {
      std::fprintf(f, "  %-18s %-11s tick %6llu  task %5.1f%%  grasp margin %7.2f N  late %llu%s%s\n", id.c_str(),
                   state, static_cast<unsigned long long>(s.tick()), 100.0 * s.progress(), s.grasp_margin(),
                   static_cast<unsigned long long>(s.late()), s.detail().empty() ? "" : "  ", s.detail().c_str());
    } else if (s.role() == "robot") {
      std::fprintf(f, "  %-18s %-11s tick %6llu  |e_p| %9.3e m  rejected %llu  pid %lld%s%s\n", id.c_str(), state,
                   static_cast<unsigned long long>(s.tick()), s.tracking_error(),
                   static_cast<unsigned long long>(s.late()), static_cast<long long>(s.pid()),
                   s.detail().empty() ? "" : "  ", s.detail().c_str());
    } else {
      std::fprintf(f, "  %-18s %-11s pid %lld%s%s\n", id.c_str(), state, static_cast<long long>(s.pid()),
                   s.detail().empty() ? "" : "  ", s.detail().c_str());
    }
  }
}

}  // namespace tandem::cli
