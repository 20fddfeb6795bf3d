#include "tandem/dds/qos.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <stdexcept>

namespace tandem::dds {
namespace fdds = eprosima::fastdds::dds;

bool secured() {
  const char* dir = std::getenv("TANDEM_SECURITY_DIR");
  return dir != nullptr && *dir != '\0';
}

std::string private_shm_dir() {
  static const std::string dir = [] {
    std::string d = "/dev/shm/tandem-" + std::to_string(::getuid());
    if (::mkdir(d.c_str(), 0700) != 0 && errno != EEXIST) return std::string();
    struct stat st {};
    if (::stat(d.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != ::getuid()) {
      throw std::runtime_error(d + " exists but is not a directory of this user: the secured per-tick samples "
                               "would not be private (remove it)");
    }
    if ((st.st_mode & 077) != 0) ::chmod(d.c_str(), 0700);
    return d;
  }();
  return dir;
}

bool shares_data(TopicKind kind, bool data_sharing) {
  if (!per_tick(kind) || !data_sharing) return false;
  if (kind == TopicKind::SensorsRealtime) return true;
  auto env_is_1 = [](const char* name) {
    const char* v = std::getenv(name);
    return v != nullptr && std::string(v) == "1";
  };
  static const bool torques_forced = env_is_1("TANDEM_TORQUES_DATA_SHARING");
  static const bool sensors_forced = env_is_1("TANDEM_SENSORS_DATA_SHARING");
  return (kind == TopicKind::Sensors ? sensors_forced : torques_forced) || secured();
}

namespace {
// Per-tick topics: reliable (lockstep must not lose a tick), keep-last 256 (a reader that is behind, a
// recorder, still gets everything), volatile (a late joiner starts from the next
// tick). Summaries and status: reliable, transient-local, keep-last 1 per key, so a launcher or a
// `tandem status` that looks late still sees the latest value; the same for task assignments and task
// states, so a supervisor that (re)joins gets its module's current task. Control requests: reliable, keep-last 32,
// volatile (a request is for the launchers running now).
template <class Q>
void apply(Q& q, TopicKind kind) {
  q.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  q.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  if (kind == TopicKind::Summary || kind == TopicKind::Status || kind == TopicKind::Task) {
    q.history().depth = 1;
    q.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  } else if (kind == TopicKind::Record) {
    q.history().depth = 64;
    q.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  } else if (kind == TopicKind::SensorsRealtime || kind == TopicKind::TorquesRealtime) {
    // Real time: a sample that is late is worthless (the world has stepped on), so no repair traffic
    // (HEARTBEAT/ACKNACK) and no queue: best effort, the newest only.
    q.reliability().kind = fdds::BEST_EFFORT_RELIABILITY_QOS;
    q.history().depth = 1;
    q.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  } else if (kind == TopicKind::Sensors || kind == TopicKind::Torques) {
    // Lockstep per-tick: 256 ticks of slack, so that an observer (tandem record) that is descheduled for a
    // while (tens of ms at lockstep's pace of ~4 ticks/ms) still gets every tick (docs/recording.md).
    q.history().depth = 256;
    q.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  } else {
    q.history().depth = 32;
    q.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  }
  // Keyed topics carry one instance per arm, process or module: the default limit of 10 instances would
  // silently drop the 11th process of a large deployment.
  // Torque commands: SHARED ownership and no liveliness lease. The world hears every robot of an arm and
  // follows the strongest that answers by ticks (world::WorldCore): a finite lease costs a timer restart per
  // sample on both sides (measured: 15% of a module's CPU), and ticks decide faster than a lease.
  if (per_tick(kind)) {
    // One instance per topic (a topic per arm, unkeyed): a short history that can live in a preallocated,
    // shared pool (data-sharing delivery needs both).
    q.resource_limits().max_instances = 1;
    q.resource_limits().max_samples_per_instance = q.history().depth;
    q.resource_limits().max_samples = q.history().depth;
  } else {
    q.resource_limits().max_instances = 1024;
    q.resource_limits().max_samples_per_instance = q.history().depth;
    q.resource_limits().max_samples = 1024 * q.history().depth;
  }
}

template <class Q>
void apply_data_sharing(Q& q, TopicKind kind, bool data_sharing) {
  if (shares_data(kind, data_sharing)) {
    // Secured: the segments go in a directory only this user can enter (their samples are not encrypted, and
    // Fast DDS creates the files 0644 whatever the umask). docs/security.md, "Threat model".
    const std::string dir = secured() ? private_shm_dir() : std::string();
    if (dir.empty()) {
      q.data_sharing().automatic();
    } else {
      q.data_sharing().automatic(dir);
    }
  } else {
    q.data_sharing().off();
  }
}
}  // namespace

fdds::DataWriterQos writer_qos(TopicKind kind, int32_t /*strength*/, bool data_sharing) {
  fdds::DataWriterQos q = fdds::DATAWRITER_QOS_DEFAULT;
  apply(q, kind);
  // The wire encoding, pinned: XCDR1 (plain CDR, final types), what other vendors' readers of these types
  // expect today (docs/interop.md). Fast DDS 2.9 writes it by default; pinned so that an upgrade cannot move it.
  q.representation().m_value.assign(1, fdds::XCDR_DATA_REPRESENTATION);
  apply_data_sharing(q, kind, data_sharing);
  if (per_tick(kind)) {
    q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::PREALLOCATED_MEMORY_MODE;
    // Pool slots beyond the history, so that a write never waits for a slow reader to release one.
    q.resource_limits().extra_samples = 8;
  }
  if (kind == TopicKind::Summary || kind == TopicKind::Status || kind == TopicKind::Task) {
    // Transient-local state: a late joiner (tandem status, a restarted supervisor, another vendor's reader)
    // is repaired at the writer's next heartbeat; 100 ms instead of Fast DDS's 3 s. Heartbeats go out only
    // while a reader has not acknowledged everything, so a settled domain pays nothing.
    q.reliable_writer_qos().times.heartbeatPeriod = eprosima::fastrtps::Duration_t(0, 100000000);
  }
  if (kind == TopicKind::Sensors || kind == TopicKind::Torques) {
    // Lockstep over a transport (UDP, or shared memory: lockstep's samples no longer go by data-sharing): a
    // message a reader lost (a recorder's socket or port overflowing while it was descheduled) is repaired only
    // after the writer's next heartbeat (3 s by default), long after 256 ticks have pushed it out of the
    // history. 20 ms keeps the repair inside the history (docs/recording.md).
    q.reliable_writer_qos().times.heartbeatPeriod = eprosima::fastrtps::Duration_t(0, 20000000);
  }
  return q;
}

fdds::DataReaderQos reader_qos(TopicKind kind, bool data_sharing) {
  fdds::DataReaderQos q = fdds::DATAREADER_QOS_DEFAULT;
  apply(q, kind);
  apply_data_sharing(q, kind, data_sharing);
  return q;
}

}  // namespace tandem::dds
