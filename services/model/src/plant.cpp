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

ModulePlant::ModulePlant(const ModuleParams& params) : params_(params) { reset(ModuleState{}); }

void ModulePlant::reset(const ModuleState& state) {
  state_ = state;
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
    const ArmParams& arm = params_.arms[j];
    const Vec2 p = forward_kinematics(arm, s.q[j]).head<2>();
    const Vec2 v = (jacobian(arm, s.q[j]) * s.qd[j]).head<2>();
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

ModulePlant::StateVec ModulePlant::pack(const ModuleState& s) noexcept {
  StateVec v;
  v << s.q[0], s.q[1], s.qd[0], s.qd[1], s.c, s.psi, s.cd, s.psid;
  return v;
}

ModuleState ModulePlant::unpack(const StateVec& v) noexcept {
  ModuleState s;
  s.q[0] = v.segment<3>(0);
  s.q[1] = v.segment<3>(3);
  s.qd[0] = v.segment<3>(6);
  s.qd[1] = v.segment<3>(9);
  s.c = v.segment<2>(12);
  s.psi = v(14);
  s.cd = v.segment<2>(15);
  s.psid = v(17);
  return s;
}

ModulePlant::StateVec ModulePlant::derivative(const StateVec& x, const std::array<Vec3, 2>& tau,
                                              double t) const noexcept {
  const ModuleState s = unpack(x);
  const ContactReading c = contact_forces(s);
  StateVec dx;
  for (int j = 0; j < 2; ++j) {
    const Vec3 h(c.h[j](0), c.h[j](1), 0.0);  // point contacts transmit no moment
    if (braked_[static_cast<size_t>(j)]) {
      // Braked joints: the brake takes whatever torque it needs and stops them along qdd = -qd / T_b, as a
      // real holding brake stops a moving arm over a short distance (an instant stop of an arm moving with
      // the object jolts the object against it and makes it slip); at rest they stay locked.
      dx.segment<3>(3 * j) = s.qd[j];
      dx.segment<3>(6 + 3 * j) = -s.qd[j] / kBrakeTimeConstant;
      continue;
    }
    const Vec3 qdd = forward_dynamics(params_.arms[j], s.q[j], s.qd[j], tau[j], h) + params_.disturbance[j](t);
    dx.segment<3>(3 * j) = s.qd[j];
    dx.segment<3>(6 + 3 * j) = qdd;
  }
  const auto& op = params_.object;
  // eq. (13), planar: M p'' = f_E - M g, I psi'' = mu_E (the gyroscopic term vanishes in the plane).
  const Vec2 acc = c.force_on_object / op.mass + Vec2(0.0, -params_.g0);
  dx.segment<2>(12) = s.cd;
  dx(14) = s.psid;
  dx.segment<2>(15) = acc;
  dx(17) = c.torque_on_object / op.effective_inertia();
  return dx;
}

void ModulePlant::update_anchors() noexcept {
  const auto& cp = params_.contact;
  const auto& op = params_.object;
  const Mat2 R = rotation(state_.psi);
  const ContactReading c = contact_forces(state_);
  for (int j = 0; j < 2; ++j) {
    const ArmParams& arm = params_.arms[j];
    const Vec2 r = end_effector(j).head<2>() - state_.c;
    const Vec2 rho = R.transpose() * r;
    const double sigma = kFaceTangent.dot(rho);
    if (!c.in_contact[j]) {
      ++counters_.contact_lost;
      anchor_[j] = sigma;  // nothing holds: the contact re-sticks where it touches again
      continue;
    }
    // The friction demand is the whole tangential force (spring and damper), the same force that the
    // contact model clamps to the static cone.
    const Vec2 v = (jacobian(arm, state_.q[j]) * state_.qd[j]).head<2>();
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

void ModulePlant::step(const std::array<Vec3, 2>& tau_cmd, double t, double dt, int substeps) noexcept {
  std::array<Vec3, 2> tau = tau_cmd;
  bool saturated = false;
  for (int j = 0; j < 2; ++j) {
    const Vec3& lim = params_.arms[j].tau_max;
    const Vec3 clipped = tau[j].cwiseMax(-lim).cwiseMin(lim);
    saturated = saturated || !clipped.isApprox(tau[j], 0.0);
    tau[j] = clipped;
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
    state_ = unpack(x);
    update_anchors();
  }
  for (int j = 0; j < 2; ++j) {
    const ArmParams& arm = params_.arms[j];
    if ((state_.q[j].array() < arm.q_min.array()).any() || (state_.q[j].array() > arm.q_max.array()).any()) {
      ++counters_.joint_limit;
      break;
    }
  }
}

void ModulePlant::set_brake(int j, bool on) noexcept { braked_[static_cast<size_t>(j)] = on; }

double ModulePlant::mechanical_energy() const noexcept {
  double e = 0.0;
  for (int j = 0; j < 2; ++j) {
    e += kinetic_energy(params_.arms[j], state_.q[j], state_.qd[j]) +
         potential_energy(params_.arms[j], state_.q[j]);
  }
  const auto& op = params_.object;
  e += 0.5 * op.mass * state_.cd.squaredNorm() + 0.5 * op.effective_inertia() * state_.psid * state_.psid +
       op.mass * params_.g0 * state_.c(1);
  return e;
}

}  // namespace tandem::model
