#include "tandem/model/controller.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace tandem::model {
namespace {

double sgn(double v) noexcept { return static_cast<double>((v > 0.0) - (v < 0.0)); }

}  // namespace

Mat3 contact_frame(double phi) noexcept {
  // Columns: tangent t, approach a, and the orientation axis. t = (a_y, -a_x) so that t x a = +z.
  const Vec2 a = approach_axis(phi);
  Mat3 R = Mat3::Identity();
  R(0, 0) = a(1);
  R(1, 0) = -a(0);
  R(0, 1) = a(0);
  R(1, 1) = a(1);
  return R;
}

HybridController::HybridController(const ArmParams& arm, const HybridParams& params)
    : HybridController(std::make_shared<const Planar3R>(arm), params) {}

HybridController::HybridController(std::shared_ptr<const Manipulator> arm, const HybridParams& params)
    : arm_(std::move(arm)), params_(params), tau_to_u_(TaskJacobian::Zero(3, arm_->dof())),
      q_rest_(params.null_space.q_rest) {
  // Three task coordinates: an arm needs at least three joints (fewer cannot follow [px, py, phi]).
  if (arm_->dof() < 3) throw std::invalid_argument("HybridController: an arm needs at least 3 joints");
  if (q_rest_.size() != 0 && q_rest_.size() != arm_->dof()) {
    throw std::invalid_argument("HybridController: null_space.q_rest has " + std::to_string(q_rest_.size()) +
                                " entries for an arm of " + std::to_string(arm_->dof()) + " joints");
  }
}

void HybridController::track(const JointVec& delta_tau) noexcept {
  if (params_.law.type != LawType::SuperTwisting || delta_tau.size() != arm_->dof() || !delta_tau.allFinite()) return;
  twisting_v_ += tau_to_u_ * delta_tau;
}

void HybridController::reset() noexcept {
  prev_normal_force_ = 0.0;
  has_prev_ = false;
  twisting_v_.setZero();
}

JointVec HybridController::joint_acceleration(const TaskJacobian& J, const Vec3& task, const ArmSensors& in) noexcept {
  const int n = arm_->dof();
  if (n == 3) {
    const Mat3 Js = J;
    const Vec3 y = Js.partialPivLu().solve(task);  // eq. (21)
    return JointVec(y);
  }
  // Redundant: minimum-norm task solution plus the null-space task (NullSpace).
  const Mat3 JJt = J * J.transpose();
  const TaskJacobian::PlainObject W = JJt.ldlt().solve(J);  // (J J^T)^-1 J, 3 x n
  const JointMat pinv_J = W.transpose() * J;                // J^+ J
  if (q_rest_.size() != n) q_rest_ = in.q;
  const NullSpace& ns = params_.null_space;
  const JointVec z = -ns.k_damping * in.qd - ns.k_posture * (in.q - q_rest_);
  return W.transpose() * task + (JointMat::Identity(n, n) - pinv_J) * z;
}

