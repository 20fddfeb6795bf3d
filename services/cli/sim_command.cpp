// `tandem sim`: runs the cases of a scenario in one process and prints the comparison with Table IV.
#include "sim_command.hpp"

#include <sys/stat.h>

#include <cctype>
#include <cerrno>
#include <tandem_record.pb.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include "tandem/model/grasp.hpp"
#include "tandem/record/recording.hpp"
#include "tandem/page/files.hpp"
#include "tandem/runtime/args.hpp"
#include "tandem/sim/embedded.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::cli {

namespace {


/// One case's time series as SimSample messages on tandem/sim/<case> (log time = simulated time).
void record_case(record::RecordingWriter& rec, const std::string& name, double h_sg,
                 const std::vector<sim::SeriesRow>& rows, const sim::Scenario& sc) {
  const uint16_t ch = rec.channel("tandem/sim/" + name, record::SimSample::descriptor(), {{"case", name}});
  record::SimSample m;
  m.set_case_name(name);
  m.set_h_sg(h_sg);
  for (int j = 0; j < 2; ++j) m.add_arms()->set_name(sc.robots[j].name);
  uint64_t k = 0;
  for (const auto& r : rows) {
    m.set_tick(k++);
    m.set_t(r.t);
    for (int j = 0; j < 2; ++j) {
      record::SimArm& a = *m.mutable_arms(j);
      a.clear_x(); a.clear_x_d(); a.clear_tau(); a.clear_s();
      for (int i = 0; i < 3; ++i) {
        a.add_x(r.x[j](i));
        a.add_x_d(r.xd[j](i));
        a.add_s(r.s[j](i));
      }
      for (int i = 0; i < r.tau[j].size(); ++i) a.add_tau(r.tau[j](i));
      a.set_normal_force(r.normal[j]);
      a.set_e_h(r.e_h[j]);
    }
    m.clear_object();
    m.clear_object_ref();
    m.add_object(r.obj_c(0));
    m.add_object(r.obj_c(1));
    m.add_object(r.obj_psi);
    m.add_object_ref(r.obj_ref(0));
    m.add_object_ref(r.obj_ref(1));
    rec.write(ch, m, static_cast<uint64_t>(std::llround(r.t * 1e9)));
  }
}

struct SimArgs {
  std::string file, out_dir, mcap_file;
  std::vector<std::string> only;
  bool csv = true, mcap = true;
  bool no_csv = false, no_mcap = false;  // the flags as given
};

/// The command line, on CLI11 (runtime::parse_args): `tandem help sim` prints the same text as --help.
void describe(CLI::App& app, SimArgs& o) {
  app.description(
      "Runs every case of the scenario (or only those named with --case) on the embedded module:\n"
      "world, supervisor and both robot controllers in one process, 1 kHz control, RK4 plant.\n"
      "Prints per case and robot the RMS of e_p (position and orientation) and e_h, the grasp checks,\n"
      "and the paper's Table IV beside the reported robot. Writes the time series of every case to\n"
      "DIR/<scenario name>.mcap (MCAP, Protobuf SimSample per tick on tandem/sim/<case>; `tandem report` makes\n"
      "the paper's figures from it) and to DIR/<case>.csv.");
  app.add_option("scenario", o.file, "the scenario file (docs/scenario-schema.md)")->required()->type_name("SCENARIO.yaml");
  app.add_option("--out", o.out_dir, "the output directory (default: runs/<scenario name>)")->type_name("DIR");
  app.add_option("--case", o.only, "run only this case (repeat for more)")->type_name("NAME");
  app.add_flag("--no-csv", o.no_csv, "write no CSV files");
  auto* mcap = app.add_option("--mcap", o.mcap_file, "write the MCAP file here instead")->type_name("FILE");
  app.add_flag("--no-mcap", o.no_mcap, "write no MCAP file")->excludes(mcap);
  app.footer(
      "RMS definition: root mean square over every control period of the whole run of\n"
      "  e_p,pos = ||(x_d - x)_xy|| [m], e_p,phi = phi_d - phi [rad], e_h = h_ref - h_n [N],\n"
      "with x_d from eq. (15); 'steady' columns use only the final hold after the motion.\n"
      "\n"
      "Exit: 0 all cases that require the grasp kept it (no slip, no contact loss, force >= h_sg after\n"
      "the start-up transient); 1 some case failed; 2 bad arguments or scenario file.");
}

}  // namespace

