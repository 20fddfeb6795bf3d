// The soak's parts with no processes: the schedule (seeded, validated), the checker on made-up histories, and
// the SVG plot writer.
#include <catch2/catch.hpp>

#include "tandem/page/html.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>

#include "tandem/soak/checker.hpp"
#include "tandem/soak/history_file.hpp"
#include "tandem/soak/report.hpp"
#include "tandem/soak/schedule.hpp"
#include "tandem/page/svg.hpp"

using namespace tandem::soak;
using namespace tandem::page;

namespace {

std::string error_of(const std::string& yaml) {
  try {
    (void)parse_fault_file(yaml, "f.yaml");
  } catch (const ScheduleError& e) {
    return e.what();
  }
  return "";
}

/// A quiet run of one module at 10 Hz buckets: force 30 N (h_sg 20 N), a task done every 4 s.
History quiet_history(double seconds) {
  History h;
  h.duration_s = h.stop_s = seconds;
  h.h_sg["m1"] = 20.0;
  for (int i = 1; i <= static_cast<int>(seconds * 10); ++i) {
    ModuleSample s;
    s.t = 0.1 * i;
    s.tick = 100L * i;
    s.normal_min = 30.0;
    s.world = 1;
    h.modules["m1"].push_back(s);
  }
  h.events.push_back({0.5, Event::Type::Owners, "m1", "left=m1/left,right=m1/right", {{"left", "m1/left"}, {"right", "m1/right"}}});
  for (int k = 1; 4.0 * k < seconds; ++k) {
    const std::string name = "t" + std::to_string(k);
    h.task_names.push_back(name);
    h.events.push_back({4.0 * k - 3.5, Event::Type::TaskAssigned, name, "m1"});
    h.events.push_back({4.0 * k, Event::Type::TaskDone, name, "m1"});
    h.tasks_done.push_back(name);
    h.tasks_done_by.push_back("m1");
  }
  std::sort(h.events.begin(), h.events.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  return h;
}

// The SIGKILL of m1's leading supervisor at 20.0 s (`warm`: a standby held its plan).
FaultRecord kill_supervisor(bool warm) {
  FaultRecord f;
  f.fault.index = 1;
  f.fault.kind = FaultKind::Kill;
  f.fault.target = Target::Supervisor;
  f.t = 20.0;
  f.label = "m1/supervisor";
  f.module = "m1";
  f.pid = 111;
  f.had_standby = warm;
  return f;
}

FaultRecord kill_left(double t) {
  FaultRecord f;
  f.fault.index = 1;
  f.fault.kind = FaultKind::Kill;
  f.fault.target = Target::Robot;
  f.t = t;
  f.label = "m1/left";
  f.module = "m1";
  f.pid = 111;
  return f;
}

/// A fault on m1 carried out at t (`label`'s process of pid 333).
FaultRecord m1_fault(int index, FaultKind kind, Target target, double t, const std::string& label, double end_t) {
  FaultRecord f;
  f.fault.index = index;
  f.fault.kind = kind;
  f.fault.target = target;
  f.t = t;
  f.label = label;
  f.module = "m1";
  f.pid = 333;
  f.end_t = end_t;
  return f;
}

/// m1/left unplugged at t for a hand-over (plugged back 4 s later), heard at tick 20000.
FaultRecord handover_unplug(double t) {
  FaultRecord f = kill_left(t);
  f.fault.kind = FaultKind::Unplug;
  f.module_tick = 20000;
  f.end_t = t + 4.0;
  return f;
}

void add_event(History& h, Event e) {
  h.events.push_back(std::move(e));
  std::stable_sort(h.events.begin(), h.events.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
}

const Violation* find(const Verdict& v, const std::string& invariant) {
  for (const auto& x : v.violations) {
    if (x.invariant == invariant) return &x;
  }
  return nullptr;
}

/// The first recovery of `kind` the checker measured [s]; -1 if none.
double recovery_s(const Verdict& v, const std::string& kind) {
  for (const auto& r : v.recoveries) {
    if (r.kind == kind) return r.seconds;
  }
  return -1.0;
}

}  // namespace

TEST_CASE("soak schedule: the same seed gives the same schedule, another seed another") {
  const FaultFile f = preset("mixed");
  const Schedule a = make_schedule(f, 42, 600.0), b = make_schedule(f, 42, 600.0), c = make_schedule(f, 43, 600.0);
  REQUIRE(a.faults.size() == b.faults.size());
  for (size_t i = 0; i < a.faults.size(); ++i) {
    CHECK(a.faults[i].at_s == b.faults[i].at_s);
    CHECK(a.faults[i].kind == b.faults[i].kind);
    CHECK(a.faults[i].target == b.faults[i].target);
    CHECK(a.faults[i].pick == b.faults[i].pick);
    CHECK(a.faults[i].duration_s == b.faults[i].duration_s);
  }
  bool differs = a.faults.size() != c.faults.size();
  for (size_t i = 0; !differs && i < a.faults.size(); ++i) differs = a.faults[i].at_s != c.faults[i].at_s;
  CHECK(differs);
}

TEST_CASE("soak schedule: rates, spacing, warm-up and quiet end hold, and every rule fires at least once") {
  const FaultFile f = preset("mixed");
  const Schedule s = make_schedule(f, 7, 3600.0);
  // About 20.5 faults a minute over the 3575 s between warm-up and quiet end: 1220 expected, Poisson spread.
  CHECK(s.faults.size() > 1050);
  CHECK(s.faults.size() < 1400);
  for (size_t i = 0; i < s.faults.size(); ++i) {
    CHECK(s.faults[i].at_s >= f.warmup_s);
    CHECK(s.faults[i].at_s < 3600.0 - f.quiet_s);
    if (i > 0) CHECK(s.faults[i].at_s - s.faults[i - 1].at_s >= f.spacing_s - 1e-9);
    CHECK(s.faults[i].index == static_cast<int>(i + 1));
  }
  const Schedule ci = make_schedule(preset("ci"), 11, 75.0);
  std::set<std::string> kinds;
  for (const auto& x : ci.faults) kinds.insert(label(x.kind, x.target) + (x.kind == FaultKind::Hog ? std::to_string(x.cores) : ""));
  CHECK(kinds.size() == preset("ci").rules.size());
}

TEST_CASE("soak schedule: a schedule written as YAML reads back as the same faults") {
  const Schedule s = make_schedule(preset("ci"), 5, 80.0);
  const FaultFile back = parse_fault_file(to_yaml(s), "written");
  const Schedule again = make_schedule(back, 999, 80.0);
  REQUIRE(again.faults.size() == s.faults.size());
  for (size_t i = 0; i < s.faults.size(); ++i) {
    CHECK(again.faults[i].at_s == Approx(s.faults[i].at_s).margin(1e-5));
    CHECK(again.faults[i].kind == s.faults[i].kind);
    CHECK(again.faults[i].target == s.faults[i].target);
    CHECK(again.faults[i].pick == s.faults[i].pick);
    CHECK(again.faults[i].duration_s == Approx(s.faults[i].duration_s).epsilon(1e-5));
  }
}

TEST_CASE("soak schedule: bad files are refused with the key and what is accepted") {
  CHECK_THAT(error_of("faults:\n  - {kind: kill, target: robot, rate: 1, often: 2}\n"),
             Catch::Contains("unknown key 'often'") && Catch::Contains("accepted: at_least, cores, kind, max, min, rate, target"));
  CHECK_THAT(error_of("faults:\n  - {kind: explode, target: robot, rate: 1}\n"),
             Catch::Contains("'kind' = 'explode'") && Catch::Contains("accepted: kill, stall, unplug, hog"));
  CHECK_THAT(error_of("faults:\n  - {kind: unplug, target: coordinator, rate: 1}\n"),
             Catch::Contains("not accepted for unplug") && Catch::Contains("accepted: robot, standby, module"));
  CHECK_THAT(error_of("faults:\n  - {kind: kill, target: robot, rate: -1}\n"), Catch::Contains("'rate' = -1 is out of range"));
  CHECK_THAT(error_of("faults:\n  - {kind: stall, target: robot, rate: 1, min: 2, max: 1}\n"), Catch::Contains("'max' is below 'min'"));
  CHECK_THAT(error_of("faults:\n  - {kind: kill, target: robot, rate: 1, cores: 2}\n"), Catch::Contains("'cores' is only for hog"));
  CHECK_THAT(error_of("faults:\n  - {kind: kill, target: robot}\n"), Catch::Contains("missing 'rate'"));
  CHECK_THAT(error_of("at:\n  - {kind: kill, process: m1/left}\n"), Catch::Contains("missing 'at'"));
  CHECK_THAT(error_of("warmup: soon\nfaults: []\n"), Catch::Contains("'warmup' must be a number"));
  CHECK_THAT(error_of("fautls: []\n"), Catch::Contains("unknown key 'fautls'"));
  CHECK_THAT(error_of("[1, 2"), Catch::Contains("not valid YAML"));
  CHECK_THROWS_WITH(preset("gentle"), Catch::Contains("presets: mixed, ci, kills, none"));
  CHECK_THROWS_WITH(make_schedule(parse_fault_file("at:\n  - {at: 100, kind: kill, process: m1/left}\n", "f"), 1, 60.0),
                    Catch::Contains("past the end of the run"));
  CHECK(error_of("faults: []\n").empty());
}

TEST_CASE("soak checker: a quiet run holds every invariant") {
  const Verdict v = check(quiet_history(60.0), Bounds{});
  CHECK(v.ok());
  for (const auto& r : v.invariants) CHECK(r.ok);
}

TEST_CASE("soak report: modules parked at start-up and during the run are listed, and 'None' only without any") {
  History h = quiet_history(60.0);
  const Bounds b{};
  RunInfo info;
  const std::string quiet = summary_text(info, h, b, check(h, b));
  CHECK(quiet.find("None: the load always fitted") != std::string::npos);
  h.events.push_back({0.4, Event::Type::Parked, "m3", "admission at start-up: 2 of 4 fit"});
  h.events.push_back({35.0, Event::Type::Unparked, "m3", "calm: no module paused for load for 30 s"});
  const std::string shed = summary_text(info, h, b, check(h, b));
  CHECK(shed.find("- 0.4 s: m3 parked (admission at start-up: 2 of 4 fit)") != std::string::npos);
  CHECK(shed.find("- 35.0 s: m3 back (calm") != std::string::npos);
  CHECK(shed.find("None: the load always fitted") == std::string::npos);
}

TEST_CASE("soak checker: an arm served again by its own restarted robot (same label, new pid) counts as served") {
  // Run 13: the serving m1/right@49 was killed; its restart, also m1/right@49, served the arm 2 s later, and the
  // checker (by label) waited for another label for 136 s.
  History h = quiet_history(60.0);
  FaultRecord f = kill_left(20.0);
  f.had_standby = false;  // no standby: the arm waits for the restart (bound: restart_s)
  h.faults.push_back(f);
  add_event(h, {20.2, Event::Type::Owners, "m1", "left=braked,right=m1/right", {{"left", ""}, {"right", "m1/right"}}});
  add_event(h, {21.5, Event::Type::State, "m1/left", "2 333"});  // the restart: same label, new pid
  add_event(h, {22.0, Event::Type::Owners, "m1", "left=m1/left,right=m1/right", {{"left", "m1/left"}, {"right", "m1/right"}}});
  Bounds b;
  b.restart_s = 10.0;
  Verdict v = check(h, b);
  INFO((find(v, "recovery") ? find(v, "recovery")->text : std::string()));
  CHECK(find(v, "recovery") == nullptr);
  // The same label before the restart is active (the old process's last word) does not count.
  History old = quiet_history(60.0);
  old.faults.push_back(f);
  add_event(old, {20.2, Event::Type::Owners, "m1", "left=m1/left,right=m1/right", {{"left", "m1/left"}, {"right", "m1/right"}}});
  add_event(old, {40.0, Event::Type::State, "m1/left", "2 333"});
  add_event(old, {40.5, Event::Type::Owners, "m1", "left=m1/left,right=m1/right", {{"left", "m1/left"}, {"right", "m1/right"}}});
  v = check(old, b);
  REQUIRE(find(v, "recovery") != nullptr);
  CHECK_THAT(find(v, "recovery")->text, Catch::Contains("no other robot served"));
}

TEST_CASE("soak checker: a slip is a violation at its time, after the fault before it") {
  History h = quiet_history(60.0);
  h.faults.push_back(kill_left(20.0));
  add_event(h, {20.03, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}});
  add_event(h, {21.5, Event::Type::State, "m1/left@49", "2 222"});
  for (auto& s : h.modules["m1"]) {
    if (s.t >= 25.0) s.slips = 3;
    if (s.t >= 25.5) s.contact_lost = 7;
  }
  const Verdict v = check(h, Bounds{});
  const Violation* x = find(v, "object held");
  REQUIRE(x != nullptr);
  CHECK(x->t == Approx(25.0).margin(0.051));
  CHECK(x->fault == 1);
  CHECK_THAT(x->text, Catch::Contains("slipped"));
  CHECK(std::count_if(v.violations.begin(), v.violations.end(), [](const Violation& y) { return y.invariant == "object held"; }) == 1);
  CHECK(find(v, "recovery") == nullptr);
}

TEST_CASE("soak checker: every object incident counts, a failed module is one, and a task counts only if held throughout") {
  // Two slips 10 s apart on one world: two incidents (no longer one per world instance).
  History h = quiet_history(60.0);
  for (auto& s : h.modules["m1"]) {
    if (s.t >= 24.25) s.slips = 3;   // between task t6 (done at 24.0) and t7 (assigned at 24.5)
    if (s.t >= 34.95) s.slips = 5;   // during task t9 (assigned at 32.5, done at 36.0)
  }
  Verdict v = check(h, Bounds{});
  CHECK(std::count_if(v.violations.begin(), v.violations.end(), [](const Violation& y) { return y.invariant == "object held"; }) == 2);
  CHECK(v.slip_events == 5);
  CHECK(v.incidents["m1"] == 2);
  const Violation* x = find(v, "tasks held throughout");
  REQUIRE(x != nullptr);
  CHECK_THAT(x->text, Catch::Contains("task t9 was counted done by m1"));
  CHECK(std::count_if(v.violations.begin(), v.violations.end(), [](const Violation& y) { return y.invariant == "tasks held throughout"; }) == 1);
  // A world that reports its module failed: an incident, and the task running then is not done.
  History f = quiet_history(60.0);
  for (auto& s : f.modules["m1"]) {
    if (s.t >= 40.0) s.failed = true;
  }
  v = check(f, Bounds{});
  x = find(v, "object held");
  REQUIRE(x != nullptr);
  CHECK_THAT(x->text, Catch::Contains("failed (object dropped)"));
  REQUIRE(find(v, "tasks held throughout") != nullptr);
  // After the failure the object lies on the floor: the world's contact-lost counter goes on rising, in bursts
  // (seen in a soak-small hour: a second "incident" 120 s after the drop). That is the same failure, not a new one.
  History g = quiet_history(60.0);
  for (auto& s : g.modules["m1"]) {
    if (s.t >= 40.0) s.failed = true;
    if (s.t >= 45.0) s.contact_lost = 1000;
    if (s.t >= 55.0) s.contact_lost = 4000;
  }
  v = check(g, Bounds{});
  CHECK(std::count_if(v.violations.begin(), v.violations.end(), [](const Violation& y) { return y.invariant == "object held"; }) == 1);
  CHECK(v.incidents["m1"] == 0);
}

TEST_CASE("soak checker: grasp force below h_sg counts only outside the stated windows") {
  History h = quiet_history(30.0);
  auto& s = h.modules["m1"];
  s[3].normal_min = 5.0;    // t = 0.4 s, tick 400: the world's first second
  s[100].normal_min = 15.0; // t = 10.1 s, braked in this bucket
  s[100].braked = true;
  s[102].normal_min = 15.0; // within brake_grace after it
  CHECK(check(h, Bounds{}).ok());
  s[200].normal_min = 19.0; // t = 20.1 s: nothing excuses it
  s[201].normal_min = 18.0;
  const Verdict v = check(h, Bounds{});
  const Violation* x = find(v, "grasp force");
  REQUIRE(x != nullptr);
  CHECK(x->t == Approx(20.1).margin(1e-9));
  CHECK_THAT(x->text, Catch::Contains("18.00 N"));
}

TEST_CASE("soak checker: failover and restart are measured from the recording, late ones are violations") {
  History h = quiet_history(60.0);
  h.faults.push_back(kill_left(20.0));
  add_event(h, {20.021, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}});
  add_event(h, {21.8, Event::Type::State, "m1/left@49", "2 222"});
  Verdict v = check(h, Bounds{});
  CHECK(v.ok());
  CHECK(recovery_s(v, "kill robot: arm served again (standby)") == Approx(0.021));
  CHECK(recovery_s(v, "kill robot: replacement up") == Approx(1.8));

