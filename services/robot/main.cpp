// tandem-robot: the controller of one arm, wiring only. robot::RobotCore (services/robot/include) follows the
// module's plan and computes the law; robot::InputWatch says when the sensor reader is deaf or the inputs are
// gone. This process feeds them its arm's sensor samples and the plans from DDS and sends each command from the
// DDS thread that received the sample (no hand-off to another thread: docs/architecture.md, "Per-tick data
// flow"). It also publishes status every 100 ticks and the summary at the end; its last command says it is
// leaving.
#include <tandemPubSubTypes.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <unistd.h>

#include "robot_wire.hpp"
#include "tandem/launcher/exit_codes.hpp"
#include "tandem/robot/input_watch.hpp"
#include "tandem/robot/robot_core.hpp"
#include "tandem/runtime/plan_wire.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;
namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

namespace {
double seconds(Clock::time_point t) { return std::chrono::duration<double>(t.time_since_epoch()).count(); }

int run(int argc, char** argv) {
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
    return launcher::exit_code::kBadArgs;
  }
  const sim::ModuleSetup& m = ctx.module;
  const std::string my_arm = ctx.arm_id(j);
  // Process id: the arm for the primary, "<arm>@<strength>" for a standby (one per strength).
  const std::string robot_id =
      opt.strength == runtime::RoleOptions::kPrimaryStrength ? my_arm : my_arm + "@" + std::to_string(opt.strength);
  robot::RobotCore core(m, j, opt.continuous, ctx.scenario.transient);

  bus::Participant part(opt.domain, "robot/" + my_arm, opt.transport);
  bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plans(
      part, bus::module_topic(bus::kSupervisorPlanTopic, opt.module), bus::TopicKind::Task);
  // The torque writer: the world hears every robot of the arm and follows the strongest that answers. The world
  // starts ticking when every arm has a torque writer matched, so with security it is made only once this robot
  // can serve (below).
  std::optional<bus::Writer<msg::TorqueCommand, msg::TorqueCommandPubSubType>> torque_writer;
  bus::Writer<msg::RobotSummary, msg::RobotSummaryPubSubType> summary(part, bus::kRobotSummaryTopic,
                                                                       bus::TopicKind::Summary);
  runtime::StatusPublisher status(part, robot_id, "robot", opt.module);
  status.msg().deployment(opt.deployment);
  status.msg().strength(opt.strength);
  status.set(runtime::Lifecycle::Inactive, "waiting for the plan and the first tick");

