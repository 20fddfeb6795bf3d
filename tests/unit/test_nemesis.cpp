// The soak's nemesis (tandem::soak::Nemesis) driven with made-up processes and a recording actions double: no
// DDS, no signals, no clock. Each rule of docs/soak.md, "The nemesis", is made to act and to hold back.
#include <catch2/catch.hpp>

#include <map>
#include <set>
#include <string>
#include <vector>

#include "tandem/soak/nemesis.hpp"

using namespace tandem::soak;

namespace {

/// Records what the nemesis asks for; pids in `dead` are not alive.
struct Recorder : NemesisActions {
  struct Call {
    std::string what;
    long long pid = 0;
    std::string target, option;
  };
  std::vector<Call> calls;
  std::vector<std::pair<std::string, Reply>> replies;  ///< requests waiting for an answer
  std::set<long long> dead;
  long long next_hog = 9000;

  bool alive(long long pid) const override { return pid > 0 && dead.count(pid) == 0; }
  void kill(long long pid) override {
    calls.push_back({"kill", pid, "", ""});
    dead.insert(pid);
  }
  void stop(long long pid) override { calls.push_back({"stop", pid, "", ""}); }
  void resume(long long pid) override { calls.push_back({"resume", pid, "", ""}); }
  long long start_hog(int cores, double) override {
    calls.push_back({"hog", next_hog, std::to_string(cores), ""});
    return next_hog++;
  }
  void end_hog(long long pid) override { calls.push_back({"end_hog", pid, "", ""}); }
  void request(Live what, const std::string& name, bool standby, Reply done) override {
    const bool plug = what == Live::PlugRobot || what == Live::PlugModule;
    const bool module = what == Live::PlugModule || what == Live::UnplugModule;
    const std::string command = plug ? "plug" : "unplug", target = (module ? "module " : "robot ") + name;
    calls.push_back({command, 0, target, what == Live::PlugRobot ? (standby ? "standby" : "primary") : ""});
    if (done) replies.emplace_back(command + " " + target, std::move(done));
  }
  std::vector<Call> of(const std::string& what) const {
    std::vector<Call> out;
    for (const auto& c : calls) {
      if (c.what == what) out.push_back(c);
    }
    return out;
  }
};

/// A module's processes: world, primary supervisor, two arms with a primary and a standby each; pids from base.
void add_module(Nemesis& n, const std::string& m, long long base, double t) {
  auto put = [&](const std::string& label, const std::string& role, const std::string& serving, long long pid) {
    ProcessView p;
    p.role = role;
    p.module = m;
    p.serving = serving;
    p.pid = pid;
    p.state = 2;
    p.last_t = t;
    n.on_status(label, p);
  };
  put(m + "/world", "world", "", base);
  put(m + "/supervisor", "supervisor", "primary", base + 1);
  put(m + "/left", "robot", "100", base + 2);
  put(m + "/left@50", "robot", "50", base + 3);
  put(m + "/right", "robot", "100", base + 4);
  put(m + "/right@50", "robot", "50", base + 5);
  n.on_owners(m, {{"left", m + "/left"}, {"right", m + "/right"}});
}

/// A nemesis over `modules` with its schedule (`faults` in 60 s, or a schedule given), history and actions; m1 is up
/// (add_module) from t = 0.
struct Rig {
  Schedule s;
  History h;
  Recorder act;
  Nemesis n;
  explicit Rig(Schedule schedule, const std::vector<std::string>& modules = {"m1"})
      : s(std::move(schedule)), n(s, modules, h, act) {
    add_module(n, "m1", 100, 0.0);
  }
  explicit Rig(std::vector<Fault> faults, const std::vector<std::string>& modules = {"m1"})
      : Rig(sixty(std::move(faults)), modules) {}

 private:
  static Schedule sixty(std::vector<Fault> faults) {
    Schedule out;
    out.duration_s = 60;
    out.faults = std::move(faults);
    return out;
  }
};

/// Keeps every process of `labels` heard at t (as their status every 100 ms would).
void heard(Nemesis& n, double t) {
  const auto procs = n.processes();
  for (auto [label, p] : procs) {
    p.last_t = t;
    n.on_status(label, p);
  }
}

Fault fault(double at, FaultKind k, Target target, double duration = 1.0, uint64_t pick = 0) {
  Fault f;
  f.at_s = at;
  f.kind = k;
  f.target = target;
  f.duration_s = duration;
  f.pick = pick;
  return f;
}

/// Runs the nemesis from `from` to `to` in 10 ms passes, processes heard throughout.
void run(Nemesis& n, double from, double to) {
  for (double t = from; t <= to + 1e-9; t += 0.01) {
    heard(n, t);
    n.step(t);
  }
}

}  // namespace

