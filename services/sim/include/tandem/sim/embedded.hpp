// Embedded simulation of one basic module: world (plant), supervisor (eq. 15-16) and two robots
// (hybrid controllers) wired in one process, deterministically, with no middleware.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario.hpp"

namespace tandem::sim {

/// RMS and extremes of one robot over a run (RobotMeter's summary; "steady" is the final hold after the
/// object's motion ends; position RMS is of the Euclidean norm of the (x, y) error), and the gains used.
struct RobotMetrics : RobotMeter::Summary {
  model::Vec3 gains = model::Vec3::Zero();  ///< K (or K_P for PD) per contact-frame axis actually used
};

struct CaseResult {
  std::string name;
  std::string controller;
  std::string paper_case;
  bool disturbance = false;
  bool require_grasp = true;
  std::array<RobotMetrics, 2> robots{};
  model::PlantCounters counters{};
  double safe_grasp_force = 0.0;   ///< h_sg of eq. (16) [N]
  double reference_force = 0.0;    ///< h_ref [N]
  double object_pos_rms = 0.0;     ///< object centre vs the planned path [m]
  double object_final_error = 0.0; ///< at the end of the run [m]
  bool finite = true;              ///< no NaN or inf appeared
  double diverged_at = -1.0;       ///< time of the first NaN/inf [s], -1 if none
  model::ModuleState final_state{}; ///< plant state at the end of the run
  bool grasp_held() const {
    return finite && counters.slip_events == 0 && counters.contact_lost == 0 &&
           robots[0].min_normal_force >= safe_grasp_force && robots[1].min_normal_force >= safe_grasp_force;
  }
  /// Failure description, empty when the grasp held.
  std::string failure() const;
};

/// One row of the time series (one control period).
struct SeriesRow {
  double t;
  std::array<model::Vec3, 2> x, xd, s;
  std::array<model::JointVec, 2> tau;  ///< each of its arm's joint count
  std::array<double, 2> normal, e_h;
  model::Vec2 obj_c, obj_ref;
  double obj_psi;
};

struct RunOptions {
  bool record = true;  ///< keep the time series
};

/// Builds and runs one case of the scenario.
CaseResult run_case(const Scenario& sc, const CaseConfig& cc, const RunOptions& opt = {},
                    std::vector<SeriesRow>* series = nullptr);

/// Writes the time series as CSV.
void write_csv(const std::string& path, const std::vector<SeriesRow>& rows, const Scenario& sc);

/// The paper's Table IV (robot on the right), by case name.
struct PaperRow {
  const char* name;
  double ep_rms;
  double eh_rms;
};
const PaperRow* paper_table_iv(const std::string& name);

}  // namespace tandem::sim