void sim_usage(std::FILE* f) {
  SimArgs o;
  CLI::App app("", "tandem sim");
  describe(app, o);
  std::fputs(app.help().c_str(), f);
}

namespace {

/// Reads the command line; -1 to go on, else the exit code (0 after --help).
int parse_sim_args(const std::vector<std::string>& args, SimArgs& o) {
  CLI::App app("", "tandem sim");
  describe(app, o);
  const int code = runtime::parse_args(app, args);
  o.csv = !o.no_csv;
  o.mcap = !o.no_mcap;
  return code;
}

/// Loads the scenario and checks the cases asked for and every case's module (a configuration that cannot run
/// fails before any output), then the output places; -1 to go on, else the exit code.
int load_checked(SimArgs& o, sim::Scenario& sc) {
  try {
    sc = sim::load_scenario(o.file);
  } catch (const sim::ConfigError& e) {
    std::fprintf(stderr, "tandem sim: %s\n", e.what());
    return 2;
  }
  for (const auto& n : o.only) {
    bool found = false;
    for (const auto& c : sc.cases) found = found || c.name == n;
    if (!found) {
      std::string list;
      for (const auto& c : sc.cases) list += (list.empty() ? "" : ", ") + c.name;
      std::fprintf(stderr, "tandem sim: no case '%s' in %s; cases: %s\n", n.c_str(), o.file.c_str(), list.c_str());
      return 2;
    }
  }
  for (const auto& c : sc.cases) {
    try {
      (void)sim::make_module(sc, c);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "tandem sim: %s\n", e.what());
      return 2;
    }
  }
  if (o.out_dir.empty()) o.out_dir = "runs/" + sc.name;
  if (o.mcap && o.mcap_file.empty()) o.mcap_file = o.out_dir + "/" + sim::file_name(sc.name) + ".mcap";
  if (!o.mcap) o.mcap_file.clear();
  const std::string& mf = o.mcap_file;
  if (((o.csv || !mf.empty()) && !page::make_dirs(o.out_dir)) ||
      (!mf.empty() && mf.find('/') != std::string::npos && !page::make_dirs(mf.substr(0, mf.rfind('/'))))) {
    std::fprintf(stderr, "tandem sim: cannot create output directory '%s'\n", o.out_dir.c_str());
    return 2;
  }
  return -1;
}

/// The run's header: the scenario, the reaching-condition gains (eq. 33-34) of each controller that asks for them,
/// and the table's columns.
void print_header(const sim::Scenario& sc, const std::string& file) {
  std::printf("scenario %s (%s): %zu cases, %.1f s each, T = %g s, %d RK4 substeps\n", sc.name.c_str(),
              file.c_str(), sc.cases.size(), sc.duration, sc.period, sc.substeps);
  for (const auto& ctrl : sc.controllers) {
    if (ctrl.law.type == model::LawType::PD) continue;
    for (bool dist : {false, true}) {
      std::printf("eq. (33)-(34) bound on K for '%s'%s (axes tangent, approach, phi):", ctrl.name.c_str(),
                  dist ? " with eq. (37)" : ", nominal");
      for (int j = 0; j < 2; ++j) {
        const model::Vec3 k = sim::reaching_condition_gains(sc, j, ctrl, dist, 1.0);
        std::printf("  %s [%.2f %.2f %.2f]", sc.robots[j].name.c_str(), k(0), k(1), k(2));
      }
      std::printf("\n");
    }
  }
  std::printf("\n");
  std::printf("RMS over every control period of the run. e_p Sp: position axes selected by Sigma_p (contact\n"
              "frame); e_p pos: ||(x_d - x)_xy|| (the paper's e_p); e_h = h_ref - h_n [N]; steady: final hold.\n");
  std::printf("%-22s %-6s %12s %12s %12s %10s %12s %10s | %11s %9s | %s\n", "case", "robot", "e_p Sp RMS",
              "e_p pos RMS", "e_p phi RMS", "e_h RMS N", "e_p steady", "min h_n N", "Table IV ep", "eh", "grasp");
}