TEST_CASE("nemesis: faults fire at their time, a waiting one never releases a burst") {
  // One module up (three parked for load): a module unplug has no target (one module always runs) and waits;
  // the kills behind it still fire at their own times, not all at once when the unplug gives up.
  Rig rig({fault(5.0, FaultKind::Unplug, Target::Module), fault(6.0, FaultKind::Kill, Target::Robot),
           fault(7.0, FaultKind::Kill, Target::Standby), fault(9.0, FaultKind::Kill, Target::Robot)}, {"m1", "m2"});
  auto& [s, h, act, n] = rig;
  run(n, 0.0, 5.0 + Nemesis::kTargetWaitS + 5.0);
  REQUIRE(h.faults.size() == 4);
  // The kills: at 6, 7 and 9 s (within one pass), each a different process.
  std::vector<double> kill_times;
  for (const auto& r : h.faults) {
    if (r.fault.kind == FaultKind::Kill) kill_times.push_back(r.t);
  }
  REQUIRE(kill_times.size() == 3);
  CHECK(kill_times[0] == Approx(6.0).margin(0.011));
  CHECK(kill_times[1] == Approx(7.0).margin(0.011));
  CHECK(kill_times[2] == Approx(9.0).margin(0.011));
  CHECK(act.of("kill").size() == 3);
  // The unplug waited kTargetWaitS and was skipped: no second module came.
  const FaultRecord& unplug = h.faults.back();
  CHECK(unplug.fault.kind == FaultKind::Unplug);
  CHECK(unplug.skipped);
  CHECK(unplug.t == Approx(5.0 + Nemesis::kTargetWaitS).margin(0.011));
  CHECK(act.of("unplug").empty());
}

TEST_CASE("nemesis: a fault that waited fires once a target comes, at least 1 s after the last fault, one at a time") {
  Rig rig({fault(5.0, FaultKind::Unplug, Target::Module, 2.0), fault(8.0, FaultKind::Stall, Target::Supervisor, 0.5),
           fault(8.2, FaultKind::Stall, Target::Robot, 0.5)}, {"m1", "m2"});
  auto& [s, h, act, n] = rig;
  run(n, 0.0, 7.0);
  CHECK(h.faults.empty());  // the unplug waits for a second module
  CHECK(n.waiting() == 1);
  add_module(n, "m2", 200, 7.5);  // m2's world turns active at 7.5 s: m1 may go now, m2 settles for 3 s
  run(n, 7.5, 7.6);
  REQUIRE(h.faults.size() == 1);
  CHECK(h.faults[0].label == "m1");
  CHECK(h.faults[0].t == Approx(7.5).margin(0.011));
  CHECK(h.faults[0].note == "waited 3 s for a target");
  REQUIRE(act.of("unplug").size() == 1);
  CHECK(act.of("unplug")[0].target == "module m1");
  // The stalls find no target at 8.0 and 8.2 s (m1 is out, m2 settles) and wait; m2 is a target from 10.5 s,
  // and they go one at a time, 1 s apart.
  run(n, 7.6, 12.0);
  REQUIRE(h.faults.size() == 3);
  CHECK(h.faults[1].label == "m2/supervisor");
  CHECK(h.faults[1].t == Approx(10.5).margin(0.015));
  CHECK(h.faults[2].label == "m2/left");
  CHECK(h.faults[2].t == Approx(11.5).margin(0.025));
  CHECK(h.faults[2].t - h.faults[1].t >= Nemesis::kWaitedGapS - 1e-9);
  CHECK(n.waiting() == 0);
}

