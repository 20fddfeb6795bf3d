// What the launcher does with a live `plug` or `unplug` (ControlRequest), as a component: the launcher
// (services/cli/up_run.cpp) gathers the facts about the module, its arm and its processes, asks these rules,
// and carries the decision out (start a process, stop a module, send a drain or a pause) or answers the refusal.
// No processes, no DDS, no clock: tests/unit/test_launcher_rules.cpp drives each rule. docs/failure-model.md, "Live
// commands", says what a user sees.
#pragma once

#include <array>
#include <string>

namespace tandem::launcher {

/// A module as the launcher knows it when a live command names it.
struct ModuleFacts {
  bool known = false;    ///< in the deployment, or plugged in earlier
  bool started = false;  ///< its processes were started
  /// Why it ended ("" while it runs): "draining", "unplugged", "failed: ...", "repairing", "parked: ...", "cleared".
  std::string end;
  bool failed = false;  ///< its task state says failed (the world reports its object dropped)
  std::array<std::string, 2> arms{};  ///< the arms' names ("left", "right")
  bool running() const { return known && started && end.empty(); }
};

struct PlugDecision {
  enum class Action {
    Refuse,       ///< nothing changes; `text` says why and what is accepted
    StartRobot,   ///< start a robot for the arm with `strength`
    ClearModule,  ///< a module failed by a drop: stop its processes, then start it again from its initial grasp
    StartModule,  ///< start a module of the deployment (or plugged before) again
    AddModule,    ///< prepare a new module from the request's scenario and case, then start it
  };
  Action action = Action::Refuse;
  int strength = 0;  ///< StartRobot: the ownership strength of its torque writer
  std::string text;  ///< the answer (a refusal's reason, or what is done)
};

/// `plug robot <module>/<arm> [--standby]`. `robot` is the arm's name from the request. `primary_pid` is the pid of
/// the arm's live primary (0: none); `standby_strength` the strength a new standby would get (next_standby_strength;
/// below 1: none left).
PlugDecision plug_robot(const std::string& label, const std::string& robot, bool standby, const ModuleFacts& m,
                        int primary_pid, int standby_strength);

/// `plug module <name> [--scenario F --case C]`. `deployment_file` names the deployment in a refusal.
PlugDecision plug_module(const std::string& name, const ModuleFacts& m, bool scenario_given, bool case_given,
                         const std::string& deployment_file);

struct UnplugDecision {
  enum class Action {
    Refuse,           ///< nothing changes; `text` says why
    DrainModule,      ///< the supervisor finishes the task, takes no new one and exits; then the rest stops
    HandOver,         ///< another robot serves the arm: this one stops (deletes its torque writer first)
    PauseThenUnplug,  ///< the arm's only robot: pause the module (object at rest), then stop it; the arm is braked
  };
  Action action = Action::Refuse;
  std::string text;
};

UnplugDecision unplug_module(const std::string& name, const ModuleFacts& m);
/// `unplug robot <label>`: `found` says whether a running robot has that label; `other_live` counts the other live
/// robots of its arm.
UnplugDecision unplug_robot(const std::string& label, bool found, const std::string& arm, const std::string& module,
                            int other_live);

}  // namespace tandem::launcher
