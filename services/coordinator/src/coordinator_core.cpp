#include "tandem/coordinator/coordinator_core.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "tandem/launcher/exit_codes.hpp"

namespace tandem::coordinator {

namespace {
std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}
}  // namespace

CoordinatorCore::CoordinatorCore(const CoordinatorOptions& o, std::vector<std::string> task_names, double now)
    : o_(o), queue_(std::move(task_names), o.balance), lead_(o.lead, now), last_progress_(now) {}

void CoordinatorCore::on_loop(double now) {
  if (const std::string line = lead_.on_loop(now); !line.empty()) {
    log(line);
    queue_.forgive_silence(now);  // its own stall, not the modules'
  }
}

void CoordinatorCore::on_peer(const std::string& id, bool active, bool claims_primary, double now, uint64_t peer_next) {
  if (end_ || !lead_.on_peer(id, active, claims_primary, now, peer_next, own_next_)) return;
  const std::string why = lead_.doubting() || lead_.recently_stalled(now)
                              ? id + " took over while this one was stalled"
                              : id + " leads too, with its queue at task id " + std::to_string(peer_next) + " (this one's at " +
                                    std::to_string(own_next_) + ")";
  end_ = CoordinatorEnd{launcher::exit_code::kReplaced, true, "replaced: left so that one coordinator leads",
                        why + "; leaving so that only one coordinator leads (restarted as a standby by the policy)"};
}

void CoordinatorCore::on_task_state(const ModuleReport& r, double now) {
  last_module_heard_ = now;
  for (const auto& e : queue_.report(r, now)) {
    if (!lead_.primary()) continue;  // a standby only keeps the latest reports
    log(queue_.describe(e));
    // A module that left (drained) or failed (dropped its object) is started afresh when it comes back, and its new
    // supervisor, joining late, would be handed the last assignment kept for it and run that task again from its
    // initial grasp, while this queue counts it done or gave it elsewhere (soak run 53: a module plugged back after
    // its drain ran its last task again and took no new one for 50 s).
    if (e.kind == EventKind::Left || e.kind == EventKind::Failed) {
      CoordinatorAction a;
      a.kind = CoordinatorAction::Kind::Withdraw;
      a.assignment.module = r.module;
      actions_.push_back(a);
    }
  }
}

double CoordinatorCore::module_wear(const std::string& module) const {
  double w = 0.0;
  for (const auto& [id, v] : wear_) {
    if (id.rfind(module + "/", 0) == 0) w += v;
  }
  return w;
}

void CoordinatorCore::publish(double now) {
  actions_.push_back({CoordinatorAction::Kind::PublishState, queue_.snapshot(), {}});
  published_ = queue_.revision();
  last_beat_ = now;
}

