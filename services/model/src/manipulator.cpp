#include "tandem/model/manipulator.hpp"

#include <algorithm>
#include <cmath>

namespace tandem::model {
namespace {

/// Unit direction at angle a clockwise from +y, and its derivative with respect to a.
Vec2 dir(double a) noexcept { return {std::sin(a), std::cos(a)}; }
Vec2 dir_rate(double a) noexcept { return {std::cos(a), -std::sin(a)}; }
/// d/d(delta) of v rotated clockwise by delta, at delta = 0.
Vec2 perp_cw(const Vec2& v) noexcept { return {v(1), -v(0)}; }

Vec3 vec3_of(const JointVec& v) noexcept { return {v(0), v(1), v(2)}; }
JointVec joint_of(const Vec3& v) noexcept {
  JointVec out(3);
  out << v(0), v(1), v(2);
  return out;
}
JointMat joint_of(const Mat3& m) noexcept {
  JointMat out(3, 3);
  out = m;
  return out;
}

/// Positions and rates of every body of a chain at (q, q'). Joint j's pivot (revolute) or the start of its
/// travel (prismatic) is `origin[j]`; body j's angle is `theta[j]`; a prismatic joint slides along `axis[j]`.
struct ChainFrames {
  std::array<Vec2, kMaxJoints> origin{}, origin_rate{};
  std::array<Vec2, kMaxJoints> com{}, com_rate{};
  std::array<Vec2, kMaxJoints> axis{}, axis_rate{};
  std::array<double, kMaxJoints> theta{}, theta_rate{};
  Vec2 tip = Vec2::Zero(), tip_rate = Vec2::Zero();
};

ChainFrames chain_frames(const ChainParams& p, const JointVec& q, const JointVec* qd) noexcept {
  ChainFrames f;
  Vec2 tip = p.joints.base, tip_rate = Vec2::Zero();
  double th = 0.0, th_rate = 0.0;
  for (int k = 0; k < p.joints.dof; ++k) {
    const auto uk = static_cast<size_t>(k);
    const ChainBody& b = p.bodies[uk];
    const double v = qd != nullptr ? (*qd)(k) : 0.0;
    if (b.joint == JointType::Revolute) {
      f.origin[uk] = tip;
      f.origin_rate[uk] = tip_rate;
      th += q(k) + b.axis;
      th_rate += v;
    } else {
      const double a = th + b.axis;
      f.axis[uk] = dir(a);
      f.axis_rate[uk] = th_rate * dir_rate(a);
      f.origin[uk] = tip + q(k) * f.axis[uk];
      f.origin_rate[uk] = tip_rate + v * f.axis[uk] + q(k) * f.axis_rate[uk];
    }
    f.theta[uk] = th;
    f.theta_rate[uk] = th_rate;
    f.com[uk] = f.origin[uk] + b.com * dir(th);
    f.com_rate[uk] = f.origin_rate[uk] + b.com * th_rate * dir_rate(th);
    tip = f.origin[uk] + b.length * dir(th);
    tip_rate = f.origin_rate[uk] + b.length * th_rate * dir_rate(th);
  }
  f.tip = tip;
  f.tip_rate = tip_rate;
  return f;
}

using PointJacobian = Eigen::Matrix<double, 2, Eigen::Dynamic, 0, 2, kMaxJoints>;

/// Jacobian of a point that moves with body `last` (columns after it are zero), at position p.
PointJacobian point_jacobian(const ChainParams& cp, const ChainFrames& f, const Vec2& p, int last) noexcept {
  PointJacobian J = PointJacobian::Zero(2, cp.joints.dof);
  for (int j = 0; j <= last; ++j) {
    const auto uj = static_cast<size_t>(j);
    J.col(j) = cp.bodies[uj].joint == JointType::Revolute ? perp_cw(p - f.origin[uj]) : f.axis[uj];
  }
  return J;
}

/// Its time derivative along the motion, p' the point's velocity.
PointJacobian point_jacobian_rate(const ChainParams& cp, const ChainFrames& f, const Vec2& p_rate,
                                  int last) noexcept {
  PointJacobian Jd = PointJacobian::Zero(2, cp.joints.dof);
  for (int j = 0; j <= last; ++j) {
    const auto uj = static_cast<size_t>(j);
    Jd.col(j) = cp.bodies[uj].joint == JointType::Revolute ? perp_cw(p_rate - f.origin_rate[uj]) : f.axis_rate[uj];
  }
  return Jd;
}

}  // namespace

const char* arm_kind_name(ArmKind k) noexcept {
  switch (k) {
    case ArmKind::Planar3R: return "planar_3r";
    case ArmKind::CartesianPPR: return "cartesian_ppr";
    case ArmKind::Planar4R: return "planar_4r";
  }
  return "?";
}

bool parse_arm_kind(const std::string& name, ArmKind& out) noexcept {
  for (ArmKind k : {ArmKind::Planar3R, ArmKind::CartesianPPR, ArmKind::Planar4R}) {
    if (name == arm_kind_name(k)) {
      out = k;
      return true;
    }
  }
  return false;
}

// ----- the common part ----------------------------------------------------------------------------------

JointVec Manipulator::friction(const JointVec& qd, double band) const noexcept {
  JointVec f(dof());
  for (int i = 0; i < dof(); ++i) {
    const auto ui = static_cast<size_t>(i);
    const double sgn = band > 0.0 ? std::tanh(qd(i) / band) : (qd(i) > 0.0) - (qd(i) < 0.0);
    f(i) = joints_.viscous[ui] * qd(i) + joints_.coulomb[ui] * sgn;
  }
  return f;
}

JointVec Manipulator::nonlinear_terms(const JointVec& q, const JointVec& qd) const noexcept {
  return coriolis(q, qd) * qd + friction(qd, joints_.coulomb_band) + gravity(q);
}

JointVec Manipulator::forward_dynamics(const JointVec& q, const JointVec& qd, const JointVec& tau,
                                       const Vec3& h) const noexcept {
  const JointVec rhs = tau - nonlinear_terms(q, qd) - jacobian(q).transpose() * h;  // eq. (2)
  return inertia(q).llt().solve(rhs);
}

double Manipulator::kinetic_energy(const JointVec& q, const JointVec& qd) const noexcept {
  return 0.5 * qd.dot(inertia(q) * qd);
}

bool Manipulator::within_limits(const JointVec& q) const noexcept {
  if (q.size() != dof()) return false;
  for (int i = 0; i < dof(); ++i) {
    const auto ui = static_cast<size_t>(i);
    if (!(q(i) >= joints_.q_min[ui] && q(i) <= joints_.q_max[ui])) return false;
  }
  return true;
}

JointVec Manipulator::home() const noexcept {
  JointVec h(dof());
  for (int i = 0; i < dof(); ++i) h(i) = joints_.home[static_cast<size_t>(i)];
  return h;
}

bool Manipulator::inverse_kinematics(const Vec3& x, const JointVec& seed, double /*branch*/,
                                     JointVec& q) const noexcept {
  if (seed.size() != dof()) return false;
  JointVec z = seed;
  constexpr int kIterations = 100;
  constexpr double kTolerance = 1e-12;  // [m] and [rad]
  for (int it = 0; it < kIterations; ++it) {
    const Vec3 fk = forward_kinematics(z);
    Vec3 e = x - fk;
    e(2) = wrap_angle(e(2));
    if (e.norm() < kTolerance) {
      if (!within_limits(z)) return false;
      q = z;
      return true;
    }
    const TaskJacobian J = jacobian(z);
    // Minimum-norm step J^T (J J^T + lambda^2 I)^-1 e; the small damping keeps it finite near a singularity.
    const Mat3 JJt = J * J.transpose() + 1e-10 * Mat3::Identity();
    JointVec step = J.transpose() * JJt.ldlt().solve(e);
    // Limit a step to 0.5 (rad or m) in its largest joint, so that a far seed does not jump to another branch.
    double big = 0.0;
    for (int i = 0; i < dof(); ++i) big = std::max(big, std::abs(step(i)));
    if (big > 0.5) step *= 0.5 / big;
    z += step;
  }
  return false;
}

JointSpace joint_space(const ArmParams& p) {
  JointSpace js;
  js.dof = 3;
  for (size_t i = 0; i < 3; ++i) {
    const auto e = static_cast<Eigen::Index>(i);
    js.type[i] = JointType::Revolute;
    js.viscous[i] = p.viscous(e);
    js.coulomb[i] = p.coulomb(e);
    js.q_min[i] = p.q_min(e);
    js.q_max[i] = p.q_max(e);
    js.effort_max[i] = p.tau_max(e);
  }
  js.coulomb_band = p.coulomb_band;
  js.base = p.base;
  js.g0 = p.g0;
  return js;
}

// ----- Planar3R: the functions of arm.hpp ---------------------------------------------------------------

Planar3R::Planar3R(const ArmParams& p) : Manipulator(joint_space(p)), p_(p) {}

Vec3 Planar3R::forward_kinematics(const JointVec& q) const noexcept {
  return model::forward_kinematics(p_, vec3_of(q));
}
TaskJacobian Planar3R::jacobian(const JointVec& q) const noexcept {
  TaskJacobian J(3, 3);
  J = model::jacobian(p_, vec3_of(q));
  return J;
}
TaskJacobian Planar3R::jacobian_dot(const JointVec& q, const JointVec& qd) const noexcept {
  TaskJacobian J(3, 3);
  J = model::jacobian_dot(p_, vec3_of(q), vec3_of(qd));
  return J;
}
JointMat Planar3R::inertia(const JointVec& q) const noexcept { return joint_of(model::inertia(p_, vec3_of(q))); }
JointMat Planar3R::coriolis(const JointVec& q, const JointVec& qd) const noexcept {
  return joint_of(model::coriolis(p_, vec3_of(q), vec3_of(qd)));
}
JointVec Planar3R::gravity(const JointVec& q) const noexcept { return joint_of(model::gravity(p_, vec3_of(q))); }
double Planar3R::potential_energy(const JointVec& q) const noexcept {
  return model::potential_energy(p_, vec3_of(q));
}
bool Planar3R::inverse_kinematics(const Vec3& x, const JointVec& /*seed*/, double branch, JointVec& q) const noexcept {
  Vec3 q3;
  if (!model::inverse_kinematics(p_, x, branch, q3)) return false;
  q = joint_of(q3);
  return true;
}

// ----- PlanarChain ---------------------------------------------------------------------------------------

PlanarChain::PlanarChain(const ChainParams& p) : Manipulator(p.joints), p_(p) {}

Vec3 PlanarChain::forward_kinematics(const JointVec& q) const noexcept {
  const ChainFrames f = chain_frames(p_, q, nullptr);
  return {f.tip(0), f.tip(1), f.theta[static_cast<size_t>(dof() - 1)]};
}

TaskJacobian PlanarChain::jacobian(const JointVec& q) const noexcept {
  const ChainFrames f = chain_frames(p_, q, nullptr);
  TaskJacobian J(3, dof());
  J.topRows<2>() = point_jacobian(p_, f, f.tip, dof() - 1);
  for (int j = 0; j < dof(); ++j) J(2, j) = p_.bodies[static_cast<size_t>(j)].joint == JointType::Revolute ? 1.0 : 0.0;
  return J;
}

TaskJacobian PlanarChain::jacobian_dot(const JointVec& q, const JointVec& qd) const noexcept {
  const ChainFrames f = chain_frames(p_, q, &qd);
  TaskJacobian Jd(3, dof());
  Jd.topRows<2>() = point_jacobian_rate(p_, f, f.tip_rate, dof() - 1);
  Jd.row(2).setZero();
  return Jd;
}

JointMat PlanarChain::inertia(const JointVec& q) const noexcept {
  const ChainFrames f = chain_frames(p_, q, nullptr);
  const int n = dof();
  JointMat B = JointMat::Zero(n, n);
  JointVec w = JointVec::Zero(n);  // angular Jacobian of body k: 1 for each revolute joint up to k
  for (int k = 0; k < n; ++k) {
    const auto uk = static_cast<size_t>(k);
    const ChainBody& b = p_.bodies[uk];
    if (b.joint == JointType::Revolute) w(k) = 1.0;
    const PointJacobian Jc = point_jacobian(p_, f, f.com[uk], k);
    B.noalias() += b.mass * Jc.transpose() * Jc;
    B.noalias() += b.inertia * w * w.transpose();
  }
  return B;
}

JointMat PlanarChain::coriolis(const JointVec& q, const JointVec& qd) const noexcept {
  const ChainFrames f = chain_frames(p_, q, &qd);
  const int n = dof();
  JointMat C = JointMat::Zero(n, n);
  for (int k = 0; k < n; ++k) {
    const auto uk = static_cast<size_t>(k);
    const PointJacobian Jc = point_jacobian(p_, f, f.com[uk], k);
    const PointJacobian Jcd = point_jacobian_rate(p_, f, f.com_rate[uk], k);
    C.noalias() += p_.bodies[uk].mass * Jc.transpose() * Jcd;
  }
  return C;
}

JointVec PlanarChain::gravity(const JointVec& q) const noexcept {
  const ChainFrames f = chain_frames(p_, q, nullptr);
  JointVec g = JointVec::Zero(dof());
  for (int k = 0; k < dof(); ++k) {
    const auto uk = static_cast<size_t>(k);
    g += p_.joints.g0 * p_.bodies[uk].mass * point_jacobian(p_, f, f.com[uk], k).row(1).transpose();
  }
  return g;
}

double PlanarChain::potential_energy(const JointVec& q) const noexcept {
  const ChainFrames f = chain_frames(p_, q, nullptr);
  double u = 0.0;
  for (int k = 0; k < dof(); ++k) {
    const auto uk = static_cast<size_t>(k);
    u += p_.joints.g0 * p_.bodies[uk].mass * f.com[uk](1);
  }
  return u;
}

Vec2 PlanarChain::body_com(const JointVec& q, int k) const noexcept {
  return chain_frames(p_, q, nullptr).com[static_cast<size_t>(k)];
}

// ----- default parameters --------------------------------------------------------------------------------

ChainParams cartesian_ppr() {
  ChainParams p;
  p.kind = ArmKind::CartesianPPR;
  // x carriage (moves the column and the wrist), y column (moves the wrist), wrist link.
  p.bodies[0] = ChainBody{JointType::Prismatic, kPi / 2.0, 0.0, 0.0, 40.0, 0.0};
  p.bodies[1] = ChainBody{JointType::Prismatic, 0.0, 0.0, 0.0, 25.0, 0.0};
  p.bodies[2] = ChainBody{JointType::Revolute, 0.0, 0.34, 0.17, 6.0, 6.0 * 0.34 * 0.34 / 12.0};
  JointSpace& j = p.joints;
  j.dof = 3;
  j.type = {JointType::Prismatic, JointType::Prismatic, JointType::Revolute, JointType::Revolute};
  j.viscous = {150.0, 150.0, 4.6565, 0.0};
  j.coulomb = {20.0, 20.0, 8.2911, 0.0};
  j.q_min = {-1.5, -0.5, -kPi, 0.0};
  j.q_max = {1.5, 1.8, kPi, 0.0};
  j.effort_max = {3000.0, 3000.0, 500.0, 0.0};
  j.home = {0.0, 0.8, kPi / 2.0, 0.0};  // a left arm: the wrist towards +x
  return p;
}

ChainParams planar_4r() {
  ChainParams p;
  p.kind = ArmKind::Planar4R;
  const std::array<double, 4> len{0.55, 0.45, 0.31, 0.34};
  const std::array<double, 4> mass{22.0, 14.0, 6.0, 4.0};
  for (size_t k = 0; k < 4; ++k) {
    p.bodies[k] = ChainBody{JointType::Revolute, 0.0, len[k], 0.5 * len[k], mass[k], mass[k] * len[k] * len[k] / 12.0};
  }
  JointSpace& j = p.joints;
  j.dof = 4;
  j.type = {JointType::Revolute, JointType::Revolute, JointType::Revolute, JointType::Revolute};
  j.viscous = {120.0, 20.0, 8.0, 4.6565};
  j.coulomb = {40.0, 14.0, 10.0, 8.2911};
  j.q_min = {-kPi, -kPi, -kPi, -kPi};
  j.q_max = {kPi, kPi, kPi, kPi};
  j.effort_max = {3000.0, 1500.0, 800.0, 500.0};
  j.home = {0.3, 0.6, 0.6, kPi / 2.0 - 1.5};  // a left arm: leaning towards +x, the tool along +x
  return p;
}

std::unique_ptr<Manipulator> make_manipulator(const ArmParams& p) { return std::make_unique<Planar3R>(p); }
std::unique_ptr<Manipulator> make_manipulator(const ChainParams& p) { return std::make_unique<PlanarChain>(p); }

}  // namespace tandem::model
