// Stops that keep the grasp (docs/failure-model.md, "Stops"), driven tick by tick with the real components and
// no DDS: a world, a robot per arm and a supervisor (and a standby supervisor), in real time, as their
// processes run them.
// - the last controller of an arm dies at the task's peak speed, on each arm: the world drives the arm along the
//   plan, the supervisor stops the plan inside the friction bound, the brake follows once the object is still:
//   no slip, no contact lost, eq. (14) held throughout, the object's deceleration under the bound;
// - a fresh robot takes the braked arm over 1-5 s later: it starts from the brake's holding torque, the task
//   resumes and ends where it should, with no slip;
// - the leading supervisor dies at random ticks: its replica takes over and the references stay continuous.
#include <catch2/catch.hpp>

#include <algorithm>

#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>

#include "tandem/sim/hosted_module.hpp"
#include "tandem/model/grasp.hpp"
#include "tandem/plan/plan.hpp"
#include "tandem/robot/robot_core.hpp"
#include "tandem/sim/embedded.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"
#include "tandem/supervisor/supervisor_core.hpp"
#include "tandem/world/world_core.hpp"

namespace ts = tandem::sim;
namespace tp = tandem::plan;
namespace tmo = tandem::model;
using tandem::robot::RobotCore;
using tandem::supervisor::SupervisorCore;
using tandem::supervisor::SupervisorOptions;
using tandem::world::WorldCore;

namespace {

const ts::ModuleSetup& sosm_module() {
  static const ts::Scenario sc = ts::load_scenario(std::string(TANDEM_SOURCE_DIR) + "/config/scenarios/paper.yaml");
  static const ts::ModuleSetup m = [] {
    for (const auto& c : sc.cases) {
      if (c.name == "SOSM") return ts::make_module(sc, c);
    }
    throw std::runtime_error("paper.yaml has no SOSM case");
  }();
  return m;
}

constexpr int64_t kMs = 1000000;

constexpr long kPeakTick = 2500;  // the paper task: 0.5 s hold, then 0.4 m in 4 s (quintic): peak speed at 2.5 s

// One module in real time, every part a component, in the order the processes run: the world starts tick k,
// reports every 10 ticks; supervisors hear the report and publish their plan, which the world and the robots
// follow; each live robot answers the sample in time; the world ends the tick and steps the plant.
struct Rig {
  const ts::ModuleSetup& m = sosm_module();
  WorldCore w;
  std::array<std::unique_ptr<SupervisorCore>, 2> sup;  // [0] the leader, [1] a standby (optional)
  std::array<bool, 2> sup_alive{true, true};
  std::array<std::unique_ptr<RobotCore>, 2> robot;
  std::optional<tp::PlanData> last_plan;  // what a robot that joins hears first (transient-local)
  long plan_delay = 0;  // plans reach the world and the robots this many ticks after they are made (a stall)
  std::vector<std::pair<long, tp::PlanData>> in_flight;  // plans on their way to them
  long right_skew = 0;  // late plans reach the right arm's robot this many ticks after the others
  std::vector<std::pair<long, tp::PlanData>> in_flight_right;
  std::string log;
  std::array<tandem::world::SampleOut, 2> out{};
  double min_normal = 1e300;      // after the start-up transient
  double max_decel = 0.0;         // the object's largest |acceleration| while stopping [m/s^2]
  unsigned long long plan_refusals = 0;
  tmo::Vec2 prev_cd = tmo::Vec2::Zero();
  long k = 0;

  bool continuous = false;
  bool realtime = true;
  std::array<tmo::JointVec, 2> bias{tmo::JointVec::Zero(3), tmo::JointVec::Zero(3)};  // added to each robot's command
  std::array<long, 2> mute_until{-1, -1};  // a robot standing still (a stall): it answers no sample before this tick
  std::function<void(Rig&)> during;  // called in each tick after the robots' commands, before the world ends it
  std::function<bool(int, long)> late;  // robot j's answer of tick k comes after the world ended the tick (real time)
  static tandem::world::WorldOptions opts(bool continuous = false, bool realtime = true) {
    tandem::world::WorldOptions o;
    o.continuous = continuous;
    o.arm_ids = {"m1/left", "m1/right"};
    o.arm_names = {"left", "right"};
    o.realtime = realtime;
    return o;
  }
  explicit Rig(bool standby = false, bool cont = false, bool rt = true)
      : w{m, opts(cont, rt)}, continuous(cont), realtime(rt) {
    w.set_log([this](const std::string& l) { log += "world: " + l + "\n"; });
    sup[0] = std::make_unique<SupervisorCore>(m, SupervisorOptions{"m1/supervisor", 100, cont, 0.1}, 0);
    sup[0]->set_log([this](const std::string& l) { log += "supervisor: " + l + "\n"; });
    if (standby) {
      sup[1] = std::make_unique<SupervisorCore>(m, SupervisorOptions{"m1/supervisor@50", 50, cont, 0.1}, 0);
      sup[1]->set_log([this](const std::string& l) { log += "standby: " + l + "\n"; });
    }
    for (int j = 0; j < 2; ++j) robot[static_cast<size_t>(j)] = std::make_unique<RobotCore>(m, j, cont, 0.1);
  }
  void publish(const tp::PlanData& p) {
    if (plan_delay > 0 || !in_flight.empty()) {
      in_flight.emplace_back(k + plan_delay, p);
    } else {
      deliver(p);
    }
    for (size_t i = 0; i < 2; ++i) {
      if (sup[i] && sup_alive[i] && p.supervisor_id != (i == 0 ? "m1/supervisor" : "m1/supervisor@50")) sup[i]->on_plan(p, k * kMs);
    }
    last_plan = p;
  }
  void deliver(const tp::PlanData& p) {
    std::string why;
    if (w.offer_plan(p, &why) == tp::PlanFollower::Offer::Rejected) {
      ++plan_refusals;
      log += "world refused a plan: " + why + "\n";
    } else if (!why.empty()) {
      log += "world: " + why + "\n";
    }
    if (right_skew > 0) {
      if (robot[0] && robot[0]->offer_plan(p) == tp::PlanFollower::Offer::Rejected) ++plan_refusals;
      in_flight_right.emplace_back(k + right_skew, p);
      return;
    }
    offer_robots(p);
  }
  void offer_robots(const tp::PlanData& p) {
    std::string why;
    for (auto& r : robot) {
      if (r && r->offer_plan(p, &why) == tp::PlanFollower::Offer::Rejected) {
        ++plan_refusals;
        log += "robot refused a plan: " + why + "\n";
      }
    }
  }
  void tick() {
    const int64_t now = k * kMs;
    w.begin_tick(k, now, out);
    while (!in_flight.empty() && in_flight.front().first <= k) {
      deliver(in_flight.front().second);
      in_flight.erase(in_flight.begin());
    }
    while (!in_flight_right.empty() && in_flight_right.front().first <= k) {
      if (robot[1] && robot[1]->offer_plan(in_flight_right.front().second) == tp::PlanFollower::Offer::Rejected) ++plan_refusals;
      in_flight_right.erase(in_flight_right.begin());
    }
    std::array<std::optional<tmo::JointVec>, 2> late_tau;
    const bool report = w.report_due(1L << 40);
    tandem::supervisor::ReportIn in;
    if (report) in = ts::supervisor_input(w.take_report());
    for (size_t i = 0; i < 2; ++i) {
      if (!sup[i] || !sup_alive[i]) continue;
      if (report) sup[i]->on_report(in, now);
      sup[i]->update(now);
      if (auto p = sup[i]->take_plan()) publish(*p);
    }
    for (int j = 0; j < 2; ++j) {
      const size_t a = static_cast<size_t>(j);
      if (!robot[a] || !out[a].publish || k < mute_until[a]) continue;
      tmo::ArmSensors s;
      s.q = out[a].q;
      s.qd = out[a].qd;
      s.h = out[a].h;
      // As the robot process: the plan the world follows first (a robot behind it answers nothing), then track the
      // torque of another robot, the world's drive, or the brake.
      robot[a]->world_plan(w.plan_rank(), w.plan_version(), w.plan_since(), k);
      if (robot[a]->cut_off()) continue;
      const bool other = out[a].applied_from != 100 && (out[a].applied_from != 0 || out[a].braked);
      const auto tau = robot[a]->on_sample(k, s, out[a].braked, other ? &out[a].tau_applied : nullptr);
      if (tau && late && late(j, k)) {
        late_tau[a] = *tau + bias[a];
      } else if (tau) {
        w.on_command(j, k, *tau + bias[a], 100, now + 100000, false);
      }
    }
    if (during) during(*this);
    // Lockstep: the world waits for the commands it lacks; a robot that is gone never answers, and the wait ends past
    // the no-command bound (1 s: the world then drives the arm to rest and brakes it).
    if (!realtime && !w.lockstep_done()) (void)w.lockstep_waited(1.5, 10.0, now + 400000);
    w.end_tick(now + 500000);
    for (int j = 0; j < 2; ++j) {
      if (late_tau[static_cast<size_t>(j)]) w.on_command(j, k, *late_tau[static_cast<size_t>(j)], 100, now + 1200000, true);
    }
    if (k > 100) {
      const tmo::ContactReading c = w.plant().contacts();
      min_normal = std::min({min_normal, c.normal[0], c.normal[1]});
    }
    w.step();
    const tmo::Vec2 cd = w.plant().state().cd;
    if (w.stopping(0) || w.stopping(1)) max_decel = std::max(max_decel, (cd - prev_cd).norm() / m.period);
    prev_cd = cd;
    ++k;
  }
  void run_to(long end) {
    while (k < end) tick();
  }
  long slips() const { return w.plant().counters().slip_events; }
  long contact_lost() const { return w.plant().counters().contact_lost; }
};

double a_max(const ts::ModuleSetup& m) {
  const tmo::ObjectParams& o = m.plant.object;
  return tmo::stop_deceleration_bound(m.reference_force, m.safe_grasp_force, o.mass, o.mu_s, m.plant.g0);
}

// The world's report at tick k as the supervisors hear it, with the object where the world's plan has it (the robots
// hold it there).
tandem::supervisor::ReportIn report_of(const tp::PlanFollower& world, long k) {
  tandem::supervisor::ReportIn r;
  r.tick = k;
  r.normal_min = 29.0;
  r.object_xy = world.plan().sample(k).pose.head<2>();
  r.object_known = true;
  r.world_rank = world.has_plan() ? world.rank() : tp::SupervisorRank{};
  r.world_plan_version = world.version();
  return r;
}

}  // namespace

