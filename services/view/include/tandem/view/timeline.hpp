// The page's data over a whole recording (`tandem view run.mcap`): built in one pass through the file with
// the same view::LiveState the live view uses, so a recorded run reads like a live one. Kept: a state
// snapshot every second of log time, every (decimated) plot point, every event. at(t) gives what the page
// shows at time t.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tandem/view/live_state.hpp"

namespace tandem::view {

class Timeline {
 public:
  /// Reads `path` (a tandem recording: tandem record or tandem up --record); throws record::McapError or
  /// std::runtime_error naming what is wrong. The modules' h_sg come from the recording's metadata.
  static Timeline from_recording(const std::string& path);

  double start_s() const { return start_s_; }
  double end_s() const { return end_s_; }
  /// {"t", "state": the newest snapshot at or before t, "points": the last `window_s` before t, "events": the
  /// newest 200 at or before t}.
  std::string at(double t_s, double window_s = 30.0) const;
  /// {"start", "end", "deployment", "messages", "points", "events", "snapshots"}.
  std::string summary() const;

  size_t snapshots() const { return states_.size(); }
  size_t points() const { return points_.size(); }
  size_t events() const { return events_.size(); }

 private:
  double start_s_ = 0.0, end_s_ = 0.0;
  std::string deployment_;
  uint64_t messages_ = 0;
  std::vector<std::pair<double, std::string>> states_;  ///< (t, state JSON), t ascending
  std::vector<PlotPoint> points_;                       ///< t ascending
  std::vector<std::pair<double, std::string>> events_;  ///< (t, event JSON), t ascending
};

}  // namespace tandem::view
