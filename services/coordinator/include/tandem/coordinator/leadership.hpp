// Who leads a deployment's task queue, as a component (no DDS, no clock: times in seconds are passed in). The
// rules that lived in the coordinator's main (services/coordinator/main.cpp wires this to DDS now):
// - a standby keeps the most advanced queue state it hears (next task id, then tasks finished): a restarted
//   coordinator may also hear an older copy (the launcher republishes the last state it saw);
// - it takes over when the primary's state has been silent for kTakeoverS (kFirstStateS if it never heard one,
//   then from the whole queue), and only if no live standby before it by id is active (first in line);
// - a restarted one (--resume) does not take over in its first kFirstStateS: a live primary may not be discovered
//   yet, and the state it heard may be only the launcher's copy (found by tandem soak: a restarted standby took
//   over 1.0 s after its start beside a live primary, and a task heard done went back to the queue);
// - a restarted one (--resume: a queue existed before it started) never takes over without a state heard: the
//   launcher's republished copy may reach a late joiner only after seconds, and a fresh queue would do every
//   task again (found by tandem soak: the queue went back from 1747 tasks done to none);
// - a primary whose own loop stood still longer than kStallS may have been replaced: it decides nothing for
//   kDoubtS while it listens; if another coordinator reports `primary` meanwhile, it leaves (crash-only; the
//   launcher restarts it as a standby), else it goes on (found by tandem soak: a stalled primary came back and
//   led beside its successor). Its successor's status may reach it only after the doubt (seen in the hour-long
//   soak: a primary back from a 2 s SIGSTOP heard nobody within 0.3 s and led on beside its successor): so a
//   primary that hears another primary later leaves too if it stalled within kStallMemoryS; of two primaries that
//   never stalled (or whose stall the other did not see) the one whose queue is further on stays, then the smaller
//   id (found by the lockstep soak hour: a primary back from a 1.7 s stall came back while its successor, with the
//   larger id, led; the successor left on the id rule before the stalled one had heard it, and the stalled one led
//   on with its older queue: a task was done twice). A primary that doubts or stalled lately says 0 for its queue
//   (CoordinatorCore::said_next_task_id), so the other never leaves for it; two that both stalled within 10 s both
//   leave, and a standby takes over;
// - a standby that hears a state with every task done exits with the primary;
// - a standby whose own loop stood still (kStandbyDeafS) counts the primary's silence from its return: it heard
//   nothing meanwhile (found by tandem soak: both coordinators stalled together, the standby took over on a silence
//   that was its own, and both left);
// - a standby with a state that first_in_line holds back for kPassOverS more takes over all the same: the one before
//   it in line is alive but cannot lead (found by a soak-small hour: a restarted standby that never heard a queue
//   state, which a --resume one must not lead without, stood first in line for 900 s, and no task was done);
// - a restarted one (--resume) that has heard no state for kDeafS cannot hear the queue (its reader matched neither
//   the primary's writer nor the launcher's copy): Step::Deaf, it exits 6 and the launcher restarts it with a fresh
//   participant.
// Unit tests: tests/unit/test_task_queue.cpp ("leadership: ...").
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "tandem/coordinator/task_queue.hpp"

namespace tandem::coordinator {

struct LeadershipOptions {
  std::string id = "coordinator";  ///< this process's id; among standbys the smallest live one goes first
  bool standby = false;            ///< start as a standby (else as the primary)
  bool resume = false;             ///< a queue existed before this one started: never take over without its state
};

class Leadership {
 public:
  static constexpr double kTakeoverS = 0.5;    ///< the primary's state silent this long: a standby takes over
  static constexpr double kFirstStateS = 3.0;  ///< ... or none heard this long since the start
  static constexpr double kStallS = kTakeoverS;
  static constexpr double kDoubtS = 0.3;
  static constexpr double kStallMemoryS = 10.0;
  static constexpr double kPassOverS = 2.0;
  static constexpr double kDeafS = 10.0;
  /// A standby's loop (at most 20 ms a pass) that stood still longer than this heard nothing meanwhile.
  static constexpr double kStandbyDeafS = 0.1;

  Leadership(const LeadershipOptions& o, double now) : o_(o), primary_(!o.standby), start_(now), last_loop_(now) {}

  // --- Inputs --------------------------------------------------------------------------------------------
  /// The start of a pass of the coordinator's loop. A primary whose loop stood still past kStallS starts to
  /// doubt (returns the line to log, else "").
  std::string on_loop(double now);
  /// Another coordinator's status: `active` (its lifecycle), `claims_primary` (its status says `primary`),
  /// `peer_next` the next task id of its queue (0: not said) and `own_next` this one's. True if this one must
  /// leave: another one leads while this one doubts after a stall or stalled within kStallMemoryS; else, of two
  /// primaries, the one whose queue is further on stays (it assigned tasks the other never saw), and with queues
  /// as far on (or not said) the smaller id stays.
  bool on_peer(const std::string& id, bool active, bool claims_primary, double now, uint64_t peer_next = 0,
               uint64_t own_next = 0);
  /// A primary's queue state (read while a standby). False if it was malformed or older than the one kept.
  bool on_state(const Snapshot& s, double now);

  // --- Decisions -----------------------------------------------------------------------------------------
  enum class Step {
    Wait,      ///< a standby that does not take over now, or a primary that doubts: decide nothing
    TakeOver,  ///< become the primary: restore last_state() (if any), reconcile, then lead (primary() is now true)
    Lead,      ///< the primary: assign, expire, publish
    AllDone,   ///< a standby heard every task done: exit
    Deaf,      ///< a --resume standby that heard no queue state for kDeafS: exit 6 (restarted with a fresh participant)
  };
  /// What to do at `now` for a queue of `tasks` tasks; `log` gets a line when something changed.
  Step step(double now, size_t tasks, std::string* log);

  bool primary() const { return primary_; }
  bool doubting() const { return doubt_until_ >= 0.0; }
  /// Its loop stood still past kStallS within the last kStallMemoryS: a successor may have led meanwhile (the
  /// primary reads the queue states then, and adopts a more advanced one).
  bool recently_stalled(double now) const { return now - last_stall_ <= kStallMemoryS; }
  /// When this one last came back from a stall of its own (-1e300: never).
  double last_stall() const { return last_stall_; }
  /// Another active coordinator was heard within `within` seconds.
  bool peer_alive(double now, double within = 1.0) const {
    for (const auto& [id, at] : peers_) {
      if (now - at <= within) return true;
    }
    return false;
  }
  const std::optional<Snapshot>& last_state() const { return last_state_; }
  /// Seconds since the primary's last state (since the start if none was heard), or since this standby's own loop
  /// last stood still, whichever is later.
  double silent(double now) const { return now - std::max(last_state_ ? last_state_at_ : start_, listen_from_); }
  uint64_t malformed_states() const { return malformed_; }

 private:
  bool first_in_line(double now) const;
  LeadershipOptions o_;
  bool primary_;
  double start_, last_loop_;
  double doubt_until_ = -1.0;
  double last_stall_ = -1e300;
  std::optional<Snapshot> last_state_;
  double last_state_at_ = 0.0;
  double listen_from_ = -1e300;  ///< a standby's own stall ended here: silence before it is not the primary's
  uint64_t malformed_ = 0;
  std::map<std::string, double> peers_;  ///< other active coordinators -> when last heard
};

}  // namespace tandem::coordinator