  History late = quiet_history(60.0);
  late.faults.push_back(kill_left(20.0));
  add_event(late, {20.9, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}});
  add_event(late, {21.8, Event::Type::State, "m1/left@49", "2 222"});
  v = check(late, Bounds{});
  const Violation* x = find(v, "recovery");
  REQUIRE(x != nullptr);
  CHECK(x->fault == 1);
  CHECK_THAT(x->text, Catch::Contains("no other robot served m1/left within 0.2 s") && Catch::Contains("after 0.9 s"));

  // The brakes on the arm are no service: the arm is served again only by a robot.
  History braked = quiet_history(60.0);
  braked.faults.push_back(kill_left(20.0));
  add_event(braked, {20.1, Event::Type::Owners, "m1", "left=braked,right=m1/right", {{"left", ""}, {"right", "m1/right"}}});
  CHECK(find(check(braked, Bounds{}), "recovery") != nullptr);

  // ... unless the module was already stopping or paused for load when the kill came (soak run 62): both arms braked
  // by design, and the arm shows its new robot once the module resumes. Judged by a restart's bound on the wall clock.
  // A pause that begins after the kill (a late standby's commands can bring it on) excuses nothing.
  struct Case {
    double hold_from, paused_from, resume;
    bool excused;
  };
  for (const Case c : {Case{19.0, 19.5, 26.0, true}, Case{19.95, 20.15, 26.0, true}, Case{19.0, 19.5, 31.0, true},
                       Case{20.15, 20.15, 26.0, false}}) {
    INFO("holding from " << c.hold_from << " s, paused from " << c.paused_from << " s, resumed at " << c.resume << " s");
    History load = braked;
    for (ModuleSample& m : load.modules["m1"]) {
      m.hold = m.t >= c.hold_from && m.t < c.paused_from;
      m.load_paused = m.t >= c.paused_from && m.t < c.resume;
      if (m.hold || m.load_paused) m.stop_tick = m.tick - 50;
    }
    add_event(load, {21.8, Event::Type::State, "m1/left@49", "2 222"});  // the killed one's restart
    add_event(load, {c.resume, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}});
    v = check(load, Bounds{});
    if (c.excused && c.resume - 20.0 <= Bounds{}.restart_s) {
      CHECK(find(v, "recovery") == nullptr);
      CHECK(recovery_s(v, "kill robot: arm served again (paused for load)") == Approx(c.resume - 20.0));
    } else {
      REQUIRE(find(v, "recovery") != nullptr);
      CHECK_THAT(find(v, "recovery")->text, Catch::Contains(c.excused ? "within 10.0 s" : "within 0.2 s"));
    }
  }
  // A restart (no standby) during which the module pauses for load: the arm is braked, then both are, and the world
  // shows no owner until it releases them (soak run 65: released 12.1 and 37.1 s after the kill). Served again when
  // the replacement is active, if the module stayed paused until then; the release is progress's to judge.
  struct Restart {
    double paused_from, paused_to, up;
    bool ok;
  };
  for (const Restart c : {Restart{20.9, 57.0, 22.7, true}, Restart{20.9, 22.0, 22.7, false},
                          Restart{20.9, 57.0, -1.0, false}, Restart{31.0, 57.0, 22.7, false}}) {
    INFO("paused from " << c.paused_from << " to " << c.paused_to << " s, replacement up at " << c.up << " s");
    History r = braked;
    r.faults.back().had_standby = false;
    for (ModuleSample& m : r.modules["m1"]) m.load_paused = m.t >= c.paused_from && m.t < c.paused_to;
    add_event(r, {c.paused_from, Event::Type::Owners, "m1", "left=braked(load),right=braked(load)", {{"left", ""}, {"right", ""}}});
    if (c.up > 0.0) add_event(r, {c.up, Event::Type::State, "m1/left", "2 555"});
    add_event(r, {c.paused_to + 0.05, Event::Type::Owners, "m1", "left=m1/left,right=m1/right", {{"left", "m1/left"}, {"right", "m1/right"}}});
    v = check(r, Bounds{});
    if (c.ok) {
      CHECK(find(v, "recovery") == nullptr);
      CHECK(recovery_s(v, "kill robot: arm served again (restart, paused for load)") == Approx(c.up - 20.0));
    } else {
      REQUIRE(find(v, "recovery") != nullptr);
      CHECK_THAT(find(v, "recovery")->text, Catch::Contains("no other robot served m1/left within 10.0 s"));
    }
  }
  // In module time when the fault has the world's tick (run 62: the observer, starved, heard tick 4870 at the kill;
  // the world had begun its overload stop at tick 5100 and the nemesis had heard 5250): a stop begun at a tick up to
  // the fault's counts, one begun after it does not, whatever the buckets' wall times.
  for (const long stop_tick : {5100L, 5300L}) {
    INFO("the stop began at tick " << stop_tick);
    History late_obs = braked;
    late_obs.faults[0].module_tick = 5250;
    for (ModuleSample& m : late_obs.modules["m1"]) {
      m.load_paused = m.t >= 20.1 && m.t < 26.0;
      if (m.load_paused) m.stop_tick = m.t < 20.15 ? stop_tick : m.tick - 50;
    }
    add_event(late_obs, {21.8, Event::Type::State, "m1/left@49", "2 222"});
    add_event(late_obs, {26.0, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}});
    v = check(late_obs, Bounds{});
    CHECK((find(v, "recovery") == nullptr) == (stop_tick <= 5250));
  }
}

