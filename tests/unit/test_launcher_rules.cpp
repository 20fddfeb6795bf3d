// The launcher's exit rules (tandem::launcher::on_exit / after_restart): what the exit of each kind of process
// means, rule by rule, as launcher::Supervisor carries them out (docs/failure-model.md, "Failure tiers").
#include <catch2/catch.hpp>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tandem/launcher/agent_core.hpp"
#include "tandem/launcher/cpu_plan.hpp"
#include "tandem/launcher/drain_watch.hpp"
#include "tandem/launcher/exit_rules.hpp"
#include "tandem/launcher/plug_rules.hpp"
#include "tandem/launcher/spawn.hpp"
#include "tandem/runtime/role.hpp"

using namespace tandem::launcher;

namespace {
ExitFacts running(Role r, int status) {
  ExitFacts f;
  f.role = r;
  f.status = status;
  f.coordinated = true;
  f.module_ticked = true;
  f.max_repairs = 3;
  return f;
}
}  // namespace

TEST_CASE("launcher rules: roles by name, and nothing happens while the deployment stops or for an expected exit", "[launcher]") {
  CHECK(parse_role("robot") == Role::Robot);
  CHECK(parse_role("coordinator") == Role::Coordinator);
  CHECK_FALSE(parse_role("recorder").has_value());
  for (const Role r : {Role::Coordinator, Role::World, Role::Supervisor, Role::Robot}) {
    ExitFacts f = running(r, 137);
    f.stopping = true;
    CHECK(on_exit(f) == ExitVerdict::Nothing);
  }
  ExitFacts unplugged = running(Role::Robot, 143);
  unplugged.expected = true;
  CHECK(on_exit(unplugged) == ExitVerdict::Nothing);
}

TEST_CASE("launcher rules: a coordinator that is done stops the deployment, one that dies is replaced or fails it", "[launcher]") {
  CHECK(on_exit(running(Role::Coordinator, 0)) == ExitVerdict::AllTasksDone);
  ExitFacts f = running(Role::Coordinator, 137);
  REQUIRE(on_exit(f) == ExitVerdict::Restart);
  CHECK(after_restart(f, true) == AfterRestart::CarriesOn);   // a new one takes over
  CHECK(after_restart(f, false) == AfterRestart::Fail);       // past the intensity limit, no standby
  f.live_peers = 1;
  CHECK(after_restart(f, false) == AfterRestart::CarriesOn);  // a standby coordinator carries on
  // Expected or not: a coordinator's exit is judged the same (it is never unplugged).
  f.expected = true;
  CHECK(on_exit(f) == ExitVerdict::Restart);
}

TEST_CASE("launcher rules: a module that never came up is repaired with new participants, a bounded number of times", "[launcher]") {
  for (const Role r : {Role::World, Role::Supervisor, Role::Robot}) {
    for (const int code : {exit_code::kPeersNotFound, exit_code::kNoInput}) {
      ExitFacts f = running(r, code);
      f.module_ticked = false;
      CHECK(on_exit(f) == ExitVerdict::RepairStart);
      f.module_repairs = 3;  // the last repair did not help: the ordinary rules
      CHECK(on_exit(f) != ExitVerdict::RepairStart);
      f.module_repairs = 0;
      f.module_ticked = true;  // after the first tick a missing peer is no start-up race
      CHECK(on_exit(f) != ExitVerdict::RepairStart);
    }
    ExitFacts silent = running(r, 137);  // killed because it was never heard on the domain
    silent.module_ticked = false;
    silent.never_heard = true;
    CHECK(on_exit(silent) == ExitVerdict::RepairStart);
  }
}

