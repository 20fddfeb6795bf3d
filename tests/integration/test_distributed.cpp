// Real processes over Fast DDS: `tandem up` starts world, supervisor and two robots on a domain id of its
// own; in lockstep the distributed run must give the embedded simulation's numbers.
#include <catch2/catch.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <tandemPubSubTypes.h>

#include <chrono>
#include <thread>

#include "tandem/dds/bus.hpp"
#include "tandem/sim/embedded.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace {

const std::string kSrc = TANDEM_SOURCE_DIR;
const std::string kBin = TANDEM_BIN_DIR;

// A domain id per test: a base per test run (ctest starts every test from the same parent) plus the test's
// own offset, so that the tests of one run never share a domain (a SIGKILLed participant leaves shared-memory
// ports behind that can deafen a later participant of its domain) and two runs at once are unlikely to meet.
int test_domain(int offset) { return 100 + (static_cast<int>(::getppid()) * 17 + offset) % 120; }

// Tests that SIGKILL processes run over UDP: over shared memory a killed participant's ports stay behind,
// and a later participant can take the dead one's port and hear nothing (docs/failure-model.md).
const std::string kCrashTransport = "udp";

// One scratch directory per test process, removed when the process ends.
struct WorkDir {
  std::string path = "/tmp/tandem-test-" + std::to_string(::getpid());
  WorkDir() { (void)std::system(("mkdir -p " + path).c_str()); }
  ~WorkDir() { (void)std::system(("rm -rf " + path).c_str()); }
};

std::string work_dir() {
  static const WorkDir dir;
  return dir.path;
}

std::string write_deployment(const std::string& name, int domain, const std::string& case_name,
                             const std::string& timing = "lockstep", int standby = 0, const std::string& extra = "",
                             const std::string& transport = "shm", const std::string& scenario = "") {
  std::string path = work_dir() + "/" + name + ".yaml";
  std::ofstream(path) << "name: " << name << "\ndomain_id: " << domain << "\ntransport: " << transport << "\ntiming: " << timing
                      << "\ntimeout: 10\nmodules:\n  - name: m1\n    scenario: "
                      << (scenario.empty() ? kSrc + "/config/scenarios/paper.yaml" : scenario) << "\n    case: " << case_name << "\n    standby: " << standby
                      << "\n" << extra;
  return path;
}

struct Run {
  int exit_code;
  std::string output;
};

Run run(const std::string& cmd) {
  Run r{-1, ""};
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  REQUIRE(p != nullptr);
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) r.output += buf;
  const int st = ::pclose(p);
  r.exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::map<std::string, double> read_summary(const std::string& path) {
  std::map<std::string, double> kv;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    // Numbers only; lists ("a,b,c") and words are read by read_summary_text.
    const std::string v = line.substr(eq + 1);
    char* end = nullptr;
    const double x = std::strtod(v.c_str(), &end);
    if (!v.empty() && end == v.c_str() + v.size()) kv[line.substr(0, eq)] = x;
  }
  return kv;
}

std::map<std::string, std::string> read_summary_text(const std::string& path) {
  std::map<std::string, std::string> kv;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const auto eq = line.find('=');
    if (eq != std::string::npos) kv[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return kv;
}

std::vector<double> parse_list(const std::string& text) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (!item.empty()) out.push_back(std::stod(item));
  }
  return out;
}

// The paper scenario's SOSM case on the embedded module: what a lockstep run of it must reproduce.
const tandem::sim::CaseResult& embedded_sosm() {
  static const tandem::sim::CaseResult result = [] {
    const auto sc = tandem::sim::load_scenario(kSrc + "/config/scenarios/paper.yaml");
    for (const auto& c : sc.cases) {
      if (c.name == "SOSM") return tandem::sim::run_case(sc, c);
    }
    throw std::runtime_error("paper.yaml has no case SOSM");
  }();
  return result;
}

// The paper scenario lengthened to 15 s (the object held at its goal from 4.5 s on), for the tests that kill
// a process mid-run in lockstep: 5000 ticks take about 1.5 s, less than a live command may take to reach the
// launcher, so the kills land in the first third of 15 000 ticks instead. And its SOSM case embedded.
std::string kill_scenario() {
  static const std::string path = [] {
    std::string p = work_dir() + "/paper-15s.yaml";
    (void)std::system(("sed 's/^  duration: 5.0 /  duration: 15.0 /' " + kSrc + "/config/scenarios/paper.yaml > " + p).c_str());
    return p;
  }();
  return path;
}

const tandem::sim::CaseResult& embedded_sosm_15s() {
  static const tandem::sim::CaseResult result = [] {
    const auto sc = tandem::sim::load_scenario(kill_scenario());
    for (const auto& c : sc.cases) {
      if (c.name == "SOSM") return tandem::sim::run_case(sc, c);
    }
    throw std::runtime_error("paper-15s.yaml has no case SOSM");
  }();
  return result;
}

// A deployment with a coordinator and `pairs` out-and-back tasks of 1 s each (out-i to x = 0, back-i to
// x = -0.2), lockstep; `coordinator_keys` and `modules` are YAML lines of their own.
std::string write_task_deployment(const std::string& name, int domain, int pairs, const std::string& coordinator_keys,
                                  const std::string& modules, const std::string& transport = "shm",
                                  double task_seconds = 1.0) {
  std::string path = work_dir() + "/" + name + ".yaml";
  std::ofstream f(path);
  f << "name: " << name << "\ndomain_id: " << domain << "\ntransport: " << transport << "\ntiming: lockstep\ntimeout: 20\n"
    << "coordinator:\n" << coordinator_keys << "  tasks:\n";
  for (int i = 0; i < pairs; ++i) {
    f << "    - {name: out-" << i << ", segments: [{to: [0.0, 0.8, 0.0], duration: " << task_seconds << "}]}\n"
      << "    - {name: back-" << i << ", segments: [{to: [-0.2, 0.8, 0.0], duration: " << task_seconds << "}]}\n";
  }
  f << "modules:\n" << modules;
  return path;
}

// Module entries m1..mN running the paper scenario's SOSM case, with `extra` keys ("" or ", key: value").
std::string sosm_modules(int n, const std::string& extra = "") {
  std::string out;
  for (int m = 1; m <= n; ++m) {
    out += "  - {name: m" + std::to_string(m) + ", scenario: " + kSrc + "/config/scenarios/paper.yaml, case: SOSM" +
           extra + "}\n";
  }
  return out;
}

// Shell: waits (at most 10 s) until the world of the deployment logging to `log` has started ticking, then
// `seconds` more: a fault lands mid-run however long start-up took (lockstep runs 5000 ticks in about 1.5 s).
std::string after_first_tick(const std::string& log, double seconds) {
  // "first tick at wall": the world's own line (a robot's status reads "waiting for ... the first tick").
  return "for i in $(seq 200); do grep -q \"first tick at wall\" " + log + " && break; sleep 0.05; done; sleep " +
         std::to_string(seconds) + "; ";
}

/// Shell: once the task is past 10% (the world's status in `log`), the process `pgrep -f pattern` finds stands still
/// for `seconds` (SIGSTOP, then SIGCONT); prints "pid=<pid>" first.
std::string stall_mid_task(const std::string& log, const std::string& pattern, double seconds) {
  return "for i in $(seq 200); do grep -q \"task  *[1-9][0-9]\\.\" " + log + " && break; sleep 0.05; done; " +
         "pid=$(pgrep -f \"" + pattern + "\"); echo pid=$pid; kill -STOP $pid; sleep " + std::to_string(seconds) +
         "; kill -CONT $pid; ";
}

std::string read_file_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A lockstep run's summary (tandem up --summary) against the embedded run of the same case: same inputs, same code,
// same order of operations, so equal to 1e-12 (in practice bit-equal), every joint slot of each arm included (zeros
// past its joint count).
void check_equals_embedded(const std::map<std::string, double>& kv, const tandem::sim::CaseResult& e) {
  REQUIRE(kv.count("m1.ticks") == 1);
  CHECK(kv.at("m1.ticks") == 5000);
  const char* arms[2] = {"m1/left", "m1/right"};
  for (int j = 0; j < 2; ++j) {
    const std::string a = arms[j];
    INFO(a);
    CHECK(kv.at(a + ".ep_pos_rms") == Approx(e.robots[j].ep_pos_rms).epsilon(1e-12));
    CHECK(kv.at(a + ".ep_ori_rms") == Approx(e.robots[j].ep_ori_rms).epsilon(1e-12));
    CHECK(kv.at(a + ".eh_rms") == Approx(e.robots[j].eh_rms).epsilon(1e-12));
    CHECK(kv.at(a + ".min_normal_force") == Approx(e.robots[j].min_normal_force).epsilon(1e-12));
    const auto& q = e.final_state.q[static_cast<size_t>(j)];
    for (int i = 0; i < 4; ++i) {
      CHECK(kv.at("m1.q_final" + std::to_string(4 * j + i)) == Approx(i < q.size() ? q(i) : 0.0).margin(1e-12));
    }
  }
  CHECK(kv.at("m1.object_final0") == Approx(e.final_state.c(0)).margin(1e-12));
  CHECK(kv.at("m1.object_final1") == Approx(e.final_state.c(1)).margin(1e-12));
  CHECK(kv.at("m1.slip_events") == 0);
}

