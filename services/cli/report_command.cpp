// tandem report: reads a recording (tandem record, tandem sim --mcap) and writes an HTML page with plots.
#include "report_command.hpp"

#include <string>

#include "tandem/record/report.hpp"

namespace tandem::cli {

namespace {
std::string fmt_e(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6e", v);
  return b;
}
}  // namespace

void report_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem report <run.mcap> -o DIR [--salvage]\n"
      "\n"
      "Writes DIR/index.html with SVG plots of a recording, and DIR/summary.txt with the figures recomputed\n"
      "from the recorded samples (key=value):\n"
      "  - per robot: tracking error |x_d - x| and normal force against h_sg over time, failovers and takeovers\n"
      "    marked; RMS from the recording beside the robot's own summary;\n"
      "  - per module: task progress, tasks done, pauses and brakes, late arm-ticks per second and the\n"
      "    sample->command latency p99 over time;\n"
      "  - for `tandem sim --mcap` recordings: the paper's figures (Cartesian errors, force error, sliding\n"
      "    variables, normal force) for every case side by side.\n"
      "A corrupt or truncated file is refused with the byte offset and what was wrong; --salvage reports what\n"
      "came before the damage (every intact chunk) and says so on the page.\n"
      "Exit: 0 written, 1 the recording is unreadable or DIR cannot be written, 2 bad command line.\n",
      f);
}

int report_command(const std::vector<std::string>& args) {
  std::string in, dir;
  bool salvage = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      report_usage(stdout);
      return 0;
    } else if (a == "-o" || a == "--out") {
      if (i + 1 >= args.size()) {
        std::fprintf(stderr, "tandem report: %s needs a directory\n", a.c_str());
        return 2;
      }
      dir = args[++i];
    } else if (a == "--salvage") {
      salvage = true;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "tandem report: unknown option '%s' (see 'tandem help report')\n", a.c_str());
      return 2;
    } else if (in.empty()) {
      in = a;
    } else {
      std::fprintf(stderr, "tandem report: one recording expected, got '%s' too\n", a.c_str());
      return 2;
    }
  }
  if (in.empty() || dir.empty()) {
    std::fprintf(stderr, "tandem report: %s\n\n", in.empty() ? "missing the recording (run.mcap)" : "missing -o DIR");
    report_usage(stderr);
    return 2;
  }
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