TEST_CASE("launcher rules: robots are restarted, and their arm is served, braked until the restart, or waits for a plug", "[launcher]") {
  ExitFacts f = running(Role::Robot, 137);
  REQUIRE(on_exit(f) == ExitVerdict::Restart);
  f.live_peers = 1;
  CHECK(after_restart(f, false) == AfterRestart::CarriesOn);
  f.live_peers = 0;
  CHECK(after_restart(f, true) == AfterRestart::WaitsForRestart);
  CHECK(after_restart(f, false) == AfterRestart::WaitsForPlug);
  f.coordinated = false;  // a scenario run with an arm nobody serves cannot finish
  CHECK(after_restart(f, false) == AfterRestart::Fail);
  // A robot cut off from its leader (exit 6) is restarted like a killed one.
  CHECK(on_exit(running(Role::Robot, exit_code::kCutOff)) == ExitVerdict::Restart);
  // Done: nothing, unless its policy restarts it always.
  CHECK(on_exit(running(Role::Robot, 0)) == ExitVerdict::Nothing);
  ExitFacts always = running(Role::Robot, 0);
  always.restart_always = true;
  CHECK(on_exit(always) == ExitVerdict::Restart);
}

TEST_CASE("launcher rules: supervisors: a standby carries on, a lost plan restarts the module, a drain unplugs it", "[launcher]") {
  ExitFacts killed = running(Role::Supervisor, 137);
  CHECK(on_exit(killed) == ExitVerdict::ModuleFailed);  // its module's last supervisor
  killed.live_peers = 1;
  CHECK(on_exit(killed) == ExitVerdict::Restart);
  CHECK(after_restart(killed, false) == AfterRestart::CarriesOn);
  // A standby deaf to a live leader (exit 6) restarts alone; one with no plan to follow (exit 5) restarts the module.
  ExitFacts deaf = running(Role::Supervisor, exit_code::kCutOff);
  deaf.live_peers = 1;
  CHECK(on_exit(deaf) == ExitVerdict::Restart);
  ExitFacts lost = running(Role::Supervisor, exit_code::kLostPlan);
  lost.live_peers = 1;
  CHECK(on_exit(lost) == ExitVerdict::ModuleLostPlan);
  lost.peer_leads = true;  // another supervisor leads: this one was only deaf to it, and restarts alone
  CHECK(on_exit(lost) == ExitVerdict::Restart);
  lost.peer_leads = false;
  lost.coordinated = false;  // a scenario run has no coordinator to re-plan the task: the standby carries on
  CHECK(on_exit(lost) == ExitVerdict::Restart);
  ExitFacts drained = running(Role::Supervisor, 0);
  drained.module_draining = true;
  CHECK(on_exit(drained) == ExitVerdict::Drained);
}

TEST_CASE("launcher rules: worlds: a scenario's task over, a coordinated module failed, a scenario run failed", "[launcher]") {
  ExitFacts done = running(Role::World, 0);
  done.coordinated = false;
  CHECK(on_exit(done) == ExitVerdict::TaskOver);
  CHECK(on_exit(running(Role::World, 137)) == ExitVerdict::ModuleFailed);
  ExitFacts scenario = running(Role::World, 137);
  scenario.coordinated = false;
  CHECK(on_exit(scenario) == ExitVerdict::Fail);
  // A supervisor of a scenario run whose task is done exits 0 as well: over, not failed.
  ExitFacts sup = running(Role::Supervisor, 0);
  sup.coordinated = false;
  sup.live_peers = 1;
  CHECK(on_exit(sup) == ExitVerdict::TaskOver);
}

