#include "tandem/sim/embedded.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "tandem/model/grasp.hpp"
#include "tandem/sim/module_setup.hpp"

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
  for (int j : sc.disturbed_robots) {
    mp.disturbance[j].enabled = cc.disturbance;
    mp.disturbance[j].scale = cc.disturbance_scale;
  }
  return mp;
}

struct Rms {
  double sum = 0.0;
  long n = 0;
  void add(double v) {
    sum += v * v;
    ++n;
  }
  double value() const { return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0; }
};

}  // namespace

std::string CaseResult::failure() const {
  std::ostringstream os;
  if (!finite) os << "the simulation diverged (NaN/inf at t = " << diverged_at << " s); ";
  if (counters.slip_events > 0) {
    os << "the object slipped (" << counters.slip_events << " slip substeps, " << counters.slip_distance
       << " m); ";
  }
  if (counters.contact_lost > 0) os << "a contact opened (" << counters.contact_lost << " substeps); ";
  if (counters.torque_saturated > 0) os << "torque limit hit in " << counters.torque_saturated << " periods; ";
  if (counters.joint_limit > 0) os << "joint limit exceeded in " << counters.joint_limit << " periods; ";
  for (int j = 0; j < 2; ++j) {
    if (robots[j].min_normal_force < safe_grasp_force) {
      os << "robot " << j << " grasp force fell to " << robots[j].min_normal_force << " N < h_sg "
         << safe_grasp_force << " N; ";
    }
  }
  std::string s = os.str();
  if (s.size() >= 2) s.resize(s.size() - 2);
  return s;
}

Vec3 reaching_condition_gains(const Scenario& sc, int j, const ControllerConfig& cc, bool disturbance,
                              double disturbance_scale) {
  const model::ModuleParams mp = module_params(sc, CaseConfig{});
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
  for (double t = 0.0; t <= sc.duration; t += 0.01) {
    const model::ArmReference ref = model::arm_reference(j, path.sample(t), geom, h_ref);
    Vec3 q;
    if (!model::inverse_kinematics(mp.arms[j], ref.x, sc.robots[j].elbow, q)) continue;
    const model::Mat3 R = model::contact_frame(ref.x(2));
    const model::Mat3 Jc = R.transpose() * model::jacobian(mp.arms[j], q);
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
    const Vec3 eta = twisting ? d.rate_bound() : d.bound();
    // After reaching, e' is small: the m e' term of eq. (33)-(34) is covered by the margin.
    const Vec3 m = model::LawGains::pick(sel_p, cc.law.m_p, cc.law.m_h);
    worst = worst.cwiseMax(model::reaching_gain_bound(Jc, eta, ref_term, m, Vec3::Zero(), cc.reaching_margin));
  }
  return worst;
}

