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
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

using SensorReader = bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType>;
using TorqueWriter = bus::Writer<msg::TorqueCommand, msg::TorqueCommandPubSubType>;

/// One robot process: its DDS endpoints, its core (shared by the DDS thread that receives the samples, which
/// computes, and the main thread, which watches the inputs and publishes status, under mu_), and the start-up steps.
class RobotProcess {
 public:
  RobotProcess(const runtime::RoleOptions& opt, const runtime::RoleContext& ctx, int j)
      : opt_(opt), m_(ctx.module), my_arm_(ctx.arm_id(j)),
        // Process id: the arm for the primary, "<arm>@<strength>" for a standby (one per strength).
        robot_id_(opt.strength == runtime::RoleOptions::kPrimaryStrength ? my_arm_ : my_arm_ + "@" + std::to_string(opt.strength)),
        core_(m_, j, opt.continuous, ctx.scenario.transient), part_(opt.domain, "robot/" + my_arm_, opt.transport),
        plans_(part_, bus::module_topic(bus::kSupervisorPlanTopic, opt.module), bus::TopicKind::Task),
        summary_(part_, bus::kRobotSummaryTopic, bus::TopicKind::Summary), status_(part_, robot_id_, "robot", opt.module),
        watch_(watch_rules(opt), seconds(Clock::now())) {
    status_.msg().deployment(opt.deployment);
    status_.msg().strength(opt.strength);
    status_.set(runtime::Lifecycle::Inactive, "waiting for the plan and the first tick");
    cmd_.strength(opt.strength);
    listener_.self = this;
  }

  // The sensor reader goes first: its listener uses the members below it (the sample, the core, the mutex).
  ~RobotProcess() { sensors_.reset(); }
  RobotProcess(const RobotProcess&) = delete;
  RobotProcess& operator=(const RobotProcess&) = delete;

