// The launcher's and `tandem status`'s view of a deployment: the latest ProcessStatus of every process,
// printed per module (task progress, safe-grasp margin) and per process (lifecycle, tracking error).
#pragma once

#include <tandemPubSubTypes.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace tandem::cli {

class LiveView {
 public:
  explicit LiveView(std::string deployment) : deployment_(std::move(deployment)) {}
  /// Keeps the sample if it belongs to this deployment (all deployments if the name is empty).
  void update(const msg::ProcessStatus& s) {
    if (deployment_.empty() || s.deployment() == deployment_) processes_[s.process_id()] = s;
  }
  void print(std::FILE* f) const;
  size_t size() const { return processes_.size(); }
  /// Whether the deployment's launcher has been heard (it lists the processes it runs).
  bool has_launcher() const;
  /// The processes the launcher says it runs that have not been heard from yet.
  std::vector<std::string> missing() const;

 private:
  std::string deployment_;
  std::map<std::string, msg::ProcessStatus> processes_;
};

}  // namespace tandem::cli