ControlOutput HybridController::step(const ArmSensors& in, const ArmReference& ref) noexcept {
  ControlOutput out;
  const HybridParams& p = params_;
  const double T = p.period;
  const Manipulator& arm = *arm_;
  if (in.q.size() != arm.dof() || in.qd.size() != arm.dof()) {
    // Sensors of another joint count (a wiring error): no torque is better than one computed from garbage. A NaN
    // torque is refused by every consumer (RobotCore, the world).
    out.tau = JointVec::Constant(arm.dof(), std::numeric_limits<double>::quiet_NaN());
    return out;
  }
  const Vec3 x = arm.forward_kinematics(in.q);
  const TaskJacobian J = arm.jacobian(in.q);
  const TaskJacobian Jd = arm.jacobian_dot(in.q, in.qd);
  const Vec3 xdot = J * in.qd;

  const Mat3 R = contact_frame(ref.x(2));
  const Vec3 sel_p = p.selection_p;
  const Vec3 sel_h = Vec3::Ones() - sel_p;  // Sigma_h = I - Sigma_p (Sec. VII)

  // Position error e_p = x_d - x and its rate, expressed in the contact frame.
  out.e_p = ref.x - x;
  const Vec3 ep_c = R.transpose() * out.e_p;
  const Vec3 epd_c = R.transpose() * (ref.xd - xdot);

  // Force error e_h = h_ref - h along the approach axis, scaled by K_S^-1 into a position error.
  const Vec2 a = R.block<2, 1>(0, 1);
  out.normal_force = a.dot(in.h);
  out.e_h = ref.force - out.normal_force;
  const double h_rate = has_prev_ ? (out.normal_force - prev_normal_force_) / T : 0.0;
  prev_normal_force_ = out.normal_force;
  has_prev_ = true;
  const double inv_ks = 1.0 / p.contact_stiffness;
  const Vec3 eh_c(0.0, inv_ks * out.e_h, 0.0);
  const Vec3 ehd_c(0.0, -inv_ks * h_rate, 0.0);  // the reference force is constant over a period

  const Vec3 e = sel_p.cwiseProduct(ep_c) + sel_h.cwiseProduct(eh_c);
  const Vec3 ed = sel_p.cwiseProduct(epd_c) + sel_h.cwiseProduct(ehd_c);
  out.e_c = e;
  const LawGains& g = p.law;
  const Vec3 m = LawGains::pick(sel_p, g.m_p, g.m_h);
  const Vec3 K = LawGains::pick(sel_p, g.K_p, g.K_h);
  out.s = m.cwiseProduct(e) + ed;  // eq. (25)-(26)

  const Vec3 phi = LawGains::pick(sel_p, g.phi_p, g.phi_h);
  const Vec3 kp = LawGains::pick(sel_p, g.kp_p, g.kp_h);
  const Vec3 kd = LawGains::pick(sel_p, g.kd_p, g.kd_h);
  Vec3 u;
  for (int i = 0; i < 3; ++i) {
    const double s = out.s(i);
    switch (g.type) {
      case LawType::SlidingMode:
        u(i) = K(i) * sgn(s);  // eq. (27)-(28)
        break;
      case LawType::BoundaryLayer:
        u(i) = K(i) * std::fmax(-1.0, std::fmin(1.0, s / phi(i)));
        break;
      case LawType::SuperTwisting: {
        const double k1 = 1.5 * std::sqrt(K(i));
        const double k2 = 1.1 * K(i);
        u(i) = k1 * std::sqrt(std::abs(s)) * sgn(s) + twisting_v_(i);
        twisting_v_(i) += T * k2 * sgn(s);
        break;
      }
      case LawType::PD:
        u(i) = kp(i) * e(i) + kd(i) * ed(i);  // eq. (35)-(36)
        break;
    }
  }
  // Feed-forward of the planned accelerations (x_d'' for position axes, x_e'' = x_d'' of the contact
  // surface along the approach axis), when enabled.
  const Vec3 xdd_c = R.transpose() * ref.xdd;
  Vec3 ff = Vec3::Zero();
  if (p.feedforward_position) ff += sel_p.cwiseProduct(xdd_c);
  if (p.feedforward_force) ff += sel_h.cwiseProduct(xdd_c);

  const Vec3 y_tilde = R * (u + ff);                              // eq. (20), back in the world frame
  const Vec3 qd_term = Jd * in.qd;
  const JointVec y = joint_acceleration(J, y_tilde - qd_term, in);  // eq. (21)

  // eq. (22): tau = B y + n^ + J^T h
  const Compensation& c = p.comp;
  const int n = arm.dof();
  JointVec n_hat = JointVec::Zero(n);
  if (c.coriolis) n_hat += arm.coriolis(in.q, in.qd) * in.qd;
  if (c.gravity) n_hat += arm.gravity(in.q);
  const JointSpace& js = arm.joints();
  for (int i = 0; i < n; ++i) {
    const auto ui = static_cast<size_t>(i);
    if (c.viscous) n_hat(i) += js.viscous[ui] * in.qd(i);
    if (c.coulomb) {
      n_hat(i) += js.coulomb[ui] * (c.coulomb_band > 0.0 ? std::tanh(in.qd(i) / c.coulomb_band) : sgn(in.qd(i)));
    }
  }
  const JointMat B = arm.inertia(in.q);
  out.tau = B * y + n_hat;
  if (g.type == LawType::SuperTwisting) tau_to_u_ = R.transpose() * J * B.inverse();
  if (c.contact_force) out.tau += J.transpose() * Vec3(in.h(0), in.h(1), 0.0);
  return out;
}

Vec3 reaching_gain_bound(const TaskJacobian& J_contact, const JointVec& eta_bound, const Vec3& xdd_contact,
                         const Vec3& m, const Vec3& ed_bound, double eta_margin) noexcept {
  // eq. (33)-(34)
  return J_contact.cwiseAbs() * eta_bound + Vec3::Constant(eta_margin) + xdd_contact.cwiseAbs() +
         m.cwiseProduct(ed_bound.cwiseAbs());
}

}  // namespace tandem::model
