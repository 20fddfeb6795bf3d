// The launcher's supervision of its children as a component: events in, actions out, and no DDS, no clock and no
// fork/kill/waitpid inside. `tandem up` (services/cli/up_run.cpp) feeds it what happens (a process exited, a
// status or task state heard, a live command, an agent's report, the time as seconds since the launcher started)
// and it acts through two interfaces: an Executor starts and signals processes (here by fork/exec and kill(2), or
// through the agent of another host), and an Outbox carries what it says (log lines, requests to a module's
// supervisors, the coordinator's state republished, a new module's scenario read).
//
// What it decides with the rules of exit_rules.hpp, restart_policy.hpp, plug_rules.hpp, drain_watch.hpp,
// governor.hpp and host_watch.hpp, and what it keeps over time: the child table, pending restarts (and dropping
// them when their module stops), modules being cleared or repaired (started again once every process of theirs is
// gone), unplugs waiting for their module to pause, drains, parks, a process asked to stop alone and SIGKILLed 5 s
// later, the whole deployment's stop and its SIGKILL after 5 s, a process never heard on the domain within
// kSilentStartS (SIGKILLed, its restart policy applies), a module that did not come up in time (start repairs), and
// the agents of a multi-host deployment. docs/failure-model.md says what a user sees; tests/unit/
// test_launcher_supervisor.cpp drives it with a recording Executor.
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <functional>
#include <vector>

#include "tandem/launcher/drain_watch.hpp"
#include "tandem/launcher/governor.hpp"
#include "tandem/launcher/host_watch.hpp"
#include "tandem/launcher/plug_rules.hpp"
#include "tandem/launcher/restart_policy.hpp"

