// tandem-world: the simulated hardware of one basic module, wiring only: world::WorldCore (services/world/
// include) holds the plant, the brakes, the owner of each arm, the checks on commands and the overload rule;
// world::LockstepPacer and world::StartWait hold the waits' rules; this process adds the timing policy and DDS.
// Lockstep: it publishes the samples of tick k and advances only when both arms' torque commands for tick k have
// arrived (re-publishing every 50 ms for a robot that joined late). Real time: it steps on absolute 1 kHz deadlines
// (clock_nanosleep); the commands of tick k that arrived before the deadline are applied, and an arm without one
// keeps its previous torque (a late arm-tick). It reports to its supervisor every 10 ticks (tandem/world_report) and
// publishes its status.
#include <tandemPubSubTypes.h>

#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
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

double seconds() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

long long now_ns() {
  timespec n{};
  ::clock_gettime(CLOCK_MONOTONIC, &n);
  return static_cast<long long>(n.tv_sec) * 1000000000LL + n.tv_nsec;
}

timespec to_ts(long long ns) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(ns / 1000000000LL);
  ts.tv_nsec = static_cast<long>(ns % 1000000000LL);
  return ts;
}

/// "Said at the 1st, 2nd, 4th, 8th ... time": a soak's log shows a recurring failure without flooding.
bool say_at_power_of_two(long n) { return n > 0 && (n & (n - 1)) == 0; }

world::WorldOptions world_options(const runtime::RoleOptions& opt, const runtime::RoleContext& ctx) {
  world::WorldOptions wo;
  wo.arm_ids = {ctx.arm_id(0), ctx.arm_id(1)};
  wo.arm_names = {ctx.scenario.robots[0].name, ctx.scenario.robots[1].name};
  wo.realtime = opt.realtime;
  wo.continuous = opt.continuous;
  wo.overload.enabled = opt.overload_brake;
  wo.brakes = !opt.test_no_brakes;
  return wo;
}

using SensorWriter = bus::Writer<msg::ArmSensors, msg::ArmSensorsPubSubType>;
using TorqueReader = bus::Reader<msg::TorqueCommand, msg::TorqueCommandPubSubType>;
using Inbox = runtime::Inbox<msg::TorqueCommand, 2>;

/// One world process: its DDS endpoints, its core and the loop's steps.
class WorldProcess {
 public:
  WorldProcess(const runtime::RoleOptions& opt, const runtime::RoleContext& ctx)
      : opt_(opt), ctx_(ctx), m_(ctx.module), core_(m_, world_options(opt, ctx)),
        part_(opt.domain, "world/" + opt.module, opt.transport),
        // Per arm: each robot receives only its own arm's samples. Real time: best effort, newest only.
        sensors0_(part_, bus::arm_topic(bus::kSensorsTopic, ctx.arm_id(0)), sensor_kind()),
        sensors1_(part_, bus::arm_topic(bus::kSensorsTopic, ctx.arm_id(1)), sensor_kind()),
        // Torque commands are taken in the DDS thread that received them and queued with their arrival time; the
        // world's own thread is not woken for each (real time: it sleeps to the tick's deadline and then reads the
        // queue; lockstep: it is woken when a command comes, as it waits for them).
        inbox_(!opt.realtime),
        // A torque topic per arm, every robot of the arm on it: the core follows the strongest that answers.
        // (Robots answer samples only, and none goes out before the inbox knows its readers.)
        torques0_(part_, bus::arm_topic(bus::kTorquesTopic, ctx.arm_id(0)), torque_kind(), &inbox_),
        torques1_(part_, bus::arm_topic(bus::kTorquesTopic, ctx.arm_id(1)), torque_kind(), &inbox_),
        plans_(part_, bus::module_topic(bus::kSupervisorPlanTopic, opt.module), bus::TopicKind::Task),
        report_(part_, bus::module_topic(bus::kWorldReportTopic, opt.module), bus::TopicKind::Task),
        summary_(part_, bus::kWorldSummaryTopic, bus::TopicKind::Summary),
        status_(part_, opt.module + "/world", "world", opt.module),
        clock_(std::llround(m_.period * 1e9), now_ns()) {
    core_.set_log([this](const std::string& line) {
      std::printf("tandem-world %s: %s\n", opt_.module.c_str(), line.c_str());
      std::fflush(stdout);
    });
    inbox_.set_sources({torques0_.get(), torques1_.get()});
    pacer_.start_expect(opt.standbys);
    status_.msg().deployment(opt.deployment);
    status_.set(runtime::Lifecycle::Inactive, "waiting for the supervisor and two robots");
    rep_.module_id(opt.module);
  }

