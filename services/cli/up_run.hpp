// One run of `tandem up` (docs/architecture.md, "Launcher"): the launcher::Supervisor wired to DDS (live commands,
// statuses, summaries, the coordinator's queue state, the agents), to the processes (fork/exec here, or the
// agents' executor) and to the clock. Its steps, in order: check and prepare (security, priorities), join the
// domain (the Discovery Server, the launcher's participant, the agents), start the recorder and the viewer, admit
// and start the modules and coordinators, supervise until every process is done or a stop is asked, then the
// summary and the clean-up.
#pragma once

#include <atomic>
#include <chrono>
#include <fstream>
#include <list>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "live_view.hpp"
#include "tandem/launcher/helper_process.hpp"
#include "tandem/launcher/spin_watch.hpp"
#include "tandem/runtime/shm_clean.hpp"
#include "up_parts.hpp"

namespace tandem::cli::up {

struct UpOptions {
  std::string file;          ///< the deployment file (made absolute for a multi-host run)
  std::string summary_file;  ///< --summary
  std::string view_port;     ///< --view-port ("" = 8765)
  bool check_only = false;   ///< --check
  bool with_view = false;    ///< --view
};

class UpRun {
 public:
  /// `d` loaded from o.file (with --record applied), `specs` its modules; `stop` is set by SIGINT/SIGTERM (and
  /// by `tandem down`).
  UpRun(Deployment d, UpOptions o, std::vector<launcher::ModuleSpec> specs, std::atomic<bool>& stop);
  /// The whole run; the exit code of `tandem up` (0 pass, 1 fail, 2 bad configuration or could not start).
  int run();

 private:
  using Clock = std::chrono::steady_clock;
  double now_s() const { return std::chrono::duration<double>(Clock::now() - t_start_).count(); }
  int prepare();           ///< -1: go on; else the exit code (security, --check, priorities)
  bool join_domain();      ///< the Discovery Server, this launcher's participant and its readers and writers
  bool wait_for_agents();  ///< multi-host: every host's agent serves this run
  bool start_recorder();   ///< record: started and heard before any module
  void start_viewer();     ///< --view
  void start_modules();    ///< admission (real time, shedding), then every autostart module and the coordinators
  void collect();          ///< summaries, task states and the coordinator's queue state
  void step();             ///< one pass of the supervision loop
  void publish_launcher_status();
  void serve_requests();
  int finish();            ///< the summary, the helpers stopped, the shared memory cleaned; the exit code
  void watch_spins();      ///< real time, once a second: kills a per-tick process with a spinning thread

  std::atomic<bool>& stop_;
  Deployment d_;
  UpOptions o_;
  CommandLines lines_;
  LocalExecutor local_;
  unsigned long long run_id_;
  AgentExecutor agents_;
  UpOutbox outbox_;
  launcher::Supervisor L_;
  Clock::time_point t_start_ = Clock::now();

  // Declared in the order they come to life, so that they go in the reverse one: the helpers' processes stop
  // before the participant goes, and the Discovery Server's profile is removed after the server has stopped.
  std::time_t launcher_started_ = 0;  ///< shared-memory files of this run are newer
  std::optional<runtime::ShmSweeper> sweeper_;  ///< killed children's files, once unused for a minute
  std::vector<pid_t> discovery_servers_;
  std::string discovery_profile_;
  struct RemoveFile {
    std::string& path;
    ~RemoveFile();
  } remove_profile_{discovery_profile_};
  std::list<launcher::HelperProcess> server_stops_;  ///< one per Discovery Server
  std::unique_ptr<bus::Participant> part_;
  std::unique_ptr<bus::Reader<msg::RobotSummary, msg::RobotSummaryPubSubType>> robot_sum_;
  std::unique_ptr<bus::Reader<msg::WorldSummary, msg::WorldSummaryPubSubType>> world_sum_;
  std::unique_ptr<bus::Reader<msg::ProcessStatus, msg::ProcessStatusPubSubType>> status_;
  std::unique_ptr<bus::Reader<msg::ControlRequest, msg::ControlRequestPubSubType>> control_;
  std::unique_ptr<bus::Writer<msg::ControlRequest, msg::ControlRequestPubSubType>> control_out_;
  std::unique_ptr<bus::Reader<msg::TaskState, msg::TaskStatePubSubType>> task_states_;
  std::unique_ptr<bus::Reader<msg::CoordinatorState, msg::CoordinatorStatePubSubType>> coord_state_;
  std::unique_ptr<bus::Writer<msg::CoordinatorState, msg::CoordinatorStatePubSubType>> coord_state_out_;
  std::unique_ptr<bus::Writer<msg::AgentRequest, msg::AgentRequestPubSubType>> agent_out_;
  std::unique_ptr<bus::Reader<msg::AgentState, msg::AgentStatePubSubType>> agent_state_;
  std::unique_ptr<runtime::StatusPublisher> launcher_status_;
  LiveView view_;
  launcher::Capacity capacity_;
  pid_t recorder_ = -1;
  std::optional<launcher::HelperProcess> recorder_stop_;
  bool recording_failed_ = false;
  pid_t viewer_ = -1;
  std::optional<launcher::HelperProcess> viewer_stop_;

  Heard heard_;
  launcher::SpinWatch spins_{d_.spin_limit};
  Clock::time_point t0_, last_print_, launcher_published_, heartbeat_sent_, spins_seen_;
  std::vector<std::string> running_labels_;
};

}  // namespace tandem::cli::up