namespace tandem::launcher {

/// The ownership strength of a slot's primary (runtime::RoleOptions::kPrimaryStrength).
inline constexpr int kPrimaryStrength = 100;
/// A child not heard on the domain (its status) within this long of its start is cut off: killed and restarted.
inline constexpr double kSilentStartS = 15.0;
/// A world that said its task is done and has not exited this long after is stopped (SIGTERM, SIGKILL 5 s on) and
/// its module's task counts as over: a world once hung in its teardown after its last tick (CI, 2026-11-28), and
/// the launcher waited for it, with a robot's restart pending, until the test's 120 s ran out.
inline constexpr double kWorldExitGraceS = 5.0;

/// One process of the deployment, as the launcher tracks it.
struct Child {
  std::string label;   ///< process id in status: "m1/world", "m1/left", "m1/left@50", "coordinator"
  std::string role;    ///< world | supervisor | robot | coordinator
  std::string module;  ///< its module ("" for the coordinator)
  std::string arm;     ///< robots: "<module>/<robot>"; supervisors: "<module>/supervisor" (the slot)
  int strength = 0;    ///< robots, supervisors: ownership strength
  bool standby = false;  ///< coordinators: started as a standby
  bool resume = false;   ///< coordinators: a restart, which takes over with the queue's state (--resume)
  int pid = -1;
  bool running = true;
  int status = -1;        ///< exit code once gone (128 + signal if killed)
  bool expected = false;  ///< its exit is no failure (unplugged, drained, module stopped, restarted)
  bool handled = false;   ///< its exit has been dealt with
  double term_at = -1.0;  ///< when it was asked to stop alone (SIGTERM); SIGKILL 5 s later; -1: not asked
  double started = 0.0;   ///< when it was started [s]
  int participant_id = -1;  ///< its DDS participant id (TANDEM_PARTICIPANT_ID), -1: Fast DDS's choice
  bool heard = false;       ///< its status was heard over DDS (it is part of the domain)
  bool cut_off = false;     ///< killed because it was never heard (kSilentStartS)
  bool active_seen = false; ///< its status said active once
  bool leads = false;       ///< supervisors: its latest status says it leads its module
  double done_said = -1.0;  ///< worlds: when its status first said its task is done (-1: not yet)
  bool spun = false;        ///< killed by the launcher for a spinning thread (launcher::SpinWatch)
  double status_at = -1.0;  ///< when its latest status was heard (the time of the launcher's last poll then)
  // Multi-host: started by the agent of `host` ("" = by the launcher, on this machine).
  std::string host;
  unsigned long long spawn_id = 0;  ///< the launcher's request id (AgentRequest.spawn_id)
  bool acked = false;               ///< the agent reported it (pid known, or failed to start)
  double sent = 0.0;                ///< when the start request was last sent (re-sent until acked)
  long long agent_pid = 0;          ///< the pid of the agent that reported it
  int signal = 0;                   ///< the strongest signal asked for (re-sent until the agent reports it gone)
  double signal_sent = 0.0;
};

/// A module as the launcher runs it.
struct ModuleSpec {
  std::string name;
  std::string scenario, case_name;  ///< as said when it is plugged
  int standby = 0;                  ///< standby robots per arm
  int supervisor_standby = 0;
  RestartRule restart;              ///< of its robots and supervisors (policy, limit, window, backoff)
  bool restart_as_standby = true;   ///< `restart_as: standby`
  std::vector<std::string> robots;  ///< robot names of its scenario
  double h_sg = 0.0;                ///< the safe grasp force of its case (the summary's judge)
};

struct ModuleRun {
  ModuleSpec spec;
  bool started = false;
  bool task_over = false;          ///< its world finished the scenario's task: nothing is restarted
  ModuleEnd end;                   ///< whether it runs, or why it ended
  bool paused_for_unplug = false;  ///< a pause was asked for an unplug without standby: resume on plug
  bool ticked = false;             ///< its world has reported a tick past 0 (the module came up)
  int repairs = 0;                 ///< restarts because it did not come up (docs/security.md, "Start-up")
  int spin_repairs = 0;            ///< restarts because its world was killed for a spinning thread
  double started_at = 0.0;         ///< when its processes were last started [s]
  DrainWatch drain;                ///< draining: the bounds of its drain
  double load_paused_since = -1.0; ///< its world has said "paused for load" since then [s]; -1: it has not
};

struct SupervisorConfig {
  std::string deployment;        ///< its name (in messages)
  std::string deployment_file;   ///< as the user gave it (in a refusal of `plug module`)
  bool coordinated = false;      ///< a coordinator hands out tasks
  int coordinator_standby = 0;
  RestartRule coordinator_restart{"never", 3, 30.0, 0.2};
  double timeout = 10.0;         ///< the processes' timeout [s]
  double start_timeout = 20.0;   ///< a module whose world has not ticked within this long is repaired
  bool realtime = false;         ///< real-time timing: a world's first tick may wait up to world::StartWait's bound
  std::vector<std::string> hosts;  ///< multi-host: the hosts' names (empty: every process here)
  double host_timeout = 1.0;
  unsigned long long run = 0;    ///< this launcher's run (in every request to the agents)
  int first_participant_id = 20, end_participant_id = 120;  ///< participant ids handed to children: [first, end)
  /// The deployment's modules start one by one (module_start: one_by_one): the next once the last one's world has
  /// ticked, or `start_gap_max` seconds after the last one started, whichever comes first.
  bool start_one_by_one = false;
  double start_gap_max = 10.0;
};

/// A live command (ControlRequest to the launcher) as the supervisor reads it.
struct Request {
  enum class Command { Down, Kill, Plug, Unplug, Other } command = Command::Other;
  int raw_command = 0;       ///< the command's number (for "unknown command")
  std::string command_name;  ///< "plug", "unplug", ... (as the user typed it)
  enum class Target { Module, Robot, Process, Other } target_kind = Target::Other;
  std::string target;
  unsigned long long seq = 0;  ///< 0: none (the launcher's own)
  bool standby = false;        ///< plug robot --standby
  std::string scenario, case_name, host;  ///< plug module: a new one
};

/// An agent's heartbeat (AgentState) as the supervisor reads it.
struct AgentReport {
  std::string host;
  long long pid = 0;
  unsigned long long run = 0;
  std::string detail;
  struct Process {
    unsigned long long spawn_id = 0;
    std::string label;
    long long pid = 0;
    bool running = false;
    int status = 0;
  };
  std::vector<Process> children;
};

/// Requests from the launcher to a module's supervisors.
enum class ModuleCommand { Pause, Resume, Drain };

/// Starts and signals processes: here (fork/exec, kill) or through a host's agent.
class Executor {
 public:
  virtual ~Executor() = default;
  /// Where `c` runs: "" on this machine, else the host whose agent starts it.
  virtual std::string place(const Child& c) const = 0;
  /// Starts `c` (or sends its start again, same spawn id). Here: its pid, -1 if it could not be started; on a host:
  /// 0 (its pid comes with the agent's report).
  virtual int start(const Child& c) = 0;
  /// Sends `sig` to `c` (here by pid, on a host through its agent by spawn id).
  virtual void signal(const Child& c, int sig) = 0;
  /// Multi-host: `sig` to a process of this run the launcher no longer counts (fencing), by spawn id.
  virtual void signal_spawn(const std::string& host, unsigned long long spawn_id, const std::string& label, int sig) = 0;
  /// Multi-host: the launcher lives (and counts `host` as lost or not); `end`: the run is over.
  virtual void heartbeat(const std::string& host, bool lost, bool end) = 0;
};

/// What the supervisor says and reads besides processes.
class Outbox {
 public:
  virtual ~Outbox() = default;
  /// A line of the launcher's log (with its newline); `error`: on stderr.
  virtual void log(const std::string& line, bool error) = 0;
  /// A request to a module's supervisors, with the launcher's own sequence number.
  virtual void control(const std::string& module, ModuleCommand command, unsigned long long seq) = 0;
  /// No coordinator is left: republish the last queue state heard, for the successor.
  virtual void republish_coordinator_state() = 0;
  /// A module plugged from a scenario and case: validated and read (throws with the reason). `case_found` false
  /// if the scenario has no such case.
  virtual ModuleSpec load_module(const std::string& name, const std::string& scenario, const std::string& case_name,
                                 const std::string& host, bool& case_found) = 0;
};

class Supervisor {
 public:
  static constexpr int kStartRepairs = 3;
  /// A coordinated module whose world was killed for a spinning thread (a Fast DDS loop, docs/soak.md finding 85: no
  /// physical event) is restarted from its initial grasp, as a module that lost its plan is, at most this often; past
  /// that it stays failed until cleared.
  static constexpr int kSpinRepairs = 3;