TEST_CASE("nemesis: one module always runs, and a settling module is left alone") {
  Rig rig({fault(1.0, FaultKind::Kill, Target::World, 2.0), fault(2.0, FaultKind::Kill, Target::Robot)});
  auto& [s, h, act, n] = rig;
  CHECK(n.candidates(Target::World, 0.5).empty());  // the only module
  CHECK(n.candidates(Target::Robot, 0.5).empty());  // settling: its world turned active at 0 s
  heard(n, 3.5);
  CHECK(n.candidates(Target::World, 3.5).empty());  // a kill: the only module always runs
  CHECK(n.candidates(Target::World, 3.5, FaultKind::Stall) == std::vector<std::string>{"m1/world"});  // a stall takes nothing out
  // ... unless the launcher holds another back for load: then the running one may be taken out; not once it is back.
  n.on_parked("m2", true);
  CHECK(n.candidates(Target::World, 3.5) == std::vector<std::string>{"m1/world"});
  CHECK(n.candidates(Target::Module, 3.5) == std::vector<std::string>{"m1"});
  n.on_parked("m2", false);
  CHECK(n.candidates(Target::World, 3.5).empty());
  n.on_parked("m1", true);  // the running one itself said parked (its processes still stopping): not a reason
  CHECK(n.candidates(Target::World, 3.5).empty());
  n.on_parked("m1", false);
  CHECK(n.candidates(Target::Robot, 3.5).size() == 2);
  CHECK(n.candidates(Target::Standby, 3.5).size() == 2);
  CHECK(n.candidates(Target::Robot, 5.1).empty());  // not heard for 1.6 s
  run(n, 0.0, 4.0);
  // The robot kill waited for the settling time and fired at 3 s; the world kill still waits.
  REQUIRE(h.faults.size() == 1);
  CHECK(h.faults[0].t == Approx(3.0).margin(0.011));
  CHECK(h.faults[0].had_standby);
  CHECK(act.of("kill").size() == 1);
}

TEST_CASE("nemesis: a stall continues after its duration, a killed world's module is plugged in again") {
  Rig rig({fault(4.0, FaultKind::Stall, Target::Robot, 1.5, 1), fault(6.0, FaultKind::Kill, Target::World, 2.0)}, {"m1", "m2"});
  auto& [s, h, act, n] = rig;
  add_module(n, "m2", 200, 0.0);
  run(n, 0.0, 4.5);
  REQUIRE(act.of("stop").size() == 1);
  const long long stalled = act.of("stop")[0].pid;
  // A stalled process is nobody's candidate.
  for (const auto& label : n.candidates(Target::Robot, 4.5)) CHECK(n.processes().at(label).pid != stalled);
  run(n, 4.5, 5.6);
  REQUIRE(act.of("resume").size() == 1);
  CHECK(act.of("resume")[0].pid == stalled);
  CHECK(h.faults[0].end_t == Approx(5.5).margin(0.011));
  run(n, 5.6, 8.5);
  REQUIRE(act.of("kill").size() == 1);
  const std::string module = h.faults[1].module;
  CHECK(h.faults[1].fault.target == Target::World);
  CHECK(n.candidates(Target::World, 8.5).empty());  // the other module alone is up: no module fault
  REQUIRE(act.of("plug").size() == 1);              // at 6 + 2 s
  CHECK(act.of("plug")[0].target == "module " + module);
  // Refused (still draining): retried a second later; accepted: the fault's end is the answer's time.
  REQUIRE(act.replies.size() == 1);
  auto refused = std::move(act.replies[0].second);
  act.replies.clear();
  refused(false, "module is draining", 8.6);
  run(n, 8.6, 9.7);
  REQUIRE(act.of("plug").size() == 2);
  REQUIRE(act.replies.size() == 1);
  act.replies[0].second(true, "ok", 9.8);
  CHECK(h.faults[1].end_t == Approx(9.8));
}

TEST_CASE("nemesis: an unplugged robot is plugged in again as a standby if a restarted robot took the primary's place") {
  Rig rig({fault(4.0, FaultKind::Unplug, Target::Robot, 1.0, 0)});
  auto& [s, h, act, n] = rig;
  run(n, 0.0, 5.1);
  REQUIRE(act.of("unplug").size() == 1);
  CHECK(act.of("unplug")[0].target == "robot m1/left");
  REQUIRE(act.of("plug").size() == 1);
  CHECK(act.of("plug")[0].target == "robot m1/left");
  CHECK(act.of("plug")[0].option == "primary");
  REQUIRE(act.replies.size() == 1);
  auto reply = std::move(act.replies[0].second);
  act.replies.clear();
  reply(false, "m1/left has its primary already", 5.2);
  REQUIRE(act.of("plug").size() == 2);
  CHECK(act.of("plug")[1].option == "standby");
  act.replies[0].second(true, "ok", 5.3);
  CHECK(h.faults[0].end_t == Approx(5.3));
}

