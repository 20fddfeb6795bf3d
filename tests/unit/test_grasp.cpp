// Unit tests of the two-robot grasp (eq. 6-18), the supervisor's reference (eq. 15) and the module plant's
// contacts at rest, checked against independent linear algebra, statics and finite differences.
#include <catch2/catch.hpp>

#include "test_support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <cstdint>
#include <vector>

#include "tandem/model/arm.hpp"
#include "tandem/model/grasp.hpp"
#include "tandem/model/plant.hpp"
#include "tandem/model/reference.hpp"

namespace {

using tandem::model::kPi;
using tandem::model::Mat3;
using tandem::model::Vec2;
using tandem::model::Vec3;
namespace tmd = tandem::model;
using Mat12 = Eigen::Matrix<double, 12, 12>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

using tandem::test::Lcg;

double max_abs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

/// Grasp state built the way the embedded simulation builds its initial state (sim/src/embedded.cpp).
struct Grasp {
  tmd::ModuleParams params;
  tmd::ModuleState state;
  tmd::GraspGeometry geometry;
  double h_ref = 0.0;
};

Grasp make_grasp(const Vec3& object_pose, double h_ref) {
  Grasp g;
  g.h_ref = h_ref;
  g.params.arms[0].base = Vec2(-1.0, 0.0);
  g.params.arms[1].base = Vec2(1.0, 0.0);
  g.geometry.stick_length[0] = g.geometry.stick_length[1] = g.params.object.half_width;
  g.geometry.preload = h_ref / g.params.contact.k_normal;
  tmd::PoseSample p0;
  p0.pose = object_pose;
  const double elbow[2] = {-1.0, 1.0};
  for (int j = 0; j < 2; ++j) {
    const tmd::ArmReference r = tmd::arm_reference(j, p0, g.geometry, h_ref);
    const bool ok = tmd::inverse_kinematics(g.params.arms[static_cast<size_t>(j)], r.x, elbow[j],
                                           g.state.q[static_cast<size_t>(j)]);
    REQUIRE(ok);
  }
  g.state.c = object_pose.head<2>();
  g.state.psi = -object_pose(2);
  return g;
}

}  // namespace

TEST_CASE("grasp matrix: pseudo-inverse and null space identities", "[grasp]") {
  Lcg rng(101);
  for (int i = 0; i < 40; ++i) {
    // Planar sticks (as in the module) and general 3-D ones.
    Vec3 r1 = rng.vec3(-0.5, 0.5), r2 = rng.vec3(-0.5, 0.5);
    if (i % 2 == 0) r1(2) = r2(2) = 0.0;
    const tmd::Mat6x12 W = tmd::grasp_matrix(r1, r2);
    const tmd::Mat12x6 Wp = tmd::grasp_pseudo_inverse(W);
    INFO("r1 = " << r1.transpose() << "  r2 = " << r2.transpose());

    CHECK(max_abs(W * Wp - tmd::Mat6::Identity()) <= 1e-12);
    const Mat12 P = Wp * W;
    CHECK(max_abs(P - P.transpose()) <= 1e-12);
    CHECK(max_abs(P * P - P) <= 1e-12);

    // Against Eigen's own Moore-Penrose pseudo-inverse.
    const Eigen::MatrixXd pinv = Eigen::MatrixXd(W).completeOrthogonalDecomposition().pseudoInverse();
    CHECK(max_abs(Wp - pinv) <= 1e-10);

    // Null space: W V = 0, V orthonormal, and V V^T completes W^+ W to the identity.
    const tmd::Mat12x6 V = tmd::grasp_null_space(W);
    CHECK(max_abs(W * V) <= 1e-12);
    CHECK(max_abs(V.transpose() * V - tmd::Mat6::Identity()) <= 1e-12);
    CHECK(max_abs(P + V * V.transpose() - Mat12::Identity()) <= 1e-12);

    // Each block moves a wrench to the stick tip: force unchanged, moment about the tip = mu - r x f.
    const Vec6 h1 = (Vec6() << rng.vec3(-10, 10), rng.vec3(-3, 3)).finished();
    const Vec6 h2 = (Vec6() << rng.vec3(-10, 10), rng.vec3(-3, 3)).finished();
    Eigen::Matrix<double, 12, 1> h;
    h << h1, h2;
    const Vec6 sum = W * h;
    const Vec3 f = h1.head<3>() + h2.head<3>();
    const Vec3 mu = h1.tail<3>() - r1.cross(Vec3(h1.head<3>())) + h2.tail<3>() - r2.cross(Vec3(h2.head<3>()));
    CHECK(max_abs(sum.head<3>() - f) <= 1e-12);
    CHECK(max_abs(sum.tail<3>() - mu) <= 1e-12);
  }
}