  Supervisor(SupervisorConfig cfg, Executor& exec, Outbox& out);

  // ---- set-up ----
  /// A module of the deployment (validated, its scenario read).
  void add_module(ModuleSpec spec);
  void start_module(const std::string& name, double now);
  /// The deployment's modules at `tandem up`: all at once, or one by one (SupervisorConfig::start_one_by_one; the
  /// rest are started by poll()). Modules stopped or plugged meanwhile are not held back.
  void start_modules(const std::vector<std::string>& names, double now);
  /// Modules waiting for their turn to start (module_start: one_by_one).
  size_t queued_starts() const { return start_queue_.size(); }
  void start_coordinators(double now);
  /// Shedding whole modules: the governor over `order` (priority order); the first `fit` start, the rest start
  /// parked (returned).
  std::vector<std::string> admit(const std::vector<std::string>& order, size_t fit, double now);

  // ---- events ----
  /// A process of this machine exited (reaped) with `status` (128 + signal if killed).
  void on_exit(int pid, int status);
  /// A status sample from process `label` (pid): it is part of the domain. Returns the child if this is its first
  /// active status (the caller measures its start-up CPU), else nullptr.
  const Child* on_status(const std::string& label, long long pid, bool active, bool serving_known, bool leads);
  /// A world's final status said its task is done: the module's task is over (a restart pending is dropped), and
  /// the world is stopped if it has not exited kWorldExitGraceS later.
  void on_world_done(const std::string& label, long long pid, double now);
  /// The caller is about to SIGKILL process `pid` of this machine for a spinning thread (launcher::SpinWatch).
  void on_spun(int pid);
  /// A world's status: its tick and detail ("paused for load ..." for the governor).
  void on_world_load(const std::string& module, const std::string& detail, unsigned long long tick, double now);
  /// A module's task state (plan::TaskStateCode).
  void on_task_state(const std::string& module, int state);
  /// A coordinator's queue state was heard: its next task id, tasks finished (more than its done-set lists when a
  /// task was done twice) and tasks its done-set lists. The most advanced state is kept (the launcher's own
  /// republished copy comes back too): an older one is dropped, the same or a more advanced one kept by the caller,
  /// and a more advanced one republished from the launcher's writer, so that a coordinator that starts with --resume
  /// always finds the queue's state even when every coordinator that published it died meanwhile.
  enum class QueueState { Older, Same, Advanced };
  QueueState on_coordinator_state(unsigned long long next_task_id, unsigned long long done_total, size_t done);
  /// A live command; while the deployment stops it is refused.
  void on_request(const Request& r, double now);
  /// An agent's heartbeat and the state of the processes it started for this launcher.
  void on_agent_state(const AgentReport& st, double now);

