// Interpolation, resampling, mirroring and hand-size normalisation of tracks.
#include "handsteady/track_ops.hpp"

#include "handsteady/time_series.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hs {

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
  Track out;
  out.header_lines = track.header_lines;
  for (Hand h : {Hand::Left, Hand::Right}) {
    const HandSeries s = hand_series(track, h);
    if (!s.empty()) add_hand_series(out, h, resample_series(s, rate_hz, max_gap_s));
  }
  out.set_meta("rate_hz", fmt::format("{:g}", rate_hz));
  return out;
}

Pose mirror_pose(const Pose& p) {
  Pose m = p;
  m.col(0) = -p.col(0);
  return m;
}

Track mirror_track(const Track& track) {
  Track out;
  out.header_lines = track.header_lines;
  out.rows.reserve(track.rows.size());
  for (const auto& r : track.rows)
    out.rows.push_back({r.t, r.hand == Hand::Left ? Hand::Right : Hand::Left, mirror_pose(r.pos)});
  // Keep the file convention at equal times (left before right).
  std::stable_sort(out.rows.begin(), out.rows.end(), [](const TrackRow& a, const TrackRow& b) {
    if (a.t != b.t) return a.t < b.t;
    return a.hand < b.hand;
  });
  const bool was = track.meta("mirrored").value_or("no") == "yes";
  out.set_meta("mirrored", was ? "no" : "yes");
  return out;
}

double hand_size(const HandSeries& series) {
  const int w = idx(Joint::Wrist), m = idx(Joint::MiddleProximal);
  std::vector<double> d;
  d.reserve(series.size());
  for (const auto& p : series.pos)
    if (joint_tracked(p, w) && joint_tracked(p, m)) d.push_back((p.row(m) - p.row(w)).norm());
  if (d.empty()) return std::nan("");
  const size_t half = d.size() / 2;
  std::nth_element(d.begin(), d.begin() + static_cast<long>(half), d.end());
  if (d.size() % 2 == 1) return d[half];
  const double upper = d[half];
  const double lower = *std::max_element(d.begin(), d.begin() + static_cast<long>(half));
  return 0.5 * (lower + upper);
}

double normalize_hand_size(HandSeries& series, double target_m) {
  if (!(target_m > 0.0) || !std::isfinite(target_m))
    throw std::invalid_argument("normalize_hand_size: target must be positive");
  const double size = hand_size(series);
  if (!(size > 0.0)) return 1.0;
  const double scale = target_m / size;
  const int w = idx(Joint::Wrist);
  for (auto& p : series.pos) {
    Eigen::RowVector3d centre;
    if (joint_tracked(p, w)) {
      centre = p.row(w);
    } else {
      // No wrist in this row: scale about the tracked joints' centroid instead.
      centre.setZero();
      int n = 0;
      for (int j = 0; j < kJointCount; ++j)
        if (joint_tracked(p, j)) {
          centre += p.row(j);
          ++n;
        }
      if (n == 0) continue;
      centre /= n;
    }
    for (int j = 0; j < kJointCount; ++j)
      if (joint_tracked(p, j)) p.row(j) = centre + scale * (p.row(j) - centre);
  }
  return scale;
}

Track normalize_hand_size(const Track& track, double target_m) {
  Track out;
  out.header_lines = track.header_lines;
  for (Hand h : {Hand::Left, Hand::Right}) {
    HandSeries s = hand_series(track, h);
    if (s.empty()) continue;
    const double scale = normalize_hand_size(s, target_m);
    add_hand_series(out, h, s);
    out.set_meta(fmt::format("hand_scale_{}", hand_name(h)), fmt::format("{:.6f}", scale));
  }
  out.set_meta("hand_size_m", fmt::format("{:g}", target_m));
  return out;
}

}  // namespace hs
