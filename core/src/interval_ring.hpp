#pragma once
// The last N sample intervals of a stream and their median: how the adapter (stgae_filter)
// and the choice by rate (rate_choice) measure an input's rate, robust to a late, early or
// dropped row. Plain struct, no allocation.
#include <algorithm>
#include <array>
#include <cstddef>

namespace hs {

template <int N>
struct IntervalRing {
  static_assert(N > 0);
  std::array<double, N> dt{};  // ring, oldest overwritten
  long seen = 0;               // intervals recorded since reset

  void reset() noexcept { seen = 0; }
  void record(double interval) noexcept {
    dt[static_cast<size_t>(seen % N)] = interval;
    ++seen;
  }
  bool full() const noexcept { return seen >= N; }
  // The median of the last N intervals (of all of them while fewer); 0 when none.
  double median() const noexcept {
    if (seen == 0) return 0.0;
    std::array<double, N> v{};
    const auto n = static_cast<std::ptrdiff_t>(std::min<long>(seen, N));
    std::copy(dt.begin(), dt.begin() + n, v.begin());
    const auto mid = v.begin() + n / 2;
    std::nth_element(v.begin(), mid, v.begin() + n);
    return *mid;
  }
};

}  // namespace hs
