// Deployment file of `tandem up`: which modules run, from which scenario and case, on which DDS domain.
#pragma once

#include <string>
#include <vector>

namespace tandem::cli {

struct ModuleDeployment {
  std::string name;
  std::string scenario;  ///< resolved path
  std::string case_name;
};

struct Deployment {
  std::string name;
  std::string source;
  int domain_id = 0;
  std::string transport = "shm";  ///< shm | udp
  std::string timing = "lockstep";
  double timeout = 10.0;
  std::vector<ModuleDeployment> modules;
};

/// Reads and validates a deployment, including every scenario and case it names. Throws sim::ConfigError.
Deployment load_deployment(const std::string& path);

}  // namespace tandem::cli
