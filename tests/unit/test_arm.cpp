// Unit tests of the single-arm model (eq. 1-3): every quantity is checked against an independent
// computation (finite differences, geometry by hand, Lagrangian identities, energy balance).
#include <catch2/catch.hpp>

#include "test_support.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "tandem/model/arm.hpp"

namespace {

using tandem::model::ArmParams;
using tandem::model::kPi;
using tandem::model::Mat3;
using tandem::model::Vec2;
using tandem::model::Vec3;
namespace tm = tandem::model;

using tandem::test::Lcg;

/// Fixed pseudo-random joint configurations over the workspace [-2.5, 2.5]^3.
std::vector<Vec3> sample_configurations(int n, std::uint64_t seed) {
  Lcg rng(seed);
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) out.push_back(rng.vec3(-2.5, 2.5));
  return out;
}

double max_abs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

/// Position of the end-effector built link by link from 2-D rotations (independent of eq. 1's formula):
/// each link is the vector (0, l) rotated clockwise by the absolute link angle.
Vec3 chain_pose(const ArmParams& p, const Vec3& q) {
  Vec2 tip = p.base;
  double angle = 0.0;
  for (int i = 0; i < 3; ++i) {
    angle += q(i);
    Eigen::Matrix2d cw;  // clockwise rotation by `angle`
    cw << std::cos(angle), std::sin(angle), -std::sin(angle), std::cos(angle);
    tip += cw * Vec2(0.0, p.link_length(i));
  }
  return {tip(0), tip(1), angle};
}

/// Central finite-difference Jacobian of forward_kinematics.
Mat3 fd_jacobian(const ArmParams& p, const Vec3& q, double h) {
  Mat3 J;
  for (int k = 0; k < 3; ++k) {
    const Vec3 dq = h * Vec3::Unit(k);
    J.col(k) = (tm::forward_kinematics(p, q + dq) - tm::forward_kinematics(p, q - dq)) / (2.0 * h);
  }
  return J;
}

using tandem::test::ArmState;
using tandem::test::rk4;

double total_energy(const ArmParams& p, const ArmState& s) {
  return tm::kinetic_energy(p, s.q, s.qd) + tm::potential_energy(p, s.q);
}

}  // namespace

TEST_CASE("forward kinematics: upright pose and hand-computed poses", "[arm]") {
  ArmParams p = tm::smart3s2();
  p.base = Vec2(0.4, -0.7);
  const double l1 = p.link_length(0), l2 = p.link_length(1), l3 = p.link_length(2);

  SECTION("q = 0 stands straight up from the base") {
    const Vec3 x = tm::forward_kinematics(p, Vec3::Zero());
    CHECK(x(0) == Approx(0.4).margin(1e-15));
    CHECK(x(1) == Approx(-0.7 + l1 + l2 + l3).epsilon(1e-14));
    CHECK(x(2) == Approx(0.0).margin(1e-15));
  }

  SECTION("quarter-turn poses drawn by hand (clockwise from +y)") {
    struct Case {
      Vec3 q;
      Vec3 expected;  // base offset added below
    };
    const Case cases[] = {
        // link 1 along +x, link 2 back up (+y), link 3 along +x
        {Vec3(kPi / 2, -kPi / 2, kPi / 2), Vec3(l1 + l3, l2, kPi / 2)},
        // link 1 along +x, links 2 and 3 hanging down (-y)
        {Vec3(kPi / 2, kPi / 2, 0.0), Vec3(l1, -(l2 + l3), kPi)},
        // whole arm along -x (counter-clockwise quarter turn)
        {Vec3(-kPi / 2, 0.0, 0.0), Vec3(-(l1 + l2 + l3), 0.0, -kPi / 2)},
        // link 1 up, link 2 along +x, link 3 down
        {Vec3(0.0, kPi / 2, kPi / 2), Vec3(l2, l1 - l3, kPi)},
    };
    for (const auto& c : cases) {
      const Vec3 x = tm::forward_kinematics(p, c.q);
      const Vec3 want = c.expected + Vec3(p.base(0), p.base(1), 0.0);
      INFO("q = " << c.q.transpose() << "  x = " << x.transpose() << "  want = " << want.transpose());
      CHECK(max_abs(x - want) <= 1e-12);
    }
  }

  SECTION("agrees with a link-by-link chain of rotations over the workspace") {
    for (const Vec3& q : sample_configurations(200, 11)) {
      const Vec3 x = tm::forward_kinematics(p, q);
      const Vec3 want = chain_pose(p, q);
      INFO("q = " << q.transpose());
      CHECK(max_abs(x - want) <= 1e-12);
    }
  }
}