  int run() {
    if (const int code = wait_for_peers(); code >= 0) return code;
    clock_ = world::TickClock(std::llround(m_.period * 1e9), now_ns());  // the first tick starts now
    status_.msg().owners(world_wire::owners(core_));
    status_.set(runtime::Lifecycle::Active, opt_.realtime ? "real time" : "lockstep");
    if (runtime::raise_to_realtime_from_env() < 0) std::fprintf(stderr, "tandem: could not raise to SCHED_FIFO once active\n");
    for (; k_ < m_.steps && !runtime::g_stop; ++k_) {
      take_plans();
      if (!opt_.realtime) pacer_.tick_begin(seconds());  // lockstep's accounting only: no clock reads per real-time tick
      if (!opt_.realtime) lease_wait();
      sent_ = now_ns();
      core_.begin_tick(k_, sent_, samples_);
      publish_status_if_changed();
      if (k_ % 100 == 0) publish_live_status();
      if (opt_.realtime) {
        const int64_t woke_late_ns = clock_.begin(sent_);  // re-anchors after a stall
        wake_late_us_.add(static_cast<double>(woke_late_ns) * 1e-3);
        // The world itself stood still (SIGSTOP, starvation): the robots' silence meanwhile was its own.
        if (woke_late_ns > 20'000'000) core_.forgive_silence(sent_);
      }
      publish_samples(false);
      if (core_.report_due(m_.steps)) send_report();
      if (opt_.realtime && k_ == 0) start_wait();
      const bool gave_up = collect_commands();
      // Lockstep: once tick 0's commands are in (every robot of each arm, LockstepPacer); real time: after the start
      // wait. A fault injected "after the first tick" then lands in the run, not in its start.
      if (k_ == 0 && !opt_.realtime && !gave_up && !runtime::g_stop) say_first_tick();
      if (runtime::g_stop) break;
      if (!end_tick(gave_up)) break;
    }
    return finish();
  }

 private:
  bus::TopicKind sensor_kind() const { return opt_.realtime ? bus::TopicKind::SensorsRealtime : bus::TopicKind::Sensors; }
  bus::TopicKind torque_kind() const { return opt_.realtime ? bus::TopicKind::TorquesRealtime : bus::TopicKind::Torques; }
  SensorWriter& sensors(size_t j) { return j == 0 ? sensors0_ : sensors1_; }

