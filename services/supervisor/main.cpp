// tandem-supervisor: the supervisor of one basic module, off the per-tick path (docs/architecture.md,
// "Per-tick data flow"). Wiring only: supervisor::SupervisorCore (services/supervisor/include) holds the plan
// and the leadership rules described here; this process feeds it the world's reports, the other supervisors'
// plans, tasks and requests from DDS, and publishes its plan, task state and status. It makes the module's plan (plan::ModulePlan: the object path of the scenario or of
// the tasks the coordinator assigns, sampled through a time scale for pause and resume, eq. 15-16 evaluated
// by each robot) and publishes it when it changes and every 20 ms as a heartbeat; robots and the world
// evaluate it tick by tick themselves. It plans from the world's report (tandem/world_report: tick, brakes,
// lowest normal force, every 10 ticks and at once on a brake change): a change applies kLeadTicks after the
// newest tick heard, so it reaches the robots before its tick in real time (a plan that comes late is
// applied at once by the followers).
//
// Pause and resume: the module pauses when an arm is braked (no live controller) or when the launcher asks
// ("pause", for an unplug without a standby); it resumes when both arms have been controlled again for
// kReleaseSettleTicks and no pause is asked for. A requested pause ramps the object smoothly to rest (0.3 s); a
// braked arm stops the path fast (20 ms ramp). Drain: finish the task, take no new one, report "left", exit.
// Grasp watch (eq. 14): the world reports the lowest normal force of every 10 ticks; a value below h_sg is
// logged with its tick.
//
// Hot standby (--strength below 100): a standby reads the same reports, requests and tasks and makes the same
// decisions, and adopts every plan of a higher-ranked supervisor (plan::SupervisorRank: epoch, strength).
// When no plan has come from a higher-ranked supervisor for kTakeOverAfter while the world's ticks move on
// (kTakeOverTicks past the newest tick that one had heard), it takes over in a new epoch, one above the
// highest heard, and publishes its plan at once. Robots keep the highest-ranked plan, so a leader that was only
// stalled and comes back with its old epoch is ignored by them; it hears the new leader's plan and steps down.
// A leader that finds the world kTakeOverTicks past the newest tick it had heard (it was stalled) decides and
// publishes nothing until it has heard the others at that tick (or kSuspectMax has passed).
#include <tandemPubSubTypes.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "tandem/launcher/exit_codes.hpp"
#include "tandem/runtime/plan_wire.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/supervisor/supervisor_core.hpp"

using namespace tandem;
namespace bus = tandem::dds;

