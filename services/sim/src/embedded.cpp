#include "tandem/sim/embedded.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "tandem/model/grasp.hpp"
#include "tandem/sim/hosted_module.hpp"
#include "tandem/sim/module_setup.hpp"

namespace tandem::sim {
namespace {

using model::Vec3;

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

  // World, supervisor and the two robots: the distributed processes' components, hosted in one process.
  HostedModule mod(m, sc.transient);
  const model::ModulePlant& plant = mod.world().plant();
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
  long saturated = 0;
  for (long k = 0; k < m.steps; ++k) {
    const double t = static_cast<double>(k) * m.period;
    const model::PoseSample ps = m.path.sample(t);
    obj.add((plant.state().c - ps.pose.head<2>()).norm());
    SeriesRow row{};
    if (series != nullptr && opt.record) {
      row.t = t;
      row.obj_c = plant.state().c;
      row.obj_ref = ps.pose.head<2>();
      row.obj_psi = plant.state().psi;
    }
    const bool ok = mod.tick();
    // The robots clip their commands at tau_max (as the drives would): a period in which either did counts.
    if (ok && (mod.robot(0).last_saturated() || mod.robot(1).last_saturated())) ++saturated;
    for (int j = 0; j < 2; ++j) {
      const robot::RobotCore& r = mod.robot(j);
      if (!ok || r.done() != k || !r.last_tau().allFinite()) continue;
      const model::ControlOutput& out = r.last_output();
      const model::ArmReference& ref = r.last_reference();
      row.x[j] = ref.x - out.e_p;
      row.xd[j] = ref.x;
      row.tau[j] = out.tau;
      row.s[j] = out.s;
      row.normal[j] = out.normal_force;
      row.e_h[j] = out.e_h;
    }
    if (series != nullptr && opt.record) series->push_back(row);
    const auto& st = plant.state();
    if (!ok || !mod.robot(0).last_tau().allFinite() || !mod.robot(1).last_tau().allFinite()) {
      res.finite = false;
      res.diverged_at = t;
      break;
    }
    if (!st.c.allFinite() || !st.q[0].allFinite() || !st.q[1].allFinite()) {
      res.finite = false;
      res.diverged_at = t + m.period;
      break;
    }
  }
  for (int j = 0; j < 2; ++j) static_cast<RobotMeter::Summary&>(res.robots[j]) = mod.robot(j).summary();
  res.counters = plant.counters();
  res.counters.torque_saturated = saturated;
  res.object_pos_rms = obj.value();
  res.object_final_error = (plant.state().c - m.path.sample(sc.duration).pose.head<2>()).norm();
  res.final_state = plant.state();
  return res;
}

void write_csv(const std::string& path, const std::vector<SeriesRow>& rows, const Scenario& sc) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write the time series");
  out << "t";
  for (int j = 0; j < 2; ++j) {
    const std::string n = sc.robots[j].name;
    for (const char* f : {"x", "y", "phi"}) out << "," << n << "_" << f;
    for (const char* f : {"x_d", "y_d", "phi_d"}) out << "," << n << "_" << f;
    for (int i = 0; i < sc.robots[j].dof(); ++i) out << "," << n << "_tau" << i + 1;
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
      for (int i = 0; i < 3; ++i) put(r.x[j](i));
      for (int i = 0; i < 3; ++i) put(r.xd[j](i));
      for (int i = 0; i < sc.robots[j].dof(); ++i) put(i < r.tau[j].size() ? r.tau[j](i) : 0.0);
      for (int i = 0; i < 3; ++i) put(r.s[j](i));
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
