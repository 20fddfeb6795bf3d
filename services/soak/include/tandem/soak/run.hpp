// The soak as a run (`tandem soak`, docs/soak.md): the deployment under its own `tandem up` (a child process, its
// output in the report's launcher.log) and this process one more DDS participant beside it, which records what the
// deployment reports (worlds' reports, every process's status, the coordinator's queue) plus memory and log
// sizes, carries out the nemesis's faults (signals by the pids processes report, tandem_hog children, live
// commands as `tandem plug` would send them), and at the end judges the history (soak::check) and writes the
// report. Jepsen's shape: nemesis, history, checker. The parts with no DDS and no processes (schedule, nemesis,
// checker, report) are the tandem::soak library; this is tandem::soak_run.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>

#include "tandem/runtime/deployment.hpp"
#include "tandem/soak/schedule.hpp"

namespace tandem::soak {

struct RunOptions {
  std::string file;           ///< the user's deployment file (named in the report)
  std::string derived;        ///< the deployment as run (derived_deployment, written to the report directory)
  std::string report;         ///< the report directory (exists)
  std::string command;        ///< the command line as typed, for the report
  std::string faults_source;  ///< the schedule's rules: a preset's name or a file
  std::string timing;         ///< realtime | lockstep
  uint64_t seed = 1;
  double duration_s = 600.0;
};

/// The deployment the soak runs: the user's file with the chosen timing (and transport, if not empty), absolute
/// scenario paths, and a coordinator whose queue lasts the whole run; `generated` gets the number of soak tasks.
std::string derived_deployment(const std::string& file, const runtime::Deployment& d, const std::string& timing,
                               const std::string& transport, double duration_s, size_t& generated);

/// Runs `d` (the derived deployment, loaded) for o.duration_s under `sched` until then or until `stop`, stops it,
/// judges and reports. Returns 0 when every invariant held, 1 on a violation, 2 if it could not start.
int run(const runtime::Deployment& d, const Schedule& sched, const RunOptions& o, const std::atomic<bool>& stop);
/// True if run() left its observer's DDS teardown hung (a Fast DDS deadlock): the caller ends the process with _exit
/// once its output is flushed, as library teardown at exit would hang the same way.
bool teardown_hung();

}  // namespace tandem::soak
