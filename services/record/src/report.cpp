#include "tandem/record/report.hpp"

#include <sys/stat.h>
#include <tandem_record.pb.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "tandem/page/files.hpp"
#include "tandem/page/html.hpp"
#include "tandem/page/svg.hpp"

namespace tandem::record {
namespace {

using page::Plot;
using page::RefLine;
using page::Series;
using page::write_file;
using page::xml_escape;

std::string fmt(double v, const char* f = "%.4g") {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

void make_dirs(const std::string& dir) {
  if (!page::make_dirs(dir)) throw std::runtime_error("cannot create the directory " + dir);
}

/// Keeps a plot readable and its file small: at most ~n points, per bucket the extreme (max, or min with
/// keep_min) so that no spike disappears.
std::vector<std::pair<double, double>> decimate(const std::vector<std::pair<double, double>>& xy, size_t n = 1500,
                                                bool keep_min = false) {
  if (xy.size() <= n) return xy;
  std::vector<std::pair<double, double>> out;
  const size_t per = (xy.size() + n - 1) / n;
  for (size_t i = 0; i < xy.size(); i += per) {
    std::pair<double, double> best = xy[i];
    for (size_t k = i; k < std::min(xy.size(), i + per); ++k) {
      if (keep_min ? xy[k].second < best.second : xy[k].second > best.second) best = xy[k];
    }
    out.push_back(best);
  }
  return out;
}

struct Rms {
  double sum = 0.0;
  uint64_t n = 0;
  void add(double v) {
    sum += v * v;
    ++n;
  }
  double value() const { return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0; }
};

// What the recording holds, gathered in one pass.
struct RobotTrace {
  std::string arm;
  int strength = 0;
  long long last = -1;
  uint64_t first = 0, ticks = 0;
  Rms pos, ori, eh;
  double min_n = 1e300;
  std::vector<std::pair<double, double>> ep, hn;  // (t, |e_p xy|), (t, h_n)
};
struct ModuleTrace {
  std::vector<std::pair<double, double>> progress, latency, late_rate, tasks_done, normal_min;
  double last_late_t = -1.0;
  uint64_t last_late = 0;
  struct Mark {
    double wall;     // wall time since the recording began [s]
    uint64_t tick;   // the world tick it refers to (0: unknown)
    std::string label;
  };
  std::vector<Mark> marks;
  std::vector<std::pair<double, double>> paused;      // (t, 0/1)
};
struct SimCase {
  SimCaseFigures fig;
  std::vector<std::pair<double, double>> e[2][3], eh[2], s[2][3], hn[2];
  Rms pos[2], ehr[2];
  double min_n[2] = {1e300, 1e300};
};

std::string module_of(const std::string& id) { return id.substr(0, id.find('/')); }
std::string last_part(const std::string& topic, const char* base) {
  const std::string b = std::string(base) + "/";
  return topic.rfind(b, 0) == 0 ? topic.substr(b.size()) : topic;
}

std::string svg_name(std::string s) {
  for (char& c : s) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) c = '_';
  }
  return s;
}

}  // namespace

