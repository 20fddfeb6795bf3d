// tandem report: reads a recording (tandem record, tandem sim --mcap) and writes an HTML page with plots.
#include "report_command.hpp"

#include <string>

#include "tandem/record/report.hpp"
#include "tandem/runtime/args.hpp"

namespace tandem::cli {

namespace {
std::string fmt_e(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6e", v);
  return b;
}
}  // namespace

namespace {

struct ReportArgs {
  std::string in, dir;
  bool salvage = false;
};

/// The command line, on CLI11 (runtime::parse_args): `tandem help report` prints the same text as --help.
void describe(CLI::App& app, ReportArgs& o) {
  app.description(
      "Writes DIR/index.html with SVG plots of a recording, and DIR/summary.txt with the figures recomputed\n"
      "from the recorded samples (key=value):\n"
      "  - per robot: tracking error |x_d - x| and normal force against h_sg over time, failovers and takeovers\n"
      "    marked; RMS from the recording beside the robot's own summary;\n"
      "  - per module: task progress, tasks done, pauses and brakes, late arm-ticks per second and the\n"
      "    sample->command latency p99 over time;\n"
      "  - for `tandem sim --mcap` recordings: the paper's figures (Cartesian errors, force error, sliding\n"
      "    variables, normal force) for every case side by side.");
  app.add_option("recording", o.in, "the recording (tandem record, tandem sim --mcap)")->required()->type_name("RUN.mcap");
  app.add_option("-o,--out", o.dir, "the report's directory")->required()->type_name("DIR");
  app.add_flag("--salvage", o.salvage,
               "a corrupt or truncated file is refused with the byte offset and what was wrong; with this, report\n"
               "what came before the damage (every intact chunk) and say so on the page");
  app.footer("Exit: 0 written, 1 the recording is unreadable or DIR cannot be written, 2 bad command line.");
}

}  // namespace

void report_usage(std::FILE* f) {
  ReportArgs o;
  CLI::App app("", "tandem report");
  describe(app, o);
  std::fputs(app.help().c_str(), f);
}

int report_command(const std::vector<std::string>& args) {
  ReportArgs o;
  CLI::App app("", "tandem report");
  describe(app, o);
  if (const int code = runtime::parse_args(app, args); code >= 0) return code;
  const std::string& in = o.in;
  const std::string& dir = o.dir;
  const bool salvage = o.salvage;
  try {
    const record::ReportResult r = record::write_recording_report(in, dir, salvage);
    if (r.salvaged) std::printf("tandem report: warning: %s\n  reported what came before the damage\n", r.damage.c_str());
    std::printf("tandem report: %s (%zu plots, %llu messages)\n", r.index.c_str(), r.images.size(),
                static_cast<unsigned long long>(r.messages));
    for (const auto& rb : r.robots) {
      std::printf("  %-14s %7llu ticks  e_p RMS %.6e m (its summary: %s)  e_h RMS %.4f N  min h_n %.2f N\n",
                  rb.robot_id.c_str(), static_cast<unsigned long long>(rb.ticks), rb.ep_pos_rms,
                  rb.has_summary ? fmt_e(rb.summary_ep_pos_rms).c_str() : "not recorded", rb.eh_rms,
                  rb.min_normal_force);
    }
    for (const auto& c : r.cases) {
      std::printf("  case %-22s %6llu ticks  e_p RMS right %.3e m  e_h RMS right %.3f N\n", c.name.c_str(),
                  static_cast<unsigned long long>(c.ticks), c.ep_pos_rms[1], c.eh_rms[1]);
    }
  } catch (const record::McapError& e) {
    std::fprintf(stderr, "tandem report: %s\n", e.what());
    const std::string what = e.what();
    if (!salvage && (what.find("truncated") != std::string::npos || what.find("corrupt") != std::string::npos ||
                     what.find("ends at byte") != std::string::npos)) {
      std::fprintf(stderr, "  (--salvage reports what came before the damage)\n");
    }
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem report: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace tandem::cli
