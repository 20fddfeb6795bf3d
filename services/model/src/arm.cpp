#include "tandem/model/arm.hpp"

#include <cmath>

namespace tandem::model {
namespace {
constexpr double kIdentifiedG0 = 9.81;  // gamma_4 of the identified model includes this g0
}  // namespace

ArmParams smart3s2() { return ArmParams{}; }

Vec3 forward_kinematics(const ArmParams& p, const Vec3& q) noexcept {
  const double q12 = q(0) + q(1);
  const double phi = q12 + q(2);
  const auto& l = p.link_length;
  // eq. (1)
  return {p.base(0) + l(0) * std::sin(q(0)) + l(1) * std::sin(q12) + l(2) * std::sin(phi),
          p.base(1) + l(0) * std::cos(q(0)) + l(1) * std::cos(q12) + l(2) * std::cos(phi), phi};
}

Mat3 jacobian(const ArmParams& p, const Vec3& q) noexcept {
  const auto& l = p.link_length;
  const double a1 = q(0), a2 = q(0) + q(1), a3 = a2 + q(2);
  const double c1 = l(0) * std::cos(a1), c2 = l(1) * std::cos(a2), c3 = l(2) * std::cos(a3);
  const double s1 = l(0) * std::sin(a1), s2 = l(1) * std::sin(a2), s3 = l(2) * std::sin(a3);
  Mat3 J;
  J << c1 + c2 + c3, c2 + c3, c3,  //
      -(s1 + s2 + s3), -(s2 + s3), -s3, 1.0, 1.0, 1.0;
  return J;
}

Mat3 jacobian_dot(const ArmParams& p, const Vec3& q, const Vec3& qd) noexcept {
  const auto& l = p.link_length;
  const double a1 = q(0), a2 = q(0) + q(1), a3 = a2 + q(2);
  const double w1 = qd(0), w2 = qd(0) + qd(1), w3 = w2 + qd(2);  // absolute link rates
  const double c1 = l(0) * std::cos(a1) * w1, c2 = l(1) * std::cos(a2) * w2, c3 = l(2) * std::cos(a3) * w3;
  const double s1 = l(0) * std::sin(a1) * w1, s2 = l(1) * std::sin(a2) * w2, s3 = l(2) * std::sin(a3) * w3;
  Mat3 Jd;
  Jd << -(s1 + s2 + s3), -(s2 + s3), -s3,  //
      -(c1 + c2 + c3), -(c2 + c3), -c3, 0.0, 0.0, 0.0;
  return Jd;
}

Mat3 inertia(const ArmParams& p, const Vec3& q) noexcept {
  const auto& g = p.gamma;
  const auto& l = p.link_length;
  const double a1 = g[4] * l(0), a2 = g[5] * l(1), a3 = g[5] * l(0);
  const double c2 = std::cos(q(1)), c3 = std::cos(q(2)), c23 = std::cos(q(1) + q(2));
  Mat3 B;
  B(0, 0) = g[2] + 2 * a1 * c2 + 2 * a2 * c3 + 2 * a3 * c23;
  B(0, 1) = g[1] + a1 * c2 + 2 * a2 * c3 + a3 * c23;
  B(0, 2) = g[0] + a2 * c3 + a3 * c23;
  B(1, 1) = g[1] + 2 * a2 * c3;
  B(1, 2) = g[0] + a2 * c3;
  B(2, 2) = g[0];
  B(1, 0) = B(0, 1);
  B(2, 0) = B(0, 2);
  B(2, 1) = B(1, 2);
  return B;
}

std::array<Mat3, 3> inertia_partials(const ArmParams& p, const Vec3& q) noexcept {
  const auto& g = p.gamma;
  const auto& l = p.link_length;
  const double a1 = g[4] * l(0), a2 = g[5] * l(1), a3 = g[5] * l(0);
  const double s2 = std::sin(q(1)), s3 = std::sin(q(2)), s23 = std::sin(q(1) + q(2));
  std::array<Mat3, 3> dB{Mat3::Zero(), Mat3::Zero(), Mat3::Zero()};  // B does not depend on q1
  Mat3& d2 = dB[1];
  d2(0, 0) = -2 * a1 * s2 - 2 * a3 * s23;
  d2(0, 1) = -a1 * s2 - a3 * s23;
  d2(0, 2) = -a3 * s23;
  Mat3& d3 = dB[2];
  d3(0, 0) = -2 * a2 * s3 - 2 * a3 * s23;
  d3(0, 1) = -2 * a2 * s3 - a3 * s23;
  d3(0, 2) = -a2 * s3 - a3 * s23;
  d3(1, 1) = -2 * a2 * s3;
  d3(1, 2) = -a2 * s3;
  for (Mat3* d : {&d2, &d3}) {
    (*d)(1, 0) = (*d)(0, 1);
    (*d)(2, 0) = (*d)(0, 2);
    (*d)(2, 1) = (*d)(1, 2);
  }
  return dB;
}

Mat3 coriolis(const ArmParams& p, const Vec3& q, const Vec3& qd) noexcept {
  // Christoffel symbols of the first kind: c_ij = sum_k 1/2 (dB_ij/dq_k + dB_ik/dq_j - dB_jk/dq_i) q'_k.
  const auto dB = inertia_partials(p, q);
  Mat3 C = Mat3::Zero();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double c = 0.0;
      for (int k = 0; k < 3; ++k) {
        c += 0.5 * (dB[k](i, j) + dB[j](i, k) - dB[i](j, k)) * qd(k);
      }
      C(i, j) = c;
    }
  }
  return C;
}

