#include "tandem/launcher/plug_rules.hpp"

#include <algorithm>

namespace tandem::launcher {

namespace {

constexpr int kPrimaryStrength = 100;

PlugDecision refuse(std::string text) { return {PlugDecision::Action::Refuse, 0, std::move(text)}; }

}  // namespace

PlugDecision plug_robot(const std::string& label, const std::string& robot, bool standby, const ModuleFacts& m,
                        int primary_pid, int standby_strength) {
  const std::string module = label.substr(0, label.find('/'));
  if (!m.running()) return refuse("'plug robot " + label + "': no running module '" + module + "'");
  if (std::find(m.arms.begin(), m.arms.end(), robot) == m.arms.end() || robot.empty()) {
    return refuse("'plug robot " + label + "': module " + module + " has no arm '" + robot + "' (arms: " + m.arms[0] +
                  ", " + m.arms[1] + ")");
  }
  if (standby) {
    if (standby_strength < 1) {
      return refuse("'plug robot " + label + " --standby': no ownership strength left below the live ones");
    }
    return {PlugDecision::Action::StartRobot, standby_strength,
            "plugged a robot into " + label + " as a standby (ownership strength " + std::to_string(standby_strength) + ")"};
  }
  if (primary_pid > 0) {
    return refuse("'plug robot " + label + "': the arm has a primary already (pid " + std::to_string(primary_pid) +
                  "); plug a standby or unplug it first");
  }
  return {PlugDecision::Action::StartRobot, kPrimaryStrength,
          "plugged a robot into " + label + " as the primary (ownership strength " + std::to_string(kPrimaryStrength) + ")"};
}

PlugDecision plug_module(const std::string& name, const ModuleFacts& m, bool scenario_given, bool case_given,
                         const std::string& deployment_file) {
  if (m.known && m.started && m.end.running() && m.failed) {
    // Failed by a drop (its world brakes both arms for good): a person clears it (docs/failure-model.md).
    return {PlugDecision::Action::ClearModule, 0,
            "clearing module " + name + " (failed: object dropped): its processes stop, then it starts again"};
  }
  if (m.running()) return refuse("'plug module " + name + "': it is running already");
  if (m.known && m.started && m.end.is(ModuleEnd::Kind::Draining)) {
    // Its processes still run (finishing the task): a second set would simulate the module twice.
    return refuse("'plug module " + name + "': it is draining (finishing its task before it leaves); plug it in again "
                  "once it has left");
  }
  if (!m.known || scenario_given) {
    if (name.empty() || name.find('/') != std::string::npos || !scenario_given || !case_given) {
      return refuse("'plug module " + name + "': not a module of " + deployment_file +
                    "; give its scenario and case (tandem plug module NAME --scenario FILE --case CASE)");
    }
    return {PlugDecision::Action::AddModule, 0, ""};
  }
  return {PlugDecision::Action::StartModule, 0, ""};
}

UnplugDecision unplug_module(const std::string& name, const ModuleFacts& m) {
  if (!m.running()) return {UnplugDecision::Action::Refuse, "'unplug module " + name + "': no running module of that name"};
  return {UnplugDecision::Action::DrainModule, "unplugging module " + name + ": draining (it finishes its task first)"};
}

UnplugDecision unplug_robot(const std::string& label, bool found, const std::string& arm, const std::string& module,
                            int other_live) {
  if (!found) {
    return {UnplugDecision::Action::Refuse, "'unplug robot " + label + "': no such running robot (labels as in 'tandem "
                                            "status', e.g. m1/left or m1/left@50)"};
  }
  if (other_live > 0) {
    // Graceful: the next strongest serves at once (a standby computes in shadow: no transient).
    return {UnplugDecision::Action::HandOver, "unplugging " + label + ": another robot serves " + arm + ", handing over"};
  }
  // The only robot of its arm: the module pauses (object brought to rest), then the robot goes, the world brakes
  // the arm, and the module resumes when a robot is plugged in again.
  return {UnplugDecision::Action::PauseThenUnplug,
          "unplugging " + label + ": no standby for " + arm + "; pausing " + module + " first"};
}

}  // namespace tandem::launcher