bool processes_left(int domain) {
  // The bracket keeps pgrep (and its shell) from matching their own command lines.
  return run("pgrep -f 'tandem-[wrsc][a-z]* .*--domain " + std::to_string(domain) + " '").exit_code == 0;
}

}  // namespace

TEST_CASE("lockstep over DDS gives the embedded simulation's numbers", "[distributed]") {
  const int domain = test_domain(0);
  const std::string deploy = write_deployment("lockstep", domain, "SOSM");
  const std::string summary = work_dir() + "/lockstep.summary";
  const Run r = run(kBin + "/tandem up " + deploy + " --summary " + summary);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_FALSE(processes_left(domain));

  check_equals_embedded(read_summary(summary), embedded_sosm());
}

TEST_CASE("lockstep over DDS gives the embedded numbers for heterogeneous modules (3R + PPR, 3R + 4R)", "[distributed][hetero]") {
  int offset = 28;
  for (const std::string name : {"hetero-ppr", "hetero-4r"}) {
    INFO(name);
    const std::string scenario = kSrc + "/config/scenarios/" + name + ".yaml";
    const int domain = test_domain(offset++);
    const std::string deploy = write_deployment(name, domain, "SOSM-u", "lockstep", 0, "", "shm", scenario);
    const std::string summary = work_dir() + "/" + name + ".summary";
    const Run r = run(kBin + "/tandem up " + deploy + " --summary " + summary);
    INFO(r.output);
    REQUIRE(r.exit_code == 0);
    CHECK_FALSE(processes_left(domain));
    const auto sc = tandem::sim::load_scenario(scenario);
    const tandem::sim::CaseConfig* cc = nullptr;
    for (const auto& c : sc.cases) {
      if (c.name == "SOSM-u") cc = &c;
    }
    REQUIRE(cc != nullptr);
    const tandem::sim::CaseResult e = tandem::sim::run_case(sc, *cc, tandem::sim::RunOptions{false});
    CHECK(e.final_state.q[0].size() == 3);
    CHECK(e.final_state.q[1].size() == sc.robots[1].dof());  // the 4R's fourth joint is compared too
    check_equals_embedded(read_summary(summary), e);
  }
}