/// A case's rows of the table (each robot beside the paper's Table IV for the reported one).
void print_case(const sim::Scenario& sc, const sim::CaseConfig& c, const sim::CaseResult& r, double secs) {
  const bool held = r.grasp_held();
  const sim::PaperRow* paper = sim::paper_table_iv(c.paper_case);
  for (int j = 0; j < 2 && !r.finite; ++j) {
    std::printf("%-22s %-6s %s\n", j == 0 ? c.name.c_str() : "", sc.robots[j].name.c_str(),
                j == 0 ? (c.require_grasp ? "DIVERGED" : "DIVERGED (allowed)") : "");
  }
  for (int j = 0; j < 2 && r.finite; ++j) {
    const auto& m = r.robots[j];
    std::printf("%-22s %-6s %12.4e %12.4e %12.4e %10.4f %12.4e %10.2f | ", j == 0 ? c.name.c_str() : "",
                sc.robots[j].name.c_str(), m.ep_sel_rms, m.ep_pos_rms, m.ep_ori_rms, m.eh_rms, m.ep_pos_rms_steady,
                m.min_normal_force);
    if (j == sc.report_robot && paper != nullptr) {
      std::printf("%11.4e %9.4g | ", paper->ep_rms, paper->eh_rms);
    } else {
      std::printf("%11s %9s | ", "", "");
    }
    if (j == 0) {
      std::printf("%s%s", held ? "held" : "LOST", !held && !c.require_grasp ? " (allowed)" : "");
    } else {
      std::printf("K/K_P [%.3g %.3g %.3g]", m.gains(0), m.gains(1), m.gains(2));
    }
    std::printf("\n");
  }
  if (!held) std::printf("%-22s   -> %s\n", "", r.failure().c_str());
  if (r.finite) {
    std::printf("%-22s   object RMS %.3e m, final %.3e m; torque limit hit in %ld periods; %.2f s wall\n", "",
                r.object_pos_rms, r.object_final_error, r.counters.torque_saturated, secs);
  }
}

/// Runs the selected cases, prints each and writes its CSV and recording; -1 when all ran (`ok`: every case that
/// requires it kept the safe grasp), else the exit code.
int run_cases(const SimArgs& o, const sim::Scenario& sc, record::RecordingWriter* rec, bool& ok) {
  std::vector<sim::SeriesRow> series;
  for (const auto& c : sc.cases) {
    bool selected = o.only.empty();
    for (const auto& n : o.only) selected = selected || n == c.name;
    if (!selected) continue;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      const sim::CaseResult r = sim::run_case(sc, c, {}, (o.csv || rec != nullptr) ? &series : nullptr);
      if (!r.grasp_held() && c.require_grasp) ok = false;
      print_case(sc, c, r, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      if (rec != nullptr) record_case(*rec, c.name, sim::make_module(sc, c).safe_grasp_force, series, sc);
      if (o.csv) sim::write_csv(o.out_dir + "/" + sim::file_name(c.name) + ".csv", series, sc);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "tandem sim: case '%s': %s\n", c.name.c_str(), e.what());
      return 2;
    }
  }
  return -1;
}

}  // namespace

int sim_command(const std::vector<std::string>& args) {
  SimArgs o;
  if (const int code = parse_sim_args(args, o); code >= 0) return code;
  sim::Scenario sc;
  if (const int code = load_checked(o, sc); code >= 0) return code;
  print_header(sc, o.file);
  std::unique_ptr<record::RecordingWriter> rec;
  try {
    if (!o.mcap_file.empty()) {
      rec = std::make_unique<record::RecordingWriter>(o.mcap_file);
      std::map<std::string, std::string> meta{{"scenario", sc.name}, {"scenario_file", o.file},
                                              {"period", std::to_string(sc.period)}, {"duration", std::to_string(sc.duration)}};
      rec->metadata("scenario", meta);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem sim: %s\n", e.what());
    return 2;
  }
  bool ok = true;
  if (const int code = run_cases(o, sc, rec.get(), ok); code >= 0) return code;
  std::printf("\nh_sg (eq. 16) = %.3f N; reference force h_ref = %.2f x h_sg. Table IV: robot on the right.\n",
              model::safe_grasp_force(sc.object.mass, sc.object.mu_s, sc.g0), sc.grasp_safety_factor);
  if (o.csv) std::printf("time series: %s/<case>.csv\n", o.out_dir.c_str());
  if (rec) {
    try {
      rec->close();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "tandem sim: %s\n", e.what());
      return 2;
    }
    std::printf("recording: %s (%llu samples; tandem report %s -o DIR for the figures)\n", o.mcap_file.c_str(),
                static_cast<unsigned long long>(rec->messages()), o.mcap_file.c_str());
  }
  std::printf("%s\n", ok ? "result: PASS (every case that requires it kept the safe grasp)"
                         : "result: FAIL (a case lost the safe grasp; see above)");
  return ok ? 0 : 1;
}

}  // namespace tandem::cli
