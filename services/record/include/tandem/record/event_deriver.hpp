// The recorder's events (lifecycle changes, failovers and takeovers, brakes and releases, load pauses, a dropped
// object, tasks assigned and done, live commands) derived from what the deployment reports: a component with
// plain data in and events out, no DDS and no file inside. `tandem record` feeds it the samples it takes and
// writes what it returns to the recording's tandem/events channel; tests/unit/test_record.cpp drives it with
// made-up reports. docs/recording.md, "Events".
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace tandem::record {

/// One derived event, as the recording's tandem.record.Event carries it.
struct DerivedEvent {
  std::string kind;     ///< lifecycle, failover, takeover, brake, release, load_pause, load_resume,
                        ///< module_failed, task_assigned, task_done, control
  std::string module;   ///< "" for deployment-wide events
  std::string subject;  ///< the process, arm, task or target it is about
  std::string detail;
  uint64_t tick = 0;    ///< the world's tick it happened at (0 if none)
};

/// Who an arm follows (from the world's owners).
struct ArmOwnerView {
  std::string arm;
  bool served = false;   ///< a robot serves it (else it is stopping or braked)
  int strength = 0;      ///< served: that robot's strength
  std::string text;      ///< for people: the robot's label, or stopping / braked / braked(load)
};

/// What an event needs of a world's report.
struct WorldView {
  uint64_t tick = 0;
  std::array<bool, 2> braked{};
  bool load_paused = false;
  bool failed = false;
  std::string failure;
  std::vector<ArmOwnerView> owners;
};

class EventDeriver {
 public:
  /// A process's status: an event when its lifecycle state changes (the first one heard: "(new) -> ...").
  std::vector<DerivedEvent> on_status(const std::string& process, const std::string& module, int state,
                                      const std::string& detail, uint64_t tick);
  /// A world's report. From the second report of a module on: brake / release per arm, load_pause /
  /// load_resume, module_failed once when the world reports its object dropped, and for each arm whose robot
  /// changed a failover (to a weaker robot: the one it followed died or left) or a takeover (to a stronger
  /// one: a restarted or plugged robot came back). Braked or stopping in between is neither: the brake and
  /// release events tell those.
  std::vector<DerivedEvent> on_world(const std::string& module, const WorldView& w);
  /// A task assignment: one event per task id.
  std::vector<DerivedEvent> on_assignment(uint64_t task_id, const std::string& module, const std::string& name);
  /// A module's task state: an event when its count of tasks done grows.
  std::vector<DerivedEvent> on_task_state(const std::string& module, uint64_t task_id, uint64_t tasks_done, uint64_t tick);
  /// A live command addressed to the deployment.
  std::vector<DerivedEvent> on_control(const std::string& command, const std::string& target, const std::string& option);

  /// "left=m1/left@50,right=braked".
  static std::string owners_text(const std::vector<ArmOwnerView>& owners);

 private:
  struct WorldPrev {
    std::array<bool, 2> braked{};
    bool load_paused = false;
    bool failed = false;
    std::string owners;                   ///< as text, for the event's detail
    std::map<std::string, int> strength;  ///< arm -> strength of the robot it follows (0: none)
  };
  std::map<std::string, int> states_;
  std::map<std::string, WorldPrev> worlds_;
  std::set<uint64_t> tasks_seen_;
  std::map<std::string, uint64_t> tasks_done_;
};

/// A lifecycle state's name (ProcessStatus.state): unconfigured, inactive, active, finalized, error.
const char* lifecycle_state_name(int state);

}  // namespace tandem::record