  // The core is shared by the receiving thread (which computes) and the main thread (status, exit).
  std::mutex mu;
  msg::TorqueCommand cmd;
  cmd.strength(opt.strength);
  bool activated = false;
  double interval_worst_us = 0.0;
  robot::InputWatch::Rules rules;
  rules.timeout_s = opt.timeout;
  robot::InputWatch watch(rules, seconds(Clock::now()));  // under mu
  msg::SupervisorPlan plan_in;
  std::string why;
  bool cut_off = false;  // the module's leader fell silent for this robot (RobotCore::cut_off): exit 6
  auto take_plans = [&] {  // under mu
    while (plans.take(plan_in)) {
      if (plan_in.module_id() != opt.module) continue;
      watch.on_plan(seconds(Clock::now()), static_cast<long>(plan_in.heard_tick()));
      why.clear();
      const plan::PlanFollower::Offer o = core.offer_plan(runtime::from_wire(plan_in), &why);
      if (o == plan::PlanFollower::Offer::Rejected) {
        std::fprintf(stderr, "tandem-robot %s: plan from '%s' rejected: %s\n", robot_id.c_str(),
                     plan_in.supervisor_id().c_str(), why.c_str());
      } else if (!why.empty()) {
        std::fprintf(stderr, "tandem-robot %s: %s\n", robot_id.c_str(), why.c_str());
      }
    }
  };
  // One tick, in the thread that received the sample: the core computes, the command goes out at once.
  msg::ArmSensors s;
  auto on_sample = [&](const msg::ArmSensors& smp) {  // under mu
    const auto t_in = Clock::now();
    watch.on_sample(seconds(t_in));
    // Another robot's torque, the world's drive or the brake's holding torque drove the arm over the last period:
    // the core tracks it (bumpless transfer and release).
    const model::Vec3 applied(smp.tau()[0], smp.tau()[1], smp.tau()[2]);
    const bool other = robot_wire::driven_by_other(smp, opt.strength);
    core.world_plan({smp.plan_epoch(), smp.plan_strength()}, smp.plan_version(), static_cast<long>(smp.plan_since()),
                    static_cast<long>(smp.tick()));
    if (core.cut_off()) return;  // a stale plan is never served: the main loop leaves the arm
    const std::optional<model::Vec3> tau =
        core.on_sample(static_cast<long>(smp.tick()), robot_wire::inputs(smp), smp.braked(), other ? &applied : nullptr);
    if (!tau) return;
    robot_wire::fill_command(core, *tau, cmd);
    torque_writer->write(cmd);
    interval_worst_us = std::max(interval_worst_us, std::chrono::duration<double, std::micro>(Clock::now() - t_in).count());
  };
  struct Listener : fdds::DataReaderListener {
    std::function<void(fdds::DataReader*)> fn;
    void on_data_available(fdds::DataReader* r) override { fn(r); }
  } listener;
  bool stopping = false;  // under mu: set once the robot leaves; the receiving thread computes nothing more
  bool ready = false;     // under mu: the torque writer exists; until then samples are dropped
  listener.fn = [&](fdds::DataReader* r) {
    std::lock_guard<std::mutex> lock(mu);
    if (!stopping && ready) take_plans();
    fdds::SampleInfo info;
    while (r->take_next_sample(&s, &info) == ReturnCode_t::RETCODE_OK) {
      // Always taken: a sample left unread here stops Fast DDS 2.9 from calling this listener again (seen: robots
      // that never computed a tick). Before the robot is ready, or once it leaves, it is dropped (lockstep sends a
      // tick's samples again every 50 ms; real time sends the next tick's).
      if (info.valid_data && !stopping && ready) on_sample(s);
    }
  };
  // Makes the torque writer; lockstep with a recorder (--observers, set by the launcher): the first command waits
  // until the recorder's reader of this arm's torques has matched too (the world is the other reader), so that the
  // recording has this robot's every command. A recorder that is slow to match holds the robot for half the
  // timeout at most. Then samples are answered.
  auto take_part = [&] {
    torque_writer.emplace(part, bus::arm_topic(bus::kTorquesTopic, my_arm),
                          opt.realtime ? bus::TopicKind::TorquesRealtime : bus::TopicKind::Torques, opt.strength);
    if (!opt.realtime && opt.observers > 0) {
      const auto w0 = Clock::now();
      while (!runtime::g_stop && torque_writer->matched() < 2 &&
             std::chrono::duration<double>(Clock::now() - w0).count() < 0.5 * opt.timeout) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    }
    std::lock_guard<std::mutex> lock(mu);
    ready = true;
  };
  // Secured: ready only once this robot's own side of its inbound pairs works (below). Plain: at once, as a
  // plain pair that matched on the world's side matches on this side too (a robot that joins a running module
  // must not wait for anything it does not need).
  const bool check_ready = part.secured();
  if (!check_ready) take_part();
  // The robot takes part (its sensor reader, which the world waits for) only once the launcher hears it (the
  // reader of its summary): a robot the launcher cannot hear (a pair that never authenticated, docs/security.md
  // "Start-up") would serve an arm whose summary and status are lost. Past the timeout: exit 3, and the launcher
  // restarts the module if it had not ticked yet.
  status.set(runtime::Lifecycle::Inactive, "waiting for the launcher");
  for (const auto l0 = Clock::now(); !runtime::g_stop && summary.matched() < 1;) {
    if (std::chrono::duration<double>(Clock::now() - l0).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-robot %s: the launcher was not found within %.1f s (summary readers 0/1)\n",
                   robot_id.c_str(), opt.timeout);
      status.set(runtime::Lifecycle::Error, "launcher not found");
      return launcher::exit_code::kPeersNotFound;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  using SensorReader = bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType>;
  auto make_sensor_reader = [&] {
    return std::make_unique<SensorReader>(part, bus::arm_topic(bus::kSensorsTopic, my_arm),
                                          opt.realtime ? bus::TopicKind::SensorsRealtime : bus::TopicKind::Sensors, &listener);
  };
  std::unique_ptr<SensorReader> sensors = make_sensor_reader();
  // Secured: ready to serve only when this side of each inbound pair works too: the sensor reader has matched the
  // world's writer and a plan has been heard. A secured pair can match on one side only (seen: the world's sensor
  // writer matched a robot that never got a sample nor a plan, and the world ticked with that arm braked); the
  // world waits for this robot's torque writer, so it starts only once the robot can serve. Past the timeout:
  // exit 3, and the launcher restarts the module if it had not ticked yet (docs/security.md, "Start-up").
  if (check_ready) status.set(runtime::Lifecycle::Inactive, "waiting for the world's samples and a plan");
  for (const auto r0 = Clock::now(); check_ready;) {
    if (runtime::g_stop) return launcher::exit_code::kDone;
    {
      const bool matched = sensors->matched() >= 1;  // not under mu (the listener takes mu under the reader's lock)
      std::lock_guard<std::mutex> lock(mu);
      take_plans();
      const bool planned = core.has_plan();
      if (matched && planned) break;
      const char* waiting = !matched ? (planned ? "waiting for the world's samples" : "waiting for the world's samples and a plan")
                                     : "waiting for a plan";
      if (status.msg().detail() != waiting) status.set(runtime::Lifecycle::Inactive, waiting);
      if (std::chrono::duration<double>(Clock::now() - r0).count() > opt.timeout) {
        std::fprintf(stderr, "tandem-robot %s: not ready within %.1f s (world's sensor writer %s, plan %s)\n",
                     robot_id.c_str(), opt.timeout, matched ? "matched" : "not matched", planned ? "heard" : "not heard");
        status.set(runtime::Lifecycle::Error, "peers not found");
        return launcher::exit_code::kPeersNotFound;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (check_ready) take_part();
  status.set(runtime::Lifecycle::Inactive, "waiting for the first tick");

  long reported_tick = -1;
  {
    std::lock_guard<std::mutex> lock(mu);
    watch.renewed(seconds(Clock::now()));  // no renewal in the loop's first 2 s (start-up is not deafness)
  }
  while (!runtime::g_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    // Asked before taking mu: Fast DDS holds the reader's lock while it calls the listener, which takes mu, so asking
    // the reader under mu could deadlock the two (the robot then computes nothing more).
    const bool reader_matched = sensors->matched() >= 1;
    std::unique_lock<std::mutex> lock(mu);
    take_plans();
    const long done = core.done();
    if (done + 1 >= m.steps) break;
    if (done >= 0 && !activated) {
      activated = true;
      status.set(runtime::Lifecycle::Active, "controlling");
      if (runtime::raise_to_realtime_from_env() < 0) std::fprintf(stderr, "tandem-robot: could not raise to SCHED_FIFO once active\n");
    }
    if (done >= 0 && done / 100 != reported_tick / 100) {
      reported_tick = done;
      robot_wire::fill_status(core, status);
      status.msg().latency_p99_us(interval_worst_us);  // worst control step + write of the interval
      interval_worst_us = 0.0;
      status.publish();
    }
    if (core.cut_off()) {
      std::fprintf(stderr, "tandem-robot %s: the world has followed a newer plan than this robot's (epoch %llu, "
                   "strength %d, version %llu) for %ld ticks at tick %ld: cut off from the module's leader; leaving its arm "
                   "and exiting, to come back with a fresh participant\n",
                   robot_id.c_str(), static_cast<unsigned long long>(core.plan_rank().epoch), core.plan_rank().strength,
                   static_cast<unsigned long long>(core.plan_version()), robot::RobotCore::kBehindTicks, core.done());
      cut_off = true;
      break;
    }
    // Samples stopped while the module's plan still comes (robot::InputWatch): a new reader, outside the lock
    // (its listener takes it).
    const double now = seconds(Clock::now());
    const robot::InputWatch::Action act = watch.on_pass(now, activated, reader_matched);
    if (act == robot::InputWatch::Action::GiveUp) {
      std::fprintf(stderr, "tandem-robot %s: no input for %.1f s after tick %ld%s; stopping\n", robot_id.c_str(),
                   watch.silent_s(now), core.done(),
                   watch.renewals() > 0 && !activated ? " while the module ran, with new sensor readers" : "");
      break;
    }
    if (act == robot::InputWatch::Action::RenewReader) {
      std::fprintf(stderr, "tandem-robot %s: no sample for %.1f s after tick %ld while the module's plan comes: a new "
                   "sensor reader (%d so far)\n", robot_id.c_str(), watch.silent_s(now), core.done(), watch.renewals());
      lock.unlock();
      sensors.reset();
      sensors = make_sensor_reader();
      lock.lock();
      watch.renewed(seconds(Clock::now()));
    }
  }
  std::unique_lock<std::mutex> lock(mu);
  stopping = true;             // nothing more is computed or written by the receiving thread
  cmd.leaving(true);           // the last word: the world follows the next robot of the arm at once
  torque_writer->write(cmd);
  lock.unlock();
  torque_writer->wait_for_acks(0.1);  // lockstep: the last command reaches the world
  std::this_thread::sleep_for(std::chrono::milliseconds(5));  // real time (best effort): give it a tick or two
  torque_writer.reset();       // give the arm up: the world follows the next strongest robot at once, then report
  lock.lock();
  const long done = core.done();
  msg::RobotSummary rs;
  robot_wire::fill_summary(core, my_arm, robot_id, rs);
  summary.write(rs);
  robot_wire::fill_status(core, status);
  const bool finished = done + 1 >= m.steps;
  if (finished) {
    status.set(runtime::Lifecycle::Finalized, "task done");
  } else {
    status.set(runtime::g_stop ? runtime::Lifecycle::Finalized : runtime::Lifecycle::Error,
               runtime::g_stop ? "stopped" : cut_off ? "cut off from the module's leader" : "no input");
  }
  lock.unlock();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  return (finished || runtime::g_stop) ? launcher::exit_code::kDone : cut_off ? launcher::exit_code::kCutOff : launcher::exit_code::kNoInput;
}

}  // namespace

int main(int argc, char** argv) { return runtime::run_guarded("tandem-robot", run, argc, argv); }
