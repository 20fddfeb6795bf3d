// What the launcher does with a live `plug` or `unplug` (ControlRequest), as a component: the launcher
// (services/cli/up_run.cpp) gathers the facts about the module, its arm and its processes, asks these rules,
// and carries the decision out (start a process, stop a module, send a drain or a pause) or answers the refusal.
// No processes, no DDS, no clock: tests/unit/test_launcher_rules.cpp drives each rule. docs/failure-model.md, "Live
// commands", says what a user sees.
#pragma once

#include <array>
#include <string>
#include <utility>

namespace tandem::launcher {

/// Whether a module's run goes on, or why it ended.
struct ModuleEnd {
  enum class Kind {
    Running,    ///< it runs
    Draining,   ///< unplugged: finishing its task before it leaves (its processes still run)
    Unplugged,  ///< left after its drain
    Repairing,  ///< stopped to be started again with new processes (it did not come up)
    Parked,     ///< stopped for load (admission at start-up or shedding); `why` says which
    Cleared,    ///< stopped to be started again after a failure was cleared
    Failed,     ///< a process it cannot do without exited for good; `why` says which
  };
  Kind kind = Kind::Running;
  std::string why;  ///< Parked, Failed: the reason

  static ModuleEnd of(Kind k, std::string reason = "") { return {k, std::move(reason)}; }
  bool running() const { return kind == Kind::Running; }
  bool is(Kind k) const { return kind == k; }
  /// The word for it: "running", "draining", "unplugged", "repairing", "parked", "cleared", "failed".
  const char* word() const {
    switch (kind) {
      case Kind::Running: return "running";
      case Kind::Draining: return "draining";
      case Kind::Unplugged: return "unplugged";
      case Kind::Repairing: return "repairing";
      case Kind::Parked: return "parked";
      case Kind::Cleared: return "cleared";
      case Kind::Failed: return "failed";
    }
    return "?";
  }
  /// As said to people: "" while it runs, else the word and the reason ("failed: m1/world exited with code 1").
  std::string text() const {
    if (running()) return "";
    return why.empty() ? std::string(word()) : std::string(word()) + ": " + why;
  }
};

/// A module as the launcher knows it when a live command names it.
struct ModuleFacts {
  bool known = false;    ///< in the deployment, or plugged in earlier
  bool started = false;  ///< its processes were started
  ModuleEnd end;  ///< whether it runs, or why it ended
  bool failed = false;  ///< its task state says failed (the world reports its object dropped)
  std::array<std::string, 2> arms{};  ///< the arms' names ("left", "right")
  bool running() const { return known && started && end.running(); }
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