Vec3 gravity(const ArmParams& p, const Vec3& q) noexcept {
  const auto& g = p.gamma;
  const double s1 = std::sin(q(0)), s12 = std::sin(q(0) + q(1)), s123 = std::sin(q(0) + q(1) + q(2));
  // Published formula (model-parameters.md Sec. 1) with the sign flipped for y up.
  const double t3 = p.g0 * g[5] * s123;
  const double t2 = p.g0 * g[4] * s12 + t3;
  const double t1 = g[3] * (p.g0 / kIdentifiedG0) * s1 + t2;  // gamma_4 was identified with g0 = 9.81
  return {-t1, -t2, -t3};
}

double potential_energy(const ArmParams& p, const Vec3& q) noexcept {
  const auto& g = p.gamma;
  return g[3] * (p.g0 / kIdentifiedG0) * std::cos(q(0)) + p.g0 * g[4] * std::cos(q(0) + q(1)) +
         p.g0 * g[5] * std::cos(q(0) + q(1) + q(2));
}

Vec3 friction(const ArmParams& p, const Vec3& qd, double band) noexcept {
  Vec3 f;
  for (int i = 0; i < 3; ++i) {
    const double sgn = band > 0.0 ? std::tanh(qd(i) / band) : (qd(i) > 0.0) - (qd(i) < 0.0);
    f(i) = p.viscous(i) * qd(i) + p.coulomb(i) * sgn;
  }
  return f;
}

Vec3 nonlinear_terms(const ArmParams& p, const Vec3& q, const Vec3& qd) noexcept {
  // eq. (3): n = C q' + Fv q' + Fs sgn(q') + g(q)
  return coriolis(p, q, qd) * qd + friction(p, qd, p.coulomb_band) + gravity(p, q);
}

Vec3 forward_dynamics(const ArmParams& p, const Vec3& q, const Vec3& qd, const Vec3& tau,
                      const Vec3& h) noexcept {
  const Mat3 B = inertia(p, q);
  const Vec3 rhs = tau - nonlinear_terms(p, q, qd) - jacobian(p, q).transpose() * h;  // eq. (2)
  return B.llt().solve(rhs);
}

double kinetic_energy(const ArmParams& p, const Vec3& q, const Vec3& qd) noexcept {
  return 0.5 * qd.dot(inertia(p, q) * qd);
}

bool inverse_kinematics(const ArmParams& p, const Vec3& x, double elbow_sign, Vec3& q) noexcept {
  const auto& l = p.link_length;
  const double phi = x(2);
  // Wrist point in the arm's base frame.
  const double wx = x(0) - p.base(0) - l(2) * std::sin(phi);
  const double wy = x(1) - p.base(1) - l(2) * std::cos(phi);
  const double r2 = wx * wx + wy * wy;
  const double c2 = (r2 - l(0) * l(0) - l(1) * l(1)) / (2.0 * l(0) * l(1));
  if (c2 < -1.0 || c2 > 1.0) return false;
  const double q2 = (elbow_sign >= 0.0 ? 1.0 : -1.0) * std::acos(c2);
  // Angles are measured from +y clockwise, so atan2 takes (x, y).
  const double q1 = std::atan2(wx, wy) - std::atan2(l(1) * std::sin(q2), l(0) + l(1) * std::cos(q2));
  q = Vec3(q1, q2, phi - q1 - q2);
  return true;
}

bool inverse_kinematics(const ArmParams& p, const Vec3& x, double elbow_sign, JointVec& q) noexcept {
  Vec3 q3;
  if (!inverse_kinematics(p, x, elbow_sign, q3)) return false;
  q = q3;
  return true;
}

}  // namespace tandem::model
