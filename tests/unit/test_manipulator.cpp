// Unit tests of the manipulator model interface (issue "heterogeneous modules"): for each type (the
// identified planar 3R, the cartesian PPR, the redundant planar 4R) the Jacobian and its derivative against
// finite differences, B symmetric positive definite, B' - 2C skew and C q' the Lagrangian Coriolis vector,
// gravity the gradient of U, energy conserved with no torque and no friction, and free fall against an
// independent computation (the test's own centre-of-mass geometry and a Lagrangian by finite differences,
// and for the PPR the closed-form parabola).
#include <catch2/catch.hpp>

#include "test_support.hpp"

#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tandem/model/manipulator.hpp"

namespace {

namespace mdl = tandem::model;
using mdl::JointMat;
using mdl::JointVec;
using mdl::kPi;
using mdl::Vec2;
using mdl::Vec3;

struct Case {
  std::string name;
  std::unique_ptr<mdl::Manipulator> model;
  std::unique_ptr<mdl::Manipulator> frictionless;
};

mdl::ArmParams frictionless(mdl::ArmParams p) {
  p.viscous.setZero();
  p.coulomb.setZero();
  return p;
}
mdl::ChainParams frictionless(mdl::ChainParams p) {
  p.joints.viscous.fill(0.0);
  p.joints.coulomb.fill(0.0);
  return p;
}

std::vector<Case> all_types() {
  std::vector<Case> out;
  mdl::ArmParams smart = mdl::smart3s2();
  smart.base = Vec2(-0.9, 0.0);
  out.push_back({"planar_3r", mdl::make_manipulator(smart), mdl::make_manipulator(frictionless(smart))});
  mdl::ChainParams ppr = mdl::cartesian_ppr();
  ppr.joints.base = Vec2(0.9, 0.0);
  out.push_back({"cartesian_ppr", mdl::make_manipulator(ppr), mdl::make_manipulator(frictionless(ppr))});
  mdl::ChainParams r4 = mdl::planar_4r();
  r4.joints.base = Vec2(0.9, 0.2);
  out.push_back({"planar_4r", mdl::make_manipulator(r4), mdl::make_manipulator(frictionless(r4))});
  return out;
}

JointVec random_joints(const mdl::Manipulator& m, tandem::test::Lcg& rng, double scale) {
  JointVec q(m.dof());
  for (int i = 0; i < m.dof(); ++i) {
    const bool prismatic = m.joints().type[static_cast<size_t>(i)] == mdl::JointType::Prismatic;
    q(i) = prismatic ? rng.uniform(-0.8, 0.8) * scale : rng.uniform(-2.5, 2.5) * scale;
  }
  return q;
}

double max_abs(const Eigen::MatrixXd& m) { return m.size() == 0 ? 0.0 : m.cwiseAbs().maxCoeff(); }

/// One RK4 step of a free arm (no torque, no contact).
struct State {
  JointVec q, qd;
};
State rk4(const State& s, double h,
          const std::function<JointVec(const JointVec&, const JointVec&)>& accel) {
  const JointVec k1q = s.qd, k1v = accel(s.q, s.qd);
  const JointVec k2q = s.qd + 0.5 * h * k1v, k2v = accel(s.q + 0.5 * h * k1q, s.qd + 0.5 * h * k1v);
  const JointVec k3q = s.qd + 0.5 * h * k2v, k3v = accel(s.q + 0.5 * h * k2q, s.qd + 0.5 * h * k2v);
  const JointVec k4q = s.qd + h * k3v, k4v = accel(s.q + h * k3q, s.qd + h * k3v);
  return {s.q + (h / 6.0) * (k1q + 2.0 * k2q + 2.0 * k3q + k4q), s.qd + (h / 6.0) * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)};
}

// ----- the test's own geometry of each chain: centres of mass by hand, not by the library's chain code -----

Vec2 d(double a) { return {std::sin(a), std::cos(a)}; }

