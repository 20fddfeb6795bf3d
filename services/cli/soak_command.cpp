// `tandem soak`: the command line of the soak (docs/soak.md). It reads the arguments, the deployment and the fault
// rules, writes the deployment as run and the schedule to the report directory, and hands over to soak::run
// (services/soak/src/run.cpp), which runs the deployment, injects the faults, records, judges and reports.
#include "soak_command.hpp"

#include <sys/stat.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "tandem/runtime/deployment.hpp"
#include "tandem/soak/run.hpp"
#include "tandem/soak/schedule.hpp"

namespace tandem::cli {
namespace {

using namespace tandem::soak;

std::atomic<bool> g_soak_stop{false};
void on_soak_signal(int) { g_soak_stop = true; }

/// "90", "90s", "10m", "1h", "1.5m" -> seconds; -1 if malformed.
double parse_duration(const std::string& s) {
  if (s.empty()) return -1.0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || !std::isfinite(v) || v <= 0.0) return -1.0;
  const std::string unit(end);
  if (unit.empty() || unit == "s") return v;
  if (unit == "m" || unit == "min") return 60.0 * v;
  if (unit == "h") return 3600.0 * v;
  return -1.0;
}

struct SoakArgs {
  std::string file, faults = "mixed", report, timing = "realtime", transport;
  double duration = 600.0;
  uint64_t seed = 1;
  bool print_only = false;
  bool help = false;
};

/// The command line; std::invalid_argument naming what was wrong and what is accepted.
SoakArgs parse_soak_args(const std::vector<std::string>& args) {
  SoakArgs s;
  auto value = [&](size_t& i, const char* opt) -> std::string {
    if (i + 1 >= args.size()) throw std::invalid_argument(std::string(opt) + " needs a value (see 'tandem help soak')");
    return args[++i];
  };
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      s.help = true;
      return s;
    } else if (a == "--duration") {
      const std::string v = value(i, "--duration");
      s.duration = parse_duration(v);
      if (s.duration <= 0.0) throw std::invalid_argument("--duration '" + v + "': expected a time above 0 such as 90, 90s, 10m or 1h");
    } else if (a == "--seed") {
      const std::string v = value(i, "--seed");
      char* end = nullptr;
      s.seed = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || v[0] == '-') throw std::invalid_argument("--seed '" + v + "': expected a whole number >= 0");
    } else if (a == "--faults") {
      s.faults = value(i, "--faults");
    } else if (a == "--report") {
      s.report = value(i, "--report");
    } else if (a == "--timing") {
      s.timing = value(i, "--timing");
      if (s.timing != "realtime" && s.timing != "lockstep") {
        throw std::invalid_argument("--timing '" + s.timing + "': accepted: realtime, lockstep");
      }
    } else if (a == "--transport") {
      s.transport = value(i, "--transport");
      if (s.transport != "udp" && s.transport != "shm") {
        throw std::invalid_argument("--transport '" + s.transport + "': accepted: udp, shm");
      }
    } else if (a == "--print-schedule") {
      s.print_only = true;
    } else if (!a.empty() && a[0] == '-') {
      throw std::invalid_argument("unknown option '" + a + "' (see 'tandem help soak')");
    } else if (s.file.empty()) {
      s.file = a;
    } else {
      throw std::invalid_argument("one deployment file expected, got '" + a + "' too");
    }
  }
  if (s.file.empty()) throw std::invalid_argument("missing the deployment file (see 'tandem help soak')");
  return s;
}

}  // namespace

