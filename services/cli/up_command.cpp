// `tandem up`: starts a deployment as separate processes (world, supervisor and robots per module, and the
// coordinator) that talk only over Fast DDS, supervises them, serves live commands, and ends with a summary.
// Ctrl-C / SIGTERM stops every child; no child outlives the launcher (PR_SET_PDEATHSIG), every child is reaped.
//
// The launcher is the deployment's supervisor (DESIGN.md, failure tiers 2 and 3): it restarts robots and
// coordinators by policy (intensity limit, doubling backoff) and gives up on one that keeps failing; with a
// coordinator, a module whose world or supervisor dies is failed and stopped while the others go on (the
// coordinator re-plans its task). Live commands arrive over DDS (tandem plug/unplug/kill/down) and are
// carried out here: docs/failure-model.md. The supervision itself is launcher::Supervisor (services/launcher:
// events in, actions out); this file wires it to DDS, to the processes and to the clock.
#include "up_command.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <tandemPubSubTypes.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "live_view.hpp"
#include "tandem/launcher/estimate.hpp"
#include "tandem/launcher/helper_process.hpp"
#include "tandem/launcher/drain_watch.hpp"
#include "tandem/launcher/spawn.hpp"
#include "tandem/launcher/supervisor.hpp"
#include "tandem/dds/bus.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/security.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/shm_clean.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::cli {
using runtime::Deployment;
using runtime::load_deployment;
namespace {

namespace bus = tandem::dds;
using Clock = std::chrono::steady_clock;
using launcher::Child;

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop = true; }

/// What the capacity estimate needs of the deployment (its first module is built from its scenario when timed).
launcher::LoadSpec load_of(const Deployment& d) {
  launcher::LoadSpec l;
  l.realtime = d.timing == "realtime";
  l.overload_brake = d.overload_brake;
  l.simple_discovery = d.discovery == "simple";
  for (const auto& m : d.modules) l.standbys.push_back(m.standby);
  if (!d.modules.empty()) {
    const runtime::ModuleDeployment first = d.modules.front();
    l.first_module = [first]() -> std::optional<sim::ModuleSetup> {
      const sim::Scenario sc = sim::load_scenario(first.scenario);
      for (const auto& c : sc.cases) {
        if (c.name == first.case_name) return sim::make_module(sc, c);
      }
      return std::nullopt;
    };
  }
  return l;
}

/// The supervisor's view of the deployment (`file` as given, absolute with hosts; `run`: this launcher's run).
launcher::SupervisorConfig supervisor_config(const Deployment& d, const std::string& file, unsigned long long run) {
  launcher::SupervisorConfig cfg;
  cfg.deployment = d.name;
  cfg.deployment_file = file;
  cfg.coordinated = d.coordinator;
  cfg.coordinator_standby = d.coordinator_standby;
  cfg.coordinator_restart = launcher::RestartRule{d.coordinator_restart, d.coordinator_restart_limit,
                                                  d.coordinator_restart_window, 0.2};
  cfg.timeout = d.timeout;
  cfg.start_timeout = d.start_timeout;
  for (const auto& h : d.hosts) cfg.hosts.push_back(h.name);
  cfg.host_timeout = d.host_timeout;
  cfg.run = run;
  // Participant ids for children, the one left longest ago first: 20-119 (0-19 stay for Fast DDS's own choice:
  // the launcher, `tandem status` and other tools).
  cfg.end_participant_id = static_cast<int>(bus::kMaxParticipantId);
  return cfg;
}

/// Tasks a coordinator's queue state lists as done (its compact done-set).
size_t done_in(const msg::CoordinatorState& cs) {
  return static_cast<size_t>(std::count_if(cs.done_by().begin(), cs.done_by().end(), [](uint8_t b) { return b != 0; }));
}

/// Starts a process on this machine (launcher::spawn); with rt_priority > 0 the child runs SCHED_FIFO at that
/// priority, and so do the threads it creates (Fast DDS's receive and event threads inherit it).
pid_t spawn(const std::string& exe, const std::vector<std::string>& args, int rt_priority = 0,
            int participant_id = -1, const std::string& identity = "", bool own_group = true) {
  return launcher::spawn("tandem up", exe, args, launcher::SpawnOptions{rt_priority, participant_id, identity, own_group});
}

/// A module of the deployment (or plugged from a scenario) as the supervisor runs it: its scenario read once.
launcher::ModuleSpec module_spec(const runtime::ModuleDeployment& cfg, bool* case_found = nullptr) {
  launcher::ModuleSpec s;
  s.name = cfg.name;
  s.scenario = cfg.scenario;
  s.case_name = cfg.case_name;
  s.standby = cfg.standby;
  s.supervisor_standby = cfg.supervisor_standby;
  s.restart = launcher::RestartRule{cfg.restart, cfg.restart_limit, cfg.restart_window, cfg.restart_backoff};
  s.restart_as_standby = cfg.restart_as == "standby";
  const sim::Scenario sc = sim::load_scenario(cfg.scenario);
  bool found = false;
  for (const auto& c : sc.cases) {
    if (c.name == cfg.case_name) {
      s.h_sg = sim::make_module(sc, c).safe_grasp_force;
      found = true;
    }
  }
  for (const auto& r : sc.robots) s.robots.push_back(r.name);
  if (case_found != nullptr) *case_found = found;
  return s;
}

/// How a child is started, from the deployment: its executable, arguments, host, DDS-Security identity and
/// scheduling.
class CommandLines {
 public:
  CommandLines(const Deployment& d, std::string file) : d_(d), file_(std::move(file)), dir_(launcher::self_dir()) {
    for (const auto& m : d.modules) modules_[m.name] = m;
  }
  void add(const runtime::ModuleDeployment& m) { modules_[m.name] = m; }
  const std::string& dir() const { return dir_; }