TEST_CASE("planar grasp matrix (eq. 18) splits the object's load into equal halves", "[grasp]") {
  const Eigen::Matrix<double, 2, 4> W = tmd::planar_grasp_matrix();
  const Eigen::Matrix<double, 4, 2> Wp = tmd::planar_grasp_pseudo_inverse();
  CHECK(max_abs(W * Wp - Eigen::Matrix2d::Identity()) <= 1e-15);
  const Eigen::Matrix4d P = Wp * W;
  CHECK(max_abs(P - P.transpose()) <= 1e-15);
  CHECK(max_abs(P * P - P) <= 1e-15);

  // The same W^T (W W^T)^-1 formula as eq. (10), computed here.
  const Eigen::Matrix<double, 4, 2> formula = W.transpose() * (W * W.transpose()).inverse();
  CHECK(max_abs(Wp - formula) <= 1e-15);
  // The 6x12 grasp matrix with both sticks at the centre reduces to [I I]; its force rows/columns in the
  // plane are the planar pseudo-inverse.
  const tmd::Mat12x6 Wp6 = tmd::grasp_pseudo_inverse(tmd::grasp_matrix(Vec3::Zero(), Vec3::Zero()));
  Eigen::Matrix<double, 4, 2> restricted;
  restricted << Wp6.block<2, 2>(0, 0), Wp6.block<2, 2>(6, 0);
  CHECK(max_abs(Wp - restricted) <= 1e-12);

  // A weight wrench (and any other planar force) splits into two equal halves that sum back to it.
  const double M = 2.0, g0 = 9.81;
  for (const Vec2& hE : {Vec2(0.0, M * g0), Vec2(3.0, -1.5), Vec2(-7.25, 0.4)}) {
    const Eigen::Vector4d h = Wp * hE;
    CHECK(max_abs(h.head<2>() - 0.5 * hE) <= 1e-15);
    CHECK(max_abs(h.tail<2>() - 0.5 * hE) <= 1e-15);
    CHECK(max_abs(W * h - hE) <= 1e-15);
  }
}

TEST_CASE("safe grasp force (eq. 16): two friction cones carry exactly the weight", "[grasp]") {
  CHECK(tmd::safe_grasp_force(2.0, 0.5, 9.81) == Approx(19.62).epsilon(1e-14));
  for (double M : {0.5, 2.0, 7.3}) {
    for (double mu : {0.2, 0.5, 1.1}) {
      const double g0 = 9.81;
      const double N = tmd::safe_grasp_force(M, mu, g0);
      INFO("M = " << M << "  mu_s = " << mu);
      // Coulomb: each contact holds at most mu_s N along the face; two of them must hold M g.
      CHECK(2.0 * mu * N == Approx(M * g0).epsilon(1e-14));
      CHECK(tmd::safe_grasp_force(2.0 * M, mu, g0) == Approx(2.0 * N).epsilon(1e-14));
      CHECK(tmd::safe_grasp_force(M, 2.0 * mu, g0) == Approx(0.5 * N).epsilon(1e-14));
      CHECK(tmd::safe_grasp_holds(N, N));
      CHECK(tmd::safe_grasp_holds(1.01 * N, N));
      CHECK_FALSE(tmd::safe_grasp_holds(0.99 * N, N));
    }
  }
}

