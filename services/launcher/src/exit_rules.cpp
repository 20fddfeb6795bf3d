#include "tandem/launcher/exit_rules.hpp"

namespace tandem::launcher {

std::optional<Role> parse_role(std::string_view role) {
  if (role == "coordinator") return Role::Coordinator;
  if (role == "world") return Role::World;
  if (role == "supervisor") return Role::Supervisor;
  if (role == "robot") return Role::Robot;
  return std::nullopt;
}

ExitVerdict on_exit(const ExitFacts& f) {
  if (f.stopping) return ExitVerdict::Nothing;
  if (f.role == Role::Coordinator) {
    // Every task done; otherwise a standby coordinator carries on, or a restart takes over.
    return f.status == exit_code::kDone ? ExitVerdict::AllTasksDone : ExitVerdict::Restart;
  }
  if (f.expected) return ExitVerdict::Nothing;  // unplugged, or its module was stopped
  // A module that did not come up: a process gave up waiting for its peers before the world's first tick, or was
  // never heard. With DDS-Security a pair of participants sometimes never authenticates (Fast DDS 2.9.1), and new
  // participants for the whole module repair it (docs/security.md, "Start-up").
  if (!f.module_ticked && (f.status == exit_code::kPeersNotFound || f.status == exit_code::kNoInput || f.never_heard) &&
      f.module_repairs < f.max_repairs) {
    return ExitVerdict::RepairStart;
  }
  if (f.role == Role::Supervisor && f.status == exit_code::kDone && f.module_draining) return ExitVerdict::Drained;
  if (f.role == Role::Robot) {
    if (f.status == exit_code::kDone && !f.restart_always) return ExitVerdict::Nothing;  // its task is done
    return ExitVerdict::Restart;
  }
  // Exit 5 (no plan to follow: it never heard a leader, and the object is not where the initial plan has it) means
  // the module lost its plan only if no other supervisor leads it. With a leader alive, this standby was merely
  // deaf to it (a new participant that did not match the leader's writer in 6 s, on a loaded machine): it restarts
  // alone, with a fresh participant, as exit 6 does (soak run 26 restarted a module whose leader was alive).
  if (f.role == Role::Supervisor && f.status == exit_code::kLostPlan && f.coordinated && !f.peer_leads) {
    return ExitVerdict::ModuleLostPlan;
  }
  // Hot standby: another supervisor of the module carries on with the same plan (tier 1); this one comes back as a
  // standby if its policy says so (a deaf one, exit 6, with a fresh participant).
  if (f.role == Role::Supervisor && !(f.status == exit_code::kDone && !f.coordinated) && f.live_peers > 0) {
    return ExitVerdict::Restart;
  }
  // The world, or a module's last supervisor.
  if (f.status == exit_code::kDone && !f.coordinated) return ExitVerdict::TaskOver;
  return f.coordinated ? ExitVerdict::ModuleFailed : ExitVerdict::Fail;
}

AfterRestart after_restart(const ExitFacts& f, bool restarting) {
  switch (f.role) {
    case Role::Coordinator:
      return f.live_peers > 0 || restarting ? AfterRestart::CarriesOn : AfterRestart::Fail;
    case Role::Supervisor:
      return AfterRestart::CarriesOn;  // on_exit asked for a restart only with a live peer
    case Role::Robot:
      if (f.live_peers > 0) return AfterRestart::CarriesOn;
      if (restarting) return AfterRestart::WaitsForRestart;
      return f.coordinated ? AfterRestart::WaitsForPlug : AfterRestart::Fail;
    case Role::World:
      break;
  }
  return AfterRestart::Fail;  // a world is never restarted alone (on_exit never says Restart for it)
}

DueRestartDecision due_restart(const DueRestart& f) {
  constexpr int kPrimary = 100;
  if (f.task_over && f.role != Role::Coordinator) return {false, 0, "its module is done with its task"};
  switch (f.role) {
    case Role::Robot: {
      const bool primary = f.strength == kPrimary && !f.restart_as_standby && !f.primary_alive;
      if (primary) return {true, kPrimary, ""};
      if (f.standby_strength < 1) return {false, 0, "no ownership strength left below the live robots"};
      return {true, f.standby_strength, ""};
    }
    case Role::Supervisor:
      if (f.live_in_slot == 0) return {false, 0, "no supervisor serves the module"};
      if (f.standby_strength < 1) return {false, 0, "no strength left below the live supervisors"};
      return {true, f.standby_strength, ""};
    case Role::Coordinator:
      return {true, 0, ""};
    case Role::World:
      break;
  }
  return {false, 0, "a world is never restarted alone"};
}

}  // namespace tandem::launcher
