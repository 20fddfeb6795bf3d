// QoS of every topic, in one place. docs/architecture.md has the table with the reasons.
#pragma once

#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <string>

namespace tandem::dds {

enum class TopicKind {
  Sensors,          ///< world -> one robot, every tick, lockstep: reliable, nothing lost
  SensorsRealtime,  ///< world -> one robot, every tick, real time: best effort, only the newest matters
  Torques,          ///< robot -> world, every tick, lockstep: reliable, nothing lost
  TorquesRealtime,  ///< robot -> world, every tick, real time: best effort, only the newest matters
  Summary,     ///< end-of-run results for the launcher
  Status,      ///< lifecycle and live figures of every process
  Control,     ///< requests to a launcher (tandem down)
  Task,        ///< task assignments and task states (latest per module)
  /// Readers of observers (tandem soak, recorders) of Status/Task/Summary topics: the same QoS as those
  /// writers (reliable, transient-local), but a deeper history (64 per instance), so that no sample is lost between two takes.
  Record,
};

/// strength: kept for the call sites; torque writers use SHARED ownership (the world picks by strength).
eprosima::fastdds::dds::DataWriterQos writer_qos(TopicKind kind, int32_t strength = 0, bool data_sharing = true);
/// True if this process takes part in a secured deployment (TANDEM_SECURITY_DIR is set).
bool secured();
/// The directory a secured process's data-sharing segments go in: /dev/shm/tandem-<uid>, mode 0700 (made if
/// missing). Throws if it exists and is not this user's directory.
std::string private_shm_dir();

eprosima::fastdds::dds::DataReaderQos reader_qos(TopicKind kind, bool data_sharing = true);

/// Per-tick topics (sensor samples, torque commands): one instance, a short preallocated history.
inline bool per_tick(TopicKind kind) {
  return kind == TopicKind::Sensors || kind == TopicKind::SensorsRealtime || kind == TopicKind::Torques ||
         kind == TopicKind::TorquesRealtime;
}

/// Whether a per-tick topic's samples go by data-sharing (`data_sharing`: the participant's transport allows it).
/// Real-time sensor samples do. Torque commands of a plain deployment go by the shared-memory transport instead:
/// their writers are the robots, which the failure model kills and restarts, and Fast DDS 2.9.1's data-sharing
/// reader aborts its whole process when a writer dies at the wrong moment (an assertion in ReaderPool::
/// init_shared_segment, or an uncaught "Interprocess mutex timeout when locking" on a lock the dead writer held;
/// seen: a world in a soak; bench/peer_kill.sh reproduces both). The transport's reader survives it. Lockstep's
/// sensor samples (reliable) go by the transport too: there the world, their writer, aborted on the same
/// uncaught timeout when a robot reading its samples was killed (five worlds in lockstep soaks, none in three
/// real-time hours; docs/soak.md, finding 45). A secured deployment keeps every per-tick topic on data-sharing,
/// whose segments are private to the user (docs/security.md); the transport's are not.
/// TANDEM_TORQUES_DATA_SHARING=1 and TANDEM_SENSORS_DATA_SHARING=1 restore data-sharing for torques and for
/// lockstep's sensor samples (benchmarks and tests only).
bool shares_data(TopicKind kind, bool data_sharing);

/// Topic names. The per-tick topics are per module ("<base>/<module>"), so that a world and its robots receive
/// only their own module's samples, however many modules share the domain; sensor samples are per arm
/// ("<base>/<module>/<robot>"), so that each robot receives only its own arm's.
inline std::string module_topic(const char* base, const std::string& module) { return std::string(base) + "/" + module; }
inline std::string arm_topic(const char* base, const std::string& arm_id) { return std::string(base) + "/" + arm_id; }

inline constexpr const char* kSensorsTopic = "tandem/arm_sensors";
inline constexpr const char* kWorldReportTopic = "tandem/world_report";
inline constexpr const char* kTorquesTopic = "tandem/torque_commands";
inline constexpr const char* kRobotSummaryTopic = "tandem/robot_summary";
inline constexpr const char* kWorldSummaryTopic = "tandem/world_summary";
inline constexpr const char* kStatusTopic = "tandem/process_status";
inline constexpr const char* kControlTopic = "tandem/control";
inline constexpr const char* kTaskAssignmentTopic = "tandem/task_assignment";
inline constexpr const char* kTaskStateTopic = "tandem/task_state";
inline constexpr const char* kCoordinatorStateTopic = "tandem/coordinator_state";
inline constexpr const char* kSupervisorPlanTopic = "tandem/supervisor_plan";
inline constexpr const char* kAgentRequestTopic = "tandem/agent_request";
inline constexpr const char* kAgentStateTopic = "tandem/agent_state";

}  // namespace tandem::dds
