// A basic module hosted in one process: the world, the supervisor and the two robots are the same components
// (world::WorldCore, supervisor::SupervisorCore, robot::RobotCore) that the distributed processes run, wired in
// the lockstep order with no DDS and no clock. `tandem sim` (run_case) runs on it, so that the embedded run and
// the distributed run share one code path, not just one result.
#pragma once

#include <array>
#include <optional>

#include "tandem/robot/robot_core.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/supervisor/supervisor_core.hpp"
#include "tandem/world/world_core.hpp"

namespace tandem::sim {

/// The world's report as the supervisor hears it (WorldReport on the wire, converted by the processes).
supervisor::ReportIn supervisor_input(const world::ReportOut& r);

class HostedModule {
 public:
  /// `transient`: the start-up interval the robots' meters and the supervisor's grasp watch leave out [s].
  HostedModule(const ModuleSetup& m, double transient);

  /// One lockstep tick: the world samples, the supervisor hears the report when one is due and publishes its
  /// plan when it changes, each robot answers its sample, the world applies the torques and steps the plant.
  /// Returns false when a robot had no answer (no plan yet) or the world refused a command: the run cannot go on.
  bool tick();

  long k() const { return k_; }
  const world::WorldCore& world() const { return world_; }
  const robot::RobotCore& robot(int j) const { return *robots_[static_cast<size_t>(j)]; }

 private:
  const ModuleSetup& m_;
  world::WorldCore world_;
  supervisor::SupervisorCore sup_;
  std::array<std::optional<robot::RobotCore>, 2> robots_;
  std::array<world::SampleOut, 2> out_{};
  long k_ = 0;
};

}  // namespace tandem::sim