  // Peers: a robot per arm reads its sensors and writes torques; the supervisor reads the report; the launcher reads
  // the summary (a world the launcher cannot hear, a pair that never authenticated, docs/security.md "Start-up",
  // must not run a task whose summary and status would be lost). --observers counts the sensor readers besides the
  // first robot (the arm's standbys, and a recorder), and the world waits for all of them: with a recorder, so that
  // a recording holds every tick from the first; on several hosts, so that the arms do not start braked because
  // their primaries' host answered later than a standby's. A reader that is slow to come must not hold the module
  // for long: after half the timeout, one reader besides the first is enough (the recorder, started before any
  // module, is normally there by then). Returns -1 when the peers are there, else the exit code.
  int wait_for_peers() {
    const int readers_all = 1 + opt_.observers;
    const int writers_all = 1 + (opt_.realtime ? 0 : opt_.standbys);  // lockstep: every robot of the arm (tick 0)
    // (After half the timeout one torque writer per arm is enough: a standby that never comes holds no module.)
    runtime::PeerWait peers({{"sensor readers of " + ctx_.arm_id(0), readers_all, std::min(readers_all, 2)},
                             {"sensor readers of " + ctx_.arm_id(1), readers_all, std::min(readers_all, 2)},
                             {"torque writers of " + ctx_.arm_id(0), writers_all, 1},
                             {"torque writers of " + ctx_.arm_id(1), writers_all, 1},
                             {"supervisor (report reader)", 1},
                             {"launcher (summary reader)", 1}},
                            opt_.timeout, seconds());
    while (!runtime::g_stop) {
      const runtime::PeerWait::Verdict v =
          peers.pass(seconds(), {sensors0_.matched(), sensors1_.matched(), torques0_.matched(), torques1_.matched(),
                                 report_.matched(), summary_.matched()});
      for (const size_t i : peers.take_lowered()) {
        std::fprintf(stderr, "tandem-world %s: %s: not all there after %.1f s; starting with %d\n", opt_.module.c_str(),
                     peers.peer(i).name.c_str(), 0.5 * opt_.timeout, peers.needed(i));
      }
      if (v == runtime::PeerWait::Verdict::Ready) break;
      if (v == runtime::PeerWait::Verdict::TimedOut) {
        std::fprintf(stderr, "tandem-world: peers not found within %.1f s (%s)\n", opt_.timeout, peers.missing().c_str());
        status_.set(runtime::Lifecycle::Error, "peers not found");
        return launcher::exit_code::kPeersNotFound;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the reverse matches settle
    return -1;
  }

  void take_plans() {
    while (plans_.take(plan_in_)) {
      if (plan_in_.module_id() != opt_.module) continue;
      std::string why;
      const plan::PlanFollower::Offer o = core_.offer_plan(runtime::from_wire(plan_in_), &why);
      if (o == plan::PlanFollower::Offer::Rejected || !why.empty()) {
        std::fprintf(stderr, "tandem-world %s: %s%s\n", opt_.module.c_str(),
                     o == plan::PlanFollower::Offer::Rejected ? "a plan was refused: " : "", why.c_str());
      }
    }
  }

  void publish_status_if_changed() {
    if (!core_.serving_changed()) return;
    status_.msg().owners(world_wire::owners(core_));
    status_.msg().detail(core_.status_detail());
    status_.publish();
  }

  void publish_live_status() {  // every 100 ticks
    auto& st = status_.msg();
    st.tick(static_cast<uint64_t>(k_));
    st.progress(opt_.continuous ? -1.0 : static_cast<double>(k_) / static_cast<double>(m_.steps));
    // (At tick 0 no step has measured a force yet: the margin stays as it was, not 1e300.)
    if (const double n = core_.normal_min_since_status(); n < 1e299) st.grasp_margin(n - m_.safe_grasp_force);
    st.late(opt_.realtime ? core_.late : core_.timeouts);
    st.tracking_error(core_.tracking_error());
    st.latency_p99_us(interval_worst_us_);  // the worst of the interval (at most 200 arm-ticks)
    interval_worst_us_ = 0.0;
    status_.publish();
    log_matches();
  }

  // Once a minute: how many remote endpoints each per-tick topic is matched with. Counts that stay low while new
  // robots come mean this world no longer learns of newcomers (docs/soak.md, finding 74: the Discovery Server's
  // re-send storm showed as "samples to 0 and 0 readers").
  void log_matches() {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_match_log_ < std::chrono::seconds(60)) return;
    last_match_log_ = now;
    std::printf("tandem-world %s: matched at tick %ld: samples to %d and %d readers, commands from %d and %d writers, "
                "plans from %d writers\n",
                opt_.module.c_str(), k_, sensors0_.matched(), sensors1_.matched(), torques0_.matched(), torques1_.matched(),
                plans_.matched());
    std::fflush(stdout);
  }

  void say_first_tick() const {  // for start-up measurements (bench/scale.sh)
    timespec wall{};
    ::clock_gettime(CLOCK_REALTIME, &wall);
    std::printf("tandem-world %s: first tick at wall %.3f\n", opt_.module.c_str(),
                static_cast<double>(wall.tv_sec) + static_cast<double>(wall.tv_nsec) * 1e-9);
    std::fflush(stdout);
  }

  void send_report() {
    const world::ReportOut r = core_.take_report();
    rep_.tick(static_cast<uint64_t>(r.tick));
    rep_.braked()[0] = r.braked[0];
    rep_.braked()[1] = r.braked[1];
    rep_.hold(r.hold);
    rep_.braked_since(r.braked_since);
    rep_.released_at(r.released_at);
    rep_.normal_min(r.normal_min);
    for (int i = 0; i < 3; ++i) rep_.object()[static_cast<size_t>(i)] = r.object(i);
    rep_.failed(r.failed);
    if (r.failed && rep_.failure() != r.failure) rep_.failure(r.failure);
    world_wire::fill_report_counters(core_, opt_.realtime, rep_);
    rep_.plan_epoch(r.plan_rank.epoch);  // the rank and version as of this report
    rep_.plan_strength(r.plan_rank.strength);
    rep_.plan_version(r.plan_version);
    report_.write(rep_);
    reported_ = true;
  }

  // Lockstep: the world runs no further ahead of the leader it follows than the plan's lease (WorldCore::
  // plan_lease_ok), and waits for its commands; world::LockstepPacer says how long and what to do meanwhile.
  void lease_wait() {
    if (!pacer_.lease_wait_needed(core_.plan_lease_ok(k_), core_.plan_lease())) return;
    pacer_.lease_wait_begin(seconds());
    // A report of the tick it waits after: the leader's lease then covers it whatever ticks it had heard (a brake's
    // extra report can leave the last plan's tick between the periodic ones), and a standby sees the world a full
    // lease past a silent leader's last plan.
    if (reported_) send_report();
    double republished_at = seconds();
    while (!runtime::g_stop && !core_.plan_lease_ok(k_)) {
      const world::LockstepPacer::LeaseAction a = pacer_.lease_wait_pass(seconds(), core_.plan_lease(), reported_);
      if (a == world::LockstepPacer::LeaseAction::Lapsed) {
        std::fprintf(stderr, "tandem-world %s: tick %ld: no plan from the leader that has heard tick %ld or later "
                     "within %.1f s; going on without waiting for it until it renews its lease\n", opt_.module.c_str(),
                     k_, k_ - plan::kPlanLeaseTicks, pacer_.rules().lease_wait_s);
        break;
      }
      publish_status_if_changed();
      if (a == world::LockstepPacer::LeaseAction::ResendReport) report_.write(rep_);
      // The last tick's samples again (its robots answered them: they repeat their answer, which is stale here), so
      // that a robot hearing plans from another supervisor meanwhile does not renew a reader that is not deaf.
      if (k_ > 0 && seconds() - republished_at > pacer_.rules().republish_s) {
        publish_samples(true, k_ - 1);
        republished_at = seconds();
      }
      (void)plans_.wait(0.005);
      take_plans();
    }
    pacer_.lease_wait_end(seconds());
  }

  /// The tick's samples (`tick`: another tick's label, for the previous tick's samples sent again).
  void publish_samples(bool all, long tick = -1) {
    if (tick < 0) tick = k_;
    const plan::SupervisorRank plan_rank = core_.plan_rank();
    const uint64_t plan_version = core_.plan_version();
    const long plan_since = core_.plan_since();
    for (size_t j = 0; j < 2; ++j) {
      const world::SampleOut& o = samples_[j];
      if (!o.publish && !all) continue;
      world_wire::fill_sample(o, core_.plant().arm(static_cast<int>(j)).kind(), tick, plan_rank, plan_version, plan_since, s_);
      const bool written = sensors(j).write(s_);
      if (sensors(j).history_clears() != history_clears_[j]) {
        const long n = history_clears_[j] = sensors(j).history_clears();
        if (say_at_power_of_two(n)) {
          std::fprintf(stderr, "tandem-world %s: tick %ld: the sample writer of %s had a full pool (a change never "
                       "acknowledged, Fast DDS 2.9): its history cleared (%ld so far)\n", opt_.module.c_str(), k_,
                       ctx_.arm_id(static_cast<int>(j)).c_str(), n);
        }
      }
      // Fast DDS refused the sample (a writer history held full by a reader that does not acknowledge).
      if (!written && say_at_power_of_two(++write_failures_[j])) {
        std::fprintf(stderr, "tandem-world %s: tick %ld: the sample for %s was not written (%ld so far)\n",
                     opt_.module.c_str(), k_, ctx_.arm_id(static_cast<int>(j)).c_str(), write_failures_[j]);
      }
    }
  }

  /// One command to the core; in real time its latency from the tick's start is measured (not in the start wait).
  void apply(const Inbox::Item& item, bool late_arrival, bool measure = true) {
    const msg::TorqueCommand& cmd = item.sample;
    // The command's joint count as sent (the core refuses one that is not its arm's), and its arm type: a command
    // made for an arm of another type (a robot started with another scenario) is refused here.
    if (cmd.arm_kind() != static_cast<uint8_t>(core_.plant().arm(item.source).kind())) {
      ++core_.rejected;
      return;
    }
    model::JointVec tau(std::clamp(static_cast<int>(cmd.joints()), 1, model::kMaxJoints));
    for (int i = 0; i < tau.size(); ++i) tau(i) = cmd.tau()[static_cast<size_t>(i)];
    const world::WorldCore::Verdict v = core_.on_command(item.source, static_cast<long>(cmd.tick()), tau, cmd.strength(),
                                                         item.at_ns, late_arrival, cmd.leaving());
    // Lockstep tick 0: a valid answer to it counts for the wait for every robot of the arm (not a refused or a last one).
    if (!opt_.realtime && k_ == 0 && cmd.tick() == 0 && !cmd.leaving() && v != world::WorldCore::Verdict::Rejected) {
      pacer_.start_heard(item.source, cmd.strength());
    }
    if (v == world::WorldCore::Verdict::Applied && opt_.realtime && measure) {
      const double us = static_cast<double>(item.at_ns - sent_) * 1e-3;
      latency_us_.add(us);
      interval_worst_us_ = std::max(interval_worst_us_, us);
    }
  }

  // Real time: the first tick waits for both arms' first commands (world::StartWait says how long and what
  // meanwhile), then the clock starts.
  void start_wait() {
    world::StartWait start(seconds());
    Inbox::Item first;
    world::StartWait::Action a = world::StartWait::Action::Wait;
    while (!runtime::g_stop) {
      take_plans();
      while (inbox_.pop(first)) apply(first, false, /*measure=*/false);
      a = start.pass(seconds(), core_.have(0) && core_.have(1));
      if (a == world::StartWait::Action::Go || a == world::StartWait::Action::GiveUp) break;
      publish_status_if_changed();
      if (a == world::StartWait::Action::Republish) publish_samples(true);
      if (a == world::StartWait::Action::ResendReport) report_.write(rep_);
      inbox_.wait(0.002);
    }
    if (start.waited(seconds()) > 0.1 || a == world::StartWait::Action::GiveUp) {
      std::fprintf(stderr, "tandem-world %s: tick 0 waited %.2f s for the robots' first commands%s\n",
                   opt_.module.c_str(), start.waited(seconds()),
                   a == world::StartWait::Action::GiveUp ? "; starting with the start brakes on the arms not answered" : "");
    }
    // An arm that answered early in the wait counts as heard now: its answers to the tick's samples sent again are
    // repeats, which the core takes as stale and does not count as heard, and a silence as long as the wait would
    // otherwise brake it at tick 1.
    core_.forgive_silence(now_ns());
    clock_ = world::TickClock(std::llround(m_.period * 1e9), now_ns());
    say_first_tick();
  }

  // Real time: the tick ends at an absolute deadline; lockstep: when every arm that is not braked has its command in
  // (a braked arm's robot may answer too: that releases it). True if lockstep gave up on a robot that never answered.
  bool collect_commands() {
    deadline_ns_ = clock_.deadline();
    const timespec deadline = to_ts(deadline_ns_);
    if (!opt_.realtime) pacer_.commands_begin(seconds());
    Inbox::Item item;
    while (!runtime::g_stop) {
      // Lockstep: whatever is queued is taken first, even once the tick is complete. With both arms braked the tick
      // is complete at once, and breaking before the queue was read left the commands of the robots that would
      // release them unread for ever: no release, and the queue grew with every tick (soak run 17: arms braked
      // for 136 s with two new robots answering, and a world's memory 26 -> 65 MiB in 148 s).
      if (inbox_.pop(item)) {
        const bool late_arrival = opt_.realtime && item.at_ns > deadline_ns_;
        apply(item, late_arrival);
        if (late_arrival) break;  // the rest are for the next tick's pass (as stale)
        continue;
      }
      if (opt_.realtime) {
        if (now_ns() >= deadline_ns_) break;
        ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);  // the commands queue meanwhile
      } else if (core_.lockstep_done() && (k_ > 0 || pacer_.start_answers_in(seconds()))) {
        if (k_ == 0 && pacer_.start_short()) {
          std::fprintf(stderr, "tandem-world %s: tick 0: %d and %d of the %d robots of each arm answered within %.1f s; "
                       "going on (a standby that answers later runs in shadow from then on)\n", opt_.module.c_str(),
                       pacer_.start_heard_count(0), pacer_.start_heard_count(1), 1 + opt_.standbys,
                       pacer_.rules().start_answers_s);
        }
        break;
      } else {
        if (!core_.lockstep_waited(pacer_.commands_waited(seconds()), opt_.timeout, now_ns())) return true;
        publish_status_if_changed();
        // Lockstep: every 50 ms without the tick's commands, publish the tick's samples again, for a robot that
        // joined (or restarted) after they went out.
        if (pacer_.republish_due(seconds())) publish_samples(true);
        inbox_.wait(0.01);
      }
    }
    return false;
  }

