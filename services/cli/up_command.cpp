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

#include "up_run.hpp"

namespace tandem::cli {
namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop = true; }

/// The command line: false (said why, exit code in `code`) unless the run goes on.
bool parse_up_args(const std::vector<std::string>& args, up::UpOptions& o, std::string& record_file, int& code) {
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") {
      up_usage(stdout);
      code = 0;
      return false;
    } else if (args[i] == "--check") {
      o.check_only = true;
    } else if (args[i] == "--summary" && i + 1 < args.size()) {
      o.summary_file = args[++i];
    } else if (args[i] == "--record" && i + 1 < args.size()) {
      record_file = args[++i];
    } else if (args[i] == "--view") {
      o.with_view = true;
    } else if (args[i] == "--view-port" && i + 1 < args.size()) {
      o.with_view = true;
      o.view_port = args[++i];
    } else if (!args[i].empty() && args[i][0] == '-') {
      std::fprintf(stderr, "tandem up: unknown option '%s' (see 'tandem help up')\n", args[i].c_str());
      return false;
    } else if (o.file.empty()) {
      o.file = args[i];
    } else {
      std::fprintf(stderr, "tandem up: one deployment file expected, got '%s' too\n", args[i].c_str());
      return false;
    }
  }
  if (o.file.empty()) {
    std::fprintf(stderr, "tandem up: missing the deployment file\n\n");
    up_usage(stderr);
    return false;
  }
  return true;
}

}  // namespace

void up_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem up <deploy.yaml> [--summary FILE] [--record FILE.mcap] [--view] [--view-port N] [--check]\n"
      "\n"
      "Starts every module of the deployment as separate processes over Fast DDS: tandem-world,\n"
      "tandem-supervisor and one tandem-robot per arm (plus standbys), and the coordinator if the file has\n"
      "one, in lockstep or real-time timing. Prints progress while it runs and a summary at the end (RMS per\n"
      "robot, slips, contact losses, rejected samples, failovers, and in real time the latency and late ticks).\n"
      "While it runs, from any terminal: tandem status | plug | unplug | kill | down (see 'tandem help plug').\n"
      "Robots, supervisors and coordinators can have hot standbys and are restarted by the file's restart policy;\n"
      "with a coordinator, a module whose world (or supervisor, without a standby) fails is stopped and the others\n"
      "go on (docs/failure-model.md). In real-time timing the world, supervisors and robots run SCHED_FIFO at the\n"
      "file's realtime_priority (default 20; a note says so if the system refuses it).\n"
      "--summary FILE also writes the summary as key=value lines (full precision).\n"
      "--record FILE.mcap records the run with `tandem record` (as the file's `record:` key does; see 'tandem\n"
      "help record'); `tandem report FILE.mcap -o DIR` makes the plots.\n"
      "--view starts `tandem view` beside the deployment (the page and Foxglove on http://127.0.0.1:8765/;\n"
      "--view-port N for another port, 0 for any free one; see 'tandem help view').\n"
      "--check validates the file and every scenario it names, prints the real-time capacity estimate (and a\n"
      "warning when the deployment needs more cores than the machine has), and starts nothing. The estimate is\n"
      "calibrated on this machine in about 0.3 s (a cross-process wake-up, a plant step, a law step).\n"
      "Real time with a coordinator: modules the estimate does not fit start parked, and a load that does not\n"
      "fit for 20 s parks the last modules of the file until the machine is calm (shed_modules: false: never).\n"
      "Ctrl-C or SIGTERM stops every process cleanly. Schema: docs/architecture.md.\n"
      "\n"
      "Exit: 0 every process finished (or the coordinator did every task) and every module kept the safe\n"
      "grasp; 1 a process failed or a grasp was lost; 2 bad arguments or configuration (nothing is started).\n",
      f);
}

int up_command(const std::vector<std::string>& args) {
  up::UpOptions o;
  std::string record_file;
  int code = 2;
  if (!parse_up_args(args, o, record_file, code)) return code;
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
