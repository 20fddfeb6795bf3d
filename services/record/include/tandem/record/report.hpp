// The report of a recording (tandem report): decodes an MCAP file written by `tandem record` or `tandem sim
// --mcap` and writes an HTML page with SVG plots (soak::render_svg) and the figures recomputed from the
// recorded samples (docs/recording.md, "Report").
#pragma once

#include <map>
#include <string>
#include <vector>

#include "tandem/record/mcap.hpp"

namespace tandem::record {

/// Per robot of a distributed run: what its recorded torque commands say (one per tick, repeats dropped).
struct RobotFigures {
  std::string robot_id;   ///< "m1/left", "m1/left@50"
  std::string arm;        ///< "m1/left"
  int strength = 0;
  uint64_t ticks = 0;     ///< distinct ticks commanded
  uint64_t first_tick = 0, last_tick = 0;
  double ep_pos_rms = 0.0, ep_ori_rms = 0.0, eh_rms = 0.0, min_normal_force = 0.0;
  bool has_summary = false;  ///< the robot's own RobotSummary was recorded too
  double summary_ep_pos_rms = 0.0, summary_eh_rms = 0.0;
  uint64_t summary_ticks = 0;
};

/// Per case of a `tandem sim` recording.
struct SimCaseFigures {
  std::string name;
  uint64_t ticks = 0;
  double h_sg = 0.0;
  double ep_pos_rms[2] = {0.0, 0.0}, eh_rms[2] = {0.0, 0.0}, min_normal_force[2] = {0.0, 0.0};
};

struct ReportResult {
  std::string index;  ///< path of index.html
  std::vector<std::string> images;
  std::vector<RobotFigures> robots;
  std::vector<SimCaseFigures> cases;
  std::map<std::string, uint64_t> sensor_ticks;  ///< arm -> sensor samples recorded (distinct ticks)
  uint64_t messages = 0;
  bool salvaged = false;
  std::string damage;
};

/// Reads `mcap` and writes `dir`/index.html, the SVG plots and summary.txt (key=value). Throws McapError for a
/// file that is not a readable recording (unless `salvage`), std::runtime_error if `dir` cannot be written.
ReportResult write_recording_report(const std::string& mcap, const std::string& dir, bool salvage = false);

}  // namespace tandem::record
