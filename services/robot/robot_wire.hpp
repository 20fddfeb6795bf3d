// The robot's messages on the wire: a sensor sample into the model's inputs, the core's output into a torque
// command, and its results into a RobotSummary and its status.
#pragma once

#include <tandemPubSubTypes.h>

#include <string>

#include "tandem/model/controller.hpp"
#include "tandem/robot/robot_core.hpp"
#include "tandem/runtime/status.hpp"

namespace tandem::robot_wire {

/// The arm's measured state in a sensor sample.
model::ArmSensors inputs(const msg::ArmSensors& s);

/// Whether the torque that drove the arm over the last period (the sample's tau) was not this robot's: another
/// robot's, the world's drive (from -1) or the brake's holding torque (braked). The core tracks it then.
bool driven_by_other(const msg::ArmSensors& s, int32_t my_strength);

/// The command of the tick the core just computed.
void fill_command(const robot::RobotCore& core, const model::JointVec& tau, msg::TorqueCommand& cmd);
/// The effort the arm got over the last period (ArmSensors.tau, its joint count's entries).
model::JointVec applied(const msg::ArmSensors& s);

/// The robot's results at its end.
void fill_summary(const robot::RobotCore& core, const std::string& arm_id, const std::string& robot_id,
                  msg::RobotSummary& rs);

/// The live figures of its status (tick, tracking error, rejected plans, wear, workload).
void fill_status(const robot::RobotCore& core, runtime::StatusPublisher& status);

}  // namespace tandem::robot_wire
