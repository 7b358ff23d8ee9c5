#pragma once

// Histogram of the loop's period error (wake-up time minus deadline) in
// 1 µs bins up to 10 ms, plus an overflow bin and the exact maximum.
// Add() is O(1) and allocation-free for use inside the loop.
#include <array>
#include <cstdint>

namespace ves::haptics {

class PeriodHistogram {
 public:
  static constexpr int kBins = 10000;  // 1 µs each

  void Add(std::int64_t error_ns);
  std::uint64_t count() const { return count_; }
  std::int64_t max_ns() const { return max_ns_; }
  // Error (ns) below which `fraction` (0..1] of the samples fall, at 1 µs
  // resolution (upper edge of the bin); max_ns() for samples in the overflow.
  std::int64_t PercentileNs(double fraction) const;

 private:
  std::array<std::uint32_t, kBins + 1> bins_{};
  std::uint64_t count_{0};
  std::int64_t max_ns_{0};
};

}  // namespace ves::haptics