/// Centres of mass, masses and inertias of a PlanarChain's bodies, written out per type.
struct Bodies {
  std::vector<Vec2> com;
  std::vector<double> angle;  // absolute body angle (for the rotational energy)
};
Bodies hand_bodies(const mdl::ChainParams& p, const JointVec& q) {
  Bodies b;
  const Vec2 base = p.joints.base;
  if (p.kind == mdl::ArmKind::CartesianPPR) {
    // carriage at (q1, 0), column at (q1, q2), wrist link from (q1, q2) at angle q3
    const Vec2 c(q(0), q(1));
    b.com = {base + Vec2(q(0), 0.0), base + c, base + c + p.bodies[2].com * d(q(2))};
    b.angle = {0.0, 0.0, q(2)};
  } else {
    Vec2 joint = base;
    double a = 0.0;
    for (int k = 0; k < 4; ++k) {
      a += q(k);
      const auto& body = p.bodies[static_cast<size_t>(k)];
      b.com.push_back(joint + body.com * d(a));
      b.angle.push_back(a);
      joint += body.length * d(a);
    }
  }
  return b;
}

/// Kinetic and potential energy from the hand geometry; velocities by central differences along q'.
double hand_kinetic(const mdl::ChainParams& p, const JointVec& q, const JointVec& qd) {
  const double h = 1e-6;
  const Bodies a = hand_bodies(p, q + h * qd), b = hand_bodies(p, q - h * qd);
  double t = 0.0;
  for (size_t k = 0; k < a.com.size(); ++k) {
    const Vec2 v = (a.com[k] - b.com[k]) / (2.0 * h);
    const double w = (a.angle[k] - b.angle[k]) / (2.0 * h);
    t += 0.5 * p.bodies[k].mass * v.squaredNorm() + 0.5 * p.bodies[k].inertia * w * w;
  }
  return t;
}
double hand_potential(const mdl::ChainParams& p, const JointVec& q) {
  const Bodies b = hand_bodies(p, q);
  double u = 0.0;
  for (size_t k = 0; k < b.com.size(); ++k) u += p.joints.g0 * p.bodies[k].mass * b.com[k](1);
  return u;
}

/// B from the hand kinetic energy: B_ij = T(e_i + e_j) - T(e_i) - T(e_j) (T is quadratic in q').
Eigen::MatrixXd hand_inertia(const mdl::ChainParams& p, const JointVec& q) {
  const int n = p.joints.dof;
  Eigen::MatrixXd B(n, n);
  auto unit = [n](int i) {
    JointVec e = JointVec::Zero(n);
    e(i) = 1.0;
    return e;
  };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double tij = hand_kinetic(p, q, unit(i) + unit(j));
      B(i, j) = tij - hand_kinetic(p, q, unit(i)) - hand_kinetic(p, q, unit(j));
    }
  }
  return B;
}

/// The Lagrangian's free acceleration: B q'' = -(B' q' - 1/2 d/dq (q'^T B q')) - dU/dq, all by differences
/// of the hand energies.
JointVec hand_free_acceleration(const mdl::ChainParams& p, const JointVec& q, const JointVec& qd) {
  const int n = p.joints.dof;
  const double h = 1e-5;
  const Eigen::MatrixXd B = hand_inertia(p, q);
  const Eigen::MatrixXd Bdot = (hand_inertia(p, q + h * qd) - hand_inertia(p, q - h * qd)) / (2.0 * h);
  Eigen::VectorXd rhs = -Bdot * Eigen::VectorXd(qd);
  for (int k = 0; k < n; ++k) {
    JointVec e = JointVec::Zero(n);
    e(k) = h;
    const double dT = (hand_kinetic(p, q + e, qd) - hand_kinetic(p, q - e, qd)) / (2.0 * h);
    const double dU = (hand_potential(p, q + e) - hand_potential(p, q - e)) / (2.0 * h);
    rhs(k) += dT - dU;
  }
  const Eigen::VectorXd qdd = B.ldlt().solve(rhs);
  return JointVec(qdd);
}

}  // namespace