TEST_CASE("the stop's deceleration bound follows from eq. (14) and the grasp's squeeze", "[stops]") {
  const ts::ModuleSetup& m = sosm_module();
  // paper.yaml: M = 2 kg, mu_s = 0.5, h_ref = 1.5 h_sg: h_sg = M g / (2 mu_s) = 19.62 N, and the bound
  // (h_ref - h_sg) / M = 0.5 h_sg / M = g / 4 ... with mu_s = 0.5: (1.5 - 1) * 19.62 / 2 = 4.905 m/s^2.
  CHECK(m.safe_grasp_force == Approx(2.0 * 9.81 / (2.0 * 0.5)));
  CHECK(a_max(m) == Approx(0.5 * m.safe_grasp_force / 2.0));
  CHECK(a_max(m) == Approx(4.905).epsilon(1e-3));
  // Along the faces: 2 mu_s h_ref / M - g = 0.5 * 2 * 29.43 / 2 - 9.81 = 4.905 as well (mu_s = 1/2).
  CHECK(tmo::stop_deceleration_bound(29.43, 19.62, 2.0, 0.5, 9.81) == Approx(4.905).epsilon(1e-3));
  // A slipperier grasp is bounded along the faces: mu_s = 0.3 and h_ref = 1.2 h_sg.
  const double hsg = 2.0 * 9.81 / (2.0 * 0.3);
  CHECK(tmo::stop_deceleration_bound(1.2 * hsg, hsg, 2.0, 0.3, 9.81) == Approx(std::min(0.2 * hsg / 2.0, 0.6 * 1.2 * hsg / 2.0 - 9.81)));
  // The supervisor's stop ramp at the task's peak speed keeps the ramp's deceleration within a quarter of the bound.
  SupervisorCore s(m, SupervisorOptions{"m1/supervisor", 100, false, 0.1}, 0);
  const double v_peak = m.path.sample(2.5).vel.head<2>().norm();
  CHECK(v_peak == Approx(1.875 * 0.4 / 4.0).epsilon(1e-6));  // quintic: peak speed 15/8 of the mean
  CHECK(1.5 * v_peak / s.stop_ramp(kPeakTick) <= 0.25 * a_max(m) + 1e-9);
}

TEST_CASE("the last controller of an arm dies at peak speed: the object is brought to rest without a slip, on each arm", "[stops]") {
  for (int j = 0; j < 2; ++j) {
    Rig rig;
    const double hsg = rig.m.safe_grasp_force;
    rig.run_to(kPeakTick);
    const double speed = rig.w.plant().state().cd.norm();
    rig.robot[static_cast<size_t>(j)].reset();  // killed: it answers nothing more
    rig.run_to(kPeakTick + 1500);
    INFO("arm " << j << "\n" << rig.log);
    CHECK(speed == Approx(0.1875).epsilon(0.05));  // it was moving at the task's peak speed
    CHECK(rig.log.find(std::string(j == 0 ? "m1/left" : "m1/right") + " has no live controller") != std::string::npos);
    CHECK(rig.log.find("object at rest after") != std::string::npos);
    CHECK(rig.w.braked(j));
    CHECK_FALSE(rig.w.braked(1 - j));
    CHECK(rig.w.stops == 1);
    CHECK(rig.slips() == 0);
    CHECK(rig.contact_lost() == 0);
    CHECK(rig.min_normal >= hsg);                 // eq. (14) throughout
    CHECK(rig.max_decel <= a_max(rig.m));         // the stop stayed inside the bound
    CHECK(rig.w.plant().state().cd.norm() < 1e-3);
    CHECK(rig.sup[0]->state() == tp::TaskStateCode::Paused);
  }
}

TEST_CASE("a plan version that reaches the followers 170 ticks after its change is blended in: continuous references, no slip (finding 86)", "[stops]") {
  // Soak run 59: a machine stall of 0.34 s; the leader's next version, made at tick 1082200, reached the world and
  // the robots at 1082367, 6.66 mm from the reference they followed; the object slid 2.1 mm. Here at the task's peak
  // speed, the versions of a stop reach the followers 170 ticks late: a pause asked for, or both robots standing
  // still 150 ms (the world drives both arms to rest and brakes them; the leader's stop comes late). Each follower
  // anchors its blend at its own tick: the right arm's robot also gets the versions 3 or 10 ticks after the others.
  for (const bool stall : {false, true}) {
   for (const long skew : {0L, 3L, 10L}) {
    Rig rig;
    const double hsg = rig.m.safe_grasp_force;
    rig.run_to(kPeakTick);
    const double v_peak = rig.w.plant().state().cd.norm();
    rig.plan_delay = 170;
    rig.right_skew = skew;
    if (stall) {
      rig.mute_until = {kPeakTick + 150, kPeakTick + 150};
    } else {
      rig.sup[0]->on_request(SupervisorCore::Request::Pause);
    }
    tmo::Vec3 prev = rig.w.follower().sample(rig.k - 1).pose;
    double max_step = 0.0, max_acc = 0.0;
    while (rig.k < kPeakTick + 2500) {
      if (rig.k == kPeakTick + 1000) rig.plan_delay = 0;
      rig.tick();
      const tmo::PoseSample s = rig.w.follower().sample(rig.k - 1);  // as the world followed tick k - 1
      max_step = std::max(max_step, (s.pose - prev).head<2>().norm());
      max_acc = std::max(max_acc, s.acc.head<2>().norm());
      prev = s.pose;
    }
    INFO((stall ? "both robots stood still 150 ms" : "a pause") << ", the right robot " << skew << " ticks later than the rest\n" << rig.log);
    CHECK(rig.log.find("reference jumps by") != std::string::npos);  // the case arose: a late version
    CHECK(rig.log.find("blended into over") != std::string::npos);
    // No jump (a catch-up after a late resume runs faster than the task, never more than twice its peak speed).
    CHECK(max_step <= 2.0 * v_peak * rig.m.period);
    CHECK(max_acc <= 0.5 * a_max(rig.m));              // a stop ramp's quarter of eq. (14)'s bound, and the blend's
    CHECK(rig.slips() == 0);
    CHECK(rig.contact_lost() == 0);
    CHECK(rig.min_normal >= hsg);
   }
  }
}

TEST_CASE("a fresh robot takes over a braked arm 1-5 s later: it starts from the holding torque, and the task ends without a slip", "[stops]") {
  // Real time, and lockstep (lockstep soak run 37, finding 68: the world released the arm on the fresh robot's first
  // answer, computed by a law just reset, and the object slipped 3-4 ticks later: 25 slip events).
  for (const bool realtime : {true, false}) {
  for (const int j : {0, 1}) {
    for (const long delay_ms : {1000L, 3000L, 5000L}) {
      Rig rig(false, false, realtime);
      rig.run_to(kPeakTick);
      rig.robot[static_cast<size_t>(j)].reset();
      rig.run_to(kPeakTick + delay_ms);
      REQUIRE(rig.w.braked(j));
      // A restarted robot: a fresh law, the latest plan (transient-local), then samples.
      rig.robot[static_cast<size_t>(j)] = std::make_unique<RobotCore>(rig.m, j, false, 0.1);
      rig.robot[static_cast<size_t>(j)]->offer_plan(*rig.last_plan);
      const long joined = rig.k;
      // Its torque at release is the brake's holding torque, to within the law's reaction to the small error.
      tmo::Vec3 at_release = tmo::Vec3::Zero(), holding = tmo::Vec3::Zero();
      while (rig.w.braked(j) && rig.k < joined + 1000) {
        holding = rig.w.holding_torque(j);
        rig.tick();
        at_release = rig.robot[static_cast<size_t>(j)]->last_tau();
      }
      INFO((realtime ? "real time" : "lockstep") << ", arm " << j << ", restarted after " << delay_ms << " ms\n" << rig.log);
      REQUIRE_FALSE(rig.w.braked(j));
      CHECK(rig.k - joined >= (realtime ? WorldCore::kReleaseTrialTicks : WorldCore::kLockstepReleaseTicks));
      // The status's handover: from the dead robot's last command (kPeakTick - 1) to the release, the whole stop.
      CHECK(rig.w.owner(j).handover_ticks == rig.k - 1 - (kPeakTick - 1));
      CHECK((at_release - holding).norm() < 0.05 * holding.norm() + 1.0);
      // The rest of the task: 4.5 s of motion in all, 2 s of it done before the stop.
      rig.run_to(rig.k + 4000);
      CHECK(rig.slips() == 0);
      CHECK(rig.contact_lost() == 0);
      CHECK(rig.min_normal >= rig.m.safe_grasp_force);
      CHECK(rig.w.plant().state().c(0) == Approx(0.2).margin(2e-3));  // where the task ends
      CHECK(rig.w.plant().state().c(1) == Approx(0.8).margin(2e-3));
    }
  }
  }
}

