#pragma once
// Models for different input rates behind one PoseFilter: a model trained at 90 Hz sees a
// 90 Hz tracker's every row, one trained at 30 Hz runs a 60 Hz tracker as two interleaved
// streams (stgae_filter.hpp). The input's rate is measured over its first rows, as the
// adapter does for its streams, and every row then goes to the filter whose model rate
// suits it; a runtime that changes its rate for good moves to another one (a restart).
#include "handsteady/filters.hpp"

#include <memory>
#include <span>
#include <vector>

namespace hs {

struct RateFilter {
  double rate_hz = 0.0;  // the model's frame rate
  std::unique_ptr<PoseFilter> filter;
};

// The index of the rate for input at input_hz: the fastest model rate at most
// kRateChoiceSlack x the input's (a 75 Hz tracker under a 90 Hz model: its frames lock to
// the samples; a 60 Hz tracker under the 90 Hz one would be resampled, which mixes
// interpolated and sampled noise), else the slowest. Rates must be positive.
inline constexpr double kRateChoiceSlack = 1.25;
int choose_rate(std::span<const double> rates_hz, double input_hz) noexcept;

// One PoseFilter over several (at least one; rates positive and distinct). Before the rate
// is known (the first kRateChoiceRows rows) rows go to every filter, so the one chosen has
// them. Throws std::invalid_argument for an empty list, a null filter or a bad rate.
inline constexpr int kRateChoiceRows = 4;
std::unique_ptr<PoseFilter> make_rate_chosen_filter(std::vector<RateFilter> filters);

}  // namespace hs
