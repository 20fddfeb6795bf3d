#include "tandem/sim/hosted_module.hpp"

namespace tandem::sim {
namespace {

world::WorldOptions lockstep_world() {
  world::WorldOptions o;
  o.arm_ids = {"m1/left", "m1/right"};
  o.arm_names = {"left", "right"};
  o.realtime = false;
  // The embedded simulation shows the physics of the whole run, as the paper's figures do: a lost object is
  // reported (slip and contact counters, the grasp check), not turned into a failed module with braked arms.
  o.drop_is_failure = false;
  return o;
}

}  // namespace

supervisor::ReportIn supervisor_input(const world::ReportOut& r) {
  supervisor::ReportIn in;
  in.tick = r.tick;
  in.braked = r.braked;
  in.hold = r.hold;
  in.braked_since = r.braked_since;
  in.released_at = r.released_at;
  in.normal_min = r.normal_min;
  in.object_xy = r.object.head<2>();
  in.object_known = true;
  in.failed = r.failed;
  in.world_rank = r.plan_rank;
  in.world_plan_version = r.plan_version;
  return in;
}

HostedModule::HostedModule(const ModuleSetup& m, double transient)
    : m_(m),
      world_(m, lockstep_world()),
      sup_(m, supervisor::SupervisorOptions{"m1/supervisor", plan::kPrimaryStrength, false, transient}, 0) {
  for (int j = 0; j < 2; ++j) robots_[static_cast<size_t>(j)].emplace(m, j, false, transient);
}

bool HostedModule::tick() {
  const int64_t now = 0;  // lockstep: no clock
  world_.begin_tick(k_, now, out_);
  if (world_.report_due(m_.steps)) sup_.on_report(supervisor_input(world_.take_report()), now);
  sup_.update(now);
  if (const auto p = sup_.take_plan()) {
    (void)world_.offer_plan(*p);
    for (auto& r : robots_) (void)r->offer_plan(*p);
  }
  for (int j = 0; j < 2; ++j) {
    const size_t a = static_cast<size_t>(j);
    if (!out_[a].publish) continue;
    model::ArmSensors s;
    s.q = out_[a].q;
    s.qd = out_[a].qd;
    s.h = out_[a].h;
    const auto tau = robots_[a]->on_sample(k_, s, out_[a].braked);
    if (!tau) return false;
    if (world_.on_command(j, k_, *tau, plan::kPrimaryStrength, now, false) != world::WorldCore::Verdict::Applied) {
      return false;
    }
  }
  if (!world_.end_tick(now)) return false;
  world_.step();
  ++k_;
  return true;
}

}  // namespace tandem::sim
