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
#include "tandem/coordinator/task_queue.hpp"

using namespace tandem;
namespace bus = tandem::dds;
using coordinator::TaskQueue;

namespace {

constexpr double kHeartbeatS = 0.1;   // state and status are published at least this often

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

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
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
  auto say = [&who](const std::string& line) {
    std::printf("%s: %s\n", who.c_str(), line.c_str());
    std::fflush(stdout);  // the launcher interleaves the output of many processes
  };

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
  TaskQueue queue(names,
                  d.balance == "round_robin" ? coordinator::Balance::RoundRobin : coordinator::Balance::Wear);
  std::map<std::string, double> wear;   // robot process id -> joint travel [rad]
  auto module_wear = [&wear](const std::string& module) {  // joint travel of a module's robots
    double w = 0.0;
    for (const auto& [id, v] : wear) {
      if (id.rfind(module + "/", 0) == 0) w += v;
    }
    return w;
  };

  const auto t0 = std::chrono::steady_clock::now();
  auto now = [t0] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  coordinator::Leadership lead({opt.id, opt.standby, opt.resume}, now());
  uint64_t published = 0;   // revision of the queue last published
  double last_beat = -1.0, last_progress = 0.0;
  size_t progress_mark = 0;

  auto detail = [&] {
    std::string s;
    if (lead.primary()) {
      s = std::to_string(queue.done_count()) + "/" + std::to_string(queue.task_count()) + " tasks done, " +
          std::to_string(queue.running_count()) + " running, " + std::to_string(queue.pending_count()) +
          " pending; " + std::to_string(queue.module_count()) + " module(s), " +
          std::to_string(queue.lost_count()) + " lost";
    } else {
      s = lead.last_state() ? "standby, primary at " + std::to_string(queue.count_done(*lead.last_state())) + "/" +
                                  std::to_string(queue.task_count()) + " tasks done"
                            : "standby, no primary heard yet";
    }
    if (queue.rejected() > 0) s += "; " + std::to_string(queue.rejected()) + " invalid task state(s) ignored";
    if (lead.malformed_states() > 0) {
      s += "; " + std::to_string(lead.malformed_states()) + " malformed coordinator state(s) ignored";
    }
    return s;
  };
  auto heartbeat = [&](double t) {
    status.msg().detail(detail());
    status.publish();
    last_beat = t;
  };
  auto publish_state = [&](double t) {
    msg::CoordinatorState m = to_msg(d.name, queue.snapshot());
    state_out.write(m);
    published = queue.revision();
    heartbeat(t);
  };
  auto send = [&](const coordinator::Assignment& a) {
    msg::TaskAssignment m;
    m.module_id(a.module);
    m.task_id(a.id);
    m.task_name(d.tasks[a.task].name);
    m.waypoints(d.tasks[a.task].waypoints);
    assign.write(m);
  };