TEST_CASE("lockstep: a braked arm's robot that answers late is waited for, and released after 10 answers in step", "[stops]") {
  Rig rig(false, false, /*rt=*/false);
  rig.run_to(kPeakTick);
  rig.robot[0].reset();  // the left arm's robot dies
  rig.run_to(kPeakTick + 1500);
  REQUIRE(rig.w.braked(0));
  tmo::JointVec hold = rig.w.holding_torque(0);
  // A late answer (the tick before, after the world stepped on): stale, and from now on the world waits for the arm.
  bool waited = false;
  rig.during = [&](Rig& r) {
    CHECK(r.w.on_command(0, r.k - 1, hold, 100, r.k * kMs, false) == WorldCore::Verdict::Stale);
    waited = !r.w.lockstep_done();
    r.during = nullptr;
  };
  rig.tick();  // its lockstep wait ran past 1 s without the robot: the trial is dropped, the arm stays braked
  CHECK(waited);
  CHECK(rig.w.braked(0));
  CHECK(rig.w.lockstep_done());
  // Answers in step: each tick the world waits for the next one, and the 10th releases the arm.
  long released_at = -1;
  for (int n = 1; n <= 12 && released_at < 0; ++n) {
    rig.during = [&](Rig& r) {
      if (n > 1) CHECK_FALSE(r.w.lockstep_done());  // the trial's robot has not answered this tick yet
      hold = r.w.holding_torque(0);
      r.w.on_command(0, r.k, hold, 100, r.k * kMs, false);
      CHECK(r.w.lockstep_done());
    };
    rig.tick();
    if (!rig.w.braked(0)) released_at = n;
  }
  rig.during = nullptr;
  CHECK(released_at == WorldCore::kLockstepReleaseTicks);
}

TEST_CASE("a rejoined robot's first answer does not end a release trial: a warm answer does, and nothing slips", "[stops]") {
  // Lockstep soak run 38: an arm released 10 answers into its trial, two robots of the arm answering, slipped 6 ticks
  // later; the releasing answer may have been a rejoined robot's first, from a law just reset.
  for (const bool realtime : {true, false}) {
    Rig rig(false, false, realtime);
    rig.run_to(kPeakTick);
    rig.robot[0].reset();
    rig.run_to(kPeakTick + 1500);
    REQUIRE(rig.w.braked(0));
    auto answer = [](RobotCore& rc, int32_t strength, Rig& r) {
      tmo::ArmSensors s;
      s.q = r.out[0].q;
      s.qd = r.out[0].qd;
      s.h = r.out[0].h;
      rc.world_plan(r.w.plan_rank(), r.w.plan_version(), r.w.plan_since(), r.k);
      const bool other = r.out[0].applied_from != strength && (r.out[0].applied_from != 0 || r.out[0].braked);
      auto tau = rc.on_sample(r.k, s, r.out[0].braked, other ? &r.out[0].tau_applied : nullptr);
      if (tau) r.w.on_command(0, r.k, *tau, strength, r.k * kMs, false);
      return tau;
    };
    // A standby joins and answers every tick of the trial but its last.
    RobotCore standby(rig.m, 0, false, 0.1);
    standby.offer_plan(*rig.last_plan);
    const int trial = realtime ? WorldCore::kReleaseTrialTicks : WorldCore::kLockstepReleaseTicks;
    rig.during = [&](Rig& r) { (void)answer(standby, 50, r); };
    for (int n = 0; n < trial - 1; ++n) rig.tick();
    REQUIRE(rig.w.braked(0));
    // The primary, restarted, answers first at what would be the trial's last tick: its law was just reset.
    RobotCore primary(rig.m, 0, false, 0.1);
    primary.offer_plan(*rig.last_plan);
    rig.during = [&](Rig& r) {
      (void)answer(primary, 100, r);
      (void)answer(standby, 50, r);
    };
    rig.tick();
    INFO((realtime ? "real time" : "lockstep") << "\n" << rig.log);
    CHECK(rig.w.braked(0));
    // The next tick both answer again, the primary first and now warm: it releases the arm from the holding torque.
    const tmo::JointVec holding = rig.w.holding_torque(0);
    rig.tick();
    CHECK_FALSE(rig.w.braked(0));
    CHECK((primary.last_tau() - holding).norm() < 0.05 * holding.norm() + 1.0);
    rig.during = nullptr;
    rig.robot[0] = std::make_unique<RobotCore>(std::move(primary));
    rig.run_to(rig.k + 4000);
    CHECK(rig.slips() == 0);
    CHECK(rig.contact_lost() == 0);
  }
}

TEST_CASE("the leading supervisor dies at random ticks: its replica takes over and the references stay continuous", "[stops]") {
  std::mt19937 rng(20261124);
  std::uniform_int_distribution<long> when(200, 4500);
  for (int trial = 0; trial < 4; ++trial) {
    const long death = when(rng);
    Rig rig(true);
    tp::PlanFollower follower(rig.m, false);  // what the robots evaluate, checked tick by tick
    double max_step = 0.0;
    tmo::Vec3 prev = tmo::Vec3::Zero();
    for (long k = 0; k < 5500; ++k) {
      if (k == death) rig.sup_alive[0] = false;
      rig.tick();
      if (rig.last_plan) follower.offer(*rig.last_plan);
      const tmo::Vec3 x = follower.reference(1, k).x;
      if (k > 0) max_step = std::max(max_step, (x - prev).head<2>().norm());
      prev = x;
    }
    INFO("leader killed at tick " << death << "\n" << rig.log);
    CHECK(rig.sup[1]->active());
    CHECK(rig.log.find("standby: taking over in epoch 1") != std::string::npos);
    CHECK(rig.plan_refusals == 0);
    // Continuous: never more than the path's peak speed (0.1875 m/s) over one tick, with margin.
    CHECK(max_step <= 0.1875 * rig.m.period * 1.1);
    CHECK(rig.slips() == 0);
    CHECK(rig.w.plant().state().c(0) == Approx(0.2).margin(2e-3));
  }
}

TEST_CASE("followers adopt a takeover plan that jumps (and say so), and a standby that never heard a leader does not lead a moved object", "[stops]") {
  const ts::ModuleSetup& m = sosm_module();
  tp::ModulePlan leader(m, false);
  tp::PlanData p;
  leader.export_to(p);
  p.supervisor_id = "m1/supervisor";
  tp::PlanFollower f(m, false), lagging(m, false);
  REQUIRE(f.offer(p, nullptr, 2500) == tp::PlanFollower::Offer::Adopted);
  REQUIRE(lagging.offer(p, nullptr, 2100) == tp::PlanFollower::Offer::Adopted);
  // The same leader's next version, a pause planned from tick 2300 on, reaches a robot that is 400 ticks
  // behind (back from a stall) and one that is current: both follow it, whatever it means at their tick, so
  // the module never splits (the heavy-fault soak's drop came from a robot that refused such a plan).
  leader.set_rate(2300, 0.0, 0.15);
  tp::PlanData next;
  leader.export_to(next);
  next.supervisor_id = "m1/supervisor";
  std::string why, why_lagging;
  const tmo::ArmReference before = f.reference(0, 2500);
  CHECK(f.offer(next, &why, 2500) == tp::PlanFollower::Offer::Adopted);
  CHECK(lagging.offer(next, &why_lagging, 2100) == tp::PlanFollower::Offer::Adopted);
  // The current one got a change 200 ticks in its past: the jump is said (soak finding 58), though it is no
  // takeover; the lagging one got it before the change: nothing to say, nothing to blend.
  CHECK(why.find("a plan version whose reference jumps by") != std::string::npos);
  CHECK(why.find("version " + std::to_string(next.version) + " after " + std::to_string(p.version)) != std::string::npos);
  CHECK(why.find("adopted, blended into over") != std::string::npos);
  CHECK(why_lagging.empty());
  CHECK_FALSE(lagging.blending(2100));
  CHECK(f.jump() == 0.0);  // jump() stays a takeover's
  // Bumpless (finding 86): the current one's reference goes on from where it was, in position and velocity ...
  CHECK((f.reference(0, 2500).x - before.x).norm() < 1e-12);
  CHECK((f.reference(0, 2500).xd - before.xd).norm() < 1e-12);
  REQUIRE(f.blending(2500));
  // ... and is the plan as made once the blend is over: both followers agree again, and at every tick before the
  // change.
  const long end = 2500 + f.blend_ticks();
  for (long k : {2100L, 2400L, end, end + 500}) CHECK((f.reference(0, k).x - lagging.reference(0, k).x).norm() == 0.0);
  CHECK((f.reference(0, 2600).x - lagging.reference(0, 2600).x).norm() > 1e-3);
  {
    // A follower behind the tick the version was made at (a robot back from a stall, a standby just joined) takes it
    // as made: it skips to the newest tick, where a blend anchored in its past would leave it off the module's plan.
    tp::PlanData late = next;
    late.heard_tick = 2480;
    tp::PlanFollower current(m, false), behind(m, false), close(m, false);
    REQUIRE(current.offer(p, nullptr, 2500) == tp::PlanFollower::Offer::Adopted);
    REQUIRE(behind.offer(p, nullptr, 1500) == tp::PlanFollower::Offer::Adopted);
    REQUIRE(close.offer(p, nullptr, 1500) == tp::PlanFollower::Offer::Adopted);
    std::string why_current, why_behind, why_close;
    CHECK(current.offer(late, &why_current, 2500) == tp::PlanFollower::Offer::Adopted);
    CHECK(behind.offer(late, &why_behind, 2400) == tp::PlanFollower::Offer::Adopted);
    // A follower a tick or a few behind the heard tick (it answers the sample its supervisor heard, a little later)
    // is serving: it blends from its own tick like the current one, and ends on the same plan.
    CHECK(close.offer(late, &why_close, 2480 - tp::PlanFollower::kBehindGraceTicks) == tp::PlanFollower::Offer::Adopted);
    CHECK(why_close.find("adopted, blended into over") != std::string::npos);
    CHECK(close.blending(2480 - tp::PlanFollower::kBehindGraceTicks));
    CHECK((close.reference(0, 2500).x - current.reference(0, 2500).x).norm() < 2e-4);
    for (long k : {3500L, 4000L}) CHECK((close.reference(0, k).x - current.reference(0, k).x).norm() == 0.0);
    CHECK(current.blending(2500));
    CHECK_FALSE(behind.blending(2400));
    CHECK(why_behind.find("adopted, as made (this follower is 80 ticks behind it)") != std::string::npos);
    for (long k : {2400L, 2500L, 2600L}) CHECK((behind.reference(0, k).x - lagging.reference(0, k).x).norm() == 0.0);
  }
  // A takeover plan (a new epoch) from a supervisor that paused the path at tick 1000 long ago: 0.2 m behind at
  // tick 2500. Reported, and adopted as every follower adopts it.
  tp::ModulePlan drifted(m, false);
  drifted.set_rate(1000, 0.0, 0.0);
  tp::PlanData q;
  drifted.export_to(q);
  q.supervisor_id = "m1/supervisor@50";
  q.epoch = 1;
  CHECK(f.offer(q, &why, 2500) == tp::PlanFollower::Offer::Adopted);
  CHECK(f.jump() > 0.05);
  CHECK(why.find("a takeover plan whose reference jumps by") != std::string::npos);
  // A standby that never heard a leader, with the object 5 cm from where its initial plan has it.
  SupervisorCore s(m, SupervisorOptions{"m1/supervisor@50", 50, false, 0.1}, 0);
  std::string log;
  s.set_log([&](const std::string& l) { log += l + "\n"; });
  for (long k = 0; k <= 7000; k += 10) {
    tandem::supervisor::ReportIn r;
    r.tick = k;
    r.normal_min = 29.0;
    r.object_xy = m.path.sample(0.0).pose.head<2>() + tmo::Vec2(0.05, 0.0);
    s.on_report(r, k * kMs);
    s.update(k * kMs);
  }
  CHECK_FALSE(s.active());
  CHECK(log.find("never heard a leader, and the object is not where the initial plan has it") != std::string::npos);
  // With the object where the initial plan has it (a module whose leader never started), it leads after 6 s.
  SupervisorCore t(m, SupervisorOptions{"m1/supervisor@50", 50, false, 0.1}, 0);
  for (long k = 0; k <= 7000; k += 10) {
    tandem::supervisor::ReportIn r;
    r.tick = k;
    r.normal_min = 29.0;
    r.object_xy = m.path.sample(static_cast<double>(k) * m.period).pose.head<2>();
    t.on_report(r, k * kMs);
    t.update(k * kMs);
  }
  CHECK(t.active());
}