namespace {

int run(int argc, char** argv) {
  runtime::RoleOptions opt;
  runtime::RoleContext ctx;
  int code = 0;
  if (!runtime::start_role("supervisor", argc, argv, false, opt, ctx, code)) return code;
  const bool started_as_standby = opt.strength != runtime::RoleOptions::kPrimaryStrength;
  const std::string self_id = opt.module + "/supervisor" + (started_as_standby ? "@" + std::to_string(opt.strength) : "");
  auto now_ns = [] {
    return static_cast<int64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
  };
  bus::Participant part(opt.domain, "supervisor/" + opt.module, opt.transport);
  bus::Reader<msg::WorldReport, msg::WorldReportPubSubType> reports(part, bus::module_topic(bus::kWorldReportTopic, opt.module),
                                                                    bus::TopicKind::Task);
  bus::Reader<msg::TaskAssignment, msg::TaskAssignmentPubSubType> assignments(part, bus::kTaskAssignmentTopic,
                                                                              bus::TopicKind::Task);
  bus::Writer<msg::TaskState, msg::TaskStatePubSubType> task_state(part, bus::kTaskStateTopic, bus::TopicKind::Task);
  bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType> control(part, bus::kControlTopic,
                                                                         bus::TopicKind::Control);
  const std::string plan_topic = bus::module_topic(bus::kSupervisorPlanTopic, opt.module);
  bus::Writer<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plan_out(part, plan_topic, bus::TopicKind::Task);
  // Every supervisor listens to the others' plans: they say who leads, that it is alive, and what it decided.
  bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plan_in(part, plan_topic, bus::TopicKind::Task);
  runtime::StatusPublisher status(part, self_id, "supervisor", opt.module);
  status.msg().deployment(opt.deployment);

  supervisor::SupervisorOptions so;
  so.self_id = self_id;
  so.strength = opt.strength;
  so.continuous = opt.continuous;
  so.transient_s = ctx.scenario.transient;
  // Lockstep: the world waits for the leader's plan to have heard its recent ticks (world::WorldCore::
  // plan_lease_ok): a plan at every world report.
  so.lease_every = opt.realtime ? 0 : plan::kPlanLeaseTicks;
  supervisor::SupervisorCore core(ctx.module, so, now_ns());
  core.set_log([&](const std::string& line) {
    std::printf("tandem-supervisor %s: %s\n", self_id.c_str(), line.c_str());
    std::fflush(stdout);
  });
  status.msg().serving(core.active() ? msg::ROLE_PRIMARY : msg::ROLE_STANDBY);
  status.set(runtime::Lifecycle::Active, opt.continuous ? "waiting for a task" : "planning");
  if (runtime::raise_to_realtime_from_env(/*per_tick=*/false) < 0) std::fprintf(stderr, "tandem: could not raise to SCHED_FIFO once active\n");

  msg::TaskState ts;
  ts.module_id(opt.module);
  ts.deployment(opt.deployment);
  msg::SupervisorPlan plan_msg;
  plan_msg.module_id(opt.module);
  plan_msg.deployment(opt.deployment);
  msg::WorldReport rep;
  msg::SupervisorPlan heard;
  msg::TaskAssignment a;
  msg::ControlRequest req;
  bool was_active = core.active();
  auto last_report = std::chrono::steady_clock::now();
  auto last_status = std::chrono::steady_clock::now();
  auto publish = [&] {
    if (auto p = core.take_plan()) {
      runtime::to_wire(*p, plan_msg);
      plan_out.write(plan_msg);
    }
    if (auto st = core.take_state()) {
      ts.task_id(st->task_id);
      ts.state(st->state);
      ts.tasks_done(st->tasks_done);
      ts.tick(st->tick);
      task_state.write(ts);
    }
    if (core.active() != was_active) {
      was_active = core.active();
      status.msg().serving(was_active ? msg::ROLE_PRIMARY : msg::ROLE_STANDBY);
      status.publish();
    }
    if (auto d = core.take_detail()) {
      status.msg().detail(*d);
      status.publish();
      last_status = std::chrono::steady_clock::now();
    }
    // A heartbeat, as every process's status (about every 100 ms): observers (tandem soak) tell a live
    // supervisor from a dead one's last row by it.
    if (std::chrono::steady_clock::now() - last_status > std::chrono::milliseconds(100)) {
      status.publish();
      last_status = std::chrono::steady_clock::now();
    }
  };
  publish();
  while (!runtime::g_stop && !core.world_done() && !core.leaving()) {
    const int64_t now = now_ns();
    while (plan_in.take(heard)) {
      if (heard.module_id() == opt.module) core.on_plan(runtime::from_wire(heard), now);
    }
    while (control.take(req)) {
      if (req.deployment() != opt.deployment || req.target_kind() != msg::TARGET_MODULE || req.target() != opt.module) continue;
      using R = supervisor::SupervisorCore::Request;
      if (req.command() == msg::CMD_PAUSE) core.on_request(R::Pause);
      if (req.command() == msg::CMD_RESUME) core.on_request(R::Resume);
      if (req.command() == msg::CMD_DRAIN) core.on_request(R::Drain);
    }
    while (assignments.take(a)) {
      if (a.module_id() == opt.module) core.on_assignment(a.task_id(), a.task_name(), a.waypoints());
    }
    while (reports.take(rep)) {
      if (rep.module_id() != opt.module) continue;
      supervisor::ReportIn r;
      r.tick = static_cast<long>(rep.tick());
      r.braked = {rep.braked()[0], rep.braked()[1]};
      r.hold = rep.hold();
      r.braked_since = static_cast<long>(rep.braked_since());
      r.released_at = static_cast<long>(rep.released_at());
      r.normal_min = rep.normal_min();
      r.object_xy = model::Vec2(rep.object()[0], rep.object()[1]);
      r.object_known = true;
      r.failed = rep.failed();
      r.world_rank = {rep.plan_epoch(), static_cast<int32_t>(rep.plan_strength())};
      r.world_plan_version = rep.plan_version();
      core.on_report(r, now);
      last_report = std::chrono::steady_clock::now();
    }
    core.update(now);
    publish();
    if (core.deaf()) {
      // A leader lives (the world's plan kept changing) but this standby hears none of its plans: a fresh
      // participant may. Exit 6: the launcher restarts this supervisor alone, as a standby.
      std::fprintf(stderr, "tandem-supervisor %s: cannot hear the module's leader (the world's plan changed while this "
                   "standby heard none of it); exiting, to come back with a fresh participant\n", opt.module.c_str());
      status.set(runtime::Lifecycle::Error, "cannot hear the leader");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return launcher::exit_code::kCutOff;
    }
    if (core.no_plan()) {
      // Never heard a leader and cannot lead the moved object with the initial plan: the module has lost its
      // plan. Exit 5: the launcher restarts the module (docs/architecture.md, "Hot standby (supervisors)").
      std::fprintf(stderr, "tandem-supervisor %s: no plan to follow (never heard a leader, and the object is not where "
                   "the initial plan has it); the module must be restarted\n", opt.module.c_str());
      status.set(runtime::Lifecycle::Error, "no plan to follow");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return launcher::exit_code::kLostPlan;
    }
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - last_report).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-supervisor %s: no report from the world for %.1f s; stopping\n", opt.module.c_str(),
                   opt.timeout);
      status.set(runtime::Lifecycle::Error, "no world reports");
      return launcher::exit_code::kNoInput;
    }
    reports.wait(0.01);
  }
  if (core.leaving()) {
    status.set(runtime::Lifecycle::Finalized, "drained");
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the state reach the coordinator
    return launcher::exit_code::kDone;
  }
  status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return launcher::exit_code::kDone;
}

}  // namespace

int main(int argc, char** argv) { return runtime::run_guarded("tandem-supervisor", run, argc, argv); }