  /// Ends the tick and steps the plant; false when the run stops (lockstep: a robot that never answered).
  bool end_tick(bool gave_up) {
    if (!opt_.realtime) pacer_.commands_end(seconds());
    if (!core_.end_tick(now_ns()) || gave_up) {
      for (int j = 0; j < 2; ++j) {
        if (!core_.have(j)) {
          std::fprintf(stderr, "tandem-world: tick %ld: no valid torque from %s within %.1f s; stopping\n", k_,
                       ctx_.arm_id(j).c_str(), opt_.timeout);
        }
      }
      return false;
    }
    publish_status_if_changed();
    if (opt_.realtime) {
      const timespec deadline = to_ts(deadline_ns_);
      ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);
    } else if (core_.braked(0) && core_.braked(1)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));  // nothing to wait for: hold at about 1 kHz
    }
    core_.step();
    if (opt_.realtime) clock_.advance();
    // A lockstep tick that held the module for long (the plant stands still meanwhile) is said, split by what it
    // waited for, so that a soak's wall-clock gaps can be told apart. What is the world's own is stepping (end_tick,
    // step) and writing (a write blocks up to 1 s on a shared-memory port whose reader was killed holding its lock:
    // Fast DDS builds its interprocess locks with a 1000 ms timeout).
    if (const auto held = opt_.realtime ? std::nullopt : pacer_.tick_end(seconds())) {
      std::fprintf(stderr, "tandem-world %s: tick %ld held the module %.2f s: %.2f s for the leader's plan, %.2f s "
                   "stepping and publishing, %.2f s for the commands\n", opt_.module.c_str(), k_, held->total_s,
                   held->lease_s, held->own_s, held->commands_s);
    }
    return true;
  }

  int finish() {
    if (pacer_.lease_waits() > 0) {
      std::printf("tandem-world %s: waited for the leader's plan %ld time(s), %.2f s in all (lockstep)\n",
                  opt_.module.c_str(), pacer_.lease_waits(), pacer_.lease_wait_s());
    }
    if (inbox_.dropped() > 0) {
      std::fprintf(stderr, "tandem-world %s: %llu torque command(s) dropped unread: the queue was full\n",
                   opt_.module.c_str(), inbox_.dropped());
    }
    msg::WorldSummary ws;
    world_wire::fill_summary(core_, opt_.module, k_, opt_.realtime, clock_.overruns, latency_us_, wake_late_us_, ws);
    summary_.write(ws);
    status_.msg().tick(static_cast<uint64_t>(k_));
    status_.msg().progress(opt_.continuous ? -1.0 : static_cast<double>(k_) / static_cast<double>(m_.steps));
    const bool never_answered = !core_.answered_once();
    if (never_answered && !runtime::g_stop) {
      status_.set(runtime::Lifecycle::Error, "a robot did not answer a tick");
    } else {
      status_.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
    }
    const model::ModulePlant& plant = core_.plant();
    std::printf("tandem-world %s: %ld ticks, slip %ld, contact lost %ld, rejected %llu, stale %llu, %s %llu, "
                "overruns %llu, pauses for load %llu\n",
                opt_.module.c_str(), k_, plant.counters().slip_events, plant.counters().contact_lost, core_.rejected,
                core_.stale, opt_.realtime ? "late arm-ticks" : "brakings", opt_.realtime ? core_.late : core_.timeouts,
                clock_.overruns, core_.load_pauses);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // let the summary reach the launcher
    return never_answered && !runtime::g_stop ? launcher::exit_code::kNoInput : launcher::exit_code::kDone;
  }

  const runtime::RoleOptions& opt_;
  const runtime::RoleContext& ctx_;
  const sim::ModuleSetup& m_;
  world::WorldCore core_;
  bus::Participant part_;
  std::chrono::steady_clock::time_point last_match_log_ = std::chrono::steady_clock::now();
  SensorWriter sensors0_, sensors1_;
  Inbox inbox_;
  TorqueReader torques0_, torques1_;
  bus::Reader<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plans_;
  bus::Writer<msg::WorldReport, msg::WorldReportPubSubType> report_;
  bus::Writer<msg::WorldSummary, msg::WorldSummaryPubSubType> summary_;
  runtime::StatusPublisher status_;
  world::TickClock clock_;
  world::LockstepPacer pacer_;
  runtime::Histogram latency_us_, wake_late_us_;  // fixed bins: no allocation per tick, any run length
  double interval_worst_us_ = 0.0;
  msg::SupervisorPlan plan_in_;
  msg::WorldReport rep_;
  msg::ArmSensors s_;
  std::array<world::SampleOut, 2> samples_{};
  std::array<long, 2> write_failures_{0, 0}, history_clears_{0, 0};
  bool reported_ = false;  // a report went out (the lease wait sends the latest again)
  long k_ = 0;
  long long sent_ = 0, deadline_ns_ = 0;
};

int run(int argc, char** argv) {
  runtime::RoleOptions opt;
  runtime::RoleContext ctx;
  int code = 0;
  if (!runtime::start_role("world", argc, argv, false, opt, ctx, code)) return code;
  WorldProcess w(opt, ctx);
  return runtime::bound_teardown("tandem-world", w.run());  // (then its DDS teardown, bounded)
}

}  // namespace

int main(int argc, char** argv) { return runtime::run_guarded("tandem-world", run, argc, argv); }