TEST_CASE("drain bounds: re-sent every second until acknowledged, a deaf leader stopped after 5 s, the module after 30 s", "[launcher]") {
  // A leader that never acknowledges: the launcher's loop every 20 ms for 40 s.
  DrainWatch w;
  CHECK_FALSE(w.active());
  w.start(100.0);
  int resends = 0, warns = 0;
  double first_stop_leader = -1.0, forced_at = -1.0;
  for (double t = 100.0; t < 140.0; t += 0.02) {
    const DrainStep s = w.step(t, false);
    resends += s.resend ? 1 : 0;
    warns += s.warn ? 1 : 0;
    if (s.stop_leader && first_stop_leader < 0.0) first_stop_leader = t;
    if (s.force) {
      forced_at = t;
      CHECK_FALSE((s.resend || s.stop_leader || s.warn));
    }
  }
  CHECK(resends == Approx(30).margin(1));  // about one a second until the bound
  CHECK(warns == 1);
  CHECK(first_stop_leader > 105.0);
  CHECK(first_stop_leader < 106.1);
  CHECK(forced_at > 130.0);
  CHECK(forced_at < 131.1);
  CHECK_FALSE(w.active());  // over: nothing more
  CHECK_FALSE(w.step(200.0, false).resend);

  // No standby ran at the first try: the leader is asked for again each second until one does.
  DrainWatch v;
  v.start(0.0);
  int asks = 0;
  for (double t = 0.0; t < 9.0; t += 0.02) {
    if (v.step(t, false).stop_leader) {
      ++asks;
      if (t > 7.0) v.leader_stopped();  // a standby supervisor ran from then on
    }
  }
  CHECK(asks == 3);  // at about 6, 7 and 8 s: none after the stop

  // Acknowledged at 2 s: no more requests, no leader stopped; the task still has to end within 30 s.
  DrainWatch a;
  a.start(0.0);
  bool resent_after_ack = false, stop_leader = false, forced = false;
  for (double t = 0.0; t < 31.5; t += 0.02) {
    const DrainStep s = a.step(t, t >= 2.0);
    resent_after_ack = resent_after_ack || (s.resend && t >= 2.0);
    stop_leader = stop_leader || s.stop_leader;
    forced = forced || s.force;
  }
  CHECK_FALSE(resent_after_ack);
  CHECK_FALSE(stop_leader);
  CHECK(forced);
  // A new drain starts the bounds again.
  a.start(50.0);
  CHECK(a.active());
  CHECK_FALSE(a.step(50.5, false).resend);
  CHECK(a.step(51.0, false).resend);
}

namespace {
// Processes that only record what is asked of them; a test decides when one exits.
struct RecordedProcesses : Processes {
  int next_pid = 1000;
  std::vector<Spec> started;
  std::vector<std::pair<int, int>> signals;  // (pid, signal)
  std::map<int, int> exits;                  // pid -> status, once exited
  int start(const Spec& s) override {
    started.push_back(s);
    return s.exe.find("coordinator") != std::string::npos && s.args.empty() ? -1 : next_pid++;
  }
  void signal(int pid, int sig) override {
    signals.emplace_back(pid, sig);
    if (sig == 9) exits[pid] = 128 + 9;  // SIGKILL always ends it
  }
  int reap(int pid) override {
    const auto it = exits.find(pid);
    if (it == exits.end()) return -1;
    const int st = it->second;
    exits.erase(it);
    return st;
  }
};

AgentRequestIn req(AgentRequestIn::Kind kind, unsigned long long run, unsigned long long spawn_id = 0,
                   const std::string& role = "robot") {
  AgentRequestIn r;
  r.kind = kind;
  r.run = run;
  r.spawn_id = spawn_id;
  r.label = "m1/left";
  r.role = role;
  r.args = {"--arm", "left"};
  return r;
}
}  // namespace

