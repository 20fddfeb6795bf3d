#include <chrono>
#include <exception>
#include <thread>
#include "tandem/launcher/exit_codes.hpp"
#include "tandem/launcher/sched_group.hpp"
#include "tandem/runtime/role.hpp"
#include "tandem/runtime/args.hpp"

#include <sched.h>
#include <unistd.h>

#include <dirent.h>
#include <sys/resource.h>

#include <csignal>
#include <cstdio>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::runtime {

std::atomic<bool> g_stop{false};

namespace {
void on_signal(int /*sig*/) { g_stop = true; }

}  // namespace

void install_stop_handlers() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

bool parse_role_options(const char* role, int argc, const char* const* argv, bool needs_arm, RoleOptions& o,
                        int& exit_code, std::string* err) {
  const bool ranked = needs_arm || std::string(role) == "supervisor";
  CLI::App app("Started by 'tandem up': one Fast DDS participant of a module.", std::string("tandem-") + role);
  app.add_option("--scenario", o.scenario, "scenario file (module physics, task, controllers)")->required()->type_name("FILE");
  app.add_option("--case", o.case_name, "case of the scenario (controller, disturbance)")->required()->type_name("NAME");
  app.add_option("--module", o.module, "module name, prefix of the arm ids")->capture_default_str()->type_name("NAME");
  if (needs_arm) app.add_option("--arm", o.arm, "robot name (an arm of the scenario)")->required()->type_name("ROBOT");
  add_domain(app, o.domain)->capture_default_str();
  std::string transport = "shm", timing = "lockstep";
  app.add_option("--transport", transport, "DDS transport")->check(CLI::IsMember(std::vector<std::string>{"shm", "udp"}))->capture_default_str();
  app.add_option("--timeout", o.timeout, "seconds to wait for peers or a tick before giving up")
      ->check(seconds_up_to(86400.0))->capture_default_str()->type_name("SECONDS");
  app.add_option("--timing", timing, "step on the wall clock at 1 kHz, or tick by tick")
      ->check(CLI::IsMember(std::vector<std::string>{"lockstep", "realtime"}))->capture_default_str();
  app.add_option("--deployment", o.deployment, "deployment name (in status messages)")->type_name("NAME");
  app.add_flag("--continuous", o.continuous, "run until stopped, with tasks from the coordinator");
  bool no_overload_brake = false;
  app.add_flag("--no-overload-brake", no_overload_brake, "world, real time: keep stepping a module whose commands come late");
  app.add_flag("--test-no-brakes", o.test_no_brakes, "world, test only: an arm whose controller is gone keeps no brake");
  app.add_option("--observers", o.observers, "world: sensor readers besides the first robot to wait for at start")
      ->check(CLI::Range(0, 16))->capture_default_str()->type_name("N");
  app.add_option("--standbys", o.standbys, "world, lockstep: robots per arm besides the primary; tick 0 waits for their first answers")
      ->check(CLI::Range(0, 7))->capture_default_str()->type_name("N");
  if (ranked) {
    app.add_option("--strength", o.strength, "ownership strength (robot) or rank (supervisor); 100: primary")
        ->check(CLI::Range(1, 1000000))->capture_default_str()->type_name("N");
  }
  app.footer("Exit: 0 done, 2 bad arguments or configuration, 3 peers not found in time, 4 a tick timed out, 5\n"
             "(supervisor) no plan to follow, 6 cut off from the module's leader (robot: the world followed a newer\n"
             "plan for 2000 ticks; supervisor: a standby that cannot hear the live leader).");
  exit_code = parse_args(app, argc, argv, err);
  if (exit_code >= 0) return false;
  o.transport = transport == "shm" ? dds::Transport::SharedMemory : dds::Transport::Udp;
  o.realtime = timing == "realtime";
  o.overload_brake = !no_overload_brake;
  exit_code = launcher::exit_code::kDone;
  return true;
}

std::vector<std::string> role_args(const std::string& role, const RoleOptions& o) {
  char timeout[32];
  std::snprintf(timeout, sizeof timeout, "%.17g", o.timeout);  // read back exactly
  std::vector<std::string> a{"--scenario", o.scenario, "--case", o.case_name, "--module", o.module,
                             "--domain", std::to_string(o.domain),
                             "--transport", o.transport == dds::Transport::Udp ? "udp" : "shm",
                             "--timeout", timeout, "--timing", o.realtime ? "realtime" : "lockstep"};
  if (!o.deployment.empty()) a.insert(a.end(), {"--deployment", o.deployment});
  if (o.continuous) a.emplace_back("--continuous");
  if (!o.overload_brake) a.emplace_back("--no-overload-brake");
  if (o.test_no_brakes) a.emplace_back("--test-no-brakes");
  if (o.standbys > 0) a.insert(a.end(), {"--standbys", std::to_string(o.standbys)});
  if (o.observers > 0) a.insert(a.end(), {"--observers", std::to_string(o.observers)});
  if (role == "robot") a.insert(a.end(), {"--arm", o.arm});
  if (role == "robot" || role == "supervisor") a.insert(a.end(), {"--strength", std::to_string(o.strength)});
  return a;
}

