// Everything a basic module needs to run, built from a scenario and one of its cases. The embedded
// simulation and the distributed processes (world, supervisor, robots) build their parts from the same
// ModuleSetup, so that both compute the same numbers.
#pragma once

#include <array>

#include "tandem/model/controller.hpp"
#include "tandem/model/plant.hpp"
#include "tandem/model/reference.hpp"
#include "tandem/sim/scenario.hpp"

namespace tandem::sim {

struct ModuleSetup {
  model::ModuleParams plant;                 ///< world: arms, object, contacts, disturbance
  model::ModuleState initial;                ///< safe-grasp start: arms on their references, at rest
  model::ObjectPath path;                    ///< supervisor: the object's task
  model::GraspGeometry geometry;             ///< supervisor: eq. (15) with the preload h_ref / K_S
  double safe_grasp_force = 0.0;             ///< h_sg, eq. (16) [N]
  double reference_force = 0.0;              ///< h_ref = factor x h_sg [N]
  std::array<model::HybridParams, 2> control{};  ///< each robot's controller
  double period = 1e-3;
  int substeps = 10;
  long steps = 0;                            ///< control periods in the run
};

/// Builds the module of one case. Throws std::invalid_argument (naming the scenario file) if an arm cannot
/// reach its initial reference or the case names an unknown controller.
ModuleSetup make_module(const Scenario& sc, const CaseConfig& cc);

/// Gains K per contact-frame axis that meet eq. (33)-(34) for robot j along the scenario's path,
/// with the given disturbance on or off. Evaluated on the reference trajectory (inverse kinematics).
model::Vec3 reaching_condition_gains(const Scenario& sc, int j, const ControllerConfig& cc, bool disturbance,
                                     double disturbance_scale);

/// The supervisor's reference for arm j at tick k (eq. 15 on the planned object pose at t = k T).
inline model::ArmReference supervisor_reference(const ModuleSetup& m, int j, long k) {
  const double t = static_cast<double>(k) * m.period;
  return model::arm_reference(j, m.path.sample(t), m.geometry, m.reference_force);
}

/// Accumulates one robot's RMS and extremes, tick by tick (the metrics of RobotMetrics).
class RobotMeter {
 public:
  RobotMeter(const model::Vec3& selection_p, double transient, double motion_end)
      : sel_(selection_p), transient_(transient), motion_end_(motion_end) {}
  void add(double t, const model::ArmReference& ref, const model::ControlOutput& out) noexcept;
  /// RMS over every tick ("steady": the ticks after the planned motion ends), extremes after the transient.
  struct Summary {
    double ep_pos_rms = 0.0;  ///< ||(x_d - x)_xy|| [m]
    double ep_ori_rms = 0.0;  ///< |phi_d - phi| [rad]
    double ep_sel_rms = 0.0;  ///< position components selected by Sigma_p (contact frame) [m]
    double eh_rms = 0.0;      ///< |h_ref - h_n| [N]
    double ep_pos_rms_steady = 0.0;
    double ep_ori_rms_steady = 0.0;
    double eh_rms_steady = 0.0;
    double ep_pos_max = 0.0;
    double min_normal_force = 0.0;  ///< after the start-up transient [N]
    double max_normal_force = 0.0;
  };
  Summary summary() const noexcept;

 private:
  struct Rms {
    double sum = 0.0;
    long n = 0;
    void add(double v) noexcept {
      sum += v * v;
      ++n;
    }
    double value() const noexcept;
  };
  model::Vec3 sel_;
  double transient_, motion_end_;
  Rms pos_, ori_, sel_rms_, eh_, pos_ss_, ori_ss_, eh_ss_;
  double max_ep_ = 0.0, min_n_ = 1e300, max_n_ = 0.0;
};

}  // namespace tandem::sim
