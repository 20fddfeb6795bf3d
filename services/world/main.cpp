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
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "tandem/launcher/exit_codes.hpp"
#include "tandem/runtime/histogram.hpp"
#include "tandem/runtime/inbox.hpp"
#include "tandem/runtime/peer_wait.hpp"
#include "tandem/runtime/plan_wire.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/world/lockstep_pacer.hpp"
#include "tandem/world/start_wait.hpp"
#include "tandem/world/world_core.hpp"
#include "world_wire.hpp"

using namespace tandem;
namespace bus = tandem::dds;

namespace {

int run(int argc, char** argv) {
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
  wo.brakes = !opt.test_no_brakes;
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
  runtime::Inbox<msg::TorqueCommand, 2> inbox(!opt.realtime);
  // A torque topic per arm, every robot of the arm on it: the core follows the strongest that answers. (Robots
  // answer samples only, and none goes out before the inbox knows its readers.)
  const bus::TopicKind torque_kind = opt.realtime ? bus::TopicKind::TorquesRealtime : bus::TopicKind::Torques;
  bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType> torques0(part, bus::arm_topic(bus::kTorquesTopic, ctx.arm_id(0)),
                                                                          torque_kind, &inbox);
  bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType> torques1(part, bus::arm_topic(bus::kTorquesTopic, ctx.arm_id(1)),
                                                                          torque_kind, &inbox);
  inbox.set_sources({torques0.get(), torques1.get()});
  bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plans(part, bus::module_topic(bus::kSupervisorPlanTopic, opt.module),
                                                                        bus::TopicKind::Task);
  bus::Writer<msg::WorldReport, msg::WorldReportPubSubType> report(part, bus::module_topic(bus::kWorldReportTopic, opt.module),
                                                                   bus::TopicKind::Task);
  bus::Writer<msg::WorldSummary, msg::WorldSummaryPubSubType> summary(part, bus::kWorldSummaryTopic,
                                                                       bus::TopicKind::Summary);

  runtime::StatusPublisher status(part, opt.module + "/world", "world", opt.module);
  status.msg().deployment(opt.deployment);
  status.set(runtime::Lifecycle::Inactive, "waiting for the supervisor and two robots");
  // Peers: a robot per arm reads its sensors and writes torques; the supervisor reads the report; the launcher reads
  // the summary (a world the launcher cannot hear, a pair that never authenticated, docs/security.md "Start-up",
  // must not run a task whose summary and status would be lost). --observers counts the sensor readers besides the
  // first robot (the arm's standbys, and a recorder), and the world waits for all of them: with a recorder, so that
  // a recording holds every tick from the first; on several hosts, so that the arms do not start braked because
  // their primaries' host answered later than a standby's. A reader that is slow to come must not hold the module
  // for long: after half the timeout, one reader besides the first is enough (the recorder, started before any
  // module, is normally there by then).
  auto seconds = [] { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); };
  const int readers_all = 1 + opt.observers;
  runtime::PeerWait peers({{"sensor readers of " + ctx.arm_id(0), readers_all, std::min(readers_all, 2)},
                           {"sensor readers of " + ctx.arm_id(1), readers_all, std::min(readers_all, 2)},
                           {"torque writer of " + ctx.arm_id(0), 1},
                           {"torque writer of " + ctx.arm_id(1), 1},
                           {"supervisor (report reader)", 1},
                           {"launcher (summary reader)", 1}},
                          opt.timeout, seconds());
  while (!runtime::g_stop) {
    const runtime::PeerWait::Verdict v = peers.pass(seconds(), {sensors0.matched(), sensors1.matched(), torques0.matched(),
                                                                torques1.matched(), report.matched(), summary.matched()});
    for (const size_t i : peers.take_lowered()) {
      std::fprintf(stderr, "tandem-world %s: %s: not all there after %.1f s; starting with %d\n", opt.module.c_str(),
                   peers.peer(i).name.c_str(), 0.5 * opt.timeout, peers.needed(i));
    }
    if (v == runtime::PeerWait::Verdict::Ready) break;
    if (v == runtime::PeerWait::Verdict::TimedOut) {
      std::fprintf(stderr, "tandem-world: peers not found within %.1f s (%s)\n", opt.timeout, peers.missing().c_str());
      status.set(runtime::Lifecycle::Error, "peers not found");
      return launcher::exit_code::kPeersNotFound;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the reverse matches settle

  runtime::Histogram latency_us, wake_late_us;  // fixed bins: no allocation per tick, any run length
  double interval_worst_us = 0.0;
  msg::SupervisorPlan plan_in;
  msg::WorldReport rep;
  rep.module_id(opt.module);
  msg::ArmSensors s;
  std::array<world::SampleOut, 2> samples{};
  auto to_ts = [](long long ns) {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(ns / 1000000000LL);
    ts.tv_nsec = static_cast<long>(ns % 1000000000LL);
    return ts;
  };
  auto now_ns = [] {
    timespec n{};
    ::clock_gettime(CLOCK_MONOTONIC, &n);
    return static_cast<long long>(n.tv_sec) * 1000000000LL + n.tv_nsec;
  };
  world::TickClock clock(std::llround(m.period * 1e9), now_ns());
  auto publish_status_if_changed = [&] {
    if (!core.serving_changed()) return;
    status.msg().owners(world_wire::owners(core));
    status.msg().detail(core.failed()            ? "failed: object dropped (" + core.failure() + ")"
                        : core.paused_for_load() ? "paused for load (overload: commands late)"
                        : core.stopping(0) || core.stopping(1) ? "stopping: an arm has no live controller"
                        : core.braked(0) || core.braked(1) ? "arm braked: no live controller" : "");
    status.publish();
  };
  status.msg().owners(world_wire::owners(core));
  status.set(runtime::Lifecycle::Active, opt.realtime ? "real time" : "lockstep");
  if (runtime::raise_to_realtime_from_env() < 0) std::fprintf(stderr, "tandem: could not raise to SCHED_FIFO once active\n");
  long k = 0;
  std::array<long, 2> write_failures{0, 0}, history_clears{0, 0};
  auto take_plans = [&] {
    while (plans.take(plan_in)) {
      std::string why;
      if (plan_in.module_id() == opt.module) {
        const plan::PlanFollower::Offer o = core.offer_plan(runtime::from_wire(plan_in), &why);
        if (o == plan::PlanFollower::Offer::Rejected || !why.empty()) {
          std::fprintf(stderr, "tandem-world %s: %s%s\n", opt.module.c_str(),
                       o == plan::PlanFollower::Offer::Rejected ? "a plan was refused: " : "", why.c_str());
        }
      }
    }
  };
  // Lockstep: the world runs no further ahead of the leader it follows than the plan's lease (WorldCore::
  // plan_lease_ok), and waits for its commands; world::LockstepPacer says how long and what to do meanwhile.
  world::LockstepPacer pacer;
  bool reported = false;  // a report went out (the lease wait sends the latest again)
  auto send_report = [&] {
    const world::ReportOut r = core.take_report();
    rep.tick(static_cast<uint64_t>(r.tick));
    rep.braked()[0] = r.braked[0];
    rep.braked()[1] = r.braked[1];
    rep.hold(r.hold);
    rep.braked_since(r.braked_since);
    rep.released_at(r.released_at);
    rep.normal_min(r.normal_min);
    for (int i = 0; i < 3; ++i) rep.object()[static_cast<size_t>(i)] = r.object(i);
    rep.failed(r.failed);
    if (r.failed && rep.failure() != r.failure) rep.failure(r.failure);
    world_wire::fill_report_counters(core, opt.realtime, rep);
    rep.plan_epoch(r.plan_rank.epoch);  // the rank and version as of this report
    rep.plan_strength(r.plan_rank.strength);
    rep.plan_version(r.plan_version);
    report.write(rep);
    reported = true;
  };
  for (; k < m.steps && !runtime::g_stop; ++k) {
    take_plans();
    if (!opt.realtime) pacer.tick_begin(seconds());  // lockstep's accounting only: no clock reads per real-time tick
    if (!opt.realtime && pacer.lease_wait_needed(core.plan_lease_ok(k), core.plan_lease())) {
      pacer.lease_wait_begin(seconds());
      // A report of the tick it waits after: the leader's lease then covers it whatever ticks it had heard (a
      // brake's extra report can leave the last plan's tick between the periodic ones), and a standby sees the world
      // a full lease past a silent leader's last plan.
      if (reported) send_report();
      while (!runtime::g_stop && !core.plan_lease_ok(k)) {
        const world::LockstepPacer::LeaseAction a = pacer.lease_wait_pass(seconds(), core.plan_lease(), reported);
        if (a == world::LockstepPacer::LeaseAction::Lapsed) {
          std::fprintf(stderr, "tandem-world %s: tick %ld: no plan from the leader that has heard tick %ld or later "
                       "within %.1f s; going on without waiting for it until it renews its lease\n", opt.module.c_str(),
                       k, k - plan::kPlanLeaseTicks, pacer.rules().lease_wait_s);
          break;
        }
        publish_status_if_changed();
        if (a == world::LockstepPacer::LeaseAction::ResendReport) report.write(rep);
        (void)plans.wait(0.005);
        take_plans();
      }
      pacer.lease_wait_end(seconds());
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
      const int64_t woke_late_ns = clock.begin(sent);  // re-anchors after a stall
      wake_late_us.add(static_cast<double>(woke_late_ns) * 1e-3);
      // The world itself stood still (SIGSTOP, starvation): the robots' silence meanwhile was its own.
      if (woke_late_ns > 20'000'000) core.forgive_silence(sent);
    }
    auto publish_samples = [&](bool all) {
      const plan::SupervisorRank plan_rank = core.plan_rank();
      const uint64_t plan_version = core.plan_version();
      const long plan_since = core.plan_since();
      for (size_t j = 0; j < 2; ++j) {
        const world::SampleOut& o = samples[j];
        if (!o.publish && !all) continue;
        world_wire::fill_sample(o, k, plan_rank, plan_version, plan_since, s);
        const bool written = sensors[j]->write(s);
        if (sensors[j]->history_clears() != history_clears[j]) {
          // Said at the 1st, 2nd, 4th, 8th ... clear of the arm, as the failures below.
          const long n = history_clears[j] = sensors[j]->history_clears();
          if ((n & (n - 1)) == 0) {
            std::fprintf(stderr, "tandem-world %s: tick %ld: the sample writer of %s had a full pool (a change never "
                         "acknowledged, Fast DDS 2.9): its history cleared (%ld so far)\n", opt.module.c_str(), k,
                         ctx.arm_id(static_cast<int>(j)).c_str(), n);
          }
        }
        if (!written) {
          // Fast DDS refused the sample (a writer history held full by a reader that does not acknowledge): said
          // at the 1st, 2nd, 4th, 8th ... failure of the arm, so that a soak's log shows it without flooding.
          const long n = ++write_failures[j];
          if ((n & (n - 1)) == 0) {
            std::fprintf(stderr, "tandem-world %s: tick %ld: the sample for %s was not written (%ld so far)\n",
                         opt.module.c_str(), k, ctx.arm_id(static_cast<int>(j)).c_str(), n);
          }
        }
      }
    };
    publish_samples(false);
    if (core.report_due(m.steps)) send_report();
    if (opt.realtime && k == 0) {
      // The first tick waits for both arms' first commands (world::StartWait says how long and what meanwhile).
      world::StartWait start(seconds());
      runtime::Inbox<msg::TorqueCommand, 2>::Item first;
      world::StartWait::Action a = world::StartWait::Action::Wait;
      while (!runtime::g_stop) {
        take_plans();
        while (inbox.pop(first)) {
          const msg::TorqueCommand& cmd = first.sample;
          (void)core.on_command(first.source, static_cast<long>(cmd.tick()),
                                model::Vec3(cmd.tau()[0], cmd.tau()[1], cmd.tau()[2]), cmd.strength(), first.at_ns,
                                false, cmd.leaving());
        }
        a = start.pass(seconds(), core.have(0) && core.have(1));
        if (a == world::StartWait::Action::Go || a == world::StartWait::Action::GiveUp) break;
        publish_status_if_changed();
        if (a == world::StartWait::Action::Republish) publish_samples(true);
        if (a == world::StartWait::Action::ResendReport) report.write(rep);
        inbox.wait(0.002);
      }
      if (start.waited(seconds()) > 0.1 || a == world::StartWait::Action::GiveUp) {
        std::fprintf(stderr, "tandem-world %s: tick 0 waited %.2f s for the robots' first commands%s\n",
                     opt.module.c_str(), start.waited(seconds()),
                     a == world::StartWait::Action::GiveUp ? "; starting with the start brakes on the arms not answered" : "");
      }
      clock = world::TickClock(std::llround(m.period * 1e9), now_ns());  // the clock starts now
    }
    // Real time: the tick ends at an absolute deadline; lockstep: when every arm that is not braked has its
    // command in (a braked arm's robot may answer too: that releases it).
    const timespec deadline = to_ts(clock.deadline());
    const long long deadline_ns = clock.deadline();
    if (!opt.realtime) pacer.commands_begin(seconds());
    runtime::Inbox<msg::TorqueCommand, 2>::Item item;
    bool gave_up = false;
    while (!runtime::g_stop) {
      // Lockstep: whatever is queued is taken first, even once the tick is complete. With both arms braked the tick
      // is complete at once, and breaking before the queue was read left the commands of the robots that would
      // release them unread for ever: no release, and the queue grew with every tick (soak run 17: arms braked
      // for 136 s with two new robots answering, and a world's memory 26 -> 65 MiB in 148 s).
      if (!inbox.pop(item)) {
        if (opt.realtime) {
          if (now_ns() >= deadline_ns) break;
          ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);  // the commands queue meanwhile
        } else if (core.lockstep_done()) {
          break;
        } else {
          if (!core.lockstep_waited(pacer.commands_waited(seconds()), opt.timeout, now_ns())) {
            gave_up = true;
            break;
          }
          publish_status_if_changed();
          // Lockstep: every 50 ms without the tick's commands, publish the tick's samples again, for a robot
          // that joined (or restarted) after they went out.
          if (pacer.republish_due(seconds())) publish_samples(true);
          inbox.wait(0.01);
        }
        continue;
      }
      const msg::TorqueCommand& cmd = item.sample;
      const bool late_arrival = opt.realtime && item.at_ns > deadline_ns;
      const model::Vec3 tau(cmd.tau()[0], cmd.tau()[1], cmd.tau()[2]);
      if (core.on_command(item.source, static_cast<long>(cmd.tick()), tau, cmd.strength(), item.at_ns, late_arrival,
                          cmd.leaving()) == world::WorldCore::Verdict::Applied &&
          opt.realtime) {
        const double us = static_cast<double>(item.at_ns - sent) * 1e-3;
        latency_us.add(us);
        interval_worst_us = std::max(interval_worst_us, us);
      }
      if (late_arrival) break;  // the rest are for the next tick's pass (as stale)
    }
    if (runtime::g_stop) break;
    if (!opt.realtime) pacer.commands_end(seconds());
    if (!core.end_tick(now_ns()) || gave_up) {
      for (int j = 0; j < 2; ++j) {
        if (!core.have(j)) {
          std::fprintf(stderr, "tandem-world: tick %ld: no valid torque from %s within %.1f s; stopping\n", k,
                       ctx.arm_id(j).c_str(), opt.timeout);
        }
      }
      break;
    }
    publish_status_if_changed();
    if (opt.realtime) {
      ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);
    } else if (core.braked(0) && core.braked(1)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));  // nothing to wait for: hold at about 1 kHz
    }
    core.step();
    if (opt.realtime) clock.advance();
    // A lockstep tick that held the module for long (the plant stands still meanwhile) is said, split by what it
    // waited for, so that a soak's wall-clock gaps can be told apart. What is the world's own is stepping (end_tick, step) and writing
    // (a write blocks up to 1 s on a shared-memory port whose reader was killed holding its lock: Fast DDS builds its
    // interprocess locks with a 1000 ms timeout).
    if (const auto held = opt.realtime ? std::nullopt : pacer.tick_end(seconds())) {
      std::fprintf(stderr, "tandem-world %s: tick %ld held the module %.2f s: %.2f s for the leader's plan, %.2f s "
                   "stepping and publishing, %.2f s for the commands\n", opt.module.c_str(), k, held->total_s,
                   held->lease_s, held->own_s, held->commands_s);
    }
  }

  if (pacer.lease_waits() > 0) {
    std::printf("tandem-world %s: waited for the leader's plan %ld time(s), %.2f s in all (lockstep)\n",
                opt.module.c_str(), pacer.lease_waits(), pacer.lease_wait_s());
  }
  if (inbox.dropped() > 0) {
    std::fprintf(stderr, "tandem-world %s: %llu torque command(s) dropped unread: the queue was full\n", opt.module.c_str(),
                 inbox.dropped());
  }
  msg::WorldSummary ws;
  world_wire::fill_summary(core, opt.module, k, opt.realtime, clock.overruns, latency_us, wake_late_us, ws);
  summary.write(ws);
  status.msg().tick(static_cast<uint64_t>(k));
  status.msg().progress(opt.continuous ? -1.0 : static_cast<double>(k) / static_cast<double>(m.steps));
  const bool never_answered = !core.answered_once();
  if (never_answered && !runtime::g_stop) {
    status.set(runtime::Lifecycle::Error, "a robot did not answer a tick");
  } else {
    status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  }
  const model::ModulePlant& plant = core.plant();
  std::printf("tandem-world %s: %ld ticks, slip %ld, contact lost %ld, rejected %llu, stale %llu, %s %llu, "
              "overruns %llu, pauses for load %llu\n",
              opt.module.c_str(), k, plant.counters().slip_events, plant.counters().contact_lost, core.rejected,
              core.stale, opt.realtime ? "late arm-ticks" : "brakings", opt.realtime ? core.late : core.timeouts,
              clock.overruns, core.load_pauses);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the summary reach the launcher
  return never_answered && !runtime::g_stop ? launcher::exit_code::kNoInput : launcher::exit_code::kDone;
}

}  // namespace

int main(int argc, char** argv) { return runtime::run_guarded("tandem-world", run, argc, argv); }