TEST_CASE("nemesis: calm continues every stalled process and stops every hog") {
  Fault hog = fault(4.5, FaultKind::Hog, Target::None, 30.0);
  hog.cores = 2;
  Rig rig({fault(4.0, FaultKind::Stall, Target::Standby, 30.0), hog});
  auto& [s, h, act, n] = rig;
  run(n, 0.0, 5.0);
  REQUIRE(act.of("stop").size() == 1);
  REQUIRE(act.of("hog").size() == 1);
  CHECK(act.of("hog")[0].target == "2");
  n.calm(6.0);
  CHECK(act.of("resume").size() == 1);
  CHECK(act.of("end_hog").size() == 1);
  CHECK(h.faults[1].end_t == Approx(6.0));
  run(n, 6.0, 40.0);  // nothing more once calm
  CHECK(act.of("resume").size() == 1);
  CHECK(h.faults.size() == 2);
}

TEST_CASE("nemesis: a supervisor kill records whether a standby held the leader's plan") {
  // Run 13: m1's only standby supervisor had been restarted 1.9 s before its leader's kill and never heard its plan;
  // the checker judges such a kill by the lost-plan path's bound, and a warm standby's by the takeover bound.
  Rig rig({fault(5.0, FaultKind::Kill, Target::Supervisor), fault(10.0, FaultKind::Kill, Target::Supervisor)});
  auto& [s, h, act, n] = rig;
  ProcessView standby;
  standby.role = "supervisor";
  standby.module = "m1";
  standby.serving = "standby";
  standby.pid = 150;
  standby.state = 2;
  standby.last_t = 0.0;
  standby.replica = false;  // started, not yet a replica
  n.on_status("m1/supervisor@50", standby);
  run(n, 0.0, 5.5);
  REQUIRE(h.faults.size() == 1);
  CHECK(h.faults[0].label == "m1/supervisor");
  CHECK_FALSE(h.faults[0].had_standby);
  // The standby takes over; a new standby comes that holds the plan.
  standby.serving = "primary";
  standby.last_t = 5.5;
  n.on_status("m1/supervisor@50", standby);
  ProcessView warm = standby;
  warm.serving = "standby";
  warm.pid = 160;
  warm.replica = true;
  n.on_status("m1/supervisor@49", warm);
  run(n, 5.5, 10.5);
  REQUIRE(h.faults.size() == 2);
  CHECK(h.faults[1].label == "m1/supervisor@50");
  CHECK(h.faults[1].had_standby);
}

TEST_CASE("nemesis: a robot kill counts a standby behind the world's plan as no standby") {
  // Soak run 60: m1/left@49 missed a new leader's plan for 2 s (it answers nothing meanwhile, and says so in its
  // status); the serving m1/left@48 was killed then, and the checker held the arm to the 0.2 s of a warm standby.
  Rig rig({fault(5.0, FaultKind::Kill, Target::Robot), fault(10.0, FaultKind::Kill, Target::Robot)});
  auto& [s, h, act, n] = rig;
  // Both arms' standbys are behind the world's plan: neither kill had a standby.
  for (const char* label : {"m1/left@50", "m1/right@50"}) {
    ProcessView p = n.processes().at(label);
    p.behind = true;
    n.on_status(label, p);
  }
  run(n, 0.0, 5.5);
  REQUIRE(h.faults.size() == 1);
  CHECK_FALSE(h.faults[0].had_standby);
  // Back on the plan: the next kill of a primary had one.
  for (const char* label : {"m1/left@50", "m1/right@50"}) {
    ProcessView p = n.processes().at(label);
    p.behind = false;
    n.on_status(label, p);
  }
  run(n, 5.5, 10.5);
  REQUIRE(h.faults.size() == 2);
  CHECK(h.faults[1].label.find("@50") == std::string::npos);  // a primary (the other arm's, or this one's)
  CHECK(h.faults[1].had_standby);
}

