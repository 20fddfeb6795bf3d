// Helpers shared by the unit tests.
#pragma once

#include <cstdint>

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

}  // namespace tandem::test
