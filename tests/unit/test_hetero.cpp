// Heterogeneous modules (issue "manipulators of different type"): a module whose two arms are of different types
// (the identified 3R with a cartesian PPR, or with a redundant planar 4R), from the inverse kinematics of each type
// through the plant, the world's and the robots' checks of joint counts, the scenario loader's per-type keys, to
// the paper's task run by the embedded module (the distributed processes' components in one process).
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>

#include "tandem/model/manipulator.hpp"
#include "tandem/model/plant.hpp"
#include "tandem/robot/robot_core.hpp"
#include "tandem/sim/embedded.hpp"
#include "tandem/sim/hosted_module.hpp"
#include "tandem/sim/module_setup.hpp"
#include "tandem/sim/scenario_yaml.hpp"
#include "tandem/world/world_core.hpp"

namespace {

namespace mdl = tandem::model;
namespace ts = tandem::sim;
using mdl::JointVec;
using mdl::Vec3;

const ts::Scenario& scenario(const std::string& name) {
  static const ts::Scenario ppr = ts::load_scenario(std::string(TANDEM_SOURCE_DIR) + "/config/scenarios/hetero-ppr.yaml");
  static const ts::Scenario r4 = ts::load_scenario(std::string(TANDEM_SOURCE_DIR) + "/config/scenarios/hetero-4r.yaml");
  return name == "ppr" ? ppr : r4;
}

const ts::CaseConfig& case_of(const ts::Scenario& sc, const std::string& name) {
  for (const auto& c : sc.cases) {
    if (c.name == name) return c;
  }
  throw std::runtime_error(sc.source + " has no case " + name);
}

std::unique_ptr<mdl::Manipulator> model_of(mdl::ArmKind k) {
  switch (k) {
    case mdl::ArmKind::Planar3R: return mdl::make_manipulator(mdl::smart3s2());
    case mdl::ArmKind::CartesianPPR: return mdl::make_manipulator(mdl::cartesian_ppr());
    case mdl::ArmKind::Planar4R: return mdl::make_manipulator(mdl::planar_4r());
  }
  return nullptr;
}

/// A posture drawn inside the joint limits, within `spread` of the type's home (the 3R: of zero).
JointVec near_home(const mdl::Manipulator& arm, std::mt19937& rng, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread);
  JointVec q = arm.home();
  for (int i = 0; i < arm.dof(); ++i) {
    const auto ui = static_cast<size_t>(i);
    q(i) = std::clamp(q(i) + u(rng), arm.joints().q_min[ui] + 1e-3, arm.joints().q_max[ui] - 1e-3);
  }
  return q;
}

std::string yaml_with_right(const std::string& right) {
  return "name: t\nmodule:\n  object: {mass: 2.0, mu_s: 0.5}\n  robots:\n    - {name: left, elbow: -1, selection_p: [1, 1, 1]}\n    - " +
         right + "\ntask:\n  start: [-0.2, 0.8, 0.0]\n  segments:\n    - {to: [0.2, 0.8, 0.0], duration: 4.0}\n"
         "controllers:\n  sosm: {law: super_twisting}\ncases:\n  - {name: A, controller: sosm}\n";
}

