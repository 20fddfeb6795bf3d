// The launcher's and `tandem status`'s view of a deployment: the latest ProcessStatus of every process,
// printed per module (task progress, safe-grasp margin) and per process (lifecycle, tracking error).
#pragma once

#include <tandemPubSubTypes.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace tandem::cli {

class LiveView {
 public:
  explicit LiveView(std::string deployment) : deployment_(std::move(deployment)) {}
  /// Keeps the sample if it belongs to this deployment (all deployments if the name is empty).
  void update(const msg::ProcessStatus& s, std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now()) {
    if (deployment_.empty() || s.deployment() == deployment_) {
      processes_[s.process_id()] = s;
      heard_[s.process_id()] = now;
    }
  }
  /// Which processes a table shows. A killed process's last status (transient-local) still says what it was doing,
  /// so once a launcher is heard, a world, robot, supervisor or coordinator it no longer runs is left out and counted: at once (Run: `tandem
  /// status`, whose statuses all arrive at its start), or once not heard for kGoneAfter (Recent: the launcher's own
  /// table every second). All: the final table, every process heard.
  enum class Rows { All, Run, Recent };
  void print(std::FILE* f, Rows rows = Rows::Recent,
             std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now()) const;
  static constexpr std::chrono::seconds kGoneAfter{2};
  size_t size() const { return processes_.size(); }
  /// Whether the deployment's launcher has been heard (it lists the processes it runs).
  bool has_launcher() const;
  /// The processes the launcher says it runs that have not been heard from yet.
  std::vector<std::string> missing() const;

 private:
  std::string deployment_;
  std::map<std::string, msg::ProcessStatus> processes_;
  std::map<std::string, std::chrono::steady_clock::time_point> heard_;
};

}  // namespace tandem::cli