TEST_CASE("manipulator types: the Jacobian and its derivative match finite differences", "[manipulator]") {
  tandem::test::Lcg rng(7);
  for (const Case& c : all_types()) {
    INFO(c.name);
    const mdl::Manipulator& m = *c.model;
    for (int s = 0; s < 20; ++s) {
      const JointVec q = random_joints(m, rng, 1.0), qd = random_joints(m, rng, 1.0);
      const double h = 1e-6;
      Eigen::MatrixXd Jfd(3, m.dof());
      for (int k = 0; k < m.dof(); ++k) {
        JointVec dq = JointVec::Zero(m.dof());
        dq(k) = h;
        Jfd.col(k) = (m.forward_kinematics(q + dq) - m.forward_kinematics(q - dq)) / (2.0 * h);
      }
      CHECK(max_abs(Eigen::MatrixXd(m.jacobian(q)) - Jfd) < 1e-7);
      const Eigen::MatrixXd Jdfd =
          (Eigen::MatrixXd(m.jacobian(q + h * qd)) - Eigen::MatrixXd(m.jacobian(q - h * qd))) / (2.0 * h);
      CHECK(max_abs(Eigen::MatrixXd(m.jacobian_dot(q, qd)) - Jdfd) < 1e-6);
    }
  }
}

TEST_CASE("manipulator types: B is symmetric positive definite, B' - 2C is skew, C q' is Lagrange's", "[manipulator]") {
  tandem::test::Lcg rng(11);
  for (const Case& c : all_types()) {
    INFO(c.name);
    const mdl::Manipulator& m = *c.model;
    const int n = m.dof();
    for (int s = 0; s < 20; ++s) {
      const JointVec q = random_joints(m, rng, 1.0), qd = random_joints(m, rng, 1.0);
      const Eigen::MatrixXd B = m.inertia(q);
      CHECK(max_abs(B - B.transpose()) < 1e-12);
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(B);
      CHECK(eig.eigenvalues().minCoeff() > 1e-3);
      const double h = 1e-6;
      const Eigen::MatrixXd Bdot = (Eigen::MatrixXd(m.inertia(q + h * qd)) - Eigen::MatrixXd(m.inertia(q - h * qd))) / (2.0 * h);
      const Eigen::MatrixXd N = Bdot - 2.0 * Eigen::MatrixXd(m.coriolis(q, qd));
      CHECK(max_abs(N + N.transpose()) < 1e-6 * (1.0 + max_abs(Bdot)));
      // Lagrange: C q' = B' q' - 1/2 d/dq (q'^T B q')
      Eigen::VectorXd lag = Bdot * Eigen::VectorXd(qd);
      for (int k = 0; k < n; ++k) {
        JointVec e = JointVec::Zero(n);
        e(k) = h;
        lag(k) -= (m.kinetic_energy(q + e, qd) - m.kinetic_energy(q - e, qd)) / (2.0 * h);
      }
      const Eigen::VectorXd Cqd = m.coriolis(q, qd) * qd;
      CHECK(max_abs(Cqd - lag) < 1e-5 * (1.0 + lag.cwiseAbs().maxCoeff()));
      // gravity is the gradient of U
      Eigen::VectorXd grad(n);
      for (int k = 0; k < n; ++k) {
        JointVec e = JointVec::Zero(n);
        e(k) = h;
        grad(k) = (m.potential_energy(q + e) - m.potential_energy(q - e)) / (2.0 * h);
      }
      CHECK(max_abs(Eigen::VectorXd(m.gravity(q)) - grad) < 1e-6 * (1.0 + grad.cwiseAbs().maxCoeff()));
    }
  }
}

