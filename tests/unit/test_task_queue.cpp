// Unit tests of the coordinator's bookkeeping (services/coordinator/task_queue.hpp): balance, modules that
// are lost, leave or come back, the rebuild of a standby that takes over, and that no task is counted twice,
// also against simulated supervisors that fall silent and a primary that dies mid-run.
#include <catch2/catch.hpp>

#include "test_support.hpp"

#include <map>
#include <string>
#include <vector>

#include "tandem/coordinator/coordinator_core.hpp"
#include "tandem/coordinator/leadership.hpp"
#include "tandem/coordinator/task_queue.hpp"

namespace {

using tandem::coordinator::Assignment;
using tandem::coordinator::Balance;
using tandem::coordinator::EventKind;
using tandem::coordinator::kModuleLostS;
using tandem::coordinator::ModuleReport;
using tandem::coordinator::Snapshot;
using tandem::coordinator::TaskQueue;
using tandem::test::Lcg;

constexpr uint8_t kIdle = 0, kRunning = 1, kDone = 2, kPaused = 3, kDraining = 4, kLeft = 5, kFailed = 6;

std::vector<std::string> task_names(int n) {
  std::vector<std::string> out;
  out.reserve(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) out.push_back("t" + std::to_string(i));
  return out;
}

double no_wear(const std::string& /*module*/) { return 0.0; }

bool has(const std::vector<tandem::coordinator::Event>& events, EventKind kind) {
  for (const auto& e : events) {
    if (e.kind == kind) return true;
  }
  return false;
}

/// Every task done exactly once, in the queue and in its published state.
void check_done_once(const TaskQueue& q) {
  CHECK(q.complete());
  CHECK(q.duplicates() == 0);
  const Snapshot s = q.snapshot();
  CHECK(s.done_count() == q.task_count());
  CHECK(s.done_total == q.task_count());  // no task finished twice
  REQUIRE(s.done_by.size() == q.task_count());
  for (size_t t = 0; t < s.done_by.size(); ++t) {
    INFO(q.task_name(t));
    CHECK(s.done_by[t] >= 1);
    CHECK(s.done_by[t] <= s.modules.size());
  }
}

}  // namespace

TEST_CASE("tasks go to the least worn free module, ties to fewer tasks then name", "[coordinator]") {
  TaskQueue q(task_names(4), Balance::Wear);
  for (const char* m : {"m3", "m1", "m2"}) q.report({m, 0, kIdle}, 0.0);
  std::map<std::string, double> wear{{"m1", 2.0}, {"m2", 1.0}, {"m3", 1.0}};
  auto wear_of = [&wear](const std::string& m) { return wear[m]; };

  auto a = q.assign_next(wear_of);
  REQUIRE(a);
  CHECK(a->module == "m2");  // m2 and m3 wear least: the name decides
  CHECK(a->id == 1);
  CHECK(q.task_name(a->task) == "t0");
  CHECK(a->wear == 1.0);
  a = q.assign_next(wear_of);
  REQUIRE(a);
  CHECK(a->module == "m3");
  CHECK(a->id == 2);
  a = q.assign_next(wear_of);
  REQUIRE(a);
  CHECK(a->module == "m1");
  CHECK_FALSE(q.assign_next(wear_of));  // nobody is free
  CHECK(q.running_count() == 3);
  CHECK(q.pending() == std::vector<std::string>{"t3"});

  // m2 and m3 finish; then m2 wears less than m3 and gets the last task.
  CHECK(has(q.report({"m2", 1, kDone}, 0.1), EventKind::Finished));
  q.report({"m3", 2, kDone}, 0.1);
  CHECK(q.done_count() == 2);
  q.report({"m2", 5, kDone}, 0.2);  // not its task: nothing is counted (ids never go back, though)
  CHECK(q.done_count() == 2);
  wear["m2"] = 0.5;
  a = q.assign_next(wear_of);
  REQUIRE(a);
  CHECK(a->module == "m2");  // less wear wins over fewer tasks
  CHECK(a->id == 6);         // above every id a module reported
}

TEST_CASE("round robin gives the next task to the module with the fewest tasks", "[coordinator]") {
  TaskQueue q(task_names(6), Balance::RoundRobin);
  q.report({"a", 0, kIdle}, 0.0);
  q.report({"b", 0, kIdle}, 0.0);
  auto heavy = [](const std::string& m) { return m == "a" ? 0.0 : 10.0; };  // ignored by round robin
  auto x = q.assign_next(heavy);
  REQUIRE(x);
  CHECK(x->module == "a");
  q.report({"a", x->id, kDone}, 0.1);
  x = q.assign_next(heavy);
  REQUIRE(x);
  CHECK(x->module == "b");  // a has done one task, b none
}

TEST_CASE("only idle or done modules with nothing in flight get tasks", "[coordinator]") {
  TaskQueue q(task_names(3), Balance::Wear);
  q.report({"paused", 0, kPaused}, 0.0);
  q.report({"draining", 0, kDraining}, 0.0);
  q.report({"busy", 0, kRunning}, 0.0);
  CHECK_FALSE(q.assign_next(no_wear));
  q.report({"free", 0, kIdle}, 0.0);
  const auto a = q.assign_next(no_wear);
  REQUIRE(a);
  CHECK(a->module == "free");
  // A paused module keeps its task: it finishes it when it resumes.
  q.report({"free", a->id, kPaused}, 0.5);
  q.report({"free", a->id, kDone}, 1.0);
  CHECK(q.done_count() == 1);
  CHECK(q.module_count() == 4);
}

TEST_CASE("a lost module's task goes back to the front of the queue", "[coordinator]") {
  TaskQueue q(task_names(4), Balance::Wear);
  q.report({"m1", 0, kIdle}, 0.0);
  q.report({"m2", 0, kIdle}, 0.0);
  const auto a1 = q.assign_next(no_wear);  // t0 -> m1
  const auto a2 = q.assign_next(no_wear);  // t1 -> m2
  REQUIRE(a1);
  REQUIRE(a2);
  CHECK(q.pending() == std::vector<std::string>{"t2", "t3"});

  q.report({"m1", a1->id, kRunning}, 1.0);  // m2 falls silent after t = 0
  CHECK(q.expire(kModuleLostS).empty());
  const auto events = q.expire(kModuleLostS + 0.01);
  REQUIRE(events.size() == 1);
  CHECK(events[0].kind == EventKind::Lost);
  CHECK(events[0].module == "m2");
  CHECK(events[0].task == "t1");
  CHECK(q.pending() == std::vector<std::string>{"t1", "t2", "t3"});
  CHECK(q.lost_count() == 1);
  CHECK(q.running_count() == 1);

  // The next free module takes it, with a new id.
  q.report({"m1", a1->id, kDone}, 1.6);
  const auto again = q.assign_next(no_wear);
  REQUIRE(again);
  CHECK(again->module == "m1");
  CHECK(q.task_name(again->task) == "t1");
  CHECK(again->id > a2->id);
}

