// The coordinator's bookkeeping, with no DDS in it: the registry of the modules that report (modules come
// and go), the queue of pending tasks, the task in flight on each module, the tasks done, and the rebuild
// of all that by a standby that takes over (from the last CoordinatorState and the modules' latest reports).
// Tasks are indices into the deployment's list (their names are unique); an assignment carries an id that
// increases per deployment. Times are seconds on any monotonic clock.
//
// A task is counted done only when the module it is in flight on reports that id finished, so no task is
// counted twice: the task of a module that is lost goes back to the front of the queue, and a late "done"
// of that module for it is ignored.
#pragma once

#include <cstddef>
#include <algorithm>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace tandem::coordinator {

/// A module whose reports stop for this long is lost: its task goes back to the front of the queue.
inline constexpr double kModuleLostS = 1.5;

/// TaskState.state on the wire (idl/tandem.idl).
enum class ModuleState : uint8_t { Idle = 0, Running = 1, Done = 2, Paused = 3, Draining = 4, Left = 5, Failed = 6 };

/// One TaskState of this deployment.
struct ModuleReport {
  std::string module;
  uint64_t task_id = 0;  ///< last task the module took (0: none)
  uint8_t state = 0;     ///< a ModuleState; larger values are rejected
};

/// The queue's state as a CoordinatorState carries it: a compact done-set (one byte per task of the
/// deployment's list, in file order: 0 not done, i done by modules[i - 1]), and the tasks in flight. Its size is
/// bounded by the deployment (tasks + module names), not by how long it runs: 10^5 tasks done by 255 modules
/// are 10^5 bytes + the names (the names of the tasks done, in order, grew without bound: coordinators grew
/// 1.4-1.8 MiB/min in the hour-long soak).
struct Snapshot {
  static constexpr size_t kMaxModules = 255;
  uint64_t next_task_id = 1;
  std::vector<std::string> modules;  ///< modules that did tasks (at most kMaxModules)
  std::vector<uint8_t> done_by;      ///< per task: 0 not done, i: done by modules[i - 1]
  uint64_t done_total = 0;           ///< tasks finished, a task finished twice counted twice
  std::vector<std::string> running, running_on;
  std::vector<uint64_t> running_id;
  /// The parallel lists have equal lengths, and every done_by names a module of the list.
  bool well_formed() const;
  /// Tasks done (distinct).
  size_t done_count() const;
  /// Bytes of its content (what the wire carries, without the CDR overhead).
  size_t payload_bytes() const;
};

/// A task handed to a module (or handed again, with the same id, after a takeover).
struct Assignment {
  std::string module;
  uint64_t id = 0;
  size_t task = 0;    ///< index into the deployment's tasks
  double wear = 0.0;  ///< the module's wear when it was chosen [rad]
};

/// What changed in the registry or the queue, for the log.
enum class EventKind {
  Joined,           ///< a module reports for the first time
  Rejoined,         ///< a lost module is heard again (it takes new tasks only)
  Finished,         ///< a module finished its task: counted done
  LateDoneIgnored,  ///< a module reports done a task taken from it when it dropped its object (or re-assigned)
  Reclaimed,        ///< a module heard again still has the task taken from it when it was lost: it stays there
  Lost,             ///< not heard for kModuleLostS (task: the one put back at the front of the queue)
  Left,             ///< reported "left": removed (task: the one put back at the front of the queue)
  Requeued,         ///< the module no longer runs the task recorded for it (a takeover, or it took a newer id)
  Failed,           ///< the module dropped its object (task: back to the front of the queue, never done there)
};
struct Event {
  EventKind kind = EventKind::Joined;
  std::string module;
  std::string task;  ///< the task concerned, "" if none
  uint64_t id = 0;   ///< its assignment id
  size_t done = 0;   ///< Finished: distinct tasks done so far
};

enum class Balance {
  Wear,        ///< least wear first, ties: fewer tasks done, then name
  RoundRobin,  ///< fewest tasks done first, ties: name
};

class TaskQueue {
 public:
  /// `tasks`: the deployment's task names in file order (all pending at first).
  TaskQueue(std::vector<std::string> tasks, Balance balance);

  // --- Registry --------------------------------------------------------------------------------------------
  /// A module's report at `now`. Rejected (counted, nothing changes) if the state is unknown (> 5) or the
  /// module is unnamed. A report of state 0 or 2 for the id in flight on the module finishes that task; a
  /// report of "left" removes the module (with the id in flight: finished before it left; with an older id:
  /// the task goes back to the front of the queue).
  std::vector<Event> report(const ModuleReport& r, double now);
  /// Modules not heard for kModuleLostS become lost; their tasks go back to the front of the queue.
  std::vector<Event> expire(double now);
  /// This coordinator itself stood still (a stall, starvation) until `now`: the modules' silence meanwhile was
  /// its own, so each module not lost yet counts as heard now (as the world forgives robots after its own stall).
  /// Found by the soak: a primary back from a 2 s stall declared both modules lost and took their tasks back.
  void forgive_silence(double now);

