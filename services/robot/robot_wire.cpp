#include "robot_wire.hpp"

#include <algorithm>

namespace tandem::robot_wire {

model::ArmSensors inputs(const msg::ArmSensors& s) {
  model::ArmSensors in;
  // The sample's joint count, kept to 1-4 entries; the core refuses a count that is not its arm's.
  const int n = std::clamp(static_cast<int>(s.joints()), 1, model::kMaxJoints);
  in.q.resize(n);
  in.qd.resize(n);
  for (int i = 0; i < n; ++i) {
    in.q(i) = s.q()[static_cast<size_t>(i)];
    in.qd(i) = s.qd()[static_cast<size_t>(i)];
  }
  in.h = model::Vec2(s.h()[0], s.h()[1]);
  return in;
}

bool driven_by_other(const msg::ArmSensors& s, int32_t my_strength) {
  return s.from() != my_strength && (s.from() != 0 || s.braked());
}

model::JointVec applied(const msg::ArmSensors& s) {
  const int n = std::clamp(static_cast<int>(s.joints()), 1, model::kMaxJoints);
  model::JointVec tau(n);
  for (int i = 0; i < n; ++i) tau(i) = s.tau()[static_cast<size_t>(i)];
  return tau;
}

void fill_command(const robot::RobotCore& core, const model::JointVec& tau, msg::TorqueCommand& cmd) {
  cmd.tick(static_cast<uint64_t>(core.done()));
  const model::ControlOutput& out = core.last_output();
  cmd.arm_kind(static_cast<uint8_t>(core.arm().kind()));
  cmd.joints(static_cast<uint8_t>(tau.size()));
  for (size_t i = 0; i < cmd.tau().size(); ++i) {
    cmd.tau()[i] = static_cast<Eigen::Index>(i) < tau.size() ? tau(static_cast<Eigen::Index>(i)) : 0.0;
  }
  for (int i = 0; i < 3; ++i) cmd.e_p()[static_cast<size_t>(i)] = out.e_p(i);
  cmd.e_h(out.e_h);
  cmd.normal_force(out.normal_force);
}

void fill_summary(const robot::RobotCore& core, const std::string& arm_id, const std::string& robot_id,
                  msg::RobotSummary& rs) {
  const sim::RobotMeter::Summary sm = core.summary();
  rs.arm_id(arm_id);
  rs.robot_id(robot_id);
  rs.ticks(static_cast<uint64_t>(core.done() + 1));
  rs.ep_pos_rms(sm.ep_pos_rms);
  rs.ep_ori_rms(sm.ep_ori_rms);
  rs.ep_sel_rms(sm.ep_sel_rms);
  rs.eh_rms(sm.eh_rms);
  rs.min_normal_force(sm.min_normal_force);
  rs.max_normal_force(sm.max_normal_force);
  rs.rejected(core.rejected());
}

void fill_status(const robot::RobotCore& core, runtime::StatusPublisher& status) {
  status.msg().tick(static_cast<uint64_t>(std::max(core.done(), 0L)));
  status.msg().tracking_error(core.tracking_error());
  status.msg().late(core.rejected());
  status.msg().wear(core.wear());
  status.msg().workload(core.workload());
}

}  // namespace tandem::robot_wire