  std::string exe(const Child& c) const { return dir_ + "/tandem-" + c.role; }
  std::vector<std::string> args(const Child& c) const {
    if (c.role == "coordinator") {
      std::vector<std::string> a{"--deployment-file", file_, "--domain", std::to_string(d_.domain_id), "--timeout",
                                 std::to_string(std::max(30.0, 3 * d_.timeout)), "--id", c.label};
      if (c.standby) a.push_back("--standby");
      if (c.resume) a.push_back("--resume");
      return a;
    }
    const runtime::ModuleDeployment& m = modules_.at(c.module);
    std::vector<std::string> a = common_args(m);
    if (c.role == "world") {
      // On several hosts the world also waits for every robot of each arm (standbys included) before its first
      // tick: the primaries' host may answer later than a standby's, and the arms would start braked. (With a
      // recorder common_args counts them already.)
      if (!d_.hosts.empty() && !records_ticks() && m.standby > 0) {
        a.insert(a.end(), {"--observers", std::to_string(m.standby)});
      }
      return a;
    }
    if (c.role == "robot") a.insert(a.end(), {"--arm", slot_of(c)});
    a.insert(a.end(), {"--strength", std::to_string(c.strength)});
    return a;
  }
  /// Multi-host: the host `c` runs on.
  std::string host(const Child& c) const {
    if (c.role == "coordinator") return runtime::coordinator_host_of(d_, c.standby);
    const runtime::ModuleDeployment& m = modules_.at(c.module);
    return c.role == "world" ? runtime::host_of(m, "world", "", false) : runtime::host_of(m, c.role, slot_of(c), c.standby);
  }
  /// The DDS-Security identity of a child ("" without security): its slot's (runtime::identities).
  std::string identity(const Child& c) const {
    if (d_.security_keys.empty()) return "";
    if (c.role == "robot") return runtime::identity_name("robot", c.module, slot_of(c));
    return runtime::identity_name(c.role, c.module);
  }
  int rt_priority(const Child& c) const { return c.role == "coordinator" ? 0 : rt_priority_; }
  /// SCHED_FIFO priority for the per-tick processes (0: normal scheduling); set once before any start.
  int rt_priority_ = 0;

  bool records_ticks() const {
    if (d_.record.empty()) return false;
    if (d_.record_topics.empty()) return true;
    const std::string t = "," + d_.record_topics + ",";
    return t.find(",ticks,") != std::string::npos || t.find(",all,") != std::string::npos;
  }

 private:
  static std::string slot_of(const Child& c) { return c.arm.substr(c.arm.find('/') + 1); }
  std::vector<std::string> common_args(const runtime::ModuleDeployment& m) const {
    std::vector<std::string> a{"--scenario", m.scenario, "--case",      m.case_name,
                               "--module",   m.name,     "--domain",    std::to_string(d_.domain_id),
                               "--transport", d_.transport, "--timeout", std::to_string(d_.timeout),
                               "--timing",   d_.timing,   "--deployment", d_.name};
    if (d_.coordinator) a.push_back("--continuous");
    if (!d_.overload_brake) a.push_back("--no-overload-brake");
    if (d_.test_no_brakes) a.push_back("--test-no-brakes");
    // Lockstep with a recorder of the per-tick topics: the world waits for every reader of its sensors (the
    // robots of the arm and the recorder) before tick 0, so that the recording has every tick.
    if (records_ticks()) a.insert(a.end(), {"--observers", std::to_string(m.standby + 1)});
    return a;
  }
  const Deployment& d_;
  std::string file_, dir_;
  std::map<std::string, runtime::ModuleDeployment> modules_;
};

/// Processes on this machine: fork/exec (launcher::spawn) and kill(2); their exits are reaped by reap_local().
class LocalExecutor : public launcher::Executor {
 public:
  explicit LocalExecutor(const CommandLines& lines) : lines_(lines) {}
  std::string place(const Child& /*c*/) const override { return ""; }
  int start(const Child& c) override {
    const std::vector<std::string> args = lines_.args(c);
    return spawn(lines_.exe(c), args, lines_.rt_priority(c), c.participant_id, lines_.identity(c),
                 launcher::own_group_for(c.role, args));
  }
  void signal(const Child& c, int sig) override { ::kill(c.pid, sig); }
  void signal_spawn(const std::string& /*host*/, unsigned long long /*spawn_id*/, const std::string& /*label*/,
                    int /*sig*/) override {}
  void heartbeat(const std::string& /*host*/, bool /*lost*/, bool /*end*/) override {}

 private:
  const CommandLines& lines_;
};

/// Processes on the hosts of a multi-host deployment: requests to each host's agent (AgentRequest); their exits
/// come in the agents' states.
class AgentExecutor : public launcher::Executor {
 public:
  AgentExecutor(const CommandLines& lines, std::string deployment, unsigned long long run)
      : lines_(lines), deployment_(std::move(deployment)), run_(run) {}
  bus::Writer<msg::AgentRequest, msg::AgentRequestPubSubType>* out_ = nullptr;

  std::string place(const Child& c) const override { return lines_.host(c); }
  int start(const Child& c) override {
    msg::AgentRequest r = request(c.host, msg::AGENT_START);
    r.spawn_id(c.spawn_id);
    r.label(c.label);
    r.role(c.role);
    r.args(lines_.args(c));
    r.rt_priority(lines_.rt_priority(c));
    r.participant_id(c.participant_id);
    r.identity(lines_.identity(c));
    out_->write(r);
    return 0;
  }
  void signal(const Child& c, int sig) override { signal_spawn(c.host, c.spawn_id, c.label, sig); }
  void signal_spawn(const std::string& host, unsigned long long spawn_id, const std::string& label, int sig) override {
    msg::AgentRequest r = request(host, msg::AGENT_SIGNAL);
    r.spawn_id(spawn_id);
    r.label(label);
    r.signal(sig);
    out_->write(r);
  }
  /// Every 100 ms, to each host's agent: the launcher lives, and whether it counts the host as lost (one-way
  /// partitions: an agent that hears the launcher but is not heard fences too). Ends the run with end=true.
  void heartbeat(const std::string& host, bool lost, bool end) override {
    msg::AgentRequest r = request(host, end ? msg::AGENT_END : msg::AGENT_HEARTBEAT);
    r.host_lost(lost);
    out_->write(r);
  }

 private:
  msg::AgentRequest request(const std::string& host, msg::AgentRequestKind kind) const {
    msg::AgentRequest r;
    r.host(host);
    r.deployment(deployment_);
    r.kind(kind);
    r.run(run_);
    return r;
  }
  const CommandLines& lines_;
  std::string deployment_;
  unsigned long long run_;
};

/// What the supervisor says: the log on stdout/stderr, requests to supervisors and the coordinator's state on DDS.
class UpOutbox : public launcher::Outbox {
 public:
  UpOutbox(std::string deployment, CommandLines& lines) : deployment_(std::move(deployment)), lines_(lines) {}
  bus::Writer<msg::ControlRequest, msg::ControlRequestPubSubType>* control_out_ = nullptr;
  bus::Writer<msg::CoordinatorState, msg::CoordinatorStatePubSubType>* coord_state_out_ = nullptr;
  msg::CoordinatorState* last_coord_ = nullptr;  ///< the latest (most advanced) queue state heard