TEST_CASE("a drop is a failure: the world brakes both arms for good, the supervisor reports the module failed, the task is not done", "[stops]") {
  Rig rig;
  rig.run_to(1500);
  // The right robot goes mad: zero torque, in time, every tick (a valid command: the world applies it). Its arm
  // falls away from the object and the left arm alone cannot hold it.
  std::string sup_state;
  long failed_at = -1;
  for (; rig.k < 3000;) {
    const long k = rig.k;
    const int64_t now = k * kMs;
    rig.w.begin_tick(k, now, rig.out);
    if (rig.w.report_due(1L << 40)) {
      const auto r = rig.w.take_report();
      rig.sup[0]->on_report(ts::supervisor_input(r), now);
      if (r.failed && failed_at < 0) failed_at = k;
    }
    rig.sup[0]->update(now);
    if (auto p = rig.sup[0]->take_plan()) rig.publish(*p);
    tmo::ArmSensors s;
    s.q = rig.out[0].q;
    s.qd = rig.out[0].qd;
    s.h = rig.out[0].h;
    if (const auto tau = rig.robot[0]->on_sample(k, s, rig.out[0].braked)) rig.w.on_command(0, k, *tau, 100, now + 100000, false);
    rig.w.on_command(1, k, tmo::Vec3::Zero(), 100, now + 100000, false);
    rig.w.end_tick(now + 500000);
    rig.w.step();
    ++rig.k;
  }
  INFO(rig.log);
  REQUIRE(rig.w.failed());
  CHECK((rig.w.failure().find("a contact carried no force") != std::string::npos || rig.w.failure().find("slid") != std::string::npos));
  CHECK(failed_at > 1500);
  CHECK(rig.w.braked(0));
  CHECK(rig.w.braked(1));  // and no robot releases them: both answered every tick since
  CHECK(rig.sup[0]->state() == tp::TaskStateCode::Failed);
  CHECK(rig.log.find("module failed") != std::string::npos);
  // With the flight record of its last ticks: the right arm got zero torque, in time, from its robot (strength 100).
  CHECK(rig.log.find("its last 60 ticks:") != std::string::npos);
  CHECK(rig.log.find("right c from 100 tau 0.00 0.00 0.00") != std::string::npos);
  const std::string record = rig.w.flight_record(3);
  CHECK(std::count(record.begin(), record.end(), '\n') == 3);
  CHECK(record.find("tick " + std::to_string(rig.k - 1) + ":") != std::string::npos);
  // The path stopped: the plan never reaches the task's end, so the task is never finished.
  CHECK_FALSE(rig.sup[0]->plan().motion_over(rig.k + 10000));
}

TEST_CASE("a standby back from its own stall does not take over before the leader's plans of the meantime arrive", "[stops]") {
  const ts::ModuleSetup& m = sosm_module();
  SupervisorCore leader(m, SupervisorOptions{"m1/supervisor", 100, true, 0.1}, 0);
  SupervisorCore standby(m, SupervisorOptions{"m1/supervisor@50", 50, true, 0.1}, 0);
  std::string log;
  standby.set_log([&](const std::string& l) { log += l + "\n"; });
  auto report = [](long k) {
    tandem::supervisor::ReportIn r;
    r.tick = k;
    r.normal_min = 29.0;
    return r;
  };
  std::vector<tp::PlanData> backlog;
  for (long k = 0; k < 4000; k += 10) {
    const int64_t now = k * kMs;
    leader.on_report(report(k), now);
    if (k == 1000) leader.on_assignment(1, "t1", {0.0, 0.8, 0.0, 1.0});
    if (k == 2400) leader.on_assignment(2, "t2", {-0.1, 0.8, 0.0, 1.0});
    leader.update(now);
    const auto p = leader.take_plan();
    const bool stalled = k >= 2300 && k < 2600;  // the standby is SIGSTOPped for 300 ms
    if (stalled) {
      if (p) backlog.push_back(*p);
      continue;
    }
    // Back from the stall: the world's report and update() come before the backlog of plans is delivered.
    standby.on_report(report(k), now);
    standby.update(now);
    for (const auto& q : backlog) standby.on_plan(q, now);
    backlog.clear();
    if (p) standby.on_plan(*p, now);
  }
  INFO(log);
  CHECK_FALSE(standby.active());
  CHECK(log.find("stood still for") != std::string::npos);
  CHECK(standby.plan().task_id() == 2);  // its replica has the leader's task of the meantime
}

TEST_CASE("a standby whose replica missed the leader's newest plan does not take over from the silent leader", "[stops]") {
  // Found by a soak on a busy machine: a standby took over with a plan version behind the leader's, the references
  // jumped 10-122 mm, and the object was dropped. Here the standby stands still from tick 2000 to 2500 while the
  // leader starts task t2 and dies at 2300; the world's object follows the leader's plan (the robots hold it). On
  // its return the plans of the meantime are delivered (a healthy replica) or were lost (a stale one).
  const ts::ModuleSetup& m = sosm_module();
  for (const bool lost : {false, true}) {
    SupervisorCore leader(m, SupervisorOptions{"m1/supervisor", 100, true, 0.1}, 0);
    SupervisorCore standby(m, SupervisorOptions{"m1/supervisor@50", 50, true, 0.1}, 0);
    std::string log;
    standby.set_log([&](const std::string& l) { log += l + "\n"; });
    const long dies = 2300;
    std::vector<tp::PlanData> backlog;
    bool took_over = false;
    for (long k = 0; k < 10000; k += 10) {
      const int64_t now = k * kMs;
      tandem::supervisor::ReportIn r;
      r.tick = k;
      r.normal_min = 29.0;
      r.object_xy = leader.plan().sample(k).pose.head<2>();  // the object where the leader's plan has it
      r.object_known = true;
      std::optional<tp::PlanData> p;
      if (k <= dies) {
        leader.on_report(r, now);
        if (k == 500) leader.on_assignment(1, "t1", {0.0, 0.8, 0.0, 1.0});
        if (k == 2000) leader.on_assignment(2, "t2", {-0.1, 0.8, 0.0, 1.0});
        leader.update(now);
        p = leader.take_plan();
      }
      if (k >= 2000 && k < 2500) {  // the standby stands still
        if (p) backlog.push_back(*p);
        continue;
      }
      standby.on_report(r, now);
      standby.update(now);
      if (!lost) {
        for (const auto& q : backlog) standby.on_plan(q, now);
      }
      backlog.clear();
      if (p) standby.on_plan(*p, now);
      if (standby.active()) {
        took_over = true;
        // Its references continue the object: no jump at the takeover.
        CHECK((standby.plan().sample(k).pose.head<2>() - r.object_xy).norm() < SupervisorCore::kReplicaMatch);
        break;
      }
    }
    INFO(log);
    if (!lost) {
      CHECK(took_over);
      CHECK_FALSE(standby.no_plan());
    } else {
      CHECK_FALSE(took_over);
      CHECK(log.find("this replica (version") != std::string::npos);
      CHECK(log.find("not taking over") != std::string::npos);
      CHECK(standby.no_plan());  // after kTakeOverAloneNs: the launcher restarts the module
    }
  }
}

