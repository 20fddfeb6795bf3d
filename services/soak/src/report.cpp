#include "tandem/soak/report.hpp"

#include "tandem/soak/nemesis.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "tandem/page/files.hpp"
#include "tandem/page/html.hpp"
#include "tandem/page/svg.hpp"

namespace tandem::soak {
using page::make_dirs;
using page::nice_ticks;
using page::Plot;
using page::RefLine;
using page::render_svg;
using page::Series;
using page::write_file;
using page::xml_escape;
namespace {

/// The summary's Markdown as HTML: headings, tables (a header row, the |---| row, body rows), list items and
/// paragraphs; inline `code` and **bold** are kept as text. Only the subset the summary writes.
std::string markdown_to_html(const std::string& md) {
  std::ostringstream out;
  std::istringstream in(md);
  std::string line;
  bool table = false, list = false, header = false;
  auto cells = [](const std::string& row) {
    std::vector<std::string> c;
    size_t a = row.find('|') + 1;
    for (size_t b = row.find('|', a); b != std::string::npos; a = b + 1, b = row.find('|', a)) {
      std::string x = row.substr(a, b - a);
      const size_t s0 = x.find_first_not_of(' '), s1 = x.find_last_not_of(' ');
      c.push_back(s0 == std::string::npos ? "" : x.substr(s0, s1 - s0 + 1));
    }
    return c;
  };
  auto close = [&] {
    if (table) out << "</table>\n";
    if (list) out << "</ul>\n";
    table = list = false;
  };
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '|') {
      if (line.find("---") != std::string::npos) continue;  // the separator row
      if (!table) {
        close();
        out << "<table>\n";
        table = true;
        header = true;
      }
      out << "<tr>";
      for (const std::string& c : cells(line)) out << (header ? "<th>" : "<td>") << xml_escape(c) << (header ? "</th>" : "</td>");
      out << "</tr>\n";
      header = false;
      continue;
    }
    if (line.rfind("- ", 0) == 0) {
      if (!list) {
        close();
        out << "<ul>\n";
        list = true;
      }
      out << "<li>" << xml_escape(line.substr(2)) << "</li>\n";
      continue;
    }
    close();
    if (line.rfind("### ", 0) == 0) {
      out << "<h3>" << xml_escape(line.substr(4)) << "</h3>\n";
    } else if (line.rfind("## ", 0) == 0) {
      out << "<h2>" << xml_escape(line.substr(3)) << "</h2>\n";
    } else if (!line.empty()) {
      out << "<p>" << xml_escape(line) << "</p>\n";
    }
  }
  close();
  return out.str();
}