TEST_CASE("stick tips meet at the object centre, and absolute and relative pose (eq. 6, 11, 12)", "[grasp]") {
  const tmd::GraspGeometry g;  // defaults: sticks 0.3 m, phi_I = -pi, p_I = 0, preload 0
  for (const Vec3& pose : {Vec3(-0.2, 0.8, 0.0), Vec3(0.1, 0.9, 0.3), Vec3(0.25, 0.7, -0.4)}) {
    tmd::PoseSample obj;
    obj.pose = pose;
    const tmd::ArmReference r0 = tmd::arm_reference(0, obj, g, 0.0);
    const tmd::ArmReference r1 = tmd::arm_reference(1, obj, g, 0.0);
    INFO("object pose " << pose.transpose() << "  x0 = " << r0.x.transpose() << "  x1 = " << r1.x.transpose());
    // Left arm points along +x rotated clockwise by phi_E, right arm the opposite way.
    CHECK(r0.x(2) == Approx(pose(2) + kPi / 2).epsilon(1e-15));
    CHECK(r1.x(2) == Approx(pose(2) - kPi / 2).epsilon(1e-15));
    // The end-effectors sit one stick length from the centre, on opposite sides.
    CHECK((r0.x.head<2>() - pose.head<2>()).norm() == Approx(0.3).epsilon(1e-14));
    CHECK(max_abs(r0.x.head<2>() + r1.x.head<2>() - 2.0 * pose.head<2>()) <= 1e-15);

    const Vec2 stick = tmd::virtual_stick(0.3, r0.x(2));
    CHECK(stick.norm() == Approx(0.3).epsilon(1e-15));
    CHECK(stick(0) == Approx(0.3 * std::sin(r0.x(2))).margin(1e-15));

    const Vec3 tip0 = tmd::stick_tip(r0.x, g.stick_length[0]);
    const Vec3 tip1 = tmd::stick_tip(r1.x, g.stick_length[1]);
    CHECK(max_abs(tip0.head<2>() - pose.head<2>()) <= 1e-14);
    CHECK(max_abs(tip1.head<2>() - pose.head<2>()) <= 1e-14);
    CHECK(max_abs(tmd::absolute_pose(tip0, tip1) - pose) <= 1e-14);
    const Vec3 rel = tmd::relative_pose(tip0, tip1);
    CHECK(max_abs(rel.head<2>()) <= 1e-14);
    CHECK(rel(2) == Approx(-kPi).epsilon(1e-15));
  }

  SECTION("a relative offset p_I shows up in relative_pose and not in absolute_pose") {
    tmd::GraspGeometry g2;
    g2.p_I = Vec2(0.02, -0.015);
    tmd::PoseSample obj;
    obj.pose = Vec3(0.05, 0.85, 0.2);
    const Vec3 tip0 = tmd::stick_tip(tmd::arm_reference(0, obj, g2, 0.0).x, 0.3);
    const Vec3 tip1 = tmd::stick_tip(tmd::arm_reference(1, obj, g2, 0.0).x, 0.3);
    CHECK(max_abs(tmd::relative_pose(tip0, tip1).head<2>() - g2.p_I) <= 1e-14);
    CHECK(max_abs(tmd::absolute_pose(tip0, tip1) - obj.pose) <= 1e-14);
  }
}