TEST_CASE("manipulator types: with no torque and no friction energy is conserved", "[manipulator]") {
  // RK4 at 0.1 ms over 2 s from a leaning pose at rest: the total energy drifts by less than 1e-6 of the
  // largest kinetic energy reached (RK4's local error is O(h^5); the arms swing through their whole range).
  tandem::test::Lcg rng(5);
  for (const Case& c : all_types()) {
    INFO(c.name);
    const mdl::Manipulator& m = *c.frictionless;
    State s{random_joints(m, rng, 0.4), JointVec::Zero(m.dof())};
    const auto accel = [&m](const JointVec& q, const JointVec& qd) {
      return m.forward_dynamics(q, qd, JointVec::Zero(m.dof()), Vec3::Zero());
    };
    const double e0 = m.potential_energy(s.q);
    double max_kinetic = 0.0, max_drift = 0.0;
    for (int i = 0; i < 20000; ++i) {
      s = rk4(s, 1e-4, accel);
      const double ke = m.kinetic_energy(s.q, s.qd);
      max_kinetic = std::max(max_kinetic, ke);
      max_drift = std::max(max_drift, std::abs(ke + m.potential_energy(s.q) - e0));
    }
    CHECK(max_kinetic > 1.0);  // it did swing or fall
    CHECK(max_drift < 1e-6 * max_kinetic);
    // With friction, energy only goes down.
    const mdl::Manipulator& f = *c.model;
    State r{random_joints(f, rng, 0.4), JointVec::Zero(f.dof())};
    const auto accel_f = [&f](const JointVec& q, const JointVec& qd) {
      return f.forward_dynamics(q, qd, JointVec::Zero(f.dof()), Vec3::Zero());
    };
    double prev = f.potential_energy(r.q);
    bool monotone = true;
    for (int i = 0; i < 5000; ++i) {
      r = rk4(r, 1e-4, accel_f);
      const double e = f.kinetic_energy(r.q, r.qd) + f.potential_energy(r.q);
      monotone = monotone && e <= prev + 1e-9;
      prev = e;
    }
    CHECK(monotone);
  }
}

TEST_CASE("cartesian PPR: free fall is the parabola, with the wrist upright and still", "[manipulator]") {
  mdl::ChainParams p = frictionless(mdl::cartesian_ppr());
  const mdl::PlanarChain m(p);
  State s{JointVec(3), JointVec::Zero(3)};
  s.q << 0.3, 1.0, 0.0;
  const auto accel = [&m](const JointVec& q, const JointVec& qd) {
    return m.forward_dynamics(q, qd, JointVec::Zero(3), Vec3::Zero());
  };
  const double h = 1e-3;
  for (int i = 0; i < 500; ++i) s = rk4(s, h, accel);
  const double t = 0.5;
  CHECK(s.q(0) == Approx(0.3).margin(1e-12));
  CHECK(s.q(1) == Approx(1.0 - 0.5 * p.joints.g0 * t * t).margin(1e-10));
  CHECK(s.qd(1) == Approx(-p.joints.g0 * t).margin(1e-10));
  CHECK(s.q(2) == Approx(0.0).margin(1e-12));
  // The end-effector falls with it: the tool tip is l3 above the column.
  const Vec3 x = m.forward_kinematics(s.q);
  CHECK(x(1) == Approx(s.q(1) + 0.34).margin(1e-12));
}

TEST_CASE("chain types: free fall matches an independent Lagrangian of the bodies", "[manipulator]") {
  // The test's own centre-of-mass geometry (hand_bodies) gives T and U; B, the Coriolis vector and g come
  // from differences of those energies. The library's forward dynamics must agree at random states, and a
  // one-second fall integrated both ways must end in the same state.
  tandem::test::Lcg rng(3);
  for (mdl::ChainParams p : {frictionless(mdl::cartesian_ppr()), frictionless(mdl::planar_4r())}) {
    INFO(mdl::arm_kind_name(p.kind));
    p.joints.base = Vec2(0.4, -0.1);
    const mdl::PlanarChain m(p);
    const int n = m.dof();
    for (int s = 0; s < 10; ++s) {
      const JointVec q = random_joints(m, rng, 1.0), qd = random_joints(m, rng, 0.5);
      CHECK(max_abs(Eigen::MatrixXd(m.inertia(q)) - hand_inertia(p, q)) < 1e-5);
      const JointVec lib = m.forward_dynamics(q, qd, JointVec::Zero(n), Vec3::Zero());
      const JointVec ref = hand_free_acceleration(p, q, qd);
      CHECK(max_abs(Eigen::VectorXd(lib - ref)) < 1e-3 * (1.0 + ref.cwiseAbs().maxCoeff()));
    }
    State a{random_joints(m, rng, 0.3), JointVec::Zero(n)};
    State b = a;
    const auto lib = [&m, n](const JointVec& q, const JointVec& qd) {
      return m.forward_dynamics(q, qd, JointVec::Zero(n), Vec3::Zero());
    };
    const auto ref = [&p](const JointVec& q, const JointVec& qd) { return hand_free_acceleration(p, q, qd); };
    for (int i = 0; i < 200; ++i) {
      a = rk4(a, 5e-3, lib);
      b = rk4(b, 5e-3, ref);
    }
    CHECK(max_abs(Eigen::VectorXd(a.q - b.q)) < 1e-4);
    CHECK(a.qd.norm() > 0.5);  // it did fall
  }
}

