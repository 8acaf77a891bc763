// Pinch detection, ink extraction and ink metrics on hand-made cases with known answers.
#include "test_support.hpp"

#include "handsteady/ink.hpp"

#include <cmath>
#include <numbers>
#include <utility>

using namespace hs;

namespace {

// A pose with only the thumb tip and index tip tracked: index at p, thumb d metres away.
Pose pinch_pose(const Eigen::Vector3d& index_tip, double d) {
  Pose p = untracked_pose();
  p.row(idx(Joint::IndexTip)) = index_tip.transpose();
  p.row(idx(Joint::ThumbTip)) = (index_tip + Eigen::Vector3d(0, -d, 0)).transpose();
  return p;
}

InkStroke stroke_of(std::vector<double> t, std::vector<Eigen::Vector3d> p) {
  InkStroke s;
  s.t = std::move(t);
  s.p = std::move(p);
  return s;
}

// Smooth, non-periodic-looking index tip motion (metres) for the latency tests.
Eigen::Vector3d wiggle(double t) {
  const double w = 2.0 * std::numbers::pi;
  return {0.05 * std::sin(w * 0.7 * t) + 0.03 * std::sin(w * 1.3 * t + 1.0), 0.04 * std::sin(w * 0.9 * t + 0.5),
          -0.45 + 0.01 * std::sin(w * 0.4 * t)};
}

HandSeries wiggle_series(double rate, double seconds) {
  HandSeries s;
  for (int k = 0; k <= static_cast<int>(seconds * rate); ++k) {
    const double t = k / rate;
    s.t.push_back(t);
    s.pos.push_back(pinch_pose(wiggle(t), 0.005));
  }
  return s;
}

// Ink in three strokes sampled at the truth's times, the pen `delay` seconds behind.
std::vector<InkStroke> delayed_ink(const HandSeries& truth, double delay) {
  std::vector<InkStroke> ink(3);
  for (size_t i = 0; i < truth.size(); ++i) {
    const double t = truth.t[i];
    if (t < 0.5 || t > 9.5 || (t > 3.0 && t < 3.3) || (t > 6.0 && t < 6.4)) continue;  // pen-up gaps
    InkStroke& s = ink[t < 3.0 ? 0 : t < 6.0 ? 1 : 2];
    s.t.push_back(t);
    s.p.push_back(wiggle(t - delay));
  }
  return ink;
}

}  // namespace

TEST_CASE("PinchDetector: hysteresis between close 2.0 cm and open 3.5 cm") {
  static_assert(noexcept(std::declval<PinchDetector&>().update(std::declval<const Pose&>())));
  static_assert(noexcept(std::declval<PinchDetector&>().update_distance(0.0)));
  PinchDetector d;
  CHECK_FALSE(d.pinched());
  CHECK_FALSE(d.update_distance(0.030));  // between the thresholds: stays open
  CHECK_FALSE(d.update_distance(0.020));  // not below close
  CHECK(d.update_distance(0.0199));
  CHECK(d.update_distance(0.030));  // between: stays pinched
  CHECK(d.update_distance(0.035));  // not above open
  CHECK_FALSE(d.update_distance(0.0351));
  CHECK_FALSE(d.update_distance(0.025));
  CHECK(d.update_distance(0.005));
  d.reset();
  CHECK_FALSE(d.pinched());
}

TEST_CASE("PinchDetector: untracked thumb or index keeps the state") {
  PinchDetector d;
  CHECK(d.update(pinch_pose({0, 0, -0.4}, 0.01)));
  Pose no_thumb = pinch_pose({0, 0, -0.4}, 0.10);
  no_thumb.row(idx(Joint::ThumbTip)).setConstant(std::nan(""));
  CHECK(d.update(no_thumb));
  CHECK(d.update(untracked_pose()));
  CHECK(d.update_distance(std::nan("")));
  CHECK_FALSE(d.update(pinch_pose({0, 0, -0.4}, 0.05)));
  CHECK_FALSE(d.update(untracked_pose()));
}

TEST_CASE("PinchDetector: custom thresholds") {
  PinchDetector d(PinchThresholds{0.01, 0.02});
  CHECK_FALSE(d.update_distance(0.015));
  CHECK(d.update_distance(0.009));
  CHECK(d.update_distance(0.019));
  CHECK_FALSE(d.update_distance(0.021));
}

TEST_CASE("extract_ink: one stroke per pinch, index tip points, gaps where untracked") {
  HandSeries s;
  // distance per frame: open, open, closed x4 (frame 4: index untracked), open x2, closed x2
  const double dist[] = {0.06, 0.03, 0.015, 0.01, 0.01, 0.03, 0.05, 0.06, 0.01, 0.012};
  for (int k = 0; k < 10; ++k) {
    s.t.push_back(0.1 * k);
    s.pos.push_back(pinch_pose({0.01 * k, 0.0, -0.45}, dist[k]));
  }
  s.pos[4].row(idx(Joint::IndexTip)).setConstant(std::nan(""));  // thumb seen, index not: state kept
  const auto ink = extract_ink(s);
  REQUIRE(ink.size() == 2);
  REQUIRE(ink[0].size() == 3);
  CHECK(ink[0].t[0] == doctest::Approx(0.2));
  CHECK(ink[0].t[1] == doctest::Approx(0.3));
  CHECK(ink[0].t[2] == doctest::Approx(0.5));  // frame 4 (0.4 s) is the gap
  CHECK(ink[0].p[0].x() == doctest::Approx(0.02));
  CHECK(ink[0].p[2].x() == doctest::Approx(0.05));
  REQUIRE(ink[1].size() == 2);
  CHECK(ink[1].t[0] == doctest::Approx(0.8));

  InkRecorder rec;
  for (size_t i = 0; i < 4; ++i) rec.push(s.t[i], s.pos[i]);
  CHECK(rec.pen_down());
  CHECK(rec.strokes().size() == 1);
  rec.clear();
  CHECK(rec.strokes().empty());
  CHECK_FALSE(rec.pen_down());
}

