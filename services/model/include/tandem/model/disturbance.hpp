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

  /// Component-wise bound sup_t |xi_i(t)| <= sum of the amplitudes (used by eq. 33-34).
  Vec3 bound() const noexcept { return enabled ? Vec3(Vec3(3.6, 14.5, 18.0) * scale) : Vec3(Vec3::Zero()); }

  /// Component-wise bound on |d xi_i / dt| (amplitude times frequency, summed) [rad/s^3]; the
  /// super-twisting law needs its gain above the bound on the perturbation's derivative.
  Vec3 rate_bound() const noexcept {
    return enabled ? Vec3(Vec3(58.0, 235.0, 290.0) * scale) : Vec3(Vec3::Zero());
  }
};

}  // namespace tandem::model