TEST_CASE("jacobian matches central finite differences of forward kinematics", "[arm]") {
  ArmParams p = tm::smart3s2();
  p.base = Vec2(-1.0, 0.0);
  for (const Vec3& q : sample_configurations(100, 21)) {
    const Mat3 J = tm::jacobian(p, q);
    const Mat3 Jfd = fd_jacobian(p, q, 1e-6);
    INFO("q = " << q.transpose() << "\nJ =\n" << J << "\nJ_fd =\n" << Jfd);
    CHECK(max_abs(J - Jfd) <= 1e-6 * (1.0 + max_abs(J)));
  }
}

TEST_CASE("jacobian_dot matches d/dt J(q + t q') by finite differences", "[arm]") {
  const ArmParams p = tm::smart3s2();
  Lcg rng(31);
  for (int i = 0; i < 100; ++i) {
    const Vec3 q = rng.vec3(-2.5, 2.5);
    const Vec3 qd = rng.vec3(-3.0, 3.0);
    const double h = 1e-6;
    const Mat3 Jd_fd = (tm::jacobian(p, q + h * qd) - tm::jacobian(p, q - h * qd)) / (2.0 * h);
    const Mat3 Jd = tm::jacobian_dot(p, q, qd);
    INFO("q = " << q.transpose() << "  qd = " << qd.transpose() << "\nJd =\n" << Jd << "\nfd =\n" << Jd_fd);
    CHECK(max_abs(Jd - Jd_fd) <= 1e-6 * (1.0 + max_abs(Jd)));
  }
}

TEST_CASE("inertia is symmetric positive definite and independent of q1", "[arm]") {
  const ArmParams p = tm::smart3s2();
  double min_eig_seen = 1e300;
  const int n = 41;
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      const double q2 = -2.5 + 5.0 * static_cast<double>(a) / (n - 1);
      const double q3 = -2.5 + 5.0 * static_cast<double>(b) / (n - 1);
      const Mat3 B = tm::inertia(p, Vec3(0.0, q2, q3));
      INFO("q2 = " << q2 << "  q3 = " << q3 << "\nB =\n" << B);
      CHECK(max_abs(B - B.transpose()) == 0.0);
      const Eigen::SelfAdjointEigenSolver<Mat3> eig(B);
      REQUIRE(eig.info() == Eigen::Success);
      CHECK(eig.eigenvalues().minCoeff() > 0.0);
      min_eig_seen = std::min(min_eig_seen, eig.eigenvalues().minCoeff());
      // B(q) must not depend on q1 (rotating the whole arm about joint 1 changes no relative geometry).
      for (double q1 : {-2.5, -0.7, 1.3, 2.5}) {
        CHECK(max_abs(tm::inertia(p, Vec3(q1, q2, q3)) - B) <= 1e-14);
      }
    }
  }
  INFO("smallest eigenvalue over the grid: " << min_eig_seen);
  CHECK(min_eig_seen > 1e-3);
}