TEST_CASE("object path: continuity, derivatives by finite differences, rest at segment ends", "[grasp]") {
  const Vec3 start(-0.2, 0.8, 0.0);
  const Vec3 w1(0.1, 0.9, 0.0);
  const Vec3 w2(0.2, 0.8, 0.3);
  const tmd::ObjectPath path(start, 0.5, {tmd::ObjectPath::Segment{w1, 1.5}, tmd::ObjectPath::Segment{w2, 1.0}});
  REQUIRE(path.motion_end() == Approx(3.0).epsilon(1e-15));
  const double boundaries[] = {0.5, 2.0, 3.0};
  const Vec3 waypoints[] = {start, w1, w2};

  SECTION("continuous position and rest (zero velocity and acceleration) at the segment ends") {
    for (int b = 0; b < 3; ++b) {
      const double tb = boundaries[b];
      INFO("boundary t = " << tb);
      for (double eps : {1e-6, 1e-9}) {
        const tmd::PoseSample before = path.sample(tb - eps), after = path.sample(tb + eps);
        CHECK(max_abs(before.pose - waypoints[b]) <= 1e-8);
        CHECK(max_abs(after.pose - waypoints[b]) <= 1e-8);
        CHECK(max_abs(before.vel) <= 1e-8);
        CHECK(max_abs(after.vel) <= 1e-8);
        CHECK(max_abs(before.acc) <= 1e-3 * eps / 1e-6);
        CHECK(max_abs(after.acc) <= 1e-3 * eps / 1e-6);
      }
      const tmd::PoseSample at = path.sample(tb);
      CHECK(max_abs(at.pose - waypoints[b]) <= 1e-15);
      CHECK(max_abs(at.vel) <= 1e-15);
      CHECK(max_abs(at.acc) <= 1e-15);
    }
    // Holding before the first segment and after the last one.
    for (double t : {0.0, 0.25, 0.4999}) {
      const tmd::PoseSample s = path.sample(t);
      CHECK(max_abs(s.pose - start) == 0.0);
      CHECK(max_abs(s.vel) + max_abs(s.acc) == 0.0);
    }
    for (double t : {3.0, 3.5, 10.0}) {
      const tmd::PoseSample s = path.sample(t);
      CHECK(max_abs(s.pose - w2) == 0.0);
      CHECK(max_abs(s.vel) + max_abs(s.acc) == 0.0);
    }
    // No jumps anywhere on a fine grid: the step between samples is bounded by max speed * dt.
    double max_jump = 0.0;
    const double dt = 1e-4;
    for (int k = 0; k < 35000; ++k) {
      const double t = dt * static_cast<double>(k);
      max_jump = std::max(max_jump, max_abs(path.sample(t + dt).pose - path.sample(t).pose));
    }
    CHECK(max_jump <= 1.875 * 0.3 / 1.0 * dt * 1.0001);  // quintic peak speed 15/8 * distance / duration
  }

  SECTION("velocity and acceleration equal finite differences of pose and velocity") {
    const double h = 1e-5;
    for (int k = 0; k < 70; ++k) {
      const double t = 0.013 + 0.05 * static_cast<double>(k);  // never within h of a boundary
      const tmd::PoseSample s = path.sample(t);
      const Vec3 vel_fd = (path.sample(t + h).pose - path.sample(t - h).pose) / (2.0 * h);
      const Vec3 acc_fd = (path.sample(t + h).vel - path.sample(t - h).vel) / (2.0 * h);
      INFO("t = " << t << "  vel = " << s.vel.transpose() << "  fd = " << vel_fd.transpose()
                  << "\n acc = " << s.acc.transpose() << "  fd = " << acc_fd.transpose());
      CHECK(max_abs(s.vel - vel_fd) <= 1e-7);
      CHECK(max_abs(s.acc - acc_fd) <= 1e-7);
    }
  }

  SECTION("arm references (eq. 15) have exact derivatives while the object rotates") {
    tmd::GraspGeometry g;
    g.preload = 0.003;
    g.p_I = Vec2(0.01, -0.02);
    const double h = 1e-5;
    for (int j = 0; j < 2; ++j) {
      for (int k = 0; k < 70; ++k) {
        const double t = 0.013 + 0.05 * static_cast<double>(k);
        const tmd::ArmReference r = tmd::arm_reference(j, path.sample(t), g, 10.0);
        const tmd::ArmReference rp = tmd::arm_reference(j, path.sample(t + h), g, 10.0);
        const tmd::ArmReference rm = tmd::arm_reference(j, path.sample(t - h), g, 10.0);
        const Vec3 xd_fd = (rp.x - rm.x) / (2.0 * h);
        const Vec3 xdd_fd = (rp.xd - rm.xd) / (2.0 * h);
        INFO("arm " << j << "  t = " << t << "\n xd = " << r.xd.transpose() << "  fd = " << xd_fd.transpose()
                    << "\n xdd = " << r.xdd.transpose() << "  fd = " << xdd_fd.transpose());
        CHECK(max_abs(r.xd - xd_fd) <= 1e-7);
        CHECK(max_abs(r.xdd - xdd_fd) <= 1e-7);
        CHECK(r.force == 10.0);
        // The end-effector stays at (stick - preload) from its (offset) target point along its tool axis.
        const Vec2 target = path.sample(t).pose.head<2>() + (j == 0 ? -0.5 : 0.5) * g.p_I;
        CHECK((target - r.x.head<2>()).norm() == Approx(0.3 - 0.003).epsilon(1e-12));
      }
    }
  }
}

