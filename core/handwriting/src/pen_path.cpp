// The pen's timeline: minimum-jerk pen-down pieces, pauses, pinch blends, lifted pen-up
// moves (docs/HANDWRITING.md, "Pen motion").
#include "handsteady/handwriting.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace hs {

namespace {

// Towards the user, off the writing plane (the plane faces +Z, the user is at z = 0).
const Eigen::Vector3d kTowardsUser = Eigen::Vector3d::UnitZ();

// Peak speed of a minimum-jerk movement is 1.875 L / T; short ones get a floor duration.
double movement_duration(double length_m, double peak_speed_m_s, double min_s) {
  return std::max(min_s, 1.875 * length_m / peak_speed_m_s);
}

// Pieces of a stroke between corners sharper than corner_deg: the pen stops at a corner
// (a human can't turn sharply at speed) but flows through the gentle turns of a curve.
std::vector<Polyline> split_at_corners(const Polyline& stroke, double corner_deg) {
  const double cos_limit = std::cos(corner_deg * std::numbers::pi / 180.0);
  std::vector<Polyline> pieces(1, Polyline{stroke.front()});
  for (size_t i = 1; i < stroke.size(); ++i) {
    if (i >= 2) {
      const Eigen::Vector3d a = (stroke[i - 1] - stroke[i - 2]).normalized();
      const Eigen::Vector3d b = (stroke[i] - stroke[i - 1]).normalized();
      if (a.dot(b) < cos_limit) pieces.push_back(Polyline{stroke[i - 1]});
    }
    pieces.back().push_back(stroke[i]);
  }
  return pieces;
}

std::vector<double> cumulative_length(const Polyline& path) {
  std::vector<double> arc(path.size(), 0.0);
  for (size_t i = 1; i < path.size(); ++i) arc[i] = arc[i - 1] + (path[i] - path[i - 1]).norm();
  return arc;
}

Eigen::Vector3d point_at_length(const PenSegment& seg, double s) {
  if (seg.path.size() == 1 || s <= 0.0) return seg.path.front();
  const auto it = std::upper_bound(seg.arc.begin(), seg.arc.end(), s);
  if (it == seg.arc.end()) return seg.path.back();
  const size_t i = static_cast<size_t>(it - seg.arc.begin());  // arc[i-1] <= s < arc[i]
  const double f = (s - seg.arc[i - 1]) / (seg.arc[i] - seg.arc[i - 1]);
  return seg.path[i - 1] + f * (seg.path[i] - seg.path[i - 1]);
}

class TimelineBuilder {
 public:
  void rest(const Eigen::Vector3d& p, double duration, double pinch_from, double pinch_to, int stroke) {
    move(Polyline{p}, duration, 0.0, pinch_from, pinch_to, stroke);
  }
  void move(Polyline path, double duration, double lift_m, double pinch_from, double pinch_to, int stroke) {
    if (!(duration > 0.0)) return;  // a zero-length pause is no segment
    PenSegment seg;
    seg.t0 = t_;
    seg.duration = duration;
    seg.arc = cumulative_length(path);
    seg.path = std::move(path);
    seg.lift_m = lift_m;
    seg.pinch_from = pinch_from;
    seg.pinch_to = pinch_to;
    seg.stroke = stroke;
    t_ += duration;
    path_.segments.push_back(std::move(seg));
  }
  PenPath take() { return std::move(path_); }