TEST_CASE("a late done of a re-assigned task is ignored and the task is counted once", "[coordinator]") {
  TaskQueue q(task_names(2), Balance::Wear);
  q.report({"m1", 0, kIdle}, 0.0);
  const auto a = q.assign_next(no_wear);  // t0 -> m1, id 1
  REQUIRE(a);
  q.expire(2.0);  // m1 is lost: t0 back in the queue
  q.report({"m2", 0, kIdle}, 2.0);
  const auto b = q.assign_next(no_wear);  // t0 -> m2, id 2
  REQUIRE(b);
  CHECK(b->module == "m2");
  CHECK(q.task_name(b->task) == "t0");

  // m1 comes back and reports t0 (id 1) done: ignored, once; it is usable again, for new tasks.
  auto events = q.report({"m1", a->id, kDone}, 2.5);
  CHECK(has(events, EventKind::Rejoined));
  CHECK(has(events, EventKind::LateDoneIgnored));
  CHECK_FALSE(has(events, EventKind::Finished));
  CHECK(q.done_count() == 0);
  CHECK_FALSE(has(q.report({"m1", a->id, kDone}, 2.6), EventKind::LateDoneIgnored));
  const auto c = q.assign_next(no_wear);  // t1 -> m1
  REQUIRE(c);
  CHECK(c->module == "m1");
  CHECK(q.task_name(c->task) == "t1");

  q.report({"m2", b->id, kDone}, 3.0);
  q.report({"m1", c->id, kDone}, 3.0);
  check_done_once(q);
  CHECK(q.done_by_module().at("m2") == std::vector<std::string>{"t0"});
  CHECK(q.done_by_module().at("m1") == std::vector<std::string>{"t1"});
}

TEST_CASE("a module that took a newer id than the one in flight on it is free again, and that task goes back, not done", "[coordinator]") {
  // Another coordinator led while this one stood still: it saw m1 finish id 1 and gave m1 id 7. This one still holds
  // id 1 in flight on m1 and hears only m1's newest state.
  TaskQueue q(task_names(3), Balance::Wear);
  q.report({"m1", 0, kIdle}, 0.0);
  const auto a = q.assign_next(no_wear);  // t0 -> m1, id 1
  REQUIRE(a);
  auto events = q.report({"m1", 7, kRunning}, 1.0);
  CHECK(has(events, EventKind::Requeued));
  CHECK(q.done_count() == 0);  // never counted without a report of it
  CHECK(q.pending().front() == "t0");
  CHECK_FALSE(q.assign_next(no_wear));  // m1 runs id 7
  q.report({"m1", 7, kDone}, 2.0);
  const auto b = q.assign_next(no_wear);  // free again: t0 once more, with an id above 7
  REQUIRE(b);
  CHECK(b->module == "m1");
  CHECK(q.task_name(b->task) == "t0");
  CHECK(b->id > 7);
}

TEST_CASE("a module that leaves is removed, its unfinished task back at the front", "[coordinator]") {
  TaskQueue q(task_names(3), Balance::Wear);
  q.report({"m1", 0, kIdle}, 0.0);
  q.report({"m2", 0, kIdle}, 0.0);
  const auto a1 = q.assign_next(no_wear);
  const auto a2 = q.assign_next(no_wear);
  REQUIRE(a1);
  REQUIRE(a2);
  // m1 drains: it finishes its task and leaves (it reports "left" with that id: counted done).
  auto events = q.report({"m1", a1->id, kLeft}, 0.5);
  CHECK(has(events, EventKind::Finished));
  CHECK(has(events, EventKind::Left));
  // m2 leaves before taking its task (its report still names an older id): the task goes back.
  events = q.report({"m2", 0, kLeft}, 0.5);
  REQUIRE(events.size() == 1);
  CHECK(events[0].task == q.task_name(a2->task));
  CHECK(q.module_count() == 0);
  CHECK(q.pending().front() == q.task_name(a2->task));
  CHECK(q.done_count() == 1);
}

TEST_CASE("a coordinator back from its own stall does not take the modules' tasks back, a module silent after it does", "[coordinator]") {
  TaskQueue q(task_names(3), Balance::Wear);
  q.report({"m1", 0, kIdle}, 0.0);
  q.report({"m2", 0, kIdle}, 0.0);
  const auto a1 = q.assign_next(no_wear);
  const auto a2 = q.assign_next(no_wear);
  REQUIRE(a1);
  REQUIRE(a2);
  // The coordinator stood still from 0.1 s to 2.1 s: nobody was heard, through its own fault.
  q.forgive_silence(2.1);
  CHECK(q.expire(2.1).empty());
  CHECK(q.expire(3.5).empty());
  CHECK(q.running_count() == 2);
  // m1 reports again; m2 stays silent for 1.5 s after the stall: m2 is lost and its task goes back.
  q.report({"m1", a1->id, kRunning}, 3.0);
  const auto events = q.expire(3.7);
  REQUIRE(events.size() == 1);
  CHECK(events[0].module == "m2");
  CHECK(q.pending().front() == q.task_name(a2->task));
  // Without the forgiveness the same stall would have lost both (the behaviour the soak found).
  TaskQueue r(task_names(3), Balance::Wear);
  r.report({"m1", 0, kIdle}, 0.0);
  r.report({"m2", 0, kIdle}, 0.0);
  REQUIRE(r.assign_next(no_wear));
  REQUIRE(r.assign_next(no_wear));
  CHECK(r.expire(2.1).size() == 2);
}

TEST_CASE("task states with an unknown state or no module are rejected and counted", "[coordinator]") {
  TaskQueue q(task_names(1), Balance::Wear);
  CHECK(q.report({"m1", 0, 7}, 0.0).empty());
  CHECK(q.report({"", 0, kIdle}, 0.0).empty());
  CHECK(q.rejected() == 2);
  CHECK(q.module_count() == 0);
  CHECK_FALSE(q.assign_next(no_wear));
}