TEST_CASE("agent: a re-sent start runs once, a signal before its start makes it never run, only known roles and signals", "[launcher]") {
  using K = AgentRequestIn::Kind;
  RecordedProcesses p;
  AgentCore a(p, "/opt/tandem/bin", 100.0, 0.0);  // a launcher silent for longer than this test
  a.on_request(req(K::Start, 7, 1), 0.1);
  a.on_request(req(K::Start, 7, 1), 0.2);  // the launcher re-sends until acknowledged
  REQUIRE(p.started.size() == 1);
  CHECK(p.started[0].exe == "/opt/tandem/bin/tandem-robot");  // from its own directory, never from the wire
  CHECK(p.started[0].module == "m1");  // from its label: it is told its module's Discovery Server only
  CHECK(a.running() == 1);
  // A signal for a start that has not arrived yet: the start, when it comes, never runs.
  AgentRequestIn kill = req(K::Signal, 7, 2);
  kill.signal = 9;
  a.on_request(kill, 0.3);
  a.on_request(req(K::Start, 7, 2), 0.4);
  CHECK(p.started.size() == 1);
  REQUIRE(a.children().size() == 2);
  CHECK(a.children()[1].status == 128 + 9);
  CHECK_FALSE(a.children()[1].running);
  // Unknown role, bad signal, unknown kind: refused with what is accepted, nothing started or sent.
  a.on_request(req(K::Start, 7, 3, "/bin/sh"), 0.5);
  CHECK(p.started.size() == 1);
  CHECK(a.detail().find("accepted: world, supervisor, robot, coordinator") != std::string::npos);
  AgentRequestIn odd = req(K::Signal, 7, 1);
  odd.signal = 19;  // SIGSTOP
  a.on_request(odd, 0.6);
  CHECK(p.signals.empty());
  CHECK(a.detail().find("accepted: 2, 9, 15") != std::string::npos);
  AgentRequestIn unknown = req(K::Unknown, 7);
  unknown.raw_kind = 42;
  a.on_request(unknown, 0.7);
  CHECK(a.detail().find("unknown kind 42") != std::string::npos);
  // SIGTERM, then SIGKILL 5 s later if it is still there.
  AgentRequestIn term = req(K::Signal, 7, 1);
  term.signal = 15;
  a.on_request(term, 1.0);
  a.poll(1.5);
  a.poll(5.9);
  CHECK(p.signals.size() == 1);
  a.poll(6.1);
  REQUIRE(p.signals.size() == 2);
  CHECK(p.signals[1].second == 9);
  a.poll(6.2);
  CHECK(a.running() == 0);
  CHECK(a.take_killed());
}

TEST_CASE("agent: fencing when the launcher falls silent or counts the host lost, and serving again after a healed partition", "[launcher]") {
  using K = AgentRequestIn::Kind;
  RecordedProcesses p;
  AgentCore a(p, "/bin", 2.0, 0.0);
  a.on_request(req(K::Start, 7, 1), 0.0);
  for (double t = 0.1; t < 1.5; t += 0.1) {
    a.on_request(req(K::Heartbeat, 7), t);
    a.poll(t);
  }
  CHECK(a.running() == 1);
  a.poll(3.6);  // silent for 2.1 s: a cut link
  CHECK(a.fenced());
  REQUIRE(p.signals.size() == 1);
  CHECK(p.signals[0].second == 9);
  a.poll(3.7);
  CHECK(a.running() == 0);
  a.on_request(req(K::Heartbeat, 7), 4.0);  // the partition heals
  CHECK_FALSE(a.fenced());
  a.on_request(req(K::Start, 7, 2), 4.1);  // the launcher places a process here again
  CHECK(a.running() == 1);
  // One-way partition: the launcher says it does not hear this host.
  AgentRequestIn lost = req(K::Heartbeat, 7);
  lost.host_lost = true;
  a.on_request(lost, 4.2);
  CHECK(a.fenced());
  CHECK(p.signals.back().second == 9);
}

TEST_CASE("agent: one launcher run at a time, a new run after the old one is over or silent, the end stops leftovers", "[launcher]") {
  using K = AgentRequestIn::Kind;
  RecordedProcesses p;
  AgentCore a(p, "/bin", 2.0, 0.0);
  a.on_request(req(K::Start, 7, 1), 0.0);
  a.on_request(req(K::Start, 8, 1), 0.5);  // a second `tandem up` while run 7 is heard
  CHECK(p.started.size() == 1);
  CHECK(a.run() == 7);
  CHECK(a.detail().find("refused requests of another launcher run (8)") != std::string::npos);
  a.on_request(req(K::End, 8), 0.6);  // the end of a run it does not serve: nothing
  CHECK(a.running() == 1);
  a.on_request(req(K::End, 7), 1.0);  // run 7 over: its leftovers get SIGTERM
  CHECK(a.run_over());
  REQUIRE(p.signals.size() == 1);
  CHECK(p.signals[0].second == 15);
  a.on_request(req(K::Start, 7, 5), 1.1);  // a start after the end is refused
  CHECK(p.started.size() == 1);
  p.exits[1000] = 0;
  a.poll(1.2);
  a.on_request(req(K::Start, 8, 1), 1.5);  // now run 8 is served, with its own spawn ids
  CHECK(a.run() == 8);
  CHECK(p.started.size() == 2);
  CHECK(a.running() == 1);
}

