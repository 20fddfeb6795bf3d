// tandem-coordinator: the high-level supervisor over many modules (the paper's future work). It keeps the
// deployment's task queue and hands the next task to a free module, balancing wear: the module whose robots
// have travelled least (sum of joint travel, from their status), ties broken by fewer tasks done. Modules
// come and go: any module of the deployment that reports its task state is used; one not heard for 1.5 s is
// lost and its task goes back to the front of the queue; one that leaves is removed (task_queue.hpp).
//
// The primary publishes the queue's state (CoordinatorState) after every change and every 100 ms, always
// before the assignment it records. A standby (--standby) assigns nothing: it keeps the latest state and the
// modules' latest reports, and when the primary falls silent (0.5 s; 3 s if it never heard one: then from the
// whole queue) it takes over: it rebuilds the queue from that state, checks what is in flight against the
// modules' reports (done, or sent again with the same id, which a supervisor ignores if it has it already)
// and carries on as the primary. With several standbys only the first by id among the live ones takes over.
//
// Exit: 0 every task done (the primary prints what each module did; a standby that sees it exits too) or
// stopped by SIGINT/SIGTERM, 1 a task was counted twice, 2 bad arguments or deployment, 4 no task finished
// for --timeout seconds (a standby counts from its takeover).
#include <tandemPubSubTypes.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "tandem/launcher/exit_codes.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"
#include "tandem/coordinator/leadership.hpp"
#include "tandem/coordinator/coordinator_core.hpp"
#include "tandem/coordinator/options.hpp"

using namespace tandem;
namespace bus = tandem::dds;

namespace {

using coordinator::Options;

msg::CoordinatorState to_msg(const std::string& deployment, const coordinator::Snapshot& s) {
  msg::CoordinatorState m;
  m.deployment(deployment);
  m.next_task_id(s.next_task_id);
  m.modules(s.modules);
  m.done_by(s.done_by);
  m.done_total(s.done_total);
  m.running(s.running);
  m.running_on(s.running_on);
  m.running_id(s.running_id);
  return m;
}

coordinator::Snapshot from_msg(const msg::CoordinatorState& m) {
  coordinator::Snapshot s;
  s.next_task_id = m.next_task_id();
  s.modules = m.modules();
  s.done_by = m.done_by();
  s.done_total = m.done_total();
  s.running = m.running();
  s.running_on = m.running_on();
  s.running_id = m.running_id();
  return s;
}


coordinator::CoordinatorOptions core_options(const Options& opt, const runtime::Deployment& d) {
  coordinator::CoordinatorOptions co;
  co.lead = {opt.id, opt.standby, opt.resume};
  co.balance = d.balance == "round_robin" ? coordinator::Balance::RoundRobin : coordinator::Balance::Wear;
  co.timeout = opt.timeout;
  return co;
}

std::vector<std::string> task_names(const runtime::Deployment& d) {
  std::vector<std::string> names;
  for (const auto& t : d.tasks) names.push_back(t.name);
  return names;
}

/// One coordinator process: its DDS endpoints, its core and the loop's steps.
class CoordinatorProcess {
 public:
  CoordinatorProcess(const Options& opt, const runtime::Deployment& d)
      : opt_(opt), d_(d), who_(opt.id == "coordinator" ? "coordinator" : "coordinator " + opt.id),
        // UDP only, as the launcher (up_run.cpp): a shared-memory listener can be wedged for good by a killed
        // sender's segment (Fast DDS 2.9, eProsima/Fast-DDS#2398, #5732); a primary deaf to the modules' task
        // states while its own status still went out held the whole queue for 40 s (soak finding 56). Its traffic
        // (task states, statuses, the queue's state, assignments) is small.
        part_(opt.domain, opt.id + "/" + d.name, bus::Transport::Udp),
        states_(part_, bus::kTaskStateTopic, bus::TopicKind::Task),
        status_in_(part_, bus::kStatusTopic, bus::TopicKind::Status),
        state_in_(part_, bus::kCoordinatorStateTopic, bus::TopicKind::Task),  // the primary's, read as a standby
        state_out_(part_, bus::kCoordinatorStateTopic, bus::TopicKind::Task),
        assign_(part_, bus::kTaskAssignmentTopic, bus::TopicKind::Task),
        status_(part_, opt.id, "coordinator", ""), t0_(std::chrono::steady_clock::now()),
        core_(core_options(opt, d), task_names(d), now()) {
    status_.msg().deployment(d.name);
    status_.msg().serving(opt.standby ? msg::ROLE_STANDBY : msg::ROLE_PRIMARY);
    status_.set(runtime::Lifecycle::Active, "task queue of " + std::to_string(d.tasks.size()));
    // Log lines name the process when it is not the default one (a standby or a restarted coordinator).
    core_.set_log([this](const std::string& line) {
      std::printf("%s: %s\n", who_.c_str(), line.c_str());
      std::fflush(stdout);  // the launcher interleaves the output of many processes
    });
  }

