// Scenario of the embedded simulation: one basic module, a task, named controller settings and the cases
// to run. Plain structs with defaults in code; the YAML loader (scenario_yaml.hpp) fills them.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "tandem/model/controller.hpp"
#include "tandem/model/manipulator.hpp"
#include "tandem/model/plant.hpp"
#include "tandem/model/reference.hpp"

namespace tandem::sim {

struct RobotConfig {
  std::string name;
  /// The manipulator's type (manipulator.hpp): the identified 3R (`arm`), or a chain type (`chain`).
  model::ArmKind type = model::ArmKind::Planar3R;
  model::ArmParams arm = model::smart3s2();
  model::ChainParams chain{};             ///< the cartesian PPR or planar 4R (type != Planar3R)
  /// The scenario gave the chain's posture (else an arm on the right mirrors the type's left-arm home).
  bool posture_given = false;
  double elbow = 1.0;                     ///< elbow branch of the initial inverse kinematics (+1 or -1)
  model::Vec3 selection_p{1.0, 0.0, 1.0}; ///< diagonal of Sigma_p (eq. 17) in the contact frame
  int dof() const { return type == model::ArmKind::Planar3R ? 3 : chain.joints.dof; }
};

struct ControllerConfig {
  std::string name;
  model::LawGains law{};
  model::Compensation comp{};
  bool feedforward_position = false;
  bool feedforward_force = true;
  /// Replace K by the reaching-condition bound of eq. (33)-(34) times this factor (0: keep K).
  double reaching_gain_factor = 0.0;
  double reaching_margin = 1.0;  ///< eta_p / eta_h of eq. (33)-(34) [m/s^2]
};

struct CaseConfig {
  std::string name;
  std::string controller;        ///< name of a ControllerConfig
  bool disturbance = false;      ///< eq. (37) on the robots listed in Scenario::disturbed_robots
  double disturbance_scale = 1.0;
  bool require_grasp = true;     ///< a lost grasp in this case fails the run
  std::string paper_case;        ///< Table IV row to print beside it ("" for none)
};

struct Scenario {
  std::string name;
  std::string source;  ///< file it was read from
  // timing
  double period = 1.0e-3;
  int substeps = 10;
  double duration = 5.0;
  double transient = 0.1;  ///< start-up interval excluded from the grasp-force check [s]
  // module
  double base_distance = 2.0;
  double base_height = 0.0;
  std::array<RobotConfig, 2> robots{};
  model::ObjectParams object{};
  model::ContactParams contact{};
  double grasp_safety_factor = 1.5;  ///< h_ref = factor * h_sg (eq. 16)
  double g0 = 9.81;
  // task
  model::Vec3 start{0.0, 0.8, 0.0};
  double hold = 0.5;
  std::vector<model::ObjectPath::Segment> segments;
  // controllers and cases
  std::vector<ControllerConfig> controllers;
  std::vector<CaseConfig> cases;
  std::vector<int> disturbed_robots{1};
  int report_robot = 1;  ///< robot whose RMS is compared with Table IV (the paper's "robot on the right")

  const ControllerConfig* find_controller(const std::string& n) const;
};

}  // namespace tandem::sim