namespace {
ModuleFacts module_running(bool failed = false) {
  ModuleFacts m;
  m.known = true;
  m.started = true;
  m.failed = failed;
  m.arms = {"left", "right"};
  return m;
}
}  // namespace

TEST_CASE("plug rules: a robot joins a running module's arm as a standby below the live ones, or as its only primary", "[launcher]") {
  using A = PlugDecision::Action;
  const ModuleFacts m = module_running();
  // A standby gets the strength the launcher computed (next_standby_strength); none left: refused.
  PlugDecision d = plug_robot("m1/left", "left", true, m, 4242, 49);
  CHECK(d.action == A::StartRobot);
  CHECK(d.strength == 49);
  CHECK(d.text == "plugged a robot into m1/left as a standby (ownership strength 49)");
  d = plug_robot("m1/left", "left", true, m, 4242, 0);
  CHECK(d.action == A::Refuse);
  CHECK(d.text.find("no ownership strength left") != std::string::npos);
  // A primary only where the arm has none.
  d = plug_robot("m1/left", "left", false, m, 4242, 49);
  CHECK(d.action == A::Refuse);
  CHECK(d.text.find("has a primary already (pid 4242)") != std::string::npos);
  d = plug_robot("m1/left", "left", false, m, 0, 49);
  CHECK(d.action == A::StartRobot);
  CHECK(d.strength == 100);
  // An unknown arm names the arms accepted; a module that does not run is refused whatever the arm.
  d = plug_robot("m1/middle", "middle", false, m, 0, 49);
  CHECK(d.action == A::Refuse);
  CHECK(d.text == "'plug robot m1/middle': module m1 has no arm 'middle' (arms: left, right)");
  CHECK(plug_robot("m1", "", false, m, 0, 49).action == A::Refuse);
  ModuleFacts ended = m;
  ended.end = tandem::launcher::ModuleEnd::of(tandem::launcher::ModuleEnd::Kind::Unplugged);
  d = plug_robot("m1/left", "left", false, ended, 0, 49);
  CHECK(d.action == A::Refuse);
  CHECK(d.text == "'plug robot m1/left': no running module 'm1'");
  CHECK(plug_robot("m9/left", "left", false, ModuleFacts{}, 0, 49).action == A::Refuse);
}

TEST_CASE("plug rules: a module is cleared after a drop, started again once it has left, added from a scenario, never twice", "[launcher]") {
  using A = PlugDecision::Action;
  // Failed by a drop: cleared (stopped, then started again from its initial grasp).
  CHECK(plug_module("m1", module_running(true), false, false, "d.yaml").action == A::ClearModule);
  // Running, or still draining (its processes finish the task): a second set would simulate it twice.
  PlugDecision d = plug_module("m1", module_running(), false, false, "d.yaml");
  CHECK(d.action == A::Refuse);
  CHECK(d.text == "'plug module m1': it is running already");
  ModuleFacts m = module_running();
  m.end = tandem::launcher::ModuleEnd::of(tandem::launcher::ModuleEnd::Kind::Draining);
  d = plug_module("m1", m, false, false, "d.yaml");
  CHECK(d.action == A::Refuse);
  CHECK(d.text.find("it is draining") != std::string::npos);
  // Gone (unplugged, failed, parked): started again as the deployment has it.
  for (const auto& end : {tandem::launcher::ModuleEnd::of(tandem::launcher::ModuleEnd::Kind::Unplugged),
                          tandem::launcher::ModuleEnd::of(tandem::launcher::ModuleEnd::Kind::Failed, "m1/world exited with code 4"),
                          tandem::launcher::ModuleEnd::of(tandem::launcher::ModuleEnd::Kind::Parked, "admission")}) {
    m.end = end;
    CHECK(plug_module("m1", m, false, false, "d.yaml").action == A::StartModule);
  }
  // Unknown: only with a scenario and a case, and a plain name.
  d = plug_module("m7", ModuleFacts{}, false, false, "d.yaml");
  CHECK(d.action == A::Refuse);
  CHECK(d.text.find("not a module of d.yaml; give its scenario and case") != std::string::npos);
  CHECK(plug_module("m7", ModuleFacts{}, true, false, "d.yaml").action == A::Refuse);
  CHECK(plug_module("m7/x", ModuleFacts{}, true, true, "d.yaml").action == A::Refuse);
  CHECK(plug_module("", ModuleFacts{}, true, true, "d.yaml").action == A::Refuse);
  CHECK(plug_module("m7", ModuleFacts{}, true, true, "d.yaml").action == A::AddModule);
  // A known module that has left, plugged with a scenario: added anew from it.
  m.end = tandem::launcher::ModuleEnd::of(tandem::launcher::ModuleEnd::Kind::Unplugged);
  CHECK(plug_module("m1", m, true, true, "d.yaml").action == A::AddModule);
}