TEST_CASE("nemesis: a robot kill of a primary behind the plan counts its arm's good standby") {
  // The review of run 60's fix: the killed robot itself is not its own standby, whether or not it is behind.
  Rig rig({fault(5.0, FaultKind::Kill, Target::Robot)});
  auto& [s, h, act, n] = rig;
  for (const char* label : {"m1/left", "m1/right"}) {  // both primaries behind; their standbys on the plan
    ProcessView p = n.processes().at(label);
    p.behind = true;
    n.on_status(label, p);
  }
  run(n, 0.0, 5.5);
  REQUIRE(h.faults.size() == 1);
  INFO("killed " << h.faults[0].label);
  // A robot kill takes a serving robot (a primary here), whose standby is on the plan.
  CHECK(h.faults[0].label.find("@50") == std::string::npos);
  CHECK(h.faults[0].had_standby);
}

TEST_CASE("nemesis: a robot kill counts a standby that lags its world's ticks as no standby") {
  // Soak run 61: m1/left@49, plugged 2 s before and starved in a burst of restarts, was 196 ticks behind its world
  // when the serving m1/left@50 was killed; it served the arm after 0.4 s, judged against a warm standby's 0.2 s.
  for (const long lag : {196L, 20L}) {
    INFO("the standbys' lag " << lag << " ticks");
    Rig rig({fault(5.0, FaultKind::Kill, Target::Robot)});
    auto& [s, h, act, n] = rig;
    n.set_tick_rate(1000.0);  // real time
    run(n, 0.0, 4.9);
    // Every robot's newest status (at 4.85 s) says its tick; at 5.0 s the world has reached tick 5000.
    for (const auto& [label, view] : n.processes()) {
      if (view.role != "robot") continue;
      ProcessView p = view;
      p.tick = label.find("@50") != std::string::npos ? 4850 - lag : 4850;
      p.last_t = 4.85;
      n.on_status(label, p);
    }
    n.on_tick("m1", 5000);
    n.step(5.0);
    REQUIRE(h.faults.size() == 1);
    CHECK(h.faults[0].label.find("@50") == std::string::npos);  // a primary
    CHECK(h.faults[0].had_standby == (lag < Nemesis::kWarmLagTicks));
  }
  // In lockstep (no tick rate) the rule is off: a world runs ticks as fast as it can, so a status's age says nothing.
  Rig lockstep({fault(5.0, FaultKind::Kill, Target::Robot)});
  run(lockstep.n, 0.0, 4.9);
  for (const auto& [label, view] : lockstep.n.processes()) {
    if (view.role != "robot") continue;
    ProcessView p = view;
    p.tick = label.find("@50") != std::string::npos ? 4654 : 4850;
    p.last_t = 4.85;
    lockstep.n.on_status(label, p);
  }
  lockstep.n.on_tick("m1", 20000);
  lockstep.n.step(5.0);
  REQUIRE(lockstep.h.faults.size() == 1);
  CHECK(lockstep.h.faults[0].had_standby);
}

TEST_CASE("nemesis: a standby resumed from a stall is no warm standby until its first status after the resume") {
  Rig rig({fault(4.0, FaultKind::Stall, Target::Standby, 1.0), fault(5.2, FaultKind::Kill, Target::Robot)});
  auto& [s, h, act, n] = rig;
  n.set_tick_rate(1000.0);
  run(n, 0.0, 4.05);  // the stall: one standby stopped from 4.0 s to 5.0 s
  REQUIRE(h.faults.size() == 1);
  const std::string stalled = h.faults[0].label;
  REQUIRE(stalled.find("@50") != std::string::npos);
  const std::string arm = stalled.substr(0, stalled.find('@'));
  // Statuses: the stalled one's last is from before its stop; every other robot's current.
  for (double t = 4.06; t <= 5.3 + 1e-9; t += 0.01) {
    for (const auto& [label, view] : n.processes()) {
      if (label == stalled) continue;
      ProcessView p = view;
      p.last_t = t;
      if (p.role == "robot") p.tick = std::lround(t * 1000.0);
      n.on_status(label, p);
    }
    n.on_tick("m1", std::lround(t * 1000.0));
    n.step(t);
  }
  REQUIRE(h.faults.size() == 2);
  INFO("stalled " << stalled << ", killed " << h.faults[1].label);
  // The arm whose standby stood still until 5.0 s, not heard since: no warm standby; the other arm's is warm.
  CHECK(h.faults[1].had_standby == (h.faults[1].label != arm));
}

