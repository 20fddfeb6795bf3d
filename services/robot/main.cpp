// tandem-robot: the controller of one arm (VLLC + LLC, docs/controller.md). For every tick it waits for its
// arm's sensor sample and the supervisor's reference of the same tick, and answers with a torque command.
// References with NaN/inf are rejected and counted; the previous valid reference is kept.
#include <tandemPubSubTypes.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <optional>
#include <thread>
#include <unistd.h>

#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;

int main(int argc, char** argv) {
  runtime::RoleOptions opt;
  runtime::RoleContext ctx;
  int code = 0;
  if (!runtime::start_role("robot", argc, argv, true, opt, ctx, code)) return code;
  int j = -1;
  for (int i = 0; i < 2; ++i) {
    if (ctx.scenario.robots[i].name == opt.arm) j = i;
  }
  if (j < 0) {
    std::fprintf(stderr, "tandem-robot: unknown arm '%s'; robots of %s: %s, %s\n", opt.arm.c_str(),
                 opt.scenario.c_str(), ctx.scenario.robots[0].name.c_str(), ctx.scenario.robots[1].name.c_str());
    return 2;
  }
  const sim::ModuleSetup& m = ctx.module;
  const std::string my_arm = ctx.arm_id(j);
  // Process id: the arm for the primary, "<arm>@<strength>" for a standby (one per strength).
  const std::string robot_id =
      opt.strength == runtime::RoleOptions::kPrimaryStrength ? my_arm : my_arm + "@" + std::to_string(opt.strength);
  model::HybridController ctl(m.plant.arms[j], m.control[j]);
  sim::RobotMeter meter(m.control[j].selection_p, ctx.scenario.transient, m.path.motion_end());

  bus::Participant part(opt.domain, "robot/" + my_arm, opt.transport);
  bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors(part, bus::module_topic(bus::kSensorsTopic, opt.module), bus::TopicKind::Sensors);
  bus::Reader<msg::ArmReference, msg::ArmReferencePubSubType> refs(part, bus::module_topic(bus::kReferencesTopic, opt.module),
                                                                   bus::TopicKind::References);
  // The torque writer goes first when the robot stops (std::optional::reset below): deleting it tells the
  // world at once, so a standby takes over within a tick instead of after the liveliness lease.
  std::optional<bus::Writer<msg::TorqueCommand, msg::TorqueCommandPubSubType>> torque_writer;
  torque_writer.emplace(part, bus::module_topic(bus::kTorquesTopic, opt.module), bus::TopicKind::Torques, opt.strength);
  auto& torques = *torque_writer;
  bus::Writer<msg::RobotSummary, msg::RobotSummaryPubSubType> summary(part, bus::kRobotSummaryTopic,
                                                                       bus::TopicKind::Summary);

  runtime::StatusPublisher status(part, robot_id, "robot", opt.module);
  status.msg().deployment(opt.deployment);
  status.msg().serving(std::to_string(opt.strength));
  status.set(runtime::Lifecycle::Inactive, "waiting for the first tick");
  msg::ArmSensors s;
  msg::ArmReference r;
  msg::TorqueCommand cmd;
  cmd.arm_id(my_arm);
  cmd.robot_id(robot_id);
  cmd.strength(opt.strength);
  long have_sensor = -1, have_ref = -1, done = -1;
  model::ArmSensors in;
  model::ArmReference ref;
  struct Slot {
    long tick = -1;
    runtime::SupervisorRank rank;  // of the supervisor that sent it
    model::ArmReference ref;
  };
  std::array<Slot, 64> ring{};
  struct SensorSlot {
    long tick = -1;
    model::ArmSensors in;
    bool braked = false;
  };
  std::array<SensorSlot, 64> sring{};
  model::Vec3 prev_q = model::Vec3::Zero();
  double wear = 0.0, workload = 0.0, interval_worst_us = 0.0;
  unsigned long long rejected = 0;
  auto last_input = std::chrono::steady_clock::now();
  auto last_assert = last_input;
  while (!runtime::g_stop && done + 1 < m.steps) {
    bool got = false;
    while (sensors.take(s)) {
      got = true;
      if (s.arm_id() != my_arm) continue;  // another arm's sample
      if (!runtime::all_finite(s.q()) || !runtime::all_finite(s.qd()) || !runtime::all_finite(s.h())) {
        ++rejected;
        continue;
      }
      // Samples are queued by tick and processed in order, so that a standby running in shadow computes
      // exactly what the primary computes (same inputs, same controller state).
      SensorSlot& slot = sring[s.tick() % sring.size()];
      for (int i = 0; i < 3; ++i) {
        slot.in.q(i) = s.q()[static_cast<size_t>(i)];
        slot.in.qd(i) = s.qd()[static_cast<size_t>(i)];
      }
      slot.in.h = model::Vec2(s.h()[0], s.h()[1]);
      slot.braked = s.braked();
      slot.tick = static_cast<long>(s.tick());
      have_sensor = std::max(have_sensor, slot.tick);
    }
    while (refs.take(r)) {
      got = true;
      if (r.arm_id() != my_arm) continue;
      if (!runtime::all_finite(r.x()) || !runtime::all_finite(r.xd()) || !runtime::all_finite(r.xdd()) ||
          !(r.force() >= 0.0 && r.force() < 1e6) || !runtime::valid_rank(r.strength(), r.epoch())) {
        ++rejected;
        continue;
      }
      // References arrive up to a tick ahead, and a standby may lag: keep a ring indexed by tick. With
      // standby supervisors every tick comes more than once: the copy of the highest-ranked supervisor
      // (epoch, then strength) stands. The copies are equal while the standbys follow the leader's plan; a
      // lower one is there if the leader died, and a stalled former leader's stale copy ranks below the
      // epoch of the one that took over from it.
      Slot& slot = ring[r.tick() % ring.size()];
      const runtime::SupervisorRank rank{r.epoch(), static_cast<int32_t>(r.strength())};
      if (!runtime::replaces(static_cast<long>(r.tick()), rank, slot.tick, slot.rank)) {
        continue;  // a late copy of a tick 64 back, or a lower-ranked copy of this tick
      }
      slot.rank = rank;
      for (int i = 0; i < 3; ++i) {
        slot.ref.x(i) = r.x()[static_cast<size_t>(i)];
        slot.ref.xd(i) = r.xd()[static_cast<size_t>(i)];
        slot.ref.xdd(i) = r.xdd()[static_cast<size_t>(i)];
      }
      slot.ref.force = r.force();
      slot.tick = static_cast<long>(r.tick());
    }
    // The next tick to compute; a robot more than a ring behind (real time) skips to the newest sample.
    long next = done + 1;
    if (have_sensor - next >= static_cast<long>(sring.size())) next = have_sensor;
    // A robot that joined late may lack the input of a tick for good: samples and references come in tick
    // order over reliable topics, so if the newest sample's tick is complete (sample and reference) while
    // `next` is not, `next`'s will never come (it went out before this robot matched): go to the newest.
    // (A robot that has been there from the start always has every tick, so a shadow stays exact.)
    if (have_sensor > next && sring[static_cast<size_t>(have_sensor) % sring.size()].tick == have_sensor &&
        ring[static_cast<size_t>(have_sensor) % ring.size()].tick == have_sensor &&
        (sring[static_cast<size_t>(std::max(next, 0L)) % sring.size()].tick != next ||
         ring[static_cast<size_t>(std::max(next, 0L)) % ring.size()].tick != next)) {
      next = have_sensor;
    }
    const SensorSlot& due_in = sring[static_cast<size_t>(std::max(next, 0L)) % sring.size()];
    const Slot& due = ring[static_cast<size_t>(std::max(next, 0L)) % ring.size()];
    const bool sensor_ready = due_in.tick == next;
    have_ref = due.tick == next ? next : -1;
    if (sensor_ready && have_ref == next) {
      const long k = next;
      in = due_in.in;
      ref = due.ref;
      const auto compute_start = std::chrono::steady_clock::now();
      // While the brakes hold the arm, the law's memory (super-twisting integral, force history) must not
      // wind up on an error the arm cannot act on: it starts afresh every braked tick, so that the first
      // tick after the release is a clean start.
      if (due_in.braked) ctl.reset();
      model::ControlOutput out = ctl.step(in, ref);
      // Actuator limits: the command is saturated here as the drive would (the plant clips the same way).
      const model::Vec3& lim = m.plant.arms[j].tau_max;
      out.tau = out.tau.cwiseMax(-lim).cwiseMin(lim);
      meter.add(static_cast<double>(k) * m.period, ref, out);
      cmd.tick(static_cast<uint64_t>(k));
      for (int i = 0; i < 3; ++i) cmd.tau()[static_cast<size_t>(i)] = out.tau(i);
      torques.write(cmd);
      interval_worst_us = std::max(
          interval_worst_us,
          std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - compute_start).count());
      // Wear and workload, for the coordinator's balancing: joint travel and mechanical work so far.
      if (done >= 0) {
        const model::Vec3 dq = (in.q - prev_q).cwiseAbs();
        wear += dq.sum();
        workload += out.tau.cwiseAbs().dot(dq);
      }
      prev_q = in.q;
      if (done < 0) status.set(runtime::Lifecycle::Active, "controlling");
      if (k % 100 == 0) {
        status.msg().tick(static_cast<uint64_t>(k));
        status.msg().tracking_error(out.e_p.head<2>().norm());
        status.msg().late(rejected);
        status.msg().wear(wear);
        status.msg().workload(workload);
        status.msg().latency_p99_us(interval_worst_us);  // worst control step + write of the interval
        interval_worst_us = 0.0;
        status.publish();
      }
      done = k;
      last_input = std::chrono::steady_clock::now();
      continue;
    }
    const auto now = std::chrono::steady_clock::now();
    if (got) last_input = now;
    // Liveliness (MANUAL_BY_TOPIC): assert while waiting, so that a live robot is never taken for dead. While
    // the world waits for this tick, repeat the last command: after a failover the new owner's earlier
    // sample was filtered out by the world's reader, and this repeat is what reaches it.
    if (now - last_assert > std::chrono::milliseconds(bus::kLivelinessAssertMs)) {
      torques.assert_liveliness();
      if (done >= 0 && now - last_input > std::chrono::milliseconds(2 * bus::kLivelinessAssertMs)) torques.write(cmd);
      last_assert = now;
    }
    if (std::chrono::duration<double>(now - last_input).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-robot %s: no input for %.1f s after tick %ld; stopping\n", my_arm.c_str(),
                   opt.timeout, done);
      break;
    }
    // The reference of a tick follows its sensor sample (the supervisor answers the sample): wait on the
    // reader whose sample is due next.
    const double wait_s = bus::kLivelinessAssertMs * 1e-3;
    if (sensor_ready && have_ref != next) {
      refs.wait(wait_s);
    } else {
      sensors.wait(wait_s);
    }
  }
  torques.unregister(cmd);     // give the arm up: the world follows the next strongest robot at once
  torques.wait_for_acks(0.1);  // the last command and the unregistration reach the world
  torque_writer.reset();       // then leave the arm at once (graceful hand-over), then report
  const sim::RobotMeter::Summary sm = meter.summary();
  msg::RobotSummary rs;
  rs.arm_id(my_arm);
  rs.robot_id(robot_id);
  rs.ticks(static_cast<uint64_t>(done + 1));
  rs.ep_pos_rms(sm.ep_pos_rms);
  rs.ep_ori_rms(sm.ep_ori_rms);
  rs.ep_sel_rms(sm.ep_sel_rms);
  rs.eh_rms(sm.eh_rms);
  rs.min_normal_force(sm.min_normal_force);
  rs.max_normal_force(sm.max_normal_force);
  rs.rejected(rejected);
  summary.write(rs);
  status.msg().tick(static_cast<uint64_t>(std::max(done, 0L)));
  status.msg().wear(wear);
  status.msg().workload(workload);
  if (done + 1 == m.steps) {
    status.set(runtime::Lifecycle::Finalized, "task done");
  } else {
    status.set(runtime::g_stop ? runtime::Lifecycle::Finalized : runtime::Lifecycle::Error,
               runtime::g_stop ? "stopped" : "no input");
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  return (done + 1 == m.steps || runtime::g_stop) ? 0 : 4;
}