TEST_CASE("soak checker: an arm's failover is judged in module time (ticks), in lockstep and in real time") {
  // The world heard at tick 20000 when the robot is killed at 20.0 s, then stands still (a lockstep wait): its reports
  // reach the observer late, and the new owner shows at 20.9 s on the wall clock in the report of tick `owner_tick`.
  auto run = [](bool realtime, long owner_tick) {
    History h = quiet_history(60.0);
    h.realtime = realtime;
    for (ModuleSample& s : h.modules["m1"]) {
      if (s.t > 20.05 && s.t < 20.95) s.tick = 20010;
      if (s.t >= 20.95) s.tick -= 900 - (owner_tick - 20000);  // the world runs on from the owner's report
    }
    h.faults.push_back(kill_left(20.0));
    Event owners{20.9, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}};
    owners.tick = owner_tick;
    add_event(h, owners);
    add_event(h, {21.8, Event::Type::State, "m1/left@49", "2 222"});
    return check(h, Bounds{});
  };
  auto failover_s = [](const Verdict& v) { return recovery_s(v, "kill robot: arm served again (standby)"); };
  // Lockstep, 50 ticks of module time: 0.05 s, held (on the wall clock it would be 0.9 s).
  const Verdict lock50 = run(false, 20050);
  CHECK(find(lock50, "recovery") == nullptr);
  CHECK(failover_s(lock50) == Approx(0.05));
  // Lockstep, 400 ticks: 0.4 s of module time without the arm served, a violation.
  const Verdict lock400 = run(false, 20400);
  const Violation* x = find(lock400, "recovery");
  REQUIRE(x != nullptr);
  CHECK_THAT(x->text, Catch::Contains("within 0.2 s") && Catch::Contains("after 0.4 s"));
  // Real time, the same recordings: the module's ticks count too, not when a starved observer heard the report.
  const Verdict real50 = run(true, 20050);
  CHECK(find(real50, "recovery") == nullptr);
  CHECK(failover_s(real50) == Approx(0.05));
  const Verdict real400 = run(true, 20400);  // kept: find() points into it
  const Violation* y = find(real400, "recovery");
  REQUIRE(y != nullptr);
  CHECK_THAT(y->text, Catch::Contains("after 0.4 s"));
  // The world says its handover (ticks from the old owner's last command to the new one followed): that count is
  // taken, whatever the ticks the observer heard: 11 ticks held, 350 ticks a violation.
  auto with_handover = [](long ticks) {
    History h = quiet_history(60.0);
    h.realtime = true;
    h.faults.push_back(kill_left(20.0));
    h.faults.back().module_tick = 19000;  // a starved observer's stale note
    Event owners{20.4, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}};
    owners.tick = 20400;
    owners.handover = {{"left", ticks}, {"right", -1}};
    add_event(h, owners);
    add_event(h, {21.8, Event::Type::State, "m1/left@49", "2 222"});
    return check(h, Bounds{});
  };
  const Verdict h11 = with_handover(11);
  CHECK(find(h11, "recovery") == nullptr);
  CHECK(failover_s(h11) == Approx(0.011));
  const Verdict h350 = with_handover(350);
  const Violation* z = find(h350, "recovery");
  REQUIRE(z != nullptr);
  CHECK_THAT(z->text, Catch::Contains("after 0.4 s"));  // 0.35 s, said to one decimal
}