TEST_CASE("inertia_partials match finite differences of inertia", "[arm]") {
  const ArmParams p = tm::smart3s2();
  for (const Vec3& q : sample_configurations(50, 41)) {
    const auto dB = tm::inertia_partials(p, q);
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6;
      const Vec3 dq = h * Vec3::Unit(k);
      const Mat3 fd = (tm::inertia(p, q + dq) - tm::inertia(p, q - dq)) / (2.0 * h);
      INFO("q = " << q.transpose() << "  k = " << k << "\ndB =\n" << dB[static_cast<size_t>(k)] << "\nfd =\n" << fd);
      CHECK(max_abs(dB[static_cast<size_t>(k)] - fd) <= 1e-6 * (1.0 + max_abs(fd)));
    }
  }
}

TEST_CASE("B' - 2C is skew-symmetric and C q' is the Lagrangian Coriolis vector", "[arm]") {
  const ArmParams p = tm::smart3s2();
  Lcg rng(51);
  for (int i = 0; i < 100; ++i) {
    const Vec3 q = rng.vec3(-2.5, 2.5);
    const Vec3 qd = rng.vec3(-3.0, 3.0);
    const double h = 1e-6;
    // B' along the motion, by central differences of inertia().
    const Mat3 Bdot = (tm::inertia(p, q + h * qd) - tm::inertia(p, q - h * qd)) / (2.0 * h);
    const Mat3 C = tm::coriolis(p, q, qd);
    const Mat3 N = Bdot - 2.0 * C;
    const double scale = 1.0 + max_abs(Bdot) + max_abs(C);
    INFO("q = " << q.transpose() << "  qd = " << qd.transpose() << "\nB' - 2C =\n" << N);
    CHECK(max_abs(N + N.transpose()) <= 1e-6 * scale);

    // Euler-Lagrange: d/dt (B q') - dT/dq = B q'' + [B' q' - 1/2 d/dq (q'^T B q')], so the velocity terms are
    // c = B' q' - 1/2 grad_q (q'^T B q'), here with the gradient by central differences.
    Vec3 grad;
    for (int k = 0; k < 3; ++k) {
      const Vec3 dq = h * Vec3::Unit(k);
      grad(k) = (qd.dot(tm::inertia(p, q + dq) * qd) - qd.dot(tm::inertia(p, q - dq) * qd)) / (2.0 * h);
    }
    const Vec3 c_lagrange = Bdot * qd - 0.5 * grad;
    const Vec3 c_model = C * qd;
    INFO("C q' = " << c_model.transpose() << "  Lagrangian = " << c_lagrange.transpose());
    CHECK(max_abs(c_model - c_lagrange) <= 1e-6 * (1.0 + c_lagrange.norm()));
  }
}

TEST_CASE("gravity is the gradient of the potential energy, which is highest upright", "[arm]") {
  ArmParams p = tm::smart3s2();
  for (const Vec3& q : sample_configurations(100, 61)) {
    const Vec3 g = tm::gravity(p, q);
    Vec3 grad;
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      const Vec3 dq = h * Vec3::Unit(k);
      grad(k) = (tm::potential_energy(p, q + dq) - tm::potential_energy(p, q - dq)) / (2.0 * h);
    }
    INFO("q = " << q.transpose() << "  g = " << g.transpose() << "  dU/dq = " << grad.transpose());
    CHECK(max_abs(g - grad) <= 1e-6 * (1.0 + grad.norm()));
  }
  // y up: lifting any link raises the potential. Upright is the maximum, hanging the minimum, and
  // horizontal is the zero reference.
  const double up = tm::potential_energy(p, Vec3::Zero());
  const double down = tm::potential_energy(p, Vec3(kPi, 0.0, 0.0));
  CHECK(up > 0.0);
  CHECK(down == Approx(-up).epsilon(1e-12));
  CHECK(tm::potential_energy(p, Vec3(kPi / 2, 0.0, 0.0)) == Approx(0.0).margin(1e-12));
  CHECK(tm::potential_energy(p, Vec3(-kPi / 2, 0.0, 0.0)) == Approx(0.0).margin(1e-12));
  // Upright is an equilibrium (zero torque), horizontal is not.
  CHECK(tm::gravity(p, Vec3::Zero()).norm() <= 1e-12);
  CHECK(tm::gravity(p, Vec3(kPi / 2, 0.0, 0.0)).norm() > 1.0);
}

