// tandem: command-line entry point of the cooperative-manipulation runtime.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "agent_command.hpp"
#include "sim_command.hpp"
#include "keys_command.hpp"
#include "record_command.hpp"
#include "remote_command.hpp"
#include "report_command.hpp"
#include "soak_command.hpp"
#include "tandem/runtime/role.hpp"
#include "up_command.hpp"
#include "view_command.hpp"

namespace {

void usage(std::FILE* f) {
  std::fputs(
      "usage: tandem <command> [options]\n"
      "\n"
      "commands:\n"
      "  sim <scenario.yaml>   run a basic module in one process (deterministic embedded simulation)\n"
      "                        and print the RMS table beside the paper's Table IV\n"
      "  up <deploy.yaml>      start a deployment as separate processes over Fast DDS (lockstep or real time)\n"
      "  status <deploy.yaml>  lifecycle state and live figures of a running deployment (over DDS)\n"
      "  down <deploy.yaml>    stop a running deployment cleanly (over DDS)\n"
      "  kill <deploy.yaml> P  fault injection: SIGKILL process (or module) P of a running deployment\n"
      "  plug <deploy.yaml> robot M/ARM [--standby] | module NAME   attach a robot or a module live\n"
      "  unplug <deploy.yaml> robot M/ARM[@S] | module NAME        detach one gracefully\n"
      "  soak <deploy.yaml>    run a deployment for a long time under a seeded fault schedule, check every\n"
      "                        invariant from what it recorded, and write a report with plots\n"
      "  record <deploy.yaml> -o FILE.mcap   record a deployment's topics (MCAP, Protobuf messages)\n"
      "  report FILE.mcap -o DIR             an HTML page with plots of a recording (tandem record, tandem sim)\n"
      "  view <deploy.yaml>    a running deployment in the browser and in Foxglove Studio (HTTP + WebSocket)\n"
      "  keys <deploy.yaml>    make the deployment's DDS-Security keys and documents (security: in the file)\n"
      "  agent <deploy.yaml> --host NAME    the agent of one host of a multi-host deployment (hosts:)\n"
      "  help [command]        show this help, or the help of one command\n"
      "\n"
      "Run 'tandem help <command>' for its options. Exit codes: 0 success, 1 a run failed its grasp\n"
      "checks, 2 bad command line or configuration.\n",
      f);
}

int dispatch(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) {
    usage(stderr);
    return 2;
  }
  const std::string cmd = args[0];
  args.erase(args.begin());
  if (cmd == "help" || cmd == "--help" || cmd == "-h") {
    if (!args.empty() && args[0] == "sim") {
      tandem::cli::sim_usage(stdout);
    } else if (!args.empty() && args[0] == "up") {
      tandem::cli::up_usage(stdout);
    } else if (!args.empty() && args[0] == "soak") {
      tandem::cli::soak_usage(stdout);
    } else if (!args.empty() && args[0] == "keys") {
      tandem::cli::keys_usage(stdout);
    } else if (!args.empty() && args[0] == "record") {
      tandem::cli::record_usage(stdout);
    } else if (!args.empty() && args[0] == "agent") {
      return tandem::cli::agent_command({"--help"});
    } else if (!args.empty() && args[0] == "view") {
      tandem::cli::view_usage(stdout);
    } else if (!args.empty() && args[0] == "report") {
      tandem::cli::report_usage(stdout);
    } else if (!args.empty() && (args[0] == "status" || args[0] == "down" || args[0] == "kill" ||
                               args[0] == "plug" || args[0] == "unplug")) {
      tandem::cli::remote_usage(stdout);
    } else {
      usage(stdout);
    }
    return 0;
  }
  if (cmd == "sim") return tandem::cli::sim_command(args);
  if (cmd == "up") return tandem::cli::up_command(args);
  if (cmd == "agent") return tandem::cli::agent_command(args);
  if (cmd == "soak") return tandem::cli::soak_command(args);
  if (cmd == "record") return tandem::cli::record_command(args);
  if (cmd == "keys") return tandem::cli::keys_command(args);
  if (cmd == "report") return tandem::cli::report_command(args);
  if (cmd == "view") return tandem::cli::view_command(args);
  if (cmd == "status") return tandem::cli::status_command(args);
  if (cmd == "down") return tandem::cli::down_command(args);
  if (cmd == "kill") return tandem::cli::kill_command(args);
  if (cmd == "plug") return tandem::cli::plug_command(args);
  if (cmd == "unplug") return tandem::cli::unplug_command(args);
  std::fprintf(stderr, "tandem: unknown command '%s'\n\n", cmd.c_str());
  usage(stderr);
  return 2;
}

}  // namespace

int main(int argc, char** argv) { return tandem::runtime::run_guarded("tandem", dispatch, argc, argv); }
