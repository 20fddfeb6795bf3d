// tandem-world: the simulated hardware of one basic module (both arms, object, contacts). Lockstep: it
// publishes the sensor sample of tick k and advances only when both arms' torque commands for tick k have
// arrived. Real time: it steps on absolute 1 kHz deadlines (clock_nanosleep), applies the commands of tick k
// that arrived before the deadline, and an arm without one keeps its previous torque (a late arm-tick).
// Invalid commands (NaN/inf, over the torque limit, unknown arm, future tick) are rejected, counted and never
// applied; commands for an earlier tick or taken after the deadline are dropped and counted as stale.
#include <tandemPubSubTypes.h>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>
#include <cstdio>
#include <thread>

#include "tandem/runtime/histogram.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;

int main(int argc, char** argv) {
  runtime::RoleOptions opt;
  runtime::RoleContext ctx;
  int code = 0;
  if (!runtime::start_role("world", argc, argv, false, opt, ctx, code)) return code;
  const sim::ModuleSetup& m = ctx.module;
  model::ModulePlant plant(m.plant);
  plant.reset(m.initial);

  bus::Participant part(opt.domain, "world/" + opt.module, opt.transport);
  bus::Writer<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors(part, bus::module_topic(bus::kSensorsTopic, opt.module), bus::TopicKind::Sensors);
  bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType> torques(part, bus::module_topic(bus::kTorquesTopic, opt.module),
                                                                         bus::TopicKind::Torques);
  bus::Writer<msg::WorldSummary, msg::WorldSummaryPubSubType> summary(part, bus::kWorldSummaryTopic,
                                                                       bus::TopicKind::Summary);

  runtime::StatusPublisher status(part, opt.module + "/world", "world", opt.module);
  status.msg().deployment(opt.deployment);
  status.set(runtime::Lifecycle::Inactive, "waiting for the supervisor and two robots");
  // Peers: two robots and the supervisor read the sensors; two robots write torques.
  const auto t0 = std::chrono::steady_clock::now();
  while (!runtime::g_stop && (sensors.matched() < 3 || torques.matched() < 2)) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-world: peers not found within %.1f s (sensor readers %d/3, torque writers %d/2)\n",
                   opt.timeout, sensors.matched(), torques.matched());
      status.set(runtime::Lifecycle::Error, "peers not found");
      return 3;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the reverse matches settle

  unsigned long long rejected = 0, timeouts = 0, late = 0;
  std::array<std::string, 2> owner;
  std::array<std::chrono::steady_clock::time_point, 2> last_applied{};
  unsigned long long failovers = 0;
  double failover_max_ms = 0.0, failover_last_ms = 0.0;
  unsigned long long stale = 0;
  runtime::Histogram latency_us, wake_late_us;  // fixed bins: no allocation per tick, any run length
  double interval_worst_us = 0.0;
  msg::ArmSensors s;
  msg::TorqueCommand cmd;
  std::array<model::Vec3, 2> tau{model::Vec3::Zero(), model::Vec3::Zero()};
  timespec tick_start{};
  ::clock_gettime(CLOCK_MONOTONIC, &tick_start);
  const long period_ns = std::lround(m.period * 1e9);
  auto to_ns = [](const timespec& ts) { return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec; };
  status.set(runtime::Lifecycle::Active, opt.realtime ? "real time" : "lockstep");
  double min_normal = 1e300;
  long k = 0;
  for (; k < m.steps && !runtime::g_stop; ++k) {
    const double t = static_cast<double>(k) * m.period;
    const model::ContactReading contact = plant.contacts();
    min_normal = std::min({min_normal, contact.normal[0], contact.normal[1]});
    if (k % 100 == 0) {  // live status, every 100 ticks
      auto& st = status.msg();
      st.tick(static_cast<uint64_t>(k));
      st.progress(opt.continuous ? -1.0 : static_cast<double>(k) / static_cast<double>(m.steps));
      st.grasp_margin(min_normal - m.safe_grasp_force);
      st.late(opt.realtime ? late : timeouts);
      st.latency_p99_us(interval_worst_us);  // the worst of the interval (at most 200 arm-ticks)
      interval_worst_us = 0.0;
      status.publish();
      min_normal = 1e300;
    }
    timespec sent{};
    ::clock_gettime(CLOCK_MONOTONIC, &sent);
    if (opt.realtime) wake_late_us.add(static_cast<double>(to_ns(sent) - to_ns(tick_start)) * 1e-3);
    auto publish_samples = [&] {
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
    };
    publish_samples();
    // Real time: the tick ends at an absolute deadline; lockstep: when both commands are in (or timeout).
    timespec deadline = tick_start;
    deadline.tv_nsec += period_ns;
    while (deadline.tv_nsec >= 1000000000L) {
      deadline.tv_nsec -= 1000000000L;
      ++deadline.tv_sec;
    }
    std::array<bool, 2> have{false, false};
    int republished = 0;
    const auto wait_start = std::chrono::steady_clock::now();
    while (!(have[0] && have[1]) && !runtime::g_stop) {
      if (!torques.take(cmd)) {
        if (opt.realtime) {
          timespec now{};
          ::clock_gettime(CLOCK_MONOTONIC, &now);
          const long long left = to_ns(deadline) - to_ns(now);
          if (left <= 0) break;
          torques.wait(static_cast<double>(left) * 1e-9);
        } else {
          const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - wait_start).count();
          if (waited > opt.timeout) break;
          // Lockstep: every 50 ms without the tick's commands, publish the tick's samples again, for a robot
          // that joined (or restarted) after they went out; the supervisor answers with the references again.
          if (waited > 0.05 * static_cast<double>(republished + 1)) {
            publish_samples();
            ++republished;
          }
          torques.wait(0.01);
        }
        continue;
      }
      if (opt.realtime) {
        timespec now{};
        ::clock_gettime(CLOCK_MONOTONIC, &now);
        if (to_ns(now) > to_ns(deadline)) {  // taken after the deadline: too late for this tick
          ++stale;
          break;
        }
      }
      const int j = ctx.arm_index(cmd.arm_id());
      if (j < 0 || !runtime::all_finite(cmd.tau())) {
        ++rejected;
        continue;
      }
      if (cmd.tick() != static_cast<uint64_t>(k)) {
        // An older tick is a late answer or a liveliness repeat: harmless, dropped. A future tick is invalid.
        if (cmd.tick() > static_cast<uint64_t>(k)) {
          ++rejected;
        } else {
          ++stale;
        }
        continue;
      }
      const model::Vec3 v(cmd.tau()[0], cmd.tau()[1], cmd.tau()[2]);
      if ((v.cwiseAbs().array() > m.plant.arms[j].tau_max.array()).any()) {
        ++rejected;
        continue;
      }
      tau[j] = v;
      have[j] = true;
      // Which robot the arm follows (EXCLUSIVE ownership picks the strongest live one): a change is a failover.
      const auto now_fo = std::chrono::steady_clock::now();
      // (In the first 50 ticks discovery order decides which of a primary and its shadow the reader hears
      // first; their commands are equal, and those switches are not failovers.)
      if (!owner[j].empty() && cmd.robot_id() != owner[j] && k >= 50) {
        const double gap_ms = std::chrono::duration<double, std::milli>(now_fo - last_applied[j]).count();
        ++failovers;
        failover_last_ms = gap_ms;
        failover_max_ms = std::max(failover_max_ms, gap_ms);
        std::printf("tandem-world %s: %s now follows %s (was %s), %.1f ms after the last command of the old one\n",
                    opt.module.c_str(), ctx.arm_id(j).c_str(), cmd.robot_id().c_str(), owner[j].c_str(), gap_ms);
        std::fflush(stdout);
      }
      owner[j] = cmd.robot_id();
      last_applied[j] = now_fo;
      if (opt.realtime) {
        timespec now{};
        ::clock_gettime(CLOCK_MONOTONIC, &now);
        const double us = static_cast<double>(to_ns(now) - to_ns(sent)) * 1e-3;
        latency_us.add(us);
        interval_worst_us = std::max(interval_worst_us, us);
      }
    }
    if (!(have[0] && have[1])) {
      if (runtime::g_stop) break;
      if (opt.realtime) {
        // A late or missing command: the arm keeps its previous torque for this tick (counted).
        late += (have[0] ? 0 : 1) + (have[1] ? 0 : 1);
      } else {
        ++timeouts;
        std::fprintf(stderr, "tandem-world: tick %ld: no valid torque from %s within %.1f s; stopping\n", k,
                     have[0] ? ctx.arm_id(1).c_str() : ctx.arm_id(0).c_str(), opt.timeout);
        break;
      }
    }
    if (opt.realtime) ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);
    plant.step(tau, t, m.period, m.substeps);
    if (opt.realtime) tick_start = deadline;
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
  ws.late_commands(opt.realtime ? late : timeouts);
  ws.rejected_commands(rejected);
  ws.realtime(opt.realtime);
  ws.latency_p50_us(latency_us.percentile(0.5));
  ws.latency_p99_us(latency_us.percentile(0.99));
  ws.latency_max_us(latency_us.percentile(1.0));
  ws.wake_late_p99_us(wake_late_us.percentile(0.99));
  ws.failovers(failovers);
  ws.failover_max_ms(failover_max_ms);
  ws.failover_last_ms(failover_last_ms);
  summary.write(ws);
  status.msg().tick(static_cast<uint64_t>(k));
  status.msg().progress(opt.continuous ? -1.0 : static_cast<double>(k) / static_cast<double>(m.steps));
  if (timeouts > 0) {
    status.set(runtime::Lifecycle::Error, "a robot did not answer a tick");
  } else {
    status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  }
  std::printf("tandem-world %s: %ld ticks, slip %ld, contact lost %ld, rejected %llu, stale %llu, %s %llu\n",
              opt.module.c_str(), k, plant.counters().slip_events, plant.counters().contact_lost, rejected, stale,
              opt.realtime ? "late arm-ticks" : "timeouts", opt.realtime ? late : timeouts);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the summary reach the launcher
  return timeouts > 0 ? 4 : 0;
}