  // ---- time ----
  /// Exits, pending restarts, clears, unplugs, silent starts, start repairs, SIGKILL after SIGTERM, drains, hosts.
  void poll(double now);
  /// Carries out the governor's decision and the parks and unparks under way.
  void govern(double now);
  /// While stopping: SIGKILL whatever did not stop within 5 s.
  void escalate(double now);
  /// Every 100 ms to each host's agent (multi-host); `end`: the run is over.
  void heartbeat(bool end = false);
  /// Counts every host's silence from `now` (after a time in which no agent state was read).
  void restart_host_clock(double now);

  /// Stops the whole deployment (SIGTERM first, then escalate()).
  void stop_all(int sig, double now);

  // ---- views ----
  bool busy() const;
  int running() const;
  bool stopping() const { return stopping_; }
  bool failed() const { return failed_; }
  bool coordinator_done() const { return coordinator_done_; }
  /// A `down` request was carried out (the caller stops as for Ctrl-C).
  bool down_requested() const { return down_requested_; }
  const std::deque<Child>& children() const { return children_; }
  /// Participant ids no running child holds (the one left longest ago first).
  std::vector<int> free_participant_ids() const { return {free_ids_.begin(), free_ids_.end()}; }
  /// A check that a free participant id still has shared-memory port files of an earlier process (they are
  /// removed between runs of runtime::clean_free_ports unless some process holds them): launch() prefers, among
  /// the free ids, the longest-free one without (soak finding 59). Unset: the longest-free id.
  void set_participant_id_check(std::function<bool(int)> has_old_ports) { has_old_ports_ = std::move(has_old_ports); }
  const std::map<std::string, ModuleRun>& modules() const { return modules_; }
  /// Hosts whose agent does not serve this run yet.
  std::vector<std::string> agents_not_serving() const;
  /// The answer to live command `seq`, if any (the newest 256 are kept).
  struct Answer {
    bool ok = false;
    std::string text;
  };
  const Answer* answer(unsigned long long seq) const;
  /// A child was killed since the last shm_cleaned(): its shared-memory files wait to be removed; when.
  bool shm_dirty() const { return shm_dirty_; }
  double killed_at() const { return killed_at_; }
  void shm_cleaned() { shm_dirty_ = false; }
  unsigned long long forced_drains() const { return forced_drains_; }
  unsigned long long deaf_leaders() const { return deaf_leaders_; }
  unsigned long long start_repairs() const { return start_repairs_; }
  unsigned long long plan_restarts() const { return plan_restarts_; }
  bool governed() const { return governor_ != nullptr; }
  unsigned long long parks() const { return parks_; }
  /// "m3, m4" (for status and the summary).
  std::string parked_text() const;

 private:
  struct PendingRestart {
    double when;
    Child child;
  };
  struct PendingUnplug {
    std::string label, module;
    double since;
  };
  struct PendingPark {
    std::string module;
    double since;
  };

  void logf(const char* fmt, ...) __attribute__((format(printf, 2, 3)));
  void errf(const char* fmt, ...) __attribute__((format(printf, 2, 3)));
  void say(bool ok, const char* fmt, ...) __attribute__((format(printf, 3, 4)));

  void start_coordinator(const std::string& id, bool standby, const char* note, double now);
  bool start_robot(const std::string& module, const std::string& robot, int strength, const char* note, double now);
  void start_supervisor(const std::string& module, int strength, const char* note, double now);
  bool start_ranked(const char* role, const std::string& module, const std::string& slot, int strength,
                    const char* note, double now);
  bool launch(Child& c, const char* note, double now);
  int standby_strength(const std::string& arm) const;
  const Child* primary_of(const std::string& arm) const;
  /// A live supervisor of the slot ("<module>/supervisor") other than `except` whose status, heard within the last
  /// 0.5 s (supervisors publish theirs every 100 ms), says it leads: a hung or stopped leader's old word does not count.
  const Child* leader_of(const std::string& slot, const Child* except) const;
  int live_robots(const std::string& arm, const Child* except = nullptr) const;
  int live_coordinators() const;
  Child* find_running(const std::string& label);
  bool module_gone(const std::string& module) const;
  int task_state(const std::string& module) const;

