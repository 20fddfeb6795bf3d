// tandem-world: the simulated hardware of one basic module (both arms, object, contacts). Lockstep: it
// publishes the sensor sample of tick k and advances only when both arms' torque commands for tick k have
// arrived. Real time: it steps on absolute 1 kHz deadlines (clock_nanosleep), applies the commands of tick k
// that arrived before the deadline, and an arm without one keeps its previous torque (a late arm-tick).
// Invalid commands (NaN/inf, over the torque limit, unknown arm, future tick) are rejected, counted and never
// applied; commands for an earlier tick or taken after the deadline are dropped and counted as stale.
// Brakes: an arm whose controller falls silent (100 ms in real time, 1 s of waiting in lockstep) is locked
// where it is (ModulePlant::set_brake) and its samples say braked, so the supervisor pauses the module; the
// first valid command of a robot for that arm releases it. Every change of the robot an arm follows is
// logged with its gap, and whether it was a failover (to a weaker robot) or a takeover (a stronger one).
#include <tandemPubSubTypes.h>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <cmath>
#include <vector>
#include <cstdio>
#include <string>
#include <thread>

#include "tandem/runtime/histogram.hpp"
#include "tandem/runtime/plan_wire.hpp"
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
  // The robot that wrote a command, from its strength (100: the primary).
  auto robot_name = [&](int j, int32_t strength) {
    return strength == runtime::RoleOptions::kPrimaryStrength ? ctx.arm_id(j) : ctx.arm_id(j) + "@" + std::to_string(strength);
  };
  // The module's plan, to measure each arm's tracking error |x_d - x| as the world sees it (the same
  // evaluation of eq. 15 as the robots'), and the report its supervisor plans from.
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

  unsigned long long rejected = 0, timeouts = 0, late = 0, stale = 0, braked_ticks = 0, overruns = 0;
  // Which robot each arm follows (EXCLUSIVE ownership: the strongest live writer) and when it last applied one.
  struct ArmLink {
    std::string owner;
    int32_t strength = 0;
    long last_tick = -1;                            // tick of the last applied command
    std::chrono::steady_clock::time_point last_at{};  // when it was applied
    bool braked = false;
    bool release = false;  // lockstep: a robot answered while braked: wait for it again from the next tick
    std::chrono::steady_clock::time_point heard{};  // last valid command of any tick: a controller is alive
  };
  std::array<ArmLink, 2> link{};
  unsigned long long failovers = 0;
  double failover_max_ms = 0.0, failover_last_ms = 0.0;
  runtime::Histogram latency_us, wake_late_us;  // fixed bins: no allocation per tick, any run length
  double interval_worst_us = 0.0;
  // The last 256 ticks' tracking error per arm and lowest normal force, and the open windows after a switch
  // of owner (failover or takeover): each gathers its worst |e_p| and lowest normal force for 300 ticks.
  constexpr size_t kHistory = 256;
  constexpr long kWindowTicks = 300;
  struct TickRecord {
    std::array<double, 2> ep{0.0, 0.0};
    double hn_min = 0.0;
  };
  std::array<TickRecord, kHistory> history{};
  struct Window {
    int arm;
    long end;
    size_t index;
  };
  std::vector<Window> windows;
  msg::WorldSummary ws;
  plan::PlanFollower follower(m, opt.continuous);
  msg::SupervisorPlan plan_in;
  std::array<double, 2> ep{0.0, 0.0};
  // The report the supervisor plans from: every kReportEvery ticks, and at once when a brake changes.
  constexpr long kReportEvery = 10;
  msg::WorldReport rep;
  rep.module_id(opt.module);
  long braked_since = -1, released_at = -1;
  double report_normal_min = 1e300;
  bool report_now = true;
  msg::ArmSensors s;
  msg::TorqueCommand cmd;
  std::array<model::Vec3, 2> tau{model::Vec3::Zero(), model::Vec3::Zero()};
  timespec tick_start{};
  ::clock_gettime(CLOCK_MONOTONIC, &tick_start);
  const long period_ns = std::lround(m.period * 1e9);
  auto to_ns = [](const timespec& ts) { return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec; };
  // An arm whose controller has gone quiet for this long is braked (real time: wall time without a command
  // while the world ticks on; lockstep: wall time the tick waited). Longer than a standby's failover (the
  // 20 ms liveliness lease plus a few ticks), so a failover never brakes.
  const double brake_after_s = opt.realtime ? 0.1 : 1.0;
  auto serving_text = [&] {
    std::string out;
    for (int j = 0; j < 2; ++j) {
      out += (j ? "," : "") + ctx.scenario.robots[j].name + "=" + (link[j].braked ? "braked" : link[j].owner);
    }
    return out;
  };
  long k = 0;
  auto set_brake = [&](int j, bool on, const std::string& why) {
    const bool was_braked = link[0].braked || link[1].braked;
    link[j].braked = on;
    plant.set_brake(j, on);
    const bool now_braked = link[0].braked || link[1].braked;
    if (now_braked && !was_braked) braked_since = k;
    if (!now_braked && was_braked) {
      braked_since = -1;
      released_at = k;
    }
    report_now = true;
    std::printf("tandem-world %s: %s %s (%s)\n", opt.module.c_str(), ctx.arm_id(j).c_str(),
                on ? "braked" : "released", why.c_str());
    std::fflush(stdout);
    status.msg().serving(serving_text());
    status.msg().detail(link[0].braked || link[1].braked ? "arm braked: no live controller" : "");
    status.publish();
  };
  status.msg().serving(serving_text());
  status.set(runtime::Lifecycle::Active, opt.realtime ? "real time" : "lockstep");
  double min_normal = 1e300;
  for (; k < m.steps && !runtime::g_stop; ++k) {
    const double t = static_cast<double>(k) * m.period;
    const model::ContactReading contact = plant.contacts();
    min_normal = std::min({min_normal, contact.normal[0], contact.normal[1]});
    for (int j = 0; j < 2; ++j) {
      if (link[j].release) {
        link[j].release = false;
        set_brake(j, false, "a robot answers again");
      }
    }
    // Tracking error as the world sees it (from the plan the robots follow), and the windows after owner switches.
    while (plans.take(plan_in)) {
      if (plan_in.module_id() == opt.module) follower.offer(runtime::from_wire(plan_in));
    }
    report_normal_min = std::min({report_normal_min, contact.normal[0], contact.normal[1]});
    TickRecord& rec = history[static_cast<size_t>(k) % kHistory];
    for (int j = 0; j < 2; ++j) {
      if (follower.has_plan()) ep[j] = (follower.reference(j, k).x.head<2>() - plant.end_effector(j).head<2>()).norm();
      rec.ep[static_cast<size_t>(j)] = ep[j];
    }
    rec.hn_min = std::min(contact.normal[0], contact.normal[1]);
    for (auto it = windows.begin(); it != windows.end();) {
      ws.switch_ep_max()[it->index] = std::max(ws.switch_ep_max()[it->index], ep[it->arm]);
      ws.switch_hn_min()[it->index] = std::min(ws.switch_hn_min()[it->index], rec.hn_min);
      it = k >= it->end ? windows.erase(it) : it + 1;
    }
    if (k % 100 == 0) {  // live status, every 100 ticks
      auto& st = status.msg();
      st.tick(static_cast<uint64_t>(k));
      st.progress(opt.continuous ? -1.0 : static_cast<double>(k) / static_cast<double>(m.steps));
      st.grasp_margin(min_normal - m.safe_grasp_force);
      st.late(opt.realtime ? late : timeouts);
      st.tracking_error(std::max(ep[0], ep[1]));
      st.latency_p99_us(interval_worst_us);  // the worst of the interval (at most 200 arm-ticks)
      interval_worst_us = 0.0;
      status.publish();
      min_normal = 1e300;
    }
    timespec sent{};
    ::clock_gettime(CLOCK_MONOTONIC, &sent);
    if (k == 0) {  // for start-up measurements (bench/scale.sh)
      timespec wall{};
      ::clock_gettime(CLOCK_REALTIME, &wall);
      std::printf("tandem-world %s: first tick at wall %.3f\n", opt.module.c_str(),
                  static_cast<double>(wall.tv_sec) + static_cast<double>(wall.tv_nsec) * 1e-9);
      std::fflush(stdout);
    }
    if (opt.realtime) {
      const long long wake_late_ns = to_ns(sent) - to_ns(tick_start);
      wake_late_us.add(static_cast<double>(wake_late_ns) * 1e-3);
      // The world is the simulated plant: when its own process stalls (a scheduler hiccup of 5-20 ms is
      // common on a shared 2-core machine), catching up in a burst of ticks would give the robots no time to
      // answer any of them, and the arms would hold stale torques for the whole burst, a failure of the
      // simulator that a real plant never has. So a tick that starts more than half a period late re-anchors
      // the clock at now: the robots always get at least half a period, and simulated time slips (counted).
      if (wake_late_ns > period_ns / 2) {
        tick_start = sent;
        ++overruns;
      }
    }
    auto publish_samples = [&] {
      for (int j = 0; j < 2; ++j) {
        s.tick(static_cast<uint64_t>(k));
        s.t(t);
        for (int i = 0; i < 3; ++i) {
          s.q()[static_cast<size_t>(i)] = plant.state().q[j](i);
          s.qd()[static_cast<size_t>(i)] = plant.state().qd[j](i);
        }
        s.h()[0] = contact.h[j](0);
        s.h()[1] = contact.h[j](1);
        s.braked(link[j].braked);
        sensors[static_cast<size_t>(j)]->write(s);
      }
    };
    publish_samples();
    if (report_now || k % kReportEvery == 0 || k + 1 == m.steps) {
      rep.tick(static_cast<uint64_t>(k));
      rep.braked()[0] = link[0].braked;
      rep.braked()[1] = link[1].braked;
      rep.braked_since(braked_since);
      rep.released_at(released_at);
      rep.normal_min(report_normal_min);
      report.write(rep);
      report_normal_min = 1e300;
      report_now = false;
    }
    // Real time: the tick ends at an absolute deadline; lockstep: when every arm that is not braked has its
    // command in (a braked arm's robot may answer too: that releases it).
    timespec deadline = tick_start;
    deadline.tv_nsec += period_ns;
    while (deadline.tv_nsec >= 1000000000L) {
      deadline.tv_nsec -= 1000000000L;
      ++deadline.tv_sec;
    }
    std::array<bool, 2> have{false, false};
    auto done_waiting = [&] {
      return (have[0] || (link[0].braked && !opt.realtime)) && (have[1] || (link[1].braked && !opt.realtime));
    };
    int republished = 0;
    const auto wait_start = std::chrono::steady_clock::now();
    long long cmd_at_ns = 0;
    int cmd_arm = 0;
    while (!done_waiting() && !runtime::g_stop) {
      if (!inbox.pop(cmd, cmd_arm, cmd_at_ns)) {
        if (opt.realtime) {
          timespec now{};
          ::clock_gettime(CLOCK_MONOTONIC, &now);
          if (to_ns(now) >= to_ns(deadline)) break;
          ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);  // the commands queue meanwhile
        } else {
          const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - wait_start).count();
          bool gave_up = false;
          for (int j = 0; j < 2; ++j) {
            if (have[j] || link[j].braked) continue;
            if (link[j].last_tick >= 0 && waited > brake_after_s) {
              set_brake(j, true, "no command for " + std::to_string(std::lround(waited * 1e3)) + " ms");
              ++timeouts;
            } else if (link[j].last_tick < 0 && waited > opt.timeout) {
              gave_up = true;
            }
          }
          if (gave_up) break;
          // Lockstep: every 50 ms without the tick's commands, publish the tick's samples again, for a robot
          // that joined (or restarted) after they went out; the supervisor answers with the references again.
          if (waited > 0.05 * static_cast<double>(republished + 1)) {
            publish_samples();
            ++republished;
          }
          inbox.wait(0.01);
        }
        continue;
      }
      if (opt.realtime) {
        if (cmd_at_ns > to_ns(deadline)) {  // arrived after the deadline: too late for this tick
          ++stale;
          link[cmd_arm].heard = std::chrono::steady_clock::now();  // late, but its controller lives
          break;
        }
      }
      const int j = cmd_arm;
      const std::string robot_id = robot_name(j, cmd.strength());
      if (!runtime::all_finite(cmd.tau())) {
        ++rejected;
        continue;
      }
      if (cmd.tick() > static_cast<uint64_t>(k)) {  // a future tick is invalid
        ++rejected;
        continue;
      }
      if (have[j] && cmd.tick() == static_cast<uint64_t>(k)) {
        // A second command for an arm that has this tick's already: a liveliness repeat, or the next
        // strongest robot's answer after the owner left within the tick (EXCLUSIVE ownership then delivers
        // it). The first one stands; a change of owner shows on the next tick.
        ++stale;
        continue;
      }
      const model::Vec3 v(cmd.tau()[0], cmd.tau()[1], cmd.tau()[2]);
      if ((v.cwiseAbs().array() > m.plant.arms[j].tau_max.array()).any()) {
        ++rejected;
        continue;
      }
      link[j].heard = std::chrono::steady_clock::now();
      if (cmd.tick() != static_cast<uint64_t>(k)) {
        // An older tick is a late answer or a liveliness repeat: dropped. From a braked arm's robot it means
        // a controller is back: lockstep waits for it again from the next tick.
        ++stale;
        if (link[j].braked && !opt.realtime && cmd.tick() + 64 > static_cast<uint64_t>(k)) link[j].release = true;
        continue;
      }
      tau[j] = v;
      have[j] = true;
      const auto now_fo = std::chrono::steady_clock::now();
      ArmLink& L = link[j];
      if (L.braked) {
        std::printf("tandem-world %s: %s follows %s after %.0f ms braked\n", opt.module.c_str(), ctx.arm_id(j).c_str(),
                    robot_id.c_str(), std::chrono::duration<double, std::milli>(now_fo - L.last_at).count());
        L.owner = robot_id;
        L.strength = cmd.strength();
        set_brake(j, false, "a robot answers again");
      } else if (!L.owner.empty() && robot_id != L.owner && k >= 50) {
        // A change of owner (EXCLUSIVE ownership picks the strongest live writer). To a weaker robot it is a
        // failover (the owner died or left); to a stronger one a takeover. In the first 50 ticks discovery
        // order decides which of a primary and its shadow the reader hears first: not a switch.
        const double gap_ms = std::chrono::duration<double, std::milli>(now_fo - L.last_at).count();
        const bool failover = cmd.strength() < L.strength;
        if (failover) {
          ++failovers;
          failover_last_ms = gap_ms;
          failover_max_ms = std::max(failover_max_ms, gap_ms);
        }
        std::printf("tandem-world %s: %s now follows %s (was %s): %s %.1f ms after the last command of the old one\n",
                    opt.module.c_str(), ctx.arm_id(j).c_str(), robot_id.c_str(), L.owner.c_str(),
                    failover ? "failover" : "takeover", gap_ms);
        std::fflush(stdout);
        if (ws.switch_gap_ms().size() < 512) {
          ws.switch_gap_ms().push_back(gap_ms);
          ws.switch_failover().push_back(failover);
          // The window starts at the old owner's last command: the gap, held on its last torque, counts.
          double ep_max = 0.0, hn_min = 1e300;
          for (long kk = std::max({L.last_tick, k - static_cast<long>(kHistory) + 1, 0L}); kk <= k; ++kk) {
            ep_max = std::max(ep_max, history[static_cast<size_t>(kk) % kHistory].ep[static_cast<size_t>(j)]);
            hn_min = std::min(hn_min, history[static_cast<size_t>(kk) % kHistory].hn_min);
          }
          ws.switch_ep_max().push_back(ep_max);
          ws.switch_hn_min().push_back(hn_min);
          windows.push_back({j, k + kWindowTicks, ws.switch_gap_ms().size() - 1});
        }
        L.owner = robot_id;
        L.strength = cmd.strength();
        status.msg().serving(serving_text());
        status.publish();
      } else if (L.owner != robot_id || L.strength != cmd.strength()) {
        L.owner = robot_id;
        L.strength = cmd.strength();
        status.msg().serving(serving_text());
        status.publish();
      }
      L.last_tick = k;
      L.last_at = now_fo;
      L.heard = now_fo;
      if (opt.realtime) {
        const double us = static_cast<double>(cmd_at_ns - to_ns(sent)) * 1e-3;
        latency_us.add(us);
        interval_worst_us = std::max(interval_worst_us, us);
      }
    }
    if (runtime::g_stop) break;
    bool stop_run = false;
    for (int j = 0; j < 2; ++j) {
      if (have[j]) continue;
      if (link[j].braked) {
        ++braked_ticks;
        continue;
      }
      if (opt.realtime) {
        // A late or missing command: the arm keeps its previous torque for this tick (counted). An arm from
        // which no command at all (late ones included) came for brake_after_s has no live controller: braked.
        ++late;
        const double quiet = std::chrono::duration<double>(std::chrono::steady_clock::now() - link[j].heard).count();
        if (link[j].last_tick >= 0 && quiet > brake_after_s) set_brake(j, true, "no live controller");
      } else if (link[j].last_tick < 0) {
        ++timeouts;
        std::fprintf(stderr, "tandem-world: tick %ld: no valid torque from %s within %.1f s; stopping\n", k,
                     ctx.arm_id(j).c_str(), opt.timeout);
        stop_run = true;
      }
    }
    if (stop_run) break;
    if (opt.realtime) {
      ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);
    } else if (link[0].braked && link[1].braked) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));  // nothing to wait for: hold at about 1 kHz
    }
    plant.step(tau, t, m.period, m.substeps);
    if (opt.realtime) tick_start = deadline;
  }

  ws.module_id(opt.module);
  ws.braked_ticks(braked_ticks);
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
  const bool never_answered = link[0].last_tick < 0 || link[1].last_tick < 0;
  if (never_answered && !runtime::g_stop) {
    status.set(runtime::Lifecycle::Error, "a robot did not answer a tick");
  } else {
    status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  }
  std::printf("tandem-world %s: %ld ticks, slip %ld, contact lost %ld, rejected %llu, stale %llu, %s %llu, "
              "overruns %llu\n",
              opt.module.c_str(), k, plant.counters().slip_events, plant.counters().contact_lost, rejected, stale,
              opt.realtime ? "late arm-ticks" : "brakings", opt.realtime ? late : timeouts, overruns);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the summary reach the launcher
  return never_answered && !runtime::g_stop ? 4 : 0;
}