TEST_CASE("a standby a plan version behind at a task's start does not take over, though the object has not moved yet", "[stops]") {
  // Found by a soak (soak-small, 40 min, m2): "taking over in epoch 1 ... with plan version 2: task 606 not running"
  // while the leader had just started task 606. The object had not moved yet, so the position check let the stale
  // replica lead; the references jumped 9.9 mm and the object was dropped. The world reports the version of the
  // plan it follows (WorldReport.plan_version), and a replica older than that does not lead. Here the leader
  // starts t2 at tick 2000 and dies at 2010; its plan of t2 reaches the world, and the standby late (at 3000) or
  // never. A third case: the leader lives on and goes on to t3, and the standby hears none of it (its reader lost
  // the leader's writer): it is deaf, and says so, instead of declaring the module's plan lost.
  const ts::ModuleSetup& m = sosm_module();
  enum Case { Late, Lost, Deaf };
  for (const Case c : {Late, Lost, Deaf}) {
    const bool lost = c != Late;
    SupervisorCore leader(m, SupervisorOptions{"m1/supervisor", 100, true, 0.1}, 0);
    SupervisorCore standby(m, SupervisorOptions{"m1/supervisor@50", 50, true, 0.1}, 0);
    tp::PlanFollower world(m, true);  // what the world follows
    std::string log;
    standby.set_log([&](const std::string& l) { log += l + "\n"; });
    const long dies = c == Deaf ? 1L << 40 : 2010;
    std::optional<tp::PlanData> missed;
    long took_over_at = -1;
    for (long k = 0; k < 10000; k += 10) {
      const int64_t now = k * kMs;
      tandem::supervisor::ReportIn r;
      r.tick = k;
      r.normal_min = 29.0;
      r.object_xy = world.plan().sample(k).pose.head<2>();  // the robots hold the object where the world's plan has it
      r.object_known = true;
      r.world_rank = world.has_plan() ? world.rank() : tp::SupervisorRank{};
      r.world_plan_version = world.version();
      if (k <= dies) {
        leader.on_report(r, now);
        if (k == 500) leader.on_assignment(1, "t1", {0.0, 0.8, 0.0, 1.0});
        if (k == 2000) leader.on_assignment(2, "t2", {-0.1, 0.8, 0.0, 1.0});
        if (k == 4500) leader.on_assignment(3, "t3", {0.1, 0.8, 0.0, 1.0});
        leader.update(now);
        if (auto p = leader.take_plan()) {
          world.offer(*p);
          if (k >= 2000 && p->task_id >= 2) missed = *p;  // t2's (and t3's) plans do not reach the standby
          else standby.on_plan(*p, now);
        }
      }
      if (!lost && k == 3000 && missed) standby.on_plan(*missed, now);  // delivered late (transient-local)
      standby.on_report(r, now);
      standby.update(now);
      if (standby.active()) {
        took_over_at = k;
        CHECK(standby.plan().task_id() == 2);
        // Its references continue the world's: no jump at the takeover, now or later in the task.
        for (long t : {k, k + 500, k + 1000}) {
          CHECK((standby.plan().sample(t).pose - world.plan().sample(t).pose).norm() < 1e-9);
        }
        break;
      }
    }
    INFO("case " << c << "\n" << log);
    REQUIRE(missed.has_value());
    CHECK(log.find("the world follows plan version") != std::string::npos);
    if (c == Late) {
      CHECK(took_over_at >= 3000);
      CHECK_FALSE(standby.no_plan());
    } else {
      CHECK(took_over_at < 0);
      // After kTakeOverAloneNs: a dead leader's module has lost its plan (the launcher restarts the module); a
      // live leader's deaf standby restarts alone (exit 6).
      CHECK(standby.no_plan() == (c == Lost));
      CHECK(standby.deaf() == (c == Deaf));
    }
  }
}

// The soak's case (soak-small, 40 min, m2 at 440 s): all of a module's robots cut off at once mid-task, fresh robots
// released one after the other 3 s later, and the coordinator's next task right after. Here it holds with the
// components alone (that soak's drop needs more than this sequence: starved processes and two leaders' plans).
TEST_CASE("continuous: both arms lose their controllers at once mid-task, fresh robots return one after the other, the next tasks end without a slip", "[stops]") {
  for (const long kill : {1500L, 3100L, 4400L}) {
    for (const long gap : {0L, 860L}) {
      Rig rig(false, true);
      uint64_t next_id = 1;
      auto feed = [&] {
        if (rig.k % 50 == 0 && rig.sup[0]->state() != tp::TaskStateCode::Running) {
          const double x = next_id % 2 == 1 ? 0.15 : -0.15;
          rig.sup[0]->on_assignment(next_id, "t" + std::to_string(next_id), {x, 0.8, 0.0, 1.5, 0.0, 0.85, 0.0, 1.5});
          ++next_id;
        }
      };
      auto run = [&](long end) { while (rig.k < end) { feed(); rig.tick(); } };
      run(kill);
      rig.robot[0].reset();
      rig.robot[1].reset();
      run(kill + 3000);
      for (int j : {1, 0}) {
        rig.robot[static_cast<size_t>(j)] = std::make_unique<RobotCore>(rig.m, j, true, 0.1);
        rig.robot[static_cast<size_t>(j)]->offer_plan(*rig.last_plan);
        if (j == 1) run(rig.k + gap);
      }
      run(rig.k + 12000);
      INFO("kill " << kill << " gap " << gap << " tasks " << rig.sup[0]->plan().done() << "\n" << rig.log);
      CHECK(rig.slips() == 0);
      CHECK(rig.min_normal >= rig.m.safe_grasp_force);
      CHECK(rig.sup[0]->plan().done() >= 4);
    }
  }
}

// Found by a soak-small hour (m1, 674 s): the serving left robot was stopped for about 0.1 s and the world drove its
// arm; the supervisor stopped the path meanwhile, and was itself starved for 0.33 s. The robot, back, took its arm
// over with the plan of before the stop (the stop's version had not reached it), ran ahead of the stopped object,
// and the object slipped and was dropped 0.4 s later. Here: the serving robot of each arm stands still for 0.1-0.3 s
// at several points of the task, the leader goes silent 150 ticks in for 330 ticks (or not at all), and the
// robot, back, hears the plans it missed one tick after its first sample, or only at the leader's next plan.
TEST_CASE("a serving robot back from a stall answers nothing until it has the plan the world follows, and nothing slips", "[stops]") {
  for (const int j : {0, 1}) {
    for (const long at : {1200L, 2500L}) {
      for (const long stall : {105L, 300L}) {
        for (const bool starved_leader : {false, true}) {
          for (const bool hears_late : {false, true}) {
            Rig rig;
            const size_t a = static_cast<size_t>(j);
            rig.run_to(at);
            auto keep = std::move(rig.robot[a]);  // stopped: it hears and answers nothing
            const long sup_from = at + 150, sup_to = at + 150 + 330;
            if (starved_leader) {
              rig.run_to(std::min(sup_from, at + stall));
              if (rig.k >= sup_from) rig.sup_alive[0] = false;
            }
            rig.run_to(at + stall);
            if (starved_leader && rig.k < sup_from) {
              rig.robot[a] = std::move(keep);
              rig.run_to(sup_from);
              rig.sup_alive[0] = false;
            }
            if (!rig.robot[a]) {
              rig.robot[a] = std::move(keep);  // back: its first sample comes before the plans it missed
              rig.tick();
              if (!hears_late && rig.last_plan) rig.robot[a]->offer_plan(*rig.last_plan);
            }
            rig.run_to(std::max(rig.k, starved_leader ? sup_to : 0L));
            rig.sup_alive[0] = true;
            rig.run_to(rig.k + 4000);
            INFO("arm " << j << ", stopped at " << at << " for " << stall << " ticks, leader starved " << starved_leader
                        << ", plans heard late " << hears_late << "\n" << rig.log);
            CHECK(rig.slips() == 0);
            CHECK(rig.min_normal >= rig.m.safe_grasp_force);
            CHECK_FALSE(rig.w.failed());
            CHECK(rig.w.plant().state().c(0) == Approx(0.2).margin(2e-3));  // the task ends where it should
          }
        }
      }
    }
  }
}

TEST_CASE("a failed module's standby takes over from a silent leader whatever its replica, and reports the module failed", "[stops]") {
  // A soak-small hour: the leader of a module whose object had been dropped was killed; the standby refused to lead
  // ("this replica is 67524539.7 mm off the object": the object had fallen), and 18 s later the module was restarted
  // as if its plan were lost. A failed module stays out, reported failed, until it is cleared.
  const ts::ModuleSetup& m = sosm_module();
  SupervisorCore leader(m, SupervisorOptions{"m1/supervisor", 100, true, 0.1}, 0);
  SupervisorCore standby(m, SupervisorOptions{"m1/supervisor@50", 50, true, 0.1}, 0);
  std::string log;
  standby.set_log([&](const std::string& l) { log += l + "\n"; });
  for (long k = 0; k < 3000; k += 10) {
    const int64_t now = k * kMs;
    tandem::supervisor::ReportIn r;
    r.tick = k;
    r.normal_min = k < 1000 ? 29.0 : 0.0;
    r.failed = k >= 1000;
    r.object_xy = k < 1000 ? m.path.sample(0.0).pose.head<2>() : tmo::Vec2(0.0, -6.7e4);
    r.object_known = true;
    if (k < 1500) {  // the leader dies at 1500
      leader.on_report(r, now);
      leader.update(now);
      if (auto p = leader.take_plan()) standby.on_plan(*p, now);
    }
    standby.on_report(r, now);
    standby.update(now);
  }
  INFO(log);
  CHECK(standby.active());
  CHECK(standby.state() == tp::TaskStateCode::Failed);
  CHECK_FALSE(standby.no_plan());
  CHECK(log.find("taking over") != std::string::npos);
}

