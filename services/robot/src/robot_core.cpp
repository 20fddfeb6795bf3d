#include "tandem/robot/robot_core.hpp"

#include <algorithm>

namespace tandem::robot {

RobotCore::RobotCore(const sim::ModuleSetup& m, int j, bool continuous, double transient)
    : m_(m), j_(j), follower_(m, continuous), ctl_(model::arm_model(m.plant, j), m.control[j]),
      meter_(m.control[j].selection_p, transient, m.path.motion_end()),
      tau_(model::JointVec::Zero(ctl_.arm().dof())), prev_q_(model::JointVec::Zero(ctl_.arm().dof())) {}

plan::PlanFollower::Offer RobotCore::offer_plan(const plan::PlanData& p, std::string* why) {
  const plan::PlanFollower::Offer o = follower_.offer(p, why, done_);
  if (o == plan::PlanFollower::Offer::Rejected) ++rejected_;
  return o;
}

void RobotCore::world_plan(const plan::SupervisorRank& world, uint64_t version, long since, long k) {
  // Without a plan a robot commands nothing (on_sample), so it cannot serve a stale one; it may still be
  // discovering the supervisor's writer (a robot that joins a running module): it gets kNoPlanTicks for that.
  const bool planless = !follower_.has_plan() && world.outranks(plan::SupervisorRank{});
  // The world follows a takeover this robot refused as older than its own plan (the world had not heard the newer
  // version): the world decides, the robot follows it too.
  if (world.outranks(follower_.rank()) && follower_.adopt_refused(world, version, done_)) ++adopted_refused_;
  const plan::SupervisorRank own = follower_.rank();
  const bool same_rank = world.epoch == own.epoch && world.strength == own.strength;
  const bool older = same_rank && version > follower_.version() && k - since > kVersionGraceTicks;
  // This robot follows a takeover the world refused (plan::PlanFollower: its version is older than the world's):
  // it missed the leader's newest plan before it heard the stale takeover. It answers nothing until the leader
  // that made the newer plan retakes, in an epoch above both.
  const bool refused = own.outranks(world) && world.strength != 0 && version > follower_.version();
  behind_ = follower_.has_plan() && (world.outranks(own) || older || refused);
  if (behind_ || planless) {
    if (behind_since_ < 0) behind_since_ = k;
  } else {
    behind_since_ = -1;
  }
  behind_limit_ = planless ? kNoPlanTicks : kBehindTicks;
  last_k_ = std::max(last_k_, k);
}

std::optional<model::JointVec> RobotCore::on_sample(long k, const model::ArmSensors& in, bool braked,
                                                    const model::JointVec* applied) {
  const int n = ctl_.arm().dof();
  if (in.q.size() != n || in.qd.size() != n || !plan::all_finite(in.q) || !plan::all_finite(in.qd) ||
      !plan::all_finite(in.h)) {
    ++rejected_;
    silent_ = "a sample with a non-finite value or of another joint count";
    return std::nullopt;
  }
  // Behind the world's plan (a takeover's plan not heard yet): no command from a plan the module has left. The
  // world serves the tick from a robot that has the plan (a standby), or keeps the last torque for a few ticks.
  if (behind_) {
    silent_ = "the world follows a plan this robot has not heard (another rank, or a newer version)";
    return std::nullopt;
  }
  if (k < done_) {
    silent_ = "a sample older than the last tick computed";
    return std::nullopt;
  }
  silent_ = "";
  if (k == done_) return tau_;                         // the world asks again: the same answer
  if (!follower_.has_plan()) {                         // nothing to follow yet
    silent_ = "no plan heard yet";
    return std::nullopt;
  }
  const model::ArmReference ref = follower_.reference(j_, k);
  // Continue from what the arm actually got over the last period, not from this controller's own last output
  // (bumpless transfer): its owner's torque when this robot is in shadow, the world's drive, or, while the
  // brakes hold the arm, the torque the brake takes to hold it (g + J^T h). A robot that takes a braked arm
  // over then starts from the holding torque, and its law's memory never winds up on an error the arm cannot
  // act on. Only right after this robot's own previous tick; a braked tick without that torque starts afresh.
  const bool tracks = applied != nullptr && done_ == k - 1 && applied->size() == n && plan::all_finite(*applied);
  if (tracks) {
    ctl_.track(*applied - tau_);
  } else if (braked) {
    ctl_.reset();
  }
  model::ControlOutput out = ctl_.step(in, ref);
  // Actuator limits: the command is saturated here as the drive would (the plant clips the same way).
  model::JointVec clipped = out.tau;
  for (int i = 0; i < n; ++i) {
    const double lim = ctl_.arm().joints().effort_max[static_cast<size_t>(i)];
    clipped(i) = std::min(std::max(clipped(i), -lim), lim);
  }
  last_saturated_ = clipped != out.tau;
  if (last_saturated_) ++saturated_;
  out.tau = clipped;
  meter_.add(static_cast<double>(k) * m_.period, ref, out);
  if (done_ >= 0) {  // wear and workload, for the coordinator's balancing
    const model::JointVec dq = (in.q - prev_q_).cwiseAbs();
    wear_ += dq.sum();
    workload_ += out.tau.cwiseAbs().dot(dq);
  }
  prev_q_ = in.q;
  tracking_ = out.e_p.head<2>().norm();
  tau_ = out.tau;
  out_ = out;
  ref_ = ref;
  done_ = k;
  return tau_;
}

}  // namespace tandem::robot
