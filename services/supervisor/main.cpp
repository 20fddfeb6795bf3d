// tandem-supervisor: the supervisor of one basic module. For every sensor sample of tick k it publishes that
// arm's references for ticks k and k+1 (eq. 15 on the planned object path) with the grasp force h_ref
// (eq. 16). The path is the scenario's task, or, with --continuous, the tasks the coordinator assigns: each
// starts where the previous one left the object; between tasks the object is held still.
//
// Pause and resume: the path is sampled through a time scale (model::TimeScale). The module pauses when an
// arm is braked (its samples say so: no live controller) or when the launcher asks ("pause", for an unplug
// without a standby); it resumes when both arms are controlled again and no pause is asked for. A requested
// pause ramps the object smoothly to rest (0.3 s); a braked arm stops the path at once (20 ms ramp).
// Drain ("drain"): the module finishes its task, takes no new one, reports "left" and exits.
// The module's task state goes to the coordinator and the launcher on every change and every 100 ms.
#include <tandemPubSubTypes.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;

namespace {

constexpr double kPauseRamp = 0.3;   // requested pause / resume [s]
constexpr double kBrakeRamp = 0.02;  // an arm braked: stop the path now [s]
constexpr long kReleaseSettleTicks = 200;  // both arms controlled again for this long before resuming

enum class TaskStateCode : uint8_t { Idle = 0, Running = 1, Done = 2, Paused = 3, Draining = 4, Left = 5 };

// The object's planned pose as a function of the tick: the scenario's path, or a chain of assigned tasks,
// each sampled through the module's time scale.
class TaskPlan {
 public:
  TaskPlan(const sim::ModuleSetup& m, bool continuous) : m_(m), continuous_(continuous) {
    rest_ = m.path.sample(0.0).pose;
  }
  model::PoseSample sample(long k) const {
    const model::TimeScale::Sample s = scale_.at(time(k));
    if (!continuous_) return model::sample_scaled(m_.path, s);
    if (task_id_ == 0 || k < start_) {
      model::PoseSample p;
      p.pose = rest_;
      return p;
    }
    return model::sample_scaled(path_, s, tau_start_);
  }
  /// Starts a task at tick `start` from the current rest pose.
  void assign(uint64_t id, const std::vector<double>& waypoints, long start) {
    std::vector<model::ObjectPath::Segment> segs;
    for (size_t i = 0; i + 3 < waypoints.size(); i += 4) {
      segs.push_back({model::Vec3(waypoints[i], waypoints[i + 1], waypoints[i + 2]), waypoints[i + 3]});
    }
    path_ = model::ObjectPath(rest_, 0.0, segs);
    end_pose_ = segs.empty() ? rest_ : segs.back().to;
    task_id_ = id;
    start_ = start;
    tau_start_ = scale_.at(time(start)).tau;
    running_ = true;
  }
  /// True once every tick of the running task has been published (then the object rests at its end).
  bool finish_if_done(long published_min) {
    if (!running_ || published_min < start_ ||
        scale_.at(time(published_min)).tau - tau_start_ < path_.motion_end()) {
      return false;
    }
    running_ = false;
    rest_ = end_pose_;
    ++done_;
    return true;
  }
  /// Scenario mode: the path's motion is over by tick k.
  bool motion_over(long k) const { return scale_.at(time(k)).tau >= m_.path.motion_end(); }
  /// From tick `from` (the first one not yet published) the path runs at `rate` (0 paused, 1 normal).
  void set_rate(long from, double rate, double ramp) {
    if (scale_.target() != rate) scale_.retarget(time(from), rate, ramp);
  }
  double target_rate() const { return scale_.target(); }
  bool paused_at(long k) const { return scale_.target() == 0.0 && scale_.settled(time(k)); }
  bool running() const { return running_; }
  uint64_t task_id() const { return task_id_; }
  uint64_t done() const { return done_; }

