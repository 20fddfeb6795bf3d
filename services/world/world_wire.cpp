#include <algorithm>
#include <cstdint>

#include "world_wire.hpp"

namespace tandem::world_wire {

void fill_sample(const world::SampleOut& o, model::ArmKind kind, long k, const plan::SupervisorRank& plan_rank, uint64_t plan_version,
                 long plan_since, msg::ArmSensors& s) {
  s.tick(static_cast<uint64_t>(k));
  s.t(o.t);
  const auto n = static_cast<size_t>(o.q.size());
  s.arm_kind(static_cast<uint8_t>(kind));
  s.joints(static_cast<uint8_t>(n));
  for (size_t i = 0; i < s.q().size(); ++i) {
    const auto e = static_cast<Eigen::Index>(i);
    s.q()[i] = i < n ? o.q(e) : 0.0;
    s.qd()[i] = i < n ? o.qd(e) : 0.0;
    s.tau()[i] = i < n && e < o.tau_applied.size() ? o.tau_applied(e) : 0.0;
  }
  s.h()[0] = o.h(0);
  s.h()[1] = o.h(1);
  s.braked(o.braked);
  s.from(o.applied_from);
  s.plan_epoch(plan_rank.epoch);
  s.plan_strength(plan_rank.strength);
  s.plan_version(plan_version);
  s.plan_since(plan_since);
}

void fill_summary(const world::WorldCore& core, const std::string& module, long ticks, bool realtime,
                  unsigned long long overruns, const runtime::Histogram& latency_us,
                  const runtime::Histogram& wake_late_us, msg::WorldSummary& ws) {
  const model::ModulePlant& plant = core.plant();
  ws.module_id(module);
  ws.braked_ticks(core.braked_ticks);
  ws.overruns(overruns);
  ws.ticks(static_cast<uint64_t>(ticks));
  for (int j = 0; j < 2; ++j) {
    const model::JointVec& q = plant.state().q[static_cast<size_t>(j)];
    for (int i = 0; i < model::kMaxJoints; ++i) {
      const size_t slot = static_cast<size_t>(model::kMaxJoints) * static_cast<size_t>(j) + static_cast<size_t>(i);
      ws.q_final()[slot] = i < q.size() ? q(i) : 0.0;
    }
  }
  ws.object_final()[0] = plant.state().c(0);
  ws.object_final()[1] = plant.state().c(1);
  ws.object_final()[2] = plant.state().psi;
  ws.slip_events(static_cast<uint64_t>(plant.counters().slip_events));
  ws.contact_lost(static_cast<uint64_t>(plant.counters().contact_lost));
  ws.late_commands(realtime ? core.late : core.timeouts);
  ws.rejected_commands(core.rejected);
  ws.realtime(realtime);
  ws.latency_p50_us(latency_us.percentile(0.5));
  ws.latency_p99_us(latency_us.percentile(0.99));
  ws.latency_max_us(latency_us.percentile(1.0));
  ws.wake_late_p99_us(wake_late_us.percentile(0.99));
  ws.failovers(core.failovers);
  ws.failover_max_ms(core.failover_max_ms);
  ws.failover_last_ms(core.failover_last_ms);
  ws.load_pauses(core.load_pauses);
  ws.load_paused_ticks(core.load_paused_ticks);
  for (const world::Switch& sw : core.switches) {
    ws.switch_gap_ms().push_back(sw.gap_ms);
    ws.switch_failover().push_back(sw.failover);
    ws.switch_ep_max().push_back(sw.ep_max);
    ws.switch_hn_min().push_back(sw.hn_min);
  }
}

void fill_report_counters(const world::WorldCore& core, bool realtime, msg::WorldReport& rep) {
  rep.slips(static_cast<uint64_t>(core.plant().counters().slip_events));
  rep.contact_lost(static_cast<uint64_t>(core.plant().counters().contact_lost));
  rep.late(realtime ? core.late : core.timeouts);
  rep.failovers(core.failovers);
  rep.load_paused(core.paused_for_load());
  rep.owners(owners(core));
  const plan::SupervisorRank rank = core.plan_rank();
  rep.plan_epoch(rank.epoch);
  rep.plan_strength(rank.strength);
}

std::vector<msg::ArmOwner> owners(const world::WorldCore& core) {
  using State = world::WorldCore::Owner::State;
  std::vector<msg::ArmOwner> out(2);
  for (int j = 0; j < 2; ++j) {
    const auto o = core.owner(j);
    msg::ArmOwner& w = out[static_cast<size_t>(j)];
    w.arm(core.arm_name(j));
    w.state(o.state == State::Served     ? msg::ARM_SERVED
            : o.state == State::Stopping ? msg::ARM_STOPPING
            : o.state == State::Braked   ? msg::ARM_BRAKED
                                         : msg::ARM_BRAKED_LOAD);
    w.robot(o.robot);
    w.strength(o.strength);
    w.handover_ticks(o.state == State::Served ? static_cast<int32_t>(std::min<long>(o.handover_ticks, INT32_MAX)) : -1);
  }
  return out;
}

}  // namespace tandem::world_wire
