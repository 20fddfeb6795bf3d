#include "tandem/model/plant.hpp"

#include <algorithm>
#include <cmath>

namespace tandem::model {
namespace {

Mat2 rotation(double psi) {
  Mat2 R;
  R << std::cos(psi), -std::sin(psi), std::sin(psi), std::cos(psi);
  return R;
}

// Outward normal of face j in the object frame: the left face (j = 0) faces -x, the right face +x.
Vec2 face_normal(int j) { return {j == 0 ? -1.0 : 1.0, 0.0}; }
const Vec2 kFaceTangent{0.0, 1.0};

double cross2(const Vec2& a, const Vec2& b) { return a(0) * b(1) - a(1) * b(0); }

}  // namespace

std::shared_ptr<const Manipulator> arm_model(const ModuleParams& p, int j) {
  const auto uj = static_cast<size_t>(j);
  return p.models[uj] ? p.models[uj] : std::make_shared<const Planar3R>(p.arms[uj]);
}

ModulePlant::ModulePlant(const ModuleParams& params) : params_(params) {
  for (int j = 0; j < 2; ++j) {
    const auto uj = static_cast<size_t>(j);
    models_[uj] = arm_model(params_, j);
    if (const auto* p3 = dynamic_cast<const Planar3R*>(models_[uj].get())) p3r_[uj] = &p3->params();
  }
  ModuleState s;
  for (int j = 0; j < 2; ++j) {
    s.q[static_cast<size_t>(j)] = JointVec::Zero(arm(j).dof());
    s.qd[static_cast<size_t>(j)] = JointVec::Zero(arm(j).dof());
  }
  reset(s);
}

Vec3 ModulePlant::end_effector(int j) const noexcept {
  const auto uj = static_cast<size_t>(j);
  if (p3r_[uj] != nullptr) return forward_kinematics(*p3r_[uj], Vec3(state_.q[uj]));
  return models_[uj]->forward_kinematics(state_.q[uj]);
}

Vec2 ModulePlant::tip(int j, const JointVec& q, const JointVec& qd, Vec2* v) const noexcept {
  const auto uj = static_cast<size_t>(j);
  if (const ArmParams* a = p3r_[uj]) {
    const Vec3 q3 = q;
    if (v != nullptr) *v = (jacobian(*a, q3) * Vec3(qd)).head<2>();
    return forward_kinematics(*a, q3).head<2>();
  }
  if (v != nullptr) *v = (models_[uj]->jacobian(q) * qd).head<2>();
  return models_[uj]->forward_kinematics(q).head<2>();
}

void ModulePlant::reset(const ModuleState& state) {
  state_ = state;
  for (int j = 0; j < 2; ++j) {
    // A state of another joint count than the arm's (a caller's mistake): the arm starts at zero.
    const auto uj = static_cast<size_t>(j);
    if (state_.q[uj].size() != arm(j).dof()) state_.q[uj] = JointVec::Zero(arm(j).dof());
    if (state_.qd[uj].size() != arm(j).dof()) state_.qd[uj] = JointVec::Zero(arm(j).dof());
  }
  counters_ = PlantCounters{};
  // Pre-load each sticking contact with half the weight (upwards on the object).
  const Mat2 R = rotation(state_.psi);
  for (int j = 0; j < 2; ++j) {
    const Vec2 rho = R.transpose() * (end_effector(j).head<2>() - state_.c);
    const double sigma = kFaceTangent.dot(rho);
    anchor_[j] = sigma - 0.5 * params_.object.mass * params_.g0 / params_.contact.k_tangent;
  }
}

ContactReading ModulePlant::contact_forces(const ModuleState& s) const noexcept {
  ContactReading out;
  const auto& cp = params_.contact;
  const auto& op = params_.object;
  const Mat2 R = rotation(s.psi);
  for (int j = 0; j < 2; ++j) {
    Vec2 v;
    const Vec2 p = tip(j, s.q[static_cast<size_t>(j)], s.qd[static_cast<size_t>(j)], &v);
    const Vec2 r = p - s.c;
    const Vec2 material_v = s.cd + s.psid * Vec2(-r(1), r(0));  // object point under the tip
    const Vec2 rho = R.transpose() * r;
    const Vec2 vrel = R.transpose() * (v - material_v);
    const Vec2 n = face_normal(j);
    const double delta = op.half_width - n.dot(rho);  // eq. (19): spring deflection x - x_e
    const double delta_dot = -n.dot(vrel);
    out.penetration[j] = delta;
    if (delta <= 0.0) continue;
    const double N = std::max(0.0, cp.k_normal * delta + cp.d_normal * delta_dot);
    if (N <= 0.0) continue;
    const double sigma = kFaceTangent.dot(rho);
    // The tip must be on the face: within its height and not through the object.
    if (std::abs(sigma) > op.half_height || delta >= 2.0 * op.half_width) continue;
    const double sigma_dot = kFaceTangent.dot(vrel);
    double Ft = cp.k_tangent * (sigma - anchor_[j]) + cp.d_tangent * sigma_dot;
    const double limit = op.mu_s * N;
    Ft = std::clamp(Ft, -limit, limit);
    const Vec2 F = R * (-N * n + Ft * kFaceTangent);  // force of the end-effector on the object
    out.h[j] = F;
    out.normal[j] = N;
    out.tangential[j] = Ft;
    out.in_contact[j] = true;
    out.force_on_object += F;
    out.torque_on_object += cross2(r, F);
  }
  return out;
}

ModulePlant::StateVec ModulePlant::pack(const ModuleState& s) const noexcept {
  StateVec v = StateVec::Zero();
  for (int j = 0; j < 2; ++j) {
    const auto uj = static_cast<size_t>(j);
    const int n = arm(j).dof();
    v.segment(slot_q(j), n) = s.q[uj];
    v.segment(slot_qd(j), n) = s.qd[uj];
  }
  v.segment<2>(kObject) = s.c;
  v(kObject + 2) = s.psi;
  v.segment<2>(kObject + 3) = s.cd;
  v(kObject + 5) = s.psid;
  return v;
}

void ModulePlant::unpack(const StateVec& v, ModuleState& s) const noexcept {
  for (int j = 0; j < 2; ++j) {
    const auto uj = static_cast<size_t>(j);
    const int n = arm(j).dof();
    s.q[uj] = v.segment(slot_q(j), n);
    s.qd[uj] = v.segment(slot_qd(j), n);
  }
  s.c = v.segment<2>(kObject);
  s.psi = v(kObject + 2);
  s.cd = v.segment<2>(kObject + 3);
  s.psid = v(kObject + 5);
}

ModulePlant::StateVec ModulePlant::derivative(const StateVec& x, const ArmEfforts& tau, double t) const noexcept {
  ModuleState s;
  unpack(x, s);
  const ContactReading c = contact_forces(s);
  StateVec dx = StateVec::Zero();
  for (int j = 0; j < 2; ++j) {
    const auto uj = static_cast<size_t>(j);
    const int n = arm(j).dof();
    const Eigen::Index qi = slot_q(j), qdi = slot_qd(j);
    const Vec3 h(c.h[uj](0), c.h[uj](1), 0.0);  // point contacts transmit no moment
    dx.segment(qi, n) = s.qd[uj];
    if (braked_[uj]) {
      // Braked joints: the brake takes whatever torque it needs and stops them along qdd = -qd / T_b, as a
      // real holding brake stops a moving arm over a short distance (an instant stop of an arm moving with
      // the object jolts the object against it and makes it slip); at rest they stay locked.
      dx.segment(qdi, n) = -s.qd[uj] / kBrakeTimeConstant;
      continue;
    }
    if (const ArmParams* a = p3r_[uj]) {  // the identified 3R: fixed-size Eigen (the fast path)
      dx.segment<3>(qdi) = forward_dynamics(*a, Vec3(s.q[uj]), Vec3(s.qd[uj]), Vec3(tau[uj]), h) +
                           params_.disturbance[uj](t);
    } else {
      dx.segment(qdi, n) = models_[uj]->forward_dynamics(s.q[uj], s.qd[uj], tau[uj], h) + params_.disturbance[uj].at(t, n);
    }
  }
  const auto& op = params_.object;
  // eq. (13), planar: M p'' = f_E - M g, I psi'' = mu_E (the gyroscopic term vanishes in the plane).
  const Vec2 acc = c.force_on_object / op.mass + Vec2(0.0, -params_.g0);
  dx.segment<2>(kObject) = s.cd;
  dx(kObject + 2) = s.psid;
  dx.segment<2>(kObject + 3) = acc;
  dx(kObject + 5) = c.torque_on_object / op.effective_inertia();
  return dx;
}

void ModulePlant::update_anchors() noexcept {
  const auto& cp = params_.contact;
  const auto& op = params_.object;
  const Mat2 R = rotation(state_.psi);
  const ContactReading c = contact_forces(state_);
  for (int j = 0; j < 2; ++j) {
    Vec2 v;
    const Vec2 r = tip(j, state_.q[static_cast<size_t>(j)], state_.qd[static_cast<size_t>(j)], &v) - state_.c;
    const Vec2 rho = R.transpose() * r;
    const double sigma = kFaceTangent.dot(rho);
    if (!c.in_contact[j]) {
      ++counters_.contact_lost;
      anchor_[j] = sigma;  // nothing holds: the contact re-sticks where it touches again
      continue;
    }
    // The friction demand is the whole tangential force (spring and damper), the same force that the
    // contact model clamps to the static cone.
    const Vec2 vrel = R.transpose() * (v - (state_.cd + state_.psid * Vec2(-r(1), r(0))));
    const double sigma_dot = kFaceTangent.dot(vrel);
    const double demand = cp.k_tangent * (sigma - anchor_[j]) + cp.d_tangent * sigma_dot;
    if (std::abs(demand) >= op.mu_s * c.normal[j]) {
      // Slip: the contact slides until spring and damper carry the kinetic friction force.
      const double new_anchor =
          sigma - (std::copysign(op.mu_k * c.normal[j], demand) - cp.d_tangent * sigma_dot) / cp.k_tangent;
      counters_.slip_distance += std::abs(new_anchor - anchor_[j]);
      anchor_[j] = new_anchor;
      ++counters_.slip_events;
    }
  }
}

void ModulePlant::step(const std::array<Vec3, 2>& tau, double t, double dt, int substeps) noexcept {
  ArmEfforts e{JointVec(tau[0]), JointVec(tau[1])};
  step(e, t, dt, substeps);
}

void ModulePlant::step(const ArmEfforts& tau_cmd, double t, double dt, int substeps) noexcept {
  ArmEfforts tau = tau_cmd;
  bool saturated = false;
  for (int j = 0; j < 2; ++j) {
    const auto uj = static_cast<size_t>(j);
    const JointSpace& js = arm(j).joints();
    if (tau[uj].size() != js.dof) tau[uj] = JointVec::Zero(js.dof);
    for (int i = 0; i < js.dof; ++i) {
      const double lim = js.effort_max[static_cast<size_t>(i)];
      const double clipped = std::min(std::max(tau[uj](i), -lim), lim);
      saturated = saturated || clipped != tau[uj](i);
      tau[uj](i) = clipped;
    }
  }
  if (saturated) ++counters_.torque_saturated;
  const double h = dt / substeps;
  StateVec x = pack(state_);
  for (int i = 0; i < substeps; ++i) {
    const double ti = t + i * h;
    const StateVec k1 = derivative(x, tau, ti);
    const StateVec k2 = derivative(x + 0.5 * h * k1, tau, ti + 0.5 * h);
    const StateVec k3 = derivative(x + 0.5 * h * k2, tau, ti + 0.5 * h);
    const StateVec k4 = derivative(x + h * k3, tau, ti + h);
    x += (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    unpack(x, state_);
    update_anchors();
  }
  for (int j = 0; j < 2; ++j) {
    if (!arm(j).within_limits(state_.q[static_cast<size_t>(j)])) {
      ++counters_.joint_limit;
      break;
    }
  }
}

void ModulePlant::set_brake(int j, bool on) noexcept { braked_[static_cast<size_t>(j)] = on; }

double ModulePlant::mechanical_energy() const noexcept {
  double e = 0.0;
  for (int j = 0; j < 2; ++j) {
    const auto uj = static_cast<size_t>(j);
    e += arm(j).kinetic_energy(state_.q[uj], state_.qd[uj]) + arm(j).potential_energy(state_.q[uj]);
  }
  const auto& op = params_.object;
  e += 0.5 * op.mass * state_.cd.squaredNorm() + 0.5 * op.effective_inertia() * state_.psid * state_.psid +
       op.mass * params_.g0 * state_.c(1);
  return e;
}

}  // namespace tandem::model