TEST_CASE("soak checker: a later fault hits first when it comes before the bound ran out in module time, not on the wall clock") {
  // Lockstep soak run 54: m1/left unplugged for a hand-over at tick 20000 (20.0 s), the world standing still at that
  // tick, its world killed at 21.0 s (1.0 s later on the wall clock, 0 ticks of module time) and the arm served again
  // only by the restarted module at 31.6 s.
  auto run = [](bool world_stands_still) {
    History h = quiet_history(60.0);
    for (ModuleSample& s : h.modules["m1"]) {
      if (world_stands_still && s.t > 20.0 && s.t <= 21.0) s.tick = 20000;
      if (s.t > 21.0) s.world = 2;  // the world restarted after its kill
    }
    h.faults = {handover_unplug(20.0), m1_fault(2, FaultKind::Kill, Target::World, 21.0, "m1/world", 25.0)};
    Event owners{31.6, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}};
    owners.tick = 200;
    add_event(h, owners);
    add_event(h, {24.5, Event::Type::State, "m1/left", "2 444"});
    add_event(h, {26.0, Event::Type::State, "m1/world", "2 555"});
    return check(h, Bounds{});
  };
  // The world stood still: the hand-over's 0.2 s of module time had not run out when the world was killed.
  const Verdict still = run(true);
  for (const Violation& x : still.violations) INFO(x.text);
  CHECK(find(still, "recovery") == nullptr);
  // The world ran on at 1 kHz: 1000 ticks passed before the kill, the hand-over is judged and late.
  const Verdict ran = run(false);
  const Violation* x = find(ran, "recovery");
  REQUIRE(x != nullptr);
  CHECK_THAT(x->text, Catch::Contains("unplug robot") && Catch::Contains("within 0.2 s"));
  // A world that stands still at the fault's tick for good: the window ends at the progress bound (45 s), and a fault
  // after that does not excuse the hand-over that never came.
  auto stuck = [](double later_fault_t) {
    History h = quiet_history(120.0);
    for (ModuleSample& s : h.modules["m1"]) {
      if (s.t > 20.0) s.tick = 20000;
    }
    FaultRecord stall = m1_fault(2, FaultKind::Stall, Target::Supervisor, later_fault_t, "m1/supervisor", later_fault_t + 0.5);
    stall.fault.duration_s = 0.5;
    h.faults = {handover_unplug(20.0), stall};
    add_event(h, {24.5, Event::Type::State, "m1/left", "2 444"});
    return check(h, Bounds{});
  };
  const Verdict soon = stuck(30.0);
  for (const Violation& v : soon.violations) {
    CHECK(v.text.find("unplug robot") == std::string::npos);  // within the window: the later fault hit first
  }
  const Verdict late = stuck(80.0);
  bool judged = false;
  for (const Violation& v : late.violations) judged = judged || v.text.find("fault #1 (unplug robot") != std::string::npos;
  CHECK(judged);
}

TEST_CASE("soak checker: tasks done twice or lost are violations") {
  History h = quiet_history(120.0);
  h.tasks_done.push_back(h.tasks_done.front());
  h.tasks_done_by.push_back("m2");
  Verdict v = check(h, Bounds{});
  REQUIRE(find(v, "tasks exactly once") != nullptr);
  CHECK_THAT(find(v, "tasks exactly once")->text, Catch::Contains("done twice"));

  History back = quiet_history(120.0);
  add_event(back, {50.0, Event::Type::QueueBack, "12", "3"});
  v = check(back, Bounds{});
  REQUIRE(find(v, "tasks exactly once") != nullptr);
  CHECK_THAT(find(v, "tasks exactly once")->text, Catch::Contains("went back from 12 to 3"));

  History lost = quiet_history(120.0);
  lost.task_names.push_back("orphan");
  add_event(lost, {10.0, Event::Type::TaskAssigned, "orphan", "m1"});
  v = check(lost, Bounds{});
  REQUIRE(find(v, "tasks exactly once") != nullptr);
  CHECK_THAT(find(v, "tasks exactly once")->text, Catch::Contains("orphan") && Catch::Contains("lost"));
}

TEST_CASE("soak checker: resident memory that keeps growing is a violation, flat noise is not") {
  History h = quiet_history(300.0);
  for (int i = 0; i < 150; ++i) {
    const double t = 2.0 * i;
    h.rss.push_back({t, "m1/world", 10, 30.0 + ((i % 3) - 1) * 0.2});   // flat with noise
    h.rss.push_back({t, "coordinator", 11, 20.0 + 3.0 * t / 60.0});     // 3 MiB/min
  }
  const Verdict v = check(h, Bounds{});
  const Violation* x = find(v, "memory flat");
  REQUIRE(x != nullptr);
  CHECK_THAT(x->text, Catch::Contains("coordinator") && Catch::Contains("3.00 MiB/min"));
  CHECK(v.rss_slope.at("m1/world") == Approx(0.0).margin(0.05));
  CHECK(v.rss_slope.at("coordinator") == Approx(3.0).epsilon(1e-9));
}

TEST_CASE("soak checker: memory is judged over the later half of a life, at most the last half hour, and not for a process a fault hit") {
  // A world that grows 3 MiB/min for its first 20 minutes (start-up, a warm-up of caches) and is flat for the last
  // 40: judged over its last 30 min, it holds.
  History early = quiet_history(3600.0);
  for (int i = 0; i <= 1800; ++i) {
    const double t = 2.0 * i;
    early.rss.push_back({t, "m1/world", 10, t < 1200.0 ? 20.0 + 3.0 * t / 60.0 : 80.0});
  }
  Verdict v = check(early, Bounds{});
  CHECK(find(v, "memory flat") == nullptr);
  CHECK(v.rss_slope.at("m1/world") == Approx(0.0).margin(1e-9));
  // Growth in the last half hour is found whatever came before.
  History late = quiet_history(3600.0);
  for (int i = 0; i <= 1800; ++i) {
    const double t = 2.0 * i;
    late.rss.push_back({t, "m1/world", 10, t < 2400.0 ? 40.0 : 40.0 + 2.0 * (t - 2400.0) / 60.0});
  }
  v = check(late, Bounds{});
  REQUIRE(find(v, "memory flat") != nullptr);
  CHECK_THAT(find(v, "memory flat")->text, Catch::Contains("m1/world"));
  // The same growth in a process that a fault stalled (its peers' samples piled up for it) is not judged.
  History hit = late;
  FaultRecord stall = kill_left(2500.0);
  stall.fault.kind = FaultKind::Stall;
  stall.label = "m1/world";
  stall.pid = 10;
  stall.end_t = 2500.5;
  hit.faults.push_back(stall);
  v = check(hit, Bounds{});
  CHECK(find(v, "memory flat") == nullptr);
  CHECK(v.rss_slope.count("m1/world") == 0);
  // A process that lived under rss_min_life_s (120 s) is not judged either, however it grew.
  History brief = quiet_history(600.0);
  for (int i = 0; i <= 50; ++i) brief.rss.push_back({300.0 + 2.0 * i, "m1/left@49", 12, 10.0 + 0.5 * i});
  v = check(brief, Bounds{});
  CHECK(find(v, "memory flat") == nullptr);
}

TEST_CASE("soak checker: progress is judged per module in service, and a module's pause or a fault on it excuses its gap") {
  // Two modules; m2 does no task from 10 s to 70 s (over the 45 s bound) while m1 goes on: a violation naming m2.
  auto two = [](bool m2_paused, bool m2_faulted) {
    History h = quiet_history(120.0);
    h.h_sg["m2"] = 20.0;
    for (ModuleSample s : h.modules["m1"]) {
      if (m2_paused && s.t > 30.0 && s.t < 40.0) s.load_paused = true;
      h.modules["m2"].push_back(s);
    }
    for (int k = 1; 4.0 * k < 120.0; ++k) {
      const double t = 4.0 * k + 1.0;
      if (t > 10.0 && t < 70.0) continue;
      const std::string name = "u" + std::to_string(k);
      h.task_names.push_back(name);
      add_event(h, {t - 3.0, Event::Type::TaskAssigned, name, "m2"});
      add_event(h, {t, Event::Type::TaskDone, name, "m2"});
      h.tasks_done.push_back(name);
      h.tasks_done_by.push_back("m2");
    }
    if (m2_faulted) {
      FaultRecord f = kill_left(35.0);
      f.label = "m2/left";
      f.module = "m2";
      f.had_standby = false;
      h.faults.push_back(f);
      add_event(h, {36.0, Event::Type::State, "m2/left@49", "2 222"});
      add_event(h, {35.5, Event::Type::Owners, "m2", "left=m2/left@49,right=m2/right", {{"left", "m2/left@49"}, {"right", "m2/right"}}});
    }
    return check(h, Bounds{});
  };
  const Verdict gap = two(false, false);
  const Violation* x = find(gap, "progress");
  REQUIRE(x != nullptr);
  CHECK_THAT(x->text, Catch::Contains("m2 did no task"));
  for (const auto& y : gap.violations) {
    if (y.invariant == "progress") CHECK_THAT(y.text, !Catch::Contains("m1 did no task"));
  }
  CHECK(find(two(true, false), "progress") == nullptr);   // paused for load meanwhile: a safe stop, excused
  CHECK(find(two(false, true), "progress") == nullptr);   // a fault on m2 meanwhile: excused
}

