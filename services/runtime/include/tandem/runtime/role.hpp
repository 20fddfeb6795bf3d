// What every role process (world, robot, supervisor) shares: its command line, the module it belongs to
// (built from the same ModuleSetup as the embedded simulation), arm naming, validation of wire samples,
// and signal handling for a clean stop.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "tandem/dds/bus.hpp"
#include "tandem/plan/plan.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario.hpp"

namespace tandem::runtime {

struct RoleOptions {
  std::string scenario;       ///< scenario file (module physics, task, controllers)
  std::string case_name;      ///< case of the scenario (controller, disturbance)
  std::string module = "m1";  ///< module name, prefix of the arm ids
  std::string arm;            ///< robot name (robot role only)
  int domain = 0;
  dds::Transport transport = dds::Transport::SharedMemory;
  double timeout = 10.0;      ///< seconds to wait for peers / a tick before giving up
  bool realtime = false;      ///< world: step on the wall clock (else lockstep)
  std::string deployment;     ///< name of the deployment (in status messages)
  bool continuous = false;    ///< run until stopped, tasks from the coordinator (else the scenario's task)
  bool overload_brake = true; ///< world, real time: brake and pause a module whose commands keep coming late
  bool test_no_brakes = false; ///< world, test only: never brake an arm whose controller is gone
  int standbys = 0;           ///< world, lockstep: robots per arm besides the primary, whose first answers tick 0 waits for
  int observers = 0;          ///< world, lockstep: sensor readers besides the first robot (standbys, a recorder) to wait for before tick 0
  int strength = kPrimaryStrength;  ///< robot: ownership strength of its torque writer; supervisor: its rank (standby: lower)
  static constexpr int kPrimaryStrength = plan::kPrimaryStrength;  // one definition (services/plan)
};

/// Parses the common options (CLI11, runtime::parse_args); on error says the problem on stderr (or into `err` when
/// given) and returns false. `exit_code` is 0 for --help, 2 for bad arguments.
bool parse_role_options(const char* role, int argc, const char* const* argv, bool needs_arm, RoleOptions& out,
                        int& exit_code, std::string* err = nullptr);
/// The command line (without the program) that parse_role_options reads back as `o` for `role` ("world", "robot",
/// "supervisor"): how the launcher hands a role its configuration. It sits beside the parser, the only other place
/// that names the flags, and a round-trip test keeps the two in step (tests/unit/test_args.cpp).
std::vector<std::string> role_args(const std::string& role, const RoleOptions& o);

/// The loaded scenario, case and module. Throws with a message naming the file on error.
struct RoleContext {
  sim::Scenario scenario;
  sim::CaseConfig case_config;
  sim::ModuleSetup module;
  std::string arm_id(int j) const { return module_name + "/" + scenario.robots[j].name; }
  int arm_index(const std::string& arm_id) const;  ///< -1 if not an arm of this module
  std::string module_name;
};
RoleContext load_context(const RoleOptions& o);

/// Parses a DDS domain id (an integer in [0, 232]); false if the text is not one.
bool parse_domain(const std::string& text, int& domain);

/// The common start of a role process: options, stop handlers, and the module's context. On failure prints
/// the reason and returns false with `exit_code` set (0 for --help, 2 for bad arguments or configuration).
bool start_role(const char* role, int argc, char** argv, bool needs_arm, RoleOptions& opt, RoleContext& ctx,
                int& exit_code);

/// Set by SIGINT/SIGTERM.
extern std::atomic<bool> g_stop;
void install_stop_handlers();

/// Real-time once active (docs/architecture.md, "Real-time timing"): a role process is started at normal priority
/// (its start-up, discovery and handshakes must not preempt the running modules' per-tick processes; a soak
/// restarts about a thousand processes an hour) and raises every thread it has to SCHED_FIFO at
/// TANDEM_RT_PRIORITY (set by launcher::spawn) when it turns active; threads created later inherit it.
/// Returns the number of threads raised (0 without the variable; -1 if the kernel refused).
/// Without the variable (lockstep, or real time where SCHED_FIFO is not permitted), a per-tick process (world,
/// robot: `per_tick`) that inherited the launcher's raised niceness (launcher::kServiceNice) goes back to niceness 0,
/// so that lockstep's per-tick work, which fills every core, never starves the control plane (supervisors,
/// coordinators, the launcher, processes starting); a supervisor keeps it.
/// A per-tick process (`per_tick`) with TANDEM_CPU set (launcher::SpawnOptions::cpu, deployment key
/// `cpu_affinity: module`) is first pinned, every thread, to that CPU: a module's world and robots on one core wake
/// each other without a cross-CPU interrupt (on the 2-vCPU virtual machines measured, SCHED_FIFO across the two
/// vCPUs tripped the overload rule on the bare floor 1.5-18 times a minute and pinned not once: docs/benchmarks.md
/// item 48). Opt-in: a Fast DDS thread that spins at SCHED_FIFO then holds the module's CPU (soak finding 85).
int raise_to_realtime_from_env(bool per_tick = true);

/// TANDEM_CPU's value: a CPU number in [0, CPU_SETSIZE), or -1 (unset, empty or not a number).
int parse_cpu(const char* text);
/// Pins every thread of this process to the CPU in TANDEM_CPU: the threads pinned, 0 without the variable, -1 if
/// the kernel refused (a CPU outside this process's cpuset).
int pin_to_cpu_from_env();

/// Runs a process's body: an exception that escapes it (a Fast DDS or allocation failure at set-up) is reported
/// as "<program>: <what>" and the process exits 1, instead of aborting.
int run_guarded(const char* program, int (*body)(int, char**), int argc, char** argv);

/// The bound on a role process's teardown once its work is done [s].
constexpr double kTeardownBoundS = 5.0;
/// Called with the process's exit code once its work is done, before its DDS entities are deleted: returns `code`,
/// and if the process has not ended `seconds` later, says so and ends it with `code` (_exit, no library teardown).
/// Fast DDS 2.9 can deadlock in a participant's deletion (the soak's observer hung 8 minutes there, finding 59's
/// neighbour); a world once said "task done" in a CI run and never exited (2026-11-28). Bounded here, the process
/// still ends with its own code, which the launcher reads (docs/failure-model.md).
int bound_teardown(const char* program, int code, double seconds = kTeardownBoundS);

// Ranks and wire checks live with the plan (services/plan); the role processes use them under these names.
using plan::SupervisorRank;
using plan::valid_rank;
using plan::all_finite;

}  // namespace tandem::runtime
