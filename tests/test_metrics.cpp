// Quality measures on hand-made cases with analytically known answers.
#include "handsteady/metrics.hpp"

#include "test_support.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace {

using hs::Joint;
using hs::Pose;
using hs::idx;
using hs::kNaN;
using hs::test::synthetic_hand;


Pose translated(const Pose& p, double x, double y, double z) {
  Pose q = p;
  q.rowwise() += Eigen::RowVector3d(x, y, z);
  return q;
}

std::vector<Pose> repeated(const Pose& p, size_t n) { return std::vector<Pose>(n, p); }

// Whole hand moving along x: x(f) = amplitude * sin(2 pi (f - delay) / period), metres.
std::vector<Pose> sine_motion(size_t n, double period, double delay, double amplitude = 0.02) {
  std::vector<Pose> s;
  const Pose base = synthetic_hand();
  for (size_t f = 0; f < n; ++f)
    s.push_back(translated(base, amplitude * std::sin(2.0 * std::numbers::pi * (static_cast<double>(f) - delay) / period), 0, 0));
  return s;
}

hs::Track track_of(const std::vector<double>& t, const std::vector<Pose>& pos, hs::Hand hand = hs::Hand::Right) {
  hs::Track tr;
  hs::HandSeries s;
  s.t = t;
  s.pos = pos;
  hs::add_hand_series(tr, hand, s);
  return tr;
}

}  // namespace

TEST_CASE("constant offset: E_pos, MPJPE exact, bones and symmetry unchanged") {
  const auto truth = repeated(synthetic_hand(), 10);
  // Offset (1, 2, 2) mm: distance 3 mm, per-coordinate squared error (1 + 4 + 4) / 3 = 3 mm^2.
  const auto est = repeated(translated(synthetic_hand(), 0.001, 0.002, 0.002), 10);
  CHECK(hs::mpjpe_mm(truth, est) == doctest::Approx(3.0));
  CHECK(hs::e_pos_mm2(truth, est) == doctest::Approx(3.0));
  // Offset (3, 0, 0) mm: MPJPE 3, E_pos 9 / 3 = 3.
  const auto est_x = repeated(translated(synthetic_hand(), 0.003, 0, 0), 10);
  CHECK(hs::mpjpe_mm(truth, est_x) == doctest::Approx(3.0));
  CHECK(hs::e_pos_mm2(truth, est_x) == doctest::Approx(3.0));
  CHECK(hs::e_bon_mm2(truth, est) == doctest::Approx(0.0).scale(1.0).epsilon(1e-9));
  CHECK(hs::e_sym_mm2(truth, est) == doctest::Approx(0.0).scale(1.0).epsilon(1e-9));
  CHECK(hs::accel_error_mm(truth, est) == doctest::Approx(0.0).scale(1.0).epsilon(1e-9));
  CHECK(hs::jitter_mm(est) == doctest::Approx(0.0).scale(1.0).epsilon(1e-9));
}

TEST_CASE("untracked joints are skipped, nothing to compare gives NaN, lengths must match") {
  auto truth = repeated(synthetic_hand(), 4);
  auto est = repeated(translated(synthetic_hand(), 0.003, 0, 0), 4);
  // Untracked joints with a huge error elsewhere must not count.
  for (auto& p : est) p.row(idx(Joint::IndexTip)).setConstant(kNaN);
  truth[0].row(idx(Joint::Wrist)).setConstant(kNaN);
  est[0].row(idx(Joint::ThumbTip)) << 5, 5, 5;
  est[0].row(idx(Joint::ThumbTip)).setConstant(kNaN);
  CHECK(hs::mpjpe_mm(truth, est) == doctest::Approx(3.0));
  const std::vector<Pose> none(3, hs::untracked_pose());
  CHECK(std::isnan(hs::mpjpe_mm(none, none)));
  CHECK(std::isnan(hs::e_pos_mm2(none, none)));
  CHECK(std::isnan(hs::lag_frames(none, none, 3)));
  CHECK_THROWS_AS(hs::mpjpe_mm(truth, std::vector<Pose>(3, synthetic_hand())), std::invalid_argument);
}

TEST_CASE("edge length errors: one bone lengthened, uniform scaling") {
  const hs::Skeleton& sk = hs::xr_hand_skeleton();
  const Pose clean = synthetic_hand();
  SUBCASE("index tip moved 2 mm along its bone") {
    Pose est = clean;
    const Eigen::RowVector3d dir = (clean.row(idx(Joint::IndexTip)) - clean.row(idx(Joint::IndexDistal))).normalized();
    est.row(idx(Joint::IndexTip)) += 0.002 * dir;
    const std::vector<Pose> t{clean}, e{est};
    // Only the distal->tip bone changes, by 2 mm: (2^2) / bone count.
    CHECK(hs::e_bon_mm2(t, e) == doctest::Approx(4.0 / static_cast<double>(sk.bones.size())));
    const std::vector<hs::Edge> one{{idx(Joint::IndexDistal), idx(Joint::IndexTip)}};
    CHECK(hs::edge_length_error_mm2(t, e, one) == doctest::Approx(4.0));
  }
  SUBCASE("hand scaled by 1.1 about the wrist") {
    const Pose est = 1.1 * clean;  // wrist at the origin
    double mean_sq = 0;
    for (auto [a, b] : sk.bones) mean_sq += (clean.row(a) - clean.row(b)).squaredNorm() * 1e6;
    mean_sq /= static_cast<double>(sk.bones.size());
    const std::vector<Pose> t{clean, clean}, e{est, est};
    CHECK(hs::e_bon_mm2(t, e) == doctest::Approx(0.01 * mean_sq));
    double sym_sq = 0;
    for (auto [a, b] : sk.symmetry) sym_sq += (clean.row(a) - clean.row(b)).squaredNorm() * 1e6;
    sym_sq /= static_cast<double>(sk.symmetry.size());
    CHECK(hs::e_sym_mm2(t, e) == doctest::Approx(0.01 * sym_sq));
  }
}