TEST_CASE("ink distances: a straight stroke and known offsets") {
  const std::vector<Polyline> font = {{{0, 0, 0}, {0.1, 0, 0}}};
  const std::vector<InkStroke> ink = {
      stroke_of({0.0, 0.1, 0.2}, {{0.02, 0.003, 0.0}, {0.05, 0.003, 0.004}, {0.11, 0.0, 0.0}})};
  const auto d = ink_distances_m(ink, font);
  REQUIRE(d.size() == 3);
  CHECK(d[0] == doctest::Approx(0.003));
  CHECK(d[1] == doctest::Approx(0.005));
  CHECK(d[2] == doctest::Approx(0.010));  // past the end: distance to the end point
  const InkMetrics m = ink_metrics(ink, font, nullptr);
  CHECK(m.mean_distance_mm == doctest::Approx(6.0));
  CHECK(m.p95_distance_mm == doctest::Approx(9.5));  // 5 + 0.9 * (10 - 5)
  CHECK(m.ink_strokes == 1);
  CHECK(m.font_strokes == 1);
  CHECK(m.ink_points == 3);
  CHECK(std::isnan(m.latency_ms));
  // A one-point font stroke (a dot) is a point.
  const std::vector<Polyline> dot = {{{0, 0, 0}}};
  CHECK(distance_to_polylines({0.003, 0.004, 0}, dot) == doctest::Approx(0.005));
  CHECK(std::isnan(distance_to_polylines({0, 0, 0}, std::vector<Polyline>{})));
}

TEST_CASE("ink coverage: half a stroke drawn") {
  const std::vector<Polyline> font = {{{0, 0, 0}, {0.1, 0, 0}}};
  // Ink along x in [0, 0.05] 2 mm off the line: covers x <= 0.05 + sqrt(5^2 - 2^2) mm.
  const std::vector<InkStroke> ink = {stroke_of({0.0, 0.1}, {{0.0, 0.002, 0.0}, {0.05, 0.002, 0.0}})};
  CHECK(ink_coverage(ink, font) == doctest::Approx((0.05 + std::sqrt(21.0) * 1e-3) / 0.1).epsilon(0.01));
  CHECK(ink_coverage(ink, font, 0.001) == doctest::Approx(0.0));
  CHECK(ink_coverage({}, font) == doctest::Approx(0.0));
  CHECK(std::isnan(ink_coverage(ink, std::vector<Polyline>{})));
}

TEST_CASE("ink jerk: a cubic at irregular times has jerk 6a, a straight line at constant speed none") {
  const double a = 2.0;  // x = a t^3 -> jerk 12 m/s^3
  InkStroke cubic, line;
  for (double t : {0.0, 0.013, 0.031, 0.047, 0.058, 0.081, 0.1}) {
    cubic.t.push_back(t);
    cubic.p.emplace_back(a * t * t * t, 0.3 * t * t, 0.1 * t);
    line.t.push_back(t);
    line.p.emplace_back(0.2 * t, -0.1 * t, 0.0);
  }
  CHECK(ink_jerk_rms(std::vector<InkStroke>{cubic}) == doctest::Approx(6.0 * a));
  CHECK(ink_jerk_rms(std::vector<InkStroke>{line}) == doctest::Approx(0.0).epsilon(1e-9));
  // Fewer than 4 points in a stroke: nothing to measure.
  CHECK(std::isnan(ink_jerk_rms(std::vector<InkStroke>{stroke_of({0, 1, 2}, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}})})));
}

TEST_CASE("ink latency: a delayed copy of the truth") {
  const HandSeries truth = wiggle_series(60.0, 10.0);
  CHECK(std::abs(ink_latency_ms(delayed_ink(truth, 0.0), truth)) < 0.1);
  CHECK(ink_latency_ms(delayed_ink(truth, 0.05), truth) == doctest::Approx(50.0).epsilon(0.01));  // 3 frames
  CHECK(ink_latency_ms(delayed_ink(truth, 0.04), truth) == doctest::Approx(40.0).epsilon(0.05));  // 2.4 frames
  CHECK(ink_latency_ms(delayed_ink(truth, -0.03), truth) == doctest::Approx(-30.0).epsilon(0.05));  // ahead
  const InkMetrics m = ink_metrics(delayed_ink(truth, 0.05), std::vector<Polyline>{{{0, 0, -0.45}}}, &truth);
  CHECK(m.latency_ms == doctest::Approx(50.0).epsilon(0.01));
  CHECK(m.ink_strokes == 3);
}

TEST_CASE("ink metrics with no ink") {
  const InkMetrics m = ink_metrics({}, std::vector<Polyline>{{{0, 0, 0}, {0.1, 0, 0}}}, nullptr);
  CHECK(m.ink_strokes == 0);
  CHECK(m.ink_points == 0);
  CHECK(std::isnan(m.mean_distance_mm));
  CHECK(std::isnan(m.p95_distance_mm));
  CHECK(m.coverage == 0.0);
  CHECK(std::isnan(m.jerk_rms_m_s3));
}
