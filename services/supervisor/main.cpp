// tandem-supervisor: the supervisor of one basic module. For every sensor sample of tick k it publishes that
// arm's references for ticks k and k+1 (eq. 15 on the planned object path) with the grasp force h_ref
// (eq. 16). The path is the scenario's task, or, with --continuous, the tasks the coordinator assigns: each
// starts where the previous one left the object, at the first tick not yet published; between tasks the
// object is held still. The module's task state is published for the coordinator.
#include <tandemPubSubTypes.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;

namespace {

// The object's planned pose as a function of the tick: the scenario's path, or a chain of assigned tasks.
class TaskPlan {
 public:
  TaskPlan(const sim::ModuleSetup& m, bool continuous) : m_(m), continuous_(continuous) {
    rest_ = m.path.sample(0.0).pose;
  }
  model::PoseSample sample(long k) const {
    if (!continuous_) return m_.path.sample(static_cast<double>(k) * m_.period);
    if (task_id_ == 0 || k < start_) {
      model::PoseSample p;
      p.pose = rest_;
      return p;
    }
    return path_.sample(static_cast<double>(k - start_) * m_.period);
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
    end_tick_ = start + static_cast<long>(std::ceil(path_.motion_end() / m_.period));
    running_ = true;
  }
  /// True once every tick of the running task has been published (then the object rests at its end).
  bool finish_if_done(long published_min) {
    if (!running_ || published_min < end_tick_) return false;
    running_ = false;
    rest_ = end_pose_;
    ++done_;
    return true;
  }
  bool running() const { return running_; }
  uint64_t task_id() const { return task_id_; }
  uint64_t done() const { return done_; }

 private:
  const sim::ModuleSetup& m_;
  bool continuous_;
  model::Vec3 rest_ = model::Vec3::Zero(), end_pose_ = model::Vec3::Zero();
  model::ObjectPath path_;
  uint64_t task_id_ = 0, done_ = 0;
  long start_ = 0, end_tick_ = 0;
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
  runtime::StatusPublisher status(part, opt.module + "/supervisor", "supervisor", opt.module);
  status.msg().deployment(opt.deployment);
  status.set(runtime::Lifecycle::Active, opt.continuous ? "waiting for a task" : "publishing references");

  TaskPlan plan(m, opt.continuous);
  msg::TaskState ts;
  ts.module_id(opt.module);
  auto publish_state = [&](uint8_t state, long tick) {
    ts.task_id(plan.task_id());
    ts.state(state);
    ts.tasks_done(plan.done());
    ts.tick(static_cast<uint64_t>(std::max(tick, 0L)));
    task_state.write(ts);
  };
  if (opt.continuous) publish_state(0, 0);

  msg::ArmSensors s;
  msg::ArmReference r;
  msg::TaskAssignment a;
  std::array<long, 2> last{-1, -1};
  auto last_input = std::chrono::steady_clock::now();
  while (!runtime::g_stop && (last[0] + 1 < m.steps || last[1] + 1 < m.steps)) {
    bool got = false;
    while (opt.continuous && assignments.take(a)) {
      if (a.module_id() != opt.module || a.task_id() <= plan.task_id() || plan.running()) continue;
      const long start = std::max(last[0], last[1]) + 1;  // never change a published reference
      plan.assign(a.task_id(), a.waypoints(), start);
      publish_state(1, start);
      status.msg().detail("task " + a.task_name());
      status.publish();
    }
    while (sensors.take(s)) {
      got = true;
      const int j = ctx.arm_index(s.arm_id());
      if (j < 0) continue;  // another module's arm
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
      if (opt.continuous && plan.finish_if_done(std::min(last[0], last[1]))) {
        publish_state(2, std::min(last[0], last[1]));
        status.msg().detail("idle, " + std::to_string(plan.done()) + " task(s) done");
        status.publish();
      }
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
