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

using namespace tandem;
namespace bus = tandem::dds;

namespace {

struct Options {
  std::string file;
  int domain = -1;
  double timeout = 30.0;
  std::string id = "coordinator";
  bool standby = false;
  bool resume = false;  ///< a queue existed before this one started: never take over without its state
};

void usage(std::FILE* f) {
  std::fprintf(
      f,
      "usage: tandem-coordinator --deployment-file FILE --domain ID [--timeout S] [--id NAME] [--standby] [--resume]\n"
      "Started by 'tandem up' for deployments with a coordinator section. --timeout: give up after S\n"
      "seconds with no task finished (default 30); --id: process id in status (default coordinator);\n"
      "--standby: assign nothing until the primary falls silent, then take over its queue.\n"
      "--resume (a restart): take over only with a queue state heard, never with a fresh queue.\n"
      "Exit: 0 every task done or stopped, 1 a task done twice, 2 bad arguments or deployment, 3 left after a\n"
      "stall (another one leads), 4 no progress, 6 a restart (--resume) that heard no queue state in 10 s.\n");
}

/// Parses the command line; on error prints the problem and the usage and returns false with `exit_code`
/// 2 (0 for --help).
bool parse_options(int argc, char** argv, Options& o, int& exit_code) {
  exit_code = launcher::exit_code::kBadArgs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      usage(stdout);
      exit_code = launcher::exit_code::kDone;
      return false;
    }
    if (a == "--standby") {
      o.standby = true;
      continue;
    }
    if (a == "--resume") {
      o.resume = true;
      continue;
    }
    if (a != "--deployment-file" && a != "--domain" && a != "--timeout" && a != "--id") {
      std::fprintf(
          stderr,
          "tandem-coordinator: unknown option '%s'; accepted: --deployment-file, --domain, --timeout, "
          "--id, --standby, --resume, --help\n",
          a.c_str());
      usage(stderr);
      return false;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "tandem-coordinator: '%s' needs a value\n", a.c_str());
      usage(stderr);
      return false;
    }
    const std::string v = argv[++i];
    if (a == "--deployment-file") {
      o.file = v;
    } else if (a == "--domain") {
      if (!runtime::parse_domain(v, o.domain)) {
        std::fprintf(stderr, "tandem-coordinator: --domain must be an integer in [0, 232], got '%s'\n",
                     v.c_str());
        return false;
      }
    } else if (a == "--timeout") {
      char* end = nullptr;
      o.timeout = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !std::isfinite(o.timeout) || o.timeout <= 0.0 || o.timeout > 86400.0) {
        std::fprintf(stderr,
                     "tandem-coordinator: --timeout must be a number of seconds in (0, 86400], got '%s'\n",
                     v.c_str());
        return false;
      }
    } else {
      o.id = v;
      if (o.id.empty()) {
        std::fprintf(stderr, "tandem-coordinator: --id must be a non-empty process id\n");
        return false;
      }
    }
  }
  if (o.file.empty() || o.domain < 0) {
    std::fprintf(stderr, "tandem-coordinator: --deployment-file and --domain are required\n");
    usage(stderr);
    return false;
  }
  return true;
}

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


}  // namespace