TEST_CASE("a standby that never heard the leader the world follows leads only an object at rest where its replica has it", "[stops]") {
  // A soak-small hour: a standby deaf to a takeover (epoch 4) stepped down; when epoch 4's leader was killed, it took
  // over with its replica of epoch 3 while the object, on the dead leader's last task, was still 5 mm from the
  // replica's rest pose: the references jumped 5 mm. Here a leader the standby never hears (epoch 1) takes over at
  // tick 1500, starts task 2 and dies; the leader the standby hears dies at 1600; the world follows task 2 to its
  // end. Task 2 ends where the replica rests (a takeover then is safe), or 0.1 m away (the module has lost its plan:
  // restarted).
  const ts::ModuleSetup& m = sosm_module();
  for (const bool same_end : {true, false}) {
    SupervisorCore leader(m, SupervisorOptions{"m1/supervisor", 100, true, 0.1}, 0);
    SupervisorCore standby(m, SupervisorOptions{"m1/supervisor@50", 50, true, 0.1}, 0);
    tp::PlanFollower world(m, true);
    std::string log;
    standby.set_log([&](const std::string& l) { log += l + "\n"; });
    long took_over_at = -1;
    double jump = 0.0;
    for (long k = 0; k < 9000; k += 10) {
      const int64_t now = k * kMs;
      tandem::supervisor::ReportIn r;
      r.tick = k;
      r.normal_min = 29.0;
      r.object_xy = world.plan().sample(k).pose.head<2>();
      r.object_known = true;
      r.world_rank = world.has_plan() ? world.rank() : tp::SupervisorRank{};
      r.world_plan_version = world.version();
      if (k < 1600) {
        leader.on_report(r, now);
        if (k == 200) leader.on_assignment(1, "t1", {0.0, 0.8, 0.0, 1.0});
        leader.update(now);
        if (auto p = leader.take_plan()) {
          world.offer(*p);
          standby.on_plan(*p, now);
        }
      }
      if (k == 1500) {  // the unheard leader: epoch 1, task 2 from where task 1 left the object
        tp::PlanData base;
        leader.plan().export_to(base);
        tp::ModulePlan unheard(m, true);
        REQUIRE(unheard.import_from(base));
        unheard.assign(2, same_end ? std::vector<double>{0.1, 0.8, 0.0, 1.0, 0.0, 0.8, 0.0, 1.0}
                                   : std::vector<double>{0.1, 0.8, 0.0, 1.0},
                       1500);
        tp::PlanData q;
        unheard.export_to(q);
        q.supervisor_id = "m1/supervisor@49";
        q.strength = 49;
        q.epoch = 1;
        REQUIRE(world.offer(q) == tp::PlanFollower::Offer::Adopted);
      }
      standby.on_report(r, now);
      standby.update(now);
      if (standby.active() && took_over_at < 0) {
        took_over_at = k;
        jump = (standby.plan().sample(k + 20).pose.head<2>() - world.plan().sample(k + 20).pose.head<2>()).norm();
      }
    }
    INFO((same_end ? "task 2 ends where task 1 did" : "task 2 ends 0.1 m away") << "\n" << log);
    CHECK(log.find("that this replica never heard") != std::string::npos);
    if (same_end) {
      CHECK(took_over_at >= 3500);  // not while the object moves on the dead leader's task
      CHECK(jump < SupervisorCore::kAloneMatch);
    } else {
      CHECK(took_over_at < 0);
      CHECK(standby.no_plan());  // the module has lost its plan: restarted
    }
  }
}

// Found by a soak-small hour (m1, 2026-11-25, commit 97dede3): the right robot died as the plan passed the zero
// speed between a task's two segments, with the leader just taken over (and starved): the world found the object
// "at rest after 0 ms" and braked the arm at once, the plan moved on with the left arm, and the object slipped
// and was dropped 148 ticks later. The world now brakes an arm it drives only once the plan has stopped too.
TEST_CASE("an arm whose controller dies where the plan's speed passes zero is braked only once the plan has stopped", "[stops]") {
  for (const int j : {0, 1}) {
    for (const long off : {-40L, 0L, 40L}) {
      for (const long starved : {0L, 400L}) {
        Rig rig(false, true);
        rig.sup[0]->on_assignment(1, "t1", {0.15, 0.8, 0.0, 1.5, 0.0, 0.85, 0.0, 1.5});
        const long kill = 20 + 1500 - 100 + off;  // the segments meet at tick 1520; the stop begins 100 ms after the kill
        rig.run_to(kill);
        rig.robot[static_cast<size_t>(j)].reset();
        if (starved > 0) rig.sup_alive[0] = false;  // the leader stands still meanwhile
        rig.run_to(kill + starved);
        rig.sup_alive[0] = true;
        rig.run_to(kill + 3000);
        INFO("arm " << j << " killed at " << kill << ", leader starved " << starved << " ticks\n" << rig.log);
        CHECK(rig.slips() == 0);
        CHECK_FALSE(rig.w.failed());
        CHECK(rig.w.braked(j));
        CHECK(rig.min_normal >= rig.m.safe_grasp_force);
      }
    }
  }
}

TEST_CASE("a takeover older than the live leader's plan is refused by the followers, and the leader retakes", "[stops]") {
  // Found by a soak-small hour (seed 11, m2 at 2778 s): the standby took over from a leader silent for 50 ms with plan
  // version 4; the leader, only stalled, started the next task in version 5 which the world followed; the standby's
  // takeover reached the world 320 ticks later, the references jumped 9.99 mm and the object slid out. Here the
  // leader stands still from tick 1940, the standby takes over at 2000 on a report of before the leader's next task,
  // its takeover plans reach the others only from 2300 on. Cases: the leader lives on (the world refuses the older
  // takeover, the leader retakes above it, the standby steps down to it); the leader dies at 2000 right after its
  // newest plan (refused, no one retakes: the module has lost its plan, no_plan); the world has not heard the
  // leader's newest plan when the takeover arrives (the world follows the taker, the leader steps down to it).
  const ts::ModuleSetup& m = sosm_module();
  enum Case { Lives, Dies, WorldBehind };
  for (const Case c : {Lives, Dies, WorldBehind}) {
    SupervisorCore leader(m, SupervisorOptions{"m1/supervisor", 100, true, 0.1}, 0);
    SupervisorCore standby(m, SupervisorOptions{"m1/supervisor@50", 50, true, 0.1}, 0);
    tp::PlanFollower world(m, true);
    tp::PlanFollower robot(m, true);  // a robot that heard every plan, in the order the world did
    std::string log, world_log;
    leader.set_log([&](const std::string& l) { log += "leader: " + l + "\n"; });
    standby.set_log([&](const std::string& l) { log += "standby: " + l + "\n"; });
    std::optional<tp::PlanData> leader_newest_held;  // WorldBehind: the leader's plan of t2, late to the world
    std::optional<tp::PlanData> taker_held;           // the standby's plans, delayed until 2300
    double max_step = 0.0;                            // the world's object reference, tick to tick [m]
    tmo::Vec2 prev = world.plan().sample(0).pose.head<2>();
    auto to_followers = [&](const tp::PlanData& p, long k) {
      std::string why;
      world.offer(p, &why, k);
      if (!why.empty()) world_log += why + "\n";
      robot.offer(p, nullptr, k);
    };
    for (long k = 0; k < 12000; ++k) {
      const int64_t now = k * kMs;
      const tmo::Vec2 xy = world.plan().sample(k).pose.head<2>();
      max_step = std::max(max_step, (xy - prev).norm());
      prev = xy;
      if (k % 10 != 0) continue;
      const tandem::supervisor::ReportIn r = report_of(world, k);
      // The standby: it hears the world's report of this tick before the leader's plan of this tick.
      standby.on_report(r, now);
      standby.update(now);
      if (auto p = standby.take_plan()) {
        if (k < 2300) {
          taker_held = *p;  // the takeover (and its heartbeats) reach the others late
        } else {
          to_followers(*p, k);
          leader.on_plan(*p, now);
        }
      }
      if (k == 2300 && taker_held) {
        to_followers(*taker_held, k);
        leader.on_plan(*taker_held, now);
      }
      const bool leader_runs = (k < 1940 || k >= 2000) && (c != Dies || k <= 2000);
      if (leader_runs) {
        leader.on_report(r, now);
        if (k == 500) {
          leader.on_assignment(1, "t1", {0.0, 0.8, 0.0, 1.0});
          standby.on_assignment(1, "t1", {0.0, 0.8, 0.0, 1.0});
        }
        if (k == 2000) {
          leader.on_assignment(2, "t2", {-0.1, 0.8, 0.0, 1.0});
          standby.on_assignment(2, "t2", {-0.1, 0.8, 0.0, 1.0});
        }
        leader.update(now);
        if (auto p = leader.take_plan()) {
          if (c == WorldBehind && k >= 2000 && k < 2400 && p->task_id == 2 && p->epoch == 0) {
            leader_newest_held = *p;  // reaches the world after the takeover
          } else {
            to_followers(*p, k);
          }
          // From 1940 on the standby hears nothing of this leader, but a retake (a new writer's sample) it hears.
          if (k < 1940 || p->epoch > 0) standby.on_plan(*p, now);
        }
      }
      if (k == 2400 && leader_newest_held) to_followers(*leader_newest_held, k);
    }
    INFO("case " << c << "\n" << log << "world:\n" << world_log);
    // No reference jump under the object at any time: under the path's own speed (0.2 m/s peak: 0.2 mm a tick).
    CHECK(max_step < 0.5e-3);
    CHECK(robot.rank().epoch == world.rank().epoch);
    CHECK(robot.version() == world.version());
    if (c == Lives) {
      CHECK(world_log.find("a takeover plan older than the one followed was refused") != std::string::npos);
      CHECK(log.find("retaking in epoch 2") != std::string::npos);
      CHECK(leader.active());
      CHECK_FALSE(standby.active());
      CHECK(world.rank().epoch == 2);
      CHECK(leader.plan().done() == 2);  // t2 ran to its end under the leader
    } else if (c == Dies) {
      CHECK(world_log.find("was refused") != std::string::npos);
      CHECK(log.find("the world refuses this takeover") != std::string::npos);
      // Not a lost plan (a leader made a newer one than this replica): the taker leaves the lead and comes back as a
      // standby with a fresh participant (exit 6); the object rests at t2's end meanwhile.
      CHECK(standby.deaf());
      CHECK_FALSE(standby.no_plan());
      CHECK(world.rank().epoch == 0);
    } else {
      CHECK(log.find("waiting for the world") != std::string::npos);
      CHECK(log.find("leader: stepping down") != std::string::npos);
      CHECK(standby.active());
      CHECK_FALSE(leader.active());
      CHECK(world.rank().epoch == 1);
      CHECK(standby.plan().done() == 2);  // the taker started t2 itself (its assignment) and ended it
    }
  }
}