  void handle(const Request& r, double now);
  void refuse_while_stopping(const Request& r);
  void kill_target(const std::string& target, double now);
  ModuleFacts module_facts(const std::string& name) const;
  void plug(const Request& r, double now);
  void plug_module(const std::string& name, const std::string& scenario, const std::string& case_name,
                   const std::string& host, double now);
  bool add_plugged_module(const std::string& name, const std::string& scenario, const std::string& case_name,
                          const std::string& host);
  void unplug(const Request& r, double now);
  void resume_if_paused_for_unplug(const std::string& module);

  void handle_exit(Child& c, double now);
  bool schedule_restart(const Child& c, const RestartRule& rule, double now);
  void repair_start(const std::string& module, const std::string& why, double now);
  void stop_module(const std::string& module, double now);
  void fail(const std::string& why, double now);
  void terminate(Child& c, double now);
  void signal_child(Child& c, int sig, double now);
  void send(const std::string& module, ModuleCommand command);
  void mark_exited(Child& c, int status);
  void stop_deaf_leader(const std::string& module, ModuleRun& mr, double now);
  void resend_drains(double now);
  void start_queued(double now);
  void watch_hosts(double now);
  void run_pending_restarts(double now);

  SupervisorConfig cfg_;
  Executor& exec_;
  Outbox& out_;
  std::deque<Child> children_;  // deque: references stay valid as children are added
  std::map<std::string, ModuleRun> modules_;
  std::vector<PendingRestart> pending_restarts_;
  RestartPolicy restarts_;
  std::vector<PendingUnplug> pending_unplugs_;
  std::vector<std::string> pending_clears_;  ///< modules being cleared or repaired: started again once stopped
  std::deque<std::string> start_queue_;      ///< module_start: one_by_one: the modules still to start, in order
  std::string last_queued_start_;            ///< the module started last from the queue
  double last_queued_start_at_ = 0.0;
  std::map<std::string, double> world_done_;  ///< modules whose world finished its task, and when
  std::map<std::string, int> task_states_;
  std::unique_ptr<Governor> governor_;
  std::vector<PendingPark> pending_parks_;
  std::vector<std::string> pending_unparks_;
  unsigned long long parks_ = 0;
  unsigned long long forced_drains_ = 0;  ///< unplugged modules stopped with their task unfinished (DrainWatch)
  unsigned long long deaf_leaders_ = 0;   ///< leaders stopped because they did not hear a drain
  unsigned long long start_repairs_ = 0;  ///< modules restarted because they did not come up
  unsigned long long plan_restarts_ = 0;  ///< modules restarted because their supervisors lost the plan
  std::unique_ptr<HostWatch> hosts_;      ///< multi-host: the agents' liveness (nullptr without hosts)
  unsigned long long spawns_ = 0;
  std::map<std::string, std::map<long long, double>> agent_heard_;  ///< per host: agent pid -> last heard [s]
  std::set<std::string> two_agents_;                    ///< hosts with two agents at once, said once
  std::map<std::string, unsigned long long> agent_runs_;  ///< the run each host's agent last said it serves
  std::set<std::string> other_runs_;                    ///< "<host>/<run>" of other runs seen, said once
  std::set<unsigned long long> fenced_;                 ///< processes of a host that came back, SIGKILLed once
  bool have_coord_state_ = false;
  size_t coord_done_ = 0;  ///< tasks done in the latest queue state heard
  unsigned long long coord_next_ = 0, coord_total_ = 0;  ///< its next task id and tasks finished
  bool stopping_ = false, escalated_ = false, failed_ = false, coordinator_done_ = false;
  double polled_at_ = 0.0;  ///< the time of the last poll() (statuses are stamped with it)
  bool down_requested_ = false;
  bool all_heard_said_ = false;
  double stop_started_ = 0.0;
  bool shm_dirty_ = false;
  double killed_at_ = 0.0;
  int coordinator_restarts_ = 0;
  unsigned long long seq_ = 0;
  std::set<unsigned long long> handled_seqs_;
  std::map<unsigned long long, Answer> answers_;
  unsigned long long current_seq_ = 0;  ///< the live command being carried out (its say() lines are its answer)
  std::deque<int> free_ids_;            ///< participant ids, the one left longest ago first
  std::function<bool(int)> has_old_ports_;
};

}  // namespace tandem::launcher
