// Fixed-bin histogram of durations in microseconds: 1 us bins up to 1 ms, 10 us bins up to 20 ms, then one
// overflow bin that remembers the maximum. Allocation happens once, at construction.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace tandem::runtime {

class Histogram {
 public:
  Histogram() : bins_(kFine + kCoarse + 1, 0) {}
  void add(double us) noexcept {
    ++count_;
    max_ = std::max(max_, us);
    size_t b;
    if (us < 0.0) {
      b = 0;
    } else if (us < kFine) {
      b = static_cast<size_t>(us);
    } else if (us < kFine + 10.0 * kCoarse) {
      b = kFine + static_cast<size_t>((us - kFine) / 10.0);
    } else {
      b = kFine + kCoarse;
    }
    ++bins_[b];
  }
  /// Upper edge of the bin holding the p-quantile (p in [0, 1]); the maximum for the overflow bin.
  double percentile(double p) const noexcept {
    if (count_ == 0) return 0.0;
    if (p >= 1.0) return max_;
    const auto target = static_cast<uint64_t>(p * static_cast<double>(count_));
    uint64_t seen = 0;
    for (size_t b = 0; b < bins_.size(); ++b) {
      seen += bins_[b];
      if (seen > target) {
        if (b < kFine) return static_cast<double>(b + 1);
        if (b < kFine + kCoarse) return kFine + 10.0 * static_cast<double>(b - kFine + 1);
        return max_;
      }
    }
    return max_;
  }
  uint64_t count() const noexcept { return count_; }

 private:
  static constexpr size_t kFine = 1000;    // 1 us bins below 1 ms
  static constexpr size_t kCoarse = 1900;  // 10 us bins from 1 ms to 20 ms
  std::vector<uint64_t> bins_;
  uint64_t count_ = 0;
  double max_ = 0.0;
};

}  // namespace tandem::runtime