TEST_CASE("module plant at reset: pressing arms hold the object in static equilibrium", "[grasp]") {
  const double h = 29.43;  // 1.5 h_sg for M = 2, mu_s = 0.5
  Grasp g = make_grasp(Vec3(-0.2, 0.8, 0.0), h);
  tmd::ModulePlant plant(g.params);
  plant.reset(g.state);
  const tmd::ContactReading c = plant.contacts();
  const double M = g.params.object.mass, g0 = g.params.g0;

  for (int j = 0; j < 2; ++j) {
    INFO("contact " << j);
    CHECK(c.in_contact[static_cast<size_t>(j)]);
    CHECK(c.penetration[static_cast<size_t>(j)] == Approx(g.geometry.preload).epsilon(1e-9));
    CHECK(std::abs(c.normal[static_cast<size_t>(j)] - h) <= 1e-6);
    CHECK(std::abs(c.tangential[static_cast<size_t>(j)] - 0.5 * M * g0) <= 1e-9);
    // The sticking force is inside the static friction cone (the grasp is safe).
    CHECK(std::abs(c.tangential[static_cast<size_t>(j)]) <= g.params.object.mu_s * c.normal[static_cast<size_t>(j)]);
  }
  // Left arm pushes +x, right arm -x; both lift.
  CHECK(c.h[0](0) == Approx(h).epsilon(1e-6));
  CHECK(c.h[1](0) == Approx(-h).epsilon(1e-6));
  CHECK(std::abs(c.tangential[0] + c.tangential[1] - M * g0) <= 1e-9);
  // Newton: contact forces plus gravity cancel; the moments about the centre cancel too.
  const Vec2 net = c.h[0] + c.h[1] + Vec2(0.0, -M * g0);
  CHECK(max_abs(c.force_on_object - (c.h[0] + c.h[1])) <= 1e-12);
  CHECK(net.norm() <= 1e-6);
  CHECK(std::abs(c.torque_on_object) <= 1e-6);

  SECTION("holding torques g(q) + J^T h keep the whole module at rest") {
    std::array<Vec3, 2> tau;
    for (size_t j = 0; j < 2; ++j) {
      const Vec3 hj(c.h[j](0), c.h[j](1), 0.0);
      tau[j] = tmd::gravity(g.params.arms[j], g.state.q[j]) + tmd::jacobian(g.params.arms[j], g.state.q[j]).transpose() * hj;
    }
    const double e0 = plant.mechanical_energy();
    for (int k = 0; k < 100; ++k) plant.step(tau, 1e-3 * static_cast<double>(k), 1e-3, 10);
    const tmd::ModuleState& s = plant.state();
    INFO("object moved by " << (s.c - g.state.c).transpose() << ", psi " << s.psi);
    CHECK((s.c - g.state.c).norm() <= 1e-8);
    CHECK(std::abs(s.psi - g.state.psi) <= 1e-8);
    for (size_t j = 0; j < 2; ++j) CHECK(max_abs(s.q[j] - g.state.q[j]) <= 1e-8);
    CHECK(std::abs(plant.mechanical_energy() - e0) <= 1e-6);
    CHECK(plant.counters().slip_events == 0);
    CHECK(plant.counters().contact_lost == 0);
  }
}