RoleContext load_context(const RoleOptions& o) {
  RoleContext c;
  c.scenario = sim::load_scenario(o.scenario);
  bool found = false;
  std::string list;
  for (const auto& k : c.scenario.cases) {
    list += (list.empty() ? "" : ", ") + k.name;
    if (k.name == o.case_name) {
      c.case_config = k;
      found = true;
    }
  }
  if (!found) throw sim::ConfigError(o.scenario + ": no case '" + o.case_name + "'; cases: " + list);
  c.module = sim::make_module(c.scenario, c.case_config);
  if (o.continuous) c.module.steps = std::numeric_limits<long>::max();  // until stopped
  c.module_name = o.module;
  return c;
}

bool parse_domain(const std::string& text, int& domain) {
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || v < 0 || v > 232) return false;
  domain = static_cast<int>(v);
  return true;
}

bool start_role(const char* role, int argc, char** argv, bool needs_arm, RoleOptions& opt, RoleContext& ctx,
                int& exit_code) {
  if (!parse_role_options(role, argc, argv, needs_arm, opt, exit_code)) return false;
  install_stop_handlers();
  try {
    ctx = load_context(opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem-%s: %s\n", role, e.what());
    exit_code = launcher::exit_code::kBadArgs;
    return false;
  }
  return true;
}

int RoleContext::arm_index(const std::string& id) const {
  for (int j = 0; j < 2; ++j) {
    if (id == arm_id(j)) return j;
  }
  return -1;
}

int run_guarded(const char* program, int (*body)(int, char**), int argc, char** argv) {
  try {
    return body(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
  } catch (...) {
    std::fprintf(stderr, "%s: unknown exception\n", program);
  }
  return launcher::exit_code::kError;
}

int bound_teardown(const char* program, int code, double seconds) {
  std::thread([program, code, seconds] {
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    std::fprintf(stderr, "%s: its teardown did not end within %.0f s (a Fast DDS deadlock in a participant's deletion); "
                 "exiting with code %d without it\n", program, seconds, code);
    std::fflush(stdout);  // (its final summary line, if still buffered)
    std::fflush(stderr);
    ::_exit(code);
  }).detach();
  return code;
}

int parse_cpu(const char* text) {
  if (text == nullptr || *text == '\0') return -1;
  char* end = nullptr;
  const long v = std::strtol(text, &end, 10);
  if (*end != '\0' || v < 0 || v >= CPU_SETSIZE) return -1;
  return static_cast<int>(v);
}

namespace {
/// Calls `fn(tid)` for every thread of this process until it returns false; false if /proc/self/task is unreadable.
template <class Fn>
bool for_each_thread(Fn fn) {
  DIR* dir = ::opendir("/proc/self/task");
  if (dir == nullptr) return false;
  while (const dirent* e = ::readdir(dir)) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
    if (!fn(static_cast<pid_t>(std::atoi(e->d_name)))) break;
  }
  ::closedir(dir);
  return true;
}
}  // namespace

int pin_to_cpu_from_env() {
  const int cpu = parse_cpu(std::getenv("TANDEM_CPU"));
  if (cpu < 0) return 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  int pinned = 0;
  const bool listed = for_each_thread([&](pid_t tid) {
    if (::sched_setaffinity(tid, sizeof set, &set) == 0) {
      ++pinned;
      return true;
    }
    if (errno == ESRCH) return true;  // a thread that ended meanwhile
    pinned = -1;
    return false;
  });
  if (!listed) return ::sched_setaffinity(0, sizeof set, &set) == 0 ? 1 : -1;
  return pinned;
}

int raise_to_realtime_from_env(bool per_tick) {
  if (per_tick && pin_to_cpu_from_env() < 0) {
    std::fprintf(stderr, "tandem: could not pin to CPU %s (TANDEM_CPU): %s; running on any CPU\n", std::getenv("TANDEM_CPU"),
                 std::strerror(errno));
  }
  const char* env = std::getenv("TANDEM_RT_PRIORITY");
  const int priority = env != nullptr ? std::atoi(env) : 0;
  if (priority <= 0) {
    // Linux keeps a niceness per thread: every thread of this process back to 0 (always permitted: lowering).
    errno = 0;
    const int nice_now = ::getpriority(PRIO_PROCESS, 0);
    if (!per_tick || errno != 0 || nice_now >= 0) return 0;
    (void)for_each_thread([](pid_t tid) {
      (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(tid), 0);
      return true;
    });
    // And its autogroup (launcher::spawn gave it its own, at the niceness it inherited).
    if (launcher::leads_session()) (void)launcher::set_autogroup_nice(0);
    return 0;
  }
  sched_param sp{};
  sp.sched_priority = priority;
  int raised = 0;
  const bool listed = for_each_thread([&](pid_t tid) {
    if (::sched_setscheduler(tid, SCHED_FIFO, &sp) != 0) {
      raised = -1;
      return false;
    }
    ++raised;
    return true;
  });
  if (!listed) return ::sched_setscheduler(0, SCHED_FIFO, &sp) == 0 ? 1 : -1;
  return raised;
}

}  // namespace tandem::runtime