  void log(const std::string& line, bool error) override { std::fputs(line.c_str(), error ? stderr : stdout); }
  void control(const std::string& module, launcher::ModuleCommand command, unsigned long long seq) override {
    msg::ControlRequest req;
    req.deployment(deployment_);
    req.command(command == launcher::ModuleCommand::Pause    ? msg::CMD_PAUSE
                : command == launcher::ModuleCommand::Resume ? msg::CMD_RESUME
                                                             : msg::CMD_DRAIN);
    req.target_kind(msg::TARGET_MODULE);
    req.target(module);
    req.seq(seq);
    control_out_->write(req);
  }
  void republish_coordinator_state() override {
    if (coord_state_out_ != nullptr && last_coord_ != nullptr) coord_state_out_->write(*last_coord_);
  }
  launcher::ModuleSpec load_module(const std::string& name, const std::string& scenario, const std::string& case_name,
                                   const std::string& host, bool& case_found) override {
    runtime::ModuleDeployment cfg;
    cfg.name = name;
    cfg.scenario = scenario;
    cfg.case_name = case_name;
    cfg.host = host;
    launcher::ModuleSpec spec = module_spec(cfg, &case_found);
    lines_.add(cfg);
    return spec;
  }

 private:
  std::string deployment_;
  CommandLines& lines_;
};

/// A live command as the supervisor reads it.
launcher::Request request_of(const msg::ControlRequest& r) {
  launcher::Request q;
  using C = launcher::Request::Command;
  using T = launcher::Request::Target;
  q.command = r.command() == msg::CMD_DOWN     ? C::Down
              : r.command() == msg::CMD_KILL   ? C::Kill
              : r.command() == msg::CMD_PLUG   ? C::Plug
              : r.command() == msg::CMD_UNPLUG ? C::Unplug
                                               : C::Other;
  q.raw_command = static_cast<int>(r.command());
  q.command_name = runtime::command_name(r.command());
  q.target_kind = r.target_kind() == msg::TARGET_MODULE    ? T::Module
                  : r.target_kind() == msg::TARGET_ROBOT   ? T::Robot
                  : r.target_kind() == msg::TARGET_PROCESS ? T::Process
                                                           : T::Other;
  q.target = r.target();
  q.seq = r.seq();
  q.standby = r.standby();
  q.scenario = r.scenario();
  q.case_name = r.case_name();
  q.host = r.host();
  return q;
}

/// An agent's state as the supervisor reads it.
launcher::AgentReport report_of(const msg::AgentState& st) {
  launcher::AgentReport a;
  a.host = st.host();
  a.pid = st.pid();
  a.run = st.run();
  a.detail = st.detail();
  for (const auto& ac : st.children()) {
    a.children.push_back({ac.spawn_id(), ac.label(), ac.pid(), ac.running(), static_cast<int>(ac.status())});
  }
  return a;
}

/// Exits of the processes started on this machine, handed to the supervisor (`block`: wait for each).
void reap_local(launcher::Supervisor& s, bool block = false) {
  std::vector<int> pids;
  for (const auto& c : s.children()) {
    if (c.running && c.host.empty() && c.pid > 0) pids.push_back(c.pid);
  }
  for (const int pid : pids) {
    int st = 0;
    if (::waitpid(pid, &st, block ? 0 : WNOHANG) == pid) s.on_exit(pid, WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st));
  }
}

/// This launcher's run, in every request to the agents: random, so that two runs (two `tandem up`, even with one pid
/// in two containers) never take each other's processes.
unsigned long long new_run() {
  std::random_device rd;
  unsigned long long r = 0;
  while (r == 0) r = (static_cast<unsigned long long>(rd()) << 32) ^ rd();
  return r;
}

/// The Discovery Server's own participant: a server over UDP only. With Fast DDS's built-in transports it also
/// listens on shared memory, and its clients on this machine reach it there; a client SIGKILLed while it held the
/// server's port lock (the soak kills about a thousand processes an hour) left the server deaf to every client
/// that came after: soak run 18 (soak-small, seed 12) heard no process started after 151 s, a coordinator's
/// kill, and the deployment wore away as its processes were restarted and never heard (docs/failure-model.md,
/// "Shared memory and SIGKILL"). Over UDP a dead client leaves nothing held. The clients keep their transports.
constexpr const char* kDiscoveryServerProfile = R"(<?xml version="1.0" encoding="UTF-8" ?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>tandem_udp</transport_id>
        <type>UDPv4</type>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="tandem_discovery_server" is_default_profile="true">
      <rtps>
        <userTransports><transport_id>tandem_udp</transport_id></userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
        <builtin><discovery_config><discoveryProtocol>SERVER</discoveryProtocol></discovery_config></builtin>
      </rtps>
    </participant>
  </profiles>
</dds>
)";

/// Writes kDiscoveryServerProfile to a new file in /tmp; its path, "" if it could not.
std::string write_discovery_profile() {
  char path[] = "/tmp/tandem-discovery-XXXXXX.xml";
  const int fd = ::mkstemps(path, 4);
  if (fd < 0) return "";
  const std::string text = kDiscoveryServerProfile;
  const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ::close(fd);
  if (!ok) {
    ::unlink(path);
    return "";
  }
  return path;
}

/// discovery: server. Starts the Discovery Server (a child like the others: it dies with the launcher; `pid`), or
/// uses an external one, and makes this process and every process it starts a client of it. False (said why) if
/// it cannot run.
bool start_discovery(const Deployment& d, pid_t& pid, std::string& profile) {
  if (d.discovery == "server" && d.discovery_start == "external") {
    std::printf("  discovery server             %s (external)\n", runtime::discovery_text(d).c_str());
    runtime::use_discovery(d);
  } else if (d.discovery == "server") {
    const std::string exe = "/usr/bin/fast-discovery-server";
    if (::access(exe.c_str(), X_OK) != 0) {
      std::fprintf(stderr, "tandem up: discovery: server needs %s (Debian package fastdds-tools)\n", exe.c_str());
      return false;
    }
    std::vector<std::string> args{"-i", "0", "-l", d.discovery_address, "-p", std::to_string(runtime::discovery_port_of(d))};
    profile = write_discovery_profile();
    if (profile.empty()) {
      std::fprintf(stderr, "tandem up: note: cannot write the Discovery Server's UDP-only profile in /tmp (%s); it runs "
                           "with Fast DDS's default transports\n", std::strerror(errno));
    } else {
      args.insert(args.end(), {"-x", profile});
    }
    pid = spawn(exe, args);
    if (pid < 0) return false;
    std::printf("  started discovery server     pid %d on %s:%d\n", pid, d.discovery_address.c_str(),
                runtime::discovery_port_of(d));
    runtime::use_discovery(d);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // listening before the first client comes
    if (::waitpid(pid, nullptr, WNOHANG) == pid) {
      std::fprintf(stderr, "tandem up: the Discovery Server exited at start: is %s an address of this machine, and "
                           "port %d free? (discovery_start: external uses one that runs already)\n",
                   d.discovery_address.c_str(), runtime::discovery_port_of(d));
      return false;
    }
  }
  return true;
}

