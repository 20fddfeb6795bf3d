// `tandem up`: starts a deployment as separate processes (world, supervisor and robots per module, and the
// coordinator) that talk only over Fast DDS, supervises them, serves live commands, and ends with a summary.
// Ctrl-C / SIGTERM stops every child; no child outlives the launcher (PR_SET_PDEATHSIG), every child is reaped.
//
// The launcher is the deployment's supervisor (DESIGN.md, failure tiers 2 and 3): it restarts robots and
// coordinators by policy (intensity limit, doubling backoff) and gives up on one that keeps failing; with a
// coordinator, a module whose world or supervisor dies is failed and stopped while the others go on (the
// coordinator re-plans its task). Live commands arrive over DDS (tandem plug/unplug/kill/down) and are
// carried out here: docs/failure-model.md.
#include "up_command.hpp"

#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <tandemPubSubTypes.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdarg>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "live_view.hpp"
#include "tandem/launcher/capacity.hpp"
#include "tandem/launcher/drain_watch.hpp"
#include "tandem/launcher/exit_rules.hpp"
#include "tandem/launcher/plug_rules.hpp"
#include "tandem/launcher/governor.hpp"
#include "tandem/launcher/host_watch.hpp"
#include "tandem/launcher/restart_policy.hpp"
#include "tandem/launcher/spawn.hpp"
#include "tandem/dds/bus.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/security.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/shm_clean.hpp"
#include "tandem/plan/plan.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/model/controller.hpp"
#include "tandem/model/plant.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::cli {
using runtime::Deployment;
using runtime::load_deployment;
namespace {

namespace bus = tandem::dds;
using Clock = std::chrono::steady_clock;

std::atomic<bool> g_stop{false};

// Real-time cost figures for the capacity warning (bench/scale.sh, docs/benchmarks.md) and the share of the
// machine above which `tandem up` warns.
constexpr double kCorePerModule = 0.2;
constexpr double kCorePerStandbyRobot = 0.05;
constexpr double kUsableShare = 0.8;
// A child not heard on the domain (its status) within this long of its start is cut off: killed and restarted.
constexpr double kSilentStartS = 15.0;
void on_signal(int) { g_stop = true; }

struct Child {
  std::string label;               ///< process id in status: "m1/world", "m1/left", "m1/left@50", "coordinator"
  std::string role;                ///< world | supervisor | robot | coordinator
  std::string module;              ///< its module ("" for the coordinator)
  std::string arm;                 ///< robots: "<module>/<robot>"
  int strength = 0;                ///< robots: ownership strength of the torque writer
  std::string exe;
  std::vector<std::string> args;   ///< how to start it (again)
  pid_t pid = -1;
  bool running = true;
  int status = -1;                 ///< exit code once reaped (128 + signal if killed)
  bool expected = false;           ///< its exit is no failure (unplugged, drained, module stopped, restarted)
  bool handled = false;            ///< its exit has been dealt with
  Clock::time_point term_at{};     ///< when it was asked to stop alone (SIGTERM); SIGKILL 5 s later
  Clock::time_point started{};     ///< when it was started
  int participant_id = -1;         ///< its DDS participant id (TANDEM_PARTICIPANT_ID), -1: Fast DDS's choice
  bool heard = false;              ///< its status was heard over DDS (it is part of the domain)
  bool cut_off = false;            ///< killed because it was never heard (kSilentStartS)
  bool active_seen = false;        ///< its status said active once (its start-up CPU is then measured)
  bool leads = false;              ///< supervisors: its latest status says it leads its module
  // Multi-host: started by the agent of `host` ("" = by the launcher, on this machine).
  std::string host;
  unsigned long long spawn_id = 0;  ///< the launcher's request id (AgentRequest.spawn_id)
  bool acked = false;               ///< the agent reported it (pid known, or failed to start)
  Clock::time_point sent{};         ///< when the start request was last sent (re-sent until acked)
  long long agent_pid = 0;          ///< the pid of the agent that reported it
  int signal = 0;                   ///< the strongest signal asked for (re-sent until the agent reports it gone)
  Clock::time_point signal_sent{};
};

struct ModuleRun {
  runtime::ModuleDeployment cfg;
  std::vector<std::string> robots;  ///< robot names of its scenario
  double h_sg = 0.0;
  bool started = false;
  bool task_over = false;            ///< its world finished the scenario's task: nothing is restarted
  std::string end;                   ///< "", "failed: ...", "unplugged"
  bool paused_for_unplug = false;    ///< a pause was asked for an unplug without standby: resume on plug
  bool ticked = false;               ///< its world has reported a tick past 0 (the module came up)
  int repairs = 0;                   ///< restarts because it did not come up (docs/security.md, "Start-up")
  Clock::time_point started_at{};    ///< when its processes were last started
  launcher::DrainWatch drain;        ///< draining: the bounds of its drain
};


/// User + system CPU seconds of a process so far (/proc/<pid>/stat), -1 if it cannot be read.
double process_cpu_s(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return -1.0;
  std::istringstream in(text.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && in >> field; ++i) {  // fields 14 and 15: utime, stime (clock ticks)
    if (i == 14) utime = std::strtoull(field.c_str(), nullptr, 10);
    if (i == 15) stime = std::strtoull(field.c_str(), nullptr, 10);
  }
  return static_cast<double>(utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

/// Tasks a coordinator's queue state lists as done (its compact done-set).
size_t done_in(const msg::CoordinatorState& cs) {
  return static_cast<size_t>(std::count_if(cs.done_by().begin(), cs.done_by().end(), [](uint8_t b) { return b != 0; }));
}

/// Starts a process on this machine (launcher::spawn); with rt_priority > 0 the child runs SCHED_FIFO at that
/// priority, and so do the threads it creates (Fast DDS's receive and event threads inherit it).
pid_t spawn(const std::string& exe, const std::vector<std::string>& args, int rt_priority = 0,
            int participant_id = -1, const std::string& identity = "") {
  return launcher::spawn("tandem up", exe, args, launcher::SpawnOptions{rt_priority, participant_id, identity});
}

/// The launcher's state and its actions; the main loop calls poll() until nothing runs.
class Launcher {
 public:
  Launcher(Deployment d, std::string file) : d_(std::move(d)), file_(std::move(file)), dir_(self_dir()) {}

  /// Validates every module (scenario read once) and starts what autostarts.
  void prepare_module(const runtime::ModuleDeployment& cfg) {
    ModuleRun run;
    run.cfg = cfg;
    const sim::Scenario sc = sim::load_scenario(cfg.scenario);
    for (const auto& c : sc.cases) {
      if (c.name == cfg.case_name) run.h_sg = sim::make_module(sc, c).safe_grasp_force;
    }
    for (const auto& r : sc.robots) run.robots.push_back(r.name);
    modules_[cfg.name] = run;
  }

  void start_module(const std::string& name) {
    ModuleRun& mr = modules_.at(name);
    const auto& m = mr.cfg;
    mr.started = true;
    mr.end.clear();
    mr.task_over = false;
    mr.ticked = false;
    mr.started_at = Clock::now();
    Child w;
    w.label = m.name + "/world";
    w.role = "world";
    w.module = m.name;
    w.exe = dir_ + "/tandem-world";
    w.args = common_args(m);
    // On several hosts the world also waits for every robot of each arm (standbys included) before its first
    // tick: the primaries' host may answer later than a standby's, and the arms would start braked. (With a
    // recorder common_args counts them already.)
    if (!d_.hosts.empty() && !records_ticks() && m.standby > 0) {
      w.args.insert(w.args.end(), {"--observers", std::to_string(m.standby)});
    }
    w.host = runtime::host_of(m, "world", "", false);
    launch(w);
    for (int i = 0; i <= m.supervisor_standby; ++i) {
      start_supervisor(m.name, i == 0 ? runtime::RoleOptions::kPrimaryStrength : 60 - 10 * i, "");
    }
    for (const auto& robot : mr.robots) {
      for (int i = 0; i <= m.standby; ++i) {
        // The primary has strength 100; standbys 50, 40, ...: the world follows the strongest live one.
        start_robot(m.name, robot, i == 0 ? runtime::RoleOptions::kPrimaryStrength : 60 - 10 * i, "");
      }
    }
  }

  void start_coordinators() {
    if (!d_.coordinator) return;
    for (int i = 0; i <= d_.coordinator_standby; ++i) {
      start_coordinator(i == 0 ? "coordinator" : "coordinator@standby" + std::to_string(i), i > 0, "");
    }
  }

  void start_coordinator(const std::string& id, bool standby, const char* note) {
    Child c;
    c.label = id;
    c.role = "coordinator";
    c.exe = dir_ + "/tandem-coordinator";
    c.args = {"--deployment-file", file_, "--domain", std::to_string(d_.domain_id), "--timeout",
              std::to_string(std::max(30.0, 3 * d_.timeout)), "--id", id};
    if (standby) c.args.push_back("--standby");
    // A restart: the queue has a history, so it must take over with its state, never afresh.
    if (std::strcmp(note, " (restart)") == 0) c.args.push_back("--resume");
    c.host = runtime::coordinator_host_of(d_, standby);
    launch(c, note);
  }

  /// Starts a robot for `module`/`robot` with the given strength; false if the process could not be started.
  bool start_robot(const std::string& module, const std::string& robot, int strength, const char* note) {
    return start_ranked("robot", module, robot, strength, {"--arm", robot}, note);
  }

  /// Starts a supervisor for `module`: the primary (strength 100) or a standby (lower).
  void start_supervisor(const std::string& module, int strength, const char* note) {
    start_ranked("supervisor", module, "supervisor", strength, {}, note);
  }

  /// A process that serves a slot of a module by strength (an arm's robot, the module's supervisor): its
  /// slot is kept in Child::arm (standby strengths and live counts are per slot), its label is the slot, with
  /// "@strength" for a standby.
  bool start_ranked(const char* role, const std::string& module, const std::string& slot, int strength,
                    std::vector<std::string> extra, const char* note) {
    Child c;
    c.arm = module + "/" + slot;
    c.label = c.arm + (strength == runtime::RoleOptions::kPrimaryStrength ? "" : "@" + std::to_string(strength));
    c.role = role;
    c.module = module;
    c.strength = strength;
    c.exe = dir_ + "/tandem-" + role;
    c.args = common_args(modules_.at(module).cfg);
    extra.insert(extra.end(), {"--strength", std::to_string(strength)});
    c.args.insert(c.args.end(), extra.begin(), extra.end());
    c.host = runtime::host_of(modules_.at(module).cfg, role, slot, strength != runtime::RoleOptions::kPrimaryStrength);
    return launch(c, note);
  }

  /// Strength for a new standby of `arm` (launcher::next_standby_strength over the live robots of the arm).
  int standby_strength(const std::string& arm) const {
    std::vector<int> live;
    for (const auto& c : children_) {
      if (c.running && c.arm == arm) live.push_back(c.strength);
    }
    return launcher::next_standby_strength(live);
  }
  const Child* primary_of(const std::string& arm) const {
    for (const auto& c : children_) {
      if (c.running && !c.expected && c.arm == arm && c.strength == runtime::RoleOptions::kPrimaryStrength) return &c;
    }
    return nullptr;
  }
  int live_robots(const std::string& arm, const Child* except = nullptr) const {
    int n = 0;
    for (const auto& c : children_) n += (c.running && !c.expected && c.arm == arm && &c != except) ? 1 : 0;
    return n;
  }

  // ---- live commands ------------------------------------------------------------------------------------

  void handle(const msg::ControlRequest& req) {
    if (req.deployment() != d_.name) return;
    if (to_supervisor(req.command())) return;  // the launcher's own, to supervisors
    // Requests are re-sent until answered: carry each out once.
    if (req.seq() != 0 && !handled_seqs_.insert(req.seq()).second) return;
    current_seq_ = req.seq();
    switch (req.command()) {
      case msg::CMD_DOWN:
        if (!stopping_) say(true, "'down' requested over DDS; stopping %d process(es)\n", running());
        g_stop = true;
        break;
      case msg::CMD_KILL:
        kill_target(req.target());
        break;
      case msg::CMD_PLUG:
        plug(req);
        break;
      case msg::CMD_UNPLUG:
        unplug(req);
        break;
      default:
        say(false, "unknown command %d (accepted: down, kill, plug, unplug)\n", static_cast<int>(req.command()));
    }
    std::fflush(stdout);
  }

  static bool to_supervisor(msg::ControlCommand c) {
    return c == msg::CMD_PAUSE || c == msg::CMD_RESUME || c == msg::CMD_DRAIN;
  }

  /// Prints a command's outcome and keeps it as the launcher's answer (its status detail), which the
  /// `tandem plug/unplug/kill` that sent the request waits for.
  void say(bool ok, const char* fmt, ...) __attribute__((format(printf, 3, 4))) {
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    std::printf("tandem up: %s", buf);
    std::string text(buf);
    while (!text.empty() && text.back() == '\n') text.pop_back();
    if (current_seq_ == 0) return;  // no live command's (seq 0: the launcher's own requests)
    const auto [it, fresh] = answers_.try_emplace(current_seq_);
    Answer& a = it->second;
    if (fresh) {
      a = Answer{ok, text};
    } else {  // a further line for the same request (e.g. kill of a module)
      a.text += "; " + text;
      a.ok = a.ok && ok;
    }
    while (answers_.size() > 256 && answers_.begin()->first != current_seq_) answers_.erase(answers_.begin());
  }

  void kill_target(const std::string& target) {
    bool found = false;
    for (auto& c : children_) {
      if (!c.running) continue;
      if (c.label == target || (c.module == target && !target.empty())) {
        say(true, "fault injection: SIGKILL %s (pid %d%s%s)\n", c.label.c_str(), c.pid, c.host.empty() ? "" : " on ",
            c.host.c_str());
        signal_child(c, SIGKILL);
        found = true;
      }
    }
    if (!found) say(false, "'kill %s': no such running process or module\n", target.c_str());
  }

  /// What the plug and unplug rules need to know of a module (launcher::ModuleFacts).
  launcher::ModuleFacts module_facts(const std::string& name) const {
    launcher::ModuleFacts f;
    const auto it = modules_.find(name);
    if (it == modules_.end()) return f;
    f.known = true;
    f.started = it->second.started;
    f.end = it->second.end;
    const auto ts = task_states_.find(name);
    f.failed = ts != task_states_.end() && ts->second.state() == static_cast<uint8_t>(plan::TaskStateCode::Failed);
    for (size_t i = 0; i < 2 && i < it->second.robots.size(); ++i) f.arms[i] = it->second.robots[i];
    return f;
  }

  void plug(const msg::ControlRequest& req) {
    const std::string& name = req.target();
    if (req.target_kind() == msg::TARGET_MODULE) {
      plug_module(name, req.scenario(), req.case_name(), req.host());
      return;
    }
    if (req.target_kind() != msg::TARGET_ROBOT) {
      say(false, "'plug %s': expected a robot for an arm (<module>/<arm>) or a module\n", name.c_str());
      return;
    }
    const auto slash = name.find('/');
    const std::string module = name.substr(0, slash), robot = slash == std::string::npos ? "" : name.substr(slash + 1);
    const Child* primary = primary_of(name);
    const launcher::PlugDecision dec = launcher::plug_robot(name, robot, req.standby(), module_facts(module),
                                                            primary != nullptr ? primary->pid : 0, standby_strength(name));
    if (dec.action == launcher::PlugDecision::Action::Refuse) {
      say(false, "%s\n", dec.text.c_str());
      return;
    }
    if (!start_robot(module, robot, dec.strength, " (plugged)")) {
      say(false, "'plug robot %s': the process could not be started\n", name.c_str());
      return;
    }
    say(true, "%s\n", dec.text.c_str());
    resume_if_paused_for_unplug(module);
  }

  /// Plugs a module in again (one of the deployment, or one failed by a drop: cleared), or a new one from a
  /// scenario and case (on `host` in a multi-host deployment).
  void plug_module(const std::string& name, const std::string& scenario, const std::string& case_name,
                   const std::string& host) {
    using Action = launcher::PlugDecision::Action;
    const launcher::PlugDecision dec = launcher::plug_module(name, module_facts(name), !scenario.empty(),
                                                             !case_name.empty(), file_);
    switch (dec.action) {
      case Action::Refuse:
        say(false, "%s\n", dec.text.c_str());
        return;
      case Action::ClearModule:
        say(true, "%s\n", dec.text.c_str());
        task_states_.erase(name);
        modules_.at(name).end = "cleared";
        if (governor_) governor_->set_available(name, true);
        stop_module(name);
        pending_clears_.push_back(name);  // started again once its processes are gone
        return;
      case Action::AddModule:
        if (!add_module(name, scenario, case_name, host)) return;
        break;
      case Action::StartModule:
      case Action::StartRobot:
        break;
    }
    say(true, "plugging module %s (%s, case %s)\n", name.c_str(), modules_.at(name).cfg.scenario.c_str(),
                modules_.at(name).cfg.case_name.c_str());
    if (governor_) {  // plugged by hand: out of the governor's parked set, and in its hands again
      governor_->set_available(name, false);
      governor_->set_available(name, true);
    }
    start_module(name);
  }

  /// A new module from a scenario and case: its host checked (multi-host), its scenario loaded and its case found.
  bool add_module(const std::string& name, const std::string& scenario, const std::string& case_name,
                  const std::string& host) {
    runtime::ModuleDeployment cfg;
    cfg.name = name;
    cfg.scenario = scenario;
    cfg.case_name = case_name;
    if (!d_.hosts.empty()) {
      if (host.empty() || runtime::find_host(d_, host) == nullptr) {
        std::string list;
        for (const auto& x : d_.hosts) list += (list.empty() ? "" : ", ") + x.name;
        say(false, "'plug module %s': a multi-host deployment places a new module on a host: give --host (hosts: %s)\n",
            name.c_str(), list.c_str());
        return false;
      }
      cfg.host = host;
    }
    try {
      prepare_module(cfg);
    } catch (const std::exception& e) {
      say(false, "'plug module %s': %s\n", name.c_str(), e.what());
      return false;
    }
    bool found = false;
    for (const auto& c : sim::load_scenario(cfg.scenario).cases) found = found || c.name == cfg.case_name;
    if (!found) {
      modules_.erase(name);
      say(false, "'plug module %s': no case '%s' in %s\n", name.c_str(), cfg.case_name.c_str(), cfg.scenario.c_str());
      return false;
    }
    return true;
  }

  void unplug(const msg::ControlRequest& req) {
    const std::string& name = req.target();
    using Action = launcher::UnplugDecision::Action;
    if (req.target_kind() == msg::TARGET_MODULE) {
      const launcher::UnplugDecision dec = launcher::unplug_module(name, module_facts(name));
      say(dec.action != Action::Refuse, "%s\n", dec.text.c_str());
      if (dec.action == Action::Refuse) return;
      ModuleRun& mr = modules_.at(name);
      mr.end = "draining";
      mr.drain.start(seconds());
      if (governor_) governor_->set_available(name, false);
      send(name, msg::CMD_DRAIN);
      return;
    }
    if (req.target_kind() != msg::TARGET_PROCESS) {
      say(false, "'unplug %s': expected a robot's label or a module\n", name.c_str());
      return;
    }
    Child* c = find_running(name);
    if (c != nullptr && c->role != "robot") c = nullptr;
    const launcher::UnplugDecision dec = launcher::unplug_robot(name, c != nullptr, c ? c->arm : "", c ? c->module : "",
                                                                c ? live_robots(c->arm, c) : 0);
    say(dec.action != Action::Refuse, "%s\n", dec.text.c_str());
    if (dec.action == Action::Refuse) return;
    c->expected = true;
    if (dec.action == Action::HandOver) {
      terminate(*c);  // it deletes its torque writer first: the world follows the next strongest at once
      return;
    }
    modules_.at(c->module).paused_for_unplug = true;
    send(c->module, msg::CMD_PAUSE);
    pending_unplugs_.push_back({c->label, c->module, Clock::now()});
  }

  // ---- supervision ---------------------------------------------------------------------------------------

  void poll() {
    reap();
    watch_hosts();
    resend_drains();
    for (auto& c : children_) {
      if (c.running || c.handled) continue;
      c.handled = true;
      on_exit(c);
    }
    // Failed modules being cleared: started again once every process of theirs is gone.
    for (auto it = pending_clears_.begin(); it != pending_clears_.end();) {
      bool gone = true;
      for (const auto& c : children_) gone = gone && !(c.running && c.module == *it);
      if (!gone || stopping_) {
        it = stopping_ ? pending_clears_.erase(it) : it + 1;
        continue;
      }
      std::printf("tandem up: module %s %s; starting it again from its initial grasp\n", it->c_str(),
                  modules_.at(*it).end == "repairing" ? "stopped for the repair" : "cleared");
      start_module(*it);
      it = pending_clears_.erase(it);
    }
    // Unplugs waiting for their module to be at rest.
    for (auto it = pending_unplugs_.begin(); it != pending_unplugs_.end();) {
      const auto ts = task_states_.find(it->module);
      const bool paused = ts != task_states_.end() && ts->second.state() == 3;
      const bool late = Clock::now() - it->since > std::chrono::seconds(5);
      Child* c = find_running(it->label);
      if (c == nullptr) {
        it = pending_unplugs_.erase(it);
        continue;
      }
      if (!paused && !late) {
        ++it;
        continue;
      }
      if (!paused) std::printf("tandem up: %s did not report paused within 5 s; unplugging %s anyway (the brakes hold the arm)\n", it->module.c_str(), c->label.c_str());
      std::printf("tandem up: %s paused; %s leaves, its arm is braked until a robot is plugged in\n",
                  it->module.c_str(), c->label.c_str());
      terminate(*c);
      it = pending_unplugs_.erase(it);
    }
    for (auto it = world_done_.begin(); it != world_done_.end();) {
      if (Clock::now() - it->second < std::chrono::seconds(2)) {
        ++it;
        continue;
      }
      for (auto& c : children_) {
        if (c.module != it->first || !c.running) continue;
        std::printf("tandem up: %s is still waiting after its module's task ended; stopping it\n", c.label.c_str());
        c.expected = true;
        terminate(c);
      }
      it = world_done_.erase(it);
    }
    // Said once: every process started so far has been heard (the deployment is up, as far as discovery goes).
    if (!all_heard_said_ && !stopping_) {
      int n = 0;
      bool all = true;
      for (const auto& c : children_) {
        if (!c.running || c.expected) continue;
        ++n;
        all = all && c.heard && !c.cut_off;
      }
      if (all && n > 0) {
        std::printf("tandem up: all %d process(es) heard on the domain\n", n);
        all_heard_said_ = true;
      }
    }
    // A process whose status was never heard within kSilentStartS of its start runs cut off from the domain
    // (seen in soaks: now and then a participant started beside many others never matched anyone): it is
    // killed, and its restart policy applies as for any failure.
    for (auto& c : children_) {
      if (!c.running || c.heard || c.expected || stopping_ || c.role == "discovery") continue;
      if (Clock::now() - c.started > std::chrono::duration<double>(kSilentStartS)) {
        std::printf("tandem up: %s (pid %d) was not heard on the domain within %.0f s of its start; SIGKILL, its "
                    "restart policy applies\n", c.label.c_str(), c.pid, kSilentStartS);
        signal_child(c, SIGKILL);
        c.heard = true;  // once
        c.cut_off = true;
      }
    }
    // A module that has not come up in time (start_timeout): some pair of its participants never matched.
    if (!stopping_) {
      for (auto& [name, mr] : modules_) {
        if (!mr.started || mr.ticked || !mr.end.empty() || mr.repairs >= kStartRepairs) continue;
        // (A world waits up to half its timeout for late sensor readers besides the first: not cut short.)
        const double limit = std::max(d_.start_timeout, 0.5 * d_.timeout + 2.0);
        if (Clock::now() - mr.started_at < std::chrono::duration<double>(limit)) continue;
        char why[96];
        std::snprintf(why, sizeof why, "its world did not tick within %.1f s of its start", limit);
        repair_start(name, why);
      }
    }
    // A process asked to stop alone that is still there after 5 s (hung, or stopped by a signal).
    for (auto& c : children_) {
      if (c.running && c.term_at != Clock::time_point{} && Clock::now() - c.term_at > std::chrono::seconds(5)) {
        std::printf("tandem up: %s did not stop within 5 s of SIGTERM; sending SIGKILL\n", c.label.c_str());
        signal_child(c, SIGKILL);
        c.term_at = Clock::time_point{};
      }
    }
    for (auto it = pending_restarts_.begin(); it != pending_restarts_.end();) {
      if (!it->child.module.empty() && modules_.at(it->child.module).task_over) {  // at once, not when due
        std::printf("tandem up: not restarting %s: module %s is done with its task\n", it->child.label.c_str(),
                    it->child.module.c_str());
        it = pending_restarts_.erase(it);
        continue;
      }
      if (stopping_ || Clock::now() < it->when) {
        ++it;
        continue;
      }
      Child c = it->child;
      it = pending_restarts_.erase(it);
      const std::optional<launcher::Role> role = launcher::parse_role(c.role);
      if (!role) continue;
      launcher::DueRestart f;
      f.role = *role;
      f.strength = c.strength;
      f.restart_as_standby = !c.module.empty() && modules_.at(c.module).cfg.restart_as == "standby";
      f.primary_alive = c.role == "robot" && primary_of(c.arm) != nullptr;
      f.standby_strength = c.arm.empty() ? 0 : standby_strength(c.arm);
      f.live_in_slot = c.arm.empty() ? 0 : live_robots(c.arm);
      f.task_over = !c.module.empty() && modules_.at(c.module).task_over;
      const launcher::DueRestartDecision d = launcher::due_restart(f);
      if (!d.start) {
        std::printf("tandem up: not restarting %s: %s\n", c.label.c_str(), d.why.c_str());
        continue;
      }
      if (c.role == "robot") {
        start_robot(c.module, c.arm.substr(c.arm.find('/') + 1), d.strength, " (restart)");
      } else if (c.role == "supervisor") {
        start_supervisor(c.module, d.strength, " (restart)");  // a standby: it adopts the serving one's plan
      } else {
        // No coordinator left: the queue's state lived only in their writers (transient-local), so hand the
        // newcomer the last state this launcher heard; it takes over from it.
        if (live_coordinators() == 0 && have_coord_state_ && coord_state_out_ != nullptr) {
          coord_state_out_->write(last_coord_state_);
          std::printf("tandem up: republished the coordinator's last state (%zu task(s) done) for its successor\n",
                      done_in(last_coord_state_));
        }
        start_coordinator("coordinator@r" + std::to_string(++coordinator_restarts_), true, " (restart)");
      }
    }
  }

  void on_exit(Child& c) {
    if (c.status >= 128) {  // killed: its shared-memory files are left behind (cleaned in the main loop)
      shm_dirty_ = true;
      killed_at_ = Clock::now();
    }
    const std::optional<launcher::Role> role = launcher::parse_role(c.role);
    if (!role) return;  // not a role the launcher supervises (never started as such)
    launcher::ExitFacts f;
    f.role = *role;
    f.status = c.status;
    f.expected = c.expected;
    f.never_heard = c.cut_off;
    f.stopping = stopping_;
    f.coordinated = d_.coordinator;
    f.max_repairs = kStartRepairs;
    ModuleRun* mr = c.module.empty() ? nullptr : &modules_.at(c.module);
    if (mr != nullptr) {
      f.module_ticked = mr->ticked;
      f.module_repairs = mr->repairs;
      f.module_draining = mr->end == "draining";
      f.restart_always = mr->cfg.restart == "always";
    }
    f.live_peers = *role == launcher::Role::Coordinator ? live_coordinators() : live_robots(c.arm);
    const std::string code = std::to_string(c.status);
    switch (launcher::on_exit(f)) {
      case launcher::ExitVerdict::Nothing:
        return;
      case launcher::ExitVerdict::AllTasksDone:
        std::printf("tandem up: %s reports every task done; stopping the deployment\n", c.label.c_str());
        coordinator_done_ = true;
        stop_all(SIGTERM);
        return;
      case launcher::ExitVerdict::Restart:
        break;
      case launcher::ExitVerdict::RepairStart:
        repair_start(c.module, c.label + (c.cut_off ? " was never heard on the domain" : " exited with code " + code) +
                                   " before the first tick: its peers did not match");
        return;
      case launcher::ExitVerdict::Drained:
        std::printf("tandem up: module %s drained; stopping its processes\n", c.module.c_str());
        mr->end = "unplugged";
        if (governor_) governor_->set_available(c.module, false);
        stop_module(c.module);
        return;
      case launcher::ExitVerdict::ModuleLostPlan:
        // No leader and no replica has the module's plan (its leader died before a standby heard it). Tier 3: the
        // module restarts from its initial grasp with new processes; the coordinator re-plans its task meanwhile.
        std::printf("tandem up: module %s lost its plan (%s had no leader to follow); restarting the module\n",
                    c.module.c_str(), c.label.c_str());
        ++plan_restarts_;
        mr->end = "repairing";
        stop_module(c.module);
        pending_clears_.push_back(c.module);
        return;
      case launcher::ExitVerdict::TaskOver:
        // The module's task is over. Its processes end by themselves, but for one that joined late (a restarted
        // standby) and waits for ticks that will not come: stopped after a grace for the summaries.
        if (*role == launcher::Role::World) {
          world_done_[c.module] = Clock::now();
          mr->task_over = true;
        }
        return;
      case launcher::ExitVerdict::ModuleFailed:
        std::printf("tandem up: module %s failed (%s exited with code %d); stopping its processes, the others go on\n",
                    c.module.c_str(), c.label.c_str(), c.status);
        mr->end = "failed: " + c.label + " exited with code " + code;
        if (governor_) governor_->set_available(c.module, false);
        stop_module(c.module);
        return;
      case launcher::ExitVerdict::Fail:
        fail(c.label + " exited with code " + code);
        return;
    }
    // Restart: by the policy of its slot, then whether the slot is still served.
    const bool restarting =
        mr == nullptr ? schedule_restart(c, d_.coordinator_restart, d_.coordinator_restart_limit,
                                         d_.coordinator_restart_window, 0.2)
                      : schedule_restart(c, mr->cfg.restart, mr->cfg.restart_limit, mr->cfg.restart_window,
                                         mr->cfg.restart_backoff);
    f.live_peers = *role == launcher::Role::Coordinator ? live_coordinators() : live_robots(c.arm);
    const launcher::AfterRestart next = launcher::after_restart(f, restarting);
    switch (*role) {
      case launcher::Role::Coordinator:
        if (next == launcher::AfterRestart::Fail) {
          fail(c.label + " exited with code " + code + " and no coordinator is left");
          return;
        }
        std::printf("tandem up: %s exited with code %d; %s\n", c.label.c_str(), c.status,
                    f.live_peers > 0 ? "a standby coordinator carries on" : "a new coordinator will take over");
        return;
      case launcher::Role::Supervisor:
        std::printf("tandem up: %s exited with code %d; a standby supervisor carries on%s\n", c.label.c_str(), c.status,
                    restarting ? " (the exited one comes back as a standby)" : "");
        return;
      case launcher::Role::Robot:
      case launcher::Role::World:
        break;
    }
    switch (next) {
      case launcher::AfterRestart::CarriesOn:
        std::printf("tandem up: %s exited with code %d; another robot serves its arm, the deployment goes on\n",
                    c.label.c_str(), c.status);
        return;
      case launcher::AfterRestart::WaitsForRestart:
        std::printf("tandem up: %s exited with code %d; its arm is braked until the restarted robot answers\n",
                    c.label.c_str(), c.status);
        return;
      case launcher::AfterRestart::WaitsForPlug:
        std::printf("tandem up: %s exited with code %d and nobody serves %s: the module stays paused with the "
                    "arm braked; plug a robot in ('tandem plug robot %s') to resume\n",
                    c.label.c_str(), c.status, c.arm.c_str(), c.arm.c_str());
        return;
      case launcher::AfterRestart::Fail:
        fail(c.label + " exited with code " + code);
        return;
    }
  }

  /// Restart policy (OTP-style, launcher::RestartPolicy): returns true if `c` will be started again after the
  /// backoff.
  bool schedule_restart(const Child& c, const std::string& policy, int limit, double window, double backoff) {
    const std::string key = c.arm.empty() ? "coordinator" : c.arm;  // an arm, a module's supervisor slot
    const auto now = Clock::now();
    const launcher::RestartRule rule{policy, limit, window, backoff};
    const launcher::RestartDecision d = restarts_.on_exit(key, c.status, rule, std::chrono::duration<double>(now - t0_).count());
    if (d.kind == launcher::RestartDecision::Kind::None) return false;
    if (d.kind == launcher::RestartDecision::Kind::GiveUp) {
      std::printf("tandem up: giving up on %s: %d restarts within %.0f s (restart_limit %d)\n", key.c_str(), d.count,
                  window, limit);
      return false;
    }
    const double delay = d.delay;
    std::printf("tandem up: restarting %s in %.2f s (restart %d of at most %d within %.0f s)\n", c.label.c_str(),
                delay, d.count, limit, window);
    pending_restarts_.push_back({now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(delay)), c});
    return true;
  }

  /// A module that did not come up: a process gave up waiting for its peers (world 3: peers not found; world,
  /// robot or supervisor 4: no tick, input or report), or was never heard, before the world's first tick, or its
  /// world did not tick within start_timeout. With DDS-Security a pair of participants sometimes never
  /// authenticates (a race in Fast DDS 2.9.1's SecurityManager, fixed in 2.9.2; docs/security.md), and nothing in
  /// the library retries it; new participants for the whole module (new GUIDs, fresh handshakes with everyone)
  /// repair it. Restarted up to kStartRepairs times, logged and counted.
  void repair_start(const std::string& module, const std::string& why) {
    ModuleRun& mr = modules_.at(module);
    ++mr.repairs;
    ++start_repairs_;
    std::printf("tandem up: module %s did not come up (%s); restarting the module with new participants (repair %d "
                "of at most %d)\n", module.c_str(), why.c_str(), mr.repairs, kStartRepairs);
    mr.end = "repairing";
    stop_module(module);
    pending_clears_.push_back(module);
  }

  void stop_module(const std::string& module) {
    for (auto& c : children_) {
      if (c.module != module) continue;
      c.expected = true;
      if (c.running) terminate(c);
    }
    pending_unplugs_.erase(std::remove_if(pending_unplugs_.begin(), pending_unplugs_.end(),
                                          [&](const auto& u) { return u.module == module; }),
                           pending_unplugs_.end());
    // Restarts still pending for it are dropped (a module plugged in again starts afresh).
    const size_t before = pending_restarts_.size();
    pending_restarts_.erase(std::remove_if(pending_restarts_.begin(), pending_restarts_.end(),
                                           [&](const auto& r) { return r.child.module == module; }),
                            pending_restarts_.end());
    if (pending_restarts_.size() != before) {
      std::printf("tandem up: %zu pending restart(s) of module %s dropped: it was stopped\n",
                  before - pending_restarts_.size(), module.c_str());
    }
  }

  void fail(const std::string& why) {
    std::fprintf(stderr, "tandem up: %s; stopping the deployment\n", why.c_str());
    failed_ = true;
    stop_all(SIGTERM);
  }

  /// Asks one process to stop (SIGTERM); poll() sends SIGKILL if it is still there 5 s later.
  void terminate(Child& c) {
    if (!c.running || (c.pid <= 0 && c.host.empty())) return;
    signal_child(c, SIGTERM);
    if (c.term_at == Clock::time_point{}) c.term_at = Clock::now();
  }

  /// The answer to a request that came while the deployment stops: nothing is carried out.
  void refuse_while_stopping(const msg::ControlRequest& req) {
    if (to_supervisor(req.command())) return;  // the launcher's own, to supervisors
    if (req.seq() != 0 && !handled_seqs_.insert(req.seq()).second) return;
    current_seq_ = req.seq();
    if (req.command() == msg::CMD_DOWN) {
      say(true, "'down' requested over DDS; the deployment is already stopping\n");
    } else {
      // As the user typed it: "plug robot m1/left", "unplug module m2", "kill m1/world".
      const char* kind = req.target_kind() == msg::TARGET_MODULE && req.command() != msg::CMD_KILL ? "module "
                         : req.target_kind() == msg::TARGET_ROBOT ||
                                   (req.target_kind() == msg::TARGET_PROCESS && req.command() == msg::CMD_UNPLUG)
                             ? "robot "
                             : "";
      say(false, "'%s %s%s' refused: the deployment is stopping\n", runtime::command_name(req.command()), kind,
          req.target().c_str());
    }
  }

  void stop_all(int sig) {
    if (!stopping_) stop_started_ = Clock::now();
    stopping_ = true;
    for (auto& c : children_) {
      if (c.running && (c.pid > 0 || !c.host.empty())) signal_child(c, sig);
    }
  }

  /// While stopping: SIGKILL whatever did not stop within 5 s.
  void escalate() {
    if (stopping_ && !escalated_ && Clock::now() - stop_started_ > std::chrono::seconds(5)) {
      std::printf("tandem up: %d process(es) did not stop within 5 s; sending SIGKILL\n", running());
      stop_all(SIGKILL);
      escalated_ = true;
    }
  }

  void reap(bool block = false) {
    for (auto& c : children_) {
      if (!c.host.empty()) continue;  // started by an agent: its exit comes in the agent's state (on_agent_state)
      if (c.running && c.pid <= 0) {  // never started
        c.running = false;
        c.status = 127;
      }
      if (!c.running) continue;
      int st = 0;
      const pid_t r = ::waitpid(c.pid, &st, block ? 0 : WNOHANG);
      if (r == c.pid) {
        c.running = false;
        c.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        if (c.participant_id >= 0) free_ids_.push_back(c.participant_id);  // reused last
        c.participant_id = -1;
      }
    }
  }

  // --- Shedding whole modules (launcher::Governor, docs/failure-model.md) ---------------------------------
  /// A world's status: paused for load or not, for the governor.
  void on_world_load(const std::string& module, const std::string& detail, uint64_t tick) {
    const auto it = modules_.find(module);
    if (it != modules_.end() && tick > 0) it->second.ticked = true;
    if (!governor_ || stopping_) return;
    if (it == modules_.end() || !it->second.started || !it->second.end.empty()) return;
    governor_->on_load(module, detail.rfind("paused for load", 0) == 0, seconds());
  }
  /// Carries out the governor's decision, if any: a module parks (its supervisor pauses the path, then its
  /// processes stop; the coordinator re-plans its task) or comes back (its processes start again).
  void govern() {
    if (!governor_ || stopping_) return;
    const launcher::Governor::Decision dec = governor_->decide(seconds());
    if (dec.kind == launcher::Governor::Decision::Kind::Park) {
      std::printf("tandem up: parking module %s (%s): its processes stop once it is paused; its task goes back to "
                  "the queue\n", dec.module.c_str(), dec.why.c_str());
      modules_.at(dec.module).end = "parked: " + dec.why;
      ++parks_;
      send(dec.module, msg::CMD_PAUSE);
      pending_parks_.push_back({dec.module, Clock::now()});
    } else if (dec.kind == launcher::Governor::Decision::Kind::Unpark) {
      std::printf("tandem up: unparking module %s (%s)\n", dec.module.c_str(), dec.why.c_str());
      pending_unparks_.push_back(dec.module);
    }
    // Parks: stop once the module reports paused (object at rest), or after 2 s (the brakes hold it).
    for (auto it = pending_parks_.begin(); it != pending_parks_.end();) {
      const auto ts = task_states_.find(it->module);
      const bool paused = ts != task_states_.end() && ts->second.state() == 3;
      if (!paused && Clock::now() - it->since < std::chrono::seconds(2)) {
        ++it;
        continue;
      }
      stop_module(it->module);
      task_states_.erase(it->module);
      std::printf("tandem up: module %s parked%s\n", it->module.c_str(), paused ? " (paused first)" : " (not paused within 2 s)");
      it = pending_parks_.erase(it);
    }
    // Unparks: once every process of the module is gone.
    for (auto it = pending_unparks_.begin(); it != pending_unparks_.end();) {
      bool gone = true;
      for (const auto& c : children_) gone = gone && !(c.running && c.module == *it);
      if (!gone) {
        ++it;
        continue;
      }
      start_module(*it);
      it = pending_unparks_.erase(it);
    }
  }
  struct PendingPark {
    std::string module;
    Clock::time_point since;
  };
  std::unique_ptr<launcher::Governor> governor_;
  std::vector<PendingPark> pending_parks_;
  std::vector<std::string> pending_unparks_;
  unsigned long long parks_ = 0;
  /// "m3, m4" (for status and the summary).
  std::string parked_text() const {
    std::string out;
    if (!governor_) return out;
    for (const auto& m : governor_->parked_set()) out += (out.empty() ? "" : ", ") + m;
    return out;
  }

  void send(const std::string& module, msg::ControlCommand command) {
    msg::ControlRequest req;
    req.deployment(d_.name);
    req.command(command);
    req.target_kind(msg::TARGET_MODULE);
    req.target(module);
    req.seq(++seq_);
    control_out_->write(req);
  }

  void resume_if_paused_for_unplug(const std::string& module) {
    ModuleRun& mr = modules_.at(module);
    if (!mr.paused_for_unplug) return;
    mr.paused_for_unplug = false;
    send(module, msg::CMD_RESUME);  // it resumes once the arm's new robot answers (the world releases the brake)
  }

  int running() const {
    int n = 0;
    for (const auto& c : children_) n += c.running ? 1 : 0;
    return n;
  }
  bool busy() const { return running() > 0 || (!pending_restarts_.empty() && !stopping_); }
  int live_coordinators() const {
    int n = 0;
    for (const auto& c : children_) n += (c.running && c.role == "coordinator") ? 1 : 0;
    return n;
  }
  Child* find_running(const std::string& label) {
    for (auto& c : children_) {
      if (c.running && c.label == label) return &c;
    }
    return nullptr;
  }

  /// A status sample from process `label` (pid): it is part of the domain.
  void on_status(const std::string& label, long long pid, bool active, msg::ServingRole serving) {
    for (auto& c : children_) {
      if (!(c.running && c.label == label && c.pid == pid)) continue;
      c.heard = true;
      if (serving != msg::ROLE_NONE) c.leads = serving == msg::ROLE_PRIMARY;
      if (active && !c.active_seen && c.host.empty()) {
        // The CPU one start costs (a soak restarts about a thousand processes an hour): user + system time
        // of the process from its start to its first active status.
        c.active_seen = true;
        const double cpu = process_cpu_s(static_cast<pid_t>(pid));
        if (cpu >= 0.0) start_cpu_[c.role].push_back(cpu);
      }
    }
  }
  /// Per role: the CPU seconds each process took from its start to active.
  std::map<std::string, std::vector<double>> start_cpu_;

  /// A leader that has not acknowledged a drain sent every second for kDeafLeader does not hear the launcher:
  /// seen in a soak-small hour, a restarted supervisor that took the lead never heard the drain (nor the
  /// coordinator's next task) while its standby logged "drain requested"; the module then idled until the drain
  /// bound stopped it. Such a leader is stopped when another supervisor of the module runs: that one takes over
  /// with the drain it heard and finishes the task properly.
  void stop_deaf_leader(const std::string& module, ModuleRun& mr) {
    Child* leader = nullptr;
    bool other = false;
    for (auto& c : children_) {
      if (!c.running || c.role != "supervisor" || c.module != module) continue;
      if (c.leads && leader == nullptr) {
        leader = &c;
      } else {
        other = true;
      }
    }
    if (leader == nullptr || !other) return;
    mr.drain.leader_stopped();
    ++deaf_leaders_;
    std::printf("tandem up: %s leads module %s but has not acknowledged its drain for %.0f s (it does not hear the "
                "launcher); stopping it, a standby supervisor that heard the drain takes over\n",
                leader->label.c_str(), module.c_str(), launcher::DrainWatch::kDeafLeader);
    leader->expected = true;  // not restarted: the module is leaving
    terminate(*leader);
  }

  /// A drain the module's leading supervisor has not acknowledged (its task state neither draining nor left)
  /// is sent again every second: found by the soak, a leader whose control reader missed the one request kept
  /// taking tasks, and the module never left (its plug-in retries gave up after 60 s).
  /// The bounds are launcher::DrainWatch's: past kDeafLeader the leader is taken for deaf (stop_deaf_leader); past kTimeout the module is stopped.
  void resend_drains() {
    const double now = seconds();
    for (auto& [name, mr] : modules_) {
      if (mr.end != "draining") continue;
      const auto ts = task_states_.find(name);
      const bool acked = ts != task_states_.end() && (ts->second.state() == static_cast<uint8_t>(plan::TaskStateCode::Draining) ||
                                                      ts->second.state() == static_cast<uint8_t>(plan::TaskStateCode::Left));
      const launcher::DrainStep step = mr.drain.step(now, acked);
      if (step.force) {
        const std::string last = ts == task_states_.end() ? std::string("no task state heard")
                                                          : std::string("its task state: ") + plan::task_state_name(ts->second.state());
        std::printf("tandem up: module %s did not drain within %.0f s (%s); stopping it with its task unfinished, "
                    "which goes back to the queue\n", name.c_str(), launcher::DrainWatch::kTimeout, last.c_str());
        ++forced_drains_;
        mr.end = "unplugged";
        stop_module(name);
        continue;
      }
      if (step.stop_leader) stop_deaf_leader(name, mr);
      if (step.warn) {
        std::printf("tandem up: module %s has not acknowledged its drain within %.0f s; still asking\n", name.c_str(),
                    launcher::DrainWatch::kWarnAfter);
      }
      if (step.resend) send(name, msg::CMD_DRAIN);
    }
  }

  void on_task_state(const msg::TaskState& ts) {
    if (ts.deployment() == d_.name) task_states_[ts.module_id()] = ts;
  }

  Deployment d_;
  std::string file_, dir_;
  std::deque<Child> children_;  // deque: references stay valid as children are added
  std::map<std::string, ModuleRun> modules_;
  struct PendingRestart {
    Clock::time_point when;
    Child child;
  };
  std::vector<PendingRestart> pending_restarts_;
  launcher::RestartPolicy restarts_;
  Clock::time_point t0_ = Clock::now();
  struct PendingUnplug {
    std::string label, module;
    Clock::time_point since;
  };
  std::vector<PendingUnplug> pending_unplugs_;
  std::vector<std::string> pending_clears_;  ///< failed modules being cleared (plug module): restarted once stopped
  static constexpr int kStartRepairs = 3;
  unsigned long long forced_drains_ = 0;     ///< unplugged modules stopped with their task unfinished (DrainWatch)
  unsigned long long deaf_leaders_ = 0;      ///< leaders stopped because they did not hear a drain
  unsigned long long start_repairs_ = 0;     ///< modules restarted because they did not come up
  unsigned long long plan_restarts_ = 0;     ///< modules restarted because their supervisors lost the plan
  std::map<std::string, Clock::time_point> world_done_;  ///< modules whose world finished its task, and when
  std::map<std::string, msg::TaskState> task_states_;
  bus::Writer<msg::ControlRequest, msg::ControlRequestPubSubType>* control_out_ = nullptr;
  bus::Writer<msg::AgentRequest, msg::AgentRequestPubSubType>* agent_out_ = nullptr;
  std::unique_ptr<launcher::HostWatch> hosts_;  ///< multi-host: the agents' liveness (nullptr without hosts:)
  unsigned long long spawns_ = 0;
  /// This launcher's run, in every request to the agents: random, so that two runs (two `tandem up`, even with
  /// one pid in two containers) never take each other's processes.
  unsigned long long run_ = [] {
    std::random_device rd;
    unsigned long long r = 0;
    while (r == 0) r = (static_cast<unsigned long long>(rd()) << 32) ^ rd();
    return r;
  }();
  std::map<std::string, std::map<long long, double>> agent_heard_;  ///< per host: agent pid -> last heard [s]
  std::set<std::string> two_agents_;  ///< hosts with two agents at once, said once
  std::map<std::string, unsigned long long> agent_runs_;  ///< the run each host's agent last said it serves
  /// Hosts whose agent does not serve this run yet (not heard, or it has not received this launcher's heartbeat:
  /// its reader of the requests has not matched yet).
  std::vector<std::string> agents_not_serving() const {
    std::vector<std::string> out;
    for (const auto& h : d_.hosts) {
      const auto it = agent_runs_.find(h.name);
      if (it == agent_runs_.end() || it->second != run_) out.push_back(h.name);
    }
    return out;
  }
  std::set<std::string> other_runs_;             ///< "<host>/<run>" of other runs seen, said once
  std::set<unsigned long long> fenced_;  ///< processes of a host that came back, SIGKILLed once
  bus::Writer<msg::CoordinatorState, msg::CoordinatorStatePubSubType>* coord_state_out_ = nullptr;
  msg::CoordinatorState last_coord_state_;  ///< the latest queue state heard from a coordinator
  bool have_coord_state_ = false;
  bool stopping_ = false, escalated_ = false, failed_ = false, coordinator_done_ = false;
  bool all_heard_said_ = false;
  Clock::time_point stop_started_{};
  bool shm_dirty_ = false;           ///< a child was killed: its shared-memory files wait to be removed
  Clock::time_point killed_at_{};
  int coordinator_restarts_ = 0;
  unsigned long long seq_ = 0;
  std::set<unsigned long long> handled_seqs_;
  /// The outcome of a live command, kept by its seq (the newest 256) until its sender has read it: status keeps
  /// one sample per process, so an answer to another terminal's request can replace this one before it is
  /// read, and a request re-sent (not yet answered, as its sender sees it) gets its answer again.
  struct Answer {
    bool ok = false;
    std::string text;
  };
  std::map<unsigned long long, Answer> answers_;
  unsigned long long current_seq_ = 0;  ///< the live command being carried out (its say() lines are its answer)
  /// SCHED_FIFO priority for the per-tick processes (0: normal scheduling); set once before any start.
  int rt_priority_ = 0;
  /// Participant ids for children, the one left longest ago first: 20-119 (0-19 stay for Fast DDS's own choice:
  /// the launcher, `tandem status` and other tools).
  std::deque<int> free_ids_ = [] {
    std::deque<int> ids;
    for (int i = 20; i < static_cast<int>(bus::kMaxParticipantId); ++i) ids.push_back(i);
    return ids;
  }();

 private:
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
  /// The DDS-Security identity of a child ("" without security): its slot's (runtime::identities).
  std::string identity_of(const Child& c) const {
    if (d_.security_keys.empty()) return "";
    if (c.role == "robot") return runtime::identity_name("robot", c.module, c.arm.substr(c.arm.find('/') + 1));
    return runtime::identity_name(c.role, c.module);
  }
  bool records_ticks() const {
    if (d_.record.empty()) return false;
    if (d_.record_topics.empty()) return true;
    const std::string t = "," + d_.record_topics + ",";
    return t.find(",ticks,") != std::string::npos || t.find(",all,") != std::string::npos;
  }
  /// Starts `c` (here, or by its host's agent); false if it could not be started.
  bool launch(Child& c, const char* note = "") {
    // The participant id left longest ago (see services/dds/src/participant.cpp); none left: Fast DDS picks.
    c.participant_id = -1;
    if (!free_ids_.empty()) {
      c.participant_id = free_ids_.front();
      free_ids_.pop_front();
    }
    c.running = true;
    c.started = Clock::now();
    c.heard = false;
    if (c.host.empty()) {
      c.pid = spawn(c.exe, c.args, rt_priority_of(c), c.participant_id, identity_of(c));
      std::printf("  started %-22s pid %d%s\n", c.label.c_str(), c.pid, note);
    } else if (hosts_ != nullptr && hosts_->lost(c.host)) {
      std::printf("  cannot start %-18s on %s: the host is lost%s\n", c.label.c_str(), c.host.c_str(), note);
      c.pid = -1;
      mark_exited(c, 127);
    } else {
      c.pid = 0;  // known when the agent reports it
      c.spawn_id = ++spawns_;
      c.acked = false;
      c.signal = 0;
      send_start(c);
      std::printf("  started %-22s on %s%s\n", c.label.c_str(), c.host.c_str(), note);
    }
    children_.push_back(c);
    return c.running && (c.pid > 0 || !c.host.empty());
  }
  int rt_priority_of(const Child& c) const { return c.role == "coordinator" ? 0 : rt_priority_; }

 public:
  // ---- multi-host: the agents ------------------------------------------------------------------------------

  msg::AgentRequest request(const std::string& host, msg::AgentRequestKind kind) const {
    msg::AgentRequest r;
    r.host(host);
    r.deployment(d_.name);
    r.kind(kind);
    r.run(run_);
    return r;
  }

  void send_start(Child& c) {
    msg::AgentRequest r = request(c.host, msg::AGENT_START);
    r.spawn_id(c.spawn_id);
    r.label(c.label);
    r.role(c.role);
    r.args(c.args);
    r.rt_priority(rt_priority_of(c));
    r.participant_id(c.participant_id);
    r.identity(identity_of(c));
    agent_out_->write(r);
    c.sent = Clock::now();
  }

  /// Sends `sig` to a child: here with kill(2), on another host through its agent.
  void signal_child(Child& c, int sig) {
    if (c.host.empty()) {
      if (c.pid > 0) ::kill(c.pid, sig);
      return;
    }
    if (hosts_ != nullptr && hosts_->lost(c.host)) return;  // counted as gone already
    if (c.signal != SIGKILL) c.signal = sig;  // re-sent by watch_hosts until the agent reports it gone
    send_signal(c.host, c.spawn_id, c.label, c.signal);
    c.signal_sent = Clock::now();
  }
  void send_signal(const std::string& host, unsigned long long spawn_id, const std::string& label, int sig) {
    msg::AgentRequest r = request(host, msg::AGENT_SIGNAL);
    r.spawn_id(spawn_id);
    r.label(label);
    r.signal(sig);
    agent_out_->write(r);
  }

  /// Every 100 ms, to each host's agent: the launcher lives, and whether it counts the host as lost (one-way
  /// partitions: an agent that hears the launcher but is not heard fences too). Ends the run with end=true.
  void heartbeat(bool end = false) {
    if (hosts_ == nullptr) return;
    for (const auto& h : d_.hosts) {
      msg::AgentRequest r = request(h.name, end ? msg::AGENT_END : msg::AGENT_HEARTBEAT);
      r.host_lost(hosts_->lost(h.name));
      agent_out_->write(r);
    }
  }

  /// A child is gone: exited with `status` (128 + signal if killed), or counted as failed (its host was lost).
  void mark_exited(Child& c, int status) {
    c.running = false;
    c.status = status;
    if (c.participant_id >= 0) free_ids_.push_back(c.participant_id);
    c.participant_id = -1;
  }

  /// An agent's heartbeat and the state of the processes it started for this launcher.
  void on_agent_state(const msg::AgentState& st) {
    if (st.deployment() != d_.name || hosts_ == nullptr || !hosts_->known(st.host())) return;
    agent_runs_[st.host()] = st.run();
    if (st.run() != run_ && st.run() != 0) {
      if (other_runs_.insert(st.host() + "/" + std::to_string(st.run())).second) {
        std::printf("tandem up: the agent of %s serves another launcher run (%llu): is another `tandem up` of %s "
                    "running? It will not start this run's processes while that one lives\n",
                    st.host().c_str(), static_cast<unsigned long long>(st.run()), d_.name.c_str());
      }
      return;
    }
    // Which agent pids answer for the host, and when each was last heard: a process belongs to the agent that
    // reported it, and counts as failed when that agent falls silent (a restarted agent: its processes died with
    // it) even while the host is heard through another pid. Two pids heard at once: two agents for one host (the
    // newer leaves by itself).
    auto& pids = agent_heard_[st.host()];
    pids[st.pid()] = seconds();
    for (const auto& [other, at] : pids) {
      if (other != st.pid() && seconds() - at < 0.5 && two_agents_.insert(st.host()).second) {
        std::printf("tandem up: two agents answer for host %s (pids %lld and %lld): one agent per host\n",
                    st.host().c_str(), static_cast<long long>(other), static_cast<long long>(st.pid()));
      }
    }
    if (hosts_->heard(st.host(), seconds())) {
      std::printf("tandem up: host %s is back (its agent is heard again); its processes were replaced meanwhile\n",
                  st.host().c_str());
    }
    if (st.run() != run_) return;  // it has not had a request of this run yet
    std::set<unsigned long long> listed;
    for (const auto& ac : st.children()) {
      listed.insert(ac.spawn_id());
      Child* c = nullptr;
      for (auto& x : children_) {
        if (x.spawn_id == ac.spawn_id() && x.host == st.host()) c = &x;
      }
      if (c == nullptr || !c->running) {
        // A process this launcher counts as gone (its host was lost meanwhile): fenced off, so that two robots
        // never command one arm as primaries.
        if (ac.running() && fenced_.insert(ac.spawn_id()).second) {
          std::printf("tandem up: %s on %s still runs but was counted as failed; SIGKILL\n", ac.label().c_str(),
                      st.host().c_str());
          send_signal(st.host(), ac.spawn_id(), ac.label(), SIGKILL);
        }
        continue;
      }
      if (!c->acked) {
        c->acked = true;
        c->agent_pid = st.pid();
        c->pid = static_cast<pid_t>(ac.pid());
        if (ac.pid() > 0) std::printf("  %-30s runs on %s as pid %lld\n", c->label.c_str(), c->host.c_str(), static_cast<long long>(ac.pid()));
      }
      if (!ac.running()) {
        if (ac.pid() <= 0) std::printf("tandem up: the agent of %s could not start %s: %s\n", st.host().c_str(), c->label.c_str(), st.detail().c_str());
        mark_exited(*c, ac.status());
        if (c->status >= 128) {
          shm_dirty_ = true;
          killed_at_ = Clock::now();
        }
      }
    }
    // A process the agent acknowledged and no longer lists (it forgot this run: restarted with the same pid?).
    for (auto& c : children_) {
      if (c.running && c.acked && c.host == st.host() && c.agent_pid == st.pid() && listed.count(c.spawn_id) == 0) {
        std::printf("tandem up: the agent of %s no longer reports %s; counted as failed\n", st.host().c_str(), c.label.c_str());
        mark_exited(c, 128 + SIGKILL);
      }
    }
  }

  /// Hosts whose agent fell silent: their processes count as failed (on_exit: standbys elsewhere take over, a
  /// module without its world is re-planned). Start requests not yet answered are re-sent.
  void watch_hosts() {
    if (hosts_ == nullptr) return;
    for (const auto& h : hosts_->newly_lost(seconds())) {
      std::string labels;
      int n = 0;
      for (auto& c : children_) {
        if (!c.running || c.host != h) continue;
        labels += (labels.empty() ? "" : ", ") + c.label;
        ++n;
        mark_exited(c, 128 + SIGKILL);
      }
      std::printf("tandem up: host %s lost: no word from its agent for %.1f s; its %d process(es) count as failed%s%s\n",
                  h.c_str(), d_.host_timeout, n, n > 0 ? ": " : "", labels.c_str());
    }
    // Processes whose agent fell silent while its host is still heard (through a new agent: a restart).
    for (auto& c : children_) {
      if (!c.running || c.host.empty() || !c.acked || hosts_->lost(c.host)) continue;
      const auto& pids = agent_heard_[c.host];
      const auto it = pids.find(c.agent_pid);
      if (it != pids.end() && seconds() - it->second > d_.host_timeout) {
        std::printf("tandem up: the agent of %s that ran %s (pid %lld) is gone (another agent answers for the host); "
                    "counted as failed\n", c.host.c_str(), c.label.c_str(), c.agent_pid);
        mark_exited(c, 128 + SIGKILL);
      }
    }
    const auto now = Clock::now();
    for (auto& c : children_) {
      if (!c.running || c.host.empty() || c.acked) continue;
      if (now - c.started > std::chrono::seconds(10)) {
        std::printf("tandem up: the agent of %s did not start %s within 10 s; counted as failed to start\n",
                    c.host.c_str(), c.label.c_str());
        mark_exited(c, 127);
      } else if (now - c.sent > std::chrono::milliseconds(200)) {
        send_start(c);
      }
    }
    // Signals are re-sent until the agent reports the process gone (the request topic keeps the newest 32 per
    // host: a burst to many processes of one host could lose some).
    for (auto& c : children_) {
      if (c.running && !c.host.empty() && c.signal != 0 && now - c.signal_sent > std::chrono::milliseconds(200)) {
        send_signal(c.host, c.spawn_id, c.label, c.signal);
        c.signal_sent = now;
      }
    }
  }
  double seconds() const { return std::chrono::duration<double>(Clock::now() - t0_).count(); }
};

/// The plant step and control-law step of a module, timed here (thread CPU time, the median of a few batches).
void time_model(const runtime::ModuleDeployment& m, launcher::Calibration& c) {
  const sim::Scenario sc = sim::load_scenario(m.scenario);
  const sim::CaseConfig* cc = nullptr;
  for (const auto& x : sc.cases) {
    if (x.name == m.case_name) cc = &x;
  }
  if (cc == nullptr) return;
  const sim::ModuleSetup ms = sim::make_module(sc, *cc);
  auto thread_cpu_us = [] {
    timespec ts{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e6 + static_cast<double>(ts.tv_nsec) * 1e-3;
  };
  model::ModulePlant plant(ms.plant);
  plant.reset(ms.initial);
  const std::array<model::Vec3, 2> tau{model::gravity(ms.plant.arms[0], ms.initial.q[0]),
                                       model::gravity(ms.plant.arms[1], ms.initial.q[1])};
  model::HybridController law(ms.plant.arms[0], ms.control[0]);
  model::ArmSensors in;
  in.q = ms.initial.q[0];
  std::vector<double> plant_us, law_us;
  for (int batch = 0; batch < 5; ++batch) {
    double t = thread_cpu_us();
    for (int k = 0; k < 40; ++k) plant.step(tau, 0.0, ms.period, ms.substeps);
    plant_us.push_back((thread_cpu_us() - t) / 40.0);
    t = thread_cpu_us();
    for (int k = 0; k < 200; ++k) (void)law.step(in, sim::supervisor_reference(ms, 0, k));
    law_us.push_back((thread_cpu_us() - t) / 200.0);
  }
  std::sort(plant_us.begin(), plant_us.end());
  std::sort(law_us.begin(), law_us.end());
  c.plant_us = plant_us[2];
  c.law_us = law_us[2];
}

// The real-time capacity estimate: what the deployment needs against what the machine has, calibrated on this
// machine (launcher::Calibration: a cross-process wake-up, a plant step, a law step), with a warning when it does
// not fit. In lockstep there is no real-time load.
struct Capacity {
  std::string text;
  double per_module = 0.0, per_standby = 0.0, usable = 0.0;
  bool realtime = false;
  /// Cores a module needs with its standby robots.
  double of(const runtime::ModuleDeployment& m) const { return per_module + 2.0 * m.standby * per_standby; }
};

Capacity capacity_estimate(const Deployment& d) {
  Capacity cap;
  if (d.timing != "realtime") {
    cap.text = "lockstep: no real-time load (it runs as fast as the machine allows)";
    return cap;
  }
  cap.realtime = true;
  launcher::Calibration cal = launcher::calibrate_wakeup();
  const auto t0 = std::chrono::steady_clock::now();
  if (!d.modules.empty()) {
    try {
      time_model(d.modules.front(), cal);
    } catch (const std::exception&) {
      // the scenario was checked when the file was loaded; a failure here only leaves the model's share out
    }
  }
  cal.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const launcher::CapacityModel model;
  const double per_module = cal.ok ? model.core_per_module(cal) : kCorePerModule;
  const double per_standby = cal.ok ? model.core_per_standby(cal) : kCorePerStandbyRobot;
  cap.per_module = per_module;
  cap.per_standby = per_standby;
  double need = 0.0;
  for (const auto& m : d.modules) need += per_module + 2.0 * m.standby * per_standby;
  const long cores = ::sysconf(_SC_NPROCESSORS_ONLN);
  cap.usable = kUsableShare * static_cast<double>(cores);
  const std::string measured = cal.ok ? "calibrated here: " + launcher::describe(cal)
                                      : std::string("the calibration could not run: figures from docs/benchmarks.md");
  char text[768];
  if (need > kUsableShare * static_cast<double>(cores)) {
    std::snprintf(text, sizeof text,
                  "warning: this deployment needs about %.2f cores in real time (%.3f per module, %.3f per standby "
                  "robot; %s) and this machine has %ld: expect modules to pause for load%s, or run it in lockstep",
                  need, per_module, per_standby, measured.c_str(), cores,
                  d.overload_brake ? " (the world holds the object and brakes; they resume when there is room)"
                                   : "; overload_brake is off, so late commands may drop objects");
  } else {
    std::snprintf(text, sizeof text, "real time: about %.2f of %ld cores (%.3f per module, %.3f per standby robot; %s)",
                  need, cores, per_module, per_standby, measured.c_str());
  }
  std::string out = text;
  if (d.discovery == "simple" && d.modules.size() >= 4) {
    // Measured: 8 modules with simple discovery all paused for load at start-up, none with the server.
    out += "; with 4 or more modules 'discovery: server' keeps discovery from loading the machine";
  }
  cap.text = out;
  return cap;
}

}  // namespace

void up_usage(std::FILE* f) {
  std::fputs(
      "usage: tandem up <deploy.yaml> [--summary FILE] [--record FILE.mcap] [--check]\n"
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
  std::string file, summary_file, record_file;
  bool check_only = false;
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
  Launcher L(d, file);
  try {
    for (const auto& m : d.modules) L.prepare_module(m);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem up: %s\n", e.what());
    return 2;
  }

  // DDS-Security: every identity's files are there and valid before anything starts; the launcher joins as
  // "launcher", its children inherit the keys' directory and get their slot's identity (identity_of).
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
                d.domain_id, d.timing.c_str(), capacity_estimate(d).text.c_str());
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
      L.rt_priority_ = d.realtime_priority;
      (void)launcher::raise_service_priority(why);  // permitted wherever SCHED_FIFO is
    } else {
      std::printf("tandem up: note: real-time priority %d not permitted here (%s); the per-tick processes run "
                  "with normal scheduling and may miss more ticks (run as root, or grant CAP_SYS_NICE or an "
                  "RLIMIT_RTPRIO; 'realtime_priority: 0' silences this)\n",
                  d.realtime_priority, why.c_str());
    }
  }

