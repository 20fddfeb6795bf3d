// Unit tests of the hybrid controller (eq. 17-36): contact frame, exactness of the inverse-dynamics
// linearisation, finite-time reaching of the sliding mode against the PD law, the super-twisting law,
// the reaching-gain bound, and that the control and plant steps do not allocate.
#include <catch2/catch.hpp>

#include "test_support.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <new>
#include <vector>

#include "tandem/model/arm.hpp"
#include "tandem/model/controller.hpp"
#include "tandem/model/manipulator.hpp"
#include "tandem/model/plant.hpp"
#include "tandem/model/reference.hpp"

// ---------------------------------------------------------------------------------------------------------
// Counting global allocation functions. They replace the library's for the whole test binary, forward to
// malloc/free (aligned_alloc for over-aligned requests) and count only while g_count_allocations is set.
namespace {
std::atomic<long> g_allocations{0};
std::atomic<bool> g_count_allocations{false};

void* counted_malloc(std::size_t n) noexcept {
  if (g_count_allocations.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n == 0 ? 1 : n);
}

void* counted_aligned_malloc(std::size_t n, std::align_val_t al) noexcept {
  if (g_count_allocations.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t a = static_cast<std::size_t>(al);
  const std::size_t size = ((n == 0 ? 1 : n) + a - 1) / a * a;  // aligned_alloc wants a multiple of a
  return std::aligned_alloc(a, size);
}

// Out of line so that the compiler does not inline free() into callers of a new-expression and then warn
// about a new/free mismatch (-Wmismatched-new-delete): every replaced operator new returns malloc'd memory.
[[gnu::noinline]] void release(void* p) noexcept { std::free(p); }
}  // namespace

void* operator new(std::size_t n) {
  void* p = counted_malloc(n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t n) {
  void* p = counted_malloc(n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return counted_malloc(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return counted_malloc(n); }
void* operator new(std::size_t n, std::align_val_t al) {
  void* p = counted_aligned_malloc(n, al);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t n, std::align_val_t al) {
  void* p = counted_aligned_malloc(n, al);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new(std::size_t n, std::align_val_t al, const std::nothrow_t&) noexcept {
  return counted_aligned_malloc(n, al);
}
void* operator new[](std::size_t n, std::align_val_t al, const std::nothrow_t&) noexcept {
  return counted_aligned_malloc(n, al);
}
void operator delete(void* p) noexcept { release(p); }
void operator delete[](void* p) noexcept { release(p); }
void operator delete(void* p, std::size_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t) noexcept { release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete(void* p, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
// ---------------------------------------------------------------------------------------------------------

namespace {

using tandem::model::ArmParams;
using tandem::model::kPi;
using tandem::model::Mat3;
using tandem::model::Vec2;
using tandem::model::Vec3;
namespace mdl = tandem::model;

using tandem::test::Lcg;

double max_abs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

/// The contact frame written out by hand: columns tangent t = (cos phi, -sin phi) (the approach axis
/// turned clockwise by 90 degrees), approach a = (sin phi, cos phi), and the out-of-plane axis.
Mat3 frame_by_hand(double phi) {
  Mat3 R;
  R << std::cos(phi), std::sin(phi), 0.0,  //
      -std::sin(phi), std::cos(phi), 0.0,  //
      0.0, 0.0, 1.0;
  return R;
}

/// End-effector velocity by central differences of forward kinematics along q' (independent of jacobian()).
Vec3 fd_velocity(const ArmParams& p, const Vec3& q, const Vec3& qd) {
  const double h = 1e-7;
  return (mdl::forward_kinematics(p, q + h * qd) - mdl::forward_kinematics(p, q - h * qd)) / (2.0 * h);
}

using tandem::test::ArmState;
using tandem::test::rk4;

/// Samples of a closed-loop run: time, and the error and sliding variable in the contact frame computed
/// by the test from the state (not taken from the controller's diagnostics).
struct Run {
  std::vector<double> t;
  std::vector<Vec3> e;
  std::vector<Vec3> s;
  std::vector<Vec3> s_controller;
};

/// Free arm holding a fixed reference, sampled-data loop: controller every T, 10 RK4 substeps of T/10.
Run closed_loop(const ArmParams& arm, const mdl::HybridParams& hp, const mdl::ArmReference& ref, ArmState st,
                double duration) {
  mdl::HybridController ctl(arm, hp);
  const double T = hp.period;
  const Mat3 R = frame_by_hand(ref.x(2));
  const Vec3 m = hp.law.m_p;  // all axes are position axes here
  const long steps = std::lround(duration / T);
  Run run;
  for (long k = 0; k <= steps; ++k) {
    const Vec3 e = R.transpose() * (ref.x - mdl::forward_kinematics(arm, st.q));
    const Vec3 ed = R.transpose() * (ref.xd - fd_velocity(arm, st.q, st.qd));
    mdl::ArmSensors in;
    in.q = st.q;
    in.qd = st.qd;
    const mdl::ControlOutput out = ctl.step(in, ref);
    run.t.push_back(T * static_cast<double>(k));
    run.e.push_back(e);
    run.s.push_back(m.cwiseProduct(e) + ed);
    run.s_controller.push_back(out.s);
    for (int i = 0; i < 10; ++i) st = rk4(arm, st, out.tau, T / 10.0);
  }
  return run;
}

/// Reference at rest at a pose, and the arm started 2 cm (world x) short of it.
struct Setup {
  ArmParams arm = mdl::smart3s2();
  mdl::ArmReference ref;
  ArmState start;
};

Setup offset_start(const Vec3& error) {
  Setup su;
  su.ref.x = Vec3(0.3, 1.0, 0.0);  // tool up: the contact frame is the world frame
  REQUIRE(mdl::inverse_kinematics(su.arm, su.ref.x - error, -1.0, su.start.q));
  return su;
}

mdl::HybridParams free_space_params(mdl::LawType type) {
  mdl::HybridParams hp;
  hp.selection_p = Vec3(1.0, 1.0, 1.0);
  hp.law.type = type;
  hp.law.K_p = Vec3::Constant(10.0);
  hp.law.m_p = Vec3::Constant(5.0);
  hp.period = 1e-3;
  return hp;
}

/// Module state built like the embedded simulation's initial state (sim/src/embedded.cpp).
struct Module {
  mdl::ModuleParams params;
  mdl::ModuleState state;
  mdl::GraspGeometry geometry;
  double h_ref = 29.43;
};

Module make_module(const Vec3& object_pose) {
  Module md;
  md.params.arms[0].base = Vec2(-1.0, 0.0);
  md.params.arms[1].base = Vec2(1.0, 0.0);
  md.geometry.stick_length[0] = md.geometry.stick_length[1] = md.params.object.half_width;
  md.geometry.preload = md.h_ref / md.params.contact.k_normal;
  mdl::PoseSample p0;
  p0.pose = object_pose;
  const double elbow[2] = {-1.0, 1.0};
  for (size_t j = 0; j < 2; ++j) {
    const mdl::ArmReference r = mdl::arm_reference(static_cast<int>(j), p0, md.geometry, md.h_ref);
    REQUIRE(mdl::inverse_kinematics(md.params.arms[j], r.x, elbow[j], md.state.q[j]));
  }
  md.state.c = object_pose.head<2>();
  md.state.psi = -object_pose(2);
  return md;
}

void* volatile g_escape = nullptr;  // keeps the sanity-check allocation observable

}  // namespace

TEST_CASE("contact frame is orthonormal with the approach axis as its second column", "[controller]") {
  for (int k = 0; k <= 72; ++k) {
    const double phi = -2.0 * kPi + 4.0 * kPi * static_cast<double>(k) / 72.0;
    const Mat3 R = mdl::contact_frame(phi);
    INFO("phi = " << phi << "\nR =\n" << R);
    CHECK(max_abs(R.transpose() * R - Mat3::Identity()) <= 1e-15);
    CHECK(R.determinant() == Approx(1.0).epsilon(1e-15));
    const Vec2 a = mdl::approach_axis(phi);
    CHECK(max_abs(R.block<2, 1>(0, 1) - a) <= 1e-15);
    CHECK(a(0) == Approx(std::sin(phi)).margin(1e-15));
    CHECK(a(1) == Approx(std::cos(phi)).margin(1e-15));
    // Tangent x approach = +z, and the orientation axis is untouched.
    CHECK(R(0, 0) * R(1, 1) - R(1, 0) * R(0, 1) == Approx(1.0).epsilon(1e-15));
    CHECK(max_abs(R.col(2) - Vec3::UnitZ()) == 0.0);
    CHECK(max_abs(R - frame_by_hand(phi)) <= 1e-15);
  }
}

TEST_CASE("inverse-dynamics VLLC makes the task-space acceleration equal the PD law exactly", "[controller]") {
  const ArmParams arm = mdl::smart3s2();
  Lcg rng(201);
  int tested = 0;
  for (int i = 0; i < 200 && tested < 100; ++i) {
    const Vec3 q = rng.vec3(-2.5, 2.5);
    if (std::abs(std::sin(q(1))) < 0.2) continue;  // keep J well conditioned (det J = l1 l2 sin q2)
    ++tested;
    const Vec3 qd = rng.vec3(-1.5, 1.5);
    mdl::ArmReference ref;
    ref.x = mdl::forward_kinematics(arm, q) + Vec3(rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05),
                                                  rng.uniform(-0.1, 0.1));
    ref.xd = rng.vec3(-0.3, 0.3);
    ref.xdd = rng.vec3(-1.0, 1.0);
    const bool feedforward = (i % 2) == 1;
    // Half the samples carry a measured contact force, which the VLLC must cancel with J^T h.
    const Vec2 h = (i % 4) < 2 ? Vec2::Zero() : Vec2(rng.uniform(-40.0, 40.0), rng.uniform(-40.0, 40.0));

    mdl::HybridParams hp;
    hp.selection_p = Vec3(1.0, 1.0, 1.0);
    hp.law.type = mdl::LawType::PD;
    hp.feedforward_position = feedforward;
    mdl::HybridController ctl(arm, hp);
    mdl::ArmSensors in;
    in.q = q;
    in.qd = qd;
    in.h = h;
    const Vec3 tau = ctl.step(in, ref).tau;

    // Plant with the same (nominal) model and the same contact force.
    const Vec3 qdd = mdl::forward_dynamics(arm, q, qd, tau, Vec3(h(0), h(1), 0.0));
    const Vec3 xdd = mdl::jacobian(arm, q) * qdd + mdl::jacobian_dot(arm, q, qd) * qd;

    // PD law of eq. (35) in the contact frame, computed here, rotated back to the world frame.
    const Mat3 R = frame_by_hand(ref.x(2));
    const Vec3 e = R.transpose() * (ref.x - mdl::forward_kinematics(arm, q));
    const Vec3 ed = R.transpose() * (ref.xd - fd_velocity(arm, q, qd));
    Vec3 u = hp.law.kp_p.cwiseProduct(e) + hp.law.kd_p.cwiseProduct(ed);
    if (feedforward) u += R.transpose() * ref.xdd;
    const Vec3 expected = R * u;
    INFO("q = " << q.transpose() << "  qd = " << qd.transpose() << "  ff = " << feedforward
                << "\n x'' = " << xdd.transpose() << "\n law = " << expected.transpose());
    CHECK(max_abs(xdd - expected) <= 1e-6 * (1.0 + expected.norm()));

    // The same acceleration from forward kinematics alone: second central difference along
    // q(t) = q + q' t + q'' t^2 / 2.
    const double dt = 1e-4;
    auto at = [&](double t) { return mdl::forward_kinematics(arm, q + qd * t + 0.5 * qdd * t * t); };
    const Vec3 xdd_fd = (at(dt) - 2.0 * at(0.0) + at(-dt)) / (dt * dt);
    CHECK(max_abs(xdd_fd - expected) <= 1e-5 * (1.0 + expected.norm()));
  }
  CHECK(tested == 100);
}

TEST_CASE("sliding mode reaches the surface in finite time, PD only approaches it", "[controller]") {
  const double T = 1e-3, K = 10.0, m = 5.0;
  const double band = 2.0 * K * T;  // sampled-and-held K sgn(s) moves s by about K T per period
  // The identified arm, and the same arm without Coulomb friction. Its smoothed term (band 0.01 rad/s)
  // changes within a control period while the torque is held, so the sampled loop only approximately
  // follows the ideal per-axis dynamics; without it the sampled PD loop can be predicted tightly.
  for (bool coulomb : {true, false}) {
    Setup su = offset_start(Vec3(0.02, 0.0, 0.0));
    if (!coulomb) su.arm.coulomb.setZero();
    INFO("Coulomb friction " << (coulomb ? "on" : "off"));

    const Run sm = closed_loop(su.arm, free_space_params(mdl::LawType::SlidingMode), su.ref, su.start, 0.5);
    const double s0 = std::abs(sm.s[0](0));
    REQUIRE(s0 == Approx(m * 0.02).epsilon(1e-9));  // s = m e + e' with e = 2 cm, at rest
    const double disturbance = 0.0;                // nominal model, no xi(t)
    const double t_r = s0 / (K - disturbance);     // reaching-time bound (eq. 29-30)

    size_t reach = sm.t.size();
    for (size_t k = 0; k < sm.t.size(); ++k) {
      if (std::abs(sm.s[k](0)) < band) {
        reach = k;
        break;
      }
    }
    REQUIRE(reach < sm.t.size());
    INFO("s(0) = " << s0 << "  t_r = " << t_r << "  band = " << band << "  reached at t = " << sm.t[reach]);
    CHECK(sm.t[reach] <= 1.5 * t_r);
    // s' = m e' - K sgn(s) with e' between -K t and 0 here: s cannot fall faster than about K (1 + m t),
    // so reaching the band takes at least (s0 - band) / (K (1 + m t_r)).
    CHECK(sm.t[reach] >= (s0 - band) / (K * (1.0 + m * t_r)) - T);
    // Once there it stays in the chattering band, on every axis, and the controller's own s agrees.
    double worst_after = 0.0;
    for (size_t k = reach; k < sm.t.size(); ++k) worst_after = std::max(worst_after, sm.s[k].cwiseAbs().maxCoeff());
    INFO("largest |s| after reaching: " << worst_after);
    CHECK(worst_after <= band);
    double worst_diag = 0.0;
    for (size_t k = 0; k < sm.t.size(); ++k) worst_diag = std::max(worst_diag, max_abs(sm.s[k] - sm.s_controller[k]));
    CHECK(worst_diag <= 1e-6);
    // On the surface e' = -m e: after 0.5 s (2.5 time constants) the error is well below its start.
    CHECK(std::abs(sm.e.back()(0)) < 0.2 * 0.02);

    // PD with the same initial error. Gains placing both closed-loop poles at -m (K_P = m^2, K_D = 2 m)
    // make s(t) = s(0) exp(-m t) for the continuous loop: s never reaches zero in finite time. The
    // sampled loop (acceleration u_k = K_P e_k + K_D e'_k held over each period) is predicted here by
    //   e_k+1 = e_k + T e'_k - T^2/2 u_k,   e'_k+1 = e'_k - T u_k.
    mdl::HybridParams pd = free_space_params(mdl::LawType::PD);
    const double kp = m * m, kd = 2.0 * m;
    pd.law.kp_p = Vec3::Constant(kp);
    pd.law.kd_p = Vec3::Constant(kd);
    const Run run_pd = closed_loop(su.arm, pd, su.ref, su.start, 0.5);
    double e = 0.02, ed = 0.0, worst_pred = 0.0, worst_cont = 0.0, min_s = 1e300;
    for (size_t k = 0; k < run_pd.t.size(); ++k) {
      const double predicted = m * e + ed;
      const double continuous = s0 * std::exp(-m * run_pd.t[k]);
      worst_pred = std::max(worst_pred, std::abs(run_pd.s[k](0) - predicted) / predicted);
      worst_cont = std::max(worst_cont, std::abs(run_pd.s[k](0) - continuous) / continuous);
      min_s = std::min(min_s, run_pd.s[k](0));
      const double u = kp * e + kd * ed;
      e += T * ed - 0.5 * T * T * u;
      ed -= T * u;
    }
    INFO("PD over 0.5 s: min s = " << min_s << "  largest relative deviation from the sampled-loop prediction "
                                   << worst_pred << ", from s0 exp(-m t) " << worst_cont);
    CHECK(min_s > 0.0);           // never reaches the surface
    CHECK(worst_cont <= 0.1);     // decays like exp(-m t)
    if (!coulomb) CHECK(worst_pred <= 5e-3);  // held viscous torque and the arm's nonlinearity: ~0.2 %
    const size_t k_tr = static_cast<size_t>(std::lround(1.5 * t_r / T));
    INFO("PD |s| at 1.5 t_r: " << run_pd.s[k_tr](0) << "  SM: " << sm.s[k_tr](0));
    CHECK(std::abs(run_pd.s[k_tr](0)) > band);
    CHECK(std::abs(run_pd.s[k_tr](0)) > 3.0 * std::abs(sm.s[k_tr](0)));
  }
}

TEST_CASE("super-twisting drives s and e to zero while holding still", "[controller]") {
  const Setup su = offset_start(Vec3(0.01, -0.005, 0.02));
  const double K = 10.0, T = 1e-3, m = 5.0;
  const double k2 = 1.1 * K;  // integral gain of the law (Levant's choice for the bound K)
  const Run st = closed_loop(su.arm, free_space_params(mdl::LawType::SuperTwisting), su.ref, su.start, 3.5);
  const Run sm = closed_loop(su.arm, free_space_params(mdl::LawType::SlidingMode), su.ref, su.start, 3.5);

  // On the surface s = 0 the error obeys e' = -m e: one second after reaching, e has shrunk by exp(-m).
  const size_t k1 = 300, k2s = 1300;  // t = 0.3 s and 1.3 s
  for (int i = 0; i < 3; ++i) {
    const double ratio = st.e[k2s](i) / st.e[k1](i);
    INFO("axis " << i << ": e(1.3)/e(0.3) = " << ratio << "  exp(-m) = " << std::exp(-m));
    CHECK(ratio == Approx(std::exp(-m)).epsilon(0.05));
  }

  // Steady state (3 s to 3.5 s): the sampled second-order sliding mode keeps |s| at O(k2 T^2), far below
  // the O(K T) chattering of the first-order law, and e follows s down to |e| <= |s| / m.
  double e_after = 0.0, s_after = 0.0, s_after_sm = 0.0;
  for (size_t k = 3000; k < st.t.size(); ++k) {
    e_after = std::max(e_after, st.e[k].cwiseAbs().maxCoeff());
    s_after = std::max(s_after, st.s[k].cwiseAbs().maxCoeff());
    s_after_sm = std::max(s_after_sm, sm.s[k].cwiseAbs().maxCoeff());
  }
  INFO("after 3 s: max |e| = " << e_after << "  max |s| = " << s_after << "  (first-order SM: " << s_after_sm
                               << ")");
  CHECK(s_after <= 5.0 * k2 * T * T);
  CHECK(s_after < 1e-2 * K * T);
  CHECK(s_after_sm > 0.1 * K * T);
  CHECK(e_after <= s_after / m);
  CHECK(e_after < 2e-6);
}

TEST_CASE("control and plant steps do not allocate", "[controller]") {
  // The counter itself works: a heap allocation inside the window is seen.
  g_allocations = 0;
  g_count_allocations = true;
  {
    auto probe = std::make_unique<std::array<double, 32>>();
    g_escape = probe.get();
  }
  g_count_allocations = false;
  REQUIRE(g_allocations.load() >= 1);

  Module md = make_module(Vec3(-0.2, 0.8, 0.0));
  mdl::ModulePlant plant(md.params);
  plant.reset(md.state);
  const mdl::ObjectPath path(Vec3(-0.2, 0.8, 0.0), 0.1,
                            {mdl::ObjectPath::Segment{Vec3(-0.1, 0.85, 0.1), 0.8}});
  std::array<mdl::HybridController, 2> ctl{mdl::HybridController(md.params.arms[0], mdl::HybridParams{}),
                                          mdl::HybridController(md.params.arms[1], mdl::HybridParams{})};
  mdl::HybridParams pd;
  pd.law.type = mdl::LawType::PD;
  ctl[1] = mdl::HybridController(md.params.arms[1], pd);  // exercise two laws

  g_allocations = 0;
  g_count_allocations = true;
  for (int k = 0; k < 1000; ++k) {
    const double t = 1e-3 * static_cast<double>(k);
    const mdl::PoseSample ps = path.sample(t);
    const mdl::ContactReading c = plant.contacts();
    std::array<Vec3, 2> tau;
    for (size_t j = 0; j < 2; ++j) {
      const mdl::ArmReference ref = mdl::arm_reference(static_cast<int>(j), ps, md.geometry, md.h_ref);
      mdl::ArmSensors in;
      in.q = plant.state().q[j];
      in.qd = plant.state().qd[j];
      in.h = c.h[j];
      tau[j] = ctl[j].step(in, ref).tau;
    }
    plant.step(tau, t, 1e-3, 10);
  }
  g_count_allocations = false;
  CHECK(g_allocations.load() == 0);
  // The loop really ran a grasp (not a degenerate no-op).
  CHECK(plant.state().c.allFinite());
  CHECK(plant.contacts().in_contact[0]);
  CHECK(plant.contacts().in_contact[1]);
}

TEST_CASE("every manipulator type's model evaluations do not allocate", "[controller][manipulator]") {
  std::vector<std::unique_ptr<mdl::Manipulator>> models;
  models.push_back(mdl::make_manipulator(mdl::smart3s2()));
  models.push_back(mdl::make_manipulator(mdl::cartesian_ppr()));
  models.push_back(mdl::make_manipulator(mdl::planar_4r()));
  double sink = 0.0;
  // The controller's step over each type too (the 4R's minimum-norm solve and null-space projection included).
  std::vector<mdl::HybridController> laws;
  mdl::HybridParams hp;
  hp.law.type = mdl::LawType::SuperTwisting;
  laws.emplace_back(std::make_shared<const mdl::Planar3R>(mdl::smart3s2()), hp);
  laws.emplace_back(std::make_shared<const mdl::PlanarChain>(mdl::cartesian_ppr()), hp);
  laws.emplace_back(std::make_shared<const mdl::PlanarChain>(mdl::planar_4r()), hp);
  std::vector<mdl::ArmSensors> sensors(3);
  for (size_t i = 0; i < 3; ++i) {
    const int n = laws[i].arm().dof();
    sensors[i].q = mdl::JointVec::Constant(n, 0.4);
    sensors[i].qd = mdl::JointVec::Constant(n, 0.1);
    sensors[i].h = mdl::Vec2(5.0, -1.0);
  }
  mdl::ArmReference ref;
  ref.x = Vec3(0.2, 0.9, 0.3);
  ref.force = 10.0;
  g_allocations = 0;
  g_count_allocations = true;
  for (int k = 0; k < 100; ++k) {
    for (size_t i = 0; i < 3; ++i) sink += laws[i].step(sensors[i], ref).tau.sum();
  }
  for (const auto& m : models) {
    mdl::JointVec q = mdl::JointVec::Constant(m->dof(), 0.3), qd = mdl::JointVec::Constant(m->dof(), -0.2);
    for (int k = 0; k < 200; ++k) {
      q(0) += 1e-3;
      const mdl::JointVec qdd = m->forward_dynamics(q, qd, mdl::JointVec::Zero(m->dof()), Vec3(1.0, -2.0, 0.1));
      const mdl::TaskJacobian J = m->jacobian(q), Jd = m->jacobian_dot(q, qd);
      sink += qdd.sum() + J.sum() + Jd.sum() + m->forward_kinematics(q).sum() + m->kinetic_energy(q, qd) +
              m->potential_energy(q);
    }
  }
  g_count_allocations = false;
  CHECK(g_allocations.load() == 0);
  CHECK(std::isfinite(sink));
}

TEST_CASE("reaching_gain_bound equals the sum of eq. (33)-(34) terms", "[controller]") {
  Mat3 Jc;
  Jc << 0.8, -0.3, 0.05,  //
      -1.2, 0.6, -0.4,    //
      1.0, -1.0, 1.0;
  const Vec3 eta(3.6, 14.5, 18.0);
  const Vec3 xdd(-0.7, 0.25, 0.0);
  const Vec3 m(5.0, 4.0, 6.0);
  const Vec3 ed(-0.02, 0.1, -0.3);
  const double margin = 0.5;
  const Vec3 K = mdl::reaching_gain_bound(Jc, eta, xdd, m, ed, margin);
  for (int i = 0; i < 3; ++i) {
    double want = margin + std::abs(xdd(i)) + m(i) * std::abs(ed(i));
    for (int j = 0; j < 3; ++j) want += std::abs(Jc(i, j)) * eta(j);
    INFO("axis " << i);
    CHECK(K(i) == Approx(want).epsilon(1e-14));
  }
  // Hand-evaluated row 0: 0.8*3.6 + 0.3*14.5 + 0.05*18 + 0.5 + 0.7 + 5*0.02 = 9.43.
  CHECK(K(0) == Approx(9.43).epsilon(1e-14));
}
