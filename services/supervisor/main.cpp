// tandem-supervisor: the supervisor of one basic module, off the per-tick path (docs/architecture.md,
// "Per-tick data flow"). It makes the module's plan (plan::ModulePlan: the object path of the scenario or of
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

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <thread>

#include "tandem/runtime/plan_wire.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;
using plan::TaskStateCode;

namespace {

constexpr double kPauseRamp = 0.3;   // requested pause / resume [s]
constexpr double kBrakeRamp = 0.02;  // an arm braked: stop the path now [s]
// Overload (the world's report says hold): stop the path smoothly, from a few ticks ahead; the world brakes
// both arms once the object is still. A 0.15 s smoothstep from 0.19 m/s (the paper task's top speed) needs
// about 2 m/s^2, 4 N on the 2 kg object, well inside the grasp's friction margin, and a plan that reaches a
// robot a few ticks late changes its reference by micrometres (the ramp starts flat).
constexpr double kHoldRamp = 0.15;
constexpr long kHoldLeadTicks = 5;
constexpr long kReleaseSettleTicks = 200;  // both arms controlled again for this long before resuming
// A change of the plan applies this many ticks after the newest tick heard from the world: the world
// reports every 10 ticks, and plan delivery takes well under a tick, so in real time the robots hold the
// change before its tick.
constexpr long kLeadTicks = 20;
constexpr auto kHeartbeat = std::chrono::milliseconds(20);
// A standby takes over when no plan of a stronger supervisor has come for this long (the leader's heartbeat
// is 20 ms) while the world's ticks flow, and kTakeOverTicks past the newest tick the stronger one had heard.
constexpr auto kTakeOverAfter = std::chrono::milliseconds(50);
constexpr long kTakeOverTicks = 20;
// Without ever having heard a stronger supervisor (it died before this one matched), this long: longer than
// discovery takes on a busy machine, so that a standby does not take a primary it has not found yet for dead.
constexpr auto kTakeOverAlone = std::chrono::milliseconds(6000);
constexpr long kOthersRecentTicks = 100;
constexpr auto kSuspectMax = std::chrono::milliseconds(200);
using Clock = std::chrono::steady_clock;

}  // namespace

