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
//
// Hot standby (--strength below 100): a standby supervisor reads the same samples and publishes the same
// references, marked with its rank (runtime::SupervisorRank: the latest epoch it led, then its strength); a
// robot keeps, per tick, the copy of the highest-ranked supervisor, so when the leader dies the robots go on
// with the standby's references with no gap. The standby makes the same decisions from the same inputs
// (requests, tasks, brakes), and adopts the leader's plan whenever it comes (SupervisorPlan: task, start
// tick, time-scale retargets, pause and drain flags), so its references are the same to the bit, and within
// a tick or two if the leader died before its latest plan arrived. When no reference of a higher-ranked
// supervisor has come for kTakeOverAfter (and kTakeOverTicks) while samples flow, it takes over the duties
// (task state, tasks from the coordinator, publishing its plan) in a new epoch, one above the highest heard.
// A leader that was only stalled (stopped, starved of CPU) comes back with its old epoch: it hears the new
// leader's higher rank, steps down and adopts its plan; its own stale references rank below the new ones, so
// no robot follows them. A leader that finds the world kTakeOverTicks past its own last answer (it was
// stalled, and a standby may have taken over) publishes nothing until it has heard the others at that tick.
#include <tandemPubSubTypes.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <thread>

#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;

namespace {

constexpr double kPauseRamp = 0.3;   // requested pause / resume [s]
constexpr double kBrakeRamp = 0.02;  // an arm braked: stop the path now [s]
constexpr long kReleaseSettleTicks = 200;  // both arms controlled again for this long before resuming
// A standby takes over when no reference of a stronger supervisor has come for this long while it publishes
// its own (samples flow). Longer than a scheduler stall of the leader is likely to be (the leader steps
// down if that is what it was); the robots do not wait for it: they already have the standby's references.
constexpr auto kTakeOverAfter = std::chrono::milliseconds(50);
constexpr long kTakeOverTicks = 20;
// Without ever having heard a stronger supervisor (it died before this one matched), this long: longer than
// discovery takes on a busy machine, so that a standby does not take a primary it has not found yet for dead.
constexpr auto kTakeOverAlone = std::chrono::milliseconds(6000);
// A leader that sees a sample kTakeOverTicks past its own last answer while other supervisors are about
// (one published a tick within kOthersRecentTicks of its own last answer: ticks, not wall time, which a
// stall distorts) was stalled: one may have taken over. It answers nothing and decides nothing until it
// has heard another supervisor's reference of that tick or later (or kSuspectMax has passed: the others
// are gone), then steps down if that one outranks it, else leads on.
constexpr long kOthersRecentTicks = 100;
constexpr auto kSuspectMax = std::chrono::milliseconds(200);
using Clock = std::chrono::steady_clock;

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
    build_path(rest_, waypoints);
    task_id_ = id;
    start_ = start;
    tau_start_ = scale_.at(time(start)).tau;
    running_ = true;
    ++version_;
  }
  /// The plan as a standby needs it (the latest 64 retargets of the time scale).
  void export_to(msg::SupervisorPlan& p) const {
    p.version(version_);
    p.task_id(task_id_);
    p.tasks_done(done_);
    p.running(running_);
    p.start_tick(start_);
    p.tau_start(tau_start_);
    for (int i = 0; i < 3; ++i) {
      p.rest()[static_cast<size_t>(i)] = rest_(i);
      p.path_start()[static_cast<size_t>(i)] = path_start_(i);
    }
    p.waypoints(waypoints_);
    p.breaks(scale_.export_breaks(64));
  }
  /// Adopts an active supervisor's plan; false (nothing changed) if it is malformed.
  bool import_from(const msg::SupervisorPlan& p) {
    const std::vector<double>& w = p.waypoints();
    if (w.size() % 4 != 0 || !runtime::all_finite(w) || !runtime::all_finite(p.rest()) ||
        !runtime::all_finite(p.path_start()) || !(p.tau_start() >= 0.0 && p.tau_start() < 1e9) ||
        p.start_tick() < 0 || p.start_tick() >= (1LL << 40) || p.state() > static_cast<uint8_t>(TaskStateCode::Left)) {
      return false;
    }
    for (size_t i = 3; i < w.size(); i += 4) {
      if (!(w[i] > 0.0)) return false;  // a waypoint's duration
    }
    model::TimeScale scale;
    if (!scale.restore(p.breaks())) return false;
    scale_ = scale;
    rest_ = model::Vec3(p.rest()[0], p.rest()[1], p.rest()[2]);
    build_path(model::Vec3(p.path_start()[0], p.path_start()[1], p.path_start()[2]), w);
    task_id_ = p.task_id();
    done_ = p.tasks_done();
    running_ = p.running();
    start_ = static_cast<long>(p.start_tick());
    tau_start_ = p.tau_start();
    version_ = p.version();
    return true;
  }
  uint64_t version() const { return version_; }
  /// True once every tick of the running task has been published (then the object rests at its end).
  bool finish_if_done(long published_min) {
    if (!running_ || published_min < start_ ||
        scale_.at(time(published_min)).tau - tau_start_ < path_.motion_end()) {
      return false;
    }
    running_ = false;
    rest_ = end_pose_;
    ++done_;
    ++version_;
    return true;
  }
  /// Scenario mode: the path's motion is over by tick k.
  bool motion_over(long k) const { return scale_.at(time(k)).tau >= m_.path.motion_end(); }
  /// From tick `from` (the first one not yet published) the path runs at `rate` (0 paused, 1 normal).
  void set_rate(long from, double rate, double ramp) {
    if (scale_.target() != rate) {
      scale_.retarget(time(from), rate, ramp);
      ++version_;
    }
  }
  double target_rate() const { return scale_.target(); }
  bool paused_at(long k) const { return scale_.target() == 0.0 && scale_.settled(time(k)); }
  bool running() const { return running_; }
  uint64_t task_id() const { return task_id_; }
  uint64_t done() const { return done_; }

 private:
  double time(long k) const { return static_cast<double>(k) * m_.period; }
  void build_path(const model::Vec3& from, const std::vector<double>& waypoints) {
    std::vector<model::ObjectPath::Segment> segs;
    for (size_t i = 0; i + 3 < waypoints.size(); i += 4) {
      segs.push_back({model::Vec3(waypoints[i], waypoints[i + 1], waypoints[i + 2]), waypoints[i + 3]});
    }
    path_ = model::ObjectPath(from, 0.0, segs);
    path_start_ = from;
    waypoints_ = waypoints;
    end_pose_ = segs.empty() ? from : segs.back().to;
  }
  const sim::ModuleSetup& m_;
  bool continuous_;
  model::TimeScale scale_;
  model::Vec3 rest_ = model::Vec3::Zero(), end_pose_ = model::Vec3::Zero(), path_start_ = model::Vec3::Zero();
  model::ObjectPath path_;
  std::vector<double> waypoints_;
  uint64_t task_id_ = 0, done_ = 0, version_ = 0;
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
  const bool started_as_standby = opt.strength != runtime::RoleOptions::kPrimaryStrength;
  const std::string self_id = opt.module + "/supervisor" + (started_as_standby ? "@" + std::to_string(opt.strength) : "");
  bus::Participant part(opt.domain, "supervisor/" + opt.module, opt.transport);
  bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors(part, bus::module_topic(bus::kSensorsTopic, opt.module), bus::TopicKind::Sensors);
  bus::Writer<msg::ArmReference, msg::ArmReferencePubSubType> refs(part, bus::module_topic(bus::kReferencesTopic, opt.module),
                                                                   bus::TopicKind::References);
  bus::Reader<msg::TaskAssignment, msg::TaskAssignmentPubSubType> assignments(part, bus::kTaskAssignmentTopic,
                                                                              bus::TopicKind::Task);
  bus::Writer<msg::TaskState, msg::TaskStatePubSubType> task_state(part, bus::kTaskStateTopic, bus::TopicKind::Task);
  bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType> control(part, bus::kControlTopic,
                                                                         bus::TopicKind::Control);
  bus::Writer<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plan_out(part, bus::kSupervisorPlanTopic,
                                                                           bus::TopicKind::Task);
  // Every supervisor listens to the others: their references say who leads and that it is alive, their
  // plans what it decided.
  bus::Reader<msg::ArmReference, msg::ArmReferencePubSubType> refs_in(part, bus::module_topic(bus::kReferencesTopic, opt.module),
                                                                      bus::TopicKind::References);
  bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plan_in(part, bus::kSupervisorPlanTopic, bus::TopicKind::Task);
  runtime::StatusPublisher status(part, self_id, "supervisor", opt.module);
  status.msg().deployment(opt.deployment);
  bool active = !started_as_standby;
  runtime::SupervisorRank my_rank{0, opt.strength};
  status.msg().serving(active ? "primary" : "standby");
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
  // The active supervisor's plan, for its standbys: on every change of the plan or of its flags.
  msg::SupervisorPlan plan_msg;
  plan_msg.module_id(opt.module);
  plan_msg.deployment(opt.deployment);
  plan_msg.supervisor_id(self_id);
  plan_msg.strength(opt.strength);
  uint64_t plan_sent_version = ~0ULL;
  bool plan_sent_pause = false, plan_sent_drain = false;
  uint8_t plan_sent_state = 255;
  auto publish_plan = [&](TaskStateCode st) {
    if (plan.version() == plan_sent_version && pause_requested == plan_sent_pause && draining == plan_sent_drain &&
        static_cast<uint8_t>(st) == plan_sent_state) {
      return;
    }
    plan.export_to(plan_msg);
    plan_msg.pause_requested(pause_requested);
    plan_msg.draining(draining);
    plan_msg.state(static_cast<uint8_t>(st));
    plan_out.write(plan_msg);
    plan_sent_version = plan.version();
    plan_sent_pause = pause_requested;
    plan_sent_drain = draining;
    plan_sent_state = static_cast<uint8_t>(st);
  };
  auto publish_state = [&](bool force) {
    if (!active) return;  // a standby's duties start when it takes over
    const TaskStateCode st = current_state();
    publish_plan(st);
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
  r.supervisor_id(self_id);
  r.strength(opt.strength);
  r.epoch(0);
  plan_msg.epoch(0);
  msg::ArmReference heard;
  msg::SupervisorPlan adopted;
  msg::TaskAssignment a;
  msg::ControlRequest req;
  const auto t_start = Clock::now();
  auto last_input = t_start;
  auto last_stronger = t_start;  // the latest reference of a higher-ranked supervisor
  long stronger_tick = -1;       // and the newest tick it published
  bool heard_stronger = false, heard_other = false, speaking = true;
  uint64_t max_epoch = 0;        // the highest epoch heard (a takeover starts the next one)
  // Rank of the leader whose plan this one follows: at first the primary (epoch 0, strength 100); only grows.
  runtime::SupervisorRank followed{0, runtime::RoleOptions::kPrimaryStrength};
  std::optional<msg::SupervisorPlan> latest_plan;  // the highest-ranked plan heard (adopted while standing by)
  auto last_answered = t_start - std::chrono::hours(1);  // the latest sample this one answered (published or not)
  long suspect_from = -1;  // a leader back from a stall: the tick it saw (-1: none), and since when
  auto suspect_since = t_start;
  long others_newest = -1;  // the newest tick another supervisor published
  auto rank_of = [](const auto& sample) {
    return runtime::SupervisorRank{sample.epoch(), static_cast<int32_t>(sample.strength())};
  };
  // Adopts the leader's plan; false if the module left with it (this one exits too).
  auto adopt = [&](const msg::SupervisorPlan& p, bool from_new_leader) {
    // From the same leader, never back to an older task than this one already started or finished on its
    // own (its plan may come a little after the assignment); a new leader's plan is the module's plan.
    if (!from_new_leader && (p.task_id() < plan.task_id() || (p.task_id() == plan.task_id() && p.tasks_done() < plan.done()))) {
      return true;
    }
    if (!plan.import_from(p)) {
      std::fprintf(stderr, "tandem-supervisor %s: a malformed plan from %s was ignored\n", self_id.c_str(),
                   p.supervisor_id().c_str());
      return true;
    }
    if (rank_of(p).outranks(followed)) followed = rank_of(p);
    pause_requested = p.pause_requested();
    draining = p.draining();
    if (p.state() == static_cast<uint8_t>(TaskStateCode::Left)) {
      std::printf("tandem-supervisor %s: %s drained the module; leaving with it\n", self_id.c_str(), p.supervisor_id().c_str());
      return false;
    }
    return true;
  };
  // Reads the other supervisors' references and plans; true if a higher-ranked one spoke. False in `stay`
  // if this one must leave (the leader drained the module).
  auto listen = [&](Clock::time_point now, bool& stay) {
    bool stronger = false;
    while (refs_in.take(heard)) {
      if (!runtime::valid_rank(heard.strength(), heard.epoch()) || heard.supervisor_id() == self_id) continue;
      heard_other = true;
      others_newest = std::max(others_newest, static_cast<long>(heard.tick()));
      max_epoch = std::max(max_epoch, static_cast<uint64_t>(heard.epoch()));
      if (rank_of(heard).outranks(my_rank)) {
        stronger = heard_stronger = true;
        last_stronger = now;
        stronger_tick = std::max(stronger_tick, static_cast<long>(heard.tick()));
      }
    }
    while (plan_in.take(adopted)) {
      if (adopted.module_id() != opt.module || !runtime::valid_rank(adopted.strength(), adopted.epoch()) ||
          adopted.supervisor_id() == self_id) {
        continue;
      }
      max_epoch = std::max(max_epoch, static_cast<uint64_t>(adopted.epoch()));
      const runtime::SupervisorRank rank = rank_of(adopted);
      if (!rank.outranks(my_rank) || followed.outranks(rank)) continue;  // below this one, or a former leader's
      if (latest_plan && rank_of(*latest_plan).outranks(rank)) continue;
      latest_plan = adopted;
      stronger = true;  // a leader that hears a higher-ranked plan steps down, references or not
      if (!active && !adopt(adopted, rank.outranks(followed))) stay = false;
    }
    return stronger;
  };
  auto leave = [&] {
    status.set(runtime::Lifecycle::Finalized, "drained");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return 0;
  };
  auto start_task = [&](const msg::TaskAssignment& t) {
    const long start = std::max(last[0], last[1]) + 1;  // never change a published reference
    plan.assign(t.task_id(), t.waypoints(), start);
    status.msg().detail("task " + t.task_name());
    publish_state(true);
  };
  while (!runtime::g_stop && (last[0] + 1 < m.steps || last[1] + 1 < m.steps)) {
    bool got = false;
    {
      // Who leads: first of all, so that a leader back from a stall decides nothing before it has heard
      // whether another took over meanwhile.
      const auto now = Clock::now();
      bool stay = true;
      const bool stronger = listen(now, stay);
      if (!stay) return leave();
      if (suspect_from >= 0 && !stronger && (others_newest >= suspect_from || now - suspect_since > kSuspectMax)) {
        std::printf("tandem-supervisor %s: %s; leading on\n", self_id.c_str(),
                    others_newest >= suspect_from ? "no other supervisor took over" : "no other supervisor heard");
        std::fflush(stdout);
        suspect_from = -1;
      }
      // Quiet: the ticks go on (this one has published kTakeOverTicks past the stronger one's newest) and
      // nothing has come from the stronger one for kTakeOverAfter. Ticks, not time alone: in lockstep a
      // world that waits re-publishes the same tick every 50 ms, and both supervisors answer it.
      const long mine = std::max(last[0], last[1]);
      const bool flowing = now - last_answered < kTakeOverAfter;
      const bool quiet = heard_stronger ? (now - last_stronger > kTakeOverAfter && mine - stronger_tick > kTakeOverTicks)
                                        : (now - t_start > kTakeOverAlone && mine > kTakeOverTicks);
      if (!active && flowing && quiet) {
        active = true;
        my_rank.epoch = max_epoch + 1;
        max_epoch = my_rank.epoch;
        r.epoch(my_rank.epoch);
        plan_msg.epoch(my_rank.epoch);
        plan_sent_version = ~0ULL;  // publish the plan now, under the new epoch
        latest_plan.reset();        // plans of the former leaders: never to be adopted again
        std::printf("tandem-supervisor %s: taking over in epoch %llu (%s) with plan version %llu: task %llu %s, "
                    "%llu done\n",
                    self_id.c_str(), static_cast<unsigned long long>(my_rank.epoch),
                    heard_stronger ? ("no reference from the leader for " +
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
        // A higher rank leads: a standby that took over in a later epoch while this one was stalled, or a
        // stronger one of the same epoch. It decides from now on; this one follows its plan.
        active = false;
        suspect_from = -1;
        std::printf("tandem-supervisor %s: stepping down: a higher-ranked supervisor leads%s\n", self_id.c_str(),
                    latest_plan ? (" (" + latest_plan->supervisor_id() + ", epoch " + std::to_string(latest_plan->epoch()) + ")").c_str() : "");
        std::fflush(stdout);
        // Adopt the new leader's plan if it is here already (else silent until it comes, see `speak`).
        if (latest_plan && latest_plan->epoch() >= max_epoch && !adopt(*latest_plan, true)) return leave();
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
    while (opt.continuous && suspect_from < 0 && assignments.take(a)) {
      // A standby starts the task too, at the tick the active one will most likely choose: should the
      // active one die before its plan arrives, the standby's path differs by a tick or two at most.
      if (a.module_id() != opt.module || a.task_id() <= plan.task_id() || plan.running() || draining) continue;
      start_task(a);
    }
    // A standby publishes only while it follows the current leader's plan: one that has heard of a newer
    // epoch than the plan it follows (a former leader back from a stall) is silent until that plan comes,
    // or until that leader too has gone quiet (then this one's ticks must flow for it to take over).
    const bool speak = active || followed.epoch >= max_epoch || (heard_stronger && Clock::now() - last_stronger > kTakeOverAfter);
    if (speak != speaking) {
      speaking = speak;
      std::printf("tandem-supervisor %s: %s\n", self_id.c_str(),
                  speak ? "following the leader's plan; publishing references again"
                        : "silent until the new leader's plan arrives (its references are ahead of this one's plan)");
      std::fflush(stdout);
    }
    while (sensors.take(s)) {
      got = true;
      const int j = ctx.arm_index(s.arm_id());
      if (j < 0) continue;  // another module's arm
      braked[static_cast<size_t>(j)] = s.braked();
      if (braked[0] || braked[1]) last_braked_tick = static_cast<long>(s.tick());
      const long answered = std::max(last[0], last[1]);
      if (active && suspect_from < 0 && answered >= 0 && static_cast<long>(s.tick()) > answered + kTakeOverTicks &&
          others_newest >= 0 && answered - others_newest < kOthersRecentTicks) {
        suspect_from = static_cast<long>(s.tick());
        suspect_since = Clock::now();
        std::printf("tandem-supervisor %s: the world is at tick %ld, %ld past this one's last answer (it was stalled); "
                    "silent until it hears whether another supervisor took over\n",
                    self_id.c_str(), suspect_from, suspect_from - answered);
        std::fflush(stdout);
      }
      if (suspect_from >= 0) continue;  // the others answer this tick
      // Pause while an arm is braked or a pause is asked for; the change applies from the first tick not
      // yet published, so a published reference never changes. (A standby decides the same from the same
      // samples; the active one's plan, when it comes, overrides.)
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
        if (speak) refs.write(r);
        last[static_cast<size_t>(j)] = std::max(last[static_cast<size_t>(j)], kk);
      }
      last_answered = Clock::now();
      if (opt.continuous && plan.finish_if_done(std::min(last[0], last[1]))) publish_state(true);
    }
    if (suspect_from < 0) publish_state(false);
    if (active && reported == TaskStateCode::Left) {
      std::printf("tandem-supervisor %s: drained; the module leaves\n", opt.module.c_str());
      status.set(runtime::Lifecycle::Finalized, "drained");
      std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the state reach the coordinator
      return 0;
    }
    const auto now = Clock::now();
    if (got) last_input = now;
    if (std::chrono::duration<double>(now - last_input).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-supervisor %s: no sensor sample for %.1f s; stopping\n", opt.module.c_str(),
                   opt.timeout);
      status.set(runtime::Lifecycle::Error, "no sensor samples");
      return 4;
    }
    sensors.wait(started_as_standby ? 0.005 : 0.01);
  }
  status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return 0;
}