TEST_CASE("a chain built as a 3R equals the identified lumped model with the matching gammas", "[manipulator]") {
  // Two derivations of the same arm: the chain's sums over bodies, and the paper's closed-form B, C, g with
  // gamma_1..6 computed from the bodies (gamma_1 = I3 + m3 c3^2, gamma_5 = m2 c2 + m3 l2, gamma_6 = m3 c3, ...).
  const std::array<double, 3> l{0.65, 0.6576, 0.34}, c{0.3, 0.35, 0.12}, mass{30.0, 18.0, 5.0},
      I{1.1, 0.7, 0.05};
  mdl::ChainParams cp;
  cp.kind = mdl::ArmKind::Planar3R;
  cp.joints.dof = 3;
  for (size_t k = 0; k < 3; ++k) cp.bodies[k] = mdl::ChainBody{mdl::JointType::Revolute, 0.0, l[k], c[k], mass[k], I[k]};
  cp.joints.base = Vec2(-0.9, 0.0);
  mdl::ArmParams ap;
  ap.link_length = Vec3(l[0], l[1], l[2]);
  ap.base = cp.joints.base;
  ap.viscous.setZero();
  ap.coulomb.setZero();
  ap.gamma[0] = I[2] + mass[2] * c[2] * c[2];
  ap.gamma[1] = I[1] + mass[1] * c[1] * c[1] + I[2] + mass[2] * (l[1] * l[1] + c[2] * c[2]);
  ap.gamma[2] = I[0] + mass[0] * c[0] * c[0] + I[1] + mass[1] * (l[0] * l[0] + c[1] * c[1]) + I[2] +
                mass[2] * (l[0] * l[0] + l[1] * l[1] + c[2] * c[2]);
  ap.gamma[3] = 9.81 * (mass[0] * c[0] + (mass[1] + mass[2]) * l[0]);
  ap.gamma[4] = mass[1] * c[1] + mass[2] * l[1];
  ap.gamma[5] = mass[2] * c[2];
  const mdl::PlanarChain chain(cp);
  const mdl::Planar3R lumped(ap);
  tandem::test::Lcg rng(17);
  for (int s = 0; s < 20; ++s) {
    const JointVec q = random_joints(chain, rng, 1.0), qd = random_joints(chain, rng, 1.0);
    CHECK(max_abs(Eigen::VectorXd(chain.forward_kinematics(q) - lumped.forward_kinematics(q))) < 1e-12);
    CHECK(max_abs(Eigen::MatrixXd(chain.jacobian(q) - lumped.jacobian(q))) < 1e-12);
    CHECK(max_abs(Eigen::MatrixXd(chain.jacobian_dot(q, qd) - lumped.jacobian_dot(q, qd))) < 1e-12);
    CHECK(max_abs(Eigen::MatrixXd(chain.inertia(q) - lumped.inertia(q))) < 1e-10);
    CHECK(max_abs(Eigen::VectorXd(chain.coriolis(q, qd) * qd - lumped.coriolis(q, qd) * qd)) < 1e-9);
    CHECK(max_abs(Eigen::VectorXd(chain.gravity(q) - lumped.gravity(q))) < 1e-9);
  }
}