int main(int argc, char** argv) {
  runtime::RoleOptions opt;
  runtime::RoleContext ctx;
  int code = 0;
  if (!runtime::start_role("supervisor", argc, argv, false, opt, ctx, code)) return code;
  const sim::ModuleSetup& m = ctx.module;
  const bool started_as_standby = opt.strength != runtime::RoleOptions::kPrimaryStrength;
  const std::string self_id = opt.module + "/supervisor" + (started_as_standby ? "@" + std::to_string(opt.strength) : "");
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
  bool active = !started_as_standby;
  runtime::SupervisorRank my_rank{0, opt.strength};
  status.msg().serving(active ? "primary" : "standby");
  status.set(runtime::Lifecycle::Active, opt.continuous ? "waiting for a task" : "planning");

  plan::ModulePlan plan(m, opt.continuous);
  bool pause_requested = false, draining = false;
  std::array<bool, 2> braked{false, false};
  bool hold = false;  // the world asks for the path to stop (overload), before it brakes
  long braked_since = -1, released_at = -1;
  long heard_tick = -1;
  model::Vec2 object_xy = model::Vec2::Zero();
  long rebased_for = -1;  // the braking whose object pose the plan was rebased to  // the newest tick the world reported
  msg::TaskState ts;
  ts.module_id(opt.module);
  ts.deployment(opt.deployment);
  TaskStateCode reported = TaskStateCode::Idle;
  auto last_state_sent = Clock::now();
  auto current_state = [&] {
    const long k = std::max(heard_tick, 0L);
    const bool busy = opt.continuous ? plan.running() : !plan.motion_over(k);
    if (draining && !busy) return TaskStateCode::Left;
    if (plan.target_rate() == 0.0 && plan.paused_at(k)) return TaskStateCode::Paused;
    if (draining) return TaskStateCode::Draining;
    if (busy) return TaskStateCode::Running;
    return plan.done() > 0 ? TaskStateCode::Done : TaskStateCode::Idle;
  };
  // The plan on the wire: on every change, and every kHeartbeat while leading.
  plan::PlanData plan_data;
  plan_data.supervisor_id = self_id;
  plan_data.strength = opt.strength;
  msg::SupervisorPlan plan_msg;
  plan_msg.module_id(opt.module);
  plan_msg.deployment(opt.deployment);
  uint64_t plan_sent_version = ~0ULL;
  bool plan_sent_pause = false, plan_sent_drain = false;
  uint8_t plan_sent_state = 255;
  auto plan_sent_at = Clock::now() - std::chrono::hours(1);
  auto publish_plan = [&](TaskStateCode st, bool heartbeat) {
    const bool changed = plan.version() != plan_sent_version || pause_requested != plan_sent_pause ||
                         draining != plan_sent_drain || static_cast<uint8_t>(st) != plan_sent_state;
    if (!changed && !(heartbeat && Clock::now() - plan_sent_at >= kHeartbeat)) return;
    plan.export_to(plan_data);
    plan_data.epoch = my_rank.epoch;
    plan_data.pause_requested = pause_requested;
    plan_data.draining = draining;
    plan_data.state = static_cast<uint8_t>(st);
    plan_data.heard_tick = heard_tick;
    runtime::to_wire(plan_data, plan_msg);
    plan_out.write(plan_msg);
    plan_sent_version = plan.version();
    plan_sent_pause = pause_requested;
    plan_sent_drain = draining;
    plan_sent_state = static_cast<uint8_t>(st);
    plan_sent_at = Clock::now();
  };
  auto publish_state = [&](bool force) {
    if (!active) return;  // a standby's duties start when it takes over
    const TaskStateCode st = current_state();
    publish_plan(st, true);
    const auto now = Clock::now();
    if (!force && st == reported && now - last_state_sent < std::chrono::milliseconds(100)) return;
    ts.task_id(plan.task_id());
    ts.state(static_cast<uint8_t>(st));
    ts.tasks_done(plan.done());
    ts.tick(static_cast<uint64_t>(std::max(heard_tick, 0L)));
    task_state.write(ts);
    if (st != reported) {
      static const char* names[] = {"idle", "running", "done", "paused", "draining", "left"};
      std::string detail = names[static_cast<int>(st)];
      if (st == TaskStateCode::Paused) detail += hold ? " (for load)" : braked[0] || braked[1] ? " (arm braked)" : " (requested)";
      if (opt.continuous) detail += ", " + std::to_string(plan.done()) + " task(s) done";
      status.msg().detail(detail);
      status.publish();
    }
    reported = st;
    last_state_sent = now;
  };
  publish_state(true);

  msg::WorldReport rep;
  msg::SupervisorPlan adopted;
  msg::TaskAssignment a;
  msg::ControlRequest req;
  const auto t_start = Clock::now();
  auto last_report = t_start;
  auto last_stronger = t_start;  // the latest plan of a higher-ranked supervisor
  long stronger_tick = -1;       // and the newest world tick it had heard
  bool heard_stronger = false;
  uint64_t max_epoch = 0;        // the highest epoch heard (a takeover starts the next one)
  // Rank of the leader whose plan this one follows: at first the primary (epoch 0, strength 100); only grows.
  runtime::SupervisorRank followed{0, runtime::RoleOptions::kPrimaryStrength};
  std::optional<msg::SupervisorPlan> latest_plan;  // the highest-ranked plan heard
  long suspect_from = -1;  // a leader back from a stall: the tick it saw (-1: none), and since when
  auto suspect_since = t_start;
  long others_newest = -1;  // the newest world tick another supervisor had heard
  long low_force_reported = -1;
  // Adopts the leader's plan; false if the module left with it (this one exits too).
  auto adopt = [&](const msg::SupervisorPlan& p, bool from_new_leader) {
    if (!from_new_leader && (p.task_id() < plan.task_id() || (p.task_id() == plan.task_id() && p.tasks_done() < plan.done()))) {
      return true;  // never back to an older task than this one already started or finished on its own
    }
    if (!plan.import_from(runtime::from_wire(p))) {
      std::fprintf(stderr, "tandem-supervisor %s: a malformed plan from %s was ignored\n", self_id.c_str(),
                   p.supervisor_id().c_str());
      return true;
    }
    const runtime::SupervisorRank r{p.epoch(), static_cast<int32_t>(p.strength())};
    if (r.outranks(followed)) followed = r;
    pause_requested = p.pause_requested();
    draining = p.draining();
    if (p.state() == static_cast<uint8_t>(TaskStateCode::Left)) {
      std::printf("tandem-supervisor %s: %s drained the module; leaving with it\n", self_id.c_str(), p.supervisor_id().c_str());
      return false;
    }
    return true;
  };
  // Reads the other supervisors' plans; true if a higher-ranked one spoke. `stay` false: the module left.
  auto listen = [&](Clock::time_point now, bool& stay) {
    bool stronger = false;
    while (plan_in.take(adopted)) {
      if (!runtime::valid_rank(adopted.strength(), adopted.epoch()) || adopted.supervisor_id() == self_id) continue;
      others_newest = std::max(others_newest, static_cast<long>(adopted.heard_tick()));
      max_epoch = std::max(max_epoch, static_cast<uint64_t>(adopted.epoch()));
      const runtime::SupervisorRank rank{adopted.epoch(), static_cast<int32_t>(adopted.strength())};
      if (!rank.outranks(my_rank)) continue;
      heard_stronger = true;
      last_stronger = now;
      stronger_tick = std::max(stronger_tick, static_cast<long>(adopted.heard_tick()));
      stronger = true;
      if (followed.outranks(rank)) continue;  // a former leader's
      const bool newer = !latest_plan || rank.outranks(runtime::SupervisorRank{latest_plan->epoch(), static_cast<int32_t>(latest_plan->strength())}) ||
                         adopted.version() != latest_plan->version();
      if (!newer) continue;  // a heartbeat of the plan already adopted
      latest_plan = adopted;
      if (!active && !adopt(adopted, rank.outranks(followed))) stay = false;
    }
    return stronger;
  };
  auto leave = [&] {
    status.set(runtime::Lifecycle::Finalized, "drained");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return 0;
  };
  bool world_done = false;
  while (!runtime::g_stop && !world_done) {
    const auto now = Clock::now();
    {
      // Who leads: first of all, so that a leader back from a stall decides nothing before it has heard
      // whether another took over meanwhile.
      bool stay = true;
      const bool stronger = listen(now, stay);
      if (!stay) return leave();
      if (suspect_from >= 0 && !stronger && (others_newest >= suspect_from || now - suspect_since > kSuspectMax)) {
        std::printf("tandem-supervisor %s: %s; leading on\n", self_id.c_str(),
                    others_newest >= suspect_from ? "no other supervisor took over" : "no other supervisor heard");
        std::fflush(stdout);
        suspect_from = -1;
      }
      const bool flowing = now - last_report < kTakeOverAfter;
      const bool quiet = heard_stronger ? (now - last_stronger > kTakeOverAfter && heard_tick - stronger_tick > kTakeOverTicks)
                                        : (now - t_start > kTakeOverAlone && heard_tick > kTakeOverTicks);
      if (!active && flowing && quiet) {
        active = true;
        my_rank.epoch = max_epoch + 1;
        max_epoch = my_rank.epoch;
        plan_sent_version = ~0ULL;  // publish the plan now, under the new epoch
        latest_plan.reset();
        std::printf("tandem-supervisor %s: taking over in epoch %llu (%s) with plan version %llu: task %llu %s, "
                    "%llu done\n",
                    self_id.c_str(), static_cast<unsigned long long>(my_rank.epoch),
                    heard_stronger ? ("no plan from the leader for " +
                                      std::to_string(std::lround(std::chrono::duration<double, std::milli>(now - last_stronger).count())) + " ms")
                                         .c_str()
                                   : "never heard a leader",
                    static_cast<unsigned long long>(plan.version()), static_cast<unsigned long long>(plan.task_id()),
                    plan.running() ? "running" : "not running", static_cast<unsigned long long>(plan.done()));
        std::fflush(stdout);
        status.msg().serving("primary");
        reported = TaskStateCode::Idle;
        publish_state(true);
      } else if (active && stronger) {
        active = false;
        suspect_from = -1;
        std::printf("tandem-supervisor %s: stepping down: a higher-ranked supervisor leads%s\n", self_id.c_str(),
                    latest_plan ? (" (" + latest_plan->supervisor_id() + ", epoch " + std::to_string(latest_plan->epoch()) + ")").c_str() : "");
        std::fflush(stdout);
        if (latest_plan && !adopt(*latest_plan, true)) return leave();
        status.msg().serving("standby");
        status.publish();
      }
    }
    while (control.take(req)) {
      if (req.deployment() != opt.deployment || req.target() != opt.module) continue;
      if (req.command() == "pause") pause_requested = true;
      if (req.command() == "resume") pause_requested = false;
      if (req.command() == "drain") draining = true;
      if (req.command() == "pause" || req.command() == "resume" || req.command() == "drain") {
        std::printf("tandem-supervisor %s: %s requested\n", self_id.c_str(), req.command().c_str());
        std::fflush(stdout);
      }
    }
    bool got = false;
    while (reports.take(rep)) {
      if (rep.module_id() != opt.module) continue;
      got = true;
      const long k = static_cast<long>(rep.tick());
      if (active && suspect_from < 0 && heard_tick >= 0 && k > heard_tick + kTakeOverTicks && others_newest >= 0 &&
          heard_tick - others_newest < kOthersRecentTicks) {
        suspect_from = k;
        suspect_since = now;
        std::printf("tandem-supervisor %s: the world is at tick %ld, %ld past the newest this one had heard (it was "
                    "stalled); silent until it hears whether another supervisor took over\n",
                    self_id.c_str(), k, k - heard_tick);
        std::fflush(stdout);
      }
      heard_tick = std::max(heard_tick, k);
      braked = {rep.braked()[0], rep.braked()[1]};
      hold = rep.hold();
      object_xy = model::Vec2(rep.object()[0], rep.object()[1]);
      braked_since = static_cast<long>(rep.braked_since());
      released_at = static_cast<long>(rep.released_at());
      if (rep.normal_min() < m.safe_grasp_force && k > static_cast<long>(ctx.scenario.transient / m.period) &&
          k - low_force_reported > 1000) {
        low_force_reported = k;  // eq. (14) violated: at most one line a second
        std::printf("tandem-supervisor %s: grasp below the safe force at tick %ld: %.2f N < h_sg %.2f N\n",
                    self_id.c_str(), k, rep.normal_min(), m.safe_grasp_force);
        std::fflush(stdout);
      }
    }
    if (got) last_report = now;
    if (heard_tick >= 0 && suspect_from < 0) {
      // Pause while an arm is braked or a pause is asked for, from kLeadTicks after the newest tick heard.
      // A braking stops the path from the tick it began (the robots of a braked arm hold still anyway).
      const long next = heard_tick + kLeadTicks;
      if (braked[0] && braked[1] && hold && braked_since != rebased_for && plan.target_rate() == 0.0 &&
          plan.paused_at(heard_tick)) {
        // Paused for load, both arms braked: the brakes may have stopped the object before the path did.
        // Rebase the path to where the object is, so that the robots resume from it (not from a jump).
        rebased_for = braked_since;
        const double back = plan.rebase_to(heard_tick + kLeadTicks, object_xy);
        if (back > 0.0) {
          std::printf("tandem-supervisor %s: path rebased %.0f ms back, to where the braked object stands\n",
                      self_id.c_str(), back * 1e3);
          std::fflush(stdout);
        }
      }
      if (braked[0] || braked[1]) {
        plan.set_rate(std::max(braked_since, 0L), 0.0, hold ? kHoldRamp : kBrakeRamp);
      } else if (hold) {
        plan.set_rate(heard_tick + kHoldLeadTicks, 0.0, kHoldRamp);
      } else if (released_at >= 0 && heard_tick - released_at < kReleaseSettleTicks) {
        // Just released: the new controller settles on the still reference first.
      } else {
        plan.set_rate(next, pause_requested ? 0.0 : 1.0, kPauseRamp);
      }
      while (opt.continuous && assignments.take(a)) {
        // A standby starts the task too, at the tick the active one will most likely choose.
        if (a.module_id() != opt.module || a.task_id() <= plan.task_id() || plan.running() || draining) continue;
        plan.assign(a.task_id(), a.waypoints(), next);
        status.msg().detail("task " + a.task_name());
        publish_state(true);
      }
      if (opt.continuous && plan.finish_if_done(heard_tick)) publish_state(true);
      publish_state(false);
      if (!opt.continuous && heard_tick + 1 >= m.steps) world_done = true;
    }
    if (active && reported == TaskStateCode::Left) {
      std::printf("tandem-supervisor %s: drained; the module leaves\n", opt.module.c_str());
      status.set(runtime::Lifecycle::Finalized, "drained");
      std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the state reach the coordinator
      return 0;
    }
    if (std::chrono::duration<double>(now - last_report).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-supervisor %s: no report from the world for %.1f s; stopping\n", opt.module.c_str(),
                   opt.timeout);
      status.set(runtime::Lifecycle::Error, "no world reports");
      return 4;
    }
    reports.wait(0.01);
  }
  status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return 0;
}
