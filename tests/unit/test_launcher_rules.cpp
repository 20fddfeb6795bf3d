// The launcher's exit rules (tandem::launcher::on_exit / after_restart): what the exit of each kind of process
// means, rule by rule, as Launcher::on_exit carries them out (docs/failure-model.md, "Failure tiers").
#include <catch2/catch.hpp>

#include "tandem/launcher/drain_watch.hpp"
#include "tandem/launcher/exit_rules.hpp"

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

TEST_CASE("launcher rules: a coordinator that is done stops the deployment; one that dies is replaced or fails it", "[launcher]") {
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
