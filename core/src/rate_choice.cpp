// Chooses among filters of different model rates by the input's measured rate.
#include "handsteady/rate_choice.hpp"

#include "interval_ring.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace hs {

int choose_rate(std::span<const double> rates_hz, double input_hz) noexcept {
  int best = -1, slowest = 0;
  for (int i = 0; i < static_cast<int>(rates_hz.size()); ++i) {
    const double r = rates_hz[static_cast<size_t>(i)];
    if (r < rates_hz[static_cast<size_t>(slowest)]) slowest = i;
    if (r <= kRateChoiceSlack * input_hz && (best < 0 || r > rates_hz[static_cast<size_t>(best)])) best = i;
  }
  return best >= 0 ? best : slowest;
}

namespace {

class RateChosenFilter final : public PoseFilter {
 public:
  explicit RateChosenFilter(std::vector<RateFilter> filters) : filters_(std::move(filters)) {
    for (const RateFilter& f : filters_) rates_.push_back(f.rate_hz);
    reset();
  }

  void reset() noexcept override {
    for (RateFilter& f : filters_) f.filter->reset();
    chosen_ = -1;
    intervals_.reset();
    mismatch_ = 0;
    last_t_ = std::numeric_limits<double>::quiet_NaN();
  }

  // The same hand resumes (PoseFilter::restart): each filter keeps what it learnt of the
  // hand and of its tracker (its own restart), and the rate stays chosen: the runtime is
  // the same. The times start anew, so the gap is no interval of the rate watch.
  void restart() noexcept override {
    for (RateFilter& f : filters_) f.filter->restart();
    mismatch_ = 0;
    last_t_ = std::numeric_limits<double>::quiet_NaN();
  }

  bool push(double t, const Pose& observed) noexcept override {
    if (!is_next_time(t, last_t_)) return false;
    if (!std::isnan(last_t_)) intervals_.record(t - last_t_);
    last_t_ = t;
    if (chosen_ < 0) {
      // Until the rate is known every filter takes the rows.
      for (RateFilter& f : filters_) f.filter->push(t, observed);
      if (intervals_.seen >= kRateChoiceRows - 1) chosen_ = wanted();
      return true;
    }
    // A lasting change of rate (kStreak rows in a row over a full window): the other
    // filter starts from this row.
    if (intervals_.full()) {
      const int want = wanted();
      mismatch_ = want == chosen_ ? 0 : mismatch_ + 1;
      if (mismatch_ >= kStreak) {
        chosen_ = want;
        mismatch_ = 0;
        filters_[static_cast<size_t>(chosen_)].filter->reset();
      }
    }
    filters_[static_cast<size_t>(chosen_)].filter->push(t, observed);
    return true;
  }

  void estimate(double t, Pose& out) const noexcept override {
    filters_[static_cast<size_t>(std::max(chosen_, 0))].filter->estimate(t, out);
  }

  double last_time() const noexcept override { return last_t_; }

 private:
  static constexpr int kWindow = 16, kStreak = 8;  // as the adapter's rate watch

  // The rate the median of the last kWindow intervals asks for.
  int wanted() const noexcept {
    const double median = intervals_.median();
    return choose_rate(rates_, median > 0.0 ? 1.0 / median : std::numeric_limits<double>::infinity());
  }

  std::vector<RateFilter> filters_;
  std::vector<double> rates_;
  IntervalRing<kWindow> intervals_;
  int chosen_ = -1, mismatch_ = 0;
  double last_t_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace

std::unique_ptr<PoseFilter> make_rate_chosen_filter(std::vector<RateFilter> filters) {
  if (filters.empty()) throw std::invalid_argument("make_rate_chosen_filter: no filter");
  for (size_t i = 0; i < filters.size(); ++i) {
    if (!filters[i].filter) throw std::invalid_argument("make_rate_chosen_filter: filter " + std::to_string(i) + " is null");
    if (!(filters[i].rate_hz > 0.0) || !std::isfinite(filters[i].rate_hz))
      throw std::invalid_argument("make_rate_chosen_filter: rate " + std::to_string(i) + " must be positive");
    for (size_t j = 0; j < i; ++j)
      if (filters[j].rate_hz == filters[i].rate_hz)
        throw std::invalid_argument("make_rate_chosen_filter: two models at " + std::to_string(filters[i].rate_hz) + " Hz");
  }
  if (filters.size() == 1) return std::move(filters.front().filter);
  return std::make_unique<RateChosenFilter>(std::move(filters));
}

}  // namespace hs
