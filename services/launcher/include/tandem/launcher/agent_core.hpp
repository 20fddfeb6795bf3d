// The per-host agent of a multi-host deployment as a component (no DDS, no clock, no fork inside): it starts and
// signals the role processes its launcher places on this host, through a `Processes` interface, and holds the
// rules (docs/multihost.md):
// - one launcher run at a time, first come first served: another run's requests are refused while the served
//   launcher is heard and its run is not over; a new run stops the previous run's leftovers;
// - a start is carried out once per spawn id (the launcher re-sends it until acknowledged); a signal for a spawn
//   id not started yet is remembered (a tombstone): that start then never runs;
// - only this project's roles are started, from the agent's own directory, never a path from the wire; only
//   SIGINT, SIGTERM and SIGKILL are sent; SIGKILL follows 5 s after SIGTERM;
// - fencing: when the launcher has been silent for host_timeout, or its heartbeat says it counts this host as
//   lost, the agent SIGKILLs what it runs (standbys elsewhere took over); a healed partition (the launcher heard
//   again) lets the launcher place processes here again.
// `tandem agent` (services/cli/agent_command.cpp) wires it to DDS and to fork/exec; tests/unit/test_launcher_rules.cpp
// drives it with processes that only record what is asked of them.
#pragma once

#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace tandem::launcher {

/// What the agent needs of the operating system.
class Processes {
 public:
  virtual ~Processes() = default;
  struct Spec {
    std::string exe;
    std::vector<std::string> args;
    int rt_priority = 0;
    int participant_id = -1;
    std::string identity;
    bool own_group = true;  ///< launcher::SpawnOptions::own_group
    std::string module;     ///< the module of the process ("" for a coordinator), from its label
  };
  /// Starts a process; its pid, or <= 0 if it could not be started.
  virtual int start(const Spec& s) = 0;
  virtual void signal(int pid, int sig) = 0;
  /// The exit status of `pid` if it has exited (128 + signal if killed), else -1; it is reaped then.
  virtual int reap(int pid) = 0;
};

/// One request of the launcher (AgentRequest on the wire).
struct AgentRequestIn {
  enum class Kind { Start, Signal, Heartbeat, End, Unknown };
  Kind kind = Kind::Unknown;
  int raw_kind = -1;  ///< for the message about an unknown kind
  unsigned long long run = 0, spawn_id = 0;
  std::string label, role;
  std::vector<std::string> args;
  int rt_priority = 0, participant_id = -1, signal = 0;
  std::string identity;
  bool host_lost = false;
};

struct AgentChild {
  unsigned long long spawn_id = 0;
  std::string label;
  int pid = -1;
  bool running = false;
  int status = -1;
  double term_at = -1.0;  ///< when SIGTERM was sent [s] (SIGKILL 5 s later), -1: not asked
};

class AgentCore {
 public:
  static constexpr double kKillAfterTermS = 5.0;
  /// dir: where the role executables live; host_timeout [s]: the launcher's silence that fences this host.
  AgentCore(Processes& p, std::string dir, double host_timeout, double now);
  void set_log(std::function<void(const std::string&)> log) { log_ = std::move(log); }
  bool rt_permitted = false;  ///< SCHED_FIFO is allowed here (else processes run with normal scheduling)

  /// A request for this host and deployment (the caller filters on both).
  void on_request(const AgentRequestIn& r, double now);
  /// Reaps children, sends SIGKILL 5 s after SIGTERM, and fences when the launcher is silent.
  void poll(double now);
  void stop_all(int sig, double now);

  const std::vector<AgentChild>& children() const { return children_; }
  int running() const;
  unsigned long long run() const { return run_; }
  bool run_over() const { return run_over_; }
  bool fenced() const { return fenced_; }
  bool served() const { return run_ != 0; }
  double silent(double now) const { return now - launcher_heard_; }
  /// The last refusal or problem, for the agent's state ("" if none).
  const std::string& detail() const { return detail_; }
  /// A child was killed by a signal since the last call: its shared-memory files may be left.
  bool take_killed();

 private:
  void log(const std::string& s) const { if (log_) log_(s); }
  void note(const std::string& s);
  void new_run(unsigned long long run, double now);
  void fence(const std::string& why, double now);
  void start(const AgentRequestIn& r);
  void send_signal(const AgentRequestIn& r, double now);

  Processes& p_;
  std::string dir_;
  double host_timeout_;
  std::function<void(const std::string&)> log_;
  std::vector<AgentChild> children_;
  std::set<unsigned long long> seen_;
  std::map<unsigned long long, int> tombstones_;
  std::set<unsigned long long> refused_runs_;
  unsigned long long run_ = 0;
  double launcher_heard_;
  bool run_over_ = false, fenced_ = false, killed_ = false;
  std::string detail_;
};

}  // namespace tandem::launcher
