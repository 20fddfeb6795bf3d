// The tap: one participant's readers of a deployment's topics, each sample converted to its recording message
// (idl/tandem_record.proto) and handed to a sink, with the events derived from them (record::EventDeriver)
// and the per-tick gaps it sees. `tandem record` sinks it into an MCAP file, `tandem view` into its live
// clients: both read the domain the same way, with the same QoS, and derive the same events.
#pragma once

#include <tandem_record.pb.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace tandem::dds {
class Participant;
}

namespace tandem::record {

/// Where a tap's output goes. Every call is made under the tap's one mutex, from a DDS listener thread (the
/// per-tick topics) or from Tap::poll() (the rest): a sink needs no lock of its own, and must return quickly.
class TapSink {
 public:
  virtual ~TapSink() = default;
  /// A sample of DDS topic `topic`, as its recording message; `publish_ns` is the writer's source timestamp
  /// for per-tick samples, 0 for the rest.
  virtual void on_message(const std::string& topic, const google::protobuf::Message& m, uint64_t log_ns,
                          uint64_t publish_ns) = 0;
  /// A derived event (only with the "events" group).
  virtual void on_event(const Event& e, uint64_t log_ns) = 0;
};

struct TapConfig {
  std::string deployment;  ///< samples of other deployments (a shared domain) are skipped
  bool realtime = false;   ///< per-tick topics read with the real-time QoS (best effort), else lockstep's
  std::vector<std::string> modules;
  std::vector<std::string> arms;  ///< "<module>/<robot>", both arms of every module
  std::set<std::string> groups;   ///< ticks, world, status, tasks, summaries, control, events
};

/// What the tap saw of one arm's per-tick topics.
struct ArmTapStats {
  uint64_t sensor_samples = 0, torque_samples = 0;
  uint64_t missed_ticks =
      0;  ///< in gaps between samples, before the first and after the last (against the world's count)
  uint64_t gaps = 0;
};

class Tap {
 public:
  Tap(TapConfig config, TapSink& sink);
  ~Tap();
  Tap(const Tap&) = delete;
  Tap& operator=(const Tap&) = delete;

  /// Creates the readers; per-tick samples flow to the sink from then on.
  void start(dds::Participant& part);
  /// Takes what the keyed topics hold (status, reports, plans, tasks, summaries, control): call it often.
  void poll();
  /// Runs `f` under the tap's mutex (beside the sink's calls): a sink's flush, its own counters.
  void locked(const std::function<void()>& f);
  /// No sink call after this returns (the readers stay until the tap is destroyed).
  void close();
  /// The launcher's lifecycle state as last heard (-1: never).
  int launcher_state() const;
  std::map<std::string, ArmTapStats> stats();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tandem::record
