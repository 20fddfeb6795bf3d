// What a soak run recorded (the checker's only input): the worlds' reports, the processes' status, the
// coordinator's queue, resident memory and log sizes, and the nemesis's own log of what it did (used to know
// where to look and to name a violation's fault, never as evidence that something recovered).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "tandem/soak/schedule.hpp"

namespace tandem::soak {

/// A module's state over one 100 ms bucket of its world's reports (10 reports in real time).
struct ModuleSample {
  double t = 0.0;                ///< end of the bucket [s since the soak started]
  long tick = 0;                 ///< the world's newest tick
  double normal_min = 1e300;     ///< lowest normal force in the bucket [N]
  uint64_t slips = 0, contact_lost = 0, late = 0, failovers = 0;  ///< the world's running counters
  bool braked = false;           ///< an arm was braked in the bucket
  bool hold = false;             ///< the world asked for a hold (overload)
  bool load_paused = false;      ///< a report in the bucket said paused for load
  /// A report in the bucket said not paused for load right after one that said paused: a release, however short
  /// (the bucket's load_paused hides a release that is paused again within it; soak run 64)
  bool released = false;
  long stop_tick = -1;           ///< the first tick in the bucket reported holding or paused for load (-1: none)
  bool failed = false;           ///< the world reports the module failed (object dropped)
  int world = 0;                 ///< which world instance (1, 2, ... as the module is plugged in again)
};

/// A stretch of time in which a process was heard (status samples at most `gap` apart).
struct Span {
  double start = 0.0, end = 0.0;
  long long pid = 0;
};

/// A change seen in the recorded samples.
struct Event {
  double t = 0.0;
  enum class Type {
    Owners,        ///< subject: module; owners: arm -> robot; text: the same for people ("left=m1/left@50,right=braked")
    State,         ///< subject: process label; text: "<state> <pid>" (state 0..4 as ProcessStatus)
    Serving,       ///< subject: process label (supervisor, coordinator); text: "primary" | "standby"
    TaskAssigned,  ///< subject: task name; text: module
    TaskDone,      ///< subject: task name; text: module
    QueueBack,     ///< a coordinator's queue state with fewer tasks done than already heard (its state was lost);
                   ///< subject: tasks done before; text: tasks done in the new state
    Parked,        ///< the launcher parked a module for load; subject: module; text: why
    Unparked,      ///< ... and brought it back; subject: module; text: why
  } type = Type::State;
  std::string subject, text;
  std::map<std::string, std::string> owners;  ///< Owners: arm -> the robot's label it follows ("" while none)
  long tick = -1;                             ///< Owners: the world's tick in the report that showed them
  long long pid = 0;                          ///< Serving: the process that said it (0: not known)
  /// Owners: arm -> the world's own count of the ticks from the previous owner's last command to the tick it
  /// followed this one (WorldCore::Owner::handover_ticks; -1: not said)
  std::map<std::string, long> handover;

  Event() = default;
  Event(double at, Type what, std::string subj, std::string txt, std::map<std::string, std::string> arm_owners = {})
      : t(at), type(what), subject(std::move(subj)), text(std::move(txt)), owners(std::move(arm_owners)) {}
};

/// An event type's name, as in events.csv and history.pb: owners, state, serving, task_assigned, task_done,
/// queue_back, parked, unparked.
const char* name(Event::Type t);

/// What the nemesis did.
struct FaultRecord {
  Fault fault;                   ///< as scheduled
  double t = 0.0;                ///< when it was carried out
  std::string label;             ///< process label or module hit ("" if skipped)
  std::string module;            ///< its module ("" for the coordinator and a hog)
  long long pid = 0;
  bool skipped = false;          ///< no candidate was alive
  std::string note;              ///< why skipped, or what else happened (re-plugged at ...)
  double end_t = -1.0;           ///< stall: SIGCONT; hog: its end; unplug / kill world: plugged in again
  /// Robot faults: another live robot served the arm when it fired. Supervisor faults: another live supervisor
  /// of the module was a standby holding the leader's plan (a warm replica). Coordinator faults: another live
  /// coordinator was an active standby.
  bool had_standby = true;
  /// The newest tick heard from its module's world when it fired (-1: none, or no module): lockstep failovers are
  /// judged in ticks from it.
  long module_tick = -1;
};

struct RssSample {
  double t = 0.0;
  std::string label;
  long long pid = 0;
  double mib = 0.0;
  double cpu_s = -1.0;  ///< CPU time the process has used so far, user and system [s] (-1: unknown)
};


struct History {
  double duration_s = 0.0;       ///< planned length
  double stop_s = 0.0;           ///< when the deployment was asked to stop
  bool realtime = true;
  std::map<std::string, double> h_sg;                        ///< per module [N]
  std::map<std::string, std::vector<ModuleSample>> modules;  ///< per module, in time order
  std::map<std::string, std::vector<Span>> heard;            ///< per process label, in time order
  std::vector<Event> events;                                 ///< in time order
  std::vector<FaultRecord> faults;                           ///< in time order
  std::vector<RssSample> rss;
  std::vector<std::pair<double, double>> log_bytes;          ///< (t, bytes of the launcher's log)
  std::vector<std::string> task_names;                       ///< the coordinator's task list
  std::vector<std::string> tasks_done, tasks_done_by, tasks_running;  ///< the final queue state heard
  uint64_t tasks_done_total = 0;  ///< tasks finished as the coordinator counted them (more than done: twice)
  std::vector<std::string> leftover_processes;               ///< still running after the run
  std::vector<std::string> leftover_shm;                     ///< /dev/shm files new since the start and left
  int launcher_exit = -1;
  /// The deployment's launcher exited before the soak stopped it (at stop_s): a run cut short is not a pass.
  bool ended_by_itself = false;
};

}  // namespace tandem::soak
