// The module built from a scenario and one of its cases (ModuleSetup), and the per-robot meter. No YAML here:
// the role components and the embedded simulation both build on this; the loader is scenario_yaml.cpp.
#include "tandem/sim/module_setup.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "tandem/model/grasp.hpp"

namespace tandem::sim {
namespace {

using model::Vec3;

model::GraspGeometry grasp_geometry(const Scenario& sc, double h_ref) {
  model::GraspGeometry g;
  g.stick_length[0] = g.stick_length[1] = sc.object.half_width;
  g.preload = h_ref / sc.contact.k_normal;
  return g;
}

model::ObjectPath object_path(const Scenario& sc) { return {sc.start, sc.hold, sc.segments}; }

model::ModuleParams module_params(const Scenario& sc, const CaseConfig& cc) {
  model::ModuleParams mp;
  for (int j = 0; j < 2; ++j) mp.arms[j] = sc.robots[j].arm;
  mp.arms[0].base = {-0.5 * sc.base_distance, sc.base_height};
  mp.arms[1].base = {0.5 * sc.base_distance, sc.base_height};
  mp.object = sc.object;
  mp.contact = sc.contact;
  mp.g0 = sc.g0;
  for (int j = 0; j < 2; ++j) mp.arms[j].g0 = sc.g0;
  for (int j = 0; j < 2; ++j) {
    const RobotConfig& rc = sc.robots[j];
    if (rc.type == model::ArmKind::Planar3R) {
      mp.models[j] = std::make_shared<const model::Planar3R>(mp.arms[j]);
      continue;
    }
    model::ChainParams c = rc.chain;
    c.joints.base = mp.arms[j].base;
    c.joints.g0 = sc.g0;
    if (j == 1 && !rc.posture_given) {
      // The type's home is a left arm's (reaching towards +x): the right arm mirrors its revolute joints.
      for (int i = 0; i < c.joints.dof; ++i) {
        if (c.bodies[static_cast<size_t>(i)].joint == model::JointType::Revolute) c.joints.home[static_cast<size_t>(i)] *= -1.0;
      }
    }
    mp.models[j] = std::make_shared<const model::PlanarChain>(c);
  }
  for (int j : sc.disturbed_robots) {
    mp.disturbance[j].enabled = cc.disturbance;
    mp.disturbance[j].scale = cc.disturbance_scale;
  }
  return mp;
}

}  // namespace

const ControllerConfig* Scenario::find_controller(const std::string& n) const {
  for (const auto& c : controllers) {
    if (c.name == n) return &c;
  }
  return nullptr;
}

Vec3 reaching_condition_gains(const Scenario& sc, int j, const ControllerConfig& cc, bool disturbance,
                              double disturbance_scale) {
  const model::ModuleParams mp = module_params(sc, CaseConfig{});
  const model::Manipulator& arm = *mp.models[j];
  const double h_ref = sc.grasp_safety_factor * model::safe_grasp_force(sc.object.mass, sc.object.mu_s, sc.g0);
  const model::GraspGeometry geom = grasp_geometry(sc, h_ref);
  const model::ObjectPath path = object_path(sc);
  model::Disturbance d;
  bool disturbed = false;
  for (int k : sc.disturbed_robots) disturbed = disturbed || k == j;
  d.enabled = disturbance && disturbed;
  d.scale = disturbance_scale;
  const Vec3 sel_p = sc.robots[j].selection_p;
  const bool twisting = cc.law.type == model::LawType::SuperTwisting;
  const double dt = 1e-3;
  Vec3 worst = Vec3::Zero();
  model::JointVec q = arm.home();
  for (double t = 0.0; t <= sc.duration; t += 0.01) {
    const model::ArmReference ref = model::arm_reference(j, path.sample(t), geom, h_ref);
    // Each sample's inverse kinematics starts from the previous one (a redundant arm stays on one branch).
    if (!arm.inverse_kinematics(ref.x, q, sc.robots[j].elbow, q)) continue;
    const model::Mat3 R = model::contact_frame(ref.x(2));
    const model::TaskJacobian Jc = R.transpose() * arm.jacobian(q);
    // Reference term that is not fed forward: x_d'' for the first-order law (eq. 33-34), and its rate
    // (the jerk) for super-twisting, whose gain must exceed the bound on the perturbation's derivative.
    Vec3 ref_term = R.transpose() * ref.xdd;
    if (twisting) {
      const model::ArmReference next = model::arm_reference(j, path.sample(t + dt), geom, h_ref);
      ref_term = R.transpose() * (next.xdd - ref.xdd) / dt;
    }
    for (int i = 0; i < 3; ++i) {
      const bool fed = sel_p(i) > 0.5 ? cc.feedforward_position : cc.feedforward_force;
      if (fed) ref_term(i) = 0.0;
    }
    const model::JointVec eta = twisting ? d.rate_bound(arm.dof()) : d.bound(arm.dof());
    // After reaching, e' is small: the m e' term of eq. (33)-(34) is covered by the margin.
    const Vec3 m = model::LawGains::pick(sel_p, cc.law.m_p, cc.law.m_h);
    worst = worst.cwiseMax(model::reaching_gain_bound(Jc, eta, ref_term, m, Vec3::Zero(), cc.reaching_margin));
  }
  return worst;
}

ModuleSetup make_module(const Scenario& sc, const CaseConfig& cc) {
  const ControllerConfig* ctrl = sc.find_controller(cc.controller);
  if (ctrl == nullptr) throw std::invalid_argument(sc.source + ": unknown controller '" + cc.controller + "'");
  ModuleSetup m;
  m.safe_grasp_force = model::safe_grasp_force(sc.object.mass, sc.object.mu_s, sc.g0);  // eq. (16)
  m.reference_force = sc.grasp_safety_factor * m.safe_grasp_force;
  m.plant = module_params(sc, cc);
  m.geometry = grasp_geometry(sc, m.reference_force);
  m.path = object_path(sc);
  m.period = sc.period;
  m.substeps = sc.substeps;
  m.steps = std::lround(sc.duration / sc.period);

  // Initial state: both arms on their references at t = 0, at rest, pressing with h_ref (safe grasp). The
  // inverse kinematics of a chain type starts from its home posture.
  const model::PoseSample p0 = m.path.sample(0.0);
  for (int j = 0; j < 2; ++j) {
    const model::Manipulator& arm = *m.plant.models[j];
    const model::ArmReference r0 = model::arm_reference(j, p0, m.geometry, m.reference_force);
    if (!arm.inverse_kinematics(r0.x, arm.home(), sc.robots[j].elbow, m.initial.q[j])) {
      throw std::invalid_argument(sc.source + ": robot '" + sc.robots[j].name + "' (" + model::arm_kind_name(arm.kind()) +
                                  ") cannot reach its initial reference within its joint limits; move task.start or the "
                                  "bases" + (arm.kind() == model::ArmKind::Planar3R ? "" : ", or give it a posture near it"));
    }
    m.initial.qd[j] = model::JointVec::Zero(arm.dof());
  }
  m.initial.c = p0.pose.head<2>();
  m.initial.psi = -p0.pose(2);
  // Every pose of the task must be reachable by both arms within their limits (checked every 10 ms of the path,
  // each sample's inverse kinematics from the previous one).
  std::array<model::JointVec, 2> q_path = m.initial.q;
  for (double t = 0.0; t <= sc.duration + 1e-9; t += 0.01) {
    for (int j = 0; j < 2; ++j) {
      const model::Manipulator& arm = *m.plant.models[j];
      const model::ArmReference r = model::arm_reference(j, m.path.sample(t), m.geometry, m.reference_force);
      if (!arm.inverse_kinematics(r.x, q_path[j], sc.robots[j].elbow, q_path[j]) ||
          (arm.kind() != model::ArmKind::Planar3R && !arm.within_limits(q_path[j]))) {
        std::ostringstream os;
        os << sc.source << ": 'task': robot '" << sc.robots[j].name << "' cannot reach the planned object pose at t = "
           << t << " s (end-effector at " << r.x(0) << ", " << r.x(1) << ")" << " within its joint limits"
           << "; shorten task.segments or move the bases";
        throw std::invalid_argument(os.str());
      }
    }
  }

  for (int j = 0; j < 2; ++j) {
    model::HybridParams& hp = m.control[j];
    hp.selection_p = sc.robots[j].selection_p;
    hp.contact_stiffness = sc.contact.k_normal;
    hp.feedforward_position = ctrl->feedforward_position;
    hp.feedforward_force = ctrl->feedforward_force;
    hp.law = ctrl->law;
    hp.comp = ctrl->comp;
    hp.period = sc.period;
    // A redundant arm's null-space rest posture: its initial one, the same for every robot of the arm (a standby or
    // a restarted robot then continues the primary's posture task: bumpless).
    if (m.plant.models[j]->dof() > 3) hp.null_space.q_rest = m.initial.q[j];
    if (ctrl->reaching_gain_factor > 0.0) {
      // eq. (33)-(34): position axes take their bound, the force axis the bound of the approach axis.
      const Vec3 k = ctrl->reaching_gain_factor *
                     reaching_condition_gains(sc, j, *ctrl, cc.disturbance, cc.disturbance_scale);
      for (int i = 0; i < 3; ++i) {
        if (hp.selection_p(i) > 0.5) hp.law.K_p(i) = k(i);
      }
      if (hp.selection_p(1) < 0.5) hp.law.K_h = k(1);
    }
  }
  return m;
}

void RobotMeter::add(double t, const model::ArmReference& ref, const model::ControlOutput& out) noexcept {
  const double e_pos = out.e_p.head<2>().norm();
  const Vec3 e_sel = sel_.cwiseProduct(model::contact_frame(ref.x(2)).transpose() * out.e_p);
  pos_.add(e_pos);
  ori_.add(out.e_p(2));
  eh_.add(out.e_h);
  sel_rms_.add(std::hypot(e_sel(0), e_sel(1)));
  max_ep_ = std::max(max_ep_, e_pos);
  if (t >= motion_end_) {
    pos_ss_.add(e_pos);
    ori_ss_.add(out.e_p(2));
    eh_ss_.add(out.e_h);
  }
  if (t >= transient_) {
    min_n_ = std::min(min_n_, out.normal_force);
    max_n_ = std::max(max_n_, out.normal_force);
  }
}

double RobotMeter::Rms::value() const noexcept { return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0; }

RobotMeter::Summary RobotMeter::summary() const noexcept {
  return {pos_.value(),    ori_.value(),    sel_rms_.value(), eh_.value(), pos_ss_.value(),
          ori_ss_.value(), eh_ss_.value(), max_ep_,          min_n_,      max_n_};
}

}  // namespace tandem::sim