TEST_CASE("a frictionless free-swinging arm conserves energy, and friction only dissipates", "[arm]") {
  const double h = 1e-4;
  const int steps = 20000;  // 2 s
  ArmState start;
  start.q = Vec3(0.4, -0.9, 1.2);
  start.qd = Vec3(0.5, -1.0, 2.0);

  SECTION("no friction, tau = 0: kinetic + potential is constant") {
    ArmParams p = tm::smart3s2();
    p.viscous.setZero();
    p.coulomb.setZero();
    ArmState s = start;
    const double e0 = total_energy(p, s);
    REQUIRE(std::abs(e0) > 10.0);  // the relative tolerance below is meaningful
    double worst = 0.0, max_ke = 0.0;
    for (int k = 0; k < steps; ++k) {
      s = rk4(p, s, Vec3::Zero(), h);
      worst = std::max(worst, std::abs(total_energy(p, s) - e0));
      max_ke = std::max(max_ke, tm::kinetic_energy(p, s.q, s.qd));
    }
    INFO("E0 = " << e0 << "  max |E - E0| = " << worst << "  max kinetic = " << max_ke);
    CHECK(max_ke > 50.0);  // the arm really swung (energy moved between the two forms)
    CHECK(worst <= 1e-6 * std::abs(e0));
  }

  SECTION("with friction, tau = 0: energy never increases and is dissipated") {
    const ArmParams p = tm::smart3s2();
    ArmState s = start;
    const double e0 = total_energy(p, s);
    double prev = e0, worst_rise = 0.0;
    for (int k = 0; k < steps; ++k) {
      s = rk4(p, s, Vec3::Zero(), h);
      const double e = total_energy(p, s);
      worst_rise = std::max(worst_rise, e - prev);
      prev = e;
    }
    INFO("E0 = " << e0 << "  E(2 s) = " << prev << "  largest one-step rise = " << worst_rise);
    CHECK(worst_rise <= 1e-9 * std::abs(e0));
    CHECK(prev < e0 - 1.0);
  }
}

TEST_CASE("a free arm leaning to +x falls clockwise and its tip drops", "[arm]") {
  for (bool with_friction : {true, false}) {
    ArmParams p = tm::smart3s2();
    if (!with_friction) {
      p.viscous.setZero();
      p.coulomb.setZero();
    }
    ArmState s;
    s.q = Vec3(0.1, 0.0, 0.0);
    const Vec3 x0 = tm::forward_kinematics(p, s.q);
    const double u0 = tm::potential_energy(p, s.q);
    const double h = 1e-4;
    for (int k = 0; k < 3000; ++k) s = rk4(p, s, Vec3::Zero(), h);  // 0.3 s
    const Vec3 x1 = tm::forward_kinematics(p, s.q);
    INFO("friction " << with_friction << ": q(0.3) = " << s.q.transpose() << "  tip " << x0.transpose()
                     << " -> " << x1.transpose());
    CHECK(x1(1) < x0(1));                            // the tip drops
    CHECK(x1(0) > x0(0));                            // towards the side it leans to
    CHECK(x1(2) > x0(2));                            // the tool axis turns clockwise
    CHECK(tm::potential_energy(p, s.q) < u0);        // it went downhill
    if (with_friction) {
      // With the identified (large) joint friction the arm creeps down without inertial recoil: q1 grows.
      // (Without friction the heavy distal links falling can swing q1 back a little at first, so q1 alone
      // is not a law there.)
      CHECK(s.q(0) > 0.1);
    }
  }
}

