// Ink metrics: distance to the font, coverage, jerk, latency (docs/HANDWRITING.md).
#include "handsteady/ink.hpp"

#include "handsteady/gap_policy.hpp"
#include "handsteady/track_ops.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace hs {

namespace {

constexpr double kCoverageStep_m = 0.0005;  // font sampling step for the coverage

double point_segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double u = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + u * ab - p).norm();
}

double distance_to_polyline(const Eigen::Vector3d& p, const Polyline& line) {
  if (line.size() == 1) return (p - line.front()).norm();
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 1; i < line.size(); ++i) best = std::min(best, point_segment_distance(p, line[i - 1], line[i]));
  return best;
}

// Linear interpolation between order statistics (as numpy's default percentile).
double percentile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

double median(std::vector<double> v) { return percentile(std::move(v), 0.5); }

// An ink stroke as a polyline with its bounding box grown by the search radius: most
// strokes are far from a given font point and are skipped without a distance computation.
struct BoxedPolyline {
  Polyline line;
  Eigen::Vector3d lo, hi;
};

std::vector<BoxedPolyline> boxed_ink(std::span<const InkStroke> ink, double radius) {
  std::vector<BoxedPolyline> out;
  for (const InkStroke& s : ink) {
    if (s.p.empty()) continue;
    BoxedPolyline b{Polyline(s.p.begin(), s.p.end()), s.p.front(), s.p.front()};
    for (const auto& p : s.p) {
      b.lo = b.lo.cwiseMin(p);
      b.hi = b.hi.cwiseMax(p);
    }
    b.lo.array() -= radius;
    b.hi.array() += radius;
    out.push_back(std::move(b));
  }
  return out;
}

bool within(const Eigen::Vector3d& p, const std::vector<BoxedPolyline>& lines, double radius) {
  for (const BoxedPolyline& b : lines) {
    if ((p.array() < b.lo.array()).any() || (p.array() > b.hi.array()).any()) continue;
    if (distance_to_polyline(p, b.line) <= radius) return true;
  }
  return false;
}

// Velocity of the ink between two consecutive points of a stroke.
struct InkVelocity {
  double t_mid, dt;
  Eigen::Vector3d v;
};

// Consecutive pairs only; a pair spanning a gap (a dropout inside the stroke) is skipped.
std::vector<InkVelocity> ink_velocities(std::span<const InkStroke> ink, double period) {
  std::vector<InkVelocity> out;
  for (const InkStroke& s : ink)
    for (size_t i = 1; i < s.size(); ++i) {
      const double dt = s.t[i] - s.t[i - 1];
      if (dt > 0.0 && dt <= 2.5 * period) out.push_back({0.5 * (s.t[i] + s.t[i - 1]), dt, (s.p[i] - s.p[i - 1]) / dt});
    }
  return out;
}

double ink_period(std::span<const InkStroke> ink) {
  std::vector<double> dts;
  for (const InkStroke& s : ink)
    for (size_t i = 1; i < s.size(); ++i) dts.push_back(s.t[i] - s.t[i - 1]);
  return median(std::move(dts));
}

// The truth's index tip at any time (hs::interpolate_pose: untracked outside the series,
// across a gap > kInterpolateMaxGapS, or next to an untracked sample).
class IndexTipTrack {
 public:
  explicit IndexTipTrack(const HandSeries& truth) : truth_(truth) {}
  std::optional<Eigen::Vector3d> at(double t) const {
    const Eigen::Vector3d p = interpolate_pose(truth_, t).row(idx(Joint::IndexTip)).transpose();
    return std::isnan(p.x()) ? std::nullopt : std::optional<Eigen::Vector3d>(p);
  }

 private:
  const HandSeries& truth_;
};

// Normalised cross-correlation of the ink velocity at t with the truth's at t - tau; the
// truth's finite difference uses the same step as the ink's (same smoothing on both).
double velocity_correlation(const std::vector<InkVelocity>& vel, const IndexTipTrack& truth, double tau) {
  double num = 0.0, ink2 = 0.0, truth2 = 0.0;
  for (const InkVelocity& w : vel) {
    const auto a = truth.at(w.t_mid - tau - 0.5 * w.dt);
    const auto b = truth.at(w.t_mid - tau + 0.5 * w.dt);
    if (!a || !b) continue;
    const Eigen::Vector3d vt = (*b - *a) / w.dt;
    num += w.v.dot(vt);
    ink2 += w.v.squaredNorm();
    truth2 += vt.squaredNorm();
  }
  return ink2 > 0.0 && truth2 > 0.0 ? num / std::sqrt(ink2 * truth2) : kNaN;
}