TEST_CASE("a leader whose reports lag does not retake over a takeover the world follows, a second standby with the newer plan leads instead of a stale taker", "[stops]") {
  // From the review of the refusal rule. (1) The leader hears the stale taker before the world's reports of the
  // meantime: its reports lag 60 ticks, the world adopted the taker (it lacked the leader's newest version). A retake
  // on a timer would jump the references back to the leader's branch; the retake needs proof (the world follows the
  // leader's rank in a version newer than the taker's). (2) The leader dies right after its newest plan; standby A
  // missed it and takes over (refused), standby B has it: B does not follow A, takes over above A's epoch, and A
  // steps down to B.
  const ts::ModuleSetup& m = sosm_module();
  for (const int c : {1, 2}) {
    SupervisorCore leader(m, SupervisorOptions{"m1/supervisor", 100, true, 0.1}, 0);
    SupervisorCore a(m, SupervisorOptions{"m1/supervisor@50", 50, true, 0.1}, 0);
    SupervisorCore b(m, SupervisorOptions{"m1/supervisor@40", 40, true, 0.1}, 0);
    tp::PlanFollower world(m, true);
    std::string log;
    leader.set_log([&](const std::string& l) { log += "leader: " + l + "\n"; });
    a.set_log([&](const std::string& l) { log += "a: " + l + "\n"; });
    b.set_log([&](const std::string& l) { log += "b: " + l + "\n"; });
    std::vector<tandem::supervisor::ReportIn> reports;  // by tick / 10
    std::optional<tp::PlanData> a_held, leader_held;
    double max_step = 0.0;
    tmo::Vec2 prev = world.plan().sample(0).pose.head<2>();
    const long leader_dies = c == 2 ? 2000 : 1L << 40;
    for (long k = 0; k < 9000; ++k) {
      const int64_t now = k * kMs;
      const tmo::Vec2 xy = world.plan().sample(k).pose.head<2>();
      max_step = std::max(max_step, (xy - prev).norm());
      prev = xy;
      if (k % 10 != 0) continue;
      const tandem::supervisor::ReportIn r = report_of(world, k);
      reports.push_back(r);
      auto to_all = [&](const tp::PlanData& p, SupervisorCore* except) {
        world.offer(p, nullptr, k);
        for (SupervisorCore* s : {&leader, &a, &b}) {
          if (s != except && (s != &leader || k <= leader_dies) && (s != &b || c == 2)) s->on_plan(p, now);
        }
      };
      // Standby A: hears nothing of the leader from 1940; its takeover reaches the others from 2300 on.
      a.on_report(r, now);
      if (k == 500 || k == 2000) a.on_assignment(k == 500 ? 1 : 2, "t", {k == 500 ? 0.0 : -0.1, 0.8, 0.0, 1.0});
      a.update(now);
      if (auto p = a.take_plan()) {
        if (k < 2300) a_held = *p;
        else to_all(*p, &a);
      }
      if (k == 2300 && a_held) to_all(*a_held, &a);
      if (c == 2) {  // standby B: only in case 2
        b.on_report(r, now);
        if (k == 500 || k == 2000) b.on_assignment(k == 500 ? 1 : 2, "t", {k == 500 ? 0.0 : -0.1, 0.8, 0.0, 1.0});
        b.update(now);
        if (auto p = b.take_plan()) to_all(*p, &b);
      }
      if (k <= leader_dies && (k < 1940 || k >= 2000)) {
        // Case 1: the leader's reports lag 60 ticks from 2000 on.
        const size_t lag = c == 1 && k >= 2000 ? 6 : 0;
        leader.on_report(reports[reports.size() - 1 - lag], now);
        if (k == 500) leader.on_assignment(1, "t", {0.0, 0.8, 0.0, 1.0});
        if (k == 2000) leader.on_assignment(2, "t", {-0.1, 0.8, 0.0, 1.0});
        leader.update(now);
        if (auto p = leader.take_plan()) {
          if (c == 1 && p->task_id == 2 && p->epoch == 0 && k < 2400) {
            leader_held = *p;  // case 1: the world hears the leader's newest plan only after the takeover
          } else {
            world.offer(*p, nullptr, k);
            if (c == 2) b.on_plan(*p, now);
            if (k < 1940 || p->epoch > 0) a.on_plan(*p, now);
          }
        }
      }
      if (k == 2400 && leader_held) world.offer(*leader_held, nullptr, k);
    }
    INFO("case " << c << "\n" << log);
    CHECK(max_step < 0.5e-3);  // no jump under the object, ever
    if (c == 1) {
      CHECK(log.find("retaking in epoch") == std::string::npos);
      CHECK(log.find("leader: stepping down") != std::string::npos);
      CHECK(a.active());
      CHECK(world.rank().epoch == 1);
    } else {
      CHECK(log.find("b: m1/supervisor@50 took over in epoch 1 with plan version") != std::string::npos);
      CHECK(b.active());
      CHECK_FALSE(a.active());
      CHECK(world.rank().epoch == 2);
      CHECK(world.rank().strength == 40);
      CHECK(b.plan().done() == 2);  // t2 ran to its end under B
    }
  }
}

// Finding 54 (docs/soak.md): a fresh world's robots answer first only 300-500 ms after its first tick (a machine
// busy with restarts): both arms stay start-braked past tick 100, then are released one after the other while
// the grasp is still building, and the next task runs.
TEST_CASE("a fresh module whose robots answer first 0.3-0.5 s late holds the object through its first tasks", "[stops]") {
  for (const long first : {150L, 435L}) {
    for (const long gap : {0L, 3L, 40L}) {
      Rig rig(false, true);
      for (auto& r : rig.robot) r.reset();
      uint64_t next_id = 1;
      auto feed = [&] {
        if (rig.k % 50 == 0 && rig.sup[0]->state() != tp::TaskStateCode::Running) {
          const double x = next_id % 2 == 1 ? 0.15 : -0.15;
          rig.sup[0]->on_assignment(next_id, "t" + std::to_string(next_id), {x, 0.8, 0.0, 1.5, 0.0, 0.85, 0.0, 1.5});
          ++next_id;
        }
      };
      auto run = [&](long end) { while (rig.k < end) { feed(); rig.tick(); } };
      run(first);
      for (int j : {0, 1}) {
        rig.robot[static_cast<size_t>(j)] = std::make_unique<RobotCore>(rig.m, j, true, 0.1);
        rig.robot[static_cast<size_t>(j)]->offer_plan(*rig.last_plan);
        if (j == 0) run(rig.k + gap);
      }
      double min_normal = 1e300;
      while (rig.k < 8000) {
        feed();
        rig.tick();
        const tmo::ContactReading c = rig.w.plant().contacts();
        min_normal = std::min({min_normal, c.normal[0], c.normal[1]});
      }
      INFO("first " << first << " gap " << gap << " tasks " << rig.sup[0]->plan().done() << " min normal " << min_normal
                    << "\n" << rig.log);
      CHECK(rig.slips() == 0);
      CHECK(rig.contact_lost() == 0);
      CHECK(rig.sup[0]->plan().done() >= 2);
    }
  }
}

