// tandem-world: the simulated hardware of one basic module, wiring only: world::WorldCore (services/world/
// include) holds the plant, the brakes, the owner of each arm, the checks on commands and the overload rule;
// this process adds the timing policy and DDS. Lockstep: it publishes the samples of tick k and advances only
// when both arms' torque commands for tick k have arrived (re-publishing every 50 ms for a robot that joined
// late). Real time: it steps on absolute 1 kHz deadlines (clock_nanosleep); the commands of tick k that
// arrived before the deadline are applied, and an arm without one keeps its previous torque (a late
// arm-tick). It reports to its supervisor every 10 ticks (tandem/world_report) and publishes its status.
#include <tandemPubSubTypes.h>

#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "tandem/runtime/histogram.hpp"
#include "tandem/runtime/plan_wire.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/world/world_core.hpp"

using namespace tandem;
namespace bus = tandem::dds;

int main(int argc, char** argv) {
  runtime::RoleOptions opt;
  runtime::RoleContext ctx;
  int code = 0;
  if (!runtime::start_role("world", argc, argv, false, opt, ctx, code)) return code;
  const sim::ModuleSetup& m = ctx.module;
  world::WorldOptions wo;
  wo.arm_ids = {ctx.arm_id(0), ctx.arm_id(1)};
  wo.arm_names = {ctx.scenario.robots[0].name, ctx.scenario.robots[1].name};
  wo.realtime = opt.realtime;
  wo.continuous = opt.continuous;
  wo.overload.enabled = opt.overload_brake;
  world::WorldCore core(m, wo);
  core.set_log([&](const std::string& line) {
    std::printf("tandem-world %s: %s\n", opt.module.c_str(), line.c_str());
    std::fflush(stdout);
  });

  bus::Participant part(opt.domain, "world/" + opt.module, opt.transport);
  // Per arm: each robot receives only its own arm's samples. Real time: best effort, newest only.
  const bus::TopicKind sensor_kind = opt.realtime ? bus::TopicKind::SensorsRealtime : bus::TopicKind::Sensors;
  bus::Writer<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors0(part, bus::arm_topic(bus::kSensorsTopic, ctx.arm_id(0)), sensor_kind);
  bus::Writer<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors1(part, bus::arm_topic(bus::kSensorsTopic, ctx.arm_id(1)), sensor_kind);
  std::array<bus::Writer<msg::ArmSensors, msg::ArmSensorsPubSubType>*, 2> sensors{&sensors0, &sensors1};
  // Torque commands are taken in the DDS thread that received them and queued with their arrival time; the
  // world's own thread is not woken for each (real time: it sleeps to the tick's deadline and then reads the
  // queue; lockstep: it is woken when a command comes, as it waits for them).
  struct Inbox : eprosima::fastdds::dds::DataReaderListener {
    struct Item {
      msg::TorqueCommand cmd;
      int arm = 0;
      long long at_ns = 0;
    };
    std::mutex mu;
    std::condition_variable cv;
    std::deque<Item> items;
    bool notify = false;  // lockstep: the world thread waits on cv
    std::array<eprosima::fastdds::dds::DataReader*, 2> readers{nullptr, nullptr};
    msg::TorqueCommand scratch;
    void on_data_available(eprosima::fastdds::dds::DataReader* r) override {
      eprosima::fastdds::dds::SampleInfo info;
      std::unique_lock<std::mutex> lock(mu);
      const int arm = r == readers[1] ? 1 : 0;
      while (r->take_next_sample(&scratch, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        timespec now{};
        ::clock_gettime(CLOCK_MONOTONIC, &now);
        items.push_back({scratch, arm, static_cast<long long>(now.tv_sec) * 1000000000LL + now.tv_nsec});
      }
      lock.unlock();
      if (notify) cv.notify_one();
    }
    bool pop(msg::TorqueCommand& out, int& arm, long long& at_ns) {
      std::lock_guard<std::mutex> lock(mu);
      if (items.empty()) return false;
      out = items.front().cmd;
      arm = items.front().arm;
      at_ns = items.front().at_ns;
      items.pop_front();
      return true;
    }
    void wait(double seconds) {
      std::unique_lock<std::mutex> lock(mu);
      cv.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return !items.empty(); });
    }
  } inbox;
  inbox.notify = !opt.realtime;
  const bus::TopicKind torque_kind = opt.realtime ? bus::TopicKind::TorquesRealtime : bus::TopicKind::Torques;
  // A torque topic per arm (EXCLUSIVE ownership: the strongest live robot of the arm is heard).
  bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType> torques0(part, bus::arm_topic(bus::kTorquesTopic, ctx.arm_id(0)),
                                                                          torque_kind, &inbox);
  bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType> torques1(part, bus::arm_topic(bus::kTorquesTopic, ctx.arm_id(1)),
                                                                          torque_kind, &inbox);
  {
    std::lock_guard<std::mutex> lock(inbox.mu);
    inbox.readers = {torques0.get(), torques1.get()};
  }

  // The robot that wrote a command is named by the core from its strength.
  bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plans(part, bus::module_topic(bus::kSupervisorPlanTopic, opt.module),
                                                                        bus::TopicKind::Task);
  bus::Writer<msg::WorldReport, msg::WorldReportPubSubType> report(part, bus::module_topic(bus::kWorldReportTopic, opt.module),
                                                                   bus::TopicKind::Task);
  bus::Writer<msg::WorldSummary, msg::WorldSummaryPubSubType> summary(part, bus::kWorldSummaryTopic,
                                                                       bus::TopicKind::Summary);

  runtime::StatusPublisher status(part, opt.module + "/world", "world", opt.module);
  status.msg().deployment(opt.deployment);
  status.set(runtime::Lifecycle::Inactive, "waiting for the supervisor and two robots");
  // Peers: a robot per arm reads its sensors and writes torques; the supervisor reads the report.
  const auto t0 = std::chrono::steady_clock::now();
  while (!runtime::g_stop && (sensors0.matched() < 1 || sensors1.matched() < 1 || torques0.matched() < 1 || torques1.matched() < 1 ||
                              report.matched() < 1)) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-world: peers not found within %.1f s (sensor readers %d+%d/2, torque writers %d/2, "
                   "supervisor %d/1)\n", opt.timeout, sensors0.matched(), sensors1.matched(),
                   torques0.matched() + torques1.matched(), report.matched());
      status.set(runtime::Lifecycle::Error, "peers not found");
      return 3;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the reverse matches settle

  unsigned long long overruns = 0;
  runtime::Histogram latency_us, wake_late_us;  // fixed bins: no allocation per tick, any run length
  double interval_worst_us = 0.0;
  msg::SupervisorPlan plan_in;
  msg::WorldReport rep;
  rep.module_id(opt.module);
  msg::ArmSensors s;
  msg::TorqueCommand cmd;
  std::array<world::SampleOut, 2> samples{};
  timespec tick_start{};
  ::clock_gettime(CLOCK_MONOTONIC, &tick_start);
  const long period_ns = std::lround(m.period * 1e9);
  auto to_ns = [](const timespec& ts) { return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec; };
  auto now_ns = [&] {
    timespec n{};
    ::clock_gettime(CLOCK_MONOTONIC, &n);
    return to_ns(n);
  };
  auto publish_status_if_changed = [&] {
    if (!core.serving_changed()) return;
    status.msg().serving(core.serving_text());
    status.msg().detail(core.paused_for_load() ? "paused for load (overload: commands late)"
                        : core.braked(0) || core.braked(1) ? "arm braked: no live controller" : "");
    status.publish();
  };
  status.msg().serving(core.serving_text());
  status.set(runtime::Lifecycle::Active, opt.realtime ? "real time" : "lockstep");
  long k = 0;
  bool stopped_early = false;
  for (; k < m.steps && !runtime::g_stop; ++k) {
    while (plans.take(plan_in)) {
      if (plan_in.module_id() == opt.module) core.offer_plan(runtime::from_wire(plan_in));
    }
    const long long sent = now_ns();
    core.begin_tick(k, sent, samples);
    publish_status_if_changed();
    if (k % 100 == 0) {  // live status, every 100 ticks
      auto& st = status.msg();
      st.tick(static_cast<uint64_t>(k));
      st.progress(opt.continuous ? -1.0 : static_cast<double>(k) / static_cast<double>(m.steps));
      st.grasp_margin(core.normal_min_since_status() - m.safe_grasp_force);
      st.late(opt.realtime ? core.late : core.timeouts);
      st.tracking_error(core.tracking_error());
      st.latency_p99_us(interval_worst_us);  // the worst of the interval (at most 200 arm-ticks)
      interval_worst_us = 0.0;
      status.publish();
    }
    if (k == 0) {  // for start-up measurements (bench/scale.sh)
      timespec wall{};
      ::clock_gettime(CLOCK_REALTIME, &wall);
      std::printf("tandem-world %s: first tick at wall %.3f\n", opt.module.c_str(),
                  static_cast<double>(wall.tv_sec) + static_cast<double>(wall.tv_nsec) * 1e-9);
      std::fflush(stdout);
    }
    if (opt.realtime) {
      const long long wake_late_ns = sent - to_ns(tick_start);
      wake_late_us.add(static_cast<double>(wake_late_ns) * 1e-3);
      // The world is the simulated plant: when its own process stalls (a scheduler hiccup of 5-20 ms is
      // common on a shared 2-core machine), catching up in a burst of ticks would give the robots no time to
      // answer any of them, and the arms would hold stale torques for the whole burst, a failure of the
      // simulator that a real plant never has. So a tick that starts more than half a period late re-anchors
      // the clock at now: the robots always get at least half a period, and simulated time slips (counted).
      if (wake_late_ns > period_ns / 2) {
        tick_start.tv_sec = static_cast<time_t>(sent / 1000000000LL);
        tick_start.tv_nsec = static_cast<long>(sent % 1000000000LL);
        ++overruns;
      }
    }
    auto publish_samples = [&](bool all) {
      for (size_t j = 0; j < 2; ++j) {
        const world::SampleOut& o = samples[j];
        if (!o.publish && !all) continue;
        s.tick(static_cast<uint64_t>(k));
        s.t(o.t);
        for (size_t i = 0; i < 3; ++i) {
          s.q()[i] = o.q(static_cast<int>(i));
          s.qd()[i] = o.qd(static_cast<int>(i));
        }
        s.h()[0] = o.h(0);
        s.h()[1] = o.h(1);
        s.braked(o.braked);
        sensors[j]->write(s);
      }
    };
    publish_samples(false);
    if (core.report_due(m.steps)) {
      const world::ReportOut r = core.take_report();
      rep.tick(static_cast<uint64_t>(r.tick));
      rep.braked()[0] = r.braked[0];
      rep.braked()[1] = r.braked[1];
      rep.hold(r.hold);
      rep.braked_since(r.braked_since);
      rep.released_at(r.released_at);
      rep.normal_min(r.normal_min);
      for (int i = 0; i < 3; ++i) rep.object()[static_cast<size_t>(i)] = r.object(i);
      report.write(rep);
    }
    // Real time: the tick ends at an absolute deadline; lockstep: when every arm that is not braked has its
    // command in (a braked arm's robot may answer too: that releases it).
    timespec deadline = tick_start;
    deadline.tv_nsec += period_ns;
    while (deadline.tv_nsec >= 1000000000L) {
      deadline.tv_nsec -= 1000000000L;
      ++deadline.tv_sec;
    }
    const long long deadline_ns = to_ns(deadline);
    int republished = 0;
    const auto wait_start = std::chrono::steady_clock::now();
    long long cmd_at_ns = 0;
    int cmd_arm = 0;
    bool gave_up = false;
    while (!runtime::g_stop) {
      if (!opt.realtime && core.lockstep_done()) break;
      if (!inbox.pop(cmd, cmd_arm, cmd_at_ns)) {
        if (opt.realtime) {
          if (now_ns() >= deadline_ns) break;
          ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);  // the commands queue meanwhile
        } else {
          const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - wait_start).count();
          if (!core.lockstep_waited(waited, opt.timeout, now_ns())) {
            gave_up = true;
            break;
          }
          publish_status_if_changed();
          // Lockstep: every 50 ms without the tick's commands, publish the tick's samples again, for a robot
          // that joined (or restarted) after they went out.
          if (waited > 0.05 * static_cast<double>(republished + 1)) {
            publish_samples(true);
            ++republished;
          }
          inbox.wait(0.01);
        }
        continue;
      }
      const bool late_arrival = opt.realtime && cmd_at_ns > deadline_ns;
      const model::Vec3 tau(cmd.tau()[0], cmd.tau()[1], cmd.tau()[2]);
      if (core.on_command(cmd_arm, static_cast<long>(cmd.tick()), tau, cmd.strength(), cmd_at_ns, late_arrival,
                          cmd.leaving()) == world::WorldCore::Verdict::Applied &&
          opt.realtime) {
        const double us = static_cast<double>(cmd_at_ns - sent) * 1e-3;
        latency_us.add(us);
        interval_worst_us = std::max(interval_worst_us, us);
      }
      if (late_arrival) break;  // the rest are for the next tick's pass (as stale)
    }
    if (runtime::g_stop) break;
    if (!core.end_tick(now_ns()) || gave_up) {
      for (int j = 0; j < 2; ++j) {
        if (!core.have(j)) {
          std::fprintf(stderr, "tandem-world: tick %ld: no valid torque from %s within %.1f s; stopping\n", k,
                       ctx.arm_id(j).c_str(), opt.timeout);
        }
      }
      stopped_early = true;
      break;
    }
    publish_status_if_changed();
    if (opt.realtime) {
      ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);
    } else if (core.braked(0) && core.braked(1)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));  // nothing to wait for: hold at about 1 kHz
    }
    core.step();
    if (opt.realtime) tick_start = deadline;
  }
  (void)stopped_early;

  const model::ModulePlant& plant = core.plant();
  msg::WorldSummary ws;
  ws.module_id(opt.module);
  ws.braked_ticks(core.braked_ticks);
  ws.overruns(overruns);
  ws.ticks(static_cast<uint64_t>(k));
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 3; ++i) ws.q_final()[static_cast<size_t>(3 * j + i)] = plant.state().q[j](i);
  }
  ws.object_final()[0] = plant.state().c(0);
  ws.object_final()[1] = plant.state().c(1);
  ws.object_final()[2] = plant.state().psi;
  ws.slip_events(static_cast<uint64_t>(plant.counters().slip_events));
  ws.contact_lost(static_cast<uint64_t>(plant.counters().contact_lost));
  ws.late_commands(opt.realtime ? core.late : core.timeouts);
  ws.rejected_commands(core.rejected);
  ws.realtime(opt.realtime);
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
  summary.write(ws);
  status.msg().tick(static_cast<uint64_t>(k));
  status.msg().progress(opt.continuous ? -1.0 : static_cast<double>(k) / static_cast<double>(m.steps));
  const bool never_answered = !core.answered_once();
  if (never_answered && !runtime::g_stop) {
    status.set(runtime::Lifecycle::Error, "a robot did not answer a tick");
  } else {
    status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  }
  std::printf("tandem-world %s: %ld ticks, slip %ld, contact lost %ld, rejected %llu, stale %llu, %s %llu, "
              "overruns %llu, pauses for load %llu\n",
              opt.module.c_str(), k, plant.counters().slip_events, plant.counters().contact_lost, core.rejected,
              core.stale, opt.realtime ? "late arm-ticks" : "brakings", opt.realtime ? core.late : core.timeouts,
              overruns, core.load_pauses);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the summary reach the launcher
  return never_answered && !runtime::g_stop ? 4 : 0;
}