TEST_CASE("soak checker: the overall progress gap counts only time with a module in service") {
  // m1 alone; no task done from 20 s to 90 s (70 s on the wall clock).
  auto gap = [](double paused_from, double paused_to, bool drop_samples) {
    History h = quiet_history(120.0);
    std::vector<std::string> kept_names, kept_done, kept_by;
    std::vector<Event> kept;
    for (const Event& e : h.events) {
      const bool task = e.type == Event::Type::TaskAssigned || e.type == Event::Type::TaskDone;
      if (task && e.t > 20.0 && e.t < 90.0) continue;
      kept.push_back(e);
    }
    h.events = kept;
    for (size_t i = 0; i < h.tasks_done.size(); ++i) {
      const int k = std::atoi(h.tasks_done[i].c_str() + 1);
      if (4.0 * k > 20.0 && 4.0 * k < 90.0) continue;
      kept_done.push_back(h.tasks_done[i]);
      kept_by.push_back(h.tasks_done_by[i]);
    }
    for (const std::string& n : h.task_names) {
      const int k = std::atoi(n.c_str() + 1);
      if (!(4.0 * k > 20.0 && 4.0 * k < 90.0)) kept_names.push_back(n);
    }
    h.tasks_done = kept_done;
    h.tasks_done_by = kept_by;
    h.task_names = kept_names;
    std::vector<ModuleSample> series;
    for (ModuleSample s : h.modules["m1"]) {
      const bool inside = s.t > paused_from && s.t < paused_to;
      if (inside && drop_samples) continue;  // unplugged or parked: no world, no samples
      if (inside) s.load_paused = true;
      series.push_back(s);
    }
    h.modules["m1"] = series;
    return check(h, Bounds{});
  };
  // In service throughout: 70 s without a task is a violation, and the text says how much of it was in service.
  const Verdict busy = gap(0.0, 0.0, false);
  const Violation* x = find(busy, "progress");
  REQUIRE(x != nullptr);
  CHECK_THAT(x->text, Catch::Contains("no task was done from 20.0 s to 92.0 s") && Catch::Contains("72.0 s of it with a module in service"));
  // Paused for load from 30 s to 80 s: 22.1 s in service, under the 45 s bound.
  CHECK(find(gap(30.0, 80.0, false), "progress") == nullptr);
  // Out (no samples) from 30 s to 80 s: the same.
  CHECK(find(gap(30.0, 80.0, true), "progress") == nullptr);
  // Paused only from 50 s to 60 s: 62.1 s in service, still a violation.
  REQUIRE(find(gap(50.0, 60.0, false), "progress") != nullptr);
  CHECK_THAT(find(gap(50.0, 60.0, false), "progress")->text, Catch::Contains("62.1 s of it with a module in service"));
  // Out of service for good is no excuse on the wall clock: paused for load from 30 s to the end of a 200 s run,
  // no task after 20 s: at most 3 x 45 s without a task, whatever the modules say.
  History stuck = quiet_history(200.0);
  std::vector<Event> kept;
  for (const Event& e : stuck.events) {
    if ((e.type == Event::Type::TaskAssigned || e.type == Event::Type::TaskDone) && e.t > 20.0) continue;
    kept.push_back(e);
  }
  stuck.events = kept;
  stuck.tasks_done.resize(5);
  stuck.tasks_done_by.resize(5);
  stuck.task_names.resize(5);
  for (ModuleSample& s : stuck.modules["m1"]) s.load_paused = s.t > 30.0;
  const Verdict v = check(stuck, Bounds{});
  REQUIRE(find(v, "progress") != nullptr);
  CHECK_THAT(find(v, "progress")->text, Catch::Contains("no task was done after 20.0 s (10.0 s of it with a module in service)"));
}

/// 120 s of m1 with a 2 s hog of both cores from 40 s, m1 paused for load from 41 s until `resume`.
History hog_history(double resume) {
  History h = quiet_history(120.0);
  FaultRecord f;
  f.fault.index = 1;
  f.fault.kind = FaultKind::Hog;
  f.fault.duration_s = 2.0;
  f.t = 40.0;
  f.end_t = 42.0;
  f.label = "2 core(s)";
  h.faults.push_back(f);
  for (ModuleSample& s : h.modules["m1"]) s.load_paused = s.t > 41.0 && s.t < resume;
  return h;
}

TEST_CASE("soak checker: a module paused for load by a hog must resume within 20 s of its end, judged under progress") {
  // A 2 s hog from 40 s; m1 paused for load from 41 s until `resume` (tasks go on: the gap rule is not what is judged).
  auto hogged = [](double resume) { return check(hog_history(resume), Bounds{}); };
  CHECK(find(hogged(50.0), "progress") == nullptr);  // resumed 8 s after the hog
  CHECK(find(hogged(50.0), "recovery") == nullptr);
  const Verdict late = hogged(70.0);  // 28 s after it
  const Violation* x = find(late, "progress");
  REQUIRE(x != nullptr);
  CHECK_THAT(x->text, Catch::Contains("a module paused for load did not resume within 20.0 s"));
  CHECK(find(late, "recovery") == nullptr);
  // Parked for load (shed) before its resume was due: its return is the governor's, not judged here.
  auto parked = [&](double park_t, double back_t = -1.0) {
    History h = hog_history(70.0);
    add_event(h, {park_t, Event::Type::Parked, "m1", "overload: the running modules were paused for load 55% of the last 20 s"});
    if (back_t > 0.0) add_event(h, {back_t, Event::Type::Unparked, "m1", "no module has run for 5 s: one always does"});
    return check(h, Bounds{});
  };
  // Released after a good trial 8 s after the hog and paused again within the same 0.1 s bucket: the bucket
  // says paused, the release counts (the machine's load paused it again, run 64).
  History h = hog_history(70.0);
  REQUIRE(find(check(h, Bounds{}), "progress") != nullptr);
  for (ModuleSample& s : h.modules["m1"]) s.released = s.t > 50.0 && s.t < 50.11;
  CHECK(find(check(h, Bounds{}), "progress") == nullptr);
  // A release during the hog, paused again before it ends, is no resume after it.
  for (ModuleSample& s : h.modules["m1"]) s.released = s.t > 41.5 && s.t < 41.61;
  CHECK(find(check(h, Bounds{}), "progress") != nullptr);
  CHECK(find(parked(43.0), "progress") == nullptr);
  // ... and the report says so: counted as left to the governor, not silently dropped (and not when judged).
  CHECK(parked(43.0).left_to_governor.at("hog: paused modules resume") == 1);
  CHECK(late.left_to_governor.empty());
  CHECK(find(parked(43.0, 75.0), "progress") == nullptr);  // brought back after the bound: still the governor's
  // Brought back within the bound and still paused (the series says paused until 70 s): judged, late.
  REQUIRE(find(parked(43.0, 48.0), "progress") != nullptr);
  CHECK_THAT(find(parked(43.0, 48.0), "progress")->text, Catch::Contains("did not resume"));
  CHECK(find(parked(35.0), "progress") != nullptr);  // a park before the hog excuses nothing
  CHECK(find(parked(65.0), "progress") != nullptr);  // nor one after the resume was due
}

TEST_CASE("soak checker: a task assigned and never done nor running is lost, unless its module was parked since") {
  History h = quiet_history(120.0);
  add_event(h, {10.0, Event::Type::TaskAssigned, "tx", "m2"});  // given to m2, then neither done nor running
  h.task_names.push_back("tx");
  auto lost = [](const History& x) {
    const Verdict v = check(x, Bounds{});
    const Violation* y = find(v, "tasks exactly once");
    return y != nullptr && y->text.find("task tx was assigned at 10.0 s") != std::string::npos;
  };
  CHECK(lost(h));
  History parked = h;  // m2 parked for load 13 s later: the task went back to the queue, pending
  add_event(parked, {23.0, Event::Type::Parked, "m2", "overload: the running modules were paused for load 50% of the last 20 s"});
  CHECK_FALSE(lost(parked));
  History other = h;  // another module parked excuses nothing
  add_event(other, {23.0, Event::Type::Parked, "m3", "overload"});
  CHECK(lost(other));
}

TEST_CASE("soak checker: anything left behind is a violation") {
  History h = quiet_history(30.0);
  h.leftover_shm.push_back("fast_datasharing_x");
  h.leftover_processes.push_back("123 tandem-robot");
  const Verdict v = check(h, Bounds{});
  CHECK(std::count_if(v.violations.begin(), v.violations.end(),
                      [](const Violation& x) { return x.invariant == "nothing left behind"; }) == 2);
}