 private:
  PenPath path_;
  double t_ = 0.0;
};

void validate(std::span<const Polyline> strokes, const PenTiming& tm) {
  if (strokes.empty()) throw std::invalid_argument("plan_pen_path: no strokes");
  for (const Polyline& s : strokes)
    if (s.empty()) throw std::invalid_argument("plan_pen_path: a stroke has no points");
  const auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v))
      throw std::invalid_argument(std::string("pen timing: ") + name + " must be > 0");
  };
  const auto non_negative = [](double v, const char* name) {
    if (!(v >= 0.0) || !std::isfinite(v))
      throw std::invalid_argument(std::string("pen timing: ") + name + " must be >= 0");
  };
  positive(tm.peak_speed_m_s, "peak_speed_m_s");
  positive(tm.min_piece_s, "min_piece_s");
  positive(tm.penup_peak_speed_m_s, "penup_peak_speed_m_s");
  positive(tm.min_penup_s, "min_penup_s");
  positive(tm.pinch_blend_s, "pinch_blend_s");
  non_negative(tm.corner_deg, "corner_deg");
  non_negative(tm.corner_pause_s, "corner_pause_s");
  non_negative(tm.lift_m, "lift_m");
  non_negative(tm.settle_s, "settle_s");
  non_negative(tm.lead_s, "lead_s");
  non_negative(tm.approach_m, "approach_m");
  non_negative(tm.approach_s, "approach_s");
}

// Pinch closed at the stroke's start, the pieces with corner pauses, pinch opened at its end.
void add_stroke(TimelineBuilder& b, const Polyline& stroke, int index, const PenTiming& tm) {
  b.rest(stroke.front(), tm.pinch_blend_s, 0.0, 1.0, -1);
  b.rest(stroke.front(), tm.settle_s, 1.0, 1.0, index);
  const std::vector<Polyline> pieces = split_at_corners(stroke, tm.corner_deg);
  for (size_t k = 0; k < pieces.size(); ++k) {
    if (k > 0) b.rest(pieces[k].front(), tm.corner_pause_s, 1.0, 1.0, index);
    const double d = movement_duration(polyline_length(pieces[k]), tm.peak_speed_m_s, tm.min_piece_s);
    b.move(pieces[k], d, 0.0, 1.0, 1.0, index);
  }
  b.rest(stroke.back(), tm.settle_s, 1.0, 1.0, index);
  b.rest(stroke.back(), tm.pinch_blend_s, 1.0, 0.0, -1);
}

}  // namespace

double minimum_jerk(double u) {
  u = std::clamp(u, 0.0, 1.0);
  return u * u * u * (10.0 + u * (-15.0 + 6.0 * u));
}

double PenPath::duration_s() const {
  return segments.empty() ? 0.0 : segments.back().t0 + segments.back().duration;
}

PenState PenPath::at(double t) const {
  PenState st;
  if (segments.empty()) return st;
  t = std::clamp(t, 0.0, duration_s());
  auto it = std::upper_bound(segments.begin(), segments.end(), t,
                             [](double v, const PenSegment& s) { return v < s.t0; });
  const PenSegment& seg = it == segments.begin() ? segments.front() : *(it - 1);
  const double m = minimum_jerk((t - seg.t0) / seg.duration);
  st.pos = point_at_length(seg, m * seg.arc.back()) + seg.lift_m * std::sin(std::numbers::pi * m) * kTowardsUser;
  st.pinch = seg.pinch_from + (seg.pinch_to - seg.pinch_from) * m;
  st.stroke = seg.stroke;
  return st;
}

PenPath plan_pen_path(std::span<const Polyline> strokes, const PenTiming& tm) {
  validate(strokes, tm);
  TimelineBuilder b;
  const Eigen::Vector3d first = strokes.front().front(), last = strokes.back().back();
  const Eigen::Vector3d approach = tm.approach_m * kTowardsUser;
  b.rest(first + approach, tm.lead_s, 0.0, 0.0, -1);
  b.move({first + approach, first}, tm.approach_s, 0.0, 0.0, 0.0, -1);
  for (size_t i = 0; i < strokes.size(); ++i) {
    add_stroke(b, strokes[i], static_cast<int>(i), tm);
    if (i + 1 == strokes.size()) break;
    const Eigen::Vector3d from = strokes[i].back(), to = strokes[i + 1].front();
    const double d = movement_duration((to - from).norm(), tm.penup_peak_speed_m_s, tm.min_penup_s);
    b.move({from, to}, d, tm.lift_m, 0.0, 0.0, -1);
  }
  b.move({last, last + approach}, tm.approach_s, 0.0, 0.0, 0.0, -1);
  b.rest(last + approach, tm.lead_s, 0.0, 0.0, -1);
  return b.take();
}

}  // namespace hs