TEST_CASE("arm kind names round-trip and an unknown name is refused", "[manipulator]") {
  for (mdl::ArmKind k : {mdl::ArmKind::Planar3R, mdl::ArmKind::CartesianPPR, mdl::ArmKind::Planar4R}) {
    mdl::ArmKind back = mdl::ArmKind::Planar3R;
    REQUIRE(mdl::parse_arm_kind(mdl::arm_kind_name(k), back));
    CHECK(back == k);
  }
  mdl::ArmKind out = mdl::ArmKind::CartesianPPR;
  CHECK_FALSE(mdl::parse_arm_kind("scara", out));
  CHECK(out == mdl::ArmKind::CartesianPPR);
}

// ----- the hybrid controller through the interface ------------------------------------------------------

#include "tandem/model/controller.hpp"

namespace {

/// A free-space reference: a circle of radius 5 cm at 1 rad/s around c, orientation swinging by 0.1 rad.
mdl::ArmReference circle(const Vec3& c, double t) {
  mdl::ArmReference r;
  r.x = c + Vec3(0.05 * std::sin(t), 0.05 * (1.0 - std::cos(t)), 0.1 * std::sin(t));
  r.xd = Vec3(0.05 * std::cos(t), 0.05 * std::sin(t), 0.1 * std::cos(t));
  r.xdd = Vec3(-0.05 * std::sin(t), 0.05 * std::cos(t), -0.1 * std::sin(t));
  return r;
}

std::shared_ptr<const mdl::Manipulator> shared_model(const std::string& name) {
  mdl::ArmParams smart = mdl::smart3s2();
  if (name == "planar_3r") return std::make_shared<const mdl::Planar3R>(smart);
  return std::make_shared<const mdl::PlanarChain>(name == "cartesian_ppr" ? mdl::cartesian_ppr() : mdl::planar_4r());
}

/// A start pose of each type inside its workspace, away from singularities.
JointVec start_pose(const mdl::Manipulator& m) {
  JointVec q(m.dof());
  if (m.kind() == mdl::ArmKind::Planar3R) q << 0.5, 1.0, 0.4;
  if (m.kind() == mdl::ArmKind::CartesianPPR) q << 0.4, 0.8, 1.2;
  if (m.kind() == mdl::ArmKind::Planar4R) q << 0.4, 0.7, 0.6, 0.3;
  return q;
}

}  // namespace

TEST_CASE("every type tracks a free-space reference with the sliding-mode and PD laws through the interface", "[manipulator][controller]") {
  // Position control on all three axes (Sigma_p = I), the plant the same model with its friction; 4 s at 1 kHz,
  // the plant integrated with RK4 at 0.1 ms (the smoothed Coulomb term of a light distal link is stiff: its
  // time constant, the link's inertia over Fs / band, is about 0.2 ms). The error after the reaching phase stays within a few mm / mrad.
  for (const char* name : {"planar_3r", "cartesian_ppr", "planar_4r"}) {
    for (mdl::LawType law : {mdl::LawType::SlidingMode, mdl::LawType::PD, mdl::LawType::SuperTwisting}) {
      INFO(name << " law " << static_cast<int>(law));
      const auto model = shared_model(name);
      mdl::HybridParams hp;
      hp.selection_p = Vec3::Ones();
      hp.law.type = law;
      hp.feedforward_position = true;
      mdl::HybridController ctl(model, hp);
      State s{start_pose(*model), JointVec::Zero(model->dof())};
      const Vec3 c = model->forward_kinematics(s.q) + Vec3(0.01, -0.01, 0.02);  // a small initial error
      double max_err = 0.0, max_qd = 0.0;
      JointVec tau = JointVec::Zero(model->dof());
      const auto accel = [&model, &tau](const JointVec& q, const JointVec& qd) {
        return model->forward_dynamics(q, qd, tau, Vec3::Zero());
      };
      for (int k = 0; k < 4000; ++k) {
        const double t = 1e-3 * k;
        mdl::ArmSensors in;
        in.q = s.q;
        in.qd = s.qd;
        const mdl::ArmReference ref = circle(c, t);
        const mdl::ControlOutput out = ctl.step(in, ref);
        REQUIRE(out.tau.size() == model->dof());
        REQUIRE(out.tau.allFinite());
        tau = out.tau;
        for (int i = 0; i < 10; ++i) s = rk4(s, 1e-4, accel);  // the module plant's 10 substeps
        if (t > 1.5) {
          const Vec3 e = circle(c, t + 1e-3).x - model->forward_kinematics(s.q);
          max_err = std::max({max_err, e.head<2>().norm(), std::abs(e(2))});
        }
        max_qd = std::max(max_qd, s.qd.cwiseAbs().maxCoeff());
      }
      CHECK(max_err < 5e-3);
      CHECK(max_qd < 2.0);  // bounded joint rates, the 4R's self-motion included
    }
  }
}

