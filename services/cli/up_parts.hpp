// The parts of `tandem up` (services/cli/up_run.cpp) that are not its run: how a child is started (command lines,
// the local and the agents' executors), what the launcher::Supervisor reads from DDS samples and sends back
// (its outbox), the Discovery Server, and the summary at the end.
#pragma once

#include <signal.h>
#include <sys/types.h>
#include <tandemPubSubTypes.h>

#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "tandem/coordinator/options.hpp"
#include "tandem/dds/bus.hpp"
#include "tandem/launcher/cpu_plan.hpp"
#include "tandem/launcher/estimate.hpp"
#include "tandem/launcher/spawn.hpp"
#include "tandem/launcher/supervisor.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/security.hpp"
#include "tandem/runtime/status.hpp"

namespace tandem::cli::up {

namespace bus = tandem::dds;
using launcher::Child;
using runtime::Deployment;

/// What the capacity estimate needs of the deployment (its first module is built from its scenario when timed).
launcher::LoadSpec load_of(const Deployment& d);
/// The supervisor's view of the deployment (`file` as given, absolute with hosts; `run`: this launcher's run).
launcher::SupervisorConfig supervisor_config(const Deployment& d, const std::string& file, unsigned long long run);
/// Tasks a coordinator's queue state lists as done (its compact done-set).
size_t done_in(const msg::CoordinatorState& cs);
/// Starts a process on this machine (launcher::spawn); with rt_priority > 0 the child runs SCHED_FIFO at that
/// priority, and so do the threads it creates (Fast DDS's receive and event threads inherit it).
/// `discovery`: ROS_DISCOVERY_SERVER for the child ("": this process's, inherited).
pid_t spawn(const std::string& exe, const std::vector<std::string>& args, int rt_priority = 0,
            int participant_id = -1, const std::string& identity = "", bool own_group = true,
            const std::string& discovery = "", int cpu = -1);
/// A module of the deployment (or plugged from a scenario) as the supervisor runs it: its scenario read once.
launcher::ModuleSpec module_spec(const runtime::ModuleDeployment& cfg, bool* case_found = nullptr);

/// How a child is started, from the deployment: its executable, arguments, host, DDS-Security identity and
/// scheduling.
class CommandLines {
 public:
  CommandLines(const Deployment& d, std::string file)
      : d_(d), file_(std::move(file)), dir_(launcher::self_dir()),
        cpus_(d.timing == "realtime" && d.cpu_affinity == "module" && d.hosts.empty() ? launcher::allowed_cpus()
                                                                                       : std::vector<int>{}) {
    for (const auto& m : d.modules) modules_[m.name] = m;
  }
  void add(const runtime::ModuleDeployment& m) { modules_[m.name] = m; }
  const std::string& dir() const { return dir_; }

  std::string exe(const Child& c) const { return dir_ + "/tandem-" + c.role; }
  std::vector<std::string> args(const Child& c) const {
    if (c.role == "coordinator") {
      coordinator::Options o;
      o.file = file_;
      o.domain = d_.domain_id;
      o.timeout = std::max(30.0, 3 * d_.timeout);
      o.id = c.label;
      o.standby = c.standby;
      o.resume = c.resume;
      return coordinator::to_args(o);
    }
    const runtime::ModuleDeployment& m = modules_.at(c.module);
    runtime::RoleOptions o = role_options(m);
    if (c.role == "world") {
      // The world waits for every robot of each arm (standbys included) before its first tick: in lockstep for their
      // torque writers and their first answers, so that each computes every tick from the first (RoleOptions::
      // standbys, world::LockstepPacer); on several hosts also for their sensor readers, because the primaries' host
      // may answer later than a standby's and the arms would start braked. (With a recorder role_options counts the
      // readers already.)
      o.standbys = m.standby;
      if (!d_.hosts.empty() && !records_ticks() && m.standby > 0) o.observers = m.standby;
    } else {
      if (c.role == "robot") o.arm = slot_of(c);
      o.strength = c.strength;
    }
    return runtime::role_args(c.role, o);
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
  /// ROS_DISCOVERY_SERVER of a module's process: its module's Discovery Server only, with one per module
  /// (runtime::discovery_env); "" (the launcher's own: every server) for a coordinator and with simple discovery.
  std::string discovery(const Child& c) const { return c.module.empty() ? "" : runtime::discovery_env(d_, c.module); }
  int rt_priority(const Child& c) const { return c.role == "coordinator" ? 0 : rt_priority_; }
  /// The CPU a per-tick process (world, robot) of a module is pinned to on this machine, -1: none (lockstep,
  /// `cpu_affinity: none`, a supervisor or coordinator).
  int cpu(const Child& c) const { return c.role == "world" || c.role == "robot" ? cpus_.cpu_of(c.module) : -1; }
  bool pins_modules() const { return cpus_.active(); }
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
  /// What every role of module `m` is told (runtime::role_args makes the command line of it).
  runtime::RoleOptions role_options(const runtime::ModuleDeployment& m) const {
    runtime::RoleOptions o;
    o.scenario = m.scenario;
    o.case_name = m.case_name;
    o.module = m.name;
    o.domain = d_.domain_id;
    o.transport = d_.transport == "udp" ? dds::Transport::Udp : dds::Transport::SharedMemory;
    o.timeout = d_.timeout;
    o.realtime = d_.timing == "realtime";
    o.deployment = d_.name;
    o.continuous = d_.coordinator;
    o.overload_brake = d_.overload_brake;
    o.test_no_brakes = d_.test_no_brakes;
    // Lockstep with a recorder of the per-tick topics: the world waits for every reader of its sensors (the
    // robots of the arm and the recorder) before tick 0, so that the recording has every tick.
    if (records_ticks()) o.observers = m.standby + 1;
    return o;
  }
  const Deployment& d_;
  std::string file_, dir_;
  std::map<std::string, runtime::ModuleDeployment> modules_;
  mutable launcher::CpuPlan cpus_;  ///< given on a module's first start, the same for the run
};

/// Processes on this machine: fork/exec (launcher::spawn) and kill(2); their exits are reaped by reap_local().
class LocalExecutor : public launcher::Executor {
 public:
  explicit LocalExecutor(const CommandLines& lines) : lines_(lines) {}
  std::string place(const Child& /*c*/) const override { return ""; }
  int start(const Child& c) override {
    const std::vector<std::string> args = lines_.args(c);
    return spawn(lines_.exe(c), args, lines_.rt_priority(c), c.participant_id, lines_.identity(c),
                 launcher::own_group_for(c.role, args), lines_.discovery(c), lines_.cpu(c));
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
launcher::Request request_of(const msg::ControlRequest& r);
/// An agent's state as the supervisor reads it.
launcher::AgentReport report_of(const msg::AgentState& st);
/// Exits of the processes started on this machine, handed to the supervisor (`block`: wait for each).
void reap_local(launcher::Supervisor& s, bool block = false);
/// This launcher's run, in every request to the agents: random, so that two runs (two `tandem up`, even with one
/// pid in two containers) never take each other's processes.
unsigned long long new_run();
/// discovery: server. Starts the Discovery Servers, one per module or one (runtime::discovery_servers; children like
/// the others: they die with the launcher; `pids`), over UDP only (their profile written to `profile`, which the
/// caller removes), or uses an external one, and makes this process and every process it starts a client of all of
/// them (a module's processes are then told their module's server only: CommandLines::discovery). False (said
/// why) if one cannot run.
bool start_discovery(const Deployment& d, std::vector<pid_t>& pids, std::string& profile);

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
                   const std::string& summary_file, std::ofstream& out, bool& failed);

}  // namespace tandem::cli::up
