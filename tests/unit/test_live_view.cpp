// The launcher's and `tandem status`'s process table (services/cli/live_view.cpp): a killed process's last status
// (transient-local: it still says "active") is left out once its launcher no longer runs it, and counted.
#include <catch2/catch.hpp>

#include <cstdio>
#include <string>

#include "live_view.hpp"

using tandem::cli::LiveView;

namespace {

tandem::msg::ProcessStatus status(const std::string& id, const std::string& role, std::vector<std::string> runs = {}) {
  tandem::msg::ProcessStatus s;
  s.process_id(id);
  s.deployment("d");
  s.role(role);
  s.module_id("m1");
  s.state(2);  // active
  s.runs(std::move(runs));
  return s;
}

std::string printed(const LiveView& v, LiveView::Rows rows, std::chrono::steady_clock::time_point now) {
  char* buf = nullptr;
  size_t n = 0;
  std::FILE* f = open_memstream(&buf, &n);
  v.print(f, rows, now);
  std::fclose(f);
  std::string out(buf, n);
  std::free(buf);
  return out;
}

}  // namespace

TEST_CASE("the process table leaves out a killed process that the launcher no longer runs, and counts it", "[live_view]") {
  using std::chrono::seconds;
  const auto t0 = std::chrono::steady_clock::time_point{} + seconds(100);
  LiveView v("d");
  v.update(status("m1/left", "robot"), t0);       // killed at t0: its last status says active
  v.update(status("m1/left@49", "robot"), t0);    // its restart
  v.update(status("other/x", "robot"), t0);       // another deployment's: never shown
  v.update([] { auto s = status("other/x", "robot"); s.deployment("other"); return s; }(), t0);
  // Without a launcher heard, nothing is left out.
  CHECK(printed(v, LiveView::Rows::Run, t0).find("m1/left   ") != std::string::npos);
  v.update(status("launcher", "launcher", {"m1/left@49", "other/x"}), t0 + seconds(3));
  v.update(status("agent/b", "agent"), t0);  // not a process the launcher starts: always shown
  v.update(status("m1/left@49", "robot"), t0 + seconds(3));
  // The launcher's own table: gone after kGoneAfter without a status.
  const std::string recent_early = printed(v, LiveView::Rows::Recent, t0 + seconds(1));
  CHECK(recent_early.find("  m1/left ") != std::string::npos);
  const std::string recent = printed(v, LiveView::Rows::Recent, t0 + seconds(3));
  CHECK(recent.find("  m1/left ") == std::string::npos);
  CHECK(recent.find("m1/left@49") != std::string::npos);
  CHECK(recent.find("(1 process(es) that exited and are not run any more: not shown)") != std::string::npos);
  // `tandem status`: at once (its statuses all arrive together when it joins).
  const std::string run = printed(v, LiveView::Rows::Run, t0);
  CHECK(run.find("  m1/left ") == std::string::npos);
  CHECK(run.find("agent/b") != std::string::npos);
  CHECK(run.find("m1/left@49") != std::string::npos);
  // The final table shows every process heard.
  const std::string all = printed(v, LiveView::Rows::All, t0 + seconds(60));
  CHECK(all.find("  m1/left ") != std::string::npos);
  CHECK(all.find("not shown") == std::string::npos);
}