// Arg-max over lags with a parabola through the peak and its neighbours (in steps).
double peak_offset(const std::vector<double>& c) {
  size_t best = c.size();
  for (size_t i = 0; i < c.size(); ++i)
    if (!std::isnan(c[i]) && (best == c.size() || c[i] > c[best])) best = i;
  if (best == c.size()) return kNaN;
  double delta = 0.0;
  if (best > 0 && best + 1 < c.size() && !std::isnan(c[best - 1]) && !std::isnan(c[best + 1])) {
    const double denom = c[best - 1] - 2.0 * c[best] + c[best + 1];
    if (denom < 0.0) delta = std::clamp(0.5 * (c[best - 1] - c[best + 1]) / denom, -0.5, 0.5);
  }
  return static_cast<double>(best) + delta;
}

}  // namespace

double distance_to_polylines(const Eigen::Vector3d& p, std::span<const Polyline> lines) {
  double best = kNaN;
  for (const Polyline& l : lines) {
    if (l.empty()) continue;
    const double d = distance_to_polyline(p, l);
    if (!(d >= best)) best = d;  // also replaces the initial NaN
  }
  return best;
}

std::vector<double> ink_distances_m(std::span<const InkStroke> ink, std::span<const Polyline> font) {
  std::vector<double> d;
  for (const InkStroke& s : ink)
    for (const auto& p : s.p) d.push_back(distance_to_polylines(p, font));
  return d;
}

double ink_coverage(std::span<const InkStroke> ink, std::span<const Polyline> font, double radius_m) {
  const std::vector<BoxedPolyline> lines = boxed_ink(ink, radius_m);
  double total = 0.0, covered = 0.0;
  for (const Polyline& f : font)
    for (size_t i = 1; i < f.size(); ++i) {
      const double len = (f[i] - f[i - 1]).norm();
      const int n = std::max(1, static_cast<int>(std::ceil(len / kCoverageStep_m)));
      for (int k = 0; k < n; ++k) {
        const Eigen::Vector3d mid = f[i - 1] + ((k + 0.5) / n) * (f[i] - f[i - 1]);
        total += len / n;
        if (within(mid, lines, radius_m)) covered += len / n;
      }
    }
  return total > 0.0 ? covered / total : kNaN;
}

double ink_jerk_rms(std::span<const InkStroke> ink) {
  double sum2 = 0.0;
  size_t n = 0;
  for (const InkStroke& s : ink)
    for (size_t i = 0; i + 3 < s.size(); ++i) {
      const double* t = &s.t[i];
      const Eigen::Vector3d* p = &s.p[i];
      // Newton's divided differences: d1 (3), d2 (2), d3 (1).
      Eigen::Vector3d d1[3], d2[2];
      for (int k = 0; k < 3; ++k) d1[k] = (p[k + 1] - p[k]) / (t[k + 1] - t[k]);
      for (int k = 0; k < 2; ++k) d2[k] = (d1[k + 1] - d1[k]) / (t[k + 2] - t[k]);
      const Eigen::Vector3d jerk = 6.0 * (d2[1] - d2[0]) / (t[3] - t[0]);
      sum2 += jerk.squaredNorm();
      ++n;
    }
  return n > 0 ? std::sqrt(sum2 / static_cast<double>(n)) : kNaN;
}

double ink_latency_ms(std::span<const InkStroke> ink, const HandSeries& truth, double max_lag_s) {
  const double period = ink_period(ink);
  if (!(period > 0.0) || truth.size() < 2) return kNaN;
  const std::vector<InkVelocity> vel = ink_velocities(ink, period);
  const int max_lag = std::max(1, static_cast<int>(std::ceil(max_lag_s / period)));
  const IndexTipTrack tip(truth);
  std::vector<double> c;
  for (int m = -max_lag; m <= max_lag; ++m) c.push_back(velocity_correlation(vel, tip, m * period));
  const double peak = peak_offset(c);
  return (peak - max_lag) * period * 1e3;
}

InkMetrics ink_metrics(std::span<const InkStroke> ink, std::span<const Polyline> font, const HandSeries* truth,
                       double coverage_radius_m) {
  InkMetrics m;
  m.ink_strokes = ink.size();
  m.font_strokes = font.size();
  const std::vector<double> d = ink_distances_m(ink, font);
  m.ink_points = d.size();
  double sum = 0.0;
  for (double v : d) sum += v;
  m.mean_distance_mm = d.empty() ? kNaN : 1e3 * sum / static_cast<double>(d.size());
  m.p95_distance_mm = 1e3 * percentile(d, 0.95);
  m.coverage = ink_coverage(ink, font, coverage_radius_m);
  m.jerk_rms_m_s3 = ink_jerk_rms(ink);
  m.latency_ms = truth ? ink_latency_ms(ink, *truth) : kNaN;
  return m;
}

}  // namespace hs