/// What the run's summary reads besides the supervisor: the summaries heard, the coordinator's last queue state and
/// the start-up CPU per role.
struct Heard {
  std::map<std::string, msg::RobotSummary> robots;
  std::map<std::string, msg::WorldSummary> worlds;
  std::map<std::string, std::vector<double>> start_cpu;  ///< per role: the CPU seconds from start to active
  msg::CoordinatorState last_coord;                      ///< the latest (most advanced) queue state heard
  bool have_coord = false;
};

/// The run's summary on stdout and, with --summary FILE, as key=value lines in `out` (full precision). Returns
/// whether every module that counts kept its grasp; sets `failed` when one of them sent no world summary.
bool print_summary(double wall_s, const launcher::Supervisor& L, const Deployment& d, Heard& heard,
                   const std::string& summary_file, std::ofstream& out, bool& failed) {
  std::printf("\nsummary (%.1f s wall)\n", wall_s);
  std::printf("%-16s %8s %12s %12s %12s %10s %10s %9s\n", "robot", "ticks", "e_p Sp RMS", "e_p pos RMS",
              "e_p phi RMS", "e_h RMS N", "min h_n N", "rejected");
  if (!summary_file.empty()) {
    out.open(summary_file);
    if (!out) std::fprintf(stderr, "tandem up: cannot write the summary to %s\n", summary_file.c_str());
    out.precision(17);
  }
  bool grasp_ok = true;
  for (const auto& [name, mr] : L.modules()) {
    if (!mr.started) continue;
    const bool counted = mr.end.empty() || mr.end == "draining";  // failed or unplugged modules: reported only
    if (!mr.end.empty()) std::printf("%s: %s\n", name.c_str(), mr.end.c_str());
    if (out) out << name << ".end=" << (mr.end.empty() ? "ran" : mr.end.substr(0, mr.end.find(':'))) << "\n";
    for (const auto& [id, r] : heard.robots) {
      if (id.rfind(name + "/", 0) != 0) continue;
      char min_force[32] = "-";  // a robot that computed no tick has no force to report
      if (r.ticks() > 0) std::snprintf(min_force, sizeof min_force, "%.2f", r.min_normal_force());
      std::printf("%-16s %8llu %12.4e %12.4e %12.4e %10.4f %10s %9llu\n", id.c_str(),
                  static_cast<unsigned long long>(r.ticks()), r.ep_sel_rms(), r.ep_pos_rms(), r.ep_ori_rms(),
                  r.eh_rms(), min_force, static_cast<unsigned long long>(r.rejected()));
      if (counted && r.ticks() > 0 && r.min_normal_force() < mr.spec.h_sg) grasp_ok = false;
      if (out) {
        out << id << ".ep_pos_rms=" << r.ep_pos_rms() << "\n" << id << ".ep_ori_rms=" << r.ep_ori_rms() << "\n"
            << id << ".ep_sel_rms=" << r.ep_sel_rms() << "\n" << id << ".eh_rms=" << r.eh_rms() << "\n"
            << id << ".min_normal_force=" << r.min_normal_force() << "\n" << id << ".ticks=" << r.ticks() << "\n"
            << id << ".rejected=" << r.rejected() << "\n";
      }
    }
    const auto w = heard.worlds.find(name);
    if (w == heard.worlds.end()) {
      std::printf("%s: no summary from the world\n", name.c_str());
      if (counted) failed = true;
      continue;
    }
    const msg::WorldSummary& ws = w->second;
    std::printf("%s: %llu ticks, object at (%.6f, %.6f), slips %llu, contact lost %llu, rejected commands %llu, "
                "%s %llu, braked arm-ticks %llu\n",
                name.c_str(), static_cast<unsigned long long>(ws.ticks()), ws.object_final()[0], ws.object_final()[1],
                static_cast<unsigned long long>(ws.slip_events()), static_cast<unsigned long long>(ws.contact_lost()),
                static_cast<unsigned long long>(ws.rejected_commands()), ws.realtime() ? "late arm-ticks" : "brakings",
                static_cast<unsigned long long>(ws.late_commands()), static_cast<unsigned long long>(ws.braked_ticks()));
    for (size_t i = 0; i < ws.switch_gap_ms().size(); ++i) {
      std::printf("%s: %s after %.1f ms; over the next 300 ticks worst |e_p| %.3e m, lowest normal force %.2f N "
                  "(h_sg %.2f N)\n",
                  name.c_str(), ws.switch_failover()[i] ? "failover" : "takeover", ws.switch_gap_ms()[i],
                  ws.switch_ep_max()[i], ws.switch_hn_min()[i], mr.spec.h_sg);
    }
    if (ws.realtime()) {
      std::printf("%s: real time: sample->command latency p50 %.0f us, p99 %.0f us, max %.0f us; late arm-ticks %llu "
                  "of %llu (%.2f%%); world tick start late p99 %.0f us, world overruns %llu; paused for load %llu "
                  "time(s), %.1f s\n",
                  name.c_str(), ws.latency_p50_us(), ws.latency_p99_us(), ws.latency_max_us(),
                  static_cast<unsigned long long>(ws.late_commands()), 2ULL * ws.ticks(),
                  ws.ticks() > 0 ? 50.0 * static_cast<double>(ws.late_commands()) / static_cast<double>(ws.ticks()) : 0.0,
                  ws.wake_late_p99_us(), static_cast<unsigned long long>(ws.overruns()),
                  static_cast<unsigned long long>(ws.load_pauses()), static_cast<double>(ws.load_paused_ticks()) * 1e-3);
    }
    if (counted && (ws.slip_events() > 0 || ws.contact_lost() > 0)) grasp_ok = false;
    if (out) {
      out << name << ".ticks=" << ws.ticks() << "\n" << name << ".slip_events=" << ws.slip_events() << "\n"
          << name << ".contact_lost=" << ws.contact_lost() << "\n" << name
          << ".rejected_commands=" << ws.rejected_commands() << "\n" << name
          << ".late_commands=" << ws.late_commands() << "\n" << name << ".latency_p50_us=" << ws.latency_p50_us()
          << "\n" << name << ".latency_p99_us=" << ws.latency_p99_us() << "\n" << name
          << ".failovers=" << ws.failovers() << "\n" << name << ".failover_max_ms=" << ws.failover_max_ms() << "\n"
          << name << ".braked_ticks=" << ws.braked_ticks() << "\n" << name << ".overruns=" << ws.overruns() << "\n"
          << name << ".load_pauses=" << ws.load_pauses() << "\n" << name << ".load_paused_ticks=" << ws.load_paused_ticks()
          << "\n";
      auto list = [&out, &module = name](const char* key, const auto& seq) {  // (C++17: no binding captures)
        out << module << "." << key << "=";
        for (size_t i = 0; i < seq.size(); ++i) out << (i ? "," : "") << static_cast<double>(seq[i]);
        out << "\n";
      };
      list("switch_gap_ms", ws.switch_gap_ms());
      list("switch_failover", ws.switch_failover());
      list("switch_ep_max", ws.switch_ep_max());
      list("switch_hn_min", ws.switch_hn_min());
      for (size_t i = 0; i < 6; ++i) out << name << ".q_final" << i << "=" << ws.q_final()[i] << "\n";
      for (size_t i = 0; i < 3; ++i) out << name << ".object_final" << i << "=" << ws.object_final()[i] << "\n";
    }
  }
  for (const auto& c : L.children()) {
    if (c.status != 0) {
      std::printf("process %s exited with code %d%s\n", c.label.c_str(), c.status,
                  c.expected ? " (unplugged, or its module stopped)" : "");
    }
  }
  if (d.coordinator && heard.have_coord) {
    const size_t done = done_in(heard.last_coord);
    const size_t dup = heard.last_coord.done_total() > done ? static_cast<size_t>(heard.last_coord.done_total() - done) : 0;
    std::printf("coordinator: %zu/%zu tasks done, %zu duplicate(s)\n", done, d.tasks.size(), dup);
    if (out) out << "coordinator.tasks_done=" << done << "\ncoordinator.duplicates=" << dup << "\n";
    for (size_t t = 0; t < heard.last_coord.done_by().size() && t < d.tasks.size() && out; ++t) {
      const uint8_t by = heard.last_coord.done_by()[t];
      if (by != 0 && by <= heard.last_coord.modules().size()) {
        out << "coordinator.task." << d.tasks[t].name << "=" << heard.last_coord.modules()[by - 1u] << "\n";
      }
    }
  }
  for (auto& [role, v] : heard.start_cpu) {
    if (v.empty()) continue;
    std::sort(v.begin(), v.end());
    const double median = v[v.size() / 2];
    std::printf("start-up CPU of a %s (start to active): median %.3f s, max %.3f s over %zu start(s)\n", role.c_str(),
                median, v.back(), v.size());
    if (out) out << "startup_cpu." << role << ".median_s=" << median << "\nstartup_cpu." << role << ".starts=" << v.size() << "\n";
  }
  std::printf("tandem up: start-up repairs (modules restarted because they did not come up): %llu\n", L.start_repairs());
  if (L.forced_drains() > 0) {
    std::printf("tandem up: unplugged modules stopped before their task ended (drain over %.0f s): %llu\n",
                launcher::DrainWatch::kTimeout, L.forced_drains());
  }
  if (out) {
    out << "start_repairs=" << L.start_repairs() << "\nplan_restarts=" << L.plan_restarts() << "\nforced_drains=" << L.forced_drains()
        << "\ndeaf_leaders=" << L.deaf_leaders() << "\n";
  }
  if (L.plan_restarts() > 0) std::printf("tandem up: modules restarted because their supervisors lost the plan: %llu\n", L.plan_restarts());
  if (L.governed()) {
    std::printf("tandem up: modules parked for load during the run: %llu time(s); parked at the end: %s\n",
                L.parks(), L.parked_text().empty() ? "none" : L.parked_text().c_str());
    if (out) out << "shedding.parks=" << L.parks() << "\nshedding.parked=" << L.parked_text() << "\n";
  }
  return grasp_ok;
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
  std::string file, summary_file, record_file, view_port;
  bool check_only = false, with_view = false;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") {
      up_usage(stdout);
      return 0;
    } else if (args[i] == "--check") {
      check_only = true;
    } else if (args[i] == "--summary" && i + 1 < args.size()) {
      summary_file = args[++i];
    } else if (args[i] == "--record" && i + 1 < args.size()) {
      record_file = args[++i];
    } else if (args[i] == "--view") {
      with_view = true;
    } else if (args[i] == "--view-port" && i + 1 < args.size()) {
      with_view = true;
      view_port = args[++i];
    } else if (!args[i].empty() && args[i][0] == '-') {
      std::fprintf(stderr, "tandem up: unknown option '%s' (see 'tandem help up')\n", args[i].c_str());
      return 2;
    } else if (file.empty()) {
      file = args[i];
    } else {
      std::fprintf(stderr, "tandem up: one deployment file expected, got '%s' too\n", args[i].c_str());
      return 2;
    }
  }
  if (file.empty()) {
    std::fprintf(stderr, "tandem up: missing the deployment file\n\n");
    up_usage(stderr);
    return 2;
  }
  Deployment d;
  try {
    d = load_deployment(file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem up: %s\n", e.what());
    return 2;
  }
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
    absolute(file);
    for (auto& m : d.modules) absolute(m.scenario);
  }
  std::vector<launcher::ModuleSpec> specs;
  try {
    for (const auto& m : d.modules) specs.push_back(module_spec(m));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem up: %s\n", e.what());
    return 2;
  }
  CommandLines lines(d, file);
  LocalExecutor local(lines);
  const unsigned long long run = new_run();
  AgentExecutor agents(lines, d.name, run);
  UpOutbox outbox(d.name, lines);
  launcher::Supervisor L(supervisor_config(d, file, run), d.hosts.empty() ? static_cast<launcher::Executor&>(local) : agents,
                         outbox);
  const auto t_start = Clock::now();
  auto now_s = [&t_start] { return std::chrono::duration<double>(Clock::now() - t_start).count(); };
  for (auto& s : specs) L.add_module(std::move(s));

  // DDS-Security: every identity's files are there and valid before anything starts; the launcher joins as
  // "launcher", its children inherit the keys' directory and get their slot's identity (CommandLines::identity).
  if (!d.security_keys.empty()) {
    const std::string err = runtime::check_keys(d);
    if (!err.empty()) {
      std::fprintf(stderr, "tandem up: %s\n", err.c_str());
      return 2;
    }
    (void)runtime::use_security(d, "launcher");
  }
  if (check_only) {
    std::printf("tandem up: %s is valid: %zu module(s), domain %d, %s timing\n%s\n", file.c_str(), d.modules.size(),
                d.domain_id, d.timing.c_str(), capacity_estimate(load_of(d)).text.c_str());
    return 0;
  }

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);

  // Real time: the per-tick processes raise themselves to SCHED_FIFO once active; the launcher and everything it
  // starts run at kServiceNice meanwhile (before any thread or child exists, so that all inherit it).
  if (d.timing == "realtime" && d.realtime_priority > 0) {
    std::string why;
    if (launcher::fifo_permitted(d.realtime_priority, why)) {
      lines.rt_priority_ = d.realtime_priority;
      (void)launcher::raise_service_priority(why);  // permitted wherever SCHED_FIFO is
    } else {
      std::printf("tandem up: note: real-time priority %d not permitted here (%s); the per-tick processes run "
                  "with normal scheduling and may miss more ticks (run as root, or grant CAP_SYS_NICE or an "
                  "RLIMIT_RTPRIO; 'realtime_priority: 0' silences this)\n",
                  d.realtime_priority, why.c_str());
    }
  } else if (d.timing == "lockstep") {
    // Lockstep keeps both cores busy with per-tick work: the control plane (this launcher, supervisors,
    // coordinators, processes starting) runs at kServiceNice ahead of it; the world and robots go to niceness 0
    // once active (runtime::raise_to_realtime_from_env). Where not permitted, everything runs at one priority.
    std::string why;
    (void)launcher::raise_service_priority(why);
  }

  // discovery: server. The launcher starts the Discovery Server first (a child like the others: it dies with
  // the launcher) and makes itself and every process it starts a client of it.
  const std::time_t launcher_started = std::time(nullptr) - 1;  // shared-memory files of this run: newer
  pid_t discovery_server = -1;
  std::string discovery_profile;
  struct RemoveFile {
    std::string& path;
    ~RemoveFile() {
      if (!path.empty()) ::unlink(path.c_str());
    }
  } remove_profile{discovery_profile};  // after the server has stopped (declared before server_stop)
  if (!start_discovery(d, discovery_server, discovery_profile)) return 2;
  launcher::HelperProcess server_stop(discovery_server, 1.0);
  std::unique_ptr<bus::Participant> part_owner;
  try {
    part_owner = std::make_unique<bus::Participant>(d.domain_id, "launcher/" + d.name, runtime::transport_of(d));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem up: %s\n", e.what());
    return 2;
  }
  bus::Participant& part = *part_owner;
  bus::Reader<msg::RobotSummary, msg::RobotSummaryPubSubType> robot_sum(part, bus::kRobotSummaryTopic,
                                                                       bus::TopicKind::Summary);
  bus::Reader<msg::WorldSummary, msg::WorldSummaryPubSubType> world_sum(part, bus::kWorldSummaryTopic,
                                                                       bus::TopicKind::Summary);
  bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType> status(part, bus::kStatusTopic,
                                                                       bus::TopicKind::Status);
  bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType> control(part, bus::kControlTopic,
                                                                         bus::TopicKind::Control);
  bus::Writer<msg::ControlRequest, msg::ControlRequestPubSubType> control_out(part, bus::kControlTopic,
                                                                             bus::TopicKind::Control);
  bus::Reader<msg::TaskState, msg::TaskStatePubSubType> task_states(part, bus::kTaskStateTopic, bus::TopicKind::Task);
  bus::Reader<msg::CoordinatorState, msg::CoordinatorStatePubSubType> coord_state(part, bus::kCoordinatorStateTopic,
                                                                                  bus::TopicKind::Task);
  outbox.control_out_ = &control_out;
  bus::Writer<msg::CoordinatorState, msg::CoordinatorStatePubSubType> coord_state_out(part, bus::kCoordinatorStateTopic,
                                                                                    bus::TopicKind::Task);
  outbox.coord_state_out_ = &coord_state_out;
  // Multi-host: the agents (docs/multihost.md). Every host's agent is heard before anything starts.
  std::unique_ptr<bus::Writer<msg::AgentRequest, msg::AgentRequestPubSubType>> agent_out;
  std::unique_ptr<bus::Reader<msg::AgentState, msg::AgentStatePubSubType>> agent_state;
  if (!d.hosts.empty()) {
    agent_out = std::make_unique<bus::Writer<msg::AgentRequest, msg::AgentRequestPubSubType>>(part, bus::kAgentRequestTopic,
                                                                                              bus::TopicKind::Control);
    agent_state = std::make_unique<bus::Reader<msg::AgentState, msg::AgentStatePubSubType>>(part, bus::kAgentStateTopic,
                                                                                            bus::TopicKind::Status);
    agents.out_ = agent_out.get();
  }
  runtime::StatusPublisher launcher_status(part, "launcher", "launcher", "");
  launcher_status.msg().deployment(d.name);
  launcher_status.set(runtime::Lifecycle::Active, "");
  LiveView view(d.name);
  if (!d.hosts.empty()) {
    const auto asked = Clock::now();
    auto last_note = asked - std::chrono::seconds(10);
    while (!g_stop) {
      msg::AgentState st;
      while (agent_state->take(st)) {
        if (st.deployment() == d.name) L.on_agent_state(report_of(st), now_s());
      }
      // Every agent heard, and serving this run: its state says so once it has this launcher's heartbeat, so the
      // requests reach it both ways (a state heard alone once came with requests that never arrived).
      const auto waiting = L.agents_not_serving();
      if (waiting.empty()) break;
      std::string list;
      for (const auto& h : waiting) list += (list.empty() ? "" : ", ") + h;
      // As long as a process waits for its peers (timeout:), at least 5 s.
      const double wait_s = std::max(5.0, d.timeout);
      if (Clock::now() - asked > std::chrono::duration<double>(wait_s)) {
        std::fprintf(stderr, "tandem up: no agent serving this run within %.0f s for host(s) %s; start `tandem agent %s "
                             "--host NAME` on each (same domain %d, discovery %s)\n",
                     wait_s, list.c_str(), file.c_str(), d.domain_id,
                     runtime::discovery_text(d).c_str());
        return 2;
      }
      if (Clock::now() - last_note > std::chrono::seconds(3)) {
        std::printf("tandem up: waiting for the agents of %s\n", list.c_str());
        std::fflush(stdout);
        last_note = Clock::now();
      }
      launcher_status.publish();
      L.heartbeat();  // the agents learn which run they serve
      agent_state->wait(0.1);
    }
    std::printf("tandem up: %zu host(s), every agent heard and serving this run\n", d.hosts.size());
  }
  std::printf("tandem up %s: %zu module(s), domain %d, %s, %s timing%s\n", d.name.c_str(), d.modules.size(),
              d.domain_id, d.transport.c_str(), d.timing.c_str(),
              lines.rt_priority_ > 0 ? (", SCHED_FIFO " + std::to_string(lines.rt_priority_)).c_str() : "");
  const launcher::Capacity capacity = launcher::capacity_estimate(load_of(d));
  if (capacity.text.find("warning") != std::string::npos) std::printf("tandem up: %s\n", capacity.text.c_str());
  // record: the recorder joins first and is heard before any module starts, so that it has every tick (the
  // worlds also wait for its readers in lockstep: --observers). It is stopped last, after the summaries.
  pid_t recorder = -1;
  if (!d.record.empty()) {
    std::vector<std::string> rargs{"record", file, "-o", d.record, "--attached"};
    if (!d.record_topics.empty()) rargs.insert(rargs.end(), {"--topics", d.record_topics});
    recorder = spawn(lines.dir() + "/tandem", rargs, 0, -1, d.security_keys.empty() ? "" : "recorder");
    if (recorder < 0) return 2;
    std::printf("  started recorder             pid %d -> %s\n", recorder, d.record.c_str());
    bool heard = false;
    const auto asked = Clock::now();
    while (!heard && !g_stop && Clock::now() - asked < std::chrono::seconds(10)) {
      msg::ProcessStatus ps;
      while (status.take(ps)) {
        view.update(ps);
        heard = heard || (ps.process_id() == "recorder" && ps.pid() == recorder && ps.state() == 2);
      }
      L.heartbeat();  // the agents' launcher lives meanwhile
      if (::waitpid(recorder, nullptr, WNOHANG) == recorder) {
        std::fprintf(stderr, "tandem up: the recorder exited at start (see its message above)\n");
        return 2;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!heard) std::printf("tandem up: note: the recorder was not heard within 10 s; starting anyway\n");
  }
  // Stopped last with SIGTERM: it closes the file (summary section, footer); SIGKILL after 30 s. An exit of its own
  // before that is a failed recording.
  launcher::HelperProcess recorder_stop(recorder, 30.0,
                                        "tandem up: the recorder did not close its file within 30 s; SIGKILL\n");
  bool recording_failed = false;
  // --view: the live view (tandem view) beside the deployment, started before the modules and stopped after the
  // summaries; it prints its URL. Not supervised: a viewer that exits leaves the deployment alone.
  pid_t viewer = -1;
  if (with_view) {
    std::vector<std::string> vargs{"view", file, "--port", view_port.empty() ? "8765" : view_port};
    // An observer at niceness 0 (it sets it itself): in the launcher's group, not a group of its own.
    viewer = spawn(lines.dir() + "/tandem", vargs, 0, -1, d.security_keys.empty() ? "" : "recorder", false);
    if (viewer > 0) std::printf("  started viewer               pid %d\n", viewer);
  }
  launcher::HelperProcess viewer_stop(viewer, 5.0, "tandem up: the viewer did not stop within 5 s; SIGKILL\n");
  L.restart_host_clock(now_s());  // the recorder was awaited without reading agent states
  std::set<std::string> start_parked;
  if (capacity.realtime && d.coordinator && d.shed_modules && d.overload_brake) {
    // Shedding whole modules (launcher::Governor), and admission: the modules the calibrated estimate fits,
    // in file order, start; the others start parked and come back when the machine has been calm.
    std::vector<std::pair<std::string, int>> autostart;
    for (const auto& m : d.modules) {
      if (m.autostart) autostart.emplace_back(m.name, m.standby);
    }
    const launcher::Admission adm = launcher::admission(capacity, autostart, !d.hosts.empty());
    for (const std::string& m : L.admit(adm.order, adm.fit, now_s())) start_parked.insert(m);
    if (!start_parked.empty()) {
      std::string list;
      for (const auto& m : start_parked) list += (list.empty() ? "" : ", ") + m;
      std::printf("tandem up: starting %s parked: the calibrated estimate gives %.3f core per module (with its "
                  "standbys) and %zu of %zu fit in %.2f usable cores; parked modules start when the machine has been "
                  "calm (docs/failure-model.md, \"Shedding whole modules\")\n",
                  list.c_str(), capacity.of(d.modules.front().standby), adm.fit, adm.order.size(), capacity.usable);
    }
  }
  for (const auto& m : d.modules) {
    if (m.autostart && !start_parked.count(m.name)) L.start_module(m.name, now_s());
  }
  L.start_coordinators(now_s());

  Heard heard;
  outbox.last_coord_ = &heard.last_coord;
  const auto t0 = Clock::now();
  auto last_print = t0;
  auto collect = [&] {
    msg::RobotSummary rs;
    while (robot_sum.take(rs)) heard.robots[rs.robot_id()] = rs;
    msg::WorldSummary ws;
    while (world_sum.take(ws)) heard.worlds[ws.module_id()] = ws;
    msg::TaskState ts;
    while (task_states.take(ts)) {
      if (ts.deployment() == d.name) L.on_task_state(ts.module_id(), ts.state());
    }
    msg::CoordinatorState cs;
    bool advanced = false;
    while (coord_state.take(cs)) {
      if (cs.deployment() != d.name) continue;
      const auto kept = L.on_coordinator_state(cs.next_task_id(), cs.done_total(), done_in(cs));
      if (kept == launcher::Supervisor::QueueState::Older) continue;
      advanced = advanced || kept == launcher::Supervisor::QueueState::Advanced;
      heard.last_coord = cs;
      heard.have_coord = true;
    }
    // Mirrored (Supervisor::on_coordinator_state). Found by the hour-long soak: the primary died while its restarted
    // peer was still starting, both came back with --resume and no state, and no task was done again.
    if (advanced && d.coordinator) coord_state_out.write(heard.last_coord);
  };
  std::vector<std::string> running_labels;
  auto launcher_published = Clock::now();
  auto heartbeat_sent = Clock::now();
  while (L.busy()) {
    if (agent_state) {  // before poll(): a host is judged on the newest word from its agent
      msg::AgentState st;
      while (agent_state->take(st)) {
        if (st.deployment() == d.name) L.on_agent_state(report_of(st), now_s());
      }
      if (Clock::now() - heartbeat_sent >= std::chrono::milliseconds(100)) {
        L.heartbeat();
        heartbeat_sent = Clock::now();
      }
    }
    reap_local(L);
    L.poll(now_s());
    L.govern(now_s());
    L.escalate(now_s());
    {
      // The launcher's status lists what it runs, so that `tandem status` knows whom to wait for.
      std::vector<std::string> labels;
      labels.reserve(L.children().size());
      for (const auto& c : L.children()) {
        if (c.running) labels.push_back(c.label);
      }
      // Also every 100 ms, like every other process: a late joiner that has matched hears the launcher within
      // 100 ms whatever its vendor's repair handshake (docs/interop.md).
      if (labels != running_labels || Clock::now() - launcher_published > std::chrono::milliseconds(100)) {
        running_labels = labels;
        launcher_status.msg().runs(labels);
        launcher_status.publish();
        launcher_published = Clock::now();
      }
    }
    collect();
    msg::ProcessStatus ps;
    while (status.take(ps)) {
      view.update(ps);
      const Child* first_active =
          L.on_status(ps.process_id(), ps.pid(), ps.state() == static_cast<uint8_t>(runtime::Lifecycle::Active),
                      ps.serving() != msg::ROLE_NONE, ps.serving() == msg::ROLE_PRIMARY);
      if (first_active != nullptr) {
        // The CPU one start costs (a soak restarts about a thousand processes an hour): user + system time of the
        // process from its start to its first active status.
        const double cpu = launcher::process_cpu_s(static_cast<int>(ps.pid()));
        if (cpu >= 0.0) heard.start_cpu[first_active->role].push_back(cpu);
      }
      if (ps.role() == "world" && ps.deployment() == d.name) L.on_world_load(ps.module_id(), ps.detail(), ps.tick(), now_s());
    }
    msg::ControlRequest req;
    while (control.take(req)) {
      if (req.deployment() != d.name) continue;
      const msg::ControlCommand cmd = req.command();
      if (cmd != msg::CMD_PAUSE && cmd != msg::CMD_RESUME && cmd != msg::CMD_DRAIN) {  // (the launcher's own)
        L.on_request(request_of(req), now_s());
        if (L.down_requested()) g_stop = true;
        std::fflush(stdout);
      }
      // The answer the sender waits for (again, for a request re-sent: see Supervisor::answer).
      if (const launcher::Supervisor::Answer* answer = L.answer(req.seq())) {
        launcher_status.msg().reply_seq(req.seq());
        launcher_status.msg().reply_ok(answer->ok);
        launcher_status.msg().reply_text(answer->text);
        launcher_status.publish();
      }
    }
    if (recorder_stop.exited()) {
      std::printf("tandem up: the recorder exited during the run (code %d); %s is incomplete\n", recorder_stop.status(),
                  d.record.c_str());
      recording_failed = true;
    }
    // Shared-memory files of killed children, once the others had 2 s to let go of them (unmapped ones only).
    if (L.shm_dirty() && now_s() - L.killed_at() > 2.0) {
      L.shm_cleaned();
      runtime::clean_stale_shm(launcher_started);
    }
    if (g_stop && !L.stopping()) {
      std::printf("tandem up: stop requested; stopping %d process(es)\n", L.running());
      L.stop_all(SIGTERM, now_s());
    }
    const auto now = Clock::now();
    if (now - last_print > std::chrono::seconds(1)) {
      std::printf("[%5.1f s] processes running %d/%zu\n", std::chrono::duration<double>(now - t0).count(), L.running(),
                  L.children().size());
      view.print(stdout);
      std::fflush(stdout);
      last_print = now;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  reap_local(L, true);
  if (agent_out) {  // the agents stop whatever is left of this run (--once agents exit)
    L.heartbeat(true);
    (void)agent_out->wait_for_acks(1.0);
  }
  size_t started_modules = 0;
  for (const auto& [name, mr] : L.modules()) started_modules += mr.started ? 1 : 0;
  const auto settle = Clock::now();
  while (heard.worlds.size() < started_modules && Clock::now() - settle < std::chrono::milliseconds(500)) {
    robot_sum.wait(0.05);
    collect();
  }
  collect();

  std::ofstream out;
  bool failed = L.failed();
  const bool grasp_ok = print_summary(std::chrono::duration<double>(Clock::now() - t0).count(), L, d, heard,
                                      summary_file, out, failed);
  launcher_status.set(runtime::Lifecycle::Finalized, "run over");
  viewer_stop.stop();
  if (recorder > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last summaries reach the recorder too
    std::fflush(stdout);
    recorder_stop.stop();
    if (recorder_stop.status() != 0) {
      std::printf("tandem up: the recorder failed (code %d): %s is incomplete\n", recorder_stop.status(), d.record.c_str());
      recording_failed = true;
    }
  }
  {
    msg::ProcessStatus ps;
    while (status.take(ps)) view.update(ps);
    std::printf("final states:\n");
    view.print(stdout, LiveView::Rows::All);
  }
  // A process killed by a signal could not remove its shared-memory files: remove those of this run that no
  // live process uses (runtime::clean_stale_shm; also done during the run, after each killed child).
  bool killed = false;
  for (const auto& c : L.children()) killed = killed || c.status >= 128;
  if (killed || discovery_server > 0) {
    server_stop.stop();
    std::this_thread::sleep_for(std::chrono::milliseconds(2100));  // the last files are 2 s old (clean_stale_shm)
    // Every child is gone: what the launcher itself still holds (the ports it sent to) is left behind too.
    int removed = runtime::clean_stale_shm(launcher_started, static_cast<int>(d.domain_id), true);
    // The Discovery Server is a participant of domain 0 (its shared-memory port stays when it stops).
    if (discovery_server > 0) removed += runtime::clean_stale_shm(launcher_started, 0, true);
    if (removed > 0) std::printf("removed %d shared-memory file(s) left by killed processes\n", removed);
  }
  if (d.coordinator && !L.coordinator_done()) failed = true;
  const bool ok = !failed && !g_stop && grasp_ok && !recording_failed;
  if (out && d.coordinator) out << "coordinator.done=" << (L.coordinator_done() ? 1 : 0) << "\n";
  std::printf("result: %s\n", ok ? "PASS (all processes finished, safe grasp kept)"
                                 : (g_stop ? "STOPPED" : "FAIL (see above)"));
  return ok ? 0 : 1;
}

}  // namespace tandem::cli