  // discovery: server. The launcher starts the Discovery Server first (a child like the others: it dies with
  // the launcher) and makes itself and every process it starts a client of it.
  const std::time_t launcher_started = std::time(nullptr) - 1;  // shared-memory files of this run: newer
  pid_t discovery_server = -1;
  if (d.discovery == "server" && d.discovery_start == "external") {
    std::printf("  discovery server             %s (external)\n", runtime::discovery_text(d).c_str());
    runtime::use_discovery(d);
  } else if (d.discovery == "server") {
    const std::string exe = "/usr/bin/fast-discovery-server";
    if (::access(exe.c_str(), X_OK) != 0) {
      std::fprintf(stderr, "tandem up: discovery: server needs %s (Debian package fastdds-tools)\n", exe.c_str());
      return 2;
    }
    discovery_server = spawn(exe, {"-i", "0", "-l", d.discovery_address, "-p", std::to_string(runtime::discovery_port_of(d))});
    if (discovery_server < 0) return 2;
    std::printf("  started discovery server     pid %d on %s:%d\n", discovery_server, d.discovery_address.c_str(),
                runtime::discovery_port_of(d));
    runtime::use_discovery(d);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // listening before the first client comes
    if (::waitpid(discovery_server, nullptr, WNOHANG) == discovery_server) {
      std::fprintf(stderr, "tandem up: the Discovery Server exited at start: is %s an address of this machine, and "
                           "port %d free? (discovery_start: external uses one that runs already)\n",
                   d.discovery_address.c_str(), runtime::discovery_port_of(d));
      return 2;
    }
  }
  struct ServerStop {
    pid_t pid;
    ~ServerStop() { stop(); }
    void stop() {
      if (pid <= 0) return;
      ::kill(pid, SIGTERM);
      for (int i = 0; i < 50 && ::waitpid(pid, nullptr, WNOHANG) == 0; ++i) ::usleep(20000);
      if (::waitpid(pid, nullptr, WNOHANG) == 0) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, nullptr, 0);
      }
      pid = -1;
    }
  } server_stop{discovery_server};
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
  L.control_out_ = &control_out;
  bus::Writer<msg::CoordinatorState, msg::CoordinatorStatePubSubType> coord_state_out(part, bus::kCoordinatorStateTopic,
                                                                                    bus::TopicKind::Task);
  L.coord_state_out_ = &coord_state_out;
  // Multi-host: the agents (docs/multihost.md). Every host's agent is heard before anything starts.
  std::unique_ptr<bus::Writer<msg::AgentRequest, msg::AgentRequestPubSubType>> agent_out;
  std::unique_ptr<bus::Reader<msg::AgentState, msg::AgentStatePubSubType>> agent_state;
  if (!d.hosts.empty()) {
    agent_out = std::make_unique<bus::Writer<msg::AgentRequest, msg::AgentRequestPubSubType>>(part, bus::kAgentRequestTopic,
                                                                                              bus::TopicKind::Control);
    agent_state = std::make_unique<bus::Reader<msg::AgentState, msg::AgentStatePubSubType>>(part, bus::kAgentStateTopic,
                                                                                            bus::TopicKind::Status);
    L.agent_out_ = agent_out.get();
  }
  runtime::StatusPublisher launcher_status(part, "launcher", "launcher", "");
  launcher_status.msg().deployment(d.name);
  launcher_status.set(runtime::Lifecycle::Active, "");
  LiveView view(d.name);
  if (!d.hosts.empty()) {
    std::vector<std::string> names;
    for (const auto& h : d.hosts) names.push_back(h.name);
    L.hosts_ = std::make_unique<launcher::HostWatch>(names, d.host_timeout);
    const auto asked = Clock::now();
    auto last_note = asked - std::chrono::seconds(10);
    while (!g_stop) {
      msg::AgentState st;
      while (agent_state->take(st)) L.on_agent_state(st);
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
              L.rt_priority_ > 0 ? (", SCHED_FIFO " + std::to_string(L.rt_priority_)).c_str() : "");
  const Capacity capacity = capacity_estimate(d);
  if (capacity.text.find("warning") != std::string::npos) std::printf("tandem up: %s\n", capacity.text.c_str());
  // record: the recorder joins first and is heard before any module starts, so that it has every tick (the
  // worlds also wait for its readers in lockstep: --observers). It is stopped last, after the summaries.
  pid_t recorder = -1;
  if (!d.record.empty()) {
    std::vector<std::string> rargs{"record", file, "-o", d.record, "--attached"};
    if (!d.record_topics.empty()) rargs.insert(rargs.end(), {"--topics", d.record_topics});
    recorder = spawn(L.dir_ + "/tandem", rargs, 0, -1, d.security_keys.empty() ? "" : "recorder");
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
  struct RecorderStop {
    pid_t pid;
    int status = 0;  ///< exit code (128 + signal if killed); 0 until it ended
    ~RecorderStop() { stop(); }
    /// Whether it has exited by itself (it should not before it is stopped: a failed recording).
    bool exited() {
      int st = 0;
      if (pid <= 0 || ::waitpid(pid, &st, WNOHANG) != pid) return false;
      status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
      pid = -1;
      return true;
    }
    void stop() {  // SIGTERM: it closes the file (summary section, footer); SIGKILL after 30 s
      if (pid <= 0) return;
      ::kill(pid, SIGTERM);
      for (int i = 0; i < 1500; ++i) {
        if (exited()) return;
        ::usleep(20000);
      }
      std::fprintf(stderr, "tandem up: the recorder did not close its file within 30 s; SIGKILL\n");
      ::kill(pid, SIGKILL);
      int st = 0;
      ::waitpid(pid, &st, 0);
      status = 128 + SIGKILL;
      pid = -1;
    }
  } recorder_stop{recorder};
  bool recording_failed = false;
  if (L.hosts_) L.hosts_->restart_clock(L.seconds());  // the recorder was awaited without reading agent states
  std::set<std::string> start_parked;
  if (capacity.realtime && d.coordinator && d.shed_modules && d.overload_brake) {
    // Shedding whole modules (launcher::Governor), and admission: the modules the calibrated estimate fits,
    // in file order, start; the others start parked and come back when the machine has been calm.
    std::vector<std::string> order;
    size_t fit = 0;
    double need = 0.0;
    bool full = false;
    for (const auto& m : d.modules) {
      if (!m.autostart) continue;
      order.push_back(m.name);
      full = full || need + capacity.of(m) > capacity.usable;
      if (!full) {
        need += capacity.of(m);
        ++fit;
      }
    }
    // With hosts: the estimate is of this machine, and the modules run on others too: admit them all (the governor
    // still parks modules whose worlds keep pausing for load). Seen: a three-host test's second module started
    // parked because all of them were counted against the launcher's machine.
    if (!d.hosts.empty()) fit = order.size();
    L.governor_ = std::make_unique<launcher::Governor>(order);
    for (const std::string& m : L.governor_->admit(fit, L.seconds())) {
      start_parked.insert(m);
      L.modules_.at(m).end = "parked: admission";
    }
    if (!start_parked.empty()) {
      std::string list;
      for (const auto& m : start_parked) list += (list.empty() ? "" : ", ") + m;
      std::printf("tandem up: starting %s parked: the calibrated estimate gives %.3f core per module (with its "
                  "standbys) and %zu of %zu fit in %.2f usable cores; parked modules start when the machine has been "
                  "calm (docs/failure-model.md, \"Shedding whole modules\")\n",
                  list.c_str(), capacity.of(d.modules.front()), fit, order.size(), capacity.usable);
    }
  }
  for (const auto& m : d.modules) {
    if (m.autostart && !start_parked.count(m.name)) L.start_module(m.name);
  }
  L.start_coordinators();

  std::map<std::string, msg::RobotSummary> robots;
  std::map<std::string, msg::WorldSummary> worlds;
  msg::CoordinatorState last_coord;
  bool have_coord = false;
  const auto t0 = Clock::now();
  auto last_print = t0;
  auto collect = [&] {
    msg::RobotSummary rs;
    while (robot_sum.take(rs)) robots[rs.robot_id()] = rs;
    msg::WorldSummary ws;
    while (world_sum.take(ws)) worlds[ws.module_id()] = ws;
    msg::TaskState ts;
    while (task_states.take(ts)) L.on_task_state(ts);
    msg::CoordinatorState cs;
    bool advanced = false;
    while (coord_state.take(cs)) {
      // The most advanced state (the launcher's own republished copy comes back too).
      const bool more = !have_coord || cs.next_task_id() > last_coord.next_task_id() ||
                        (cs.next_task_id() == last_coord.next_task_id() && cs.done_total() > last_coord.done_total());
      if (cs.deployment() == d.name &&
          (more || (cs.next_task_id() == last_coord.next_task_id() && cs.done_total() == last_coord.done_total()))) {
        advanced = advanced || more;
        last_coord = cs;
        have_coord = true;
        L.last_coord_state_ = cs;
        L.have_coord_state_ = true;
      }
    }
    // Mirrored: every advance of the queue is republished from the launcher's own writer (transient-local), so
    // that a coordinator that starts with --resume always finds the queue's state, even when every coordinator
    // that published it died meanwhile. Found by the hour-long soak: the primary died while its restarted peer
    // was still starting, both came back with --resume and no state, and no task was done again.
    if (advanced && d.coordinator) coord_state_out.write(last_coord);
  };
  std::vector<std::string> running_labels;
  auto launcher_published = Clock::now();
  auto heartbeat_sent = Clock::now();
  while (L.busy()) {
    if (agent_state) {  // before poll(): a host is judged on the newest word from its agent
      msg::AgentState st;
      while (agent_state->take(st)) L.on_agent_state(st);
      if (Clock::now() - heartbeat_sent >= std::chrono::milliseconds(100)) {
        L.heartbeat();
        heartbeat_sent = Clock::now();
      }
    }
    L.poll();
    L.govern();
    L.escalate();
    {
      // The launcher's status lists what it runs, so that `tandem status` knows whom to wait for.
      std::vector<std::string> labels;
      labels.reserve(L.children_.size());
      for (const auto& c : L.children_) {
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
      L.on_status(ps.process_id(), ps.pid(), ps.state() == static_cast<uint8_t>(runtime::Lifecycle::Active), ps.serving());
      if (ps.role() == "world" && ps.deployment() == d.name) L.on_world_load(ps.module_id(), ps.detail(), ps.tick());
    }
    msg::ControlRequest req;
    while (control.take(req)) {
      if (req.deployment() != d.name) continue;
      if (L.stopping_) {
        L.refuse_while_stopping(req);
      } else {
        L.handle(req);
      }
      // The answer the sender waits for (again, for a request re-sent: see Launcher::answers_).
      const auto answer = L.answers_.find(req.seq());
      if (answer != L.answers_.end()) {
        launcher_status.msg().reply_seq(req.seq());
        launcher_status.msg().reply_ok(answer->second.ok);
        launcher_status.msg().reply_text(answer->second.text);
        launcher_status.publish();
      }
    }
    if (recorder_stop.exited()) {
      std::printf("tandem up: the recorder exited during the run (code %d); %s is incomplete\n", recorder_stop.status,
                  d.record.c_str());
      recording_failed = true;
    }
    // Shared-memory files of killed children, once the others had 2 s to let go of them (unmapped ones only).
    if (L.shm_dirty_ && Clock::now() - L.killed_at_ > std::chrono::seconds(2)) {
      L.shm_dirty_ = false;
      runtime::clean_stale_shm(launcher_started);
    }
    if (g_stop && !L.stopping_) {
      std::printf("tandem up: stop requested; stopping %d process(es)\n", L.running());
      L.stop_all(SIGTERM);
    }
    const auto now = Clock::now();
    if (now - last_print > std::chrono::seconds(1)) {
      std::printf("[%5.1f s] processes running %d/%zu\n", std::chrono::duration<double>(now - t0).count(), L.running(),
                  L.children_.size());
      view.print(stdout);
      std::fflush(stdout);
      last_print = now;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  L.reap(true);
  if (agent_out) {  // the agents stop whatever is left of this run (--once agents exit)
    L.heartbeat(true);
    (void)agent_out->wait_for_acks(1.0);
  }
  size_t started_modules = 0;
  for (const auto& [name, mr] : L.modules_) started_modules += mr.started ? 1 : 0;
  const auto settle = Clock::now();
  while (worlds.size() < started_modules && Clock::now() - settle < std::chrono::milliseconds(500)) {
    robot_sum.wait(0.05);
    collect();
  }
  collect();

  std::printf("\nsummary (%.1f s wall)\n", std::chrono::duration<double>(Clock::now() - t0).count());
  std::printf("%-16s %8s %12s %12s %12s %10s %10s %9s\n", "robot", "ticks", "e_p Sp RMS", "e_p pos RMS",
              "e_p phi RMS", "e_h RMS N", "min h_n N", "rejected");
  std::ofstream out;
  if (!summary_file.empty()) {
    out.open(summary_file);
    if (!out) std::fprintf(stderr, "tandem up: cannot write the summary to %s\n", summary_file.c_str());
    out.precision(17);
  }
  bool grasp_ok = true, failed = L.failed_;
  for (const auto& [name, mr] : L.modules_) {
    if (!mr.started) continue;
    const bool counted = mr.end.empty() || mr.end == "draining";  // failed or unplugged modules: reported only
    if (!mr.end.empty()) std::printf("%s: %s\n", name.c_str(), mr.end.c_str());
    if (out) out << name << ".end=" << (mr.end.empty() ? "ran" : mr.end.substr(0, mr.end.find(':'))) << "\n";
    for (const auto& [id, r] : robots) {
      if (id.rfind(name + "/", 0) != 0) continue;
      char min_force[32] = "-";  // a robot that computed no tick has no force to report
      if (r.ticks() > 0) std::snprintf(min_force, sizeof min_force, "%.2f", r.min_normal_force());
      std::printf("%-16s %8llu %12.4e %12.4e %12.4e %10.4f %10s %9llu\n", id.c_str(),
                  static_cast<unsigned long long>(r.ticks()), r.ep_sel_rms(), r.ep_pos_rms(), r.ep_ori_rms(),
                  r.eh_rms(), min_force, static_cast<unsigned long long>(r.rejected()));
      if (counted && r.ticks() > 0 && r.min_normal_force() < mr.h_sg) grasp_ok = false;
      if (out) {
        out << id << ".ep_pos_rms=" << r.ep_pos_rms() << "\n" << id << ".ep_ori_rms=" << r.ep_ori_rms() << "\n"
            << id << ".ep_sel_rms=" << r.ep_sel_rms() << "\n" << id << ".eh_rms=" << r.eh_rms() << "\n"
            << id << ".min_normal_force=" << r.min_normal_force() << "\n" << id << ".ticks=" << r.ticks() << "\n"
            << id << ".rejected=" << r.rejected() << "\n";
      }
    }
    const auto w = worlds.find(name);
    if (w == worlds.end()) {
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
                  ws.switch_ep_max()[i], ws.switch_hn_min()[i], mr.h_sg);
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
  for (const auto& c : L.children_) {
    if (c.status != 0) {
      std::printf("process %s exited with code %d%s\n", c.label.c_str(), c.status,
                  c.expected ? " (unplugged, or its module stopped)" : "");
    }
  }
  if (d.coordinator && have_coord) {
    const size_t done = done_in(last_coord);
    const size_t dup = last_coord.done_total() > done ? static_cast<size_t>(last_coord.done_total() - done) : 0;
    std::printf("coordinator: %zu/%zu tasks done, %zu duplicate(s)\n", done, d.tasks.size(), dup);
    if (out) out << "coordinator.tasks_done=" << done << "\ncoordinator.duplicates=" << dup << "\n";
    for (size_t t = 0; t < last_coord.done_by().size() && t < d.tasks.size() && out; ++t) {
      const uint8_t by = last_coord.done_by()[t];
      if (by != 0 && by <= last_coord.modules().size()) {
        out << "coordinator.task." << d.tasks[t].name << "=" << last_coord.modules()[by - 1u] << "\n";
      }
    }
  }
  for (auto& [role, v] : L.start_cpu_) {
    if (v.empty()) continue;
    std::sort(v.begin(), v.end());
    const double median = v[v.size() / 2];
    std::printf("start-up CPU of a %s (start to active): median %.3f s, max %.3f s over %zu start(s)\n", role.c_str(),
                median, v.back(), v.size());
    if (out) out << "startup_cpu." << role << ".median_s=" << median << "\nstartup_cpu." << role << ".starts=" << v.size() << "\n";
  }
  std::printf("tandem up: start-up repairs (modules restarted because they did not come up): %llu\n", L.start_repairs_);
  if (L.forced_drains_ > 0) {
    std::printf("tandem up: unplugged modules stopped before their task ended (drain over %.0f s): %llu\n",
                launcher::DrainWatch::kTimeout, L.forced_drains_);
  }
  if (out) {
    out << "start_repairs=" << L.start_repairs_ << "\nplan_restarts=" << L.plan_restarts_ << "\nforced_drains=" << L.forced_drains_
        << "\ndeaf_leaders=" << L.deaf_leaders_ << "\n";
  }
  if (L.plan_restarts_ > 0) std::printf("tandem up: modules restarted because their supervisors lost the plan: %llu\n", L.plan_restarts_);
  if (L.governor_) {
    std::printf("tandem up: modules parked for load during the run: %llu time(s); parked at the end: %s\n",
                L.parks_, L.parked_text().empty() ? "none" : L.parked_text().c_str());
    if (out) out << "shedding.parks=" << L.parks_ << "\nshedding.parked=" << L.parked_text() << "\n";
  }
  launcher_status.set(runtime::Lifecycle::Finalized, "run over");
  if (recorder > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last summaries reach the recorder too
    std::fflush(stdout);
    recorder_stop.stop();
    if (recorder_stop.status != 0) {
      std::printf("tandem up: the recorder failed (code %d): %s is incomplete\n", recorder_stop.status, d.record.c_str());
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
  for (const auto& c : L.children_) killed = killed || c.status >= 128;
  if (killed || discovery_server > 0) {
    server_stop.stop();
    std::this_thread::sleep_for(std::chrono::milliseconds(2100));  // the last files are 2 s old (clean_stale_shm)
    // Every child is gone: what the launcher itself still holds (the ports it sent to) is left behind too.
    int removed = runtime::clean_stale_shm(launcher_started, static_cast<int>(d.domain_id), true);
    // The Discovery Server is a participant of domain 0 (its shared-memory port stays when it stops).
    if (discovery_server > 0) removed += runtime::clean_stale_shm(launcher_started, 0, true);
    if (removed > 0) std::printf("removed %d shared-memory file(s) left by killed processes\n", removed);
  }
  if (d.coordinator && !L.coordinator_done_) failed = true;
  const bool ok = !failed && !g_stop && grasp_ok && !recording_failed;
  if (out && d.coordinator) out << "coordinator.done=" << (L.coordinator_done_ ? 1 : 0) << "\n";
  std::printf("result: %s\n", ok ? "PASS (all processes finished, safe grasp kept)"
                                 : (g_stop ? "STOPPED" : "FAIL (see above)"));
  return ok ? 0 : 1;
}

}  // namespace tandem::cli
