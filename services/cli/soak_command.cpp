// `tandem soak`: the command line of the soak (docs/soak.md). It reads the arguments, the deployment and the fault
// rules, writes the deployment as run and the schedule to the report directory, and hands over to soak::run
// (services/soak/src/run.cpp), which runs the deployment, injects the faults, records, judges and reports.
#include "soak_command.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "tandem/runtime/args.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/soak/checker.hpp"
#include "tandem/soak/history_file.hpp"
#include "tandem/soak/report.hpp"
#include "tandem/soak/run.hpp"
#include "tandem/soak/schedule.hpp"

namespace tandem::cli {
namespace {

using namespace tandem::soak;

std::atomic<bool> g_soak_stop{false};
void on_soak_signal(int) { g_soak_stop = true; }

struct SoakArgs {
  std::string file, faults = "mixed", report, timing = "realtime", transport, judge;
  std::string duration = "10m";
  std::string seed = "1";
  bool print_only = false;
};

/// The command line, on CLI11 (runtime::parse_args): `tandem help soak` prints the same text as --help.
void describe(CLI::App& app, SoakArgs& s) {
  app.description(
      "Runs the deployment (its own `tandem up`) for the given time under a seeded schedule of faults, records\n"
      "what the deployment reports over DDS, judges the recording against the invariants and writes a report.");
  CLI::Option* deploy =
      app.add_option("deploy", s.file, "the deployment file (docs/scenario-schema.md); required but with --judge")
          ->type_name("DEPLOY.yaml");
  CLI::Option* judge =
      app.add_option("--judge", s.judge,
                     "run nothing: judge a recorded run again (DIR/history.pb, written by every run) with this\n"
                     "build's checker and write the new report into --report (default DIR/judged)")
          ->excludes(deploy)->type_name("DIR");
  app.add_option("--duration", s.duration, "how long to run: 90, 90s, 10m, 1h")
      ->check(runtime::duration())->capture_default_str()->type_name("T")->excludes(judge);
  app.add_option("--seed", s.seed, "the schedule's seed: the same seed, rules and duration give the same schedule")
      ->check(runtime::whole_number())->capture_default_str()->type_name("N")->excludes(judge);
  app.add_option("--faults", s.faults,
                 "a schedule file (YAML, docs/soak.md) or a preset: mixed (every kind, about 20 a minute), ci (every\n"
                 "kind at least once, for short runs), kills, none")
      ->capture_default_str()->type_name("FILE|PRESET")->excludes(judge);
  app.add_option("--report", s.report,
                 "where the report goes (default soak-<deployment>-<seed>): summary.md, summary.txt, index.html,\n"
                 "SVG plots, schedule.yaml, the derived deploy.yaml and launcher.log")
      ->type_name("DIR");
  app.add_option("--timing", s.timing, "realtime or lockstep, whatever the file says")
      ->check(runtime::one_of({"realtime", "lockstep"}))->capture_default_str()->type_name("realtime|lockstep")->excludes(judge);
  app.add_option("--transport", s.transport,
                 "udp or shm instead of the file's: over shared memory a SIGKILLed process can leave its port to\n"
                 "stall its peers (docs/failure-model.md); lockstep, which has the CPU, can take udp")
      ->check(runtime::one_of({"udp", "shm"}))->type_name("udp|shm")->excludes(judge);
  app.add_flag("--print-schedule", s.print_only, "print the schedule (YAML) and exit without starting anything")->excludes(judge);
  app.footer(
      "Faults: SIGKILL of a robot serving an arm, a standby robot, the serving supervisor or coordinator, or a\n"
      "module's world (plugged in again after a while); SIGSTOP stalls; unplug and plug of robots and modules;\n"
      "CPU hogs on one or both cores. The deployment gets a coordinator queue that lasts the whole run.\n"
      "Invariants: object held (no slip, no drop), grasp force >= h_sg (outside stated windows), tasks done exactly\n"
      "once, every fault recovered within its bound, progress, nothing left behind, memory flat, logs bounded.\n"
      "Progress is printed every 10 s. Ctrl-C stops early and still writes the report.\n"
      "\n"
      "Exit: 0 every invariant held; 1 a violation (listed in the report); 2 bad arguments, deployment or schedule\n"
      "(with --judge: no history.pb, or one this build cannot read).");
}

/// `--judge DIR`: the recorded history judged by this build's checker, the report written again into `out`.
int judge(const std::string& dir, const std::string& out) {
  RunInfo info;
  History h;
  try {
    load_history(dir + "/history.pb", info, h);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem soak: %s\n", e.what());
    return 2;
  }
  const Bounds bounds;
  const Verdict v = check(h, bounds);
  info.command += "  (judged again: tandem soak --judge " + dir + ")";
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) {
    std::fprintf(stderr, "tandem soak: cannot create the report directory %s: %s\n", out.c_str(), ec.message().c_str());
    return 2;
  }
  try {
    write_report(out, info, h, bounds, v);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem soak: %s\n", e.what());
    return 2;
  }
  const std::string text = summary_text(info, h, bounds, v);
  std::fputs(text.substr(0, text.find("## Plots")).c_str(), stdout);
  std::printf("report: %s/index.html\nresult: %s\n", out.c_str(),
              v.ok() ? "PASS (every invariant held)" : "FAIL (see the violations)");
  return v.ok() ? 0 : 1;
}

}  // namespace

