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
#include <optional>
#include <thread>

#include "tandem/launcher/exit_codes.hpp"
#include "tandem/runtime/plan_wire.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/supervisor/supervisor_core.hpp"

using namespace tandem;
namespace bus = tandem::dds;

namespace {

using Clock = std::chrono::steady_clock;

int64_t now_ns() {
  return static_cast<int64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count());
}

std::string self_id_of(const runtime::RoleOptions& opt) {
  const bool standby = opt.strength != runtime::RoleOptions::kPrimaryStrength;
  return opt.module + "/supervisor" + (standby ? "@" + std::to_string(opt.strength) : "");
}

supervisor::SupervisorOptions supervisor_options(const runtime::RoleOptions& opt, const runtime::RoleContext& ctx) {
  supervisor::SupervisorOptions so;
  so.self_id = self_id_of(opt);
  so.strength = opt.strength;
  so.continuous = opt.continuous;
  so.transient_s = ctx.scenario.transient;
  // Lockstep: the world waits for the leader's plan to have heard its recent ticks (world::WorldCore::
  // plan_lease_ok): a plan at every world report.
  so.lease_every = opt.realtime ? 0 : plan::kPlanLeaseTicks;
  return so;
}

/// A world report as the core reads it.
supervisor::ReportIn report_in(const msg::WorldReport& rep) {
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
  return r;
}

/// One supervisor process: its DDS endpoints, its core, and the loop's steps.
class SupervisorProcess {
 public:
  SupervisorProcess(const runtime::RoleOptions& opt, const runtime::RoleContext& ctx)
      : opt_(opt), self_id_(self_id_of(opt)), part_(opt.domain, "supervisor/" + opt.module, opt.transport),
        reports_(part_, bus::module_topic(bus::kWorldReportTopic, opt.module), bus::TopicKind::Task),
        assignments_(part_, bus::kTaskAssignmentTopic, bus::TopicKind::Task),
        task_state_(part_, bus::kTaskStateTopic, bus::TopicKind::Task),
        control_(part_, bus::kControlTopic, bus::TopicKind::Control),
        plan_out_(part_, bus::module_topic(bus::kSupervisorPlanTopic, opt.module), bus::TopicKind::Task),
        // Every supervisor listens to the others' plans: they say who leads, that it is alive, and what it decided.
        plan_in_(part_, bus::module_topic(bus::kSupervisorPlanTopic, opt.module), bus::TopicKind::Task),
        status_(part_, self_id_, "supervisor", opt.module), core_(ctx.module, supervisor_options(opt, ctx), now_ns()) {
    status_.msg().deployment(opt.deployment);
    core_.set_log([this](const std::string& line) {
      std::printf("tandem-supervisor %s: %s\n", self_id_.c_str(), line.c_str());
      std::fflush(stdout);
    });
    ts_.module_id(opt.module);
    ts_.deployment(opt.deployment);
    plan_msg_.module_id(opt.module);
    plan_msg_.deployment(opt.deployment);
    was_active_ = core_.active();
  }

  int run() {
    status_.msg().serving(core_.active() ? msg::ROLE_PRIMARY : msg::ROLE_STANDBY);
    status_.set(runtime::Lifecycle::Active, opt_.continuous ? "waiting for a task" : "planning");
    if (runtime::raise_to_realtime_from_env(/*per_tick=*/false) < 0) {
      std::fprintf(stderr, "tandem: could not raise to SCHED_FIFO once active\n");
    }
    publish();
    while (!runtime::g_stop && !core_.world_done() && !core_.leaving()) {
      const int64_t now = now_ns();
      take_inputs(now);
      core_.update(now);
      publish();
      if (const std::optional<int> code = exit_code()) return *code;
      reports_.wait(0.01);
    }
    if (core_.leaving()) {
      status_.set(runtime::Lifecycle::Finalized, "drained");
      std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the state reach the coordinator
      return launcher::exit_code::kDone;
    }
    status_.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return launcher::exit_code::kDone;
  }

 private:
  void take_inputs(int64_t now) {
    while (plan_in_.take(heard_)) {
      if (heard_.module_id() == opt_.module) core_.on_plan(runtime::from_wire(heard_), now);
    }
    while (control_.take(req_)) {
      if (req_.deployment() != opt_.deployment || req_.target_kind() != msg::TARGET_MODULE || req_.target() != opt_.module) {
        continue;
      }
      using R = supervisor::SupervisorCore::Request;
      if (req_.command() == msg::CMD_PAUSE) core_.on_request(R::Pause);
      if (req_.command() == msg::CMD_RESUME) core_.on_request(R::Resume);
      if (req_.command() == msg::CMD_DRAIN) core_.on_request(R::Drain);
    }
    while (assignments_.take(a_)) {
      if (a_.module_id() == opt_.module) core_.on_assignment(a_.task_id(), a_.task_name(), a_.waypoints());
    }
    while (reports_.take(rep_)) {
      if (rep_.module_id() != opt_.module) continue;
      core_.on_report(report_in(rep_), now);
      last_report_ = Clock::now();
    }
  }