// Finding 53 (docs/soak.md, the lockstep soak hour): in a fresh module a standby heard the leader's first plan
// (at rest) and then nothing; the leader started the coordinator's first task, which the robots followed before the
// world's reports said so; the leader stood still and the standby took over with its plan at rest (and started the
// same task anew): the robots' references jumped back 3.2 mm under the moving object, which was dropped. Here the
// world's reports lag the robots' plan by `lag` ticks (its version with them), so the version rule (behind_world)
// cannot always tell; the object's motion can. The standby stands still for 0.1 s as the task starts.
TEST_CASE("a standby at rest does not take over while the object moves on a leader's plan it missed", "[stops]") {
  const ts::ModuleSetup& m = sosm_module();
  for (const long lag : {0L, 60L, 100000L}) {
    for (const long silent_from : {120L, 200L, 400L}) {
      SupervisorCore leader(m, SupervisorOptions{"m3/supervisor", 100, true, 0.1}, 0);
      SupervisorCore standby(m, SupervisorOptions{"m3/supervisor@50", 50, true, 0.1}, 0);
      tp::PlanFollower robots(m, true), world(m, true);
      std::vector<std::pair<long, tp::PlanData>> to_world;  // plans on their way to the world (`lag` ticks)
      std::string log;
      standby.set_log([&](const std::string& l) { log += l + "\n"; });
      long took_over_at = -1;
      double jump = 0.0;
      for (long k = 0; k < 4000; k += 10) {
        const int64_t now = k * kMs;
        while (!to_world.empty() && to_world.front().first + lag <= k) {
          world.offer(to_world.front().second);
          to_world.erase(to_world.begin());
        }
        tandem::supervisor::ReportIn r;
        r.tick = k;
        r.normal_min = 29.0;
        r.object_xy = robots.has_plan() ? robots.plan().sample(k).pose.head<2>() : tmo::Vec2(0.0, 0.8);
        r.object_known = true;
        r.world_rank = world.has_plan() ? world.rank() : tp::SupervisorRank{};
        r.world_plan_version = world.version();
        if (k == 60) {  // the coordinator's first task, to every supervisor of the module
          leader.on_assignment(1, "t1", {0.3, 0.8, 0.0, 1.5});
          standby.on_assignment(1, "t1", {0.3, 0.8, 0.0, 1.5});
        }
        if (k < silent_from) {  // the leader stands still from then on (for good here)
          leader.on_report(r, now);
          leader.update(now);
          if (auto p = leader.take_plan()) {
            robots.offer(*p, nullptr, k);
            to_world.emplace_back(k, *p);
            if (p->version == 0) standby.on_plan(*p, now);  // the standby hears the leader's first plan only
          }
        }
        if (k >= 50 && k < 150) continue;  // the standby itself stands still meanwhile (a hog)
        standby.on_report(r, now);
        standby.update(now);
        if (auto p = standby.take_plan()) {
          if (standby.active() && took_over_at < 0) took_over_at = k;
          robots.offer(*p, nullptr, k);
          to_world.emplace_back(k, *p);
          jump = std::max(jump, robots.jump());
        }
      }
      INFO("world lag " << lag << " ticks, leader silent from " << silent_from << "; took over at " << took_over_at
                        << ", jump " << jump * 1e3 << " mm\n" << log);
      // A takeover is allowed only where its plan continues the robots' (a jump under a millimetre).
      CHECK(jump < tp::PlanFollower::kMaxJump);
    }
  }
}

// Lockstep soak run 43 (finding 73): an arm whose robots left it off its plan (0.36 mm in position; the orientation
// was not recorded) lost its controllers under a hog, and the world's drive, a stiff PD towards the plan, put 3000 N m
// (the limit) on joint 1 at its first tick; the robot that took the arm back continued from that torque (bumpless),
// and the object was dropped. Here a wrist disturbance the robot's law does not fully reject leaves the arm off its
// plan in orientation; its last controller dies at peak speed. The drive keeps the offset and bounds its correction.
TEST_CASE("the world's stop of an arm off its plan keeps the offset: bounded torques, no slip (finding 73)", "[stops]") {
  for (const bool realtime : {true, false}) {
    for (const int j : {0, 1}) {
      for (const double scale : {0.5, 1.0}) {
       for (const bool back : {false, true}) {
        const double bias = (j == 0 ? 10.0 : -10.0) * scale;  // [N m] on the wrist: an offset of 0.005-0.1 rad
        Rig rig(false, false, realtime);
        const size_t a = static_cast<size_t>(j);
        rig.run_to(1500);
        rig.bias[a](2) = bias;
        rig.run_to(kPeakTick);
        const double offset = rig.sup[0]->plan().reference(j, rig.k).x(2) - rig.w.plant().end_effector(j)(2);
        const long slips_before = rig.slips();
        // Killed, or (as in run 43) stalled until the stop has begun, then back: it takes the arm over from the drive's
        // torque (bumpless), so the drive's torque must be one to continue from.
        const long stop_after = realtime ? 101 : 1;
        if (back) rig.mute_until[a] = kPeakTick + stop_after + 3;
        else rig.robot[a].reset();
        tmo::JointVec drive_max = tmo::JointVec::Zero(3);
        double offset_braked = 0.0;  // the orientation offset when the brake engaged
        while (rig.k < kPeakTick + 1500) {
          const bool was_braked = rig.w.braked(j);
          rig.tick();
          if (rig.out[a].applied_from == -1) drive_max = drive_max.cwiseMax(rig.out[a].tau_applied.cwiseAbs());
          if (rig.w.braked(j) && !was_braked) {
            offset_braked = rig.sup[0]->plan().reference(j, rig.k).x(2) - rig.w.plant().end_effector(j)(2);
          }
        }
        INFO((realtime ? "real time" : "lockstep") << (back ? ", back after the stop began" : ", killed") << ", arm " << j << ", wrist bias " << bias << " N m, offset " << offset
                                                   << " rad (" << offset_braked << " when braked), drive max "
                                                   << drive_max.transpose() << "\n" << rig.log);
        REQUIRE(slips_before == 0);
        REQUIRE(std::abs(offset) > 0.003);  // the arm is off its plan when the stop begins
        if (back) {
          CHECK(rig.log.find("driven by the world") != std::string::npos);  // the robot took the stopping arm back
        } else {
          CHECK(rig.log.find("object at rest after") != std::string::npos);
          CHECK(rig.w.braked(j));
          // The drive held the arm where it was relative to the plan (a drive that pulled it back would not). Not in
          // the 0.1 rad case: there the wrist was turning at about 1.3 rad/s against the plan when its robot died, and
          // the drive stops that turn at its bounded rate (0.5 a_max / r), which takes it 0.13 rad further.
          if (scale < 1.0) CHECK(std::abs(offset_braked - offset) < 0.25 * std::abs(offset));
        }
        // The drive never went near the actuator limits (3000, 1500, 500 N m); the old one hit 3000 N m on joint 1.
        // (The longest case here, the 0.1 rad one on arm 1, peaks at 483 N m on joint 1 with finding 77's gentler stops,
        // 419 N m with the stops of before.)
        const tmo::Vec3 limit = rig.m.plant.arms[a].tau_max;
        for (int i = 0; i < 3; ++i) CHECK(drive_max(i) < 0.2 * limit(i));
        CHECK(rig.slips() == 0);
        CHECK(rig.contact_lost() == 0);
        CHECK(rig.min_normal >= rig.m.safe_grasp_force);
        CHECK(rig.max_decel <= a_max(rig.m));
       }
      }
    }
  }
}


// The CI soak's drop (finding 77): a module paused for load, released, and overloaded again while its path was still
// ramping back to speed. The stop then cut into the resume's ramp: the path's acceleration stepped from +2 m/s^2 to
// the stop's, the arms (and the object between its two compliant contacts) overshot the plan and then braked harder
// than the stop asked for; the leading contact's normal force fell under h_sg and the object slid 2 mm. With the
// time scale's ramps continuous in acceleration and the stop within a quarter of the friction bound, every phase
// of that sequence keeps the grasp (before: 12 of 135 such runs slipped, 3 of them dropped the object).
TEST_CASE("an overload stop that cuts into the resume after a pause keeps the grasp (finding 77)", "[stops]") {
  double worst = 1e300;
  int runs = 0, rising = 0;  // how many of the second holds came while the resume was still speeding the path up
  for (const long first : {600L, 700L, 800L}) {
    for (long gap = 280; gap <= 400; gap += 20) {
      Rig rig(false, true);
      uint64_t next_id = 1;
      long released = -1, second = -1;
      bool was_paused = false;
      // The left robot's answers come late every third tick (the world's overload rule: 11 in 100 ticks), first from
      // tick `first`, then again `gap` ticks after the release.
      rig.late = [&](int j, long k) {
        const bool again = second >= 0 && k >= second && k < second + 300 && rig.w.load_pauses == 1;
        return j == 0 && k % 3 == 0 && ((k >= first && k < first + 300 && rig.w.load_pauses == 0) || again);
      };
      long hold_at = -1;
      while (second < 0 || rig.k < second + 1200) {
        REQUIRE(rig.k < 8000);
        if (hold_at < 0 && rig.w.load_pauses == 2) hold_at = rig.k;
        if (rig.k % 50 == 0 && rig.sup[0]->state() != tp::TaskStateCode::Running) {
          const double x = next_id % 2 == 1 ? 0.15 : -0.15;
          rig.sup[0]->on_assignment(next_id, "t" + std::to_string(next_id), {x, 0.8, 0.0, 1.5, 0.0, 0.85, 0.0, 1.5});
          ++next_id;
        }
        rig.tick();
        const bool paused = rig.w.paused_for_load();
        if (was_paused && !paused && released < 0) {
          released = rig.k;
          second = released + gap;
        }
        was_paused = paused;
      }
      INFO("late from tick " << first << ", again " << gap << " ticks after the release at " << released << "\n" << rig.log);
      CHECK(rig.w.load_pauses == 2);
      CHECK(rig.slips() == 0);
      CHECK(rig.contact_lost() == 0);
      CHECK_FALSE(rig.w.failed());
      CHECK(rig.min_normal >= rig.m.safe_grasp_force);
      worst = std::min(worst, rig.min_normal);
      ++runs;
      if (hold_at > 10) {
        const tp::ModulePlan& p = rig.sup[0]->plan();
        if (p.sample(hold_at).vel.head<2>().norm() > p.sample(hold_at - 10).vel.head<2>().norm() + 1e-3) ++rising;
      }
    }
  }
  // The case this is about: most of these second holds cut into the resume while it still sped the path up.
  CHECK(2 * rising >= runs);
  // Margin: the worst normal force of these runs stays 2 N above h_sg (23.5 N against 19.62 N when written).
  CHECK(worst >= sosm_module().safe_grasp_force + 2.0);
}