void soak_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem soak <deploy.yaml> [--duration 10m] [--seed N] [--faults FILE|PRESET] [--report DIR]\n"
      "                   [--timing realtime|lockstep] [--transport udp|shm] [--print-schedule]\n"
      "\n"
      "Runs the deployment (its own `tandem up`) for the given time under a seeded schedule of faults, records\n"
      "what the deployment reports over DDS, judges the recording against the invariants and writes a report.\n"
      "\n"
      "  --duration T     how long to run: 90, 90s, 10m, 1h (default 10m)\n"
      "  --seed N         the schedule's seed (default 1): the same seed, rules and duration give the same schedule\n"
      "  --faults F       a schedule file (YAML, docs/soak.md) or a preset: mixed (default; every kind, about 20 a\n"
      "                   minute), ci (every kind at least once, for short runs), kills, none\n"
      "  --report DIR     where the report goes (default soak-<deployment>-<seed>): summary.md, summary.txt,\n"
      "                   index.html, SVG plots, schedule.yaml, the derived deploy.yaml and launcher.log\n"
      "  --timing T       realtime (default) or lockstep, whatever the file says\n"
      "  --transport T    udp or shm instead of the file's: over shared memory a SIGKILLed process can leave its\n"
      "                   port to stall its peers (docs/failure-model.md); lockstep, which has the CPU, can take udp\n"
      "  --print-schedule print the schedule (YAML) and exit without starting anything\n"
      "\n"
      "Faults: SIGKILL of a robot serving an arm, a standby robot, the serving supervisor or coordinator, or a\n"
      "module's world (plugged in again after a while); SIGSTOP stalls; unplug and plug of robots and modules;\n"
      "CPU hogs on one or both cores. The deployment gets a coordinator queue that lasts the whole run.\n"
      "Invariants: object held (no slip, no drop), grasp force >= h_sg (outside stated windows), tasks done exactly\n"
      "once, every fault recovered within its bound, progress, nothing left behind, memory flat, logs bounded.\n"
      "Progress is printed every 10 s. Ctrl-C stops early and still writes the report.\n"
      "\n"
      "Exit: 0 every invariant held; 1 a violation (listed in the report); 2 bad arguments, deployment or schedule.\n",
      f);
}

int soak_command(const std::vector<std::string>& args) {
  SoakArgs a;
  try {
    a = parse_soak_args(args);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "tandem soak: %s\n", e.what());
    return 2;
  }
  if (a.help) {
    soak_usage(stdout);
    return 0;
  }
  runtime::Deployment d;
  FaultFile rules;
  Schedule sched;
  try {
    d = runtime::load_deployment(a.file);
    struct stat st {};
    rules = ::stat(a.faults.c_str(), &st) == 0 ? load_fault_file(a.faults) : preset(a.faults);
    sched = make_schedule(rules, a.seed, a.duration);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem soak: %s\n", e.what());
    return 2;
  }
  if (!d.security_keys.empty()) {
    std::fprintf(stderr, "tandem soak: %s has 'security:'; soaks of secured deployments are not supported yet (the "
                         "soak's observer has no identity): soak a copy without it\n", a.file.c_str());
    return 2;
  }
  if (a.print_only) {
    std::fputs(to_yaml(sched).c_str(), stdout);
    return 0;
  }
  if (a.report.empty()) a.report = "soak-" + d.name + "-" + std::to_string(a.seed);
  if (::mkdir(a.report.c_str(), 0755) != 0 && errno != EEXIST) {
    std::fprintf(stderr, "tandem soak: cannot create the report directory %s: %s\n", a.report.c_str(), std::strerror(errno));
    return 2;
  }
  // The deployment as run: with a queue that lasts, the chosen timing; validated like any deployment file.
  const std::string derived = a.report + "/deploy.yaml";
  size_t generated = 0;
  try {
    std::ofstream(derived) << derived_deployment(a.file, d, a.timing, a.transport, a.duration, generated);
    std::ofstream(a.report + "/schedule.yaml") << to_yaml(sched);
    d = runtime::load_deployment(derived);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem soak: the derived deployment %s is not valid: %s\n", derived.c_str(), e.what());
    return 2;
  }
  std::string command = "tandem soak";
  for (const auto& arg : args) command += " " + arg;
  std::printf("tandem soak %s: %zu module(s), %s timing over %s, %.0f s, seed %llu, %zu fault(s) scheduled (%s); report in %s\n",
              d.name.c_str(), d.modules.size(), a.timing.c_str(), d.transport.c_str(), a.duration,
              static_cast<unsigned long long>(a.seed), sched.faults.size(), rules.source.c_str(), a.report.c_str());
  std::fflush(stdout);

  struct sigaction sa {};
  sa.sa_handler = on_soak_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  const RunOptions o{a.file, derived, a.report, command, rules.source, a.timing, a.seed, a.duration};
  return soak::run(d, sched, o, g_soak_stop);
}

}  // namespace tandem::cli