TEST_CASE("soak checker: helpers") {
  CHECK(slope({{0, 1}, {1, 3}, {2, 5}}) == Approx(2.0));
  CHECK(percentile({3, 1, 2}, 0.5) == Approx(2.0));
  CHECK(percentile({1, 2, 3, 4}, 1.0) == Approx(4.0));
}

TEST_CASE("svg: a plot has its series, reference lines and escaped text") {
  Plot p;
  p.title = "a <b> & c";
  Series s;
  s.name = "m1";
  for (int i = 0; i < 5; ++i) s.xy.emplace_back(i, i * i);
  p.series.push_back(s);
  p.hlines.push_back({20.0, "h_sg"});
  const std::string svg = render_svg(p);
  CHECK(svg.rfind("<svg", 0) == 0);
  CHECK(svg.find("</svg>") != std::string::npos);
  CHECK(svg.find("a &lt;b&gt; &amp; c") != std::string::npos);
  CHECK(svg.find("<polyline") != std::string::npos);
  CHECK(svg.find("h_sg") != std::string::npos);
  const auto ticks = nice_ticks(0.0, 97.0, 6);
  REQUIRE(ticks.size() >= 4);
  CHECK(ticks.front() >= 0.0);
  CHECK(ticks.back() <= 97.0);
  CHECK(ticks[1] - ticks[0] == Approx(20.0));
}

TEST_CASE("svg: category labels on the y axis fit left of the plot (none cut off at the edge)") {
  Plot p;
  p.title = "faults";
  p.ycategories = {"hog", "kill robot: arm served again (standby)", "unplug robot"};
  Series s;
  s.name = "faults";
  for (int i = 0; i < 3; ++i) s.xy.emplace_back(10.0 * i, i);
  p.series.push_back(s);
  const std::string svg = render_svg(p);
  // Each label is right-aligned at x; at font-size 10 a character is at most about 6 px wide (DejaVu Sans: 6.4 px for
  // the widest lower-case letters, 5.5 px on average): its left end x - 6 * length must be on the canvas.
  int seen = 0;
  for (const std::string& label : p.ycategories) {
    const size_t at = svg.find(">" + label + "</text>");
    REQUIRE(at != std::string::npos);
    const size_t tag = svg.rfind("<text x=\"", at);
    REQUIRE(tag != std::string::npos);
    const double x = std::stod(svg.substr(tag + 9));
    CHECK(x - 6.0 * static_cast<double>(label.size()) >= 0.0);
    ++seen;
  }
  CHECK(seen == 3);
}

TEST_CASE("soak report: index.html renders the summary as HTML tables and lists, not raw Markdown") {
  History h = quiet_history(60.0);
  h.faults.push_back(kill_left(20.0));
  add_event(h, {20.021, Event::Type::Owners, "m1", "left=m1/left@50,right=m1/right", {{"left", "m1/left@50"}, {"right", "m1/right"}}});
  add_event(h, {21.8, Event::Type::State, "m1/left@49", "2 222"});
  const Bounds b{};
  RunInfo info;
  info.deployment = "unit <test>";
  const std::string dir = "/tmp/tandem-unit-soak-report-" + std::to_string(::getpid());
  (void)write_report(dir, info, h, b, check(h, b));
  std::ifstream in(dir + "/index.html");
  REQUIRE(in.good());
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string html = ss.str();
  (void)std::system(("rm -rf " + dir).c_str());
  CHECK(html.find("<table>") != std::string::npos);
  CHECK(html.find("<th>invariant</th>") != std::string::npos);
  CHECK(html.find("<td>object held</td>") != std::string::npos);
  CHECK(html.find("<li>") != std::string::npos);
  CHECK(html.find("unit &lt;test&gt;") != std::string::npos);
  CHECK(html.find("<pre>") == std::string::npos);
  CHECK(html.find("|---") == std::string::npos);
  CHECK(html.find("\n| ") == std::string::npos);  // no Markdown table row left as text
  CHECK(html.find("<img src=\"faults.svg\"") != std::string::npos);
  // The pages' visual language: the shared stylesheet inline (services/page/style.css) and the live view's header.
  CHECK(html.find(tandem::page::style_css()) != std::string::npos);
  CHECK(html.find("<header><h1>tandem soak of unit &lt;test&gt;</h1><span class=\"verdict") != std::string::npos);
}

TEST_CASE("soak checker: a supervisor kill with no warm standby is judged by the lost-plan bound") {
  // Another supervisor serves 6.2 s later (run 13: the standby found the plan lost, the module restarted).
  auto history = [&](bool warm, double after) {
    History h = quiet_history(60.0);
    h.faults.push_back(kill_supervisor(warm));
    add_event(h, {20.0 + after, Event::Type::Serving, "m1/supervisor@50", "primary"});
    return h;
  };
  const Bounds b{};
  // A warm standby: 2 s.
  Verdict v = check(history(true, 6.2), b);
  REQUIRE(find(v, "recovery") != nullptr);
  CHECK_THAT(find(v, "recovery")->text, Catch::Contains("within 2.0 s"));
  CHECK(find(check(history(true, 0.06), b), "recovery") == nullptr);
  // None: the lost-plan path's bound, which holds 6.2 s and still fails a module that never comes back.
  v = check(history(false, 6.2), b);
  CHECK(find(v, "recovery") == nullptr);
  CHECK(recovery_s(v, "kill supervisor (no warm standby): another serves") == Approx(6.2));
  v = check(history(false, 16.0), b);
  REQUIRE(find(v, "recovery") != nullptr);
  CHECK_THAT(find(v, "recovery")->text, Catch::Contains("within 15.0 s"));
  // The module restarted for its lost plan: its new primary supervisor has the killed one's label and another pid
  // (lockstep soak run 41). It serves; the killed process itself (its pid, or no pid known) never counts.
  auto same_label = [&](long long pid) {
    History h = quiet_history(60.0);
    h.faults.push_back(kill_supervisor(false));
    Event e{23.0, Event::Type::Serving, "m1/supervisor", "primary"};
    e.pid = pid;
    add_event(h, e);
    add_event(h, {50.0, Event::Type::Serving, "m1/supervisor@50", "primary"});
    return check(h, b);
  };
  CHECK(find(same_label(222), "recovery") == nullptr);
  for (const long long stale : {111LL, 0LL}) {
    v = same_label(stale);
    REQUIRE(find(v, "recovery") != nullptr);
    CHECK_THAT(find(v, "recovery")->text, Catch::Contains("after 30.0 s"));
  }
}

TEST_CASE("soak checker: a supervisor's takeover is judged in module time: a lockstep world that waited holds, ticks run on do not") {
  // Lockstep soak run 37 (finding 67): the leader killed at 20.0 s (its world at tick 20000); the standby stood still
  // twice for about a second (Fast DDS's interprocess lock) and serves at 22.6 s on the wall clock. Meanwhile the world
  // ran `ran` ticks (a lockstep world waits for its leader's plan after 10).
  auto run = [](long ran, bool realtime) {
    History h = quiet_history(60.0);
    h.realtime = realtime;
    for (ModuleSample& s : h.modules["m1"]) {
      if (s.t > 20.0) s.tick = std::min(s.tick, 20000 + ran) + std::max(0L, s.tick - 22700);
    }
    FaultRecord f = kill_supervisor(true);
    f.module_tick = 20000;
    h.faults.push_back(f);
    add_event(h, {22.6, Event::Type::Serving, "m1/supervisor@50", "primary"});
    return check(h, Bounds{});
  };
  auto takeover_s = [](const Verdict& v) { return recovery_s(v, "kill supervisor: another serves"); };
  // The world waited after 10 ticks: 0.01 s of module time, held (2.6 s on the wall clock would be a violation).
  const Verdict waited = run(10, false);
  CHECK(find(waited, "recovery") == nullptr);
  CHECK(takeover_s(waited) == Approx(0.01));
  // The world ran 2500 ticks without its leader (a lapsed lease, or real time): 2.5 s, a violation, in both timings.
  for (const bool realtime : {false, true}) {
    const Verdict ran = run(2500, realtime);
    const Violation* x = find(ran, "recovery");
    REQUIRE(x != nullptr);
    CHECK_THAT(x->text, Catch::Contains("within 2.0 s") && Catch::Contains("after 2.5 s"));
  }
  // The wall clock bounds it: a report heard long after the takeover does not make it later than it was.
  History late = quiet_history(60.0);
  late.faults.push_back(kill_supervisor(true));  // no tick noted at the fault: the newest bucket before it (tick 20000)
  add_event(late, {20.06, Event::Type::Serving, "m1/supervisor@50", "primary"});
  const Verdict v = check(late, Bounds{});
  CHECK(find(v, "recovery") == nullptr);
  CHECK(takeover_s(v) == Approx(0.06));
}