int run(int argc, char** argv) {
  Options opt;
  int code = 0;
  if (!parse_options(argc, argv, opt, code)) return code;
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
  // Log lines name the process when it is not the default one (a standby or a restarted coordinator).
  const std::string who = opt.id == "coordinator" ? "coordinator" : "coordinator " + opt.id;

  bus::Participant part(opt.domain, opt.id + "/" + d.name, runtime::transport_of(d));
  bus::Reader<msg::TaskState, msg::TaskStatePubSubType> states(part, bus::kTaskStateTopic,
                                                               bus::TopicKind::Task);
  bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType> status_in(part, bus::kStatusTopic,
                                                                          bus::TopicKind::Status);
  // The primary's state, read while this process is a standby.
  bus::Reader<msg::CoordinatorState, msg::CoordinatorStatePubSubType> state_in(
      part, bus::kCoordinatorStateTopic, bus::TopicKind::Task);
  bus::Writer<msg::CoordinatorState, msg::CoordinatorStatePubSubType> state_out(
      part, bus::kCoordinatorStateTopic, bus::TopicKind::Task);
  bus::Writer<msg::TaskAssignment, msg::TaskAssignmentPubSubType> assign(part, bus::kTaskAssignmentTopic,
                                                                         bus::TopicKind::Task);
  runtime::StatusPublisher status(part, opt.id, "coordinator", "");
  status.msg().deployment(d.name);
  status.msg().serving(opt.standby ? msg::ROLE_STANDBY : msg::ROLE_PRIMARY);
  status.set(runtime::Lifecycle::Active, "task queue of " + std::to_string(d.tasks.size()));

  std::vector<std::string> names;
  for (const auto& t : d.tasks) names.push_back(t.name);
  const auto t0 = std::chrono::steady_clock::now();
  auto now = [t0] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  coordinator::CoordinatorOptions co;
  co.lead = {opt.id, opt.standby, opt.resume};
  co.balance = d.balance == "round_robin" ? coordinator::Balance::RoundRobin : coordinator::Balance::Wear;
  co.timeout = opt.timeout;
  coordinator::CoordinatorCore core(co, names, now());
  core.set_log([&who](const std::string& line) {
    std::printf("%s: %s\n", who.c_str(), line.c_str());
    std::fflush(stdout);  // the launcher interleaves the output of many processes
  });
  auto heartbeat = [&](double t) {
    status.msg().serving(core.primary() ? msg::ROLE_PRIMARY : msg::ROLE_STANDBY);
    status.msg().tick(core.said_next_task_id(t));  // the queue's progress: of two primaries the one further on stays
    status.msg().detail(core.detail());
    status.publish();
    core.heartbeat_sent(t);
  };
  auto carry_out = [&](double t) {
    for (const coordinator::CoordinatorAction& a : core.take_actions()) {
      if (a.kind == coordinator::CoordinatorAction::Kind::PublishState) {
        msg::CoordinatorState m = to_msg(d.name, a.state);
        state_out.write(m);
        heartbeat(t);
      } else {
        msg::TaskAssignment m;
        m.module_id(a.assignment.module);
        m.task_id(a.assignment.id);
        m.task_name(d.tasks[a.assignment.task].name);
        m.waypoints(d.tasks[a.assignment.task].waypoints);
        assign.write(m);
      }
    }
  };

  while (!runtime::g_stop && !core.end()) {
    const double t = now();
    core.on_loop(t);
    msg::ProcessStatus ps;
    while (status_in.take(ps)) {
      if (ps.deployment() != d.name) continue;
      if (ps.role() == "robot") core.on_wear(ps.process_id(), ps.wear());
      if (ps.role() == "coordinator") {
        core.on_peer(ps.process_id(), ps.state() == static_cast<uint8_t>(runtime::Lifecycle::Active),
                     ps.serving() == msg::ROLE_PRIMARY, t, ps.tick());
      }
    }
    msg::TaskState ts;
    while (states.take(ts)) {
      if (ts.deployment() == d.name) core.on_task_state({ts.module_id(), ts.task_id(), ts.state()}, t);
    }
    if (core.wants_states(t)) {
      msg::CoordinatorState cs;
      while (state_in.take(cs)) {
        if (cs.deployment() == d.name) core.on_state(from_msg(cs), t);
      }
    }
    core.update(t);
    carry_out(t);
    if (!core.end() && core.heartbeat_due(t)) heartbeat(t);
    if (!core.end()) states.wait(0.02);
  }
  if (!core.end()) {  // stopped
    core.on_stop();
    carry_out(now());
    status.set(runtime::Lifecycle::Finalized, "stopped");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return launcher::exit_code::kDone;
  }
  const coordinator::CoordinatorEnd& end = *core.end();
  if (!end.message.empty()) std::fprintf(stderr, "tandem-coordinator %s: %s\n", opt.id.c_str(), end.message.c_str());
  if (core.queue().complete() && core.primary()) {
    for (const std::string& line : core.summary_lines()) std::printf("%s: %s\n", who.c_str(), line.c_str());
    std::printf("coordinator: %s\n", end.status.c_str());
    std::fflush(stdout);
  }
  status.set(end.error ? runtime::Lifecycle::Error : runtime::Lifecycle::Finalized, end.status);
  std::this_thread::sleep_for(std::chrono::milliseconds(core.queue().complete() ? 200 : 100));
  return end.code;
}

int main(int argc, char** argv) { return runtime::run_guarded("tandem-coordinator", run, argc, argv); }
