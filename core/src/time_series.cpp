// A hand over time: interpolation at any time and resampling on a fixed grid (time_series.hpp).
#include "handsteady/time_series.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace hs {
namespace {

// Each hand of a track resampled by `resample` (HandSeries, Hand -> HandSeries); header
// kept, rate_hz set.
template <class Resample>
Track resample_each_hand(const Track& track, double rate_hz, const Resample& resample) {
  Track out;
  out.header_lines = track.header_lines;
  for (Hand h : {Hand::Left, Hand::Right}) {
    const HandSeries s = hand_series(track, h);
    if (!s.empty()) add_hand_series(out, h, resample(s, h));
  }
  out.set_meta("rate_hz", fmt::format("{:g}", rate_hz));
  return out;
}

}  // namespace

Pose interpolate_pose(const HandSeries& series, double t, double max_gap_s) {
  if (series.empty() || !std::isfinite(t) || t < series.t.front() || t > series.t.back()) return untracked_pose();
  // First row with time >= t.
  const auto it = std::lower_bound(series.t.begin(), series.t.end(), t);
  const auto i = static_cast<size_t>(it - series.t.begin());
  if (series.t[i] == t) return series.pos[i];
  // Here 0 < i < size: t lies strictly between rows i-1 and i.
  const double t0 = series.t[i - 1], t1 = series.t[i];
  if (t1 - t0 > max_gap_s) return untracked_pose();
  Pose out;
  lerp_pose(series.pos[i - 1], series.pos[i], (t - t0) / (t1 - t0), out);
  return out;
}

HandSeries resample_series(const HandSeries& series, double rate_hz, double max_gap_s) {
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) throw std::invalid_argument("resample: rate_hz must be positive");
  HandSeries out;
  if (series.empty()) return out;
  const double first = series.t.front(), last = series.t.back();
  // Grid points k / rate within [first, last]; a tolerance absorbs rounding of times
  // that are themselves on the grid (e.g. 0.1 * 3 vs 0.3).
  constexpr double kTol = 1e-9;
  const auto k0 = static_cast<long long>(std::ceil(first * rate_hz - kTol));
  const auto k1 = static_cast<long long>(std::floor(last * rate_hz + kTol));
  if (k1 >= k0) {
    out.t.reserve(static_cast<size_t>(k1 - k0 + 1));
    out.pos.reserve(static_cast<size_t>(k1 - k0 + 1));
  }
  for (long long k = k0; k <= k1; ++k) {
    const double tk = static_cast<double>(k) / rate_hz;
    // Evaluate within the span even when tk is off by rounding.
    Pose p = interpolate_pose(series, std::clamp(tk, first, last), max_gap_s);
    // A grid point within rounding of a row takes that row exactly.
    const auto it = std::lower_bound(series.t.begin(), series.t.end(), tk - kTol);
    if (it != series.t.end() && std::abs(*it - tk) <= kTol)
      p = series.pos[static_cast<size_t>(it - series.t.begin())];
    out.t.push_back(tk);
    out.pos.push_back(p);
  }
  return out;
}

Track resample_track(const Track& track, double rate_hz, double max_gap_s) {
  return resample_each_hand(track, rate_hz, [&](const HandSeries& s, Hand) { return resample_series(s, rate_hz, max_gap_s); });
}

HandSeries resample_series_jittered(const HandSeries& series, double rate_hz, double jitter, uint64_t seed,
                                    double max_gap_s) {
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) throw std::invalid_argument("resample: rate_hz must be positive");
  if (!(jitter >= 0.0 && jitter < 0.5)) throw std::invalid_argument("resample: jitter must be in [0, 0.5) of a period");
  HandSeries out;
  if (series.empty()) return out;
  std::mt19937_64 rng(seed);
  const double t0 = series.t.front(), t1 = series.t.back(), period = 1.0 / rate_hz;
  double last = -std::numeric_limits<double>::infinity();
  for (long k = 0;; ++k) {
    const double u = 2.0 * jitter * (static_cast<double>(rng() >> 11) * 0x1.0p-53) - jitter;
    const double t = t0 + (static_cast<double>(k) + u) * period;
    if (t > t1) break;
    if (t < t0 || t <= last) continue;  // the first sample may fall before the hand's first row
    out.t.push_back(t);
    out.pos.push_back(interpolate_pose(series, t, max_gap_s));
    last = t;
  }
  return out;
}

Track resample_track_jittered(const Track& track, double rate_hz, double jitter, uint64_t seed, double max_gap_s) {
  return resample_each_hand(track, rate_hz, [&](const HandSeries& s, Hand h) {
    return resample_series_jittered(s, rate_hz, jitter, seed + 17 * static_cast<uint64_t>(h), max_gap_s);
  });
}

}  // namespace hs