TEST_CASE("soak checker: a coordinator kill with no standby coordinator is judged by the restart bound") {
  auto history = [](bool standby, double after) {
    History h = quiet_history(60.0);
    FaultRecord f;
    f.fault.index = 1;
    f.fault.kind = FaultKind::Kill;
    f.fault.target = Target::Coordinator;
    f.t = 20.0;
    f.label = "coordinator@r11";
    f.pid = 111;
    f.had_standby = standby;
    h.faults.push_back(f);
    add_event(h, {20.0 + after, Event::Type::Serving, "coordinator@r13", "primary"});
    return h;
  };
  // Run 27: 5.1 s with both standbys just restarted. With a standby that is a violation (5 s), without one not (10 s).
  const Verdict warm = check(history(true, 5.1), Bounds{});
  REQUIRE(find(warm, "recovery") != nullptr);
  CHECK_THAT(find(warm, "recovery")->text, Catch::Contains("within 5.0 s"));
  const Verdict cold = check(history(false, 5.1), Bounds{});
  CHECK(find(cold, "recovery") == nullptr);
  CHECK(recovery_s(cold, "kill coordinator (no standby): another serves") == Approx(5.1));
  const Verdict never = check(history(false, 11.0), Bounds{});
  REQUIRE(find(never, "recovery") != nullptr);
  CHECK_THAT(find(never, "recovery")->text, Catch::Contains("within 10.0 s"));
}

TEST_CASE("soak checker: a deployment that ended by itself before the soak stopped it is not a pass") {
  // A CI soak whose Discovery Server could not take its port: tandem up exited at 0 s, nothing ran, and the
  // report said PASS.
  History h = quiet_history(60.0);
  CHECK(find(check(h, Bounds{}), "progress") == nullptr);
  h.stop_s = 0.0;
  h.events.clear();
  h.tasks_done.clear();
  h.tasks_done_by.clear();
  h.ended_by_itself = true;
  h.launcher_exit = 2;
  const Verdict v = check(h, Bounds{});
  CHECK_FALSE(v.ok());
  REQUIRE(find(v, "progress") != nullptr);
  CHECK_THAT(find(v, "progress")->text, Catch::Contains("ended by itself at 0.0 s of 60.0 s") && Catch::Contains("exit 2"));
}

TEST_CASE("soak checker: a module plugged in again after its world's kill is back when running, or when the launcher parks it for load") {
  auto run = [](bool parked, double back_at) {
    History h = quiet_history(60.0);
    FaultRecord f = kill_left(20.0);
    f.fault.target = Target::World;
    f.end_t = 22.0;  // plugged in again
    f.label = "m1/world";
    f.pid = 100;
    h.faults.push_back(f);
    add_event(h, {0.2, Event::Type::State, "m1/world", "2 100"});
    if (parked) add_event(h, {22.3, Event::Type::Parked, "m1", "overload: the running modules were paused for load 88% of the last 20 s"});
    if (back_at > 0.0) add_event(h, {back_at, Event::Type::State, "m1/world", "2 200"});
    return check(h, Bounds{});
  };
  auto back_violation = [](const Verdict& v) {
    for (const auto& x : v.violations) {
      if (x.text.find("was not running again") != std::string::npos) return true;
    }
    return false;
  };
  CHECK_FALSE(back_violation(run(false, 25.0)));   // its new world is active 3 s after the plug
  CHECK(back_violation(run(false, -1.0)));         // never again: a violation
  CHECK(back_violation(run(false, 40.0)));         // 18 s after the plug: past the 15 s bound
  CHECK_FALSE(back_violation(run(true, -1.0)));    // parked for load 0.3 s after the plug: the governor's, by design
}

TEST_CASE("soak checker: a fault's recovery is not judged when the launcher parks its module for load before it is due") {
  auto run = [](double parked_at) {
    History h = quiet_history(60.0);
    FaultRecord f = kill_left(20.0);
    f.fault.target = Target::Standby;  // a standby killed: its replacement must be active within 10 s
    f.label = "m1/left@50";
    f.pid = 150;
    h.faults.push_back(f);
    add_event(h, {0.3, Event::Type::State, "m1/left@50", "2 150"});
    if (parked_at > 0.0) add_event(h, {parked_at, Event::Type::Parked, "m1", "overload: paused for load 63% of the last 20 s"});
    return check(h, Bounds{});
  };
  auto replacement_violation = [](const Verdict& v) {
    for (const auto& x : v.violations) {
      if (x.text.find("no replacement robot") != std::string::npos) return true;
    }
    return false;
  };
  CHECK(replacement_violation(run(-1.0)));        // no replacement and no park: a violation
  CHECK_FALSE(replacement_violation(run(20.2)));  // parked 0.2 s after the kill: its restart was dropped by design
  CHECK(run(20.2).left_to_governor.size() == 1);  // ... and counted as left to the governor in the report
  CHECK(run(-1.0).left_to_governor.empty());
  CHECK(replacement_violation(run(35.0)));        // parked only after the bound: the violation stands
}

TEST_CASE("soak report: a process's share of a core over its last window, beside its first, from cumulative CPU time", "[soak]") {
  // A world that used 10% of a core for 5 minutes, then 60% (a wedged listener spinning), sampled every 2 s; a
  // robot that lived 60 s only (not judged); a process with no CPU reading (skipped).
  std::vector<RssSample> s;
  double cpu = 0.0;
  for (double t = 0.0; t <= 600.0; t += 2.0) {
    s.push_back({t, "m1/world", 42, 30.0, cpu});
    cpu += t < 300.0 ? 0.2 : 1.2;
  }
  for (double t = 100.0; t <= 160.0; t += 2.0) s.push_back({t, "m1/left", 43, 10.0, t});
  for (double t = 0.0; t <= 600.0; t += 2.0) s.push_back({t, "m1/right", 44, 10.0, -1.0});
  for (double t = 0.0; t <= 600.0; t += 2.0) s.push_back({t, "coordinator", 45, 20.0, 0.05 * t});
  const std::vector<CpuShare> c = cpu_shares(s, 120.0);
  REQUIRE(c.size() == 2);
  CHECK(c[0].label == "m1/world");  // the busiest first
  CHECK(c[0].pid == 42);
  CHECK(c[0].share == Approx(0.6).margin(1e-9));
  CHECK(c[0].first_share == Approx(0.1).margin(1e-9));
  CHECK(c[1].label == "coordinator");
  CHECK(c[1].share == Approx(0.05).margin(1e-9));
}

