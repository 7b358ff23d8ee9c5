#include "station/haptics/period_histogram.h"

#include <algorithm>
#include <cmath>

namespace ves::haptics {

void PeriodHistogram::Add(std::int64_t error_ns) {
  const std::int64_t clamped = std::max<std::int64_t>(0, error_ns);
  const std::int64_t bin = std::min<std::int64_t>(clamped / 1000, kBins);
  ++bins_[static_cast<std::size_t>(bin)];
  ++count_;
  max_ns_ = std::max(max_ns_, clamped);
}

std::int64_t PeriodHistogram::PercentileNs(double fraction) const {
  if (count_ == 0) return 0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(fraction * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (int bin = 0; bin < kBins; ++bin) {
    seen += bins_[static_cast<std::size_t>(bin)];
    if (seen >= std::max<std::uint64_t>(rank, 1)) {
      return std::min<std::int64_t>((bin + 1) * 1000LL, max_ns_);
    }
  }
  return max_ns_;
}

}  // namespace ves::haptics