CaseResult run_case(const Scenario& sc, const CaseConfig& cc, const RunOptions& opt,
                    std::vector<SeriesRow>* series) {
  const ModuleSetup m = make_module(sc, cc);
  CaseResult res;
  res.name = cc.name;
  res.controller = cc.controller;
  res.paper_case = cc.paper_case;
  res.disturbance = cc.disturbance;
  res.require_grasp = cc.require_grasp;
  res.safe_grasp_force = m.safe_grasp_force;
  res.reference_force = m.reference_force;

  // World, supervisor and the two robots, wired in one process.
  model::ModulePlant plant(m.plant);
  plant.reset(m.initial);
  std::array<model::HybridController, 2> ctl{model::HybridController(m.plant.arms[0], m.control[0]),
                                              model::HybridController(m.plant.arms[1], m.control[1])};
  const double motion_end = m.path.motion_end();
  std::array<RobotMeter, 2> meter{RobotMeter(m.control[0].selection_p, sc.transient, motion_end),
                                  RobotMeter(m.control[1].selection_p, sc.transient, motion_end)};
  for (int j = 0; j < 2; ++j) {
    const model::HybridParams& hp = m.control[j];
    res.robots[j].gains = hp.law.type == model::LawType::PD
                              ? model::LawGains::pick(hp.selection_p, hp.law.kp_p, hp.law.kp_h)
                              : model::LawGains::pick(hp.selection_p, hp.law.K_p, hp.law.K_h);
  }
  if (series != nullptr && opt.record) {
    series->clear();
    series->reserve(static_cast<size_t>(m.steps));
  }
  Rms obj;
  for (long k = 0; k < m.steps; ++k) {
    const double t = static_cast<double>(k) * m.period;
    const model::ContactReading contact = plant.contacts();  // world: sensor sample of tick k
    std::array<Vec3, 2> tau;
    SeriesRow row{};
    for (int j = 0; j < 2; ++j) {
      const model::ArmReference ref = supervisor_reference(m, j, k);  // supervisor, eq. (15)
      model::ArmSensors in;
      in.q = plant.state().q[j];
      in.qd = plant.state().qd[j];
      in.h = contact.h[j];
      const model::ControlOutput out = ctl[j].step(in, ref);  // robot j
      tau[j] = out.tau;
      meter[j].add(t, ref, out);
      if (!tau[j].allFinite()) res.finite = false;
      row.x[j] = ref.x - out.e_p;
      row.xd[j] = ref.x;
      row.tau[j] = out.tau;
      row.s[j] = out.s;
      row.normal[j] = out.normal_force;
      row.e_h[j] = out.e_h;
    }
    const model::PoseSample ps = m.path.sample(t);
    obj.add((plant.state().c - ps.pose.head<2>()).norm());
    if (series != nullptr && opt.record) {
      row.t = t;
      row.obj_c = plant.state().c;
      row.obj_ref = ps.pose.head<2>();
      row.obj_psi = plant.state().psi;
      series->push_back(row);
    }
    if (!res.finite) {
      res.diverged_at = t;
      break;
    }
    plant.step(tau, t, m.period, m.substeps);  // world: torques held over the period
    const auto& st = plant.state();
    if (!st.c.allFinite() || !st.q[0].allFinite() || !st.q[1].allFinite()) {
      res.finite = false;
      res.diverged_at = t + m.period;
      break;
    }
  }
  for (int j = 0; j < 2; ++j) static_cast<RobotMeter::Summary&>(res.robots[j]) = meter[j].summary();
  res.counters = plant.counters();
  res.object_pos_rms = obj.value();
  res.object_final_error = (plant.state().c - m.path.sample(sc.duration).pose.head<2>()).norm();
  res.final_state = plant.state();
  return res;
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

  // Initial state: both arms on their references at t = 0, at rest, pressing with h_ref (safe grasp).
  const model::PoseSample p0 = m.path.sample(0.0);
  for (int j = 0; j < 2; ++j) {
    const model::ArmReference r0 = model::arm_reference(j, p0, m.geometry, m.reference_force);
    if (!model::inverse_kinematics(m.plant.arms[j], r0.x, sc.robots[j].elbow, m.initial.q[j])) {
      throw std::invalid_argument(sc.source + ": robot '" + sc.robots[j].name +
                                  "' cannot reach its initial reference; move task.start or the bases");
    }
  }
  m.initial.c = p0.pose.head<2>();
  m.initial.psi = -p0.pose(2);
  // Every pose of the task must be reachable by both arms (checked every 10 ms of the path).
  for (double t = 0.0; t <= sc.duration + 1e-9; t += 0.01) {
    for (int j = 0; j < 2; ++j) {
      const model::ArmReference r = model::arm_reference(j, m.path.sample(t), m.geometry, m.reference_force);
      model::Vec3 q;
      if (!model::inverse_kinematics(m.plant.arms[j], r.x, sc.robots[j].elbow, q)) {
        std::ostringstream os;
        os << sc.source << ": 'task': robot '" << sc.robots[j].name << "' cannot reach the planned object pose at t = "
           << t << " s (end-effector at " << r.x(0) << ", " << r.x(1) << "); shorten task.segments or move the bases";
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

void write_csv(const std::string& path, const std::vector<SeriesRow>& rows, const Scenario& sc) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write the time series");
  out << "t";
  for (int j = 0; j < 2; ++j) {
    const std::string n = sc.robots[j].name;
    for (const char* f : {"x", "y", "phi"}) out << "," << n << "_" << f;
    for (const char* f : {"x_d", "y_d", "phi_d"}) out << "," << n << "_" << f;
    for (const char* f : {"tau1", "tau2", "tau3"}) out << "," << n << "_" << f;
    for (const char* f : {"s_t", "s_a", "s_phi"}) out << "," << n << "_" << f;
    out << "," << n << "_normal_force," << n << "_e_h";
  }
  out << ",object_x,object_y,object_psi,object_x_ref,object_y_ref\n";
  char buf[64];
  auto put = [&](double v) {
    std::snprintf(buf, sizeof buf, ",%.9g", v);
    out << buf;
  };
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof buf, "%.4f", r.t);
    out << buf;
    for (int j = 0; j < 2; ++j) {
      for (const Vec3* v : {&r.x[j], &r.xd[j], &r.tau[j], &r.s[j]}) {
        for (int i = 0; i < 3; ++i) put((*v)(i));
      }
      put(r.normal[j]);
      put(r.e_h[j]);
    }
    put(r.obj_c(0));
    put(r.obj_c(1));
    put(r.obj_psi);
    put(r.obj_ref(0));
    put(r.obj_ref(1));
    out << "\n";
  }
}

const PaperRow* paper_table_iv(const std::string& name) {
  static const PaperRow rows[] = {
      {"PD", 5.9056e-4, 0.0049}, {"PD^u", 0.0025, 0.0202}, {"SM", 2.7119e-5, 5.6793e-4}, {"SM^u", 7.6518e-5, 5.0986e-4}};
  for (const auto& r : rows) {
    if (name == r.name) return &r;
  }
  return nullptr;
}

}  // namespace tandem::sim
