// Mirroring and hand-size normalisation of tracks.
#include "handsteady/track_ops.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hs {

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
