// tandem-world: the simulated hardware of one basic module (both arms, object, contacts), stepping in
// lockstep: it publishes the sensor sample of tick k and advances only when both arms' torque commands
// for tick k have arrived. Invalid commands (NaN/inf, over the torque limit, unknown arm, stale tick) are
// rejected, counted and never applied.
#include <tandemPubSubTypes.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "tandem/runtime/role.hpp"

using namespace tandem;
namespace bus = tandem::dds;

int main(int argc, char** argv) {
  runtime::RoleOptions opt;
  int code = 0;
  if (!runtime::parse_role_options("world", argc, argv, false, opt, code)) return code;
  runtime::install_stop_handlers();
  runtime::RoleContext ctx;
  try {
    ctx = runtime::load_context(opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem-world: %s\n", e.what());
    return 2;
  }
  const sim::ModuleSetup& m = ctx.module;
  model::ModulePlant plant(m.plant);
  plant.reset(m.initial);

  bus::Participant part(opt.domain, "world/" + opt.module, opt.transport);
  bus::Writer<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors(part, bus::kSensorsTopic, bus::TopicKind::Sensors);
  bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType> torques(part, bus::kTorquesTopic,
                                                                         bus::TopicKind::Torques);
  bus::Writer<msg::WorldSummary, msg::WorldSummaryPubSubType> summary(part, bus::kWorldSummaryTopic,
                                                                       bus::TopicKind::Summary);

  // Peers: two robots and the supervisor read the sensors; two robots write torques.
  const auto t0 = std::chrono::steady_clock::now();
  while (!runtime::g_stop && (sensors.matched() < 3 || torques.matched() < 2)) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-world: peers not found within %.1f s (sensor readers %d/3, torque writers %d/2)\n",
                   opt.timeout, sensors.matched(), torques.matched());
      return 3;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the reverse matches settle

  unsigned long long rejected = 0, timeouts = 0;
  msg::ArmSensors s;
  msg::TorqueCommand cmd;
  long k = 0;
  for (; k < m.steps && !runtime::g_stop; ++k) {
    const double t = static_cast<double>(k) * m.period;
    const model::ContactReading contact = plant.contacts();
    for (int j = 0; j < 2; ++j) {
      s.arm_id(ctx.arm_id(j));
      s.tick(static_cast<uint64_t>(k));
      s.t(t);
      for (int i = 0; i < 3; ++i) {
        s.q()[static_cast<size_t>(i)] = plant.state().q[j](i);
        s.qd()[static_cast<size_t>(i)] = plant.state().qd[j](i);
      }
      s.h()[0] = contact.h[j](0);
      s.h()[1] = contact.h[j](1);
      s.braked(false);
      sensors.write(s);
    }
    std::array<model::Vec3, 2> tau{model::Vec3::Zero(), model::Vec3::Zero()};
    std::array<bool, 2> have{false, false};
    const auto wait_start = std::chrono::steady_clock::now();
    while (!(have[0] && have[1]) && !runtime::g_stop) {
      if (!torques.take(cmd)) {
        if (std::chrono::duration<double>(std::chrono::steady_clock::now() - wait_start).count() > opt.timeout) break;
        torques.wait(0.05);
        continue;
      }
      const int j = ctx.arm_index(cmd.arm_id());
      if (j < 0 || cmd.tick() != static_cast<uint64_t>(k) || !runtime::all_finite(cmd.tau())) {
        ++rejected;
        continue;
      }
      const model::Vec3 v(cmd.tau()[0], cmd.tau()[1], cmd.tau()[2]);
      if ((v.cwiseAbs().array() > m.plant.arms[j].tau_max.array()).any()) {
        ++rejected;
        continue;
      }
      tau[j] = v;
      have[j] = true;
    }
    if (!(have[0] && have[1])) {
      if (runtime::g_stop) break;
      ++timeouts;
      std::fprintf(stderr, "tandem-world: tick %ld: no valid torque from %s within %.1f s; stopping\n", k,
                   have[0] ? ctx.arm_id(1).c_str() : ctx.arm_id(0).c_str(), opt.timeout);
      break;
    }
    plant.step(tau, t, m.period, m.substeps);
  }

  msg::WorldSummary ws;
  ws.module_id(opt.module);
  ws.ticks(static_cast<uint64_t>(k));
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 3; ++i) ws.q_final()[static_cast<size_t>(3 * j + i)] = plant.state().q[j](i);
  }
  ws.object_final()[0] = plant.state().c(0);
  ws.object_final()[1] = plant.state().c(1);
  ws.object_final()[2] = plant.state().psi;
  ws.slip_events(static_cast<uint64_t>(plant.counters().slip_events));
  ws.contact_lost(static_cast<uint64_t>(plant.counters().contact_lost));
  ws.late_commands(timeouts);
  ws.rejected_commands(rejected);
  summary.write(ws);
  std::printf("tandem-world %s: %ld ticks, slip %ld, contact lost %ld, rejected %llu, timeouts %llu\n",
              opt.module.c_str(), k, plant.counters().slip_events, plant.counters().contact_lost, rejected, timeouts);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the summary reach the launcher
  return timeouts > 0 ? 4 : 0;
}
