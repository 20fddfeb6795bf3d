// Starting role processes (the launcher's and the agents'): fork + execve with the child's environment built
// before the fork, SCHED_FIFO on request, and PR_SET_PDEATHSIG so that no child outlives its parent.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace tandem::launcher {

struct SpawnOptions {
  int rt_priority = 0;      ///< > 0: the child (and the threads it creates) run SCHED_FIFO at this priority
  int participant_id = -1;  ///< TANDEM_PARTICIPANT_ID for the child, -1: Fast DDS's choice
  std::string identity;     ///< TANDEM_IDENTITY (DDS-Security) for the child, "": inherited environment only
  /// The child leads a session, and so a scheduling autogroup, of its own, at the niceness it inherits
  /// (sched_group.hpp); false: it stays in its parent's session and group (see own_group_for).
  bool own_group = true;
  /// ROS_DISCOVERY_SERVER for the child ("": the parent's, inherited): a module's processes are clients of their
  /// module's Discovery Server only (runtime::discovery_env).
  std::string discovery;
  /// TANDEM_CPU for the child (-1: none, and an inherited one is dropped): a per-tick process pins every thread
  /// to this CPU once active (runtime::raise_to_realtime_from_env).
  int cpu = -1;
};

/// Whether a role process gets an autogroup of its own: the control plane (supervisors, coordinators) always, and
/// the per-tick processes (world, robot) in real time, where they run SCHED_FIFO and the group only speeds their
/// start-up. Not lockstep's per-tick processes, which compute as fast as the machine allows: each in a group of
/// its own would weigh like a whole session against every other session's load (4 modules: 28 sessions' worth);
/// in their launcher's group they weigh like the one session they are.
bool own_group_for(const std::string& role, const std::vector<std::string>& args);

/// Starts `exe` with `args`; the child gets SIGTERM when its parent dies. Returns its pid, -1 if fork failed
/// (with a message naming `who` and the executable on stderr). An exec failure shows as exit code 127.
pid_t spawn(const std::string& who, const std::string& exe, const std::vector<std::string>& args,
            const SpawnOptions& opt = {});

/// The niceness of a real-time deployment's launcher, agents and everything they start (per-tick processes until
/// they raise themselves to SCHED_FIFO, coordinators, restarts): ahead of the machine's ordinary processes, so that
/// an unrelated busy process delays neither a restart nor a coordinator (soak run 13: a replacement robot active
/// after 16.2 s and coordinators standing still for 2 s while two hogs at normal priority held both cores), and
/// still below every SCHED_FIFO thread, so that a start-up never preempts a running module.
inline constexpr int kServiceNice = -10;

/// Sets this process's niceness to kServiceNice, inherited by the threads it creates afterwards and by its
/// children (call it before any thread starts); false, with the system's reason in `why`, if not permitted.
/// With `group` (the default) and this process leading its own session, its scheduling autogroup gets the same
/// niceness; not in lockstep, where the per-tick processes stay in this process's group (own_group_for): a group
/// raised to -10 with four modules' per-tick work in it starved the control plane (a soak-four lockstep launcher that
/// led its session did 2 tasks in 45 s where one that did not did 50).
bool raise_service_priority(std::string& why, bool group = true);

/// Whether this process may use SCHED_FIFO at `priority` (tried on the calling thread, then undone); `why`
/// gets the system's reason when not.
bool fifo_permitted(int priority, std::string& why);

/// The directory of this process's executable (its siblings, tandem-world etc., live there).
std::string self_dir();

}  // namespace tandem::launcher
