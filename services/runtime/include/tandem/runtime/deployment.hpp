// Deployment file of `tandem up`: which modules run, from which scenario and case, on which DDS domain.
#pragma once

#include <cstdlib>

#include <map>
#include <string>
#include <vector>

#include "tandem/dds/bus.hpp"

namespace tandem::runtime {

struct ModuleDeployment {
  std::string name;
  std::string scenario;  ///< resolved path
  std::string case_name;
  int standby = 0;  ///< standby robot processes per arm (hot standby, lower ownership strength)
  /// Standby supervisors (hot standby: they follow the active one's plan and publish the same references,
  /// and the strongest live one takes over its duties when it dies).
  int supervisor_standby = 0;
  /// Restart policy of the module's robot processes (OTP-style): never | on-failure | always, at most
  /// restart_limit restarts per arm within restart_window seconds, the n-th after restart_backoff * 2^n s.
  /// Supervisors follow it too while another supervisor of the module serves (a restarted one is a standby).
  std::string restart = "never";
  int restart_limit = 3;
  double restart_window = 30.0;
  double restart_backoff = 0.2;
  /// How a restarted robot joins: as a standby (below the live ones) or as the arm's primary (it takes the
  /// arm over from the standby that served it meanwhile).
  std::string restart_as = "standby";
  /// false: listed but not started by `tandem up`; `tandem plug module NAME` starts it later.
  bool autostart = true;
  /// Multi-host (docs/multihost.md; "" without hosts:): the host of the world, and of every other process of the
  /// module not placed otherwise; the supervisor's and its standbys' hosts; per robot (arm) the primary's and the
  /// standbys' hosts.
  std::string host;
  std::string supervisor_host;
  std::string supervisor_standby_host;
  std::map<std::string, std::string> robot_hosts;
  std::map<std::string, std::string> standby_hosts;
};

/// A host of a multi-host deployment: its agent (`tandem agent --host NAME`) starts the processes placed on it.
struct HostSpec {
  std::string name;
  std::string address;  ///< IPv4 address of the host on the network that joins the hosts
};

/// A task of the coordinator's queue: waypoints of the object's absolute pose, from wherever it is.
struct TaskSpec {
  std::string name;
  std::vector<double> waypoints;  ///< (x, y, phi_E, duration) per waypoint, flattened
};

struct Deployment {
  std::string name;
  std::string source;
  int domain_id = 0;
  std::string transport = "shm";  ///< shm | udp
  std::string timing = "lockstep";
  double timeout = 10.0;
  /// A started module whose world has not ticked within this long is restarted with new participants (a pair
  /// of its participants never matched; with DDS-Security see docs/security.md "Start-up"), at most 3 times.
  double start_timeout = 20.0;
  /// Real-time timing: SCHED_FIFO priority of the per-tick processes (world, supervisor, robots), so that
  /// the rest of the machine (discovery of a joining process, the launcher, a compiler) cannot delay a
  /// tick; 0 = normal scheduling. Ignored in lockstep. Falls back to normal scheduling, with a note, where
  /// the system does not permit it (needs root or CAP_SYS_NICE / RLIMIT_RTPRIO).
  int realtime_priority = 20;
  /// Real time, processes on this machine: module (each module's world and robots pinned to one CPU of their own,
  /// modules round the CPUs, launcher::CpuPlan) or none (the scheduler places every thread; the default: pinned,
  /// a Fast DDS thread of a world spun at SCHED_FIFO for 15 minutes and took its CPU and the machine with it, soak
  /// run 58, docs/soak.md finding 85).
  std::string cpu_affinity = "none";
  /// Real time, processes on this machine: a thread of a world, supervisor or robot that uses more than this share
  /// of a core over 3 s is spinning (docs/soak.md, finding 85), and its process is killed and restarted by its
  /// policy (launcher::SpinWatch). 0 = not watched.
  double spin_limit = 0.9;
  bool overload_brake = true;  ///< real time: brake and pause a module whose commands keep coming late
  /// Real time with a coordinator: park whole modules when the load does not fit (launcher::Governor), and
  /// start the ones the calibrated estimate does not fit parked.
  bool shed_modules = true;
  /// Test only: the worlds never brake an arm whose controller is gone (it keeps its last torque and the object
  /// falls). Exists to show that `tandem soak`'s checker catches a dropped object; never for real deployments.
  bool test_no_brakes = false;
  /// simple: every participant announces itself to every other (Fast DDS's default); server: every process is
  /// a client of a Fast DDS Discovery Server at discovery_address:discovery_port, which the launcher starts
  /// (discovery_start: launcher) or which runs already (external: `fastdds discovery -i 0 -l ADDR -p PORT`).
  std::string discovery = "simple";
  int discovery_port = 0;  ///< 0: 11811 + domain_id
  std::string discovery_address = "127.0.0.1";
  std::string discovery_start = "launcher";  ///< launcher | external
  /// module: one Discovery Server per module (server i serves module i's processes; the launcher, coordinators,
  /// the CLI and the soak are clients of all of them), so that a module's churn is relayed to its own processes
  /// only (docs/failure-model.md, "The Discovery Server under churn"); one: a single server for every process.
  /// The default: module when the launcher starts the servers, one with discovery_start: external.
  std::string discovery_servers = "module";
  /// together: `tandem up` starts every module at once; one_by_one: the next once the last one's world ticks (at
  /// most 10 s apart). The default: one_by_one with simple discovery and more than two modules (32 participants of
  /// simple discovery starting together kept three of four modules from coming up), else together.
  std::string module_start;
  /// Multi-host: the hosts (empty: every process runs on the launcher's machine, started by the launcher). With
  /// hosts, every role process is started by its host's agent, and a host whose agent is silent for host_timeout
  /// seconds is lost: its processes count as failed.
  std::vector<HostSpec> hosts;
  double host_timeout = 1.0;
  std::string coordinator_host;          ///< multi-host: the coordinator's host
  std::string coordinator_standby_host;  ///< multi-host: its standbys' host (default: coordinator_host)
  std::vector<ModuleDeployment> modules;
  bool coordinator = false;        ///< a coordinator hands out `tasks`; modules run until it is done
  std::vector<TaskSpec> tasks;
  std::string balance = "wear";    ///< wear | round_robin
  int coordinator_standby = 0;     ///< standby coordinators (they take over with the queue's state)
  std::string coordinator_restart = "never";  ///< never | on-failure | always (restarted ones are standbys)
  int coordinator_restart_limit = 3;          ///< at most this many coordinator restarts ...
  double coordinator_restart_window = 30.0;   ///< ... within this many seconds
  /// `tandem up` starts `tandem record` and writes this MCAP file ("": no recording); relative to the current
  /// directory. record_topics: comma-separated groups of `tandem record --topics` ("" = all).
  std::string record;
  std::string record_topics;
  /// DDS-Security (docs/security.md): the directory of the keys `tandem keys` makes (`security: {keys: DIR}`,
  /// relative to the deployment file); "" = no security.
  std::string security_keys;
};

/// The topic groups `tandem record --topics` accepts.
inline const char* const kRecordGroups[] = {"ticks", "world", "status", "tasks", "summaries", "control", "events"};

/// Finds a module of the deployment by name (nullptr if none).
const ModuleDeployment* find_module(const Deployment& d, const std::string& name);

/// The DDS transport a deployment asks for.
inline dds::Transport transport_of(const Deployment& d) {
  return d.transport == "udp" ? dds::Transport::Udp : dds::Transport::SharedMemory;
}

/// The Discovery Server port of a deployment (discovery: server): its first server's.
inline int discovery_port_of(const Deployment& d) {
  return d.discovery_port > 0 ? d.discovery_port : 11811 + static_cast<int>(d.domain_id);
}

/// Port distance between a deployment's per-module Discovery Servers: more than the domain ids (0-232), so that
/// deployments on different domains never share a port.
constexpr int kDiscoveryPortStride = 256;

/// One Discovery Server of a deployment: Fast DDS server id `id` (its GUID prefix; a client names it by its place
/// in ROS_DISCOVERY_SERVER), at address:port; `module`: the module whose processes it serves ("": all).
struct DiscoveryServer {
  int id = 0;
  std::string address;
  int port = 0;
  std::string module;
};

/// The Discovery Servers of a `discovery: server` deployment (none for simple discovery): one per module in the
/// modules' order (ids 0, 1, ...; ports discovery_port_of + id * kDiscoveryPortStride), or one.
std::vector<DiscoveryServer> discovery_servers(const Deployment& d);

/// ROS_DISCOVERY_SERVER for a process of `module` ("": a process of the whole deployment, such as the launcher,
/// a coordinator, the CLI, the soak): with a server per module, the module's own server only (in its place, so
/// that its id matches), or every server; "" for simple discovery, and for a module with no server of its own (one
/// plugged in live from a scenario: its processes inherit the launcher's list, every server).
std::string discovery_env(const Deployment& d, const std::string& module = "");

/// How the deployment's processes discover each other, as said to users: "ADDRESS:PORT" of its Discovery Server
/// (the first, with "and N more, one per module"), or "simple".
std::string discovery_text(const Deployment& d);

/// For `discovery: server`: makes the participants this process creates from now on (and the processes it
/// starts, unless told otherwise: launcher::SpawnOptions::discovery) clients of every Discovery Server of the
/// deployment (Fast DDS reads ROS_DISCOVERY_SERVER at participant creation). Nothing for `discovery: simple`.
inline void use_discovery(const Deployment& d) {
  if (d.discovery != "server") return;
  ::setenv("ROS_DISCOVERY_SERVER", discovery_env(d).c_str(), 1);
}

/// Multi-host: the host a process of module `m` runs on ("" without hosts:). role: world | supervisor | robot;
/// slot: the robot's name; standby: not the slot's primary.
std::string host_of(const ModuleDeployment& m, const std::string& role, const std::string& slot, bool standby);
/// Multi-host: the host of the coordinator (standby: of a standby coordinator).
std::string coordinator_host_of(const Deployment& d, bool standby);
/// The host named `name` (nullptr if none).
const HostSpec* find_host(const Deployment& d, const std::string& name);

/// Reads and validates a deployment, including every scenario and case it names. Throws sim::ConfigError.
Deployment load_deployment(const std::string& path);

/// The deployment as YAML that load_deployment reads back to the same Deployment (every field, paths made absolute
/// so that the file may live anywhere; `source` is not written). `tandem soak` derives its deployment this way.
std::string deployment_yaml(const Deployment& d);

}  // namespace tandem::runtime
