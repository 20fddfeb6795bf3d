// `tandem up`: starts a deployment as separate processes (world, supervisor and robots per module, and the
// coordinator) that talk only over Fast DDS, supervises them, serves live commands, and ends with a summary.
// Ctrl-C / SIGTERM stops every child; no child outlives the launcher (PR_SET_PDEATHSIG), every child is reaped.
//
// The launcher is the deployment's supervisor (DESIGN.md, failure tiers 2 and 3): it restarts robots and
// coordinators by policy (intensity limit, doubling backoff) and gives up on one that keeps failing; with a
// coordinator, a module whose world or supervisor dies is failed and stopped while the others go on (the
// coordinator re-plans its task). Live commands arrive over DDS (tandem plug/unplug/kill/down) and are
// carried out here: docs/failure-model.md. The supervision itself is launcher::Supervisor (services/launcher:
// events in, actions out); up_run.cpp wires it to DDS, to the processes and to the clock (up::UpRun), and
// up_parts.cpp holds what it needs besides. This file reads the command line.
#include "up_command.hpp"

#include <signal.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "tandem/runtime/args.hpp"
#include "up_run.hpp"

namespace tandem::cli {
namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop = true; }

/// The command line, on CLI11 (runtime::parse_args): `tandem help up` prints the same text as --help.
void describe(CLI::App& app, up::UpOptions& o, std::string& record_file) {
  app.description(
      "Starts every module of the deployment as separate processes over Fast DDS: tandem-world,\n"
      "tandem-supervisor and one tandem-robot per arm (plus standbys), and the coordinator if the file has\n"
      "one, in lockstep or real-time timing. Prints progress while it runs and a summary at the end (RMS per\n"
      "robot, slips, contact losses, rejected samples, failovers, and in real time the latency and late ticks).\n"
      "While it runs, from any terminal: tandem status | plug | unplug | kill | down (see 'tandem help plug').\n"
      "Robots, supervisors and coordinators can have hot standbys and are restarted by the file's restart policy;\n"
      "with a coordinator, a module whose world (or supervisor, without a standby) fails is stopped and the others\n"
      "go on (docs/failure-model.md). In real-time timing the world, supervisors and robots run SCHED_FIFO at the\n"
      "file's realtime_priority (default 20; a note says so if the system refuses it); with cpu_affinity: module\n"
      "each module's world and robots are pinned to one CPU of their own (opt-in, docs/architecture.md).");
  app.add_option("deploy", o.file, "the deployment file (docs/architecture.md)")->required()->type_name("DEPLOY.yaml");
  app.add_option("--summary", o.summary_file, "also write the summary as key=value lines (full precision)")
      ->type_name("FILE");
  app.add_option("--record", record_file,
                 "record the run with `tandem record` (as the file's `record:` key does; see 'tandem help record');\n"
                 "`tandem report FILE.mcap -o DIR` makes the plots")
      ->type_name("FILE.mcap");
  app.add_flag("--view", o.with_view,
               "start `tandem view` beside the deployment (the page and Foxglove on http://127.0.0.1:8765/)");
  app.add_option("--view-port", o.view_port, "--view on another port (0: any free one; see 'tandem help view')")
      ->check(runtime::decimal())->check(CLI::Range(0, 65535))->type_name("N")->each([&o](const std::string&) { o.with_view = true; });
  app.add_flag("--check", o.check_only,
               "validate the file and every scenario it names, print the real-time capacity estimate (and a\n"
               "warning when the deployment needs more cores than the machine has), and start nothing. The\n"
               "estimate is calibrated on this machine in about 0.3 s (a cross-process wake-up, a plant step, a\n"
               "law step)");
  app.footer(
      "Real time with a coordinator: modules the estimate does not fit start parked, and a load that does not\n"
      "fit for 20 s parks the last modules of the file until the machine is calm (shed_modules: false: never).\n"
      "Ctrl-C or SIGTERM stops every process cleanly.\n"
      "\n"
      "Exit: 0 every process finished (or the coordinator did every task) and every module kept the safe\n"
      "grasp; 1 a process failed or a grasp was lost; 2 bad arguments or configuration (nothing is started).");
}

}  // namespace

void up_usage(std::FILE* f) {
  up::UpOptions o;
  std::string record_file;
  CLI::App app("", "tandem up");
  describe(app, o, record_file);
  std::fputs(app.help().c_str(), f);
}

int up_command(const std::vector<std::string>& args) {
  up::UpOptions o;
  std::string record_file;
  CLI::App app("", "tandem up");
  describe(app, o, record_file);
  if (const int code = runtime::parse_args(app, args); code >= 0) return code;
  runtime::Deployment d;
  std::vector<launcher::ModuleSpec> specs;
  try {
    d = runtime::load_deployment(o.file);
    if (!record_file.empty()) d.record = record_file;  // --record overrides the file's record:
    if (!d.hosts.empty()) {
      // The agents start processes from their own working directories: send them absolute paths (the same
      // paths must exist on every host, docs/multihost.md).
      auto absolute = [](std::string& path) {
        if (char* abs = ::realpath(path.c_str(), nullptr)) {
          path = abs;
          std::free(abs);
        }
      };
      absolute(o.file);
      for (auto& m : d.modules) absolute(m.scenario);
    }
    for (const auto& m : d.modules) specs.push_back(up::module_spec(m));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem up: %s\n", e.what());
    return 2;
  }
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  up::UpRun run(std::move(d), o, std::move(specs), g_stop);
  return run.run();
}

}  // namespace tandem::cli
