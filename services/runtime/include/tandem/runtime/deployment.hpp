// Deployment file of `tandem up`: which modules run, from which scenario and case, on which DDS domain.
#pragma once

#include <string>
#include <vector>

#include "tandem/dds/bus.hpp"

namespace tandem::runtime {

struct ModuleDeployment {
  std::string name;
  std::string scenario;  ///< resolved path
  std::string case_name;
  int standby = 0;  ///< standby robot processes per arm (hot standby, lower ownership strength)
  /// Restart policy of the module's robot processes (OTP-style): never | on-failure | always, at most
  /// restart_limit restarts per arm within restart_window seconds, the n-th after restart_backoff * 2^n s.
  std::string restart = "never";
  int restart_limit = 3;
  double restart_window = 30.0;
  double restart_backoff = 0.2;
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
  std::vector<ModuleDeployment> modules;
  bool coordinator = false;        ///< a coordinator hands out `tasks`; modules run until it is done
  std::vector<TaskSpec> tasks;
  std::string balance = "wear";    ///< wear | round_robin
};

/// The DDS transport a deployment asks for.
inline dds::Transport transport_of(const Deployment& d) {
  return d.transport == "udp" ? dds::Transport::Udp : dds::Transport::SharedMemory;
}

/// Reads and validates a deployment, including every scenario and case it names. Throws sim::ConfigError.
Deployment load_deployment(const std::string& path);

}  // namespace tandem::runtime
