// The joint-acceleration disturbance of eq. (37), added to the plant's q'' of the robots it is enabled for.
#pragma once

#include <cmath>

#include "tandem/model/types.hpp"

namespace tandem::model {

struct Disturbance {
  bool enabled = false;
  double scale = 1.0;  ///< multiplies eq. (37); 1 is the paper's disturbance

  /// xi(t) of eq. (37) [rad/s^2].
  Vec3 operator()(double t) const noexcept {
    if (!enabled) return Vec3::Zero();
    const double s1 = std::sin(10.0 * t), s2 = std::sin(20.0 * t), s3 = std::sin(30.0 * t);
    return scale * Vec3(2.0 * s1 + 1.0 * s2 + 0.6 * s3,  //
                        8.0 * s1 + 4.0 * s2 + 2.5 * s3,  //
                        10.0 * s1 + 5.0 * s2 + 3.0 * s3);
  }

  /// xi(t) for an arm of n joints: eq. (37) on its first min(n, 3) joints, 0 on the others (the paper's
  /// disturbance is of the 3R's joints; on another type it acts on the same joint indices, in rad/s^2 or m/s^2).
  JointVec at(double t, int n) const noexcept { return spread((*this)(t), n); }
  /// bound() and rate_bound() the same way.
  JointVec bound(int n) const noexcept { return spread(bound(), n); }
  JointVec rate_bound(int n) const noexcept { return spread(rate_bound(), n); }

  /// Component-wise bound sup_t |xi_i(t)| <= sum of the amplitudes (used by eq. 33-34).
  Vec3 bound() const noexcept { return enabled ? Vec3(Vec3(3.6, 14.5, 18.0) * scale) : Vec3(Vec3::Zero()); }

  /// Component-wise bound on |d xi_i / dt| (amplitude times frequency, summed) [rad/s^3]; the
  /// super-twisting law needs its gain above the bound on the perturbation's derivative.
  Vec3 rate_bound() const noexcept {
    return enabled ? Vec3(Vec3(58.0, 235.0, 290.0) * scale) : Vec3(Vec3::Zero());
  }

 private:
  static JointVec spread(const Vec3& v, int n) noexcept {
    JointVec out = JointVec::Zero(n);
    for (int i = 0; i < n && i < 3; ++i) out(i) = v(i);
    return out;
  }
};

}  // namespace tandem::model