TEST_CASE("brakes: locked arms hold the object by friction alone, a released arm falls", "[grasp]") {
  const double h = 29.43;  // 1.5 h_sg
  Grasp g = make_grasp(Vec3(-0.2, 0.8, 0.0), h);
  tmd::ModulePlant plant(g.params);
  plant.reset(g.state);
  plant.set_brake(0, true);
  plant.set_brake(1, true);
  const std::array<Vec3, 2> zero{Vec3::Zero(), Vec3::Zero()};
  // With both arms locked and no torque at all, the pre-loaded contacts carry the weight: the object settles
  // by no more than the tangential spring deflection M g / (2 k_t) (here 0.1 mm) and never slides.
  for (int k = 0; k < 1000; ++k) plant.step(zero, 1e-3 * static_cast<double>(k), 1e-3, 10);
  const tmd::ModuleState& s = plant.state();
  for (size_t j = 0; j < 2; ++j) {
    CHECK(max_abs(s.q[j] - g.state.q[j]) == 0.0);
    CHECK(max_abs(s.qd[j]) == 0.0);
  }
  const double sag = g.params.object.mass * g.params.g0 / (2.0 * g.params.contact.k_tangent);
  INFO("object moved by " << (s.c - g.state.c).transpose());
  CHECK((s.c - g.state.c).norm() <= 2.0 * sag + 1e-9);
  CHECK(plant.counters().slip_events == 0);
  CHECK(plant.counters().contact_lost == 0);
  CHECK(s.cd.norm() <= 1e-3);
  // Released with no torque, gravity takes the left arm down: it is no longer locked.
  plant.set_brake(0, false);
  CHECK_FALSE(plant.braked(0));
  CHECK(plant.braked(1));
  for (int k = 0; k < 50; ++k) plant.step(zero, 1.0 + 1e-3 * static_cast<double>(k), 1e-3, 10);
  CHECK(max_abs(plant.state().q[0] - g.state.q[0]) > 1e-3);
  CHECK(max_abs(plant.state().q[1] - g.state.q[1]) == 0.0);
}