  int run() {
    // Secured: ready only once this robot's own side of its inbound pairs works (below). Plain: at once, as a plain
    // pair that matched on the world's side matches on this side too (a robot that joins a running module must not
    // wait for anything it does not need).
    const bool check_ready = part_.secured();
    if (!check_ready) take_part();
    if (const int code = wait_for_launcher(); code >= 0) return code;
    sensors_ = make_sensor_reader();
    if (check_ready) {
      if (const int code = wait_until_ready(); code >= 0) return code;
      take_part();
    }
    status_.set(runtime::Lifecycle::Inactive, "waiting for the first tick");
    {
      std::lock_guard<std::mutex> lock(mu_);
      watch_.renewed(seconds(Clock::now()));  // no renewal in the loop's first 2 s (start-up is not deafness)
    }
    while (!runtime::g_stop && pass()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return finish();
  }

 private:
  static robot::InputWatch::Rules watch_rules(const runtime::RoleOptions& opt) {
    robot::InputWatch::Rules rules;
    rules.timeout_s = opt.timeout;
    rules.unmatched_s = std::max(rules.unmatched_s, 0.3 * opt.timeout);
    return rules;
  }

  void take_plans() {  // under mu_
    while (plans_.take(plan_in_)) {
      if (plan_in_.module_id() != opt_.module) continue;
      watch_.on_plan(seconds(Clock::now()), static_cast<long>(plan_in_.heard_tick()));
      why_.clear();
      const plan::PlanFollower::Offer o = core_.offer_plan(runtime::from_wire(plan_in_), &why_);
      if (o == plan::PlanFollower::Offer::Rejected) {
        std::fprintf(stderr, "tandem-robot %s: plan from '%s' rejected: %s\n", robot_id_.c_str(),
                     plan_in_.supervisor_id().c_str(), why_.c_str());
      } else if (!why_.empty()) {
        std::fprintf(stderr, "tandem-robot %s: %s\n", robot_id_.c_str(), why_.c_str());
      }
    }
  }

  // One tick, in the thread that received the sample: the core computes, the command goes out at once.
  void on_sample(const msg::ArmSensors& smp) {  // under mu_
    const auto t_in = Clock::now();
    watch_.on_sample(seconds(t_in));
    // Another robot's torque, the world's drive or the brake's holding torque drove the arm over the last period:
    // the core tracks it (bumpless transfer and release).
    if (smp.arm_kind() != static_cast<uint8_t>(core_.arm().kind())) {
      // An arm of another type than this robot's model (a robot started with another scenario than its module's):
      // it serves it not. Said once; the world refuses such commands anyway.
      if (!wrong_kind_said_) {
        wrong_kind_said_ = true;
        std::fprintf(stderr, "tandem-robot %s: the arm is a %s and this robot's model a %s: not serving it\n",
                     robot_id_.c_str(), model::arm_kind_name(static_cast<model::ArmKind>(smp.arm_kind())),
                     model::arm_kind_name(core_.arm().kind()));
      }
      return;
    }
    const model::JointVec applied = robot_wire::applied(smp);
    const bool other = robot_wire::driven_by_other(smp, opt_.strength);
    core_.world_plan({smp.plan_epoch(), smp.plan_strength()}, smp.plan_version(), static_cast<long>(smp.plan_since()),
                     static_cast<long>(smp.tick()));
    if (core_.cut_off()) return;  // a stale plan is never served: the main loop leaves the arm
    const std::optional<model::JointVec> tau =
        core_.on_sample(static_cast<long>(smp.tick()), robot_wire::inputs(smp), smp.braked(), other ? &applied : nullptr);
    newest_tick_ = static_cast<long>(smp.tick());
    if (!tau) return;
    robot_wire::fill_command(core_, *tau, cmd_);
    torque_writer_->write(cmd_);
    watch_.on_answer(seconds(t_in));
    interval_worst_us_ = std::max(interval_worst_us_, std::chrono::duration<double, std::micro>(Clock::now() - t_in).count());
  }

  struct Listener : fdds::DataReaderListener {
    RobotProcess* self = nullptr;
    void on_data_available(fdds::DataReader* r) override {
      std::lock_guard<std::mutex> lock(self->mu_);
      if (!self->stopping_ && self->ready_) self->take_plans();
      fdds::SampleInfo info;
      while (r->take_next_sample(&self->s_, &info) == ReturnCode_t::RETCODE_OK) {
        // Always taken: a sample left unread here stops Fast DDS 2.9 from calling this listener again (seen: robots
        // that never computed a tick). Before the robot is ready, or once it leaves, it is dropped (lockstep sends a
        // tick's samples again every 50 ms; real time sends the next tick's).
        if (info.valid_data && !self->stopping_ && self->ready_) self->on_sample(self->s_);
      }
    }
  };

  std::unique_ptr<SensorReader> make_sensor_reader() {
    return std::make_unique<SensorReader>(part_, bus::arm_topic(bus::kSensorsTopic, my_arm_),
                                          opt_.realtime ? bus::TopicKind::SensorsRealtime : bus::TopicKind::Sensors,
                                          &listener_);
  }

  // Makes the torque writer; lockstep with a recorder (--observers, set by the launcher): the first command waits
  // until the recorder's reader of this arm's torques has matched too (the world is the other reader), so that the
  // recording has this robot's every command. A recorder that is slow to match holds the robot for half the timeout
  // at most. Then samples are answered. The world waits for this writer before its first tick, so with security it
  // is made only once this robot can serve.
  void take_part() {
    torque_writer_.emplace(part_, bus::arm_topic(bus::kTorquesTopic, my_arm_),
                           opt_.realtime ? bus::TopicKind::TorquesRealtime : bus::TopicKind::Torques, opt_.strength);
    if (!opt_.realtime && opt_.observers > 0) {
      const auto w0 = Clock::now();
      while (!runtime::g_stop && torque_writer_->matched() < 2 && since(w0) < 0.5 * opt_.timeout) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    }
    std::lock_guard<std::mutex> lock(mu_);
    ready_ = true;
  }

  // The robot takes part (its sensor reader, which the world waits for) only once the launcher hears it (the reader
  // of its summary): a robot the launcher cannot hear (a pair that never authenticated, docs/security.md
  // "Start-up") would serve an arm whose summary and status are lost. Past the timeout: exit 3, and the launcher
  // restarts the module if it had not ticked yet. Returns -1 when heard, else the exit code.
  int wait_for_launcher() {
    status_.set(runtime::Lifecycle::Inactive, "waiting for the launcher");
    for (const auto l0 = Clock::now(); !runtime::g_stop && summary_.matched() < 1;) {
      if (since(l0) > opt_.timeout) {
        std::fprintf(stderr, "tandem-robot %s: the launcher was not found within %.1f s (summary readers 0/1)\n",
                     robot_id_.c_str(), opt_.timeout);
        status_.set(runtime::Lifecycle::Error, "launcher not found");
        return launcher::exit_code::kPeersNotFound;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return -1;
  }

  // Secured: ready to serve only when this side of each inbound pair works too: the sensor reader has matched the
  // world's writer and a plan has been heard. A secured pair can match on one side only (seen: the world's sensor
  // writer matched a robot that never got a sample nor a plan, and the world ticked with that arm braked). Past the
  // timeout: exit 3, and the launcher restarts the module if it had not ticked yet (docs/security.md, "Start-up").
  // Returns -1 when ready, else the exit code.
  int wait_until_ready() {
    status_.set(runtime::Lifecycle::Inactive, "waiting for the world's samples and a plan");
    for (const auto r0 = Clock::now();;) {
      if (runtime::g_stop) return launcher::exit_code::kDone;
      const bool matched = sensors_->matched() >= 1;  // not under mu_ (the listener takes mu_ under the reader's lock)
      {
        std::lock_guard<std::mutex> lock(mu_);
        take_plans();
        const bool planned = core_.has_plan();
        if (matched && planned) return -1;
        const char* waiting = !matched ? (planned ? "waiting for the world's samples" : "waiting for the world's samples and a plan")
                                       : "waiting for a plan";
        if (status_.msg().detail() != waiting) status_.set(runtime::Lifecycle::Inactive, waiting);
        if (since(r0) > opt_.timeout) {
          std::fprintf(stderr, "tandem-robot %s: not ready within %.1f s (world's sensor writer %s, plan %s)\n",
                       robot_id_.c_str(), opt_.timeout, matched ? "matched" : "not matched", planned ? "heard" : "not heard");
          status_.set(runtime::Lifecycle::Error, "peers not found");
          return launcher::exit_code::kPeersNotFound;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }

  /// One pass of the main loop (every ~10 ms): plans, activation, status, the cut-off and the input watch. False
  /// when the robot leaves (its task done, cut off, or no input).
  bool pass() {
    // Asked before taking mu_: Fast DDS holds the reader's lock while it calls the listener, which takes mu_, so
    // asking the reader under mu_ could deadlock the two (the robot then computes nothing more).
    const bool reader_matched = sensors_->matched() >= 1;
    std::unique_lock<std::mutex> lock(mu_);
    take_plans();
    const long done = core_.done();
    if (done + 1 >= m_.steps) return false;
    if (done >= 0 && !activated_) {
      activated_ = true;
      status_.set(runtime::Lifecycle::Active, "controlling");
      if (runtime::raise_to_realtime_from_env() < 0) std::fprintf(stderr, "tandem-robot: could not raise to SCHED_FIFO once active\n");
    }
    if (activated_) {  // behind the world's plan, or back on it: said at once (a standby behind cannot take over)
      const char* detail = core_.behind() ? robot::RobotCore::kBehindDetail : "controlling";
      if (status_.msg().detail() != detail) status_.set(runtime::Lifecycle::Active, detail);
    }
    // Every 100 ticks, and at least every 250 ms: in lockstep 100 ticks can take seconds (a slow or waiting module),
    // and observers tell a live robot from a dead or stalled one by its status (soak runs 50 and 51: robots resumed
    // after a stall were heard only at their next 100th tick, 2.1-3.5 s later).
    const auto wall = Clock::now();
    if (done >= 0 && (done / 100 != reported_tick_ / 100 || wall - last_status_ > std::chrono::milliseconds(250))) {
      reported_tick_ = done;
      last_status_ = wall;
      robot_wire::fill_status(core_, status_);
      status_.msg().latency_p99_us(interval_worst_us_);  // worst control step + write of the interval
      interval_worst_us_ = 0.0;
      status_.publish();
    }
    if (core_.cut_off()) {
      std::fprintf(stderr, "tandem-robot %s: the world has followed a newer plan than this robot's (epoch %llu, "
                   "strength %d, version %llu) for %ld ticks at tick %ld: cut off from the module's leader; leaving its arm "
                   "and exiting, to come back with a fresh participant\n",
                   robot_id_.c_str(), static_cast<unsigned long long>(core_.plan_rank().epoch), core_.plan_rank().strength,
                   static_cast<unsigned long long>(core_.plan_version()), robot::RobotCore::kBehindTicks, core_.done());
      cut_off_ = true;
      return false;
    }
    // Samples stopped while the module's plan still comes (robot::InputWatch): a new reader, outside the lock (its
    // listener takes it).
    const double now = seconds(Clock::now());
    if (watch_.silent_while_fed(now)) {
      std::fprintf(stderr, "tandem-robot %s: answered no tick for %.0f ms while samples came (last computed %ld, "
                   "newest sample %ld): %s\n", robot_id_.c_str(), 1e3 * watch_.answer_age_s(now), core_.done(),
                   newest_tick_, *core_.silent_reason() != '\0' ? core_.silent_reason() : "cut off, or an arm of another type");
    }
    const robot::InputWatch::Action act = watch_.on_pass(now, activated_, reader_matched);
    if (act == robot::InputWatch::Action::GiveUp) {
      if (watch_.gave_up_unmatched()) {
        std::fprintf(stderr, "tandem-robot %s: the sensor reader has not matched the world's writer in %.1f s while the "
                     "module ran; stopping, to come back with a fresh participant\n", robot_id_.c_str(),
                     watch_.rules().unmatched_s);
      } else {
        std::fprintf(stderr, "tandem-robot %s: no input for %.1f s after tick %ld%s; stopping\n", robot_id_.c_str(),
                     watch_.silent_s(now), core_.done(),
                     watch_.renewals() > 0 && !activated_ ? " while the module ran, with new sensor readers" : "");
      }
      return false;
    }
    if (act == robot::InputWatch::Action::RenewReader) {
      std::fprintf(stderr, "tandem-robot %s: no sample for %.1f s after tick %ld while the module's plan comes: a new "
                   "sensor reader (%d so far)\n", robot_id_.c_str(), watch_.silent_s(now), core_.done(), watch_.renewals());
      lock.unlock();
      sensors_.reset();
      sensors_ = make_sensor_reader();
      lock.lock();
      watch_.renewed(seconds(Clock::now()));
    }
    return true;
  }

  int finish() {
    std::unique_lock<std::mutex> lock(mu_);
    stopping_ = true;   // nothing more is computed or written by the receiving thread
    const bool had_writer = torque_writer_.has_value();
    if (had_writer) {
      cmd_.leaving(true);  // the last word: the world follows the next robot of the arm at once
      torque_writer_->write(cmd_);
    }
    lock.unlock();
    if (had_writer) {
      torque_writer_->wait_for_acks(0.1);  // lockstep: the last command reaches the world
      std::this_thread::sleep_for(std::chrono::milliseconds(5));  // real time (best effort): give it a tick or two
    }
    torque_writer_.reset();  // give the arm up: the world follows the next strongest robot at once, then report
    lock.lock();
    const long done = core_.done();
    msg::RobotSummary rs;
    robot_wire::fill_summary(core_, my_arm_, robot_id_, rs);
    summary_.write(rs);
    robot_wire::fill_status(core_, status_);
    const bool finished = done + 1 >= m_.steps;
    if (finished) {
      status_.set(runtime::Lifecycle::Finalized, "task done");
    } else {
      status_.set(runtime::g_stop ? runtime::Lifecycle::Finalized : runtime::Lifecycle::Error,
                  runtime::g_stop ? "stopped" : cut_off_ ? "cut off from the module's leader" : "no input");
    }
    lock.unlock();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    if (finished || runtime::g_stop) return launcher::exit_code::kDone;
    return cut_off_ ? launcher::exit_code::kCutOff : launcher::exit_code::kNoInput;
  }

  const runtime::RoleOptions& opt_;
  const sim::ModuleSetup& m_;
  std::string my_arm_, robot_id_;
  robot::RobotCore core_;
  bus::Participant part_;
  bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plans_;
  // The torque writer: the world hears every robot of the arm and follows the strongest that answers.
  std::optional<TorqueWriter> torque_writer_;
  bus::Writer<msg::RobotSummary, msg::RobotSummaryPubSubType> summary_;
  runtime::StatusPublisher status_;
  std::mutex mu_;
  robot::InputWatch watch_;  // under mu_
  Listener listener_;
  std::unique_ptr<SensorReader> sensors_;  // reset first by the destructor, before what its listener uses
  msg::TorqueCommand cmd_;
  msg::SupervisorPlan plan_in_;
  msg::ArmSensors s_;
  std::string why_;
  double interval_worst_us_ = 0.0;
  long newest_tick_ = -1;  ///< the newest sample's tick (under mu_)
  long reported_tick_ = -1;
  Clock::time_point last_status_ = Clock::now();  ///< the last status published from pass()
  bool activated_ = false;
  bool stopping_ = false;  // under mu_: set once the robot leaves; the receiving thread computes nothing more
  bool ready_ = false;     // under mu_: the torque writer exists; until then samples are dropped
  bool wrong_kind_said_ = false;  // under mu_: a sample of an arm of another type was reported
  bool cut_off_ = false;   // the module's leader fell silent for this robot (RobotCore::cut_off): exit 6
};

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
  RobotProcess p(opt, ctx, j);
  return runtime::bound_teardown("tandem-robot", p.run());  // (then its DDS teardown, bounded)
}

}  // namespace

int main(int argc, char** argv) { return runtime::run_guarded("tandem-robot", run, argc, argv); }