TEST_CASE("plug rules: unplug drains a module, hands an arm over to a live standby, or pauses the module first", "[launcher]") {
  using A = UnplugDecision::Action;
  UnplugDecision d = unplug_module("m1", module_running());
  CHECK(d.action == A::DrainModule);
  CHECK(d.text == "unplugging module m1: draining (it finishes its task first)");
  ModuleFacts m = module_running();
  m.end = tandem::launcher::ModuleEnd::of(tandem::launcher::ModuleEnd::Kind::Draining);
  CHECK(unplug_module("m1", m).action == A::Refuse);  // once
  CHECK(unplug_module("m9", ModuleFacts{}).action == A::Refuse);
  d = unplug_robot("m1/left", true, "m1/left", "m1", 1);
  CHECK(d.action == A::HandOver);
  d = unplug_robot("m1/left@50", true, "m1/left", "m1", 0);
  CHECK(d.action == A::PauseThenUnplug);
  CHECK(d.text == "unplugging m1/left@50: no standby for m1/left; pausing m1 first");
  d = unplug_robot("m1/lft", false, "", "", 0);
  CHECK(d.action == A::Refuse);
  CHECK(d.text.find("no such running robot") != std::string::npos);
}

TEST_CASE("launcher rules: a due restart comes back as the primary only in its own empty slot, else as a standby, or not at all", "[launcher]") {
  DueRestart r;
  r.role = Role::Robot;
  r.strength = 100;
  r.standby_strength = 49;
  DueRestartDecision d = due_restart(r);
  CHECK(d.start);
  CHECK(d.strength == 100);  // the primary, back in its empty slot
  r.primary_alive = true;    // a primary was plugged meanwhile
  CHECK(due_restart(r).strength == 49);
  r.primary_alive = false;
  r.restart_as_standby = true;  // restart_as: standby
  CHECK(due_restart(r).strength == 49);
  r.restart_as_standby = false;
  r.strength = 49;  // a standby comes back as a standby
  CHECK(due_restart(r).strength == 49);
  r.standby_strength = 0;
  d = due_restart(r);
  CHECK_FALSE(d.start);
  CHECK(d.why == "no ownership strength left below the live robots");
  r.standby_strength = 49;
  r.task_over = true;
  CHECK_FALSE(due_restart(r).start);

  DueRestart s;
  s.role = Role::Supervisor;
  s.strength = 100;
  s.standby_strength = 50;
  s.live_in_slot = 1;
  d = due_restart(s);
  CHECK(d.start);
  CHECK(d.strength == 50);  // never back as the leader: it adopts the serving one's plan
  s.live_in_slot = 0;
  d = due_restart(s);
  CHECK_FALSE(d.start);
  CHECK(d.why == "no supervisor serves the module");

  DueRestart c;
  c.role = Role::Coordinator;
  c.task_over = true;  // (a coordinator has no module)
  CHECK(due_restart(c).start);
  DueRestart w;
  w.role = Role::World;
  CHECK_FALSE(due_restart(w).start);
}