std::string load_error(const std::string& yaml) {
  try {
    (void)ts::parse_scenario(yaml, "test.yaml");
  } catch (const ts::ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("every type's inverse kinematics puts the end-effector where asked, within the joint limits", "[hetero][manipulator]") {
  std::mt19937 rng(7);
  for (mdl::ArmKind k : {mdl::ArmKind::Planar3R, mdl::ArmKind::CartesianPPR, mdl::ArmKind::Planar4R}) {
    const auto arm = model_of(k);
    INFO(mdl::arm_kind_name(k));
    for (int trial = 0; trial < 50; ++trial) {
      // A target the arm reaches (the pose of a posture inside the limits), solved from a seed 0.3 away.
      const JointVec q_true = near_home(*arm, rng, 0.6);
      const Vec3 x = arm->forward_kinematics(q_true);
      const JointVec seed = arm->home() + 0.5 * (q_true - arm->home());
      const double branch = k == mdl::ArmKind::Planar3R ? (q_true(1) >= 0.0 ? 1.0 : -1.0) : 1.0;
      JointVec q;
      REQUIRE(arm->inverse_kinematics(x, seed, branch, q));
      REQUIRE(q.size() == arm->dof());
      const Vec3 back = arm->forward_kinematics(q);
      CHECK((back.head<2>() - x.head<2>()).norm() < 1e-9);
      CHECK(std::abs(mdl::wrap_angle(back(2) - x(2))) < 1e-9);
      if (k != mdl::ArmKind::Planar3R) CHECK(arm->within_limits(q));
    }
    // Out of reach: refused, and q untouched.
    JointVec q = JointVec::Constant(arm->dof(), 42.0);
    CHECK_FALSE(arm->inverse_kinematics(Vec3(10.0, 10.0, 0.0), arm->home(), 1.0, q));
    CHECK(q(0) == 42.0);
  }
}

TEST_CASE("4R: the inverse kinematics from a seed stays near it (the redundancy keeps one branch along a path)", "[hetero][manipulator]") {
  const auto arm = model_of(mdl::ArmKind::Planar4R);
  JointVec q = arm->home();
  const Vec3 x0 = arm->forward_kinematics(q);
  double worst_step = 0.0;
  for (int i = 1; i <= 200; ++i) {  // the tool moved 0.2 m back towards the base, 1 mm at a time, each from the last
    const Vec3 x = x0 - Vec3(1e-3 * i, 0.0, 0.0);
    JointVec next;
    REQUIRE(arm->inverse_kinematics(x, q, 1.0, next));
    worst_step = std::max(worst_step, (next - q).cwiseAbs().maxCoeff());
    q = next;
  }
  // 1 mm of tool motion moves no joint by more than a few mrad: the solution follows the seed continuously.
  CHECK(worst_step < 0.01);
}

TEST_CASE("a plant of two types: state, tips and efforts follow each arm's joint count", "[hetero][plant]") {
  for (const std::string name : {"ppr", "4r"}) {
    INFO(name);
    const ts::Scenario& sc = scenario(name);
    const ts::ModuleSetup m = ts::make_module(sc, case_of(sc, "SOSM"));
    mdl::ModulePlant plant(m.plant);
    plant.reset(m.initial);
    REQUIRE(plant.state().q[0].size() == 3);
    REQUIRE(plant.state().q[1].size() == sc.robots[1].dof());
    CHECK(sc.robots[1].dof() == (name == "ppr" ? 3 : 4));
    CHECK(plant.arm(1).kind() == (name == "ppr" ? mdl::ArmKind::CartesianPPR : mdl::ArmKind::Planar4R));
    // The tips are where eq. (15) puts them at t = 0: the grasp's preload inside each face.
    for (int j = 0; j < 2; ++j) {
      const mdl::ArmReference r0 = mdl::arm_reference(j, m.path.sample(0.0), m.geometry, m.reference_force);
      CHECK((plant.end_effector(j) - r0.x).norm() < 1e-9);
    }
    const mdl::ContactReading c = plant.contacts();
    CHECK(c.normal[0] == Approx(m.reference_force).epsilon(1e-6));
    CHECK(c.normal[1] == Approx(m.reference_force).epsilon(1e-6));
    // Holding torques (gravity + J^T h) keep the grasp still for 100 ms; an effort of the wrong size is no effort.
    for (int k = 0; k < 100; ++k) {
      mdl::ArmEfforts tau;
      for (int j = 0; j < 2; ++j) {
        const auto& q = plant.state().q[static_cast<size_t>(j)];
        const mdl::ContactReading cr = plant.contacts();
        tau[static_cast<size_t>(j)] =
            plant.arm(j).gravity(q) + plant.arm(j).jacobian(q).transpose() * Vec3(cr.h[j](0), cr.h[j](1), 0.0);
      }
      plant.step(tau, 1e-3 * k, 1e-3, 10);
    }
    CHECK((plant.state().c - m.initial.c).norm() < 1e-3);
    CHECK(plant.counters().slip_events == 0);
    mdl::ArmEfforts wrong{JointVec::Zero(2), JointVec::Constant(sc.robots[1].dof() == 3 ? 4 : 3, 1e9)};
    plant.step(wrong, 0.1, 1e-3, 10);
    CHECK(plant.state().q[1].size() == sc.robots[1].dof());
    CHECK(plant.state().q[1].allFinite());
    CHECK(plant.counters().torque_saturated == 0);  // treated as zero, not clipped
  }
}

TEST_CASE("the world and the robots refuse a command or a sample of another joint count", "[hetero][components]") {
  const ts::Scenario& sc = scenario("4r");
  const ts::ModuleSetup m = ts::make_module(sc, case_of(sc, "SOSM"));
  tandem::world::WorldOptions o;
  o.arm_ids = {"m1/left", "m1/right"};
  o.arm_names = {"left", "right"};
  o.realtime = false;
  tandem::world::WorldCore w(m, o);
  std::array<tandem::world::SampleOut, 2> out{};
  w.begin_tick(0, 0, out);
  CHECK(out[0].q.size() == 3);
  CHECK(out[1].q.size() == 4);
  CHECK(out[1].tau_applied.size() == 4);
  // The right arm is a 4R: a 3-joint command is refused, a 4-joint one applied.
  CHECK(w.on_command(1, 0, JointVec::Zero(3), 100, 0, false) == tandem::world::WorldCore::Verdict::Rejected);
  CHECK(w.on_command(1, 0, out[1].tau_applied, 100, 0, false) == tandem::world::WorldCore::Verdict::Applied);
  CHECK(w.on_command(0, 0, JointVec::Zero(4), 100, 0, false) == tandem::world::WorldCore::Verdict::Rejected);

  tandem::robot::RobotCore r(m, 1, false, 0.1);
  tandem::plan::ModulePlan plan(m, false);
  tandem::plan::PlanData p;
  plan.export_to(p);
  p.supervisor_id = "m1/supervisor";
  REQUIRE(r.offer_plan(p) == tandem::plan::PlanFollower::Offer::Adopted);
  mdl::ArmSensors bad;
  bad.q = out[1].q.head(3);
  bad.qd = out[1].qd.head(3);
  bad.h = out[1].h;
  CHECK_FALSE(r.on_sample(0, bad, false).has_value());
  CHECK(r.rejected() == 1);
  mdl::ArmSensors good;
  good.q = out[1].q;
  good.qd = out[1].qd;
  good.h = out[1].h;
  const auto tau = r.on_sample(0, good, false);
  REQUIRE(tau.has_value());
  CHECK(tau->size() == 4);
  CHECK(tau->allFinite());
}

TEST_CASE("heterogeneous modules run the paper's task with the super-twisting law and keep the grasp", "[hetero][sim]") {
  for (const std::string name : {"ppr", "4r"}) {
    const ts::Scenario& sc = scenario(name);
    for (const std::string cs : {"SOSM", "SOSM-u"}) {
      INFO(name << " " << cs);
      const ts::CaseResult r = ts::run_case(sc, case_of(sc, cs), ts::RunOptions{false});
      CHECK(r.finite);
      CHECK(r.counters.slip_events == 0);
      CHECK(r.counters.contact_lost == 0);
      CHECK(r.counters.joint_limit == 0);
      // eq. (14): the normal force never below the safe grasp force after the start-up transient.
      CHECK(r.robots[0].min_normal_force >= r.safe_grasp_force);
      CHECK(r.robots[1].min_normal_force >= r.safe_grasp_force);
      CHECK(r.grasp_held());
      // The object ends where the task puts it (the paper's 0.4 m move), to a millimetre.
      CHECK(r.object_final_error < 1e-3);
      // The super-twisting law tracks as it does on the homogeneous module: sub-millimetre position RMS.
      CHECK(r.robots[1].ep_sel_rms < 1e-3);
      CHECK(r.robots[0].ep_pos_rms < 1e-3);
    }
  }
}

TEST_CASE("4R: its joint rates stay bounded over the paper's task, and the null-space posture holds", "[hetero][sim]") {
  const ts::Scenario& sc = scenario("4r");
  const ts::ModuleSetup m = ts::make_module(sc, case_of(sc, "SOSM-u"));
  ts::HostedModule mod(m, sc.transient);
  const mdl::ModulePlant& plant = mod.world().plant();
  double max_rate = 0.0, max_posture = 0.0;
  for (long k = 0; k < m.steps; ++k) {
    REQUIRE(mod.tick());
    const JointVec& qd = plant.state().qd[1];
    max_rate = std::max(max_rate, qd.cwiseAbs().maxCoeff());
    max_posture = std::max(max_posture, (plant.state().q[1] - m.control[1].null_space.q_rest).cwiseAbs().maxCoeff());
  }
  INFO("max joint rate " << max_rate << " rad/s, max posture offset " << max_posture << " rad");
  // Peak tool speed is about 0.2 m/s on links of 0.3-0.55 m: joint rates of that order; a drifting self-motion
  // (no null-space damping) would grow without bound under the disturbance.
  CHECK(max_rate < 1.5);
  // The task moves the tool 0.4 m, so the posture must change; it stays within one radian of the rest posture.
  CHECK(max_posture < 1.0);
}

TEST_CASE("the scenario loader checks each robot's type, posture and per-joint lists", "[hetero][scenario]") {
  // Accepted: each type, with its lists of its joint count.
  CHECK(load_error(yaml_with_right("{name: right, type: cartesian_ppr, selection_p: [1, 0, 1]}")) == "");
  CHECK(load_error(yaml_with_right("{name: right, type: planar_4r, selection_p: [1, 0, 1], posture: [-0.3, -0.6, -0.6, "
                                   "-0.07], arm: {effort_max: [3000, 1500, 800, 500], q_min: [-3, -3, -3, -3]}}")) == "");
  const ts::Scenario ok = ts::parse_scenario(
      yaml_with_right("{name: right, type: planar_4r, posture: [-0.3, -0.6, -0.6, -0.07], arm: {link_length: [0.5, 0.5, "
                      "0.3, 0.34], mass: [20, 12, 6, 4]}}"),
      "ok.yaml");
  CHECK(ok.robots[1].type == mdl::ArmKind::Planar4R);
  CHECK(ok.robots[1].posture_given);
  CHECK(ok.robots[1].chain.bodies[1].length == 0.5);
  CHECK(ok.robots[1].chain.bodies[1].com == 0.25);
  CHECK(ok.robots[1].chain.bodies[1].inertia == Approx(12.0 * 0.25 / 12.0));
  // Refused, each naming the key and what is accepted.
  std::string e = load_error(yaml_with_right("{name: right, type: scara}"));
  CHECK(e.find("robots[1].type") != std::string::npos);
  CHECK(e.find("planar_3r, cartesian_ppr, planar_4r") != std::string::npos);
  e = load_error(yaml_with_right("{name: right, type: planar_4r, arm: {q_min: [0, 0, 0]}}"));
  CHECK(e.find("robots[1].arm.q_min") != std::string::npos);
  CHECK(e.find("a list of 4 numbers") != std::string::npos);
  e = load_error(yaml_with_right("{name: right, type: cartesian_ppr, model: smart3s2}"));
  CHECK(e.find("robots[1].model") != std::string::npos);
  e = load_error(yaml_with_right("{name: right, posture: [0, 0, 0]}"));
  CHECK(e.find("robots[1].posture") != std::string::npos);
  e = load_error(yaml_with_right("{name: right, type: cartesian_ppr, arm: {link_length: [0.2, 0, 0.34]}}"));
  CHECK(e.find("prismatic") != std::string::npos);
  e = load_error(yaml_with_right("{name: right, type: cartesian_ppr, arm: {q_min: [0, 0, 0], q_max: [0, 1, 1]}}"));
  CHECK(e.find("q_min must be below q_max") != std::string::npos);
  // A posture from which the arm cannot reach its start: make_module says which robot and what to change.
  const ts::Scenario far = ts::parse_scenario(
      yaml_with_right("{name: right, type: cartesian_ppr, arm: {q_min: [-0.1, -0.5, -4], q_max: [0.1, 1.8, 4]}}"), "far.yaml");
  try {
    (void)ts::make_module(far, far.cases[0]);
    FAIL("a PPR whose carriage cannot reach the object was accepted");
  } catch (const std::invalid_argument& ex) {
    CHECK(std::string(ex.what()).find("robot 'right' (cartesian_ppr) cannot reach") != std::string::npos);
  }
}