TEST_CASE("4R: the null-space task changes the joints' motion but not the end-effector's acceleration", "[manipulator][controller]") {
  // Two controllers that differ only in the null-space gains, at the same state: the task acceleration each one
  // commands, x'' = J B^-1 (tau - n) + J' q' on the matched model, is the same; the joint accelerations differ.
  const auto model = shared_model("planar_4r");
  tandem::test::Lcg rng(23);
  for (int trial = 0; trial < 20; ++trial) {
    mdl::HybridParams a, b;
    a.selection_p = b.selection_p = Vec3::Ones();
    a.null_space.k_posture = 0.0;
    a.null_space.k_damping = 0.0;
    b.null_space.k_posture = 40.0;
    b.null_space.k_damping = 15.0;
    JointVec rest(4);
    rest << 0.1, 0.2, 0.3, 0.4;
    a.null_space.q_rest = b.null_space.q_rest = rest;
    mdl::HybridController ca(model, a), cb(model, b);
    mdl::ArmSensors in;
    in.q = start_pose(*model) + random_joints(*model, rng, 0.1);
    in.qd = random_joints(*model, rng, 0.3);
    const mdl::ArmReference ref = circle(model->forward_kinematics(in.q), 0.3 * trial);
    const JointVec ta = ca.step(in, ref).tau, tb = cb.step(in, ref).tau;
    const JointVec n = model->nonlinear_terms(in.q, in.qd);
    const Eigen::MatrixXd B = model->inertia(in.q);
    const Eigen::VectorXd qdd_a = B.ldlt().solve(Eigen::VectorXd(ta - n)), qdd_b = B.ldlt().solve(Eigen::VectorXd(tb - n));
    const Eigen::MatrixXd J = model->jacobian(in.q);
    CHECK((J * (qdd_a - qdd_b)).norm() < 1e-9 * (1.0 + qdd_a.norm()));
    CHECK((qdd_a - qdd_b).norm() > 1e-3);  // the null-space task did act
  }
}

TEST_CASE("the controller refuses arms and postures it cannot serve, and sensors of the wrong size get no torque", "[manipulator][controller]") {
  mdl::HybridParams hp;
  JointVec three(3);
  three << 0.1, 0.2, 0.3;
  hp.null_space.q_rest = three;
  CHECK_THROWS_WITH(mdl::HybridController(shared_model("planar_4r"), hp),
                    Catch::Contains("q_rest has 3 entries for an arm of 4 joints"));
  mdl::ChainParams two = mdl::planar_4r();
  two.joints.dof = 2;
  CHECK_THROWS_WITH(mdl::HybridController(std::make_shared<const mdl::PlanarChain>(two), mdl::HybridParams{}),
                    Catch::Contains("at least 3 joints"));
  mdl::HybridController ctl(shared_model("planar_4r"), mdl::HybridParams{});
  mdl::ArmSensors in;  // 3 joints by default
  const mdl::ControlOutput out = ctl.step(in, mdl::ArmReference{});
  REQUIRE(out.tau.size() == 4);
  CHECK_FALSE(out.tau.allFinite());
}
