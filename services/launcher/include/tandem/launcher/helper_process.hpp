// A helper process that `tandem up` starts beside the deployment's role processes (the Discovery Server, the
// recorder): not supervised (no restart), watched for an exit of its own, and stopped on purpose with SIGTERM, then
// SIGKILL if it is still there after a grace. Stopped when the owner goes out of scope.
#pragma once

#include <string>

namespace tandem::launcher {

class HelperProcess {
 public:
  /// `pid` from spawn() (<= 0: nothing to watch). `kill_note`: said on stderr when SIGKILL is needed ("": nothing).
  HelperProcess(int pid, double grace_s, std::string kill_note = "");
  ~HelperProcess() { stop(); }
  HelperProcess(const HelperProcess&) = delete;
  HelperProcess& operator=(const HelperProcess&) = delete;

  /// Whether it has exited (reaped now; its status kept). Also true once it is gone otherwise.
  bool exited();
  /// SIGTERM, then SIGKILL after the grace; waits until it is gone.
  void stop();
  int pid() const { return pid_; }
  /// Exit code (128 + signal if killed); 0 until it ended.
  int status() const { return status_; }

 private:
  int pid_;
  double grace_s_;
  std::string kill_note_;
  int status_ = 0;
};

}  // namespace tandem::launcher