ReportResult write_recording_report(const std::string& mcap, const std::string& dir, bool salvage) {
  std::map<std::string, RobotTrace> robots;     // robot id -> trace
  std::map<std::string, ModuleTrace> modules;
  std::map<std::string, SimCase> cases;
  std::vector<std::string> case_order;
  std::map<std::string, std::set<uint64_t>> sensor_ticks;
  std::map<std::string, tandem::record::RobotSummary> robot_sums;
  std::map<std::string, tandem::record::WorldSummary> world_sums;
  std::vector<std::pair<double, tandem::record::Event>> events;
  uint64_t t0 = 0;
  bool have_t0 = false;
  ReportResult res;

  tandem::record::TorqueCommand cmd;
  tandem::record::ArmSensors sen;
  tandem::record::ProcessStatus st;
  tandem::record::SimSample sim;
  McapInfo info = read_mcap(
      mcap,
      [&](const McapMessageView& v) {
        if (!have_t0) {
          t0 = v.log_time;
          have_t0 = true;
        }
        const double wall = static_cast<double>(static_cast<int64_t>(v.log_time - t0)) * 1e-9;
        const std::string& topic = v.channel->topic;
        const auto parse = [&](google::protobuf::Message& m) {
          if (!m.ParseFromArray(v.data, static_cast<int>(v.size))) {
            throw McapError(mcap + ": a message on " + topic + " (sequence " + std::to_string(v.sequence) +
                            ") does not decode as " + m.GetTypeName());
          }
        };
        if (topic.rfind("tandem/torque_commands/", 0) == 0) {
          parse(cmd);
          const std::string arm = last_part(topic, "tandem/torque_commands");
          const std::string id = cmd.strength() == 100 ? arm : arm + "@" + std::to_string(cmd.strength());
          RobotTrace& r = robots[id];
          r.arm = arm;
          r.strength = cmd.strength();
          const auto k = static_cast<long long>(cmd.tick());
          if (k <= r.last || cmd.leaving() || cmd.e_p_size() < 3) return;  // a repeat (lockstep asks again), the last word
          if (r.ticks == 0) r.first = cmd.tick();
          r.last = k;
          ++r.ticks;
          const double e = std::hypot(cmd.e_p(0), cmd.e_p(1));
          r.pos.add(e);
          r.ori.add(cmd.e_p(2));
          r.eh.add(cmd.e_h());
          r.min_n = std::min(r.min_n, cmd.normal_force());
          // Time as tick x 1 ms here; rescaled with the module's period (metadata, read last) below.
          r.ep.emplace_back(static_cast<double>(k) * 1e-3, e);
          r.hn.emplace_back(static_cast<double>(k) * 1e-3, cmd.normal_force());
        } else if (topic.rfind("tandem/arm_sensors/", 0) == 0) {
          parse(sen);
          sensor_ticks[last_part(topic, "tandem/arm_sensors")].insert(sen.tick());
        } else if (topic == "tandem/process_status") {
          parse(st);
          if (st.role() != "world") return;
          ModuleTrace& m = modules[st.module_id()];
          if (st.progress() >= 0.0) m.progress.emplace_back(wall, st.progress());  // -1: tasks from a coordinator
          if (st.latency_p99_us() > 0) m.latency.emplace_back(wall, st.latency_p99_us());
          if (m.last_late_t >= 0 && wall > m.last_late_t + 0.05) {
            const double d = st.late() >= m.last_late ? static_cast<double>(st.late() - m.last_late) : 0.0;
            m.late_rate.emplace_back(wall, d / (wall - m.last_late_t));
          }
          m.last_late_t = wall;
          m.last_late = st.late();
        } else if (topic.rfind("tandem/world_report/", 0) == 0) {
          tandem::record::WorldReport wr;
          parse(wr);
          ModuleTrace& m = modules[wr.module_id()];
          const bool paused = wr.load_paused() || wr.hold() || (wr.braked_size() == 2 && (wr.braked(0) || wr.braked(1)));
          if (m.paused.empty() || (m.paused.back().second > 0.5) != paused) m.paused.emplace_back(wall, paused ? 1.0 : 0.0);
          m.normal_min.emplace_back(wall, wr.normal_min());
        } else if (topic == "tandem/task_state") {
          tandem::record::TaskState ts;
          parse(ts);
          ModuleTrace& m = modules[ts.module_id()];
          if (m.tasks_done.empty() || m.tasks_done.back().second != static_cast<double>(ts.tasks_done())) {
            m.tasks_done.emplace_back(wall, static_cast<double>(ts.tasks_done()));
          }
        } else if (topic == "tandem/events") {
          tandem::record::Event e;
          parse(e);
          events.emplace_back(wall, e);
          const std::string& k = e.kind();
          if (k == "failover" || k == "takeover" || k == "brake" || k == "load_pause" || k == "module_failed" ||
              (k == "lifecycle" && e.detail().find("-> error") != std::string::npos)) {
            modules[e.module_id().empty() ? module_of(e.subject()) : e.module_id()].marks.push_back(
                {wall, e.tick(), k + " " + e.subject()});
          }
        } else if (topic == "tandem/robot_summary") {
          tandem::record::RobotSummary s;
          parse(s);
          robot_sums[s.robot_id()] = s;
        } else if (topic == "tandem/world_summary") {
          tandem::record::WorldSummary s;
          parse(s);
          world_sums[s.module_id()] = s;
        } else if (topic.rfind("tandem/sim/", 0) == 0) {
          parse(sim);
          if (cases.count(sim.case_name()) == 0) case_order.push_back(sim.case_name());
          SimCase& c = cases[sim.case_name()];
          c.fig.name = sim.case_name();
          c.fig.h_sg = sim.h_sg();
          ++c.fig.ticks;
          const double t = sim.t();
          for (int j = 0; j < std::min(2, sim.arms_size()); ++j) {
            const auto& a = sim.arms(j);
            if (a.x_size() < 3 || a.x_d_size() < 3 || a.s_size() < 3) continue;
            for (int i = 0; i < 3; ++i) {
              c.e[j][i].emplace_back(t, a.x_d(i) - a.x(i));
              c.s[j][i].emplace_back(t, a.s(i));
            }
            c.eh[j].emplace_back(t, a.e_h());
            c.hn[j].emplace_back(t, a.normal_force());
            c.pos[j].add(std::hypot(a.x_d(0) - a.x(0), a.x_d(1) - a.x(1)));
            c.ehr[j].add(a.e_h());
            c.min_n[j] = std::min(c.min_n[j], a.normal_force());
          }
        }
      },
      salvage);
  res.messages = info.messages;
  res.salvaged = info.salvaged;
  res.damage = info.damage;
  std::map<std::string, std::string> deployment;
  for (const auto& md : info.metadata) {
    if (md.name == "deployment") deployment = md.values;
  }
  if (robots.empty() && cases.empty() && modules.empty() && robot_sums.empty()) {
    throw McapError(mcap + ": holds no tandem messages (" + std::to_string(info.messages) +
                    " messages on other topics); is it a recording of tandem record or tandem sim --mcap?");
  }
  make_dirs(dir);
  auto h_sg_of = [&](const std::string& module) {
    const auto it = deployment.find("module." + module + ".h_sg");
    return it == deployment.end() ? 0.0 : std::atof(it->second.c_str());
  };
  // Per-tick time: the recording's metadata gives each module's period (1 ms by default).
  auto period_of = [&](const std::string& module) {
    const auto it = deployment.find("module." + module + ".period");
    return it == deployment.end() ? 1e-3 : std::atof(it->second.c_str());
  };

  std::ostringstream body;
  auto image = [&](const std::string& name, const Plot& p, int w = 960, int h = 320) {
    write_file(dir + "/" + name + ".svg", page::render_svg(p, w, h));
    res.images.push_back(dir + "/" + name + ".svg");
    return "<img src=\"" + name + ".svg\" alt=\"" + xml_escape(p.title) + "\" width=\"" + std::to_string(w) + "\">";
  };

  // Robots: tracking error and normal force against h_sg.
  if (!robots.empty()) {
    body << "<h2>Robots</h2>\n<table><tr><th>robot</th><th>ticks</th><th>e_p RMS [m] (recording)</th>"
            "<th>e_p RMS [m] (robot's summary)</th><th>e_phi RMS [rad]</th><th>e_h RMS [N]</th><th>min h_n [N]</th></tr>\n";
    for (auto& [id, r] : robots) {
      const double per = period_of(module_of(r.arm));
      for (auto& p : r.ep) p.first = p.first / 1e-3 * per;  // recorded with 1 ms, rescaled to the module's period
      for (auto& p : r.hn) p.first = p.first / 1e-3 * per;
      RobotFigures f;
      f.robot_id = id;
      f.arm = r.arm;
      f.strength = r.strength;
      f.ticks = r.ticks;
      f.first_tick = r.first;
      f.last_tick = r.last < 0 ? 0 : static_cast<uint64_t>(r.last);
      f.ep_pos_rms = r.pos.value();
      f.ep_ori_rms = r.ori.value();
      f.eh_rms = r.eh.value();
      f.min_normal_force = r.ticks > 0 ? r.min_n : 0.0;
      const auto s = robot_sums.find(id);
      if (s != robot_sums.end()) {
        f.has_summary = true;
        f.summary_ep_pos_rms = s->second.ep_pos_rms();
        f.summary_eh_rms = s->second.eh_rms();
        f.summary_ticks = s->second.ticks();
      }
      res.robots.push_back(f);
      body << "<tr><td>" << xml_escape(id) << "</td><td>" << f.ticks << "</td><td>" << fmt(f.ep_pos_rms, "%.6e")
           << "</td><td>" << (f.has_summary ? fmt(f.summary_ep_pos_rms, "%.6e") : "-") << "</td><td>"
           << fmt(f.ep_ori_rms, "%.4e") << "</td><td>" << fmt(f.eh_rms) << "</td><td>" << fmt(f.min_normal_force)
           << "</td></tr>\n";
    }
    body << "</table>\n";
    std::set<std::string> arms;
    for (const auto& [id, r] : robots) arms.insert(r.arm);
    for (const auto& arm : arms) {
      Plot pe;
      pe.title = "Tracking error |x_d - x| of " + arm + " (every robot of the arm)";
      pe.xlabel = "time [s] (tick x period)";
      pe.ylabel = "|e_p| [m]";
      Plot ph;
      ph.title = "Normal force h_n of " + arm + " against the safe-grasp force h_sg";
      ph.xlabel = pe.xlabel;
      ph.ylabel = "h_n [N]";
      for (const auto& [id, r] : robots) {
        if (r.arm != arm) continue;
        pe.series.push_back({id, decimate(r.ep), "", Series::Style::Line});
        ph.series.push_back({id, decimate(r.hn, 1500, true), "", Series::Style::Line});
      }
      const double hsg = h_sg_of(module_of(arm));
      if (hsg > 0) ph.hlines.push_back({hsg, "h_sg " + fmt(hsg, "%.1f") + " N"});
      // Per-tick plots run on tick x period: an event is placed by the world tick it names.
      const double per = period_of(module_of(arm));
      for (const auto& mk : modules[module_of(arm)].marks) {
        if (mk.tick > 0 && mk.label.find(arm) != std::string::npos) {
          pe.markers.push_back({static_cast<double>(mk.tick) * per, mk.label, "#999999"});
        }
      }
      body << "<h3>" << xml_escape(arm) << "</h3>\n<p>" << image("robot_" + svg_name(arm) + "_error", pe) << "</p>\n<p>"
           << image("robot_" + svg_name(arm) + "_force", ph) << "</p>\n";
    }
  }

  // Modules: progress, tasks, pauses, failovers and takeovers; late ticks and latency.
  if (!modules.empty()) {
    body << "<h2>Modules</h2>\n<p>Time axis: wall time since the recording began. Grey lines: failovers, "
            "takeovers, brakes, load pauses and errors (events).</p>\n";
    for (auto& [name, m] : modules) {
      if (name.empty()) continue;
      std::vector<RefLine> marks;
      for (const auto& mk : m.marks) marks.push_back({mk.wall, mk.label, "#999999"});
      Plot pp;
      pp.title = "Module " + name + ": task progress, tasks done and pauses";
      pp.xlabel = "wall time [s]";
      pp.ylabel = "fraction / count";
      if (!m.progress.empty()) pp.series.push_back({"task progress (fraction)", decimate(m.progress), "", Series::Style::Line});
      if (!m.tasks_done.empty()) pp.series.push_back({"tasks done", m.tasks_done, "", Series::Style::Step});
      if (!m.paused.empty()) pp.series.push_back({"paused or braked (1)", m.paused, "#c0392b", Series::Style::Step});
      pp.markers = marks;
      Plot pl;
      pl.title = "Module " + name + ": late arm-ticks per second, sample->command latency p99 per 100 ms";
      pl.xlabel = "wall time [s]";
      pl.ylabel = "late/s ; latency [us]";
      if (!m.late_rate.empty()) pl.series.push_back({"late arm-ticks per s", decimate(m.late_rate), "", Series::Style::Step});
      if (!m.latency.empty()) pl.series.push_back({"latency p99 [us]", decimate(m.latency), "", Series::Style::Line});
      pl.markers = marks;
      bool late = false;
      for (const auto& p : m.late_rate) late = late || p.second > 0.0;
      body << "<h3>" << xml_escape(name) << "</h3>\n";
      if (!pp.series.empty()) body << "<p>" << image("module_" + svg_name(name) + "_progress", pp) << "</p>\n";
      if (!m.latency.empty() || late) {
        body << "<p>" << image("module_" + svg_name(name) + "_timing", pl) << "</p>\n";
      } else {
        body << "<p>No late arm-ticks and no latency figures: lockstep timing (the world waits for every command).</p>\n";
      }
      const auto ws = world_sums.find(name);
      if (ws != world_sums.end()) {
        const auto& w = ws->second;
        body << "<p>World summary: " << w.ticks() << " ticks, slips " << w.slip_events() << ", contact lost "
             << w.contact_lost() << ", late arm-ticks " << w.late_commands() << ", failovers " << w.failovers()
             << ", braked arm-ticks " << w.braked_ticks();
        if (w.realtime()) body << ", latency p50 " << fmt(w.latency_p50_us(), "%.0f") << " us, p99 " << fmt(w.latency_p99_us(), "%.0f") << " us";
        body << ".</p>\n";
      }
    }
  }

  // tandem sim: the paper's figures per case, side by side.
  if (!cases.empty()) {
    body << "<h2>Simulation cases (the paper's figures)</h2>\n<table><tr><th>case</th><th>ticks</th>"
            "<th>e_p RMS left/right [m]</th><th>e_h RMS left/right [N]</th><th>min h_n left/right [N]</th><th>h_sg [N]</th></tr>\n";
    for (const auto& name : case_order) {
      SimCase& c = cases[name];
      for (int j = 0; j < 2; ++j) {
        c.fig.ep_pos_rms[j] = c.pos[j].value();
        c.fig.eh_rms[j] = c.ehr[j].value();
        c.fig.min_normal_force[j] = c.min_n[j] < 1e299 ? c.min_n[j] : 0.0;
      }
      res.cases.push_back(c.fig);
      body << "<tr><td>" << xml_escape(name) << "</td><td>" << c.fig.ticks << "</td><td>" << fmt(c.fig.ep_pos_rms[0], "%.3e")
           << " / " << fmt(c.fig.ep_pos_rms[1], "%.3e") << "</td><td>" << fmt(c.fig.eh_rms[0]) << " / " << fmt(c.fig.eh_rms[1])
           << "</td><td>" << fmt(c.fig.min_normal_force[0]) << " / " << fmt(c.fig.min_normal_force[1]) << "</td><td>"
           << fmt(c.fig.h_sg) << "</td></tr>\n";
    }
    body << "</table>\n";
    const char* axis[3] = {"x", "y", "phi"};
    struct Fig {
      const char* key;
      const char* title;
      const char* ylabel;
    };
    const Fig figs[] = {{"cartesian", "Cartesian errors x_d - x (right robot)", "[m], [rad]"},
                        {"force", "Force error e_h = h_ref - h_n (both robots)", "e_h [N]"},
                        {"sliding", "Sliding variables s (right robot, contact frame)", "s"},
                        {"normal", "Normal force h_n against h_sg (both robots)", "h_n [N]"}};
    for (const Fig& fg : figs) {
      body << "<h3>" << fg.title << "</h3>\n<div class=\"row\">";
      for (const auto& name : case_order) {
        SimCase& c = cases[name];
        Plot p;
        p.title = name;
        p.xlabel = "t [s]";
        p.ylabel = fg.ylabel;
        const std::string key(fg.key);
        if (key == "cartesian") {
          for (int i = 0; i < 3; ++i) p.series.push_back({std::string("e_") + axis[i], decimate(c.e[1][i], 800), "", Series::Style::Line});
        } else if (key == "force") {
          for (int j = 0; j < 2; ++j) p.series.push_back({j == 0 ? "left" : "right", decimate(c.eh[j], 800), "", Series::Style::Line});
        } else if (key == "sliding") {
          const char* sn[3] = {"s_t", "s_a", "s_phi"};
          for (int i = 0; i < 3; ++i) p.series.push_back({sn[i], decimate(c.s[1][i], 800), "", Series::Style::Line});
        } else {
          for (int j = 0; j < 2; ++j) p.series.push_back({j == 0 ? "left" : "right", decimate(c.hn[j], 800, true), "", Series::Style::Line});
          if (c.fig.h_sg > 0) p.hlines.push_back({c.fig.h_sg, "h_sg"});
        }
        body << image("sim_" + key + "_" + svg_name(name), p, 460, 280);
      }
      body << "</div>\n";
    }
  }

  // Sensors and events.
  for (const auto& [arm, ticks] : sensor_ticks) res.sensor_ticks[arm] = ticks.size();
  if (!sensor_ticks.empty()) {
    body << "<h2>Sensor samples</h2>\n<table><tr><th>arm</th><th>ticks recorded</th><th>first</th><th>last</th><th>missing</th></tr>\n";
    for (const auto& [arm, ticks] : sensor_ticks) {
      const uint64_t first = *ticks.begin(), last = *ticks.rbegin();
      body << "<tr><td>" << xml_escape(arm) << "</td><td>" << ticks.size() << "</td><td>" << first << "</td><td>" << last
           << "</td><td>" << (last - first + 1 - ticks.size()) << "</td></tr>\n";
    }
    body << "</table>\n";
  }
  if (!events.empty()) {
    body << "<h2>Events (" << events.size() << ")</h2>\n<table><tr><th>t [s]</th><th>kind</th><th>module</th><th>subject</th><th>detail</th></tr>\n";
    size_t shown = 0;
    for (const auto& [t, e] : events) {
      if (++shown > 400) break;
      body << "<tr><td>" << fmt(t, "%.3f") << "</td><td>" << xml_escape(e.kind()) << "</td><td>" << xml_escape(e.module_id())
           << "</td><td>" << xml_escape(e.subject()) << "</td><td>" << xml_escape(e.detail()) << "</td></tr>\n";
    }
    body << "</table>\n";
    if (events.size() > 400) body << "<p>(the first 400 of " << events.size() << " shown)</p>\n";
  }

  std::ostringstream html;
  std::string title = deployment.count("deployment") != 0 ? "tandem run " + deployment["deployment"] : "tandem recording";
  for (const auto& md : info.metadata) {
    if (md.name == "scenario" && md.values.count("scenario") != 0) title = "tandem sim " + md.values.at("scenario");
  }
  // In the pages' visual language (services/page/style.css, as the live view and the soak's report).
  html << page::html_head(title) << page::header_bar(title) << "<main><section>\n";
  html << "<p>Recording <code>" << xml_escape(mcap) << "</code>: " << info.messages << " messages on " << info.channels.size()
       << " channels in " << info.chunks << " chunks";
  for (const char* k : {"timing", "domain", "modules", "topics"}) {
    if (deployment.count(k) != 0) html << "; " << k << " " << xml_escape(deployment[k]);
  }
  html << ".</p>\n";
  if (info.salvaged) {
    html << "<p class=\"warn\">This recording is damaged; the report shows what came before the damage: "
         << xml_escape(info.damage) << "</p>\n";
  }
  html << body.str() << "</section></main></body></html>\n";
  res.index = dir + "/index.html";
  write_file(res.index, html.str());

  // summary.txt: the figures recomputed from the recording, key=value.
  std::ostringstream sum;
  sum.precision(17);
  sum << "messages=" << info.messages << "\nsalvaged=" << (info.salvaged ? 1 : 0) << "\n";
  for (const auto& r : res.robots) {
    sum << "robot." << r.robot_id << ".ticks=" << r.ticks << "\nrobot." << r.robot_id << ".ep_pos_rms=" << r.ep_pos_rms
        << "\nrobot." << r.robot_id << ".eh_rms=" << r.eh_rms << "\nrobot." << r.robot_id
        << ".min_normal_force=" << r.min_normal_force << "\n";
  }
  for (const auto& [arm, n] : res.sensor_ticks) sum << "sensors." << arm << ".ticks=" << n << "\n";
  for (const auto& c : res.cases) {
    for (int j = 0; j < 2; ++j) {
      sum << "case." << c.name << "." << j << ".ep_pos_rms=" << c.ep_pos_rms[j] << "\ncase." << c.name << "." << j
          << ".eh_rms=" << c.eh_rms[j] << "\n";
    }
  }
  write_file(dir + "/summary.txt", sum.str());
  return res;
}

}  // namespace tandem::record