TEST_CASE("a standby rebuilds the queue from the last state and reconciles it with the modules",
          "[coordinator]") {
  // The primary's last state: t0 done by m1; in flight t1 on m1 (id 3), t2 on m2 (id 4), t3 on m3 (id 5) and
  // t4 on m4 (id 6).
  Snapshot s;
  s.next_task_id = 7;
  s.modules = {"m1"};
  s.done_by = {1, 0, 0, 0, 0, 0, 0};  // t0 done by m1
  s.done_total = 1;
  s.running = {"t1", "t2", "t3", "t4"};
  s.running_on = {"m1", "m2", "m3", "m4"};
  s.running_id = {3, 4, 5, 6};
  REQUIRE(s.well_formed());

  TaskQueue standby(task_names(7), Balance::Wear);
  CHECK(standby.count_done(s) == 1);
  // The modules' latest reports, as the standby kept them.
  standby.report({"m1", 3, kDone}, 1.0);     // finished t1 after the last state
  standby.report({"m2", 2, kDone}, 1.0);     // has not taken t2 yet: send it again
  standby.report({"m3", 5, kRunning}, 1.0);  // runs t3
  standby.report({"m5", 0, kIdle}, 1.0);     // plugged later
  // m4 never reported to the standby.
  standby.restore(s, 1.2);
  CHECK(standby.done_count() == 1);
  CHECK(standby.running_count() == 4);
  CHECK(standby.pending() == std::vector<std::string>{"t5", "t6"});

  const TaskQueue::Reconciled r = standby.reconcile(1.2);
  CHECK(has(r.events, EventKind::Finished));
  CHECK(standby.done_count() == 2);
  REQUIRE(r.resend.size() == 2);  // t2 to m2, and t4 to m4 (never heard), with their ids
  CHECK(r.resend[0].module == "m2");
  CHECK(r.resend[0].id == 4);
  CHECK(standby.task_name(r.resend[0].task) == "t2");
  CHECK(r.resend[1].module == "m4");
  CHECK(r.resend[1].id == 6);
  CHECK(standby.running_count() == 3);

  // New work goes on with fresh ids: m1 (done, free) and m5.
  const auto a = standby.assign_next(no_wear);
  const auto b = standby.assign_next(no_wear);
  REQUIRE(a);
  REQUIRE(b);
  CHECK(a->id == 7);
  CHECK(b->id == 8);
  CHECK_FALSE(standby.assign_next(no_wear));

  // m4 stays silent: lost, t4 back at the front; the others report on, finish, and one of them does t4.
  standby.report({"m2", 4, kRunning}, 2.7);
  standby.report({"m3", 5, kRunning}, 2.7);
  standby.report({a->module, a->id, kRunning}, 2.7);
  standby.report({b->module, b->id, kRunning}, 2.7);
  const auto lost = standby.expire(1.2 + kModuleLostS + 0.1);
  REQUIRE(lost.size() == 1);
  CHECK(lost[0].module == "m4");
  CHECK(standby.pending().front() == "t4");
  const double t = 3.0;
  standby.report({"m2", 4, kDone}, t);
  standby.report({"m3", 5, kDone}, t);
  standby.report({a->module, a->id, kDone}, t);
  standby.report({b->module, b->id, kDone}, t);
  while (const auto c = standby.assign_next(no_wear)) standby.report({c->module, c->id, kDone}, t);
  check_done_once(standby);
}

TEST_CASE("a takeover puts back tasks of modules that left, are lost or moved on", "[coordinator]") {
  Snapshot s;
  s.next_task_id = 4;
  s.running = {"t0", "t1", "t2"};
  s.running_on = {"gone", "silent", "ahead"};
  s.running_id = {1, 2, 3};
  TaskQueue q(task_names(4), Balance::Wear);
  q.report({"gone", 0, kLeft}, 0.0);       // left without taking t0
  q.report({"silent", 2, kRunning}, 0.0);  // last heard long ago
  q.report({"ahead", 9, kRunning}, 5.0);   // runs a task the state does not know
  q.restore(s, 5.0);
  const TaskQueue::Reconciled r = q.reconcile(5.0);
  CHECK(r.resend.empty());
  CHECK(q.running_count() == 0);
  CHECK(q.done_count() == 0);
  CHECK(q.pending().size() == 4);
  CHECK(q.module_count() == 2);  // "gone" is removed
  CHECK(q.snapshot().next_task_id == 10);
}

TEST_CASE("a standby that never heard a state starts from the whole queue", "[coordinator]") {
  TaskQueue q(task_names(3), Balance::Wear);
  q.report({"m1", 0, kIdle}, 0.0);
  const TaskQueue::Reconciled r = q.reconcile(0.5);
  CHECK(r.events.empty());
  CHECK(r.resend.empty());
  CHECK(q.pending() == std::vector<std::string>{"t0", "t1", "t2"});
}

TEST_CASE("no task is counted twice with lost modules, late reports and a takeover", "[coordinator]") {
  // Simulated supervisors as in services/supervisor: a module takes an assignment with a newer id when it is
  // free, runs it for a while and reports it done; reports every 0.1 s unless it is silent for a while.
  struct Sim {
    uint64_t task_id = 0;
    bool running = false;
    int steps_left = 0;
    double silent_until = -1.0;
  };
  int lost = 0, late_done_ignored = 0;
  auto count = [&](const std::vector<tandem::coordinator::Event>& events) {
    for (const auto& e : events) {
      lost += e.kind == EventKind::Lost ? 1 : 0;
      late_done_ignored += e.kind == EventKind::LateDoneIgnored ? 1 : 0;
    }
  };
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    INFO("seed " << seed);
    Lcg rng(seed);
    const int n_tasks = 40;
    TaskQueue primary(task_names(n_tasks), Balance::Wear);
    TaskQueue standby(task_names(n_tasks), Balance::Wear);
    TaskQueue* q = &primary;
    bool taken_over = false;
    std::map<std::string, Sim> sims{{"m1", {}}, {"m2", {}}, {"m3", {}}, {"m4", {}}};
    std::map<std::string, Assignment> inbox;  // latest assignment per module (keep-last 1)
    Snapshot last;
    const double takeover_at = rng.uniform(0.5, 3.0);
    double t = 0.0;
    for (int step = 0; step < 4000 && !q->complete(); ++step, t += 0.1) {
      for (auto& [name, sim] : sims) {
        if (t < sim.silent_until) continue;
        if (auto it = inbox.find(name); it != inbox.end() && it->second.id > sim.task_id) {
          if (!sim.running) {
            sim.task_id = it->second.id;
            sim.running = true;
            sim.steps_left = static_cast<int>(rng.uniform(2.0, 12.0));
          }
          inbox.erase(it);  // taken from the reader: a supervisor busy with a task drops an assignment
        }
        if (sim.running && --sim.steps_left <= 0) sim.running = false;
        if (rng.uniform(0.0, 1.0) < 0.01) sim.silent_until = t + rng.uniform(0.5, 3.0);  // may be lost
        const ModuleReport rep{name, sim.task_id, sim.running ? kRunning : (sim.task_id > 0 ? kDone : kIdle)};
        if (!taken_over) standby.report(rep, t);  // the standby keeps the latest reports
        count(q->report(rep, t));
      }
      if (!taken_over && t >= takeover_at) {  // the primary dies: the standby takes over from its last state
        standby.restore(last, t);
        const TaskQueue::Reconciled r = standby.reconcile(t);
        for (const auto& a : r.resend) inbox[a.module] = a;
        q = &standby;
        taken_over = true;
      }
      count(q->expire(t));
      while (const auto a = q->assign_next(no_wear)) {
        last = q->snapshot();  // published before the assignment
        inbox[a->module] = *a;
      }
      for (const auto& a : q->untaken(t)) inbox[a.module] = a;  // as CoordinatorCore::update does
      last = q->snapshot();
    }
    CHECK(taken_over);
    CHECK(q->complete());  // no module left idle with a task in flight that it never took
    check_done_once(*q);
  }
  CHECK(lost > 0);  // the runs did exercise lost modules and their late reports
  CHECK(late_done_ignored > 0);
}

