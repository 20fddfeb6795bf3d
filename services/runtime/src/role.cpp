#include <exception>
#include "tandem/launcher/exit_codes.hpp"
#include "tandem/launcher/sched_group.hpp"
#include "tandem/runtime/role.hpp"

#include <sched.h>

#include <dirent.h>
#include <sys/resource.h>

#include <csignal>
#include <cstdio>
#include <cerrno>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include "tandem/sim/scenario_yaml.hpp"

namespace tandem::runtime {

std::atomic<bool> g_stop{false};

namespace {
void on_signal(int /*sig*/) { g_stop = true; }

void usage(const char* role, bool needs_arm, std::FILE* f) {
  std::fprintf(f,
               "usage: tandem-%s --scenario FILE --case NAME [--module NAME]%s [--domain ID]\n"
               "       [--transport shm|udp] [--timeout SECONDS] [--timing lockstep|realtime]\n"
               "       [--deployment NAME] [--continuous] [--no-overload-brake] [--observers N]%s\n"
               "Started by 'tandem up'; one Fast DDS participant. Exit: 0 done, 2 bad arguments or\n"
               "configuration, 3 peers not found in time, 4 a tick timed out, 5 (supervisor) no plan to\n"
               "follow, 6 cut off from the module's leader (robot: the world followed a newer plan for 2000 ticks;\n"
               "supervisor: a standby that cannot hear the live leader).\n",
               role, needs_arm ? " --arm ROBOT" : "",
               needs_arm || std::string(role) == "supervisor" ? " [--strength N (100 primary)]" : "");
}
}  // namespace

void install_stop_handlers() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

bool parse_role_options(const char* role, int argc, char** argv, bool needs_arm, RoleOptions& o,
                        int& exit_code) {
  exit_code = launcher::exit_code::kBadArgs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      usage(role, needs_arm, stdout);
      exit_code = launcher::exit_code::kDone;
      return false;
    }
    if (a == "--continuous") {
      o.continuous = true;
      continue;
    }
    if (a == "--test-no-brakes") {  // world, test only: an arm whose controller is gone keeps its last torque
      o.test_no_brakes = true;
      continue;
    }
    if (a == "--no-overload-brake") {  // world, real time: keep stepping a module whose commands come late
      o.overload_brake = false;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "tandem-%s: '%s' needs a value (or is unknown)\n", role, a.c_str());
      usage(role, needs_arm, stderr);
      return false;
    }
    const std::string v = argv[++i];
    if (a == "--scenario") {
      o.scenario = v;
    } else if (a == "--case") {
      o.case_name = v;
    } else if (a == "--module") {
      o.module = v;
    } else if (a == "--arm" && needs_arm) {
      o.arm = v;
    } else if (a == "--domain") {
      if (!parse_domain(v, o.domain)) {
        std::fprintf(stderr, "tandem-%s: --domain must be an integer in [0, 232], got '%s'\n", role, v.c_str());
        return false;
      }
    } else if (a == "--transport") {
      if (v != "shm" && v != "udp") {
        std::fprintf(stderr, "tandem-%s: --transport must be shm or udp, got '%s'\n", role, v.c_str());
        return false;
      }
      o.transport = v == "shm" ? dds::Transport::SharedMemory : dds::Transport::Udp;
    } else if (a == "--strength" && (needs_arm || std::string(role) == "supervisor")) {
      char* end = nullptr;
      const long v2 = std::strtol(v.c_str(), &end, 10);
      if (*end != '\0' || v2 < 1 || v2 > 1000000) {
        std::fprintf(stderr, "tandem-%s: --strength must be an integer in [1, 1000000], got '%s'\n", role, v.c_str());
        return false;
      }
      o.strength = static_cast<int>(v2);
    } else if (a == "--deployment") {
      o.deployment = v;
    } else if (a == "--timing") {
      if (v != "lockstep" && v != "realtime") {
        std::fprintf(stderr, "tandem-%s: --timing must be lockstep or realtime, got '%s'\n", role, v.c_str());
        return false;
      }
      o.realtime = v == "realtime";
    } else if (a == "--observers") {
      o.observers = std::atoi(v.c_str());
      if (v.empty() || v.find_first_not_of("0123456789") != std::string::npos || o.observers > 16) {
        std::fprintf(stderr, "tandem-%s: --observers must be a count 0-16, got '%s'\n", role, v.c_str());
        return false;
      }
    } else if (a == "--timeout") {
      o.timeout = std::atof(v.c_str());
      if (!(o.timeout > 0.0)) {
        std::fprintf(stderr, "tandem-%s: --timeout must be > 0 seconds, got '%s'\n", role, v.c_str());
        return false;
      }
    } else {
      std::fprintf(stderr, "tandem-%s: unknown option '%s'\n", role, a.c_str());
      usage(role, needs_arm, stderr);
      return false;
    }
  }
  if (o.scenario.empty() || o.case_name.empty() || (needs_arm && o.arm.empty())) {
    std::fprintf(stderr, "tandem-%s: --scenario, --case%s are required\n", role, needs_arm ? " and --arm" : "");
    usage(role, needs_arm, stderr);
    return false;
  }
  exit_code = launcher::exit_code::kDone;
  return true;
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

int raise_to_realtime_from_env(bool per_tick) {
  const char* env = std::getenv("TANDEM_RT_PRIORITY");
  const int priority = env != nullptr ? std::atoi(env) : 0;
  if (priority <= 0) {
    // Linux keeps a niceness per thread: every thread of this process back to 0 (always permitted: lowering).
    errno = 0;
    const int nice_now = ::getpriority(PRIO_PROCESS, 0);
    if (!per_tick || errno != 0 || nice_now >= 0) return 0;
    if (DIR* dir = ::opendir("/proc/self/task")) {
      while (const dirent* e = ::readdir(dir)) {
        if (e->d_name[0] >= '0' && e->d_name[0] <= '9') (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(std::atoi(e->d_name)), 0);
      }
      ::closedir(dir);
    }
    // And its autogroup (launcher::spawn gave it its own, at the niceness it inherited).
    if (launcher::leads_session()) (void)launcher::set_autogroup_nice(0);
    return 0;
  }
  sched_param sp{};
  sp.sched_priority = priority;
  int raised = 0;
  DIR* dir = ::opendir("/proc/self/task");
  if (dir == nullptr) return ::sched_setscheduler(0, SCHED_FIFO, &sp) == 0 ? 1 : -1;
  while (const dirent* e = ::readdir(dir)) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
    if (::sched_setscheduler(static_cast<pid_t>(std::atoi(e->d_name)), SCHED_FIFO, &sp) != 0) {
      raised = -1;
      break;
    }
    ++raised;
  }
  ::closedir(dir);
  return raised;
}

}  // namespace tandem::runtime