  while (!runtime::g_stop) {
    const double t = now();
    if (const std::string line = lead.on_loop(t); !line.empty()) {
      say(line);
      queue.forgive_silence(t);  // its own stall, not the modules'
    }
    msg::ProcessStatus ps;
    while (status_in.take(ps)) {
      if (ps.deployment() != d.name) continue;
      if (ps.role() == "robot") wear[ps.process_id()] = ps.wear();
      if (ps.role() == "coordinator" &&
          lead.on_peer(ps.process_id(), ps.state() == static_cast<uint8_t>(runtime::Lifecycle::Active),
                       ps.serving() == msg::ROLE_PRIMARY, t)) {
        std::fprintf(stderr, "tandem-coordinator %s: %s took over while this one was stalled; leaving so that only "
                     "one coordinator leads (restarted as a standby by the policy)\n", opt.id.c_str(),
                     ps.process_id().c_str());
        status.set(runtime::Lifecycle::Error, "stalled and replaced: left so that one coordinator leads");
        return launcher::exit_code::kReplaced;
      }
    }
    msg::TaskState ts;
    while (states.take(ts)) {
      if (ts.deployment() != d.name) continue;
      const auto events = queue.report({ts.module_id(), ts.task_id(), ts.state()}, t);
      for (const auto& e : events) {
        if (lead.primary()) say(queue.describe(e));  // a standby only keeps the latest reports
      }
    }
    if (!lead.primary() || lead.recently_stalled(t)) {
      msg::CoordinatorState cs;
      while (state_in.take(cs)) {
        if (cs.deployment() == d.name) lead.on_state(from_msg(cs), t);
      }
    }
    if (lead.primary() && lead.recently_stalled(t) && lead.last_state() &&
        lead.last_state()->next_task_id > queue.snapshot().next_task_id) {
      // A successor led while this one was stalled, and died before this one heard it: its queue state is more
      // advanced than ours (it assigned tasks we never saw). Adopt it, as a takeover would, so that no task is
      // lost or done twice and the modules it assigned are not held as busy with our stale tasks (found by the
      // hour-long soak: no task was done for 63 s).
      queue.restore(*lead.last_state(), t);
      const TaskQueue::Reconciled r = queue.reconcile(t);
      say("a successor led while this one was stalled: adopting its queue state (" + std::to_string(queue.done_count()) +
          " done, " + std::to_string(queue.running_count()) + " running)");
      for (const auto& e : r.events) say(queue.describe(e));
      publish_state(t);
      for (const auto& a : r.resend) send(a);
    }
    std::string line;
    const coordinator::Leadership::Step step = lead.step(t, queue.task_count(), &line);
    if (!line.empty() && step != coordinator::Leadership::Step::TakeOver) say(line);
    if (step == coordinator::Leadership::Step::Deaf) {
      status.set(runtime::Lifecycle::Error, "cannot hear the queue state");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return launcher::exit_code::kCutOff;
    }
    if (step == coordinator::Leadership::Step::AllDone) {
      status.set(runtime::Lifecycle::Finalized, "every task done (by the primary)");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return launcher::exit_code::kDone;
    }
    if (step == coordinator::Leadership::Step::Wait) {
      if (!lead.primary() && t - last_beat >= kHeartbeatS) heartbeat(t);
      states.wait(0.02);
      continue;
    }
    if (step == coordinator::Leadership::Step::TakeOver) {
      // Take over: the primary's queue, checked against what the modules report.
      const double silent = lead.silent(t);
      if (lead.last_state()) queue.restore(*lead.last_state(), t);
      say("primary silent for " + fixed(silent * 1e3, 0) + " ms; taking over with " +
          std::to_string(queue.done_count()) + " done, " + std::to_string(queue.running_count()) +
          " running, " + std::to_string(queue.pending_count()) + " pending");
      const TaskQueue::Reconciled r = queue.reconcile(t);
      for (const auto& e : r.events) say(queue.describe(e));
      status.msg().serving(msg::ROLE_PRIMARY);
      publish_state(t);  // what is in flight, before any assignment
      for (const auto& a : r.resend) {
        send(a);
        say("sending task " + d.tasks[a.task].name + " to " + a.module + " again (id " +
            std::to_string(a.id) + ")");
      }
      last_progress = t;
      progress_mark = queue.done_count();
    }
    for (const auto& e : queue.expire(t)) say(queue.describe(e));
    while (const auto a = queue.assign_next(module_wear)) {
      publish_state(t);  // the state with the task in flight first: a standby that takes over knows of it
      send(*a);
      say("task " + d.tasks[a->task].name + " -> " + a->module + " (id " + std::to_string(a->id) + ", wear " +
          fixed(a->wear, 3) + " rad)");
    }
    if (queue.revision() != published || t - last_beat >= kHeartbeatS) publish_state(t);
    if (queue.done_count() != progress_mark) {
      progress_mark = queue.done_count();
      last_progress = t;
    }
    if (queue.complete()) break;
    if (t - last_progress > opt.timeout) {
      std::fprintf(stderr, "tandem-coordinator: no task finished for %.0f s; giving up\n", opt.timeout);
      status.set(runtime::Lifecycle::Error, "no progress");
      return launcher::exit_code::kNoInput;
    }
    states.wait(0.02);
  }

  if (runtime::g_stop) {
    if (lead.primary()) publish_state(now());
    status.set(runtime::Lifecycle::Finalized, "stopped");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return launcher::exit_code::kDone;
  }
  publish_state(now());  // every task done: standbys see it and exit
  for (const auto& [module, tasks] : queue.done_by_module()) {
    std::string list;
    for (const auto& n : tasks) list += (list.empty() ? "" : ", ") + n;
    say(module + " did " + std::to_string(tasks.size()) + " task(s) [" + list + "], joint travel " +
        fixed(module_wear(module), 3) + " rad");
  }
  const std::string total = std::to_string(queue.done_count()) + "/" + std::to_string(queue.task_count()) +
                            " tasks done, " + std::to_string(queue.duplicates()) + " duplicates";
  std::printf("coordinator: %s\n", total.c_str());
  std::fflush(stdout);
  status.set(runtime::Lifecycle::Finalized, total);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  return queue.duplicates() == 0 ? 0 : 1;
}

int main(int argc, char** argv) { return runtime::run_guarded("tandem-coordinator", run, argc, argv); }