TEST_CASE("a module heard again with the task taken from it keeps it, and an assignment it dropped is sent again", "[coordinator]") {
  // The soak-small hour: m2's world restarted, its supervisor was silent for 1.5 s and m2 was lost; heard again,
  // it got its own task back under a new id, which its supervisor (still running the old id) dropped; its "done"
  // of the old id was ignored, and m2 stood idle with a task in flight for 30 s.
  TaskQueue q(task_names(3), Balance::Wear);
  q.report({"m1", 0, kIdle}, 0.0);
  q.report({"m2", 0, kIdle}, 0.0);
  const auto a1 = q.assign_next(no_wear);  // t0 -> m1
  const auto a2 = q.assign_next(no_wear);  // t1 -> m2
  REQUIRE(a1);
  REQUIRE(a2);
  q.report({"m1", a1->id, kRunning}, 1.0);
  q.report({"m2", a2->id, kRunning}, 0.5);
  const auto lost = q.expire(2.1);  // m2 silent for 1.6 s
  REQUIRE(lost.size() == 1);
  CHECK(q.pending() == std::vector<std::string>{"t1", "t2"});
  // Heard again saying "idle" with t1's id: not given back (it may never have run it), and not credited.
  auto events = q.report({"m2", a2->id, kIdle}, 2.15);
  CHECK(has(events, EventKind::Rejoined));
  CHECK_FALSE(has(events, EventKind::Reclaimed));
  CHECK_FALSE(has(events, EventKind::Finished));
  // Then running t1: it stays with m2, and t1 is not handed to anyone else.
  events = q.report({"m2", a2->id, kRunning}, 2.2);
  CHECK(has(events, EventKind::Reclaimed));
  CHECK(q.pending() == std::vector<std::string>{"t2"});
  CHECK_FALSE(q.assign_next(no_wear));  // both busy
  events = q.report({"m2", a2->id, kDone}, 3.0);
  CHECK(has(events, EventKind::Finished));
  CHECK(q.done_count() == 1);
  // An assignment that m2 drops: it keeps reporting the older id finished; after kUntakenS it is sent again, once
  // per kUntakenS, with the same id; none while it reports the new id.
  const auto a3 = q.assign_next(no_wear);  // t2 -> m2
  REQUIRE(a3);
  CHECK(a3->module == "m2");
  q.report({"m2", a2->id, kDone}, 3.1);
  CHECK(q.untaken(3.5).empty());
  q.report({"m2", a2->id, kDone}, 4.0);
  const auto again = q.untaken(4.2);
  REQUIRE(again.size() == 1);
  CHECK(again[0].id == a3->id);
  CHECK(again[0].module == "m2");
  CHECK(q.untaken(4.5).empty());
  q.report({"m2", a3->id, kRunning}, 4.6);
  CHECK(q.untaken(9.0).empty());
  // A task taken from a module that dropped its object is never reclaimed by it.
  TaskQueue f(task_names(2), Balance::Wear);
  f.report({"m1", 0, kIdle}, 0.0);
  const auto b = f.assign_next(no_wear);
  REQUIRE(b);
  f.report({"m1", b->id, kFailed}, 0.5);
  CHECK_FALSE(has(f.report({"m1", b->id, kRunning}, 0.6), EventKind::Reclaimed));
  CHECK(f.pending() == std::vector<std::string>{"t0", "t1"});
}

TEST_CASE("a module that drops its object fails: its task goes back to the front and is never counted done there", "[coordinator]") {
  TaskQueue q(task_names(3), Balance::Wear);
  q.report({"m1", 0, kIdle}, 0.0);
  q.report({"m2", 0, kIdle}, 0.0);
  const auto a1 = q.assign_next(no_wear);  // t0 -> m1
  const auto a2 = q.assign_next(no_wear);  // t1 -> m2
  REQUIRE(a1);
  REQUIRE(a2);
  q.report({"m1", a1->id, kRunning}, 0.5);
  const auto events = q.report({"m1", a1->id, kFailed}, 1.0);
  REQUIRE(events.size() == 1);
  CHECK(events[0].kind == EventKind::Failed);
  CHECK(events[0].task == "t0");
  CHECK(q.describe(events[0]).find("failed (its object was dropped)") != std::string::npos);
  CHECK(q.pending() == std::vector<std::string>{"t0", "t2"});
  CHECK(q.report({"m1", a1->id, kFailed}, 1.1).empty());  // said once
  // A failed module takes nothing; the others do.
  q.report({"m2", a2->id, kDone}, 2.0);
  const auto next = q.assign_next(no_wear);
  REQUIRE(next);
  CHECK(next->module == "m2");
  CHECK(q.task_name(next->task) == "t0");
  CHECK_FALSE(q.assign_next(no_wear));  // t2 waits: m1 is failed, m2 busy
  // A "done" of the dropped task from the failed module is not counted.
  q.report({"m1", a1->id, kDone}, 3.0);
  CHECK(q.done_count() == 1);  // t1 only
  // Cleared (reports idle again): it takes tasks again.
  q.report({"m1", a1->id, kIdle}, 4.0);
  const auto back = q.assign_next(no_wear);
  REQUIRE(back);
  CHECK(back->module == "m1");
  CHECK(q.task_name(back->task) == "t2");
}

TEST_CASE("the queue's state is a compact done-set: 10^5 tasks done stay under 110 kB on the wire", "[coordinator]") {
  const size_t n = 100000;
  TaskQueue q(task_names(static_cast<int>(n)), Balance::RoundRobin);
  for (const char* m : {"m1", "m2", "m3", "m4"}) q.report({m, 0, kIdle}, 0.0);
  std::map<std::string, uint64_t> last;
  double t = 0.0;
  for (size_t done = 0; done < n;) {
    while (const auto a = q.assign_next(no_wear)) last[a->module] = a->id;
    for (auto& [m, id] : last) {
      if (id == 0) continue;
      q.report({m, id, kDone}, t);
      id = 0;
      ++done;
    }
    t += 0.001;
  }
  check_done_once(q);
  const Snapshot s = q.snapshot();
  // One byte per task and the four names: the names of the tasks done, in order, would be about 1.1 MB.
  CHECK(s.payload_bytes() < 110000);
  size_t names = 0;
  for (size_t i = 0; i < n; ++i) names += q.task_name(i).size() + 4 + 2 + 4;
  INFO("done-set " << s.payload_bytes() << " bytes; as lists of names " << names << " bytes");
  CHECK(names > 10 * s.payload_bytes());
  // A standby restores it exactly.
  TaskQueue standby(task_names(static_cast<int>(n)), Balance::RoundRobin);
  standby.restore(s, t);
  CHECK(standby.done_count() == n);
  CHECK(standby.duplicates() == 0);
  CHECK(standby.done_by_module().at("m3").size() == n / 4);
  // A malformed state (a module index past the list) is refused.
  Snapshot bad = s;
  bad.done_by[7] = 9;
  CHECK_FALSE(bad.well_formed());
}

namespace {
using tandem::coordinator::Leadership;
using Step = tandem::coordinator::Leadership::Step;

Snapshot state_with(uint64_t next_id, std::vector<uint8_t> done_by, uint64_t total) {
  Snapshot s;
  s.next_task_id = next_id;
  s.modules = {"m1"};
  s.done_by = std::move(done_by);
  s.done_total = total;
  return s;
}
}  // namespace