  void publish() {
    if (auto p = core_.take_plan()) {
      runtime::to_wire(*p, plan_msg_);
      plan_out_.write(plan_msg_);
    }
    if (auto st = core_.take_state()) {
      ts_.task_id(st->task_id);
      ts_.state(st->state);
      ts_.tasks_done(st->tasks_done);
      ts_.tick(st->tick);
      task_state_.write(ts_);
    }
    if (core_.active() != was_active_) {
      was_active_ = core_.active();
      status_.msg().serving(was_active_ ? msg::ROLE_PRIMARY : msg::ROLE_STANDBY);
      status_.publish();
    }
    if (auto d = core_.take_detail()) {
      status_.msg().detail(*d);
      status_.publish();
      last_status_ = Clock::now();
    }
    // A heartbeat, as every process's status (about every 100 ms): observers (tandem soak) tell a live supervisor
    // from a dead one's last row by it.
    if (Clock::now() - last_status_ > std::chrono::milliseconds(100)) {
      status_.publish();
      last_status_ = Clock::now();
    }
  }

  /// The process's exit, when the core or the world's silence says so.
  std::optional<int> exit_code() {
    if (core_.deaf()) {
      // A leader lives (the world's plan kept changing) but this standby hears none of its plans: a fresh
      // participant may. Exit 6: the launcher restarts this supervisor alone, as a standby.
      std::fprintf(stderr, "tandem-supervisor %s: cannot hear the module's leader (the world's plan changed while this "
                   "standby heard none of it); exiting, to come back with a fresh participant\n", opt_.module.c_str());
      status_.set(runtime::Lifecycle::Error, "cannot hear the leader");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return launcher::exit_code::kCutOff;
    }
    if (core_.no_plan()) {
      // Never heard a leader and cannot lead the moved object with the initial plan: the module has lost its
      // plan. Exit 5: the launcher restarts the module (docs/architecture.md, "Hot standby (supervisors)").
      std::fprintf(stderr, "tandem-supervisor %s: no plan to follow (never heard a leader, and the object is not where "
                   "the initial plan has it); the module must be restarted\n", opt_.module.c_str());
      status_.set(runtime::Lifecycle::Error, "no plan to follow");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return launcher::exit_code::kLostPlan;
    }
    if (std::chrono::duration<double>(Clock::now() - last_report_).count() > opt_.timeout) {
      std::fprintf(stderr, "tandem-supervisor %s: no report from the world for %.1f s; stopping\n", opt_.module.c_str(),
                   opt_.timeout);
      status_.set(runtime::Lifecycle::Error, "no world reports");
      return launcher::exit_code::kNoInput;
    }
    return std::nullopt;
  }

  const runtime::RoleOptions& opt_;
  std::string self_id_;
  bus::Participant part_;
  bus::Reader<msg::WorldReport, msg::WorldReportPubSubType> reports_;
  bus::Reader<msg::TaskAssignment, msg::TaskAssignmentPubSubType> assignments_;
  bus::Writer<msg::TaskState, msg::TaskStatePubSubType> task_state_;
  bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType> control_;
  bus::Writer<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plan_out_;
  bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plan_in_;
  runtime::StatusPublisher status_;
  supervisor::SupervisorCore core_;
  msg::TaskState ts_;
  msg::SupervisorPlan plan_msg_, heard_;
  msg::WorldReport rep_;
  msg::TaskAssignment a_;
  msg::ControlRequest req_;
  bool was_active_ = false;
  Clock::time_point last_report_ = Clock::now(), last_status_ = Clock::now();
};

int run(int argc, char** argv) {
  runtime::RoleOptions opt;
  runtime::RoleContext ctx;
  int code = 0;
  if (!runtime::start_role("supervisor", argc, argv, false, opt, ctx, code)) return code;
  SupervisorProcess p(opt, ctx);
  return runtime::bound_teardown("tandem-supervisor", p.run());  // (then its DDS teardown, bounded)
}

}  // namespace

int main(int argc, char** argv) { return runtime::run_guarded("tandem-supervisor", run, argc, argv); }