 private:
  double time(long k) const { return static_cast<double>(k) * m_.period; }
  const sim::ModuleSetup& m_;
  bool continuous_;
  model::TimeScale scale_;
  model::Vec3 rest_ = model::Vec3::Zero(), end_pose_ = model::Vec3::Zero();
  model::ObjectPath path_;
  uint64_t task_id_ = 0, done_ = 0;
  long start_ = 0;
  double tau_start_ = 0.0;
  bool running_ = false;
};

}  // namespace

int main(int argc, char** argv) {
  runtime::RoleOptions opt;
  runtime::RoleContext ctx;
  int code = 0;
  if (!runtime::start_role("supervisor", argc, argv, false, opt, ctx, code)) return code;
  const sim::ModuleSetup& m = ctx.module;
  bus::Participant part(opt.domain, "supervisor/" + opt.module, opt.transport);
  bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors(part, bus::module_topic(bus::kSensorsTopic, opt.module), bus::TopicKind::Sensors);
  bus::Writer<msg::ArmReference, msg::ArmReferencePubSubType> refs(part, bus::module_topic(bus::kReferencesTopic, opt.module),
                                                                   bus::TopicKind::References);
  bus::Reader<msg::TaskAssignment, msg::TaskAssignmentPubSubType> assignments(part, bus::kTaskAssignmentTopic,
                                                                              bus::TopicKind::Task);
  bus::Writer<msg::TaskState, msg::TaskStatePubSubType> task_state(part, bus::kTaskStateTopic, bus::TopicKind::Task);
  bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType> control(part, bus::kControlTopic,
                                                                         bus::TopicKind::Control);
  runtime::StatusPublisher status(part, opt.module + "/supervisor", "supervisor", opt.module);
  status.msg().deployment(opt.deployment);
  status.set(runtime::Lifecycle::Active, opt.continuous ? "waiting for a task" : "publishing references");

  TaskPlan plan(m, opt.continuous);
  bool pause_requested = false, draining = false;
  std::array<bool, 2> braked{false, false};
  long last_braked_tick = -1;
  std::array<long, 2> last{-1, -1};
  msg::TaskState ts;
  ts.module_id(opt.module);
  ts.deployment(opt.deployment);
  TaskStateCode reported = TaskStateCode::Idle;
  auto last_state_sent = std::chrono::steady_clock::now();
  // The module's state as the coordinator and the launcher see it.
  auto current_state = [&] {
    const long published = std::min(last[0], last[1]);
    const bool busy = opt.continuous ? plan.running() : !plan.motion_over(std::max(published, 0L));
    if (draining && !busy) return TaskStateCode::Left;
    if (plan.target_rate() == 0.0 && plan.paused_at(std::max(published, 0L))) return TaskStateCode::Paused;
    if (draining) return TaskStateCode::Draining;
    if (busy) return TaskStateCode::Running;
    return plan.done() > 0 ? TaskStateCode::Done : TaskStateCode::Idle;
  };
  auto publish_state = [&](bool force) {
    const TaskStateCode st = current_state();
    const auto now = std::chrono::steady_clock::now();
    if (!force && st == reported && now - last_state_sent < std::chrono::milliseconds(100)) return;
    ts.task_id(plan.task_id());
    ts.state(static_cast<uint8_t>(st));
    ts.tasks_done(plan.done());
    ts.tick(static_cast<uint64_t>(std::max(std::min(last[0], last[1]), 0L)));
    task_state.write(ts);
    if (st != reported) {
      static const char* names[] = {"idle", "running", "done", "paused", "draining", "left"};
      std::string detail = names[static_cast<int>(st)];
      if (st == TaskStateCode::Paused) detail += braked[0] || braked[1] ? " (arm braked)" : " (requested)";
      if (opt.continuous) detail += ", " + std::to_string(plan.done()) + " task(s) done";
      status.msg().detail(detail);
      status.publish();
    }
    reported = st;
    last_state_sent = now;
  };
  publish_state(true);

  msg::ArmSensors s;
  msg::ArmReference r;
  msg::TaskAssignment a;
  msg::ControlRequest req;
  auto last_input = std::chrono::steady_clock::now();
  while (!runtime::g_stop && (last[0] + 1 < m.steps || last[1] + 1 < m.steps)) {
    bool got = false;
    while (control.take(req)) {
      if (req.deployment() != opt.deployment || req.target() != opt.module) continue;
      if (req.command() == "pause") pause_requested = true;
      if (req.command() == "resume") pause_requested = false;
      if (req.command() == "drain") draining = true;
      if (req.command() == "pause" || req.command() == "resume" || req.command() == "drain") {
        std::printf("tandem-supervisor %s: %s requested\n", opt.module.c_str(), req.command().c_str());
        std::fflush(stdout);
      }
    }
    while (opt.continuous && assignments.take(a)) {
      if (a.module_id() != opt.module || a.task_id() <= plan.task_id() || plan.running() || draining) continue;
      const long start = std::max(last[0], last[1]) + 1;  // never change a published reference
      plan.assign(a.task_id(), a.waypoints(), start);
      status.msg().detail("task " + a.task_name());
      publish_state(true);
    }
    while (sensors.take(s)) {
      got = true;
      const int j = ctx.arm_index(s.arm_id());
      if (j < 0) continue;  // another module's arm
      braked[static_cast<size_t>(j)] = s.braked();
      if (braked[0] || braked[1]) last_braked_tick = static_cast<long>(s.tick());
      // Pause while an arm is braked or a pause is asked for; the change applies from the first tick not
      // yet published, so a published reference never changes.
      const long next = std::max(last[0], last[1]) + 1;
      if (braked[0] || braked[1]) {
        plan.set_rate(next, 0.0, kBrakeRamp);
      } else if (last_braked_tick >= 0 && static_cast<long>(s.tick()) - last_braked_tick < kReleaseSettleTicks) {
        // Just released: the new controller settles on the still reference first (no resume into a brake
        // that engages again).
      } else {
        plan.set_rate(next, pause_requested ? 0.0 : 1.0, kPauseRamp);
      }
      // The reference depends only on the planned path, so publish tick k and the next one: the robot then
      // holds the reference of tick k+1 before its sensor sample arrives (one DDS hop less per tick).
      const long k = static_cast<long>(s.tick());
      // A sample of a tick already answered is the world asking again (a robot joined late): answer again.
      // References depend only on the tick, so a repeat is identical.
      const long from = k <= last[static_cast<size_t>(j)] ? k : std::max(k, last[static_cast<size_t>(j)] + 1);
      for (long kk = from; kk <= std::min(k + 1, m.steps - 1); ++kk) {
        const model::ArmReference ref = model::arm_reference(j, plan.sample(kk), m.geometry, m.reference_force);
        r.arm_id(s.arm_id());
        r.tick(static_cast<uint64_t>(kk));
        for (int i = 0; i < 3; ++i) {
          r.x()[static_cast<size_t>(i)] = ref.x(i);
          r.xd()[static_cast<size_t>(i)] = ref.xd(i);
          r.xdd()[static_cast<size_t>(i)] = ref.xdd(i);
        }
        r.force(ref.force);
        refs.write(r);
        last[static_cast<size_t>(j)] = std::max(last[static_cast<size_t>(j)], kk);
      }
      if (opt.continuous && plan.finish_if_done(std::min(last[0], last[1]))) publish_state(true);
    }
    publish_state(false);
    if (reported == TaskStateCode::Left) {
      std::printf("tandem-supervisor %s: drained; the module leaves\n", opt.module.c_str());
      status.set(runtime::Lifecycle::Finalized, "drained");
      std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the state reach the coordinator
      return 0;
    }
    const auto now = std::chrono::steady_clock::now();
    if (got) last_input = now;
    if (std::chrono::duration<double>(now - last_input).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-supervisor %s: no sensor sample for %.1f s; stopping\n", opt.module.c_str(),
                   opt.timeout);
      status.set(runtime::Lifecycle::Error, "no sensor samples");
      return 4;
    }
    sensors.wait(0.01);
  }
  status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return 0;
}