TEST_CASE("nemesis: a coordinator kill records whether an active standby coordinator was there") {
  // Run 27: coordinator@r11 was killed 3 s after it took over, both other coordinators restarting; the checker judges
  // such a kill by the restart bound, one with an active standby by the takeover bound.
  Rig rig({fault(5.0, FaultKind::Kill, Target::Coordinator), fault(10.0, FaultKind::Kill, Target::Coordinator)});
  auto& [s, h, act, n] = rig;
  ProcessView c;
  c.role = "coordinator";
  c.serving = "primary";
  c.pid = 300;
  c.state = 2;
  n.on_status("coordinator@r11", c);
  ProcessView starting = c;
  starting.serving = "standby";
  starting.pid = 301;
  starting.state = 1;  // started, not active yet
  n.on_status("coordinator@r12", starting);
  run(n, 0.0, 5.5);
  REQUIRE(h.faults.size() == 1);
  CHECK(h.faults[0].label == "coordinator@r11");
  CHECK_FALSE(h.faults[0].had_standby);
  // r12 takes over; r13 comes as an active standby.
  ProcessView leader = starting;
  leader.serving = "primary";
  leader.state = 2;
  n.on_status("coordinator@r12", leader);
  ProcessView standby = leader;
  standby.serving = "standby";
  standby.pid = 302;
  n.on_status("coordinator@r13", standby);
  run(n, 5.5, 10.5);
  REQUIRE(h.faults.size() == 2);
  CHECK(h.faults[1].label == "coordinator@r12");
  CHECK(h.faults[1].had_standby);
}

TEST_CASE("nemesis: a run is over only once no fault waits for a target, and kTailS after the last that waited") {
  // Finding 75: a robot kill fell due while no robot served an arm (the module paused for load); the run ended
  // with the kill still waiting, as though the schedule had none. Now the run goes on until it fires.
  Schedule s;
  s.duration_s = 20;
  s.faults = {fault(15.0, FaultKind::Kill, Target::Robot)};
  Rig a(s);
  a.n.on_owners("m1", {});  // paused for load: the world reports no robot serving either arm
  run(a.n, 0.0, 19.0);
  CHECK_FALSE(a.n.over(19.0));  // before the duration
  run(a.n, 19.0, 30.0);
  CHECK(a.h.faults.empty());
  CHECK(a.n.waiting() == 1);
  CHECK_FALSE(a.n.over(30.0));  // past the duration, but the kill waits
  a.n.on_owners("m1", {{"left", "m1/left"}, {"right", "m1/right"}});  // resumed at 30 s
  run(a.n, 30.0, 30.05);
  REQUIRE(a.h.faults.size() == 1);
  CHECK_FALSE(a.h.faults[0].skipped);
  CHECK(a.h.faults[0].t == Approx(30.0).margin(0.011));
  CHECK(a.act.of("kill").size() == 1);
  CHECK(a.n.waiting() == 0);
  CHECK_FALSE(a.n.over(30.0 + Nemesis::kTailS - 0.1));  // its effect is still being recorded
  CHECK(a.n.over(30.0 + Nemesis::kTailS + 0.01));

  // A run whose faults all fired on time is over at its duration.
  Rig b(s);
  run(b.n, 0.0, 19.99);
  CHECK(b.h.faults.size() == 1);
  CHECK_FALSE(b.n.over(19.99));
  CHECK(b.n.over(20.0));

  // A fault that never finds a target is skipped after kTargetWaitS, and then the run ends too (bounded).
  Rig c(s);
  c.n.on_owners("m1", {});
  run(c.n, 0.0, 15.0 + Nemesis::kTargetWaitS + 0.05);
  REQUIRE(c.h.faults.size() == 1);
  CHECK(c.h.faults[0].skipped);
  CHECK_FALSE(c.n.over(15.0 + Nemesis::kTargetWaitS + 1.0));
  CHECK(c.n.over(15.0 + Nemesis::kTargetWaitS + Nemesis::kTailS + 0.1));

  // A fault due just before the end that no step has taken yet keeps the run going until a step takes it.
  Schedule late;
  late.duration_s = 20;
  late.faults = {fault(19.995, FaultKind::Kill, Target::Robot)};
  Rig d(late);
  run(d.n, 0.0, 19.99);
  CHECK(d.h.faults.empty());
  CHECK_FALSE(d.n.over(20.0));
  d.n.step(20.0);
  REQUIRE(d.h.faults.size() == 1);
  CHECK(d.n.over(20.0));
}