void CoordinatorCore::update(double now) {
  if (end_) return;
  // Compared with the ids this one assigned or adopted, not with its queue's next id: a module's report of the
  // successor's assignment raises that too (TaskQueue::report), and hid the successor's state (a soak-small hour: the
  // primary back from a 1.7 s stall heard m1 report the successor's id 454 first, kept its own state, and gave the
  // successor's task to m2 as id 455).
  if (lead_.primary() && lead_.recently_stalled(now) && lead_.last_state() && lead_.last_state()->next_task_id > own_next_) {
    // A successor led while this one was stalled, and died before this one heard it: its queue state is more
    // advanced than ours (it assigned tasks we never saw). Adopt it, as a takeover would, so that no task is lost or
    // done twice and the modules it assigned are not held as busy with our stale tasks (found by the hour-long soak:
    // no task was done for 63 s).
    queue_.restore(*lead_.last_state(), now);
    own_next_ = lead_.last_state()->next_task_id;
    const TaskQueue::Reconciled r = queue_.reconcile(now);
    log("a successor led while this one was stalled: adopting its queue state (" + std::to_string(queue_.done_count()) +
        " done, " + std::to_string(queue_.running_count()) + " running)");
    for (const auto& e : r.events) log(queue_.describe(e));
    publish(now);
    for (const auto& a : r.resend) assign(a);
  }
  if (lead_.primary() && !queue_.complete() && last_module_heard_ >= 0.0 &&
      now - std::max({last_module_heard_, lead_.last_stall(), primary_since_}) > kDeafPrimaryS && lead_.peer_alive(now)) {
    char why[200];
    std::snprintf(why, sizeof why, "heard no module's task state for %.0f s, with tasks left and another coordinator "
                  "alive: this primary cannot hear the modules; leaving for the other one", kDeafPrimaryS);
    end_ = CoordinatorEnd{launcher::exit_code::kCutOff, true, "cannot hear the modules", why};
    return;
  }
  std::string line;
  const Leadership::Step step = lead_.step(now, queue_.task_count(), &line);
  if (!line.empty() && step != Leadership::Step::TakeOver) log(line);
  switch (step) {
    case Leadership::Step::Deaf:
      end_ = CoordinatorEnd{launcher::exit_code::kCutOff, true, "cannot hear the queue state", ""};
      return;
    case Leadership::Step::AllDone:
      end_ = CoordinatorEnd{launcher::exit_code::kDone, false, "every task done (by the primary)", ""};
      return;
    case Leadership::Step::Wait:
      return;
    case Leadership::Step::TakeOver: {
      primary_since_ = now;  // the modules' silence counts from here (CoordinatorCore::kDeafPrimaryS)
      // The primary's queue, checked against what the modules report.
      const double silent = lead_.silent(now);
      if (lead_.last_state()) {
        queue_.restore(*lead_.last_state(), now);
        own_next_ = std::max(own_next_, lead_.last_state()->next_task_id);
      }
      log("primary silent for " + fixed(silent * 1e3, 0) + " ms; taking over with " + std::to_string(queue_.done_count()) +
          " done, " + std::to_string(queue_.running_count()) + " running, " + std::to_string(queue_.pending_count()) +
          " pending");
      const TaskQueue::Reconciled r = queue_.reconcile(now);
      for (const auto& e : r.events) log(queue_.describe(e));
      publish(now);  // what is in flight, before any assignment
      for (const auto& a : r.resend) {
        assign(a);
        log("sending task " + queue_.task_name(a.task) + " to " + a.module + " again (id " + std::to_string(a.id) + ")");
      }
      last_progress_ = now;
      progress_mark_ = queue_.done_count();
      break;
    }
    case Leadership::Step::Lead:
      break;
  }
  for (const auto& e : queue_.expire(now)) log(queue_.describe(e));
  while (const auto a = queue_.assign_next([this](const std::string& m) { return module_wear(m); })) {
    publish(now);  // the state with the task in flight first: a standby that takes over knows of it
    own_next_ = std::max(own_next_, a->id + 1);
    assign(*a);
    log("task " + queue_.task_name(a->task) + " -> " + a->module + " (id " + std::to_string(a->id) + ", wear " +
        fixed(a->wear, 3) + " rad)");
  }
  for (const auto& a : queue_.untaken(now)) {
    assign(a);
    log("sending task " + queue_.task_name(a.task) + " to " + a.module + " again (id " + std::to_string(a.id) +
        "): it reports an older task finished, so it never took this one");
  }
  if (queue_.revision() != published_ || now - last_beat_ >= kHeartbeatS) publish(now);
  if (queue_.done_count() != progress_mark_) {
    progress_mark_ = queue_.done_count();
    last_progress_ = now;
  }
  if (queue_.complete()) {
    publish(now);  // every task done: standbys see it and exit
    const std::string total = std::to_string(queue_.done_count()) + "/" + std::to_string(queue_.task_count()) +
                              " tasks done, " + std::to_string(queue_.duplicates()) + " duplicates";
    end_ = CoordinatorEnd{queue_.duplicates() == 0 ? launcher::exit_code::kDone : launcher::exit_code::kError, false,
                          total, ""};
    return;
  }
  if (now - last_progress_ > o_.timeout) {
    end_ = CoordinatorEnd{launcher::exit_code::kNoInput, true, "no progress",
                          "no task finished for " + fixed(o_.timeout, 0) + " s; giving up"};
  }
}

void CoordinatorCore::on_stop() {
  if (lead_.primary()) actions_.push_back({CoordinatorAction::Kind::PublishState, queue_.snapshot(), {}});
}

std::vector<CoordinatorAction> CoordinatorCore::take_actions() {
  std::vector<CoordinatorAction> out;
  out.swap(actions_);
  return out;
}

std::string CoordinatorCore::detail() const {
  std::string s;
  if (lead_.primary()) {
    s = std::to_string(queue_.done_count()) + "/" + std::to_string(queue_.task_count()) + " tasks done, " +
        std::to_string(queue_.running_count()) + " running, " + std::to_string(queue_.pending_count()) + " pending; " +
        std::to_string(queue_.module_count()) + " module(s), " + std::to_string(queue_.lost_count()) + " lost";
  } else {
    s = lead_.last_state() ? "standby, primary at " + std::to_string(queue_.count_done(*lead_.last_state())) + "/" +
                                 std::to_string(queue_.task_count()) + " tasks done"
                           : "standby, no primary heard yet";
  }
  if (queue_.rejected() > 0) s += "; " + std::to_string(queue_.rejected()) + " invalid task state(s) ignored";
  if (lead_.malformed_states() > 0) {
    s += "; " + std::to_string(lead_.malformed_states()) + " malformed coordinator state(s) ignored";
  }
  return s;
}

std::vector<std::string> CoordinatorCore::summary_lines() const {
  std::vector<std::string> lines;
  for (const auto& [module, tasks] : queue_.done_by_module()) {
    std::string list;
    for (const auto& n : tasks) list += (list.empty() ? "" : ", ") + n;
    lines.push_back(module + " did " + std::to_string(tasks.size()) + " task(s) [" + list + "], joint travel " +
                    fixed(module_wear(module), 3) + " rad");
  }
  return lines;
}

}  // namespace tandem::coordinator