TEST_CASE("leadership: a standby takes over 0.5 s after the primary's last state, from the most advanced one", "[coordinator]") {
  Leadership l({"coordinator@1", true, false}, 0.0);
  CHECK_FALSE(l.primary());
  CHECK(l.on_state(state_with(5, {1, 1, 0, 0}, 2), 1.0));
  CHECK_FALSE(l.on_state(state_with(4, {1, 0, 0, 0}, 1), 1.1));  // an older copy (the launcher's republished one)
  CHECK(l.last_state()->next_task_id == 5);
  std::string log;
  CHECK(l.step(1.4, 4, &log) == Step::Wait);
  CHECK(l.step(1.51, 4, &log) == Step::TakeOver);
  CHECK(l.primary());
  CHECK(log.find("taking over") != std::string::npos);
  CHECK(l.step(1.52, 4, &log) == Step::Lead);
  // A malformed state is counted and changes nothing.
  Leadership m({"coordinator@1", true, false}, 0.0);
  Snapshot bad = state_with(5, {3, 0}, 1);  // names a module past its list
  CHECK_FALSE(m.on_state(bad, 0.1));
  CHECK(m.malformed_states() == 1);
  CHECK_FALSE(m.last_state().has_value());
}

TEST_CASE("leadership: a late joiner with no state waits 3 s, a restarted one (--resume) never starts a fresh queue", "[coordinator]") {
  Leadership fresh({"coordinator@1", true, false}, 10.0);
  CHECK(fresh.step(12.9, 4, nullptr) == Step::Wait);
  CHECK(fresh.step(13.01, 4, nullptr) == Step::TakeOver);
  CHECK_FALSE(fresh.last_state().has_value());  // from the whole queue
  Leadership resumed({"coordinator@r1", true, true}, 10.0);
  CHECK(resumed.step(19.9, 4, nullptr) == Step::Wait);  // no state heard: it never leads without one
  CHECK_FALSE(resumed.primary());
  CHECK(resumed.on_state(state_with(9, {1, 1, 1, 0}, 3), 19.95));  // the launcher's copy arrives late
  CHECK(resumed.step(20.4, 4, nullptr) == Step::Wait);
  CHECK(resumed.step(20.46, 4, nullptr) == Step::TakeOver);
  CHECK(resumed.last_state()->done_count() == 3);
  // One that hears no state at all within kDeafS cannot hear the queue: it exits (restarted with a fresh participant).
  Leadership deaf({"coordinator@r2", true, true}, 10.0);
  CHECK(deaf.step(10.0 + Leadership::kDeafS - 0.01, 4, nullptr) == Step::Wait);
  std::string log;
  CHECK(deaf.step(10.0 + Leadership::kDeafS + 0.01, 4, &log) == Step::Deaf);
  CHECK(log.find("cannot hear the queue") != std::string::npos);
  CHECK_FALSE(deaf.primary());
}

TEST_CASE("leadership: a restarted standby does not take over in its first 3 s, when a live primary may not be discovered yet",
          "[coordinator]") {
  Leadership r({"coordinator@r10", true, true}, 100.0);
  CHECK(r.on_state(state_with(9, {1, 1, 1, 0}, 3), 100.05));  // the launcher's copy, at once
  std::string log;
  CHECK(r.step(101.0, 4, &log) == Step::Wait);   // silent 0.95 s: past kTakeoverS, but this one is 1 s old
  CHECK(r.step(102.9, 4, &log) == Step::Wait);
  CHECK_FALSE(r.primary());
  CHECK(r.on_state(state_with(10, {1, 1, 1, 1}, 4), 102.95) == true);  // the live primary, heard at last
  CHECK(r.step(103.2, 5, &log) == Step::Wait);   // and not silent
  CHECK(r.step(103.5, 5, &log) == Step::TakeOver);  // silent 0.55 s, 3.5 s old: the rule of every standby
  CHECK(r.last_state()->next_task_id == 10);
}

TEST_CASE("leadership: a standby that stood still counts the primary's silence from its return", "[coordinator]") {
  Leadership l({"coordinator@1", true, false}, 0.0);
  for (int i = 1; i <= 50; ++i) CHECK(l.on_loop(0.02 * i).empty());  // a loop pass every 20 ms, to 1.0 s
  CHECK(l.on_state(state_with(5, {1, 1, 0, 0}, 2), 1.0));
  const std::string line = l.on_loop(1.6);  // its own loop stood still 0.6 s (the primary's state came at 1.0)
  CHECK(line.find("stood still for 600 ms") != std::string::npos);
  std::string log;
  CHECK(l.step(1.6, 4, &log) == Step::Wait);  // before the fix: silent 0.6 s, a takeover on its own deafness
  CHECK(l.on_loop(1.62).empty());
  CHECK(l.step(2.05, 4, &log) == Step::Wait);
  CHECK(l.step(2.11, 4, &log) == Step::TakeOver);  // 0.51 s of silence heard awake
  // A primary's state heard after the stall keeps it a standby.
  Leadership m({"coordinator@1", true, false}, 0.0);
  CHECK(m.on_state(state_with(5, {1, 1, 0, 0}, 2), 1.0));
  (void)m.on_loop(1.6);
  CHECK(m.on_state(state_with(6, {1, 1, 1, 0}, 3), 1.7));
  CHECK(m.step(2.1, 4, &log) == Step::Wait);
  CHECK_FALSE(m.primary());
}

TEST_CASE("leadership: a standby held back by one before it in line that cannot lead takes over 2 s later", "[coordinator]") {
  // Found by a soak-small hour: coordinator@r21, a restart that never heard a queue state, stood first in line; r22
  // had the launcher's copy of the state but waited for r21 for 900 s, and no task was done.
  Leadership r21({"coordinator@r21", true, true}, 0.0), r22({"coordinator@r22", true, true}, 0.0);
  r22.on_state(state_with(5, {1, 1, 0, 0}, 2), 1.0);  // the primary's last state
  std::string log;
  for (double t = 1.0; t < 4.0; t += 0.1) {
    r21.on_peer("coordinator@r22", true, false, t);
    r22.on_peer("coordinator@r21", true, false, t);
    CHECK(r21.step(t, 4, nullptr) == Step::Wait);  // no state: it cannot lead
    const Step s = r22.step(t, 4, &log);
    if (t < 1.0 + Leadership::kTakeoverS + Leadership::kPassOverS - 0.01) {
      CHECK(s == Step::Wait);
    } else {
      CHECK(s == Step::TakeOver);
      break;
    }
  }
  CHECK(r22.primary());
  CHECK(log.find("the standby before this one in line did not") != std::string::npos);
  // With a first in line that can lead, the second one never gets to pass it over: the first takes over at 0.5 s and
  // its states make the primary heard again.
  Leadership a({"coordinator@1", true, false}, 0.0), b({"coordinator@2", true, false}, 0.0);
  a.on_state(state_with(3, {1, 0}, 1), 1.0);
  b.on_state(state_with(3, {1, 0}, 1), 1.0);
  a.on_peer("coordinator@2", true, false, 1.5);
  b.on_peer("coordinator@1", true, false, 1.5);
  CHECK(a.step(1.6, 2, nullptr) == Step::TakeOver);
  for (double t = 1.6; t < 6.0; t += 0.1) {
    b.on_state(state_with(4, {1, 0}, 1), t);  // the new primary publishes
    b.on_peer("coordinator@1", true, true, t);
    CHECK(b.step(t, 2, nullptr) == Step::Wait);
  }
}

