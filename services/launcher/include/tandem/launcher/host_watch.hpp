// Which hosts of a multi-host deployment are alive, from their agents' heartbeats (AgentState, every 100 ms), as
// a component without DDS or clock: times in seconds are passed in. A host is lost when its agent was heard and
// then stayed silent for longer than the timeout, and back when heard again; a host never heard is `waiting`.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace tandem::launcher {

class HostWatch {
 public:
  HostWatch(std::vector<std::string> hosts, double timeout_s);

  /// The agent of `host` was heard at `now`. Returns true if the host was lost and is back. Unknown hosts are
  /// ignored (false).
  bool heard(const std::string& host, double now);
  /// Counts every heard host's silence from `now` (after a time in which the caller read no heartbeat).
  void restart_clock(double now);
  /// Hosts that have just been lost at `now` (each is reported once per loss).
  std::vector<std::string> newly_lost(double now);

  bool known(const std::string& host) const { return state_.count(host) != 0; }
  bool up(const std::string& host) const;
  bool lost(const std::string& host) const;
  /// Hosts never heard yet.
  std::vector<std::string> waiting() const;

 private:
  struct State {
    bool heard = false;
    bool lost = false;
    double last = 0.0;
  };
  std::map<std::string, State> state_;
  double timeout_;
};

}  // namespace tandem::launcher
