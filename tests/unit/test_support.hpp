// Helpers shared by the unit tests.
#pragma once

#include <cstdint>

#include "tandem/model/arm.hpp"
#include "tandem/model/types.hpp"

namespace tandem::test {

/// Deterministic pseudo-random numbers (64-bit LCG), independent of the standard library's distributions.
class Lcg {
 public:
  explicit Lcg(std::uint64_t seed) : s_(seed) {}
  double uniform(double lo, double hi) {
    s_ = s_ * 6364136223846793005ULL + 1442695040888963407ULL;
    const double u = static_cast<double>(s_ >> 11) * (1.0 / 9007199254740992.0);
    return lo + (hi - lo) * u;
  }
  model::Vec3 vec3(double lo, double hi) { return {uniform(lo, hi), uniform(lo, hi), uniform(lo, hi)}; }

 private:
  std::uint64_t s_;
};

/// Arm state for the tests' own integrator.
struct ArmState {
  model::Vec3 q = model::Vec3::Zero();
  model::Vec3 qd = model::Vec3::Zero();
};

/// One classical RK4 step of q'' = forward_dynamics(q, q', tau, 0) for a free arm, tau held.
inline ArmState rk4(const model::ArmParams& p, const ArmState& s, const model::Vec3& tau, double h) {
  using model::forward_dynamics;
  using model::Vec3;
  const Vec3 zero = Vec3::Zero();
  const Vec3 k1q = s.qd;
  const Vec3 k1v = forward_dynamics(p, s.q, s.qd, tau, zero);
  const Vec3 k2q = s.qd + 0.5 * h * k1v;
  const Vec3 k2v = forward_dynamics(p, s.q + 0.5 * h * k1q, s.qd + 0.5 * h * k1v, tau, zero);
  const Vec3 k3q = s.qd + 0.5 * h * k2v;
  const Vec3 k3v = forward_dynamics(p, s.q + 0.5 * h * k2q, s.qd + 0.5 * h * k2v, tau, zero);
  const Vec3 k4q = s.qd + h * k3v;
  const Vec3 k4v = forward_dynamics(p, s.q + h * k3q, s.qd + h * k3v, tau, zero);
  ArmState n;
  n.q = s.q + (h / 6.0) * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
  n.qd = s.qd + (h / 6.0) * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
  return n;
}

}  // namespace tandem::test
