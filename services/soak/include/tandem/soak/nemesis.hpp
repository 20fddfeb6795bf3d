// The soak's fault injector (Jepsen's nemesis) as a component: it carries out a schedule against the processes
// and modules it is told about. Events in (process status, arm owners, worlds turning active, replies to live
// commands, hogs that ended, the time), actions out through NemesisActions (signals, hog processes, live
// commands). No DDS, no clock and no signal inside: `tandem soak` wires it to the deployment, unit tests drive it
// with made-up processes (tests/unit/test_soak.cpp). docs/soak.md, "The nemesis".
//
// Its rules (a target is chosen when the fault fires, so the same seed hits the processes alive then):
// - a fault picks its target among the live candidates when it fires (pick % count), never a process stalled by
//   it, nor one of a module that it took out or whose world turned active less than kSettleS ago;
// - module-level faults (kill world, unplug module) only fire while at least two modules run;
// - a fault with no target when due is set aside and waits for one, up to kTargetWaitS, then it is recorded as
//   skipped; the schedule goes on meanwhile, and a fault that waited fires at least kWaitedGapS after the last
//   fault, one at a time: faults never fire in a burst;
// - what it took out comes back: a stalled process continues after the fault's duration, a killed world's
//   module and an unplugged module or robot are plugged in again (retried until the launcher accepts).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "tandem/soak/history.hpp"
#include "tandem/soak/schedule.hpp"

namespace tandem::soak {

/// What the nemesis knows of one process (from its status over DDS).
struct ProcessView {
  std::string role;     ///< world | supervisor | robot | coordinator
  std::string module;   ///< "" for the coordinator
  std::string serving;  ///< supervisor, coordinator: "primary" | "standby"
  bool replica = false; ///< a standby supervisor that holds its leader's plan (a warm replica: it can take over)
  bool behind = false;  ///< a robot behind the world's plan (robot::RobotCore::kBehindDetail): it cannot take over
  long tick = -1;       ///< a robot: the newest tick it computed, as its status said (-1: not said)
  long long pid = 0;
  int state = 0;        ///< lifecycle: 2 active, 3 finalized, 4 error
  double last_t = -1.0; ///< when its status was last heard [s]
};

/// Reply to a live command: accepted or not, the launcher's text, and when it arrived [s].
using Reply = std::function<void(bool ok, const std::string& text, double t)>;

/// How the nemesis's actions are carried out (tandem soak: kill(2), a tandem_hog child, a ControlRequest).
class NemesisActions {
 public:
  virtual ~NemesisActions() = default;
  virtual bool alive(long long pid) const = 0;  ///< the process runs (not a zombie)
  virtual void kill(long long pid) = 0;         ///< SIGKILL
  virtual void stop(long long pid) = 0;         ///< SIGSTOP
  virtual void resume(long long pid) = 0;       ///< SIGCONT
  /// Starts a CPU hog on `cores` cores for `seconds`; its pid, or -1 if it could not be started. The host
  /// reports its end with Nemesis::hog_ended.
  virtual long long start_hog(int cores, double seconds) = 0;
  virtual void end_hog(long long pid) = 0;      ///< stops it now and reaps it
  /// The live commands the nemesis sends, as `tandem plug/unplug` would.
  enum class Live {
    UnplugRobot,   ///< name: the robot's label
    UnplugModule,  ///< name: the module
    PlugRobot,     ///< name: the arm ("m1/left"); standby or primary
    PlugModule     ///< name: the module (one of the deployment's)
  };
  /// Sends a live command; `done` (may be empty) gets the launcher's answer, or (false, why) if there is none
  /// within the host's limit.
  virtual void request(Live what, const std::string& name, bool standby, Reply done) = 0;
};

class Nemesis {
 public:
  /// A fault with no target waits this long, then is skipped: longer than admission parks a module at start-up (it
  /// comes back after 30 s of calm), so that a CI soak's world kill does not depend on the machine's calibration.
  static constexpr double kTargetWaitS = 45.0;
  static constexpr double kWaitedGapS = 1.0;    ///< a fault that waited fires at least this long after the last
  static constexpr double kSettleS = 3.0;       ///< a module is left alone this long after its world turns active
  static constexpr double kSilentS = 1.5;       ///< a process not heard this long is not a candidate
  static constexpr double kTailS = 5.0;         ///< a run goes on this long after a fault that waited past its end
  /// In real time (set_tick_rate), a robot whose computed tick (its status's, advanced by the status's age at the
  /// tick rate) is more than this many ticks behind its world's newest is not keeping up: no warm standby (soak run
  /// 61: a standby plugged 2 s before, starved in a burst of restarts, was 196 ticks behind when its primary was
  /// killed, and served the arm after 0.4 s). Not in lockstep, whose ticks follow no clock (a world runs ~4 ticks a
  /// millisecond when it can): the rule is off there (rate 0, the default). A robot resumed from a stall is not known
  /// to keep up until its first status after the resume.
  static constexpr long kWarmLagTicks = 100;

  /// `modules`: the deployment's modules in order; fault records go to `history.faults`.
  Nemesis(const Schedule& schedule, std::vector<std::string> modules, History& history, NemesisActions& actions);