TEST_CASE("time scale: pause and resume keep the reference C1, tau by finite differences", "[grasp]") {
  const tmd::ObjectPath path(Vec3(-0.2, 0.8, 0.0), 0.0, {tmd::ObjectPath::Segment{Vec3(0.2, 0.9, 0.2), 2.0}});
  tmd::TimeScale ts;
  const double T = 0.3;
  ts.retarget(0.7, 0.0, T);   // pause from t = 0.7
  ts.retarget(1.5, 1.0, T);   // resume at t = 1.5
  // Before any ramp: the identity.
  CHECK(ts.at(0.5).tau == 0.5);
  CHECK(ts.at(0.5).rate == 1.0);
  // While paused, tau stands still at 0.7 + T/2 (a smoothstep from 1 to 0 covers half its length).
  CHECK(ts.at(1.2).tau == Approx(0.7 + 0.5 * T).epsilon(1e-14));
  CHECK(ts.at(1.2).rate == 0.0);
  CHECK_FALSE(ts.settled(0.9));
  CHECK(ts.settled(1.9));
  // After the resume ramp, tau runs at rate 1 again, T/2 behind where the pause left it plus the pause.
  CHECK(ts.at(2.5).tau == Approx(0.7 + 0.5 * T + 0.5 * T + (2.5 - 1.5 - T)).epsilon(1e-13));
  // dtau/dt = rate and drate/dt = rate_dot, by central differences everywhere (ramps included).
  const double h = 1e-6;
  double worst_rate = 0.0, worst_rd = 0.0, worst_vel = 0.0, worst_acc = 0.0;
  for (double t = 0.01; t < 2.6; t += 0.00737) {
    const auto a = ts.at(t - h), b = ts.at(t + h), c = ts.at(t);
    worst_rate = std::max(worst_rate, std::abs((b.tau - a.tau) / (2 * h) - c.rate));
    worst_rd = std::max(worst_rd, std::abs((b.rate - a.rate) / (2 * h) - c.rate_dot));
    const tmd::PoseSample pa = tmd::sample_scaled(path, a), pb = tmd::sample_scaled(path, b), pc = tmd::sample_scaled(path, c);
    worst_vel = std::max(worst_vel, max_abs((pb.pose - pa.pose) / (2 * h) - pc.vel));
    worst_acc = std::max(worst_acc, max_abs((pb.vel - pa.vel) / (2 * h) - pc.acc));
  }
  CHECK(worst_rate <= 1e-8);
  CHECK(worst_rd <= 1e-5);
  CHECK(worst_vel <= 1e-7);
  CHECK(worst_acc <= 1e-4);
  // Paused: the reference is at rest.
  const tmd::PoseSample still = tmd::sample_scaled(path, ts.at(1.3));
  CHECK(max_abs(still.vel) == 0.0);
  CHECK(max_abs(still.acc) == 0.0);
  // A later retarget leaves earlier times as they were.
  const auto before = ts.at(2.0);
  ts.retarget(2.2, 0.0, 0.0);
  CHECK(ts.at(2.0).tau == before.tau);
  CHECK(ts.at(2.4).tau == ts.at(2.2).tau);
}