std::string f2(double v, const char* f = "%.2f") {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::vector<RefLine> fault_markers(const History& h) {
  std::vector<RefLine> m;
  for (const FaultRecord& f : h.faults) {
    if (f.skipped) continue;
    m.push_back({f.t, "#" + std::to_string(f.fault.index) + " " + label(f.fault.kind, f.fault.target) + " " + f.label,
                 "#999999"});
  }
  return m;
}

struct KindStats {
  std::vector<double> s;
};

std::map<std::string, KindStats> recovery_stats(const Verdict& v) {
  std::map<std::string, KindStats> by;
  for (const Recovery& r : v.recoveries) by[r.kind].s.push_back(r.seconds);
  return by;
}

std::string plot_normal_force(const History& h) {
  Plot p;
  p.title = "Lowest normal force per second (each module), faults as grey lines";
  p.xlabel = "time [s]";
  p.ylabel = "min normal force [N]";
  double hmin = 1e300;
  for (const auto& [m, series] : h.modules) {
    Series s;
    s.name = m;
    double bucket = -1, lo = 1e300;
    for (const ModuleSample& x : series) {
      const double b = std::floor(x.t);
      if (b != bucket && bucket >= 0 && lo < 1e299) {
        s.xy.emplace_back(bucket + 0.5, lo);
        lo = 1e300;
      }
      if (b != bucket && bucket >= 0 && lo >= 1e299 && !s.xy.empty() && b - bucket > 1.5) {
        s.xy.emplace_back(bucket + 1.0, std::nan(""));  // a gap (the module was out)
      }
      bucket = b;
      if (static_cast<double>(x.tick) >= 1000.0) lo = std::min(lo, x.normal_min);
    }
    if (lo < 1e299) s.xy.emplace_back(bucket + 0.5, lo);
    p.series.push_back(std::move(s));
    const auto it = h.h_sg.find(m);
    if (it != h.h_sg.end()) hmin = std::min(hmin, it->second);
  }
  if (hmin < 1e299) p.hlines.push_back({hmin, "h_sg " + f2(hmin) + " N"});
  p.markers = fault_markers(h);
  return render_svg(p);
}

std::string plot_late(const History& h) {
  Plot p;
  p.title = "Late arm-ticks per second (each module)";
  p.xlabel = "time [s]";
  p.ylabel = h.realtime ? "late arm-ticks / s" : "lockstep timeouts / s";
  for (const auto& [m, series] : h.modules) {
    Series s;
    s.name = m;
    s.style = Series::Style::Step;
    double bucket = -1;
    uint64_t at_start = 0, last = 0;
    int world = -1;
    for (const ModuleSample& x : series) {
      const double b = std::floor(x.t);
      if (x.world != world) {
        world = x.world;
        at_start = 0;
        last = 0;
      }
      if (b != bucket) {
        if (bucket >= 0) s.xy.emplace_back(bucket, static_cast<double>(last - at_start));
        bucket = b;
        at_start = last;
      }
      last = std::max(last, x.late);
    }
    if (bucket >= 0) s.xy.emplace_back(bucket, static_cast<double>(last - at_start));
    p.series.push_back(std::move(s));
  }
  p.markers = fault_markers(h);
  return render_svg(p);
}

std::string plot_rss(const History& h) {
  Plot p;
  p.title = "Resident memory of the long-lived processes";
  p.xlabel = "time [s]";
  p.ylabel = "RSS [MiB]";
  std::map<std::string, Series> by;
  std::map<std::string, double> life;
  for (const RssSample& s : h.rss) {
    Series& x = by[s.label];
    x.name = s.label;
    if (!x.xy.empty() && s.t - x.xy.back().first > 5.0) x.xy.emplace_back(s.t - 0.01, std::nan(""));
    x.xy.emplace_back(s.t, s.mib);
  }
  for (auto& [k, s] : by) life[k] = s.xy.empty() ? 0 : s.xy.back().first - s.xy.front().first;
  std::vector<std::string> keys;
  keys.reserve(by.size());
  for (const auto& [k, s] : by) keys.push_back(k);
  std::sort(keys.begin(), keys.end(), [&](const std::string& a, const std::string& b) { return life[a] > life[b]; });
  for (size_t i = 0; i < keys.size() && i < 14; ++i) p.series.push_back(by[keys[i]]);
  p.ymin_hint = 0.0;
  p.ymax_hint = 1.0;
  return render_svg(p, 960, 380);
}

std::string plot_recovery(const Verdict& v, const Bounds& b) {
  (void)b;
  Plot p;
  p.title = "Recovery times by kind (each dot a fault; log scale)";
  p.ylabel = "seconds";
  p.log_y = true;
  const auto stats = recovery_stats(v);
  Series dots, p50;
  dots.name = "recovery";
  dots.style = Series::Style::Points;
  p50.name = "median";
  p50.style = Series::Style::Points;
  p50.color = "#d62728";
  int i = 0;
  for (const auto& [kind, st] : stats) {
    p.xcategories.push_back(kind);
    for (size_t k = 0; k < st.s.size(); ++k) {
      const double jitter = 0.3 * (static_cast<double>((k * 37) % 11) / 10.0 - 0.5);
      dots.xy.emplace_back(i + jitter, std::max(st.s[k], 1e-3));
    }
    p50.xy.emplace_back(i, std::max(percentile(st.s, 0.5), 1e-3));
    ++i;
  }
  p.series = {dots, p50};
  return render_svg(p, 1100, 520);
}

std::string plot_faults(const History& h) {
  Plot p;
  p.title = "Fault schedule as carried out";
  p.xlabel = "time [s]";
  std::map<std::string, int> row;
  for (const FaultRecord& f : h.faults) row.emplace(label(f.fault.kind, f.fault.target), 0);
  int i = 0;
  for (auto& [k, r] : row) {
    r = i++;
    p.ycategories.push_back(k);
  }
  Series done, skipped;
  done.name = "carried out";
  done.style = Series::Style::Points;
  skipped.name = "skipped (no target)";
  skipped.style = Series::Style::Points;
  skipped.color = "#bbbbbb";
  for (const FaultRecord& f : h.faults) {
    (f.skipped ? skipped : done).xy.emplace_back(f.t, row[label(f.fault.kind, f.fault.target)]);
  }
  p.series = {done, skipped};
  return render_svg(p, 960, 60 + 22 * std::max<int>(4, static_cast<int>(row.size())) + 60);
}

std::string plot_tasks(const History& h) {
  Plot p;
  p.title = "Tasks done (coordinator queue), faults as grey lines";
  p.xlabel = "time [s]";
  p.ylabel = "tasks done";
  Series s;
  s.name = "done";
  s.style = Series::Style::Step;
  s.xy.emplace_back(0.0, 0.0);
  int n = 0;
  for (const Event& e : h.events) {
    if (e.type == Event::Type::TaskDone) s.xy.emplace_back(e.t, ++n);
  }
  s.xy.emplace_back(h.stop_s, n);
  p.series = {s};
  p.markers = fault_markers(h);
  return render_svg(p);
}

}  // namespace

