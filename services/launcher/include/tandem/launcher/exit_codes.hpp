// The exit codes of the role processes: the contract between each process (services/*/main.cpp) and the launcher
// that reads its exit (launcher::on_exit, exit_rules.hpp). Header only, with no dependency, so that every role links
// it (target tandem::exit_codes) without linking the launcher. docs/failure-model.md, "Failure tiers".
#pragma once

namespace tandem::launcher::exit_code {

inline constexpr int kDone = 0;           ///< task done, drained, stopped, or (coordinator) every task done
inline constexpr int kError = 1;          ///< an error the process could not handle (runtime::run_guarded)
inline constexpr int kBadArgs = 2;        ///< bad command line, deployment or scenario: nothing was started
inline constexpr int kPeersNotFound = 3;  ///< world, robot: its peers were not found in time (start-up)
/// Coordinator: it was stalled and another one took over meanwhile; it leaves so that one leads (restarted as a
/// standby by its policy, as any coordinator exit other than kDone).
inline constexpr int kReplaced = 3;
inline constexpr int kNoInput = 4;        ///< world, robot, supervisor: no tick, input or report in time
inline constexpr int kLostPlan = 5;       ///< supervisor: no leader and no replica has the module's plan
inline constexpr int kCutOff = 6;         ///< robot, supervisor, coordinator: cut off from the leader or its state
                                          ///< (a fresh participant may hear it: restarted alone)

}  // namespace tandem::launcher::exit_code
