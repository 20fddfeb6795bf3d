// The coordinator of a deployment as a component (no DDS, no clock: times in seconds are passed in): its task
// queue (TaskQueue), who leads it (Leadership), the robots' wear that the balance reads, and the loop's rules that
// join them: a primary back from a stall adopts a successor's more advanced state, a takeover restores and
// reconciles the primary's queue and sends again what its modules never took, the queue state is published before
// any assignment it holds (a standby that takes over knows of it), and a queue with no task finished for the
// timeout gives up. services/coordinator/main.cpp feeds it from DDS and carries its actions out; tests drive it
// call by call (tests/unit/test_task_queue.cpp, "coordinator: ...").
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "tandem/coordinator/leadership.hpp"
#include "tandem/coordinator/task_queue.hpp"

namespace tandem::coordinator {

struct CoordinatorOptions {
  LeadershipOptions lead;
  Balance balance = Balance::Wear;
  double timeout = 30.0;  ///< [s] give up after this long with no task finished
};

/// What the process does, in order, after update().
struct CoordinatorAction {
  enum class Kind {
    PublishState,  ///< write `state` (CoordinatorState) and the status heartbeat
    Assign,        ///< write `assignment` (TaskAssignment: the task's name and waypoints by its index)
    /// Dispose of `assignment.module`'s TaskAssignment instance: the module left or failed, and its last assignment
    /// (transient-local, kept for a supervisor that joins late) must not reach the supervisor of its next start.
    Withdraw,
  };
  Kind kind = Kind::PublishState;
  Snapshot state;
  Assignment assignment;
};

/// Why the process ends, and how (launcher::exit_code values; docs/failure-model.md).
struct CoordinatorEnd {
  int code = 0;
  bool error = false;   ///< its status says Error (else Finalized)
  std::string status;   ///< the status detail
  std::string message;  ///< a line for stderr ("" for none)
};

class CoordinatorCore {
 public:
  static constexpr double kHeartbeatS = 0.1;  ///< state and status are published at least this often
  /// A primary with tasks left that has heard no module's task state for this long (modules report every 100 ms)
  /// while another coordinator lives is deaf to the modules: it leaves for the other one (exit kCutOff; the launcher
  /// restarts it as a standby, with a fresh participant). Soak run 31 (finding 56): a primary deaf for 40 s whose
  /// status still went out held the whole queue. Counted from the first module heard, its own last stall and its
  /// takeover. (Every module gone for over 10 s, with a standby alive, makes the coordinators take turns: harmless.)
  static constexpr double kDeafPrimaryS = 10.0;

  CoordinatorCore(const CoordinatorOptions& o, std::vector<std::string> task_names, double now);
  void set_log(std::function<void(const std::string&)> log) { log_ = std::move(log); }

  // --- Inputs --------------------------------------------------------------------------------------------
  /// The start of a pass of the process's loop (a stall of its own is found here).
  void on_loop(double now);
  /// Another coordinator's status (`peer_next`: the next task id of its queue, its status's tick; 0 if not said).
  /// A primary that must leave (Leadership::on_peer) ends with kReplaced.
  void on_peer(const std::string& id, bool active, bool claims_primary, double now, uint64_t peer_next = 0);
  /// The next task id of this one's queue.
  uint64_t next_task_id() const { return own_next_; }
  /// What its status says of it (the other coordinators' on_peer): 0 while it doubts or stalled within the last
  /// 10 s. Such a primary leaves when it hears another one whatever the ids say, so the other must stay: with the
  /// queue's id it could read a tie (a successor that assigned nothing since) and leave by the smaller id, and then
  /// neither would lead.
  uint64_t said_next_task_id(double now) const {
    return lead_.doubting() || lead_.recently_stalled(now) ? 0 : own_next_;
  }
  /// A robot's status: its joint travel [rad], summed per module for the wear balance.
  void on_wear(const std::string& robot_id, double wear_rad) { wear_[robot_id] = wear_rad; }
  void on_task_state(const ModuleReport& r, double now);
  /// Queue states are read only while this wants them: a standby, or a primary that stalled recently.
  bool wants_states(double now) const { return !lead_.primary() || lead_.recently_stalled(now); }
  void on_state(const Snapshot& s, double now) { lead_.on_state(s, now); }
  /// Decides: adopt a successor's state, take over, expire lost modules, assign, publish, give up.
  void update(double now);
  /// The process was asked to stop: the primary publishes its state one last time.
  void on_stop();

  // --- Outputs -------------------------------------------------------------------------------------------
  std::vector<CoordinatorAction> take_actions();
  /// A status heartbeat is due (a standby's, every kHeartbeatS; a primary's goes with its state).
  bool heartbeat_due(double now) const { return now - last_beat_ >= kHeartbeatS; }
  void heartbeat_sent(double now) { last_beat_ = now; }
  /// Set once the process must end (then it publishes nothing more).
  const std::optional<CoordinatorEnd>& end() const { return end_; }
  bool primary() const { return lead_.primary(); }
  /// The status detail ("3/10 tasks done, 1 running, ..." or "standby, primary at ...").
  std::string detail() const;
  /// Every task done: per module, the tasks it did and its wear, then the total line.
  std::vector<std::string> summary_lines() const;
  double module_wear(const std::string& module) const;
  const TaskQueue& queue() const { return queue_; }
  const Leadership& leadership() const { return lead_; }

 private:
  void log(const std::string& s) const { if (log_) log_(s); }
  void publish(double now);
  void assign(const Assignment& a) { actions_.push_back({CoordinatorAction::Kind::Assign, {}, a}); }

  CoordinatorOptions o_;
  TaskQueue queue_;
  Leadership lead_;
  std::function<void(const std::string&)> log_;
  std::map<std::string, double> wear_;  ///< robot process id -> joint travel [rad]
  uint64_t published_ = 0;              ///< revision of the queue last published
  double last_beat_ = -1.0, last_progress_ = 0.0;
  double last_module_heard_ = -1.0;  ///< the last task state heard from any module (-1: none yet)
  double primary_since_ = -1e300;    ///< when this one took over (a standby's silence from the modules is not deafness)
  size_t progress_mark_ = 0;
  uint64_t own_next_ = 1;  ///< one above the highest id this one assigned, or the next id of a state it adopted
  std::vector<CoordinatorAction> actions_;
  std::optional<CoordinatorEnd> end_;
};

}  // namespace tandem::coordinator