  int run() {
    while (!runtime::g_stop && !core_.end()) {
      const double t = now();
      core_.on_loop(t);
      take_inputs(t);
      core_.update(t);
      carry_out(t);
      if (!core_.end() && core_.heartbeat_due(t)) heartbeat(t);
      if (!core_.end()) states_.wait(0.02);
      if (t - last_match_log_ >= 60.0) {
        // How many writers each input is matched with, once a minute: counts that stay low while processes come
        // mean this coordinator no longer learns of newcomers (docs/soak.md, finding 74).
        last_match_log_ = t;
        std::printf("%s: matched: status from %d writers, task states from %d, queue states from %d\n", who_.c_str(),
                    status_in_.matched(), states_.matched(), state_in_.matched());
        std::fflush(stdout);
      }
    }
    return finish();
  }

 private:
  double now() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }

  void take_inputs(double t) {
    msg::ProcessStatus ps;
    while (status_in_.take(ps)) {
      if (ps.deployment() != d_.name) continue;
      if (ps.role() == "robot") core_.on_wear(ps.process_id(), ps.wear());
      if (ps.role() == "coordinator") {
        core_.on_peer(ps.process_id(), ps.state() == static_cast<uint8_t>(runtime::Lifecycle::Active),
                      ps.serving() == msg::ROLE_PRIMARY, t, ps.tick());
      }
    }
    msg::TaskState ts;
    while (states_.take(ts)) {
      if (ts.deployment() == d_.name) core_.on_task_state({ts.module_id(), ts.task_id(), ts.state()}, t);
    }
    if (core_.wants_states(t)) {
      msg::CoordinatorState cs;
      while (state_in_.take(cs)) {
        if (cs.deployment() == d_.name) core_.on_state(from_msg(cs), t);
      }
    }
  }

  void heartbeat(double t) {
    status_.msg().serving(core_.primary() ? msg::ROLE_PRIMARY : msg::ROLE_STANDBY);
    status_.msg().tick(core_.said_next_task_id(t));  // the queue's progress: of two primaries the one further on stays
    status_.msg().detail(core_.detail());
    status_.publish();
    core_.heartbeat_sent(t);
  }

  void carry_out(double t) {
    for (const coordinator::CoordinatorAction& a : core_.take_actions()) {
      if (a.kind == coordinator::CoordinatorAction::Kind::PublishState) {
        msg::CoordinatorState m = to_msg(d_.name, a.state);
        state_out_.write(m);
        heartbeat(t);
      } else {
        msg::TaskAssignment m;
        m.module_id(a.assignment.module);
        if (a.kind == coordinator::CoordinatorAction::Kind::Withdraw) {
          (void)assign_.dispose(m);  // a module never assigned to by this writer: nothing to dispose of
        } else {
          m.task_id(a.assignment.id);
          m.task_name(d_.tasks[a.assignment.task].name);
          m.waypoints(d_.tasks[a.assignment.task].waypoints);
          assign_.write(m);
        }
      }
    }
  }

  int finish() {
    if (!core_.end()) {  // stopped
      core_.on_stop();
      carry_out(now());
      status_.set(runtime::Lifecycle::Finalized, "stopped");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return launcher::exit_code::kDone;
    }
    const coordinator::CoordinatorEnd& end = *core_.end();
    if (!end.message.empty()) std::fprintf(stderr, "tandem-coordinator %s: %s\n", opt_.id.c_str(), end.message.c_str());
    if (core_.queue().complete() && core_.primary()) {
      for (const std::string& line : core_.summary_lines()) std::printf("%s: %s\n", who_.c_str(), line.c_str());
      std::printf("coordinator: %s\n", end.status.c_str());
      std::fflush(stdout);
    }
    status_.set(end.error ? runtime::Lifecycle::Error : runtime::Lifecycle::Finalized, end.status);
    std::this_thread::sleep_for(std::chrono::milliseconds(core_.queue().complete() ? 200 : 100));
    return end.code;
  }

  const Options& opt_;
  const runtime::Deployment& d_;
  std::string who_;
  bus::Participant part_;
  double last_match_log_ = 0.0;
  bus::Reader<msg::TaskState, msg::TaskStatePubSubType> states_;
  bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType> status_in_;
  bus::Reader<msg::CoordinatorState, msg::CoordinatorStatePubSubType> state_in_;
  bus::Writer<msg::CoordinatorState, msg::CoordinatorStatePubSubType> state_out_;
  bus::Writer<msg::TaskAssignment, msg::TaskAssignmentPubSubType> assign_;
  runtime::StatusPublisher status_;
  std::chrono::steady_clock::time_point t0_;
  coordinator::CoordinatorCore core_;
};

}  // namespace

int run(int argc, char** argv) {
  Options opt;
  if (const int code = coordinator::parse_options(argc, argv, opt); code >= 0) return code;
  runtime::install_stop_handlers();
  runtime::Deployment d;
  try {
    d = runtime::load_deployment(opt.file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem-coordinator: %s\n", e.what());
    return launcher::exit_code::kBadArgs;
  }
  if (!d.coordinator) {
    std::fprintf(stderr, "tandem-coordinator: %s has no coordinator section (no tasks to hand out)\n",
                 opt.file.c_str());
    return launcher::exit_code::kBadArgs;
  }
  CoordinatorProcess p(opt, d);
  return runtime::bound_teardown("tandem-coordinator", p.run());  // (then its DDS teardown, bounded)
}

int main(int argc, char** argv) { return runtime::run_guarded("tandem-coordinator", run, argc, argv); }