TEST_CASE("soak history file: every recorded field reads back as written, the verdict is the same, bad files are refused") {
  // A history with every field away from its default, and a drop so that the verdict has a violation to compare.
  History h = quiet_history(60.0);
  h.stop_s = 59.5;
  h.realtime = false;
  ModuleSample& s = h.modules["m1"][300];
  s.normal_min = 0.0;
  s.slips = 1;
  s.contact_lost = 2;
  s.late = 3;
  s.failovers = 4;
  s.braked = s.hold = s.load_paused = s.released = s.failed = true;
  s.stop_tick = 29990;
  s.world = 2;
  h.heard["m1/left"] = {{1.0, 20.0, 4242}, {21.0, 59.0, 4343}};
  Event owners{30.0, Event::Type::Owners, "m1", "left=braked", {{"left", ""}, {"right", "m1/right"}}};
  owners.tick = 30000;
  owners.pid = 77;
  owners.handover = {{"left", -1}, {"right", 12}};
  add_event(h, owners);
  add_event(h, Event{31.0, Event::Type::Unparked, "m2", "calm"});
  FaultRecord f = m1_fault(7, FaultKind::Hog, Target::None, 29.0, "m1/left", 40.0);
  f.fault.at_s = 28.9;
  f.fault.label = "fixed";
  f.fault.duration_s = 11.0;
  f.fault.cores = 2;
  f.fault.pick = 0xfedcba9876543210ULL;
  f.skipped = true;
  f.note = "re-plugged at 41 s";
  f.had_standby = false;
  f.module_tick = 29000;
  h.faults.push_back(f);
  add_event(h, Event{32.0, Event::Type::State, "m1/left@49", "2 4444"});
  add_event(h, Event{33.0, Event::Type::Serving, "m1/supervisor@50", "primary"});
  add_event(h, Event{34.0, Event::Type::QueueBack, "12", "9"});
  add_event(h, Event{35.0, Event::Type::Parked, "m2", "overload"});
  h.modules["m2"] = quiet_history(2.0).modules["m1"];  // a second module, with its own h_sg
  h.modules["m2"][5].world = 3;
  h.h_sg["m2"] = 21.5;
  h.rss.push_back({12.5, "m1/world", 99, 12.25, 3.5});
  h.log_bytes = {{1.0, 100.0}, {2.0, 250.0}};
  h.tasks_running = {"t99"};
  h.tasks_done_total = 15;
  h.leftover_processes = {"123 tandem-robot"};
  h.leftover_shm = {"fastrtps_port7412"};
  h.launcher_exit = 3;
  h.ended_by_itself = true;
  RunInfo info;
  info.deployment = "small";
  info.deployment_file = "deploy/soak-small.yaml";
  info.command = "tandem soak deploy/soak-small.yaml";
  info.faults_source = "mixed";
  info.machine = "2 cores";
  info.timing = "lockstep";
  info.seed = 13;
  info.wall_s = 61.5;
  info.modules = 2;
  info.processes_seen = 17;

  const std::string dir = "/tmp/tandem-soak-history-" + std::to_string(::getpid());
  REQUIRE(std::system(("mkdir -p " + dir).c_str()) == 0);
  const std::string path = dir + "/history.pb";
  save_history(path, info, h);
  RunInfo i2;
  History r;
  load_history(path, i2, r);

  CHECK(i2.deployment == info.deployment);
  CHECK(i2.deployment_file == info.deployment_file);
  CHECK(i2.command == info.command);
  CHECK(i2.faults_source == info.faults_source);
  CHECK(i2.machine == info.machine);
  CHECK(i2.timing == info.timing);
  CHECK(i2.seed == info.seed);
  CHECK(i2.wall_s == info.wall_s);
  CHECK(i2.modules == info.modules);
  CHECK(i2.processes_seen == info.processes_seen);

  CHECK(r.duration_s == h.duration_s);
  CHECK(r.stop_s == h.stop_s);
  CHECK(r.realtime == h.realtime);
  CHECK(r.h_sg == h.h_sg);
  REQUIRE(r.modules.size() == 2);
  for (const std::string m : {"m1", "m2"}) {
  REQUIRE(r.modules[m].size() == h.modules[m].size());
  for (size_t k = 0; k < h.modules[m].size(); ++k) {
    const ModuleSample &a = h.modules[m][k], &b = r.modules[m][k];
    INFO(m << " sample " << k);
    CHECK(b.t == a.t);
    CHECK(b.tick == a.tick);
    CHECK(b.normal_min == a.normal_min);
    CHECK(b.slips == a.slips);
    CHECK(b.contact_lost == a.contact_lost);
    CHECK(b.late == a.late);
    CHECK(b.failovers == a.failovers);
    CHECK(b.braked == a.braked);
    CHECK(b.hold == a.hold);
    CHECK(b.load_paused == a.load_paused);
    CHECK(b.released == a.released);
    CHECK(b.stop_tick == a.stop_tick);
    CHECK(b.failed == a.failed);
    CHECK(b.world == a.world);
  }
  }
  std::set<Event::Type> types;
  for (const Event& e : h.events) types.insert(e.type);
  CHECK(types.size() == 8);  // every event type goes through the file
  REQUIRE(r.heard.size() == 1);
  REQUIRE(r.heard["m1/left"].size() == 2);
  CHECK(r.heard["m1/left"][0].start == 1.0);
  CHECK(r.heard["m1/left"][0].end == 20.0);
  CHECK(r.heard["m1/left"][0].pid == 4242);
  CHECK(r.heard["m1/left"][1].start == 21.0);
  CHECK(r.heard["m1/left"][1].end == 59.0);
  CHECK(r.heard["m1/left"][1].pid == 4343);
  REQUIRE(r.events.size() == h.events.size());
  for (size_t k = 0; k < h.events.size(); ++k) {
    const Event &a = h.events[k], &b = r.events[k];
    INFO("event " << k);
    CHECK(b.t == a.t);
    CHECK(b.type == a.type);
    CHECK(b.subject == a.subject);
    CHECK(b.text == a.text);
    CHECK(b.owners == a.owners);
    CHECK(b.tick == a.tick);
    CHECK(b.pid == a.pid);
    CHECK(b.handover == a.handover);
  }
  REQUIRE(r.faults.size() == 1);
  const FaultRecord& g = r.faults[0];
  CHECK(g.fault.index == 7);
  CHECK(g.fault.at_s == 28.9);
  CHECK(g.fault.kind == FaultKind::Hog);
  CHECK(g.fault.target == Target::None);
  CHECK(g.fault.label == "fixed");
  CHECK(g.fault.duration_s == 11.0);
  CHECK(g.fault.cores == 2);
  CHECK(g.fault.pick == 0xfedcba9876543210ULL);
  CHECK(g.t == f.t);
  CHECK(g.label == f.label);
  CHECK(g.module == f.module);
  CHECK(g.pid == f.pid);
  CHECK(g.skipped == f.skipped);
  CHECK(g.note == f.note);
  CHECK(g.end_t == f.end_t);
  CHECK(g.had_standby == f.had_standby);
  CHECK(g.module_tick == f.module_tick);
  REQUIRE(r.rss.size() == 1);
  CHECK(r.rss[0].t == 12.5);
  CHECK(r.rss[0].label == "m1/world");
  CHECK(r.rss[0].pid == 99);
  CHECK(r.rss[0].mib == 12.25);
  CHECK(r.rss[0].cpu_s == 3.5);
  CHECK(r.log_bytes == h.log_bytes);
  CHECK(r.task_names == h.task_names);
  CHECK(r.tasks_done == h.tasks_done);
  CHECK(r.tasks_done_by == h.tasks_done_by);
  CHECK(r.tasks_running == h.tasks_running);
  CHECK(r.tasks_done_total == h.tasks_done_total);
  CHECK(r.leftover_processes == h.leftover_processes);
  CHECK(r.leftover_shm == h.leftover_shm);
  CHECK(r.launcher_exit == h.launcher_exit);
  CHECK(r.ended_by_itself == h.ended_by_itself);

  // The checker and the report say the same of both: violations, recoveries, statistics, counts.
  const Verdict v1 = check(h, Bounds{}), v2 = check(r, Bounds{});
  REQUIRE_FALSE(v1.ok());
  REQUIRE(v2.violations.size() == v1.violations.size());
  for (size_t k = 0; k < v1.violations.size(); ++k) {
    CHECK(v2.violations[k].invariant == v1.violations[k].invariant);
    CHECK(v2.violations[k].t == v1.violations[k].t);
    CHECK(v2.violations[k].text == v1.violations[k].text);
  }
  CHECK(summary_text(i2, r, Bounds{}, v2) == summary_text(info, h, Bounds{}, v1));

  // Bad files: missing, not a history, an event type this build does not know, cut short, with a field this build
  // has no place for. Nothing is changed in the output on any of them.
  auto error_loading = [&](const std::string& file) {
    RunInfo keep_info;
    keep_info.seed = 99;
    History keep = quiet_history(2.0);
    try {
      load_history(file, keep_info, keep);
    } catch (const std::runtime_error& e) {
      CHECK(keep_info.seed == 99);
      CHECK(keep_info.deployment.empty());
      CHECK(keep.modules.size() == 1);
      CHECK(keep.modules["m1"].size() == 20);
      CHECK(keep.events.size() == quiet_history(2.0).events.size());
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(error_loading(dir + "/none.pb").find("cannot open " + dir + "/none.pb") != std::string::npos);
  std::ofstream(dir + "/junk.pb") << "this is not protobuf \xff\xff\xff";
  CHECK(error_loading(dir + "/junk.pb").find("is not a soak history") != std::string::npos);
  History future = h;  // a whole history whose last event is of a type this build does not know
  future.events.push_back(Event{59.0, static_cast<Event::Type>(42), "m1", ""});
  save_history(dir + "/future.pb", info, future);
  CHECK(error_loading(dir + "/future.pb").find("an unknown event type '?'") != std::string::npos);
  // Cut short: the file without its last 3 bytes, the `complete` field (tag 100: 2 bytes, value 1); what precedes
  // it is whole, so only the missing marker tells.
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  REQUIRE(bytes.size() > 100);
  std::ofstream(dir + "/cut.pb", std::ios::binary) << bytes.substr(0, bytes.size() - 3);
  CHECK(error_loading(dir + "/cut.pb").find("cut short") != std::string::npos);
  // A newer writer's field (number 999, a varint): refused, not judged without it.
  std::ofstream(dir + "/newer.pb", std::ios::binary) << bytes << std::string("\xb8\x3e\x01", 3);
  CHECK(error_loading(dir + "/newer.pb").find("fields this build does not know") != std::string::npos);
  CHECK(error_loading(path).empty());  // the file itself still reads
  REQUIRE(std::system(("rm -rf " + dir).c_str()) == 0);
}