TEST_CASE("own_group_for: the control plane and real-time per-tick processes get a group, lockstep's per-tick ones do not",
          "[launcher]") {
  CHECK(own_group_for("supervisor", {"--module", "m1", "--timing", "lockstep"}));
  CHECK(own_group_for("coordinator", {}));
  CHECK(own_group_for("world", {"--module", "m1", "--timing", "realtime"}));
  CHECK(own_group_for("robot", {"--timing", "realtime", "--arm", "left"}));
  CHECK_FALSE(own_group_for("world", {"--module", "m1", "--timing", "lockstep"}));
  CHECK_FALSE(own_group_for("robot", {"--arm", "left"}));  // the roles' default timing is lockstep
  CHECK_FALSE(own_group_for("robot", {"--timing"}));       // no value: not real time
}

namespace {
// Runs a shell through launcher::spawn that writes "<pid> <session id>" and its /proc autogroup line to `out`.
std::string spawned_session(bool own_group, const std::string& out) {
  SpawnOptions opt;
  opt.own_group = own_group;
  const std::string script = "read a b c d e sid rest < /proc/$$/stat; echo \"$$ $sid\" > " + out +
                             "; cat /proc/$$/autogroup >> " + out + " 2>/dev/null; true";
  const pid_t pid = spawn("test", "/bin/sh", {"-c", script}, opt);
  REQUIRE(pid > 0);
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  REQUIRE(WIFEXITED(status));
  std::ifstream in(out);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST_CASE("launcher::spawn: a child leads a session, and so an autogroup, of its own at the niceness it inherited",
          "[launcher]") {
  const std::string out = "/tmp/tandem-spawn-session-" + std::to_string(::getpid());
  errno = 0;
  const int before = ::getpriority(PRIO_PROCESS, 0);
  const bool raised = ::setpriority(PRIO_PROCESS, 0, kServiceNice) == 0;
  const std::string own = spawned_session(true, out);
  const std::string shared = spawned_session(false, out);
  (void)::setpriority(PRIO_PROCESS, 0, before);
  std::remove(out.c_str());
  INFO("own group: " << own << "shared: " << shared);
  long pid = 0, sid = 0;
  std::istringstream(own) >> pid >> sid;
  CHECK(pid > 0);
  CHECK(sid == pid);  // a session leader
  std::istringstream(shared) >> pid >> sid;
  CHECK(sid != pid);
  CHECK(sid == ::getsid(0));  // the parent's session
  // With autogroups on and the niceness permitted: the child's group has it (the file reads "/autogroup-N nice V").
  std::ifstream enabled("/proc/sys/kernel/sched_autogroup_enabled");
  int on = 0;
  if (raised && (enabled >> on) && on == 1 && own.find(" nice ") != std::string::npos) {
    CHECK(own.find(" nice " + std::to_string(kServiceNice)) != std::string::npos);
  }
}

TEST_CASE("CpuPlan: each module's per-tick processes get one CPU, the same for the run, modules round the CPUs",
          "[launcher]") {
  CpuPlan plan({0, 1});
  CHECK(plan.cpu_of("m1") == 0);
  CHECK(plan.cpu_of("m2") == 1);
  CHECK(plan.cpu_of("m1") == 0);  // a restarted robot of m1 joins its world
  CHECK(plan.cpu_of("m3") == 0);
  CHECK(plan.cpu_of("m4") == 1);
  CHECK(plan.cpu_of("m2") == 1);
  CHECK(plan.modules_on(0) == 2);
  CHECK(plan.modules_on(1) == 2);
  CHECK(plan.modules_on(7) == 0);
  // A cpuset that leaves out CPU 0: only the CPUs given are used.
  CpuPlan some({2, 5, 6});
  CHECK(some.cpu_of("a") == 2);
  CHECK(some.cpu_of("b") == 5);
  CHECK(some.cpu_of("c") == 6);
  CHECK(some.cpu_of("d") == 2);
  // No CPUs (lockstep, cpu_affinity: none): no pinning.
  CpuPlan none({});
  CHECK(none.cpu_of("m1") == -1);
  const std::vector<int> here = allowed_cpus();
  CHECK_FALSE(here.empty());
  CHECK(std::is_sorted(here.begin(), here.end()));
}

namespace {
// Runs a shell through launcher::spawn that writes its TANDEM_CPU ("-" when unset) to `out`.
std::string spawned_cpu_env(int cpu, const std::string& out) {
  SpawnOptions opt;
  opt.cpu = cpu;
  const pid_t pid = spawn("test", "/bin/sh", {"-c", "echo \"${TANDEM_CPU:--}\" > " + out}, opt);
  REQUIRE(pid > 0);
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  std::ifstream in(out);
  std::string v;
  in >> v;
  return v;
}
}  // namespace

TEST_CASE("TANDEM_CPU: spawn sets it or drops an inherited one, and a per-tick process pins every thread to it",
          "[launcher]") {
  const std::string out = "/tmp/tandem-spawn-cpu-" + std::to_string(::getpid());
  ::setenv("TANDEM_CPU", "7", 1);  // the launcher's own, if any, is never passed on
  struct Unset {
    ~Unset() { ::unsetenv("TANDEM_CPU"); }  // also when a REQUIRE throws
  } unset;
  CHECK(spawned_cpu_env(1, out) == "1");
  CHECK(spawned_cpu_env(-1, out) == "-");
  std::remove(out.c_str());
  CHECK(tandem::runtime::parse_cpu("0") == 0);
  CHECK(tandem::runtime::parse_cpu("3") == 3);
  CHECK(tandem::runtime::parse_cpu("") == -1);
  CHECK(tandem::runtime::parse_cpu(nullptr) == -1);
  CHECK(tandem::runtime::parse_cpu("-1") == -1);
  CHECK(tandem::runtime::parse_cpu("1x") == -1);
  CHECK(tandem::runtime::parse_cpu("100000") == -1);
  // In a child (the test process stays unpinned): two threads, both pinned to the last CPU this process may use.
  const int cpu = allowed_cpus().back();
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::setenv("TANDEM_CPU", std::to_string(cpu).c_str(), 1);
    std::atomic<bool> go{false};
    std::thread other([&go] {
      while (!go.load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    });
    const int pinned = tandem::runtime::pin_to_cpu_from_env();
    int ok = pinned == 2 ? 1 : 0;
    for (const pid_t tid : {static_cast<pid_t>(::getpid()), static_cast<pid_t>(::syscall(SYS_gettid))}) {
      cpu_set_t set;
      CPU_ZERO(&set);
      if (::sched_getaffinity(tid, sizeof set, &set) != 0 || CPU_COUNT(&set) != 1 || !CPU_ISSET(cpu, &set)) ok = 0;
    }
    cpu_set_t set;
    CPU_ZERO(&set);
    if (::pthread_getaffinity_np(other.native_handle(), sizeof set, &set) != 0 || CPU_COUNT(&set) != 1 ||
        !CPU_ISSET(cpu, &set)) {
      ok = 0;
    }
    go = true;
    other.join();
    ::_exit(ok == 1 ? 0 : 1);
  }
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
}

TEST_CASE("bound teardown: a role process whose teardown hangs ends with its own code, one whose teardown ends is untouched", "[launcher]") {
  // A world once said "task done" in a CI run and never exited (its DDS teardown hung, 2026-11-28).
  const auto child = [](bool hangs, int code) {
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::close(STDERR_FILENO);  // (its message is not this test's output)
      const int c = tandem::runtime::bound_teardown("test-role", code, 0.3);
      if (hangs) {
        for (;;) ::pause();  // a teardown that never ends
      }
      ::_exit(c);
    }
    return pid;
  };
  for (const bool hangs : {true, false}) {
    INFO((hangs ? "its teardown hangs" : "its teardown ends"));
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = child(hangs, 7);
    REQUIRE(pid > 0);
    int status = 0;
    pid_t got = 0;
    while ((got = ::waitpid(pid, &status, WNOHANG)) == 0 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(20)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (got == 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      FAIL("the child did not end within 20 s");
    }
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 7);
    if (hangs) CHECK(took >= 0.3);  // not before its bound
  }
}
