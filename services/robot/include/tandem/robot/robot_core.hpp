// The controller of one arm as a component (no DDS, no clock): the module's plan it follows, the hybrid
// control law (VLLC + LLC, docs/controller.md), the RMS meter and the wear it reports. The process
// (services/robot/main.cpp) feeds it sensor samples and plans from DDS; tests drive it tick by tick.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "tandem/model/controller.hpp"
#include "tandem/plan/plan.hpp"
#include "tandem/sim/module_setup.hpp"

namespace tandem::robot {

class RobotCore {
 public:
  /// j: the arm (0 or 1) of module m; continuous: the plan is a chain of coordinator tasks.
  RobotCore(const sim::ModuleSetup& m, int j, bool continuous, double transient);

  /// A plan heard on the wire: adopted if it outranks the one followed (plan::PlanFollower); a malformed one
  /// is rejected and counted (`why` says how).
  plan::PlanFollower::Offer offer_plan(const plan::PlanData& p, std::string* why = nullptr);

  /// The rank of the plan the world follows, sent with each sample of tick k (ArmSensors.plan_epoch and
  /// plan_strength). A robot with a plan that the world's outranks for more than kBehindTicks has missed its
  /// leader's plans: it is cut off from the module's leader and must not serve an arm (cut_off). A takeover's
  /// plan reaches the world and the robots within a few ticks of each other. Found by the one-hour soak: after a
  /// supervisor takeover, Fast DDS failed to add the new leader's writer to one standby robot's reader ("Failed
  /// to open segment fast_datasharing_..."); that robot kept its old plan, 158 mm off the module's reference,
  /// later took its arm over, and the object was dropped. (A first version judged the leader's heartbeat, but
  /// a leader publishes nothing while it is unsure it still leads, and robots were cut off by the dozen.)
  /// While the world's plan outranks this robot's, on_sample answers nothing (a stale plan is never served).
  void world_rank(const plan::SupervisorRank& world, long k) { world_plan(world, 0, k, k); }
  /// As world_rank, with the version of the plan the world follows and the tick at which the world adopted it
  /// (ArmSensors.plan_version, plan_since): a robot whose plan is the same leader's but an older version, more than
  /// kVersionGraceTicks after the world adopted the newer one, is behind too (it answers nothing until it has that
  /// version). Found by a soak-small hour: the serving robot was stalled for 0.1 s while the supervisor stopped the
  /// path (the world drove the arm meanwhile); back, it took the arm over with the running plan of before the stop,
  /// its reference ran ahead of the stopped object, and the object slipped and was dropped. A new version takes
  /// effect 5-20 ticks after it is made (kHoldLeadTicks, kLeadTicks) and reaches the world and the robots within a
  /// tick of each other on a quiet machine, so the grace costs nothing then; at 10 ticks into a stop ramp a stale
  /// reference is off by under 0.1 mm.
  void world_plan(const plan::SupervisorRank& world, uint64_t version, long since, long k);
  static constexpr long kVersionGraceTicks = 10;
  bool behind() const { return behind_; }
  /// 2 s: a behind robot answers nothing anyway (no stale command), so the bound trades a restart against a longer
  /// brake. It was 500 ticks: a soak-small run cut off all three live robots of a module at once when a starved
  /// new leader's plan reached the world but not the robots' plan readers within 0.5 s (the leader itself then
  /// stood still for 1 s); the restarts loaded the machine further and the module dropped its object after the
  /// release.
  static constexpr long kBehindTicks = 2000;
  /// A robot that has heard no plan at all while the world follows one is cut off after this many ticks (its
  /// plan reader never matched the leader's writer: seen in a soak, a restarted robot stayed a silent "standby"
  /// that the launcher counted as serving, and its arm stayed braked when the robot that did serve was killed).
  static constexpr long kNoPlanTicks = 10000;
  bool cut_off() const { return behind_since_ >= 0 && last_k_ - behind_since_ > behind_limit_; }

  /// One sensor sample of tick k. Returns the torque to send: for a new tick the law's output (eq. 15 from
  /// the plan, saturated at tau_max); for a repeat of the last tick (lockstep asks again) the same command;
  /// nothing for an older tick, a sample with NaN/inf (rejected, counted), or before any plan is heard.
  /// `applied`: the torque the arm got over the last period when another robot served it (nullptr when this
  /// robot served it, or unknown): the law tracks it (bumpless transfer, HybridController::track).
  /// A sample of another joint count than the arm's is rejected like a NaN one.
  std::optional<model::JointVec> on_sample(long k, const model::ArmSensors& in, bool braked,
                                           const model::JointVec* applied = nullptr);

  long done() const { return done_; }                  ///< the last tick computed (-1: none)
  /// The status detail of an active robot behind the world's plan (behind()): it answers nothing until it has that
  /// plan, so it is no standby that can take its arm over (observers such as tandem soak tell so by it).
  static constexpr const char* kBehindDetail = "behind the module's plan: answers nothing until it has it";
  /// Why the last sample got no command ("" if it got one): for a robot that falls silent (soak finding 84).
  const char* silent_reason() const { return silent_; }
  bool has_plan() const { return follower_.has_plan(); }  ///< a plan has been adopted (the law can run)
  plan::SupervisorRank plan_rank() const { return follower_.rank(); }  ///< the rank of the plan followed
  uint64_t plan_version() const { return follower_.version(); }        ///< and its version
  const model::JointVec& last_tau() const { return tau_; }
  /// The arm's model (of its type).
  const model::Manipulator& arm() const { return ctl_.arm(); }
  /// The law's output at the last tick computed (errors e_p, e_h, normal force; for recorders).
  const model::ControlOutput& last_output() const { return out_; }
  /// The reference of the last tick computed (eq. 15 from the plan).
  const model::ArmReference& last_reference() const { return ref_; }
  double wear() const { return wear_; }                ///< joint travel sum |dq| [rad]
  double workload() const { return workload_; }        ///< sum |tau| . |dq| [J]
  double tracking_error() const { return tracking_; }  ///< |x_d - x| (x, y) at the last tick [m]
  unsigned long long rejected() const { return rejected_; }
  /// Takeovers this robot refused as older than its plan and then adopted because the world follows them.
  unsigned long long adopted_refused() const { return adopted_refused_; }
  /// Ticks whose law output exceeded tau_max on some joint and was clipped; whether the last one was.
  unsigned long long saturated() const { return saturated_; }
  bool last_saturated() const { return last_saturated_; }
  sim::RobotMeter::Summary summary() const { return meter_.summary(); }

 private:
  const sim::ModuleSetup& m_;
  int j_;
  plan::PlanFollower follower_;
  model::HybridController ctl_;
  sim::RobotMeter meter_;
  long done_ = -1;
  const char* silent_ = "";
  model::JointVec tau_;
  model::ControlOutput out_{};
  model::ArmReference ref_{};
  model::JointVec prev_q_;
  double wear_ = 0.0, workload_ = 0.0, tracking_ = 0.0;
  unsigned long long rejected_ = 0;
  unsigned long long adopted_refused_ = 0;
  unsigned long long saturated_ = 0;
  bool last_saturated_ = false;
  bool behind_ = false;     ///< the world's plan outranks this robot's (world_rank)
  long behind_limit_ = kBehindTicks;
  long behind_since_ = -1;  ///< the first tick of the current run at which the world's plan outranked this one's
  long last_k_ = -1;        ///< the tick of the last world rank heard
};

}  // namespace tandem::robot