TEST_CASE("leadership: only the first live standby by id takes over, and a standby exits when every task is done", "[coordinator]") {
  Leadership a({"coordinator@1", true, false}, 0.0), b({"coordinator@2", true, false}, 0.0);
  const Snapshot s = state_with(3, {1, 0}, 1);
  a.on_state(s, 1.0);
  b.on_state(s, 1.0);
  a.on_peer("coordinator@2", true, false, 1.5);
  b.on_peer("coordinator@1", true, false, 1.5);
  CHECK(b.step(1.6, 2, nullptr) == Step::Wait);      // @1 is before it and alive
  CHECK(a.step(1.6, 2, nullptr) == Step::TakeOver);
  CHECK(b.step(2.3, 2, nullptr) == Step::TakeOver);  // @1 not heard for 0.8 s: it is next
  Leadership c({"coordinator@3", true, false}, 0.0);
  c.on_state(state_with(4, {1, 1}, 2), 0.5);
  std::string log;
  CHECK(c.step(0.6, 2, &log) == Step::AllDone);
  CHECK(log.find("every task done") != std::string::npos);
}

TEST_CASE("leadership: a primary back from a stall doubts, leaves if another one leads, else carries on", "[coordinator]") {
  for (const bool replaced : {true, false}) {
    INFO("another coordinator took over: " << replaced);
    Leadership p({"coordinator", false, false}, 0.0);
    CHECK(p.on_loop(0.1).empty());
    CHECK(p.step(0.1, 4, nullptr) == Step::Lead);
    const std::string line = p.on_loop(0.9);  // the loop stood still 0.8 s (SIGSTOP)
    CHECK(line.find("stalled for 800 ms") != std::string::npos);
    CHECK(p.doubting());
    CHECK(p.step(0.95, 4, nullptr) == Step::Wait);  // decides nothing while it listens
    if (replaced) {
      CHECK(p.on_peer("coordinator@1", true, true, 1.0));  // a successor says primary: leave
    } else {
      CHECK_FALSE(p.on_peer("coordinator@1", true, false, 1.0));  // a standby: no reason to leave
      std::string log;
      CHECK(p.step(1.21, 4, &log) == Step::Lead);
      CHECK(log.find("carrying on as the primary") != std::string::npos);
      CHECK_FALSE(p.doubting());
    }
  }
}

TEST_CASE("leadership: a primary that hears its successor only after the doubt still leaves, two primaries keep the smaller id", "[coordinator]") {
  Leadership p({"coordinator", false, false}, 0.0);
  p.on_loop(0.1);
  CHECK(p.on_loop(2.1).find("stalled") != std::string::npos);  // a 2 s SIGSTOP
  CHECK(p.step(2.5, 4, nullptr) == Step::Lead);                 // nobody heard within the doubt: leads on
  CHECK(p.on_peer("coordinator@r9", true, true, 2.6));          // the successor's status arrives late: leave
  // Two primaries, neither stalled (a partition healed): the larger id leaves, the smaller stays.
  Leadership a({"coordinator@1", false, false}, 0.0), b({"coordinator@2", false, false}, 0.0);
  a.on_loop(0.05);
  b.on_loop(0.05);
  CHECK_FALSE(a.on_peer("coordinator@2", true, true, 20.0));
  CHECK(b.on_peer("coordinator@1", true, true, 20.0));
  // A standby's status is no claim: it never makes a primary leave.
  CHECK_FALSE(a.on_peer("coordinator@0", true, false, 30.0));
}

TEST_CASE("leadership: of two primaries the one whose queue is further on stays, whatever the ids", "[coordinator]") {
  // The lockstep soak hour: r11 stalled 1.7 s; r12 took over and assigned id 667; r11 came back (queue at 667) and
  // published `primary`. r12 heard it first and must stay (its queue is at 668); r11 hears r12 and leaves.
  Leadership r11({"coordinator@r11", false, false}, 0.0), r12({"coordinator@r12", true, false}, 0.0);
  r12.on_loop(0.01);
  Snapshot s;
  s.next_task_id = 667;
  REQUIRE(r12.on_state(s, 0.01));
  for (double t = 0.02; t < 0.6; t += 0.02) {
    r12.on_loop(t);
    (void)r12.step(t, 100, nullptr);
  }
  REQUIRE(r12.primary());
  CHECK_FALSE(r12.on_peer("coordinator@r11", true, true, 1.0, 667, 668));  // behind: r12 stays despite its larger id
  r11.on_loop(0.01);
  CHECK(r11.on_loop(1.7).find("stalled") != std::string::npos);
  CHECK(r11.step(2.1, 100, nullptr) == Step::Lead);  // nobody heard within its doubt
  CHECK(r11.on_peer("coordinator@r12", true, true, 2.2, 668, 667));  // ... then r12 (further on): leave
  // Neither stalled: the one further on stays even with the larger id; as far on, the smaller id stays.
  Leadership a({"coordinator@1", false, false}, 0.0), b({"coordinator@2", false, false}, 0.0);
  a.on_loop(0.05);
  b.on_loop(0.05);
  CHECK(a.on_peer("coordinator@2", true, true, 20.0, 90, 80));
  CHECK_FALSE(b.on_peer("coordinator@1", true, true, 20.0, 80, 90));
  CHECK_FALSE(a.on_peer("coordinator@2", true, true, 21.0, 80, 80));
  CHECK(b.on_peer("coordinator@1", true, true, 21.0, 80, 80));
  // A successor that assigned nothing since it took over (its queue as far on as the stalled one's): the stalled one
  // says 0 while it doubts or remembers its stall, so the successor (larger id) stays, and the stalled one leaves.
  Leadership old_primary({"coordinator", false, false}, 0.0), successor({"coordinator@standby1", false, false}, 0.0);
  old_primary.on_loop(0.01);
  CHECK(old_primary.on_loop(1.8).find("stalled") != std::string::npos);
  for (double t = 0.02; t <= 1.8; t += 0.02) successor.on_loop(t);  // it never stalled
  CHECK_FALSE(successor.on_peer("coordinator", true, true, 1.9, 0, 500));   // what the stalled one says: 0
  CHECK(old_primary.on_peer("coordinator@standby1", true, true, 1.9, 500, 500));
  CHECK(successor.on_peer("coordinator", true, true, 1.9, 500, 500));       // (with its queue's id it would tie and leave)
}