std::string summary_text(const RunInfo& info, const History& h, const Bounds& b, const Verdict& v) {
  std::ostringstream o;
  o << "# tandem soak of " << info.deployment << ": " << (v.ok() ? "PASS" : "FAIL") << "\n\n";
  o << "- command: `" << info.command << "`\n";
  o << "- deployment: " << info.deployment_file << " (" << info.modules << " module(s), " << info.timing << " timing)\n";
  o << "- faults: " << info.faults_source << ", seed " << info.seed << "\n";
  o << "- ran " << f2(h.stop_s, "%.1f") << " s of " << f2(h.duration_s, "%.1f") << " s planned (" << f2(info.wall_s, "%.1f")
    << " s wall with start and stop); " << info.processes_seen << " processes seen\n";
  o << "- machine: " << info.machine << "\n\n";
  o << "## Invariants\n\n| invariant | result | judged | what it means |\n|---|---|---:|---|\n";
  for (const InvariantResult& r : v.invariants) {
    o << "| " << r.name << " | " << (r.ok ? "held" : "**VIOLATED**") << " | " << r.checked << " | " << r.description << " |\n";
  }
  int incidents = 0;
  for (const auto& [m, n] : v.incidents) incidents += n;
  o << "\nObject incidents (buckets in which an object slipped or lost contact): " << incidents << ", slip events "
    << v.slip_events << ".\n";
  int carried = 0;
  for (const auto& [k, n] : v.faults_by_kind) carried += n;
  o << "\n## Faults\n\n" << carried << " carried out, " << v.skipped << " skipped (no live target within " << std::lround(Nemesis::kTargetWaitS) << " s of when due).\n\n";
  o << "| fault | count |\n|---|---:|\n";
  for (const auto& [k, n] : v.faults_by_kind) o << "| " << k << " | " << n << " |\n";
  o << "\n## Recovery times (measured from the recording)\n\n| recovery | n | p50 s | p99 s | max s |\n|---|---:|---:|---:|---:|\n";
  for (const auto& [kind, st] : recovery_stats(v)) {
    o << "| " << kind << " | " << st.s.size() << " | " << f2(percentile(st.s, 0.5), "%.3f") << " | "
      << f2(percentile(st.s, 0.99), "%.3f") << " | " << f2(percentile(st.s, 1.0), "%.3f") << " |\n";
  }
  if (!v.left_to_governor.empty()) {
    o << "\nNot judged, left to the governor (the fault's module was parked for load before its recovery was due):";
    const char* sep = " ";
    for (const auto& [kind, n] : v.left_to_governor) {
      o << sep << kind << " " << n;
      sep = ", ";
    }
    o << ".\n";
  }
  o << "\nBounds: arm served again " << b.failover_s << " s (with a standby" << (h.realtime ? "" : ", in module time") << "; else " << b.restart_s
    << " s), replacement robot " << b.restart_s << " s, supervisor " << b.supervisor_s << " s, coordinator "
    << b.coordinator_s << " s (" << b.coordinator_cold_s << " s with no standby), module back " << b.module_back_s << " s after it is plugged in, task re-planned "
    << b.replan_s << " s, stalled process heard again " << b.stall_extra_s << " s after its stall, no module paused for load "
    << b.hog_s << " s after a hog; memory slope " << b.rss_slope_mib_per_min << " MiB/min.\n";
  o << "\n## Violations\n\n";
  if (v.violations.empty()) o << "None.\n";
  for (size_t i = 0; i < v.violations.size() && i < 200; ++i) {
    const Violation& x = v.violations[i];
    o << "- " << f2(x.t, "%.2f") << " s, " << x.invariant << (x.fault ? ", after fault #" + std::to_string(x.fault) : "")
      << ": " << x.text << "\n";
  }
  if (v.violations.size() > 200) o << "- ... and " << v.violations.size() - 200 << " more\n";
  o << "\n## Tasks\n\n" << h.tasks_done.size() << " done";
  std::set<std::string> unique(h.tasks_done.begin(), h.tasks_done.end());
  o << " (" << unique.size() << " distinct), " << h.tasks_running.size() << " running at the stop.\n";
  std::map<std::string, int> by_module;
  for (const auto& m : h.tasks_done_by) ++by_module[m];
  for (const auto& [m, n] : by_module) o << "- " << m << ": " << n << "\n";
  o << "\n## Modules parked for load\n\n";
  int parks = 0;
  for (const Event& e : h.events) {
    if (e.type != Event::Type::Parked && e.type != Event::Type::Unparked) continue;
    ++parks;
    o << "- " << f2(e.t, "%.1f") << " s: " << e.subject << (e.type == Event::Type::Parked ? " parked (" : " back (") << e.text
      << ")\n";
  }
  if (parks == 0) o << "None: the load always fitted, or passed within the governor's window (docs/failure-model.md).\n";
  // (A module parked at start-up shows as parked at the time the soak first read the launcher's log.)
  o << "\n## Memory (anonymous resident memory slope over the later half of each process's life, at most its last half "
       "hour, processes that lived " << b.rss_min_life_s
    << " s or more)\n\n";
  o << "| process | worst slope MiB/min |\n|---|---:|\n";
  std::vector<std::pair<double, std::string>> slopes;
  for (const auto& [k, s] : v.rss_slope) slopes.emplace_back(s, k);
  std::sort(slopes.rbegin(), slopes.rend());
  for (size_t i = 0; i < slopes.size() && i < 12; ++i) o << "| " << slopes[i].second << " | " << f2(slopes[i].first, "%.3f") << " |\n";
  o << "\n## Busiest processes (share of one core over the last 2 minutes of each process that lived that long, "
       "beside its first 2 minutes)\n\n";
  o << "| process | pid | last 2 min | first 2 min |\n|---|---:|---:|---:|\n";
  const std::vector<CpuShare> cpu = cpu_shares(h.rss, 120.0);
  if (cpu.empty()) o << "| (no process lived two minutes) | | | |\n";
  for (size_t i = 0; i < cpu.size() && i < 8; ++i) {
    o << "| " << cpu[i].label << " | " << cpu[i].pid << " | " << f2(100.0 * cpu[i].share, "%.0f") << "% | "
      << f2(100.0 * cpu[i].first_share, "%.0f") << "% |\n";
  }
  o << "\n## Plots\n\n";
  for (const char* f : {"faults", "normal_force", "late_ticks", "tasks", "recovery", "rss"}) {
    o << "![" << f << "](" << f << ".svg)\n\n";
  }
  return o.str();
}