  // --- Assignment ------------------------------------------------------------------------------------------
  /// Hands the first pending task to the best free module (not lost, state idle or done, nothing in flight),
  /// by the balance rule on `wear(module)`; nullopt if no task or no module is free.
  std::optional<Assignment> assign_next(const std::function<double(const std::string&)>& wear);
  /// Tasks in flight on a module that is heard and reports a finished state with an older id for at least
  /// kUntakenS: it never took the assignment (a supervisor still busy with an earlier task drops one). Write them
  /// again (the same id: a supervisor takes an id once). Each is returned at most once per kUntakenS.
  std::vector<Assignment> untaken(double now);
  static constexpr double kUntakenS = 1.0;

  // --- Takeover --------------------------------------------------------------------------------------------
  /// Replaces the queue by the primary's last state: done and running from it, pending = every task (file
  /// order) but those, next id from it (never below an id a module reported). Names not in the deployment
  /// are skipped. Reports received so far are kept: they are the modules' latest states for reconcile().
  void restore(const Snapshot& s, double now);
  struct Reconciled {
    std::vector<Event> events;
    std::vector<Assignment> resend;  ///< in flight but not taken yet by its module: write it again
  };
  /// Checks every task in flight against its module's latest report: done if the module reports that id
  /// finished (state 0, 2, or 5), sent again if the module reports an older id or was never heard, back to
  /// the front of the queue if the module is lost, left without it, or reports a newer id.
  Reconciled reconcile(double now);

  // --- State -----------------------------------------------------------------------------------------------
  /// The state to publish (running in id order).
  Snapshot snapshot() const;
  /// Increases on every change of the queue (done, running, pending, next id).
  uint64_t revision() const { return revision_; }
  /// One line for the log, e.g. "m2 left; task out-1 (id 4) back to the front of the queue".
  std::string describe(const Event& e) const;
  /// Distinct tasks of this deployment that `s` lists as done.
  size_t count_done(const Snapshot& s) const { return std::min(s.done_count(), names_.size()); }
  size_t task_count() const { return names_.size(); }
  const std::string& task_name(size_t task) const { return names_[task]; }
  size_t done_count() const { return done_count_; }      ///< distinct tasks done
  size_t duplicates() const { return done_total_ - done_count_; }  ///< finishes of a task already done
  bool complete() const { return done_count() == names_.size(); }
  size_t running_count() const;
  size_t pending_count() const { return pending_.size(); }
  std::vector<std::string> pending() const;  ///< names, front first
  size_t module_count() const { return modules_.size(); }
  size_t lost_count() const;
  uint64_t rejected() const { return rejected_; }
  /// Every module known or credited with a task -> the names of the tasks it did, in the deployment's order.
  std::map<std::string, std::vector<std::string>> done_by_module() const;

 private:
  struct Module {
    uint8_t state = 0;      // last reported state
    uint64_t reported = 0;  // last reported task id
    bool heard = false;     // has reported (false: known only from a restored state)
    double last_heard = 0.0;
    bool lost = false;
    uint64_t running_id = 0;  // task id in flight (0: none)
    size_t running_task = 0;
    double untaken_since = -1.0;  // reports a finished state with an id older than running_id since then
  };
  static bool finished_state(uint8_t state);
  std::optional<size_t> find_task(const std::string& name) const;
  size_t tasks_of(const std::string& module) const;
  void finish(const std::string& name, Module& m, std::vector<Event>& events);
  void requeue(Module& m);  // its task in flight back to the front of the queue

  std::vector<std::string> names_;
  Balance balance_;
  std::map<std::string, Module> modules_;
  std::map<std::string, uint64_t> left_;  // modules that left -> the last task id they reported
  struct Abandoned {
    size_t task = 0;
    std::string module;
    bool lost = false;  // taken because the module was lost (true) or dropped its object (false)
    bool said = false;  // its late "done" was said ignored (kept while lost: the module may still reclaim it)
  };
  std::map<uint64_t, Abandoned> abandoned_;  // id taken from a module -> what and why
  std::deque<size_t> pending_;
  std::vector<uint8_t> done_by_;              // per task: 0 not done, i: done by module_names_[i - 1]
  std::vector<std::string> module_names_;     // modules that did tasks (index + 1 in done_by_)
  std::map<std::string, size_t> done_of_;     // module -> tasks it did
  size_t done_count_ = 0;
  uint64_t done_total_ = 0;
  uint8_t module_index(const std::string& module);  // 0 if more than Snapshot::kMaxModules modules did tasks
  uint64_t next_id_ = 1;
  uint64_t revision_ = 0;
  uint64_t rejected_ = 0;
};

}  // namespace tandem::coordinator