void soak_usage(std::FILE* f) {
  SoakArgs a;
  CLI::App app("", "tandem soak");
  describe(app, a);
  std::fputs(app.help().c_str(), f);
}

int soak_command(const std::vector<std::string>& args) {
  SoakArgs a;
  CLI::App app("", "tandem soak");
  describe(app, a);
  if (const int rc = runtime::parse_args(app, args); rc >= 0) return rc;
  if (!a.judge.empty()) return judge(a.judge, a.report.empty() ? a.judge + "/judged" : a.report);
  if (a.file.empty()) {
    std::fprintf(stderr, "tandem soak: a deployment file is required (or --judge DIR to judge a recorded run); "
                         "see tandem soak --help\n");
    return 2;
  }
  const double duration = runtime::parse_duration(a.duration);
  const uint64_t seed = std::strtoull(a.seed.c_str(), nullptr, 10);
  runtime::Deployment d;
  FaultFile rules;
  Schedule sched;
  try {
    d = runtime::load_deployment(a.file);
    struct stat st {};
    rules = ::stat(a.faults.c_str(), &st) == 0 ? load_fault_file(a.faults) : preset(a.faults);
    sched = make_schedule(rules, seed, duration);
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
  if (a.report.empty()) a.report = "soak-" + d.name + "-" + std::to_string(seed);
  {  // with its missing parents, as mkdir -p
    std::error_code ec;
    std::filesystem::create_directories(a.report, ec);
    if (ec) {
      std::fprintf(stderr, "tandem soak: cannot create the report directory %s: %s\n", a.report.c_str(), ec.message().c_str());
      return 2;
    }
  }
  // The deployment as run: with a queue that lasts, the chosen timing; validated like any deployment file.
  const std::string derived = a.report + "/deploy.yaml";
  size_t generated = 0;
  try {
    std::ofstream(derived) << derived_deployment(a.file, d, a.timing, a.transport, duration, generated);
    std::ofstream(a.report + "/schedule.yaml") << to_yaml(sched);
    d = runtime::load_deployment(derived);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem soak: the derived deployment %s is not valid: %s\n", derived.c_str(), e.what());
    return 2;
  }
  std::string command = "tandem soak";
  for (const auto& arg : args) command += " " + arg;
  std::printf("tandem soak %s: %zu module(s), %s timing over %s, %.0f s, seed %llu, %zu fault(s) scheduled (%s); report in %s\n",
              d.name.c_str(), d.modules.size(), a.timing.c_str(), d.transport.c_str(), duration,
              static_cast<unsigned long long>(seed), sched.faults.size(), rules.source.c_str(), a.report.c_str());
  std::fflush(stdout);

  struct sigaction sa {};
  sa.sa_handler = on_soak_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  const RunOptions o{a.file, derived, a.report, command, rules.source, a.timing, seed, duration};
  const int rc = soak::run(d, sched, o, g_soak_stop);
  if (soak::teardown_hung()) {  // the report is written; library teardown at exit would hang as the observer's did
    std::fflush(nullptr);
    ::_exit(rc);
  }
  return rc;
}

}  // namespace tandem::cli