TEST_CASE("inverse kinematics round-trips forward kinematics on both elbow branches", "[arm]") {
  ArmParams p = tm::smart3s2();
  p.base = Vec2(-1.0, 0.0);
  int tested = 0;
  for (const Vec3& q : sample_configurations(200, 71)) {
    if (std::abs(std::sin(q(1))) < 0.05) continue;  // too close to the elbow singularity
    ++tested;
    const Vec3 x = tm::forward_kinematics(p, q);
    for (double elbow : {-1.0, 1.0}) {
      Vec3 qi;
      REQUIRE(tm::inverse_kinematics(p, x, elbow, qi));
      INFO("q = " << q.transpose() << "  elbow = " << elbow << "  IK = " << qi.transpose());
      CHECK(max_abs(tm::forward_kinematics(p, qi) - x) <= 1e-10);
      CHECK(qi(1) * elbow >= 0.0);
      if (elbow * q(1) > 0.0) {
        // Same branch: the joint angles themselves come back (modulo 2 pi).
        for (int i = 0; i < 3; ++i) CHECK(std::abs(tm::wrap_angle(qi(i) - q(i))) <= 1e-9);
      }
    }
  }
  CHECK(tested > 150);

  // Out of reach: farther from the base than the arm is long, and a wrist point closer to joint 1 than
  // |l1 - l2| (with phi pointing away so the wrist sits at the base).
  Vec3 qo;
  const double reach = p.link_length.sum();
  CHECK_FALSE(tm::inverse_kinematics(p, Vec3(-1.0 + reach + 0.05, 0.0, kPi / 2), 1.0, qo));
  CHECK_FALSE(tm::inverse_kinematics(p, Vec3(-1.0 + reach + 1e-6, 0.0, kPi / 2), 1.0, qo));  // just out
  CHECK(tm::inverse_kinematics(p, Vec3(-1.0 + reach - 1e-6, 0.0, kPi / 2), 1.0, qo));        // just in
  CHECK(max_abs(tm::forward_kinematics(p, qo) - Vec3(-1.0 + reach - 1e-6, 0.0, kPi / 2)) <= 1e-9);
  CHECK_FALSE(tm::inverse_kinematics(p, Vec3(-1.0, 2.0, 0.0), -1.0, qo));
  CHECK_FALSE(tm::inverse_kinematics(p, Vec3(-1.0 + p.link_length(2), 0.0, kPi / 2), 1.0, qo));
}

TEST_CASE("forward dynamics inverts the inverse dynamics", "[arm]") {
  const ArmParams p = tm::smart3s2();
  Lcg rng(81);
  for (int i = 0; i < 100; ++i) {
    const Vec3 q = rng.vec3(-2.5, 2.5);
    const Vec3 qd = rng.vec3(-2.0, 2.0);
    const Vec3 y = rng.vec3(-5.0, 5.0);
    const Vec3 h(rng.uniform(-50.0, 50.0), rng.uniform(-50.0, 50.0), rng.uniform(-5.0, 5.0));
    // tau = B y + C q' + Fv q' + Fs tanh(q'/band) + g + J^T h, assembled term by term.
    Vec3 fr;
    for (int k = 0; k < 3; ++k) {
      fr(k) = p.viscous(k) * qd(k) + p.coulomb(k) * std::tanh(qd(k) / p.coulomb_band);
    }
    const Vec3 tau = tm::inertia(p, q) * y + tm::coriolis(p, q, qd) * qd + fr + tm::gravity(p, q) +
                     tm::jacobian(p, q).transpose() * h;
    const Vec3 qdd = tm::forward_dynamics(p, q, qd, tau, h);
    INFO("q = " << q.transpose() << "  y = " << y.transpose() << "  q'' = " << qdd.transpose());
    CHECK(max_abs(qdd - y) <= 1e-8 * (1.0 + y.norm()));
  }
}