std::vector<CpuShare> cpu_shares(const std::vector<RssSample>& samples, double window_s) {
  std::map<std::pair<std::string, long long>, std::vector<const RssSample*>> by;
  for (const RssSample& s : samples) {
    if (s.cpu_s >= 0.0) by[{s.label, s.pid}].push_back(&s);
  }
  auto share = [](const RssSample* a, const RssSample* b) { return b->t > a->t ? (b->cpu_s - a->cpu_s) / (b->t - a->t) : 0.0; };
  std::vector<CpuShare> out;
  for (const auto& [key, v] : by) {
    if (v.back()->t - v.front()->t < window_s) continue;
    const auto from_end = std::lower_bound(v.begin(), v.end(), v.back()->t - window_s,
                                           [](const RssSample* s, double t) { return s->t < t; });
    const auto to_start = std::lower_bound(v.begin(), v.end(), v.front()->t + window_s,
                                           [](const RssSample* s, double t) { return s->t < t; });
    out.push_back({key.first, key.second, share(*from_end, v.back()), share(v.front(), *to_start)});
  }
  std::sort(out.begin(), out.end(), [](const CpuShare& a, const CpuShare& b) { return a.share > b.share; });
  return out;
}

std::string write_report(const std::string& dir, const RunInfo& info, const History& h, const Bounds& b,
                         const Verdict& v) {
  ::mkdir(dir.c_str(), 0755);
  const std::string md = summary_text(info, h, b, v);
  write_file(dir + "/summary.md", md);
  write_file(dir + "/faults.svg", plot_faults(h));
  write_file(dir + "/normal_force.svg", plot_normal_force(h));
  write_file(dir + "/late_ticks.svg", plot_late(h));
  write_file(dir + "/tasks.svg", plot_tasks(h));
  write_file(dir + "/recovery.svg", plot_recovery(v, b));
  write_file(dir + "/rss.svg", plot_rss(h));
  // Machine-readable: key=value, one per line.
  std::ostringstream kv;
  kv << "result=" << (v.ok() ? "pass" : "fail") << "\nseed=" << info.seed << "\nduration_s=" << h.duration_s
     << "\nviolations=" << v.violations.size() << "\nskipped=" << v.skipped << "\n";
  for (const InvariantResult& r : v.invariants) {
    std::string k = r.name;
    std::replace(k.begin(), k.end(), ' ', '_');
    kv << "invariant." << k << "=" << (r.ok ? "held" : "violated") << "\n";
  }
  int carried = 0;
  for (const auto& [k, n] : v.faults_by_kind) {
    std::string key = k;
    std::replace(key.begin(), key.end(), ' ', '_');
    kv << "faults." << key << "=" << n << "\n";
    carried += n;
  }
  kv << "faults=" << carried << "\n";
  for (const auto& [kind, st] : recovery_stats(v)) {
    std::string key = kind;
    for (char& c : key) {
      if (c == ' ' || c == ':') c = '_';
    }
    kv << "recovery." << key << ".n=" << st.s.size() << "\nrecovery." << key << ".p50_s=" << percentile(st.s, 0.5)
       << "\nrecovery." << key << ".p99_s=" << percentile(st.s, 0.99) << "\nrecovery." << key
       << ".max_s=" << percentile(st.s, 1.0) << "\n";
  }
  for (const auto& [kind, n] : v.left_to_governor) {
    std::string key = kind;
    for (char& c : key) {
      if (c == ' ' || c == ':') c = '_';
    }
    kv << "left_to_governor." << key << "=" << n << "\n";
  }
  for (const Violation& x : v.violations) {
    kv << "violation=" << x.t << "|" << x.invariant << "|" << x.fault << "|" << x.text << "\n";
  }
  kv << "tasks_done=" << h.tasks_done.size() << "\n";
  write_file(dir + "/summary.txt", kv.str());
  // The recording itself (not needed to read the report; for a closer look or another checker).
  std::ostringstream rss, mod, ev, fl;
  rss << "t,process,pid,rss_mib,cpu_s\n";
  for (const RssSample& s : h.rss) rss << s.t << "," << s.label << "," << s.pid << "," << s.mib << "," << s.cpu_s << "\n";
  mod << "t,module,world,tick,normal_min,slips,contact_lost,late,failovers,braked,hold,load_paused,released\n";
  for (const auto& [m, series] : h.modules) {
    for (const ModuleSample& s : series) {
      mod << s.t << "," << m << "," << s.world << "," << s.tick << "," << s.normal_min << "," << s.slips << ","
          << s.contact_lost << "," << s.late << "," << s.failovers << "," << s.braked << "," << s.hold << ","
          << s.load_paused << "," << s.released << "\n";
    }
  }
  ev << "t,type,subject,text,tick\n";  // tick: the world's, for owners (-1 otherwise)
  for (const Event& e : h.events) {
    ev << e.t << "," << name(e.type) << "," << e.subject << ",\"" << e.text << "\"," << e.tick << "\n";
  }
  fl << "index,t,kind,target,label,pid,duration_s,end_t,skipped,had_standby,note,module_tick\n";
  for (const FaultRecord& f : h.faults) {
    fl << f.fault.index << "," << f.t << "," << name(f.fault.kind) << "," << name(f.fault.target) << "," << f.label << ","
       << f.pid << "," << f.fault.duration_s << "," << f.end_t << "," << f.skipped << "," << f.had_standby << ",\""
       << f.note << "\"," << f.module_tick << "\n";
  }
  write_file(dir + "/rss.csv", rss.str());
  write_file(dir + "/modules.csv", mod.str());
  write_file(dir + "/events.csv", ev.str());
  write_file(dir + "/faults.csv", fl.str());
  // index.html: the summary with the plots inline.
  std::ostringstream html;
  // In the pages' visual language (services/page/style.css, as the live view and the recording's report).
  html << page::html_head("tandem soak " + info.deployment)
       << page::header_bar("tandem soak of " + info.deployment,
                           v.ok() ? "<span class=\"verdict ok\">PASS</span>" : "<span class=\"verdict bad\">FAIL</span>");
  html << "<main><section>\n"
       << markdown_to_html(md.substr(md.find('\n') + 1, md.find("## Plots") - md.find('\n') - 1))
       << "</section>\n<section><h2>Plots</h2>\n";
  for (const char* f : {"faults", "normal_force", "late_ticks", "tasks", "recovery", "rss"}) {
    html << "<p><img src=\"" << f << ".svg\" alt=\"" << f << "\"></p>\n";
  }
  html << "</section></main></body></html>\n";
  write_file(dir + "/index.html", html.str());
  return dir + "/summary.md";
}

}  // namespace tandem::soak