TEST_CASE("one module runs its task in real time: the grasp always held, the task done when nothing stopped it", "[distributed]") {
  const int domain = test_domain(3);
  const std::string deploy = write_deployment("realtime", domain, "SOSM", "realtime");
  const std::string summary = work_dir() + "/realtime.summary";
  const Run r = run(kBin + "/tandem up " + deploy + " --summary " + summary);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 5000);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  // Safety above, whatever the machine's load. Progress only where the machine gave it: with no tick braked and none
  // paused for load, the task is done (the object ends within 1 mm of the goal (0.2, 0.8)); a busy machine may
  // pause the module or brake an arm (a safe stop), and then the 5 s scenario ends short of the goal.
  REQUIRE(kv.count("m1.braked_ticks") == 1);
  REQUIRE(kv.count("m1.load_paused_ticks") == 1);
  if (kv.at("m1.braked_ticks") == 0 && kv.at("m1.load_paused_ticks") == 0) {
    CHECK(std::abs(kv.at("m1.object_final0") - 0.2) < 1e-3);
    CHECK(std::abs(kv.at("m1.object_final1") - 0.8) < 1e-3);
  } else {
    WARN("stopped safely for " << kv.at("m1.braked_ticks") << " braked and " << kv.at("m1.load_paused_ticks")
                               << " paused tick(s): the task's end is not judged");
  }
  // Late ticks are counted, not hidden (some happen on a shared 2-core machine); the grasp survives them.
  REQUIRE(kv.count("m1.late_commands") == 1);
  CHECK(kv.at("m1.late_commands") <= 2 * 5000);
  CHECK(kv.at("m1.latency_p50_us") > 0.0);  // measured: commands did arrive within ticks
  CHECK(kv.at("m1.latency_p99_us") >= kv.at("m1.latency_p50_us"));
  CHECK(kv.at("m1/right.min_normal_force") >= 19.62);
  CHECK(kv.at("m1/left.min_normal_force") >= 19.62);
  CHECK(r.output.find("latency p50") != std::string::npos);
  CHECK(r.output.find("a thread spinning") == std::string::npos);  // the spin watch (limit 0.9) names nothing here
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("real time: the launcher kills a per-tick process whose thread uses more than the spin limit of a core", "[distributed]") {
  // A spinning thread cannot be made to order, so the limit is lowered to 1% of a core: a world's tick thread uses
  // about 10%, and the launcher must name it within seconds, kill its process, and leave nothing behind.
  const int domain = test_domain(28);
  const std::string deploy = write_deployment("spin", domain, "SOSM", "realtime", 0, "spin_limit: 0.01\n");
  const Run r = run("timeout 60 " + kBin + "/tandem up " + deploy);
  INFO(r.output);
  const auto at = r.output.find(" of a core for ");
  REQUIRE(at != std::string::npos);
  const auto start = r.output.rfind('\n', at) + 1;
  const std::string line = r.output.substr(start, r.output.find('\n', at) - start);
  CHECK_THAT(line, Catch::StartsWith("tandem up: m1/") && Catch::Contains(" at SCHED_") &&
                       Catch::Contains("killed (its exit is handled as a crash)"));
  // Over the 3 s window: the newest look at least 3 s old, looks once a second.
  const double over = std::atof(r.output.c_str() + at + std::string(" of a core for ").size());
  CHECK(over >= 3.0);
  CHECK(over < 5.0);
  CHECK(r.exit_code != 124);  // the run ended (the killed process's policy ends it), not the timeout
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("invalid samples on the wire are rejected and counted, and the run is unaffected", "[distributed]") {
  const int domain = test_domain(2);
  const std::string deploy = write_deployment("inject", domain, "SOSM");
  const std::string summary = work_dir() + "/inject.summary";
  // The deployment in the background, the injector beside it for 2 s of the run.
  const std::string up_log = work_dir() + "/inject.log";
  const std::string cmd = kBin + "/tandem up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          kBin + "/tandem_inject --domain " + std::to_string(domain) + " --seconds 2; wait $up";
  const Run r = run("bash -c '" + cmd + "'");
  std::ifstream log(up_log);
  std::stringstream ss;
  ss << log.rdbuf();
  INFO(r.output << ss.str());
  REQUIRE(r.output.find("injected") != std::string::npos);
  const auto kv = read_summary(summary);
  REQUIRE(kv.count("m1.rejected_commands") == 1);
  // NaN, over the limit and unknown-arm commands: all three kinds reach the world's checks (the unknown arm
  // alone would be a third of them).
  const auto pos = r.output.find("injected_torques=");
  REQUIRE(pos != std::string::npos);
  const double injected_torques = std::stod(r.output.substr(pos + 17));
  CHECK(kv.at("m1.rejected_commands") >= 0.5 * injected_torques);
  CHECK(kv.at("m1/left.rejected") > 0);         // reference with inf
  CHECK(kv.at("m1/right.rejected") > 0);        // reference with a negative force
  CHECK(kv.at("m1.ticks") == 5000);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  // Nothing invalid was applied: the arms computed exactly what the embedded simulation computes.
  const tandem::sim::CaseResult& e = embedded_sosm();
  CHECK(kv.at("m1/left.ep_pos_rms") == Approx(e.robots[0].ep_pos_rms).epsilon(1e-12));
  CHECK(kv.at("m1/right.eh_rms") == Approx(e.robots[1].eh_rms).epsilon(1e-12));
  CHECK_FALSE(processes_left(domain));
}

int shm_files() { return std::stoi(run("ls /dev/shm | grep -c fastrtps || true").output); }

TEST_CASE("tandem status and tandem down work from another process over DDS", "[distributed]") {
  const int domain = test_domain(4);
  const int shm_before = shm_files();
  const std::string deploy = write_deployment("remote", domain, "SOSM", "realtime");
  const std::string up_log = work_dir() + "/remote.log";
  // Start the deployment in the background; ask for its status, then stop it with `tandem down`.
  // Also: the scheduling class of the running world (FF = SCHED_FIFO, TS = normal).
  // The status is asked until the world is active (it turns SCHED_FIFO then), for up to 15 s: a fixed second was
  // not always enough on a loaded CI machine.
  const std::string cmd = kBin + "/tandem up " + deploy + " > " + up_log + " 2>&1 & up=$!; sleep 1; for i in $(seq 30); do s=$(" +
                          kBin + "/tandem status " + deploy + "); echo \"$s\" | grep -q \"m1/world *active\" && break; sleep 0.5; done; " +
                          "echo \"$s\"; cls=$(ps -o cls= -p $(pgrep -f \"tandem-worl[d] .*--domain " +
                          std::to_string(domain) + " \")); echo world_cls=${cls// /}; " + kBin + "/tandem down " + deploy + "; wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  std::ifstream log(up_log);
  std::stringstream ss;
  ss << log.rdbuf();
  INFO(r.output << "\n--- tandem up ---\n" << ss.str());
  for (const char* p : {"m1/world", "m1/supervisor", "m1/left", "m1/right"}) {
    CHECK(r.output.find(std::string("  ") + p) != std::string::npos);
  }
  CHECK(r.output.find(" active ") != std::string::npos);
  CHECK(r.output.find("remote: 'down' requested over DDS") != std::string::npos);  // the launcher's answer
  CHECK(r.output.find("up_rc=1") != std::string::npos);  // stopped before the task was done
  // Real time: the per-tick processes run SCHED_FIFO, or the launcher said why not.
  if (ss.str().find("SCHED_FIFO 20") != std::string::npos) {
    CHECK(r.output.find("world_cls=FF") != std::string::npos);
  } else {
    CHECK(ss.str().find("real-time priority 20 not permitted here") != std::string::npos);
    CHECK(r.output.find("world_cls=TS") != std::string::npos);
  }
  CHECK(ss.str().find("'down' requested over DDS") != std::string::npos);
  CHECK(ss.str().find("result: STOPPED") != std::string::npos);
  CHECK(ss.str().find("finalized") != std::string::npos);
  CHECK(ss.str().find("exited with code") == std::string::npos);  // every process stopped cleanly
  CHECK_FALSE(processes_left(domain));
  CHECK(shm_files() == shm_before);  // every participant removed its shared-memory files
}

TEST_CASE("a coordinator hands a task queue to four modules, which complete it", "[distributed]") {
  const int domain = test_domain(5);
  const std::string path = write_task_deployment("four", domain, 3, "  balance: wear\n", sosm_modules(4));
  const std::string summary = work_dir() + "/four.summary";
  const Run r = run(kBin + "/tandem up " + path + " --summary " + summary);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK(r.output.find("6/6 tasks done") != std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("coordinator.done") == 1);
  int modules_with_tasks = 0;
  for (int m = 1; m <= 4; ++m) {
    const std::string id = "m" + std::to_string(m);
    INFO(id);
    CHECK(kv.at(id + ".slip_events") == 0);
    CHECK(kv.at(id + ".contact_lost") == 0);
    CHECK(kv.at(id + "/left.min_normal_force") >= 19.62);
    CHECK(kv.at(id + "/right.min_normal_force") >= 19.62);
    // Every object rests at a task's end point: x is 0.0 or -0.2, y 0.8.
    const double x = kv.at(id + ".object_final0");
    CHECK((std::abs(x) < 1e-3 || std::abs(x + 0.2) < 1e-3));
    if (r.output.find(id + " did 0 task") == std::string::npos) ++modules_with_tasks;
  }
  CHECK(modules_with_tasks >= 3);  // the queue is spread over the modules, not run by one
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("SIGKILL of a primary robot: its hot standby takes over and nothing changes", "[distributed]") {
  const int domain = test_domain(6);
  const std::string deploy = write_deployment("standby", domain, "SOSM", "lockstep", 1, "", kCrashTransport, kill_scenario());
  const std::string summary = work_dir() + "/standby.summary";
  const std::string up_log = work_dir() + "/standby.log";
  const std::string cmd = kBin + "/tandem up " + deploy + " --summary " + summary + " > " + up_log +
                          " 2>&1 & up=$!; " + after_first_tick(up_log, 0.4) + kBin + "/tandem kill " + deploy +
                          " m1/left && echo killed; wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  std::ifstream log(up_log);
  std::stringstream ss;
  ss << log.rdbuf();
  INFO(r.output << "\n--- tandem up ---\n" << ss.str());
  REQUIRE(r.output.find("killed") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(ss.str().find("fault injection: SIGKILL m1/left") != std::string::npos);
  CHECK(ss.str().find("m1/left now follows m1/left@50") != std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 15000);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  CHECK(kv.at("m1.failovers") >= 1);
  // Typically the liveliness lease (20 ms) plus a little (21-24 ms in local runs); one CI run took 2 s
  // (open: docs/architecture.md, Hot standby). The bound here is the world's 10 s tick timeout, halved.
  CHECK(kv.at("m1.failover_max_ms") > 1.0);
  CHECK(kv.at("m1.failover_max_ms") < 5000.0);
  // The standby ran the same controller in shadow on the same inputs from tick 0 (the world's tick 0 waits for every
  // robot of each arm, world::LockstepPacer): the run is exactly the embedded one. (Before, a standby heard first
  // kept the primary in shadow, and one discovered at tick 1424 had another controller memory: 2% off.)
  const tandem::sim::CaseResult& e = embedded_sosm_15s();
  CHECK(kv.at("m1/left@50.ep_pos_rms") == Approx(e.robots[0].ep_pos_rms).epsilon(1e-12));
  CHECK(kv.at("m1/left@50.eh_rms") == Approx(e.robots[0].eh_rms).epsilon(1e-12));
  CHECK(kv.at("m1.object_final0") == Approx(e.final_state.c(0)).margin(1e-12));
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a recorded failover: the report marks it, and the standby's RMS from the recording equals its summary", "[distributed]") {
  const int domain = test_domain(22);
  const std::string deploy = write_deployment("recfail", domain, "SOSM", "lockstep", 1, "", kCrashTransport, kill_scenario());
  const std::string summary = work_dir() + "/recfail.summary";
  const std::string up_log = work_dir() + "/recfail.log";
  const std::string rec = work_dir() + "/recfail.mcap";
  const std::string report = work_dir() + "/recfail-report";
  const std::string cmd = kBin + "/tandem up " + deploy + " --summary " + summary + " --record " + rec + " > " + up_log +
                          " 2>&1 & up=$!; " + after_first_tick(up_log, 0.4) + kBin + "/tandem kill " + deploy +
                          " m1/left && echo killed; wait $up; echo up_rc=$?; " + kBin + "/tandem report " + rec +
                          " -o " + report + "; echo report_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file_text(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("killed") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  REQUIRE(r.output.find("report_rc=0") != std::string::npos);
  CHECK(log.find("0 tick(s) missed in 0 gap(s)") != std::string::npos);
  const auto kv = read_summary(summary);
  const auto rep = read_summary(report + "/summary.txt");
  // The standby commanded every tick in shadow and after: its RMS recomputed from the recorded commands is its own.
  CHECK(rep.at("robot.m1/left@50.ticks") == kv.at("m1/left@50.ticks"));
  CHECK(rep.at("robot.m1/left@50.ep_pos_rms") == Approx(kv.at("m1/left@50.ep_pos_rms")).epsilon(1e-9));
  CHECK(rep.at("robot.m1/left@50.eh_rms") == Approx(kv.at("m1/left@50.eh_rms")).epsilon(1e-9));
  // The killed primary's commands stop where it died: fewer ticks than the run's.
  CHECK(rep.at("robot.m1/left.ticks") < kv.at("m1.ticks"));
  CHECK(rep.at("sensors.m1/left.ticks") == kv.at("m1.ticks"));
  // The failover is an event of the recording, shown on the page and marked on the arm's plot.
  const std::string html = read_file_text(report + "/index.html");
  CHECK(html.find("<td>failover</td><td>m1</td><td>m1/left</td>") != std::string::npos);
  CHECK(read_file_text(report + "/robot_m1_left_error.svg").find("failover m1/left") != std::string::npos);
  CHECK_FALSE(processes_left(domain));
  CHECK(run("pgrep -f \"tandem [r]ecord .*recfail\"").exit_code != 0);  // the bracket: not pgrep itself
}

namespace {
// A copy of the paper's scenario that lasts 9 s instead of 5, so that a task paused for a few seconds still
// ends within the run.
std::string long_scenario() {
  std::string path = work_dir() + "/paper-9s.yaml";
  (void)std::system(("sed 's/^  duration: 5.0 /  duration: 9.0 /' " + kSrc + "/config/scenarios/paper.yaml > " + path).c_str());
  return path;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST_CASE("SIGKILL of the supervisor: its hot standby carries on with the same references", "[distributed]") {
  const int domain = test_domain(13);
  const std::string deploy =
      write_deployment("supstandby", domain, "SOSM", "lockstep", 0,
                       "    supervisor_standby: 1\n    restart: on-failure\n", kCrashTransport, kill_scenario());
  const std::string summary = work_dir() + "/supstandby.summary", up_log = work_dir() + "/supstandby.log";
  const std::string t = kBin + "/tandem ";
  const std::string cmd = t + "up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          after_first_tick(up_log, 0.4) + t + "kill " + deploy + " m1/supervisor; echo kill_rc=$?; wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(r.output.find("kill_rc=0") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("started m1/supervisor@50") != std::string::npos);
  CHECK(log.find("m1/supervisor exited with code 137; a standby supervisor carries on") != std::string::npos);
  CHECK(log.find("m1/supervisor@50: taking over in epoch 1") != std::string::npos);
  CHECK(log.find("restarting m1/supervisor") != std::string::npos);  // back as a standby (on-failure)
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 15000);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  CHECK(kv.at("m1.braked_ticks") == 0);  // the robots never lacked a reference long enough to be braked
  // The standby published the same references all along, and the robots went on with them: the run is
  // exactly the embedded one.
  const tandem::sim::CaseResult& e = embedded_sosm_15s();
  CHECK(kv.at("m1/left.ep_pos_rms") == Approx(e.robots[0].ep_pos_rms).epsilon(1e-12));
  CHECK(kv.at("m1/right.eh_rms") == Approx(e.robots[1].eh_rms).epsilon(1e-12));
  CHECK(kv.at("m1.object_final0") == Approx(e.final_state.c(0)).margin(1e-12));
  CHECK_FALSE(processes_left(domain));
}

// The supervisor failover tests (three back-and-forth tasks, six in all, one module): every task done once,
// the object held without braking, and no jump of the reference. Had the path of the supervisor that took over
// differed from the one before (another start tick or pose, a stale plan), the tracking on the
// position-controlled axes would show it: an undisturbed run of these tasks is about 5e-7 m RMS, a path 1 ms off
// about 2e-4 m. The last task brings the object back to (-0.2, 0.8).
namespace {
void check_six_tasks_held(const std::map<std::string, double>& kv) {
  CHECK(kv.at("coordinator.tasks_done") == 6);
  CHECK(kv.at("coordinator.duplicates") == 0);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  CHECK(kv.at("m1.braked_ticks") == 0);
  CHECK(kv.at("m1/left.min_normal_force") >= 19.62);
  CHECK(kv.at("m1/right.min_normal_force") >= 19.62);
  CHECK(kv.at("m1/left.ep_sel_rms") < 1e-5);
  CHECK(kv.at("m1/right.ep_sel_rms") < 1e-5);
  CHECK(kv.at("m1.object_final0") == Approx(-0.2).margin(1e-3));
  CHECK(kv.at("m1.object_final1") == Approx(0.8).margin(1e-3));
}
}  // namespace

TEST_CASE("the supervisor dies mid-task under a coordinator: the standby finishes the task from the same plan", "[distributed]") {
  const int domain = test_domain(14);
  // Three out-and-back pairs: a kill that reaches the launcher late (discovery of the `tandem kill` process
  // takes seconds on a busy machine) still lands while tasks remain.
  const std::string path = write_task_deployment("suptasks", domain, 3, "", sosm_modules(1, ", supervisor_standby: 1"), kCrashTransport);
  const std::string summary = work_dir() + "/suptasks.summary", up_log = work_dir() + "/suptasks.log";
  const std::string t = kBin + "/tandem ";
  // Killed while a task runs (the second, unless the kill is slow to arrive): the standby must know that
  // task, where and when it started.
  const std::string cmd = t + "up " + path + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          "for i in $(seq 400); do grep -q \"task back-0 -> m1\" " + up_log +
                          " && break; sleep 0.05; done; sleep 0.3; " + t + "kill " + path +
                          " m1/supervisor; echo kill_rc=$?; wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(r.output.find("kill_rc=0") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("m1/supervisor@50: taking over") != std::string::npos);
  CHECK(log.find("stepping down") == std::string::npos);  // no false takeover
  check_six_tasks_held(read_summary(summary));
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a supervisor stalled past its standby's takeover steps down when it comes back, and nothing jumps", "[distributed]") {
  const int domain = test_domain(15);
  const std::string path = write_task_deployment("supstall", domain, 3, "", sosm_modules(1, ", supervisor_standby: 1"), kCrashTransport);
  const std::string summary = work_dir() + "/supstall.summary", up_log = work_dir() + "/supstall.log";
  const std::string t = kBin + "/tandem ";
  // SIGSTOP of the leading supervisor for 0.4 s (lockstep runs a 1 s task in about 0.3 s), from mid-task: the standby takes over (epoch 1) and carries
  // the module through at least one task boundary (the coordinator's next task goes to it). Then SIGCONT:
  // the old leader comes back with a stale plan and its old epoch; it must step down and adopt the new plan,
  // and no robot may follow its stale references (they would move the object along another path).
  const std::string cmd = t + "up " + path + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          "for i in $(seq 400); do grep -q \"task back-0 -> m1\" " + up_log +
                          " && break; sleep 0.05; done; sleep 0.3; pid=$(pgrep -f \"tandem-[s]upervisor .*--domain " +
                          std::to_string(domain) + " .*--strength 100\"); echo pid=$pid; kill -STOP $pid; sleep 0.4; " +
                          "kill -CONT $pid; wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("pid=\n") == std::string::npos);  // the leader was found and stopped
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("m1/supervisor@50: taking over in epoch 1") != std::string::npos);
  CHECK(log.find("m1/supervisor: stepping down") != std::string::npos);
  check_six_tasks_held(read_summary(summary));
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a robot is restarted after a crash, and given up on after the intensity limit", "[distributed]") {
  const int domain = test_domain(7);
  // Real time: the run lasts at least its 5 s of simulated time, so both kills land mid-run.
  // Real time, 9 s: long enough for the restarted robot to start, be discovered and answer (1-4 s here).
  const std::string deploy = work_dir() + "/restarts.yaml";
  std::ofstream(deploy) << "name: restarts\ndomain_id: " << domain << "\ntransport: " << kCrashTransport
                        << "\ntimeout: 10\ntiming: realtime\nmodules:\n"
                        << "  - {name: m1, scenario: " << long_scenario() << ", case: SOSM, restart: on-failure,"
                        << " restart_limit: 1, restart_window: 60}\n";
  const std::string up_log = work_dir() + "/restarts.log";
  const std::string kill = kBin + "/tandem kill " + deploy + " ";
  const std::string cmd = kBin + "/tandem up " + deploy + " > " + up_log + " 2>&1 & up=$!; " + after_first_tick(up_log, 0.3) + kill +
                          "m1/left; for i in $(seq 200); do grep -q \"(restart)\" " + up_log +
                          " && break; sleep 0.05; done; for i in $(seq 200); do grep -q \"m1/left released\" " + up_log +
                          " && break; sleep 0.05; done; " + kill + "m1/left@50; wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  std::ifstream log(up_log);
  std::stringstream ss;
  ss << log.rdbuf();
  INFO(r.output << "\n--- tandem up ---\n" << ss.str());
  // The restarted robot joins as a standby (strength 50: below every live robot of the arm, none here); the
  // arm is braked meanwhile and the module paused, and it resumes when the new robot answers.
  CHECK(ss.str().find("restarting m1/left in 0.20 s") != std::string::npos);
  CHECK(ss.str().find("started m1/left@50") != std::string::npos);
  CHECK(ss.str().find("m1/left braked") != std::string::npos);
  CHECK(ss.str().find("m1/left released") != std::string::npos);
  CHECK(ss.str().find("giving up on m1/left: 1 restarts within 60 s") != std::string::npos);
  CHECK(r.output.find("up_rc=1") != std::string::npos);  // nobody serves the arm any more: the run fails
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("lockstep: both arms braked at once are released when their restarted robots answer", "[distributed]") {
  const int domain = test_domain(25);
  // No standby: both robots SIGKILLed at once brake both arms (no live controller after 1 s of waiting, then driven
  // to rest, ~0.15 s of ticks); both come back restarted 4 s later. One signal for both: two `tandem kill`s each
  // find the launcher on their own, up to 1 s apart, and with a short backoff the first robot was back before the
  // second arm stopped (no arm braked), with a long one the released arm ran the task out before the second robot
  // answered. With both arms braked a lockstep tick is complete at once, and the world once took no command then:
  // the new robots answered every tick, their commands piled up unread (the world's memory grew), and the arms
  // stayed braked. Braked, the world ticks at ~1 kHz (~4000 of the 20 s scenario's 20000 ticks).
  std::string scenario = work_dir() + "/paper-20s.yaml";
  (void)std::system(("sed 's/^  duration: 5.0 /  duration: 20.0 /' " + kSrc + "/config/scenarios/paper.yaml > " + scenario).c_str());
  const std::string deploy = write_deployment("bothbraked", domain, "SOSM", "lockstep", 0,
                                              "    restart: on-failure\n    restart_backoff: 4\n", kCrashTransport, scenario);
  const std::string summary = work_dir() + "/bothbraked.summary", up_log = work_dir() + "/bothbraked.log";
  const std::string cmd = kBin + "/tandem up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          after_first_tick(up_log, 0.3) + "pkill -9 -f \"tandem-[r]obot .*--domain " +
                          std::to_string(domain) + " \"; echo killed=$?; wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("killed=0") != std::string::npos);
  CHECK(log.find("m1/left braked") != std::string::npos);
  CHECK(log.find("m1/right braked") != std::string::npos);
  CHECK(log.find("m1/left released") != std::string::npos);
  CHECK(log.find("m1/right released") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 20000);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("lockstep over shared memory: robots plugged one after another into a running arm never stall the world's samples", "[distributed]") {
  const int domain = test_domain(27);
  // Fast DDS 2.9, data-sharing, reliable, volatile: a reader that matches while another's acknowledgement is being
  // processed can leave one change never reported acknowledged; the pool frees slots only in order behind it, and
  // ~260 writes later every write of that arm's samples failed, for good: the arm braked and stayed braked (soak
  // run 24, every module). Reproduced here by plugging a third to seventh reader (without the fix: 1 run in 3 failed
  // with three plugs, 2 in 3 with five);
  // dds::Writer clears the stuck history and writes again. Lockstep's samples go by the shared-memory transport
  // now (a killed reader could abort the world over data-sharing); a secured deployment keeps data-sharing, and
  // TANDEM_SENSORS_DATA_SHARING=1 asks for it here.
  std::string scenario = work_dir() + "/paper-40s.yaml";  // long enough for the five plugs on a busy machine
  (void)std::system(("sed 's/^  duration: 5.0 /  duration: 40.0 /' " + kSrc + "/config/scenarios/paper.yaml > " + scenario).c_str());
  const std::string deploy = write_deployment("plugthird", domain, "SOSM", "lockstep", 0, "", "shm", scenario);
  const std::string summary = work_dir() + "/plugthird.summary", up_log = work_dir() + "/plugthird.log";
  const std::string t = kBin + "/tandem ";
  std::string plugs;
  for (int i = 0; i < 5; ++i) plugs += t + "plug " + deploy + " robot m1/left --standby; sleep 1; ";
  // The world's sample writers really go by data-sharing here (they map its segments): otherwise this tests nothing.
  plugs += "echo ds_maps=$(grep -c fast_datasharing /proc/$(pgrep -f \"tandem-[w]orld .*--domain " +
           std::to_string(domain) + " \")/maps); ";
  const std::string cmd = "TANDEM_SENSORS_DATA_SHARING=1 " + t + "up " + deploy + " --summary " + summary + " > " +
                          up_log + " 2>&1 & up=$!; " + after_first_tick(up_log, 0.3) + plugs + "wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("plugged a robot into m1/left as a standby (ownership strength 46)") != std::string::npos);
  const auto ds = r.output.find("ds_maps=");
  REQUIRE(ds != std::string::npos);
  CHECK(std::atoi(r.output.c_str() + ds + 8) > 0);
  CHECK(log.find("was not written") == std::string::npos);
  CHECK(log.find("has no live controller") == std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 40000);
  CHECK(kv.at("m1.braked_ticks") == 0);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a restart still pending when the module's task ends is dropped, not waited for", "[distributed]") {
  const int domain = test_domain(16);
  // The primary robot is killed mid-run; its restart waits 60 s of backoff (the most the schema allows), far past the
  // end of the task (the standby carries on). When the world finishes, the launcher must drop the restart and end at
  // once. Judged from the kill, against the backoff: a busy machine stretches a lockstep task (CI, 2026-11-27: the
  // run took 31 s under the suite's -j2), which must not fail the test; waiting for the restart would.
  const std::string deploy = write_deployment("lateres", domain, "SOSM", "lockstep", 1,
                                              "    restart: on-failure\n    restart_backoff: 60\n", kCrashTransport,
                                              kill_scenario());
  const std::string summary = work_dir() + "/lateres.summary", up_log = work_dir() + "/lateres.log";
  const std::string t = kBin + "/tandem ";
  const std::string cmd = t + "up " + deploy + " --summary " + summary + " > " + up_log +
                          " 2>&1 & up=$!; " + after_first_tick(up_log, 0.4) + t + "kill " + deploy +
                          " m1/left; echo kill_rc=$?; killed=$(date +%s); wait $up; echo up_rc=$?; echo took=$(( $(date +%s) - killed ))";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("kill_rc=0") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("restarting m1/left in 60.00 s") != std::string::npos);
  CHECK(log.find("not restarting m1/left: module m1 is done with its task") != std::string::npos);
  const auto took = r.output.find("took=");
  REQUIRE(took != std::string::npos);
  CHECK(std::stoi(r.output.substr(took + 5)) < 55);  // before the 60 s backoff would have ended
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 15000);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a deployment with a bad configuration fails before anything starts", "[distributed]") {
  const int domain = test_domain(1);
  const std::string deploy = write_deployment("badcase", domain, "NoSuchCase");
  const Run r = run(kBin + "/tandem up " + deploy);
  INFO(r.output);
  CHECK(r.exit_code == 2);
  CHECK(r.output.find("badcase.yaml") != std::string::npos);
  CHECK(r.output.find("no case 'NoSuchCase'") != std::string::npos);
  CHECK(r.output.find("SOSM") != std::string::npos);  // lists the accepted cases
  CHECK(r.output.find("started") == std::string::npos);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a role process with a bad configuration exits with code 2 and a clear message", "[distributed]") {
  const Run r = run(kBin + "/tandem-robot --scenario " + kSrc + "/config/scenarios/paper.yaml --case SOSM --arm middle");
  CHECK(r.exit_code == 2);
  CHECK(r.output.find("unknown arm 'middle'") != std::string::npos);
  CHECK(r.output.find("left, right") != std::string::npos);
}


TEST_CASE("unplug without a standby pauses the module with the arm braked, and a plugged robot resumes it", "[distributed]") {
  const int domain = test_domain(10);
  const std::string scenario = long_scenario();
  const std::string deploy = work_dir() + "/unplug.yaml";
  std::ofstream(deploy) << "name: unplug\ndomain_id: " << domain << "\ntimeout: 10\ntiming: realtime\nmodules:\n"
                        << "  - {name: m1, scenario: " << scenario << ", case: SOSM}\n";
  const std::string summary = work_dir() + "/unplug.summary", up_log = work_dir() + "/unplug.log";
  const std::string t = kBin + "/tandem ";
  const std::string cmd =
      t + "up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; sleep 0.5; " +
      t + "plug " + deploy + " robot m1/nose; echo bad_arm_rc=$?; " +
      t + "unplug " + deploy + " robot m1/ghost; echo ghost_rc=$?; " +
      t + "unplug " + deploy + " robot m1/left; echo unplug_rc=$?; " +
      "for i in $(seq 100); do grep -q \"m1/left braked\" " + up_log + " && break; sleep 0.05; done; sleep 0.3; " +
      t + "plug " + deploy + " robot m1/left; echo plug_rc=$?; " +
      t + "plug " + deploy + " robot m1/left; echo twice_rc=$?; " +
      "wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(r.output.find("unplug_rc=0") != std::string::npos);
  CHECK(r.output.find("no standby for m1/left; pausing m1 first") != std::string::npos);
  // Bad requests are refused with the reason, and change nothing.
  CHECK(r.output.find("bad_arm_rc=1") != std::string::npos);
  CHECK(r.output.find("module m1 has no arm 'nose' (arms: left, right)") != std::string::npos);
  CHECK(r.output.find("ghost_rc=1") != std::string::npos);
  CHECK(r.output.find("plug_rc=0") != std::string::npos);
  CHECK(r.output.find("twice_rc=1") != std::string::npos);
  CHECK(r.output.find("the arm has a primary already") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("m1 paused; m1/left leaves") != std::string::npos);
  CHECK(log.find("m1/left released") != std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 9000);
  CHECK(kv.at("m1.braked_ticks") > 100);  // at least 0.1 s held by the brakes
  // The object was held (no slip, never let go). Safety, not progress: the resume is the release above, and how
  // long the module stays paused for load depends on what else the machine runs (a full suite run kept it paused
  // until the end of its 9 s, the object 3 mm from its start), so the object must stand on the task's path, between
  // the start (-0.2) and the goal (0.2), at its height.
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  CHECK(kv.at("m1.object_final0") >= -0.2 - 2e-3);
  CHECK(kv.at("m1.object_final0") <= 0.2 + 2e-3);
  CHECK(kv.at("m1.object_final1") == Approx(0.8).margin(2e-3));
  CHECK(kv.at("m1/right.min_normal_force") >= 19.62);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("unplug of a primary with a standby hands the arm over without braking", "[distributed]") {
  const int domain = test_domain(11);
  const std::string deploy = write_deployment("handover", domain, "SOSM", "realtime", 1);
  const std::string summary = work_dir() + "/handover.summary", up_log = work_dir() + "/handover.log";
  const std::string t = kBin + "/tandem ";
  const std::string cmd = t + "up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; sleep 1.5; " +
                          t + "unplug " + deploy + " robot m1/left; echo unplug_rc=$?; wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(r.output.find("unplug_rc=0") != std::string::npos);
  CHECK(r.output.find("another robot serves m1/left, handing over") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("m1/left now follows m1/left@50 (was m1/left): failover") != std::string::npos);
  const auto kv = read_summary(summary);
  const auto text = read_summary_text(summary);
  // No arm braked for the hand-over. A busy machine (the suite runs two tests at once) may pause the module for load,
  // which brakes both arms for every paused tick (the full test command of 2026-11-27: one 0.8 s pause, 1550 braked
  // arm-ticks): those are the load rule's, not the hand-over's.
  CHECK(kv.at("m1.braked_ticks") <= 2.0 * kv.at("m1.load_paused_ticks") + 2.0);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  // The leaving robot says so in its last command: the world follows the standby at once (a tick or two), not
  // after 10 silent ticks. The hand-over is the arm's last failover in the log. (A robot stalled 10 ms by the
  // machine is also failed over to its standby and takes the arm back: harmless, equal commands; every such
  // switch is in the summary, each within 15 ms, 50 ms if the module paused for load, and with the grasp held.)
  // Paused for load, the robots answer only the probe samples, one every 10 ticks (OverloadRule::probe_every): the
  // standby's next answer is up to 10 ms away, with both arms braked meanwhile (the full test command of 2026-11-27: 10.0 ms; CI of 2026-11-28: 23.4 ms,
  // a probe answered late on a loaded machine). While paused the arms are braked, so the gap costs the grasp nothing
  // (the slip and force checks above and below say so). The bound then: the 10 silent ticks of a failover plus two
  // probe periods (a probe missed, the next one answered) plus 20 ms for a loaded machine's wake-ups: 50 ms, which
  // still fails a hand-over that waits for the 10-tick silence and then for a late probe or two.
  const bool paused = kv.at("m1.load_paused_ticks") > 0;
  const std::string key = "m1/left now follows m1/left@50 (was m1/left): failover ";
  const size_t at = log.rfind(key);
  REQUIRE(at != std::string::npos);
  CHECK(std::stod(log.substr(at + key.size())) < (paused ? 50.0 : 5.0));
  const std::vector<double> gaps = parse_list(text.at("m1.switch_gap_ms"));
  REQUIRE(!gaps.empty());
  for (double g : gaps) CHECK(g < (paused ? 50.0 : 15.0));
  for (double h : parse_list(text.at("m1.switch_hn_min"))) CHECK(h >= 19.62);
  // The standby computed every tick, but those a load pause sent no sample for (robots answer only the probes then:
  // the full test command of 2026-11-27 paused the module at tick 4412 to the end, and the standby computed 4991).
  CHECK(kv.at("m1/left@50.ticks") <= 5000);
  CHECK(kv.at("m1/left@50.ticks") >= 5000 - kv.at("m1.load_paused_ticks"));
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("tandem down with a robot that cannot stop: the launcher SIGKILLs it 5 s after SIGTERM and leaves nothing", "[distributed]") {
  const int domain = test_domain(17);
  const std::string deploy = write_deployment("stuck", domain, "SOSM", "realtime", 0, "", kCrashTransport);
  const std::string up_log = work_dir() + "/stuck.log";
  const std::string t = kBin + "/tandem ";
  // SIGSTOP the right robot (a stopped process cannot act on SIGTERM), then ask for a clean stop. Whatever
  // happens, the stopped robot is woken and killed at the end so that no test leaves it behind.
  const std::string cmd = t + "up " + deploy + " > " + up_log + " 2>&1 & up=$!; sleep 1.5; " +
                          "pid=$(pgrep -f \"tandem-[r]obot .*--domain " + std::to_string(domain) +
                          " .*--arm right\"); echo pid=$pid; kill -STOP $pid; sleep 0.3; " +
                          "t0=$(date +%s%N); " + t + "down " + deploy + "; echo down_rc=$?; " +
                          // While it waits for the stuck robot, the launcher still answers live commands.
                          "(" + t + "down " + deploy + "; echo down2_rc=$?) & (" + t + "plug " + deploy +
                          " robot m1/left --standby; echo late_rc=$?) & wait %2 %3; wait $up; echo up_rc=$?; " +
                          "echo took_ms=$(( ($(date +%s%N) - t0) / 1000000 )); " +
                          "if kill -0 $pid 2>/dev/null; then echo robot_left; kill -CONT $pid; kill -KILL $pid; fi";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("pid=\n") == std::string::npos);  // the robot was found and stopped
  CHECK(r.output.find("down_rc=0") != std::string::npos);
  CHECK(r.output.find("up_rc=1") != std::string::npos);  // stopped before its task was done
  CHECK(log.find("1 process(es) did not stop within 5 s; sending SIGKILL") != std::string::npos);
  CHECK(log.find("result: STOPPED") != std::string::npos);
  CHECK(r.output.find("robot_left") == std::string::npos);
  CHECK(r.output.find("down2_rc=0") != std::string::npos);
  CHECK(r.output.find("the deployment is already stopping") != std::string::npos);
  CHECK(r.output.find("late_rc=1") != std::string::npos);
  CHECK(r.output.find("'plug robot m1/left' refused: the deployment is stopping") != std::string::npos);
  // The escalation waits its 5 s, and not much more.
  const auto at = r.output.find("took_ms=");
  REQUIRE(at != std::string::npos);
  const long took = std::stol(r.output.substr(at + 8));
  CHECK(took >= 4500);
  CHECK(took < 12000);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a module whose world never ticks is restarted with new processes after start_timeout, with the same numbers", "[distributed]") {
  // The world is stopped (SIGSTOP) as soon as it exists, before it can match anyone: its module never ticks, as
  // when a pair of secured participants never authenticates. The launcher restarts the module once the limit is
  // past (max(start_timeout, timeout / 2 + 2 s) = 7 s here), and the new processes run the task from the start.
  const int domain = test_domain(19);
  const std::string deploy = write_deployment("startfix", domain, "SOSM", "lockstep", 0, "start_timeout: 2\n", kCrashTransport);
  const std::string up_log = work_dir() + "/startfix.log";
  const std::string summary = work_dir() + "/startfix.summary";
  const std::string cmd = kBin + "/tandem up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          "for i in $(seq 2000); do pid=$(pgrep -f \"tandem-[w]orld .*--domain " + std::to_string(domain) +
                          " \"); [ -n \"$pid\" ] && break; sleep 0.002; done; kill -STOP $pid; echo pid=$pid; " +
                          "wait $up; echo up_rc=$?; if kill -0 $pid 2>/dev/null; then echo world_left; kill -CONT $pid; kill -KILL $pid; fi";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("pid=\n") == std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(r.output.find("world_left") == std::string::npos);
  CHECK(log.find("module m1 did not come up (its world did not tick within 7.0 s of its start); restarting the module "
                 "with new participants (repair 1 of at most 3)") != std::string::npos);
  const auto kv = read_summary(summary);
  REQUIRE(kv.count("start_repairs") == 1);
  CHECK(kv.at("start_repairs") == 1);
  REQUIRE(kv.count("m1.ticks") == 1);
  CHECK(kv.at("m1.ticks") == 5000);
  const tandem::sim::CaseResult& e = embedded_sosm();
  CHECK(kv.at("m1/left.ep_pos_rms") == Approx(e.robots[0].ep_pos_rms).epsilon(1e-12));
  CHECK(kv.at("m1/right.eh_rms") == Approx(e.robots[1].eh_rms).epsilon(1e-12));
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a world stalled for 0.4 s re-anchors its clock instead of a catch-up burst, and the grasp holds", "[distributed]") {
  const int domain = test_domain(18);
  const std::string deploy = write_deployment("wstall", domain, "SOSM", "realtime", 0, "", kCrashTransport);
  const std::string summary = work_dir() + "/wstall.summary", up_log = work_dir() + "/wstall.log";
  const std::string t = kBin + "/tandem ";
  // The simulated plant itself stops mid-task (as a long scheduler stall would stop it). Caught up in a burst,
  // 400 ticks would be simulated back to back on torques computed for the tick before the stall.
  const std::string cmd = t + "up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          stall_mid_task(up_log, "tandem-[w]orld .*--domain " + std::to_string(domain) + " ", 0.4) +
                          "wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("pid=\n") == std::string::npos);  // the world was found and stopped
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 5000);
  // The stall was seen, and the clock re-anchored once: a catch-up would start each of the ~400 ticks of the
  // burst more than half a period late (an overrun each; measured with re-anchoring removed: 550 and 622
  // overruns, and in one of those two runs 742 slips and the grasp lost). Scheduler noise adds 5-50 here.
  CHECK(kv.at("m1.overruns") >= 1);
  CHECK(kv.at("m1.overruns") < 250);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  CHECK(kv.at("m1/left.min_normal_force") >= 19.62);
  CHECK(kv.at("m1/right.min_normal_force") >= 19.62);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a robot that hears no sample for 1 s while its module's plan comes gets a new sensor reader, and serves on", "[distributed]") {
  const int domain = test_domain(24);
  const std::string deploy = write_deployment("renew", domain, "SOSM", "realtime", 0, "", "shm");
  const std::string summary = work_dir() + "/renew.summary", up_log = work_dir() + "/renew.log";
  const std::string t = kBin + "/tandem ";
  // The world stands still for 1.6 s (SIGSTOP): its robots hear no sample while the supervisor's plan (a 20 ms
  // heartbeat) still comes, which is what a reader that Fast DDS stopped feeding looks like from the robot.
  const std::string cmd = t + "up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          stall_mid_task(up_log, "tandem-[w]orld .*--domain " + std::to_string(domain) + " ", 1.6) +
                          "wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("pid=\n") == std::string::npos);  // the world was found and stopped
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("m1/left: no sample for 1.") != std::string::npos);
  CHECK(log.find("m1/right: no sample for 1.") != std::string::npos);
  CHECK(log.find("a new sensor reader (1 so far)") != std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 5000);
  // Both robots answered on through their new readers (renewed near tick 800), and the grasp held. Not "to the last
  // tick": on a busy machine the world may pause for load near the end and finish its last ticks braked, with the
  // robots already stopped (seen once in the full test command: a pause at tick 4716, robots at 4991).
  CHECK(kv.at("m1/left.ticks") >= 4500);
  CHECK(kv.at("m1/right.ticks") >= 4500);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(kv.at("m1.contact_lost") == 0);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("a robot that stood still itself does not take its own silence for a deaf reader", "[distributed]") {
  const int domain = test_domain(26);
  const std::string deploy = write_deployment("selfstall", domain, "SOSM", "realtime", 1, "", "shm");
  const std::string summary = work_dir() + "/selfstall.summary", up_log = work_dir() + "/selfstall.log";
  const std::string t = kBin + "/tandem ";
  // The left arm's standby stands still for 1.5 s (SIGSTOP) while the module goes on: when it continues, the
  // samples of the meantime are gone, but its reader is fine; it must not replace it.
  const std::string cmd = t + "up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          stall_mid_task(up_log, "tandem-[r]obot .*--domain " + std::to_string(domain) + " .*--arm left --strength 50", 1.5) +
                          "wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  REQUIRE(r.output.find("pid=\n") == std::string::npos);  // the standby was found and stopped
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("a new sensor reader") == std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 5000);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("tandem up --check estimates the real-time load and warns when the machine is too small", "[distributed]") {
  const int domain = test_domain(20);
  const std::string big = work_dir() + "/capacity.yaml";
  std::ofstream f(big);
  f << "name: capacity\ndomain_id: " << domain << "\ntiming: realtime\nmodules:\n";
  for (int m = 1; m <= 100; ++m) {  // 100 modules: about 20 cores
    f << "  - {name: m" << m << ", scenario: " << kSrc << "/config/scenarios/paper.yaml, case: SOSM}\n";
  }
  f.close();
  const Run r = run(kBin + "/tandem up " + big + " --check");
  INFO(r.output);
  CHECK(r.exit_code == 0);
  CHECK(r.output.find("100 module(s)") != std::string::npos);
  // The estimate is calibrated on this machine (its figures are printed), and the total is the per-module
  // figure times 100 (no standbys here).
  const auto need_at = r.output.find("warning: this deployment needs about ");
  REQUIRE(need_at != std::string::npos);
  const double need = std::atof(r.output.c_str() + need_at + std::strlen("warning: this deployment needs about "));
  const auto per_at = r.output.find(" cores in real time (");
  REQUIRE(per_at != std::string::npos);
  const double per_module = std::atof(r.output.c_str() + per_at + std::strlen(" cores in real time ("));
  CHECK(per_module > 0.02);
  CHECK(per_module < 2.0);
  CHECK(need == Approx(100.0 * per_module).epsilon(0.01));
  CHECK(r.output.find("calibrated here: wake-up ") != std::string::npos);
  CHECK(r.output.find("expect modules to pause for load") != std::string::npos);
  CHECK(r.output.find("started") == std::string::npos);
  const Run small = run(kBin + "/tandem up " + kSrc + "/deploy/one-module-realtime.yaml --check");
  INFO(small.output);
  CHECK(small.exit_code == 0);
  CHECK(small.output.find("calibrated here: wake-up ") != std::string::npos);
  // One module needs its per-module figure. On a quiet machine that fits (about 0.6 core); the calibration measures
  // the machine as it is, and a busy one (the suite runs two tests at once) once measured 0.78 per module: said as
  // a fit or as a warning, never both, and the same figure either way.
  const size_t per = small.output.find(" per module");
  REQUIRE(per != std::string::npos);
  const size_t open = small.output.rfind('(', per);
  REQUIRE(open != std::string::npos);
  const double small_per_module = std::atof(small.output.c_str() + open + 1);
  CHECK(small_per_module > 0.02);
  CHECK(small_per_module < 2.0);
  const bool fits = small.output.find("real time: about ") != std::string::npos;
  CHECK(fits != (small.output.find("warning") != std::string::npos));
  const size_t about = fits ? small.output.find("real time: about ") + std::strlen("real time: about ")
                            : small.output.find("needs about ") + std::strlen("needs about ");
  CHECK(std::atof(small.output.c_str() + about) == Approx(small_per_module).margin(0.006));
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("with a discovery server the launcher, the CLI and a restarted robot all find each other", "[distributed]") {
  const int domain = test_domain(21);
  const std::string deploy = write_deployment("dserver", domain, "SOSM", "lockstep", 1,
                                              "    restart: on-failure\n", kCrashTransport, kill_scenario());
  std::ofstream(deploy, std::ios::app) << "discovery: server\n";
  const std::string summary = work_dir() + "/dserver.summary", up_log = work_dir() + "/dserver.log";
  const std::string t = kBin + "/tandem ";
  const std::string port = std::to_string(11811 + domain);
  const std::string cmd = t + "up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          after_first_tick(up_log, 0.3) + t + "status " + deploy + "; " + t + "kill " + deploy +
                          " m1/left; echo kill_rc=$?; wait $up; echo up_rc=$?; " +
                          "pgrep -f \"fast-discovery-serve[r] .* -p " + port + "\" && echo server_left";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(log.find("started discovery server") != std::string::npos);
  CHECK(r.output.find("m1/left@50") != std::string::npos);  // tandem status heard the standby through the server
  CHECK(r.output.find("kill_rc=0") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("m1/left now follows m1/left@50") != std::string::npos);
  CHECK(log.find("restarting m1/left") != std::string::npos);
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.ticks") == 15000);
  CHECK(kv.at("m1.slip_events") == 0);
  CHECK(r.output.find("server_left") == std::string::npos);  // the launcher stopped its server
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("both cores loaded mid-task: the modules pause for load with the object held, and resume", "[distributed]") {
  const int domain = test_domain(8);
  const std::string deploy = work_dir() + "/overload.yaml";
  // Normal scheduling for the modules (where 5 late ticks in a row also happen now and then without the hog:
  // a pause for load more), so that four busy processes (two per core, 2 s of the motion, each in a session of its
  // own at niceness -5: at 0 they no longer starve robots that have scheduling groups of their own, see
  // launcher/sched_group.hpp) starve their robots: commands come late, each module holds the object still, brakes both arms,
  // sheds its load, and resumes when a full-rate trial shows its robots keep up again.
  std::ofstream(deploy) << "name: overload\ndomain_id: " << domain << "\ntransport: shm\ntiming: realtime\n"
                        << "realtime_priority: 0\ntimeout: 20\nmodules:\n"
                        << "  - {name: m1, scenario: " << kill_scenario() << ", case: SOSM}\n"
                        << "  - {name: m2, scenario: " << kill_scenario() << ", case: SOSM}\n";
  const std::string summary = work_dir() + "/overload.summary", up_log = work_dir() + "/overload.log";
  const std::string cmd = kBin + "/tandem up " + deploy + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          after_first_tick(up_log, 1.5) + kBin + "/tandem_hog --cores 4 --busy 1000 --idle 0 --seconds 2 --nice -5; " +
                          "wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("stopping the path, the brakes follow once the object is still") != std::string::npos);
  CHECK(log.find("paused for load") != std::string::npos);
  // Recovery is tried, not promised: a module resumes only after a full-rate trial in which its robots kept up,
  // and on a machine busy with something else (CI, 2026-11-27: no "back in time" within the 15 s) every trial
  // may fail. So: it resumed, or it tried to (a trial ended "still overloaded" and backed off).
  const bool resumed = log.find("back in time") != std::string::npos;
  const bool tried = log.find("still overloaded: ") != std::string::npos;
  CHECK((resumed || tried));
  const auto kv = read_summary(summary);
  CHECK(kv.at("m1.load_pauses") + kv.at("m2.load_pauses") >= 1);
  for (const char* m : {"m1", "m2"}) {
    INFO(m);
    const std::string id(m);
    CHECK(kv.at(id + ".ticks") == 15000);
    CHECK(kv.at(id + ".slip_events") == 0);
    CHECK(kv.at(id + ".contact_lost") == 0);
    // Safety, not progress: how long the pauses last depends on what else the machine runs (a suite run beside
    // another process kept a module paused past the end of its 15 s), so the object need not reach its goal
    // (0.2, 0.8); it must stand on the task's path, between the start (-0.2) and the goal, at its height.
    CHECK(kv.at(id + ".object_final0") >= -0.2 - 2e-3);
    CHECK(kv.at(id + ".object_final0") <= 0.2 + 2e-3);
    CHECK(kv.at(id + ".object_final1") == Approx(0.8).margin(2e-3));
  }
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("an unplugged module whose task cannot end is stopped after the drain bound, and its task is done elsewhere", "[distributed]") {
  // m1's only left robot is killed mid-task (no standby, no restart): the world drives that arm to rest and brakes
  // it, and m1's task stays paused. An unplug of m1 asks for a drain that cannot end; 30 s later the launcher
  // stops m1 with its task unfinished, and the coordinator gives that task to m2. No task lost, none done twice.
  // Two tasks of 8 s each: lockstep ran the 1 s tasks this test once had in about 0.3 s, and in a CI run the kill,
  // which first has to discover the launcher, landed after m1's task had ended (m2 then did every task, the
  // deployment ended, and the unplug found no running m1).
  const int domain = test_domain(23);
  const std::string path = write_task_deployment("drainbound", domain, 1, "", sosm_modules(2), kCrashTransport, 8.0);
  const std::string summary = work_dir() + "/drainbound.summary", up_log = work_dir() + "/drainbound.log";
  const std::string t = kBin + "/tandem ";
  const std::string cmd = t + "up " + path + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          "for i in $(seq 200); do grep -q \"task .* -> m1\" " + up_log + " && break; sleep 0.05; done; " +
                          // Mid-task: after m1's first tick (a robot killed before it leaves the module waiting at
                          // tick 0, which the launcher repairs by a restart: another path, seen in a full run).
                          "for i in $(seq 200); do grep -q \"tandem-world m1: first tick\" " + up_log +
                          " && break; sleep 0.05; done; " +
                          t + "kill " + path + " m1/left; echo kill_rc=$?; " +
                          "for i in $(seq 100); do grep -q \"m1/left braked\" " + up_log + " && break; sleep 0.05; done; " +
                          t + "unplug " + path + " module m1; echo unplug_rc=$?; " +
                          "wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(r.output.find("kill_rc=0") != std::string::npos);
  CHECK(r.output.find("unplug_rc=0") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("module m1 did not drain within 30 s (its task state: draining)") != std::string::npos);
  CHECK(log.find("module m1 drained") == std::string::npos);
  CHECK(log.find("m1 finished task") == std::string::npos);  // the kill landed mid-task
  const auto kv = read_summary(summary);
  const auto text = read_summary_text(summary);
  CHECK(kv.at("forced_drains") == 1);
  CHECK(kv.at("coordinator.tasks_done") == 2);
  CHECK(kv.at("coordinator.duplicates") == 0);
  CHECK(text.at("m1.end") == "unplugged");
  CHECK(text.at("m2.end") == "ran");
  // The object was held throughout, on both modules (m1's braked, m2's moving).
  for (const char* m : {"m1", "m2"}) {
    INFO(m);
    CHECK(kv.at(std::string(m) + ".slip_events") == 0);
    CHECK(kv.at(std::string(m) + ".contact_lost") == 0);
  }
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("four modules: the coordinator is killed, one module killed and one unplugged, and every task is done once", "[distributed]") {
  const int domain = test_domain(12);
  const std::string path = write_task_deployment("live4", domain, 16, "  standby: 1\n", sosm_modules(4), kCrashTransport);
  const std::string summary = work_dir() + "/live4.summary", up_log = work_dir() + "/live4.log";
  const std::string t = kBin + "/tandem ";
  const std::string cmd = t + "up " + path + " --summary " + summary + " > " + up_log + " 2>&1 & up=$!; " +
                          "for i in $(seq 200); do grep -q \"task .* -> m2\" " + up_log + " && break; sleep 0.05; done; " +
                          t + "kill " + path + " coordinator; echo kill_coord_rc=$?; " +
                          t + "kill " + path + " m2; echo kill_module_rc=$?; " +
                          t + "unplug " + path + " module m3; echo unplug_rc=$?; " +
                          t + "unplug " + path + " module m9; echo unplug_bad_rc=$?; " +
                          "wait $up; echo up_rc=$?";
  const Run r = run("bash -c '" + cmd + "'");
  const std::string log = read_file(up_log);
  INFO(r.output << "\n--- tandem up ---\n" << log);
  CHECK(r.output.find("kill_coord_rc=0") != std::string::npos);
  CHECK(r.output.find("kill_module_rc=0") != std::string::npos);
  CHECK(r.output.find("unplug_rc=0") != std::string::npos);
  CHECK(r.output.find("unplug_bad_rc=1") != std::string::npos);
  CHECK(r.output.find("up_rc=0") != std::string::npos);
  CHECK(log.find("taking over with") != std::string::npos);  // the standby coordinator carried on
  CHECK(log.find("module m2 failed") != std::string::npos);
  CHECK(log.find("module m3 drained") != std::string::npos);
  const auto kv = read_summary(summary);
  const auto text = read_summary_text(summary);
  // No task lost, none done twice, although the coordinator and a module with a task died. (32 tasks: lockstep
  // runs a 1 s task in about 0.3 s, and the three live commands, one after the other, must land mid-run.)
  CHECK(kv.at("coordinator.tasks_done") == 32);
  CHECK(kv.at("coordinator.duplicates") == 0);
  CHECK(text.at("m2.end") == "failed");
  CHECK(text.at("m3.end") == "unplugged");
  for (const char* m : {"m1", "m4"}) {
    INFO(m);
    CHECK(text.at(std::string(m) + ".end") == "ran");
    CHECK(kv.at(std::string(m) + ".slip_events") == 0);
    CHECK(kv.at(std::string(m) + ".contact_lost") == 0);
  }
  // The drained module finished its task before it left: its object rests at a task's end point.
  const double x3 = kv.at("m3.object_final0");
  CHECK((std::abs(x3) < 1e-3 || std::abs(x3 + 0.2) < 1e-3));
  CHECK_FALSE(processes_left(domain));
}

TEST_CASE("every shipped deployment file loads, and bad live-replacement keys are refused by name", "[deployment]") {
  for (const char* f : {"one-module", "one-module-realtime", "four-modules", "live-modules", "three-hosts"}) {
    INFO(f);
    const auto d = tandem::runtime::load_deployment(kSrc + "/deploy/" + f + ".yaml");
    CHECK_FALSE(d.modules.empty());
  }
  const auto live = tandem::runtime::load_deployment(kSrc + "/deploy/live-modules.yaml");
  CHECK(live.coordinator_standby == 1);
  CHECK(live.coordinator_restart == "on-failure");
  REQUIRE(tandem::runtime::find_module(live, "m3") != nullptr);
  CHECK_FALSE(tandem::runtime::find_module(live, "m3")->autostart);
  CHECK(tandem::runtime::find_module(live, "m1")->standby == 1);
  CHECK(tandem::runtime::find_module(live, "m1")->supervisor_standby == 1);
  CHECK(tandem::runtime::find_module(live, "nope") == nullptr);
  auto refused = [](const std::string& body, const std::string& expect) {
    const std::string path = work_dir() + "/bad-deploy.yaml";
    std::ofstream(path) << "name: bad\ndomain_id: 5\n" << body;
    try {
      (void)tandem::runtime::load_deployment(path);
      FAIL("accepted: " << body);
    } catch (const std::exception& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find(expect) != std::string::npos);
    }
  };
  const std::string mod = "modules:\n  - {name: m1, scenario: " + kSrc + "/config/scenarios/paper.yaml, case: SOSM";
  refused(mod + ", restart_as: leader}\n", "restart_as");
  refused("realtime_priority: 99\n" + mod + "}\n", "realtime_priority");
  refused("spin_limit: 1.5\n" + mod + "}\n", "spin_limit");
  refused(mod + ", supervisor_standby: 4}\n", "supervisor_standby");
  refused(mod + ", autostart: maybe}\n", "autostart");
  refused(mod + "}\ncoordinator:\n  standby: 9\n  tasks:\n    - {name: a, segments: [{to: [0.0, 0.8, 0.0], duration: 1.0}]}\n",
          "standby");
  refused(mod + "}\ncoordinator:\n  tasks:\n    - {name: a, segments: [{to: [0.0, 0.8, 0.0], duration: 1.0}]}\n"
                "    - {name: a, segments: [{to: [-0.2, 0.8, 0.0], duration: 1.0}]}\n",
          "task names must be unique");
}

TEST_CASE("a task assignment withdrawn by the coordinator is not handed to a supervisor that joins later but one kept is",
          "[distributed]") {
  // The coordinator keeps the last assignment per module (transient-local) for a supervisor that joins late, and
  // disposes of it when the module leaves or fails (CoordinatorAction::Withdraw): a module plugged back after its
  // drain ran its last task again otherwise (soak run 53). Real participants in this process, over UDP.
  namespace bus = tandem::dds;
  const int domain = test_domain(41);
  bus::Participant coord(domain, "test-coordinator", bus::Transport::Udp);
  bus::Writer<tandem::msg::TaskAssignment, tandem::msg::TaskAssignmentPubSubType> w(coord, bus::kTaskAssignmentTopic,
                                                                                    bus::TopicKind::Task);
  for (const char* m : {"m1", "m2"}) {
    tandem::msg::TaskAssignment a;
    a.module_id(m);
    a.task_id(m[1] == '1' ? 7 : 8);
    a.task_name("t");
    REQUIRE(w.write(a));
  }
  tandem::msg::TaskAssignment key;
  key.module_id("m1");
  REQUIRE(w.dispose(key));
  bus::Participant late(domain, "test-supervisor", bus::Transport::Udp);
  bus::Reader<tandem::msg::TaskAssignment, tandem::msg::TaskAssignmentPubSubType> r(late, bus::kTaskAssignmentTopic,
                                                                                    bus::TopicKind::Task);
  std::map<std::string, unsigned long long> got;
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(3)) {
    (void)r.wait(0.1);
    tandem::msg::TaskAssignment a;
    while (r.take(a)) got[a.module_id()] = a.task_id();
    if (got.count("m2") != 0 && std::chrono::steady_clock::now() - t0 > std::chrono::milliseconds(500)) break;
  }
  CHECK(got.count("m2") == 1);
  if (got.count("m2") == 1) CHECK(got.at("m2") == 8);
  CHECK(got.count("m1") == 0);
}