  // ---- events in ----
  /// A process's status, heard at p.last_t (a world that turns active starts its module's settling time).
  void on_status(const std::string& label, const ProcessView& p);
  /// The robot each arm of `module` follows now (arm -> process label, from its world).
  void on_owners(const std::string& module, std::map<std::string, std::string> owners);
  /// The world's ticks a second in real time (1000), for the warm-standby rule (kWarmLagTicks); 0: lockstep, no rule.
  void set_tick_rate(double ticks_per_s) { tick_rate_ = ticks_per_s; }
  /// The newest tick heard from `module`'s world (each fault on the module records it: FaultRecord::module_tick).
  void on_tick(const std::string& module, long tick) { ticks_[module] = tick; }
  /// The launcher parked `module` for load (admission or shedding), or brought it back.
  void on_parked(const std::string& module, bool parked) {
    if (parked) {
      parked_.insert(module);
    } else {
      parked_.erase(module);
    }
  }
  /// Carries out what is due at `t`: scheduled faults, faults that waited, and timed follow-ups (continue a
  /// stalled process, plug a module or robot in again).
  void step(double t);
  /// A hog ended (exit code 127: it could not start).
  void hog_ended(long long pid, int exit_code, double t);
  /// Stops injecting: every stalled process continues, every hog stops.
  void calm(double t);

  // ---- for the host's report and progress ----
  const std::map<std::string, ProcessView>& processes() const { return procs_; }
  size_t waiting() const { return waiting_.size(); }
  /// Whether the run may end at `t`: the schedule's duration is over and no fault still waits for a target. A run
  /// whose faults wait past its end (every module paused for load, or a module being drained, when a robot kill
  /// falls due) goes on until each has fired or been skipped (at most kTargetWaitS), then kTailS more so that
  /// the last one's effect is recorded (a fault fired that late is carried out; a recovery whose bound ends after the
  /// run's stop is not judged, soak::check). Without this the CI soak ended with a robot kill still waiting
  /// (docs/soak.md, finding 75), as though the schedule had never held one.
  bool over(double t) const;
  /// Targets a fault of this kind could hit now (process labels; modules for unplug module). A kill of a world or an
  /// unplug of a module needs two modules up (one always runs), unless the others are parked for load by the
  /// launcher: they are the deployment's still, and come back when the machine is calm (on a machine that fits one
  /// module, the CI soak's world kill and module unplug never found a target while the governor held the second
  /// back). A stall of a world takes no module out, so the only one running may be stalled.
  std::vector<std::string> candidates(Target target, double t, FaultKind kind = FaultKind::Kill) const;

 private:
  bool live(const ProcessView& p, double t) const;
  bool keeps_up(const ProcessView& p, double t) const;  ///< kWarmLagTicks
  std::set<std::string> owners_now() const;
  std::vector<std::string> modules_up(double t) const;
  bool settling(const std::string& module, double t) const;
  /// Active robots of `arm` (its label) other than `except` that are on the world's plan and keep up with its ticks
  /// (kWarmLagTicks): those that can serve it at once.
  int live_robots_of(const std::string& arm, const std::string& except, double t) const;
  /// Live standby supervisors of `module` other than `except` that hold the leader's plan (ProcessView::replica).
  int warm_standbys_of(const std::string& module, const std::string& except, double t) const;
  /// Live, active standby coordinators other than `except`.
  int standby_coordinators(const std::string& except, double t) const;
  void fire(const Fault& f, double t);
  void hog(const Fault& f, FaultRecord& r, size_t index);
  void later(double at, std::function<void(double)> fn) { pending_.push_back({at, std::move(fn)}); }
  void replug_module(const std::string& module, size_t index, double at, double give_up);
  void replug_robot(const std::string& arm, bool primary, size_t index, double give_up);

  struct Pending {
    double at = 0.0;
    std::function<void(double)> fn;
  };

  const Schedule& sched_;
  std::vector<std::string> modules_;
  History& h_;
  NemesisActions& act_;
  std::map<std::string, ProcessView> procs_;
  std::map<std::string, std::map<std::string, std::string>> owners_;  ///< module -> arm -> label
  std::map<std::string, long> ticks_;  ///< module -> the newest tick heard from its world
  double tick_rate_ = 0.0;             ///< set_tick_rate
  std::map<long long, double> resumed_;  ///< pid -> when the nemesis last resumed it from a stall
  std::map<std::string, double> module_started_;  ///< module -> when its (latest) world turned active
  std::set<std::string> out_;                     ///< modules taken out, to be plugged in again
  std::set<std::string> parked_;                  ///< modules the launcher parked for load
  std::map<long long, std::string> stalled_;      ///< pid -> label
  std::map<long long, size_t> hogs_;              ///< pid -> its fault record
  std::vector<Pending> pending_;
  size_t next_fault_ = 0;
  std::vector<const Fault*> waiting_;  ///< due faults that wait for a target, in schedule order
  double last_fired_ = -1e9;           ///< when the last fault was carried out (or skipped)
  double last_waited_ = -1e9;          ///< when the last fault that had waited was carried out (or skipped)
  bool stopping_ = false;
};

}  // namespace tandem::soak