TEST_CASE("leadership: a primary back from a stall keeps the most advanced queue state it hears for 10 s", "[coordinator]") {
  Leadership p({"coordinator", false, false}, 0.0);
  CHECK_FALSE(p.recently_stalled(0.1));
  p.on_loop(0.1);
  p.on_loop(2.1);  // stalled 2 s
  CHECK(p.recently_stalled(2.2));
  CHECK(p.on_state(state_with(9, {1, 1, 1, 0}, 3), 2.3));  // its successor's state, published before it died
  CHECK(p.last_state()->next_task_id == 9);
  CHECK_FALSE(p.on_state(state_with(7, {1, 1, 0, 0}, 2), 2.4));  // its own older one is not kept
  CHECK_FALSE(p.recently_stalled(12.5));
}

// The coordinator process's loop rules as a component (CoordinatorCore): its process only carries the actions out.
namespace {
using tandem::coordinator::CoordinatorAction;
using tandem::coordinator::CoordinatorCore;
using tandem::coordinator::CoordinatorOptions;

CoordinatorOptions core_options(const std::string& id, bool standby, bool resume = false) {
  CoordinatorOptions o;
  o.lead = {id, standby, resume};
  o.timeout = 30.0;
  return o;
}

// The primary's actions as the wire would carry them to a standby (the state) and to the modules (assignments).
struct Wire {
  std::vector<Snapshot> states;
  std::vector<Assignment> sent;
  std::vector<std::string> withdrawn;  ///< modules whose assignment instance was disposed of
  std::vector<CoordinatorAction::Kind> order;
  void take(CoordinatorCore& c) {
    for (const auto& a : c.take_actions()) {
      order.push_back(a.kind);
      if (a.kind == CoordinatorAction::Kind::PublishState) states.push_back(a.state);
      else if (a.kind == CoordinatorAction::Kind::Withdraw) withdrawn.push_back(a.assignment.module);
      else sent.push_back(a.assignment);
    }
  }
};
}  // namespace

TEST_CASE("coordinator: a module that leaves or fails has its last assignment withdrawn, so that its next start does "
          "not run it again", "[coordinator]") {
  // Soak run 53: m1, plugged back right after its drain, was handed the kept assignment of the task it had just
  // finished, ran it again from its initial grasp, and took no new task for 50 s.
  CoordinatorCore c(core_options("coordinator", false), task_names(6), 0.0);
  CoordinatorCore standby(core_options("coordinator@r1", true), task_names(6), 0.0);
  Wire w, ws;
  c.on_loop(0.0);
  c.on_task_state({"m1", 0, kIdle}, 0.0);
  c.on_task_state({"m2", 0, kIdle}, 0.0);
  standby.on_task_state({"m1", 0, kIdle}, 0.0);
  c.update(0.0);
  w.take(c);
  REQUIRE(w.sent.size() == 2);
  const uint64_t id1 = w.sent[0].module == "m1" ? w.sent[0].id : w.sent[1].id;
  const uint64_t id2 = w.sent[0].module == "m2" ? w.sent[0].id : w.sent[1].id;
  c.on_task_state({"m1", id1, kRunning}, 0.5);
  c.on_task_state({"m2", id2, kRunning}, 0.5);
  c.update(0.5);
  w.take(c);
  CHECK(w.withdrawn.empty());
  // m1 finishes and leaves (drained): its assignment is withdrawn, m2's is not.
  c.on_task_state({"m1", id1, kLeft}, 1.0);
  standby.on_task_state({"m1", id1, kLeft}, 1.0);
  c.update(1.0);
  w.take(c);
  ws.take(standby);
  CHECK(w.withdrawn == std::vector<std::string>{"m1"});
  CHECK(ws.withdrawn.empty());  // a standby wrote no assignment
  // m2 drops its object: failed, its task back to the queue and its assignment withdrawn.
  c.on_task_state({"m2", id2, kFailed}, 1.5);
  c.update(1.5);
  w.take(c);
  CHECK(w.withdrawn == std::vector<std::string>{"m1", "m2"});
  // Reports that change nothing withdraw nothing more.
  c.on_task_state({"m2", id2, kFailed}, 1.6);
  c.update(1.6);
  w.take(c);
  CHECK(w.withdrawn.size() == 2);
}

TEST_CASE("coordinator: every assignment goes out after a state that holds it, all done ends with exit 0", "[coordinator]") {
  CoordinatorCore c(core_options("coordinator", false), task_names(3), 0.0);
  Wire w;
  double t = 0.0;
  for (int pass = 0; pass < 200 && !c.end(); ++pass, t += 0.02) {
    c.on_loop(t);
    for (const char* m : {"m1", "m2"}) {
      // Each module takes what was sent to it and reports it done at once.
      uint64_t id = 0;
      for (const auto& a : w.sent) {
        if (a.module == m) id = a.id;
      }
      c.on_task_state({m, id, id == 0 ? kIdle : kDone}, t);
    }
    c.update(t);
    const size_t before = w.sent.size();
    w.take(c);
    for (size_t i = before; i < w.sent.size(); ++i) {
      // The last state published before this assignment has it in flight (a standby that takes over knows of it).
      REQUIRE_FALSE(w.states.empty());
      const Snapshot& s = w.states.back();
      bool held = false;
      for (size_t k = 0; k < s.running_id.size(); ++k) held = held || s.running_id[k] == w.sent[i].id;
      CHECK(held);
    }
  }
  REQUIRE(c.end().has_value());
  CHECK(c.end()->code == 0);
  CHECK(c.end()->status == "3/3 tasks done, 0 duplicates");
  CHECK(w.sent.size() == 3);
  CHECK_FALSE(c.summary_lines().empty());
  CHECK(w.states.back().done_count() == 3);  // the last state says every task done: standbys exit with it
}

TEST_CASE("coordinator: a standby takes over from the primary's state, sends again what no module took, and leads", "[coordinator]") {
  CoordinatorCore primary(core_options("coordinator", false), task_names(4), 0.0);
  CoordinatorCore standby(core_options("coordinator@r1", true), task_names(4), 0.0);
  Wire w;
  primary.on_task_state({"m1", 0, kIdle}, 0.0);
  standby.on_task_state({"m1", 0, kIdle}, 0.0);
  primary.update(0.0);
  w.take(primary);
  REQUIRE(w.sent.size() == 1);
  for (const auto& s : w.states) standby.on_state(s, 0.0);
  // The primary dies; m1 never took its task (it still reports idle with id 0).
  double t = 0.0;
  for (; t < 1.0 && !standby.primary(); t += 0.02) {
    standby.on_loop(t);
    standby.on_task_state({"m1", 0, kIdle}, t);
    standby.update(t);
  }
  CHECK(standby.primary());
  CHECK(t > tandem::coordinator::Leadership::kTakeoverS);
  Wire after;
  after.take(standby);
  REQUIRE(after.order.size() >= 2);
  CHECK(after.order[0] == CoordinatorAction::Kind::PublishState);  // what is in flight, before any assignment
  REQUIRE_FALSE(after.sent.empty());
  CHECK(after.sent[0].id == w.sent[0].id);  // the same id again: a supervisor that has it ignores it
  CHECK(after.sent[0].module == "m1");
  CHECK(standby.detail().find("0/4 tasks done, 1 running") != std::string::npos);
}