TEST_CASE("time scale: a stop that cuts into a resume keeps the path's acceleration continuous (finding 77)", "[grasp]") {
  const tmd::ObjectPath path(Vec3(-0.15, 0.8, 0.0), 0.0, {tmd::ObjectPath::Segment{Vec3(0.15, 0.8, 0.0), 1.5}});
  tmd::TimeScale ts;
  ts.retarget(0.5, 0.0, 0.3);   // paused from t = 0.5
  ts.retarget(1.0, 1.0, 0.3);   // resumed at t = 1.0
  ts.retarget(1.12, 0.0, 0.2);  // and stopped again 0.12 s into the resume: the rate is still rising
  const double h = 1e-7;
  const auto before = ts.at(1.12 - h), after = ts.at(1.12 + h);
  REQUIRE(before.rate_dot > 1.0);  // the resume's ramp was rising at the cut (the old stop started flat: a step)
  CHECK(after.rate_dot == Approx(before.rate_dot).margin(1e-4));
  CHECK(after.rate == Approx(before.rate).margin(1e-6));
  const tmd::PoseSample pa = tmd::sample_scaled(path, before), pb = tmd::sample_scaled(path, after);
  CHECK(max_abs(pb.acc - pa.acc) < 1e-3);
  // Everywhere: dtau/dt = rate and drate/dt = rate_dot by central differences, the rate within [0, 1].
  double worst_rate = 0.0, worst_rd = 0.0, lo = 1.0, hi = 0.0;
  for (double t = 0.01; t < 2.0; t += 0.00313) {
    const auto a = ts.at(t - 1e-6), b = ts.at(t + 1e-6), c = ts.at(t);
    worst_rate = std::max(worst_rate, std::abs((b.tau - a.tau) / 2e-6 - c.rate));
    worst_rd = std::max(worst_rd, std::abs((b.rate - a.rate) / 2e-6 - c.rate_dot));
    lo = std::min(lo, c.rate);
    hi = std::max(hi, c.rate);
  }
  CHECK(worst_rate <= 1e-8);
  CHECK(worst_rd <= 1e-5);
  CHECK(lo >= 0.0);
  CHECK(hi <= 1.0);
  CHECK(ts.at(1.4).rate == 0.0);
  CHECK(ts.at(1.9).tau == ts.at(1.4).tau);
  // A follower that restores the retargets samples the same times bit for bit (it recomputes the start slopes).
  tmd::TimeScale f;
  REQUIRE(f.restore(ts.export_breaks(64)));
  for (double t = 0.0; t < 2.0; t += 0.0071) {
    CHECK(f.at(t).tau == ts.at(t).tau);
    CHECK(f.at(t).rate_dot == ts.at(t).rate_dot);
  }
  // The start slope is bounded: a steep slope towards the target never passes it, against it never leaves [0, 1].
  tmd::TimeScale down;
  down.retarget(0.0, 0.0, 1.0);  // slowing: at t = 0.5 the rate is 0.5, falling at 1.5/s
  down.retarget(0.5, 0.2, 2.0);  // a long ramp to 0.2: the slope kept as is would undershoot 0.2
  tmd::TimeScale up;
  up.retarget(0.0, 0.0, 0.0);
  up.retarget(0.1, 1.0, 1.0);    // resuming: at t = 0.6 the rate is 0.5, rising at 1.5/s
  up.retarget(0.6, 0.6, 3.0);    // a long ramp to 0.6: kept as is, the slope would pass 0.6
  tmd::TimeScale cut;
  cut.retarget(0.0, 0.0, 0.0);
  cut.retarget(0.1, 1.0, 0.2);   // at t = 0.2 the rate is 0.5, rising at 7.5/s
  cut.retarget(0.2, 0.0, 1.0);   // a stop: kept as is, the slope would carry the rate over 1
  double down_lo = 1.0, up_hi = 0.0, cut_hi = 0.0;
  for (double t = 0.5; t < 3.0; t += 0.001) down_lo = std::min(down_lo, down.at(t).rate);
  for (double t = 0.6; t < 4.0; t += 0.001) up_hi = std::max(up_hi, up.at(t).rate);
  for (double t = 0.2; t < 1.5; t += 0.001) cut_hi = std::max(cut_hi, cut.at(t).rate);
  CHECK(down_lo >= 0.2 - 1e-12);
  CHECK(up_hi <= 0.6 + 1e-12);
  CHECK(cut_hi <= 1.0);
  CHECK(cut_hi > 0.5);  // it went on rising for a while: no step in acceleration
}

TEST_CASE("time scale: exported retargets restore the same path times, bad ones are refused", "[grasp]") {
  tmd::TimeScale a;
  a.retarget(0.7, 0.0, 0.3);
  a.retarget(1.5, 1.0, 0.3);
  a.retarget(2.9, 0.0, 0.02);
  // A standby that adopts the primary's latest two retargets samples every later time exactly alike.
  tmd::TimeScale b;
  REQUIRE(b.restore(a.export_breaks(2)));
  CHECK(a.export_breaks(2).size() == 10);
  for (double t = 1.5; t < 4.0; t += 0.0137) {
    CHECK(b.at(t).tau == a.at(t).tau);
    CHECK(b.at(t).rate == a.at(t).rate);
    CHECK(b.at(t).rate_dot == a.at(t).rate_dot);
  }
  CHECK(b.target() == 0.0);
  // Refused, and nothing changed: a ragged list, a NaN, decreasing t0, a negative ramp.
  tmd::TimeScale c;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(c.restore({0.5, 0.5, 1.0, 0.0}));
  CHECK_FALSE(c.restore({0.5, nan, 1.0, 0.0, 0.3}));
  CHECK_FALSE(c.restore({0.9, 0.9, 1.0, 0.0, 0.3, 0.5, 0.5, 0.0, 1.0, 0.3}));
  CHECK_FALSE(c.restore({0.5, 0.5, 1.0, 0.0, -0.1}));
  CHECK(c.export_breaks(8).empty());
  CHECK(c.at(2.0).tau == 2.0);
}
