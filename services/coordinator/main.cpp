// tandem-coordinator: the high-level supervisor over many modules (the paper's future work). It keeps the
// deployment's task queue, hands the next task to an idle module, and balances wear: among idle modules it
// picks the one whose robots have travelled least (sum of joint travel, from their status), ties broken by
// fewer tasks done. It ends (exit 0) when every task is done; the launcher then stops the deployment.
#include <tandemPubSubTypes.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <map>
#include <string>
#include <thread>

#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;

namespace {
struct ModuleInfo {
  uint64_t assigned = 0;      // task id handed out and not yet done (0: idle)
  bool seen = false;          // its supervisor has reported
  uint64_t done = 0;
  std::vector<std::string> done_names;
};
}  // namespace

int main(int argc, char** argv) {
  std::string file;
  int domain = -1;
  double timeout = 30.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--deployment-file") file = argv[i + 1];
    if (a == "--domain" && !runtime::parse_domain(argv[i + 1], domain)) domain = -2;
    if (a == "--timeout") timeout = std::atof(argv[i + 1]);
  }
  if (domain == -2) {
    std::fprintf(stderr, "tandem-coordinator: --domain must be an integer in [0, 232]\n");
    return 2;
  }
  if (file.empty() || domain < 0) {
    std::fprintf(stderr, "usage: tandem-coordinator --deployment-file FILE --domain ID [--timeout S]\n"
                         "Started by 'tandem up' for deployments with a coordinator section.\n");
    return 2;
  }
  runtime::install_stop_handlers();
  runtime::Deployment d;
  try {
    d = runtime::load_deployment(file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem-coordinator: %s\n", e.what());
    return 2;
  }
  bus::Participant part(domain, "coordinator/" + d.name, runtime::transport_of(d));
  bus::Reader<msg::TaskState, msg::TaskStatePubSubType> states(part, bus::kTaskStateTopic, bus::TopicKind::Task);
  bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType> status_in(part, bus::kStatusTopic,
                                                                          bus::TopicKind::Status);
  bus::Writer<msg::TaskAssignment, msg::TaskAssignmentPubSubType> assign(part, bus::kTaskAssignmentTopic,
                                                                         bus::TopicKind::Task);
  runtime::StatusPublisher status(part, "coordinator", "coordinator", "");
  status.msg().deployment(d.name);
  status.set(runtime::Lifecycle::Active, "task queue of " + std::to_string(d.tasks.size()));

  std::map<std::string, ModuleInfo> modules;
  for (const auto& m : d.modules) modules[m.name] = ModuleInfo{};
  std::map<std::string, double> wear;  // per robot process id
  auto module_wear = [&wear](const std::string& module) {  // joint travel of a module's robots
    double w = 0.0;
    for (const auto& [id, v] : wear) {
      if (id.rfind(module + "/", 0) == 0) w += v;
    }
    return w;
  };
  std::deque<size_t> pending;
  for (size_t i = 0; i < d.tasks.size(); ++i) pending.push_back(i);
  std::map<uint64_t, size_t> task_of_id;
  uint64_t next_id = 1;
  size_t completed = 0;
  auto last_progress = std::chrono::steady_clock::now();

  while (!runtime::g_stop && completed < d.tasks.size()) {
    msg::ProcessStatus ps;
    while (status_in.take(ps)) {
      if (ps.deployment() == d.name && ps.role() == "robot") wear[ps.process_id()] = ps.wear();
    }
    msg::TaskState ts;
    while (states.take(ts)) {
      auto it = modules.find(ts.module_id());
      if (it == modules.end()) continue;
      ModuleInfo& mi = it->second;
      mi.seen = true;
      if (ts.state() == 2 && mi.assigned != 0 && ts.task_id() == mi.assigned) {
        mi.done_names.push_back(d.tasks[task_of_id[mi.assigned]].name);
        ++mi.done;
        ++completed;
        mi.assigned = 0;
        last_progress = std::chrono::steady_clock::now();
        std::printf("coordinator: %s finished task %s (%zu/%zu done)\n", ts.module_id().c_str(),
                    mi.done_names.back().c_str(), completed, d.tasks.size());
      }
    }
    // Hand out pending tasks to idle modules, least worn first.
    while (!pending.empty()) {
      std::string best;
      double best_wear = 0.0;
      uint64_t best_done = 0;
      for (const auto& [name, mi] : modules) {
        if (!mi.seen || mi.assigned != 0) continue;
        const double w = module_wear(name);
        // wear: least joint travel first; round_robin: fewest tasks first. Ties: fewer tasks, then name.
        const bool better = d.balance == "round_robin" ? mi.done < best_done
                                                       : (w < best_wear || (w == best_wear && mi.done < best_done));
        if (best.empty() || better) {
          best = name;
          best_wear = w;
          best_done = mi.done;
        }
      }
      if (best.empty()) break;
      const size_t t = pending.front();
      pending.pop_front();
      msg::TaskAssignment a;
      a.module_id(best);
      a.task_id(next_id);
      a.task_name(d.tasks[t].name);
      a.waypoints(d.tasks[t].waypoints);
      assign.write(a);
      task_of_id[next_id] = t;
      modules[best].assigned = next_id++;
      std::printf("coordinator: task %s -> %s (wear %.3f rad)\n", d.tasks[t].name.c_str(), best.c_str(), best_wear);
      status.msg().detail(std::to_string(completed) + "/" + std::to_string(d.tasks.size()) + " tasks done");
      status.publish();
    }
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - last_progress).count() > timeout) {
      std::fprintf(stderr, "tandem-coordinator: no task finished for %.0f s; giving up\n", timeout);
      status.set(runtime::Lifecycle::Error, "no progress");
      return 4;
    }
    states.wait(0.02);
  }
  std::printf("coordinator: %zu/%zu tasks done\n", completed, d.tasks.size());
  for (const auto& [name, mi] : modules) {
    const double w = module_wear(name);
    std::string list;
    for (const auto& n : mi.done_names) list += (list.empty() ? "" : ", ") + n;
    std::printf("coordinator: %s did %llu task(s) [%s], joint travel %.3f rad\n", name.c_str(),
                static_cast<unsigned long long>(mi.done), list.c_str(), w);
  }
  status.msg().detail(std::to_string(completed) + "/" + std::to_string(d.tasks.size()) + " tasks done");
  status.set(runtime::Lifecycle::Finalized, std::to_string(completed) + "/" + std::to_string(d.tasks.size()) +
                                                " tasks done");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  return completed == d.tasks.size() ? 0 : 1;
}