TEST_CASE("coordinator: a primary back from a stall adopts its successor's more advanced state, or leaves if it leads", "[coordinator]") {
  CoordinatorCore old(core_options("coordinator", false), task_names(6), 0.0);
  old.on_task_state({"m1", 0, kIdle}, 0.0);
  old.update(0.0);
  Wire w;
  w.take(old);
  REQUIRE(w.sent.size() == 1);
  // A successor that led during the stall (and died) assigned ids 2 and 3: its state is more advanced.
  Snapshot succ = w.states.back();
  succ.next_task_id = 4;
  old.on_loop(2.0);  // stood still for 2 s
  REQUIRE(old.wants_states(2.0));
  old.on_state(succ, 2.0);
  old.on_task_state({"m1", 1, kRunning}, 2.0);
  old.update(2.0);
  CHECK(old.queue().snapshot().next_task_id >= 4);
  CHECK_FALSE(old.end().has_value());
  // A successor that still leads: the stalled one leaves (kReplaced, 3), so that one leads.
  CoordinatorCore stalled(core_options("coordinator", false), task_names(6), 0.0);
  stalled.on_loop(3.0);
  stalled.on_peer("coordinator@r1", true, true, 3.0);
  REQUIRE(stalled.end().has_value());
  CHECK(stalled.end()->code == 3);
  CHECK(stalled.end()->error);
}

TEST_CASE("coordinator: a restarted standby that hears no state exits 6, a primary with no task finished gives up with 4", "[coordinator]") {
  CoordinatorCore late(core_options("coordinator@r2", true, true), task_names(2), 0.0);
  double t = 0.0;
  for (; t < 20.0 && !late.end(); t += 0.1) {
    late.on_loop(t);
    late.update(t);
  }
  REQUIRE(late.end().has_value());
  CHECK(late.end()->code == 6);
  CHECK_FALSE(late.primary());  // never led a fresh queue
  CHECK(late.take_actions().empty());
  CoordinatorOptions o = core_options("coordinator", false);
  o.timeout = 5.0;
  CoordinatorCore stuck(o, task_names(2), 0.0);
  for (t = 0.0; t < 10.0 && !stuck.end(); t += 0.1) {
    stuck.on_loop(t);
    stuck.on_task_state({"m1", stuck.queue().snapshot().next_task_id - 1, kRunning}, t);  // runs, never ends
    stuck.update(t);
  }
  REQUIRE(stuck.end().has_value());
  CHECK(stuck.end()->code == 4);
  CHECK(t > 5.0);
  CHECK(stuck.end()->message.find("no task finished for 5 s") != std::string::npos);
}

TEST_CASE("coordinator: a primary back from a stall adopts its successor's state though a module reported the successor's id first", "[coordinator]") {
  // The soak-small hour's case: r12 stalled 1.7 s, r13 took over and gave soak-451 to m1 as id 454; back, r12 heard m1
  // report id 454 before r13's state, its queue's next id rose to 455 with it, so r13's state (next id 455) did not
  // look more advanced, and r12 gave soak-451 to m2 as id 455: one task on two modules.
  CoordinatorCore old(core_options("coordinator@r12", false), task_names(6), 0.0);
  CoordinatorCore succ(core_options("coordinator@r13", true), task_names(6), 0.0);
  Wire w, ws;
  for (const char* m : {"m1", "m2"}) {
    old.on_task_state({m, 0, kIdle}, 0.0);
    succ.on_task_state({m, 0, kIdle}, 0.0);
  }
  old.update(0.0);
  w.take(old);
  REQUIRE(w.sent.size() == 2);  // ids 1 (m1) and 2 (m2)
  for (const auto& s : w.states) succ.on_state(s, 0.0);
  // m1 finishes id 1; the old primary stands still; the successor takes over and gives the next task to m1.
  double t = 0.02;
  for (; t < 1.0 && !succ.primary(); t += 0.02) {
    succ.on_loop(t);
    succ.on_task_state({"m1", 1, kDone}, t);
    succ.on_task_state({"m2", 2, kRunning}, t);
    succ.update(t);
  }
  REQUIRE(succ.primary());
  ws.take(succ);
  REQUIRE_FALSE(ws.sent.empty());
  const Assignment given = ws.sent.back();
  CHECK(given.module == "m1");
  CHECK(given.id == 3);
  // The old primary is back: m1's report of id 3 comes first, then the successor's state.
  old.on_loop(t + 1.2);
  old.on_task_state({"m1", given.id, kRunning}, t + 1.2);
  old.on_task_state({"m2", 2, kDone}, t + 1.2);
  REQUIRE(old.queue().snapshot().next_task_id == 4);  // raised by the report
  old.on_state(ws.states.back(), t + 1.2);
  old.update(t + 1.2);
  // It adopted the successor's state: the task on m1 is known, and nothing gives that task to another module.
  Wire after;
  for (double u = t + 1.2; u < t + 3.0; u += 0.02) {
    old.on_loop(u);
    old.on_task_state({"m1", given.id, kRunning}, u);
    old.update(u);
    after.take(old);
  }
  for (const auto& a : after.sent) CHECK(a.task != given.task);
  bool holds = false;
  const Snapshot s = old.queue().snapshot();
  for (size_t k = 0; k < s.running_id.size(); ++k) holds = holds || (s.running_id[k] == given.id && s.running_on[k] == "m1");
  CHECK(holds);
}

TEST_CASE("coordinator: a primary that hears no module for 10 s while another coordinator lives leaves for it (exit 6)", "[coordinator]") {
  for (const bool peer : {true, false}) {
    CoordinatorOptions o = core_options("coordinator@r21", false);
    o.timeout = 100.0;
    CoordinatorCore c(o, task_names(20), 0.0);
    double t = 0.0, left_at = -1.0;
    for (; t < 40.0; t += 0.1) {
      c.on_loop(t);
      if (peer) c.on_peer("coordinator@r22", true, false, t);  // a live standby
      if (t < 5.0) {  // the modules run their tasks, then the primary hears them no more (deaf)
        for (const char* m : {"m1", "m2"}) c.on_task_state({m, c.queue().snapshot().next_task_id - 1, kRunning}, t);
      }
      c.update(t);
      (void)c.take_actions();
      if (c.end() && left_at < 0.0) {
        left_at = t;
        break;
      }
    }
    INFO("peer " << peer);
    if (peer) {
      REQUIRE(c.end().has_value());
      CHECK(c.end()->code == 6);
      CHECK(left_at == Approx(5.0 + CoordinatorCore::kDeafPrimaryS).margin(0.25));
      CHECK(c.end()->message.find("cannot hear the modules") != std::string::npos);
    } else {
      CHECK_FALSE(c.end().has_value());  // alone it stays: no other coordinator would hear them better
    }
  }
  // At start-up, before any module was heard, the silence is the modules' start: no leaving.
  CoordinatorCore fresh(core_options("coordinator", false), task_names(5), 0.0);
  for (double t = 0.0; t < 20.0; t += 0.1) {
    fresh.on_loop(t);
    fresh.on_peer("coordinator@r1", true, false, t);
    fresh.update(t);
    (void)fresh.take_actions();
  }
  CHECK_FALSE(fresh.end().has_value());
}