TEST_CASE("acceleration error and jitter: ramp, parabola, alternating noise") {
  std::vector<Pose> ramp, parabola, noisy;
  for (int f = 0; f < 20; ++f) {
    const double x = 0.004 * f;                // 4 mm per frame
    const double y = 0.5 * 0.002 * f * f;      // second difference 2 mm / frame^2
    ramp.push_back(translated(synthetic_hand(), x, 0, 0));
    parabola.push_back(translated(synthetic_hand(), 0, y, 0));
    noisy.push_back(translated(synthetic_hand(), x + (f % 2 ? 0.0005 : -0.0005), 0, 0));
  }
  CHECK(hs::accel_error_mm(ramp, repeated(synthetic_hand(), 20)) == doctest::Approx(0.0).scale(1.0).epsilon(1e-9));
  CHECK(hs::jitter_mm(ramp) == doctest::Approx(0.0).scale(1.0).epsilon(1e-9));
  CHECK(hs::jitter_mm(parabola) == doctest::Approx(2.0));
  CHECK(hs::accel_error_mm(ramp, parabola) == doctest::Approx(2.0));
  // +-0.5 mm alternation: second difference +-2 mm.
  CHECK(hs::accel_error_mm(ramp, noisy) == doctest::Approx(2.0));
  CHECK(hs::jitter_mm(noisy) == doctest::Approx(2.0));
}

TEST_CASE("lag of a delayed sine, integer and sub-frame, both signs") {
  const auto truth = sine_motion(400, 40.0, 0.0);
  for (double k : {3.0, 2.5, 1.3, -2.0, 0.0}) {
    CAPTURE(k);
    const auto est = sine_motion(400, 40.0, k);
    CHECK(hs::lag_frames(truth, est, 10) == doctest::Approx(k).epsilon(0.0).scale(1.0).epsilon(0.05));
  }
}

TEST_CASE("evaluate_tracks: perfect predictor, delayed estimate, skipped rows") {
  // 50 Hz truth, whole hand moving in a sine of period 1 s and 20 mm amplitude.
  const double rate = 50.0;
  const size_t n = 500;
  std::vector<double> t;
  for (size_t i = 0; i < n; ++i) t.push_back(static_cast<double>(i) / rate);
  const auto truth_pos = sine_motion(n, rate, 0.0);
  const hs::Track truth = track_of(t, truth_pos);

  SUBCASE("estimate identical to the truth") {
    const hs::Metrics m = hs::evaluate_tracks(truth, truth, 0.0);
    CHECK(m.frames == n);
    CHECK(m.joint_samples == n * hs::kJointCount);
    CHECK(m.rows_outside == 0);
    CHECK(m.mpjpe_mm == doctest::Approx(0.0).scale(1.0).epsilon(1e-9));
    CHECK(m.jitter_mm == doctest::Approx(m.truth_jitter_mm));
    CHECK(m.lag_ms == doctest::Approx(0.0).scale(1.0).epsilon(0.5));
    CHECK(m.frame_period_ms == doctest::Approx(20.0));
  }
  SUBCASE("estimate late by 3 rows (60 ms)") {
    const hs::Track est = track_of(t, sine_motion(n, rate, 3.0));
    const hs::Metrics m = hs::evaluate_tracks(truth, est, 0.0);
    CHECK(m.lag_frames == doctest::Approx(3.0).epsilon(0.0).scale(1.0).epsilon(0.05));
    CHECK(m.lag_ms == doctest::Approx(60.0).epsilon(0.0).scale(1.0).epsilon(1.0));
    // All joints move together: distance = |x(f) - x(f - 3)| averaged over a period.
    double expected = 0;
    for (size_t f = 0; f < n; ++f)
      expected += std::abs(truth_pos[f](0, 0) - sine_motion(n, rate, 3.0)[f](0, 0)) * 1000.0;
    CHECK(m.mpjpe_mm == doctest::Approx(expected / static_cast<double>(n)));
  }
  SUBCASE("a perfect predictor at a horizon of 5 rows") {
    // est(t) = truth(t + 100 ms); compared with truth at t + 100 ms it is exact.
    const hs::Track est = track_of(t, sine_motion(n, rate, -5.0));
    const hs::Metrics m = hs::evaluate_tracks(truth, est, 0.1);
    CHECK(m.horizon_ms == doctest::Approx(100.0));
    CHECK(m.rows_outside == 5);  // the last 5 rows have no truth 100 ms later
    CHECK(m.frames == n - 5);
    CHECK(m.mpjpe_mm == doctest::Approx(0.0).scale(1.0).epsilon(1e-6));
    CHECK(m.lag_ms == doctest::Approx(0.0).scale(1.0).epsilon(1.0));
  }
  SUBCASE("untracked estimate rows and a hand missing in the truth are counted") {
    auto est_pos = truth_pos;
    for (size_t i = 100; i < 110; ++i) est_pos[i] = hs::untracked_pose();
    hs::Track est = track_of(t, est_pos);
    hs::HandSeries left;
    left.t = {0.0, 0.1};
    left.pos = {synthetic_hand(), synthetic_hand()};
    hs::add_hand_series(est, hs::Hand::Left, left);
    const hs::Metrics m = hs::evaluate_tracks(truth, est, 0.0);
    CHECK(m.rows_untracked == 10);
    CHECK(m.rows_outside == 2);
    CHECK(m.frames == n - 10);
    CHECK(m.mpjpe_mm == doctest::Approx(0.0).scale(1.0).epsilon(1e-9));
  }
}
