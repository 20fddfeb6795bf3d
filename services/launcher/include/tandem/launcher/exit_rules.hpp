// What the exit of one of the launcher's processes means, as a component (no processes, no DDS, no clock): the
// launcher (launcher::Supervisor::on_exit, services/launcher/src/supervisor.cpp) gathers the facts, asks
// `on_exit`, and carries the verdict out (restart, stop a module, fail the deployment, print). For a verdict of Restart it asks the restart
// policy (restart_policy.hpp) and then `after_restart`. The rules, in order, are those of docs/failure-model.md
// ("Failure tiers"); tests/unit/test_launcher_rules.cpp drives each.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "tandem/launcher/exit_codes.hpp"

namespace tandem::launcher {

enum class Role { Coordinator, World, Supervisor, Robot };

/// "coordinator", "world", "supervisor", "robot"; nothing for anything else.
std::optional<Role> parse_role(std::string_view role);


struct ExitFacts {
  Role role = Role::Robot;
  int status = 0;              ///< exit code, 128 + signal if killed
  bool expected = false;       ///< unplugged, drained, its module stopped, or restarted on purpose
  bool never_heard = false;    ///< killed by the launcher because it was never heard on the domain
  bool stopping = false;       ///< the whole deployment is stopping
  bool coordinated = false;    ///< the deployment has a coordinator (continuous tasks)
  bool module_ticked = false;  ///< its module's world has ticked (the module came up)
  int module_repairs = 0;      ///< start-up repairs of its module so far
  int max_repairs = 0;
  bool module_draining = false;  ///< its module is being unplugged (drained)
  bool restart_always = false;   ///< its restart policy is `always` (robots restart after a done task too)
  /// Live processes of its slot other than itself: coordinators; the module's other supervisors; its arm's other
  /// robots.
  int live_peers = 0;
  /// Supervisors: another live supervisor of its module leads it (its latest status says so).
  bool peer_leads = false;
};

enum class ExitVerdict {
  Nothing,         ///< the deployment is stopping, the exit was expected, or a robot's task is done
  AllTasksDone,    ///< a coordinator exited 0: stop the deployment
  Restart,         ///< ask the restart policy, then after_restart()
  RepairStart,     ///< the module never came up (peers not matched): restart it with new participants
  Drained,         ///< a drained module's supervisor exited 0: stop the module, it is unplugged
  ModuleLostPlan,  ///< a supervisor exited 5: restart the module from its initial grasp (tier 3)
  TaskOver,        ///< scenario mode, exit 0: the module's task is over (a world's exit marks it)
  ModuleFailed,    ///< coordinated: stop the module, the others go on, its task is re-planned
  Fail,            ///< the deployment fails
};

ExitVerdict on_exit(const ExitFacts& f);

enum class AfterRestart {
  CarriesOn,        ///< a live peer serves the slot (a standby robot, supervisor or coordinator)
  WaitsForRestart,  ///< nobody serves it until the restarted process answers (a robot's arm stays braked)
  WaitsForPlug,     ///< coordinated, a robot with no restart and no peer: its arm stays braked until a plug
  Fail,             ///< the deployment fails
};

/// After a Restart verdict: `restarting` is the restart policy's answer (a restart is scheduled).
AfterRestart after_restart(const ExitFacts& f, bool restarting);

/// A restart that has come due: what the slot looks like now.
struct DueRestart {
  Role role = Role::Robot;
  int strength = 0;              ///< the exited process's ownership strength (robots, supervisors)
  bool restart_as_standby = false;  ///< robots: the module's `restart_as: standby` (never back as the primary)
  bool primary_alive = false;    ///< robots: the arm has a live primary (strength 100)
  int standby_strength = 0;      ///< next_standby_strength over the slot's live processes (below 1: none left)
  int live_in_slot = 0;          ///< supervisors: live supervisors of the module
  bool task_over = false;        ///< its module is done with its scenario's task
};
struct DueRestartDecision {
  bool start = false;
  int strength = 0;  ///< robots, supervisors: the strength it starts with
  std::string why;   ///< not started: why (for the log)
};
/// A robot comes back as the primary (100) only if it was the primary, the module does not say
/// `restart_as: standby`, and the arm has no live primary; else as a standby below the live ones. A supervisor
/// comes back as a standby, and only while another supervisor serves the module (a restarted one with none
/// serving would not know the plan: the module has failed then, see on_exit). A coordinator always comes back (as a
/// standby that takes the queue state over). Nothing restarts in a module done with its task.
DueRestartDecision due_restart(const DueRestart& f);

}  // namespace tandem::launcher
