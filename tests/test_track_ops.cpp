#include "handsteady/track_ops.hpp"

#include "test_support.hpp"

#include <cmath>

using namespace hs;

namespace {

// A pose whose joint j sits at (a + j, 2a - j, -a) cm: affine in a, so linear
// interpolation in time of a ramp a(t) is exact.
Pose ramp_pose(double a) {
  Pose p;
  for (int j = 0; j < kJointCount; ++j) p.row(j) << 0.01 * (a + j), 0.01 * (2 * a - j), -0.01 * a;
  return p;
}

HandSeries ramp_series(const std::vector<double>& times) {
  HandSeries s;
  for (double t : times) {
    s.t.push_back(t);
    s.pos.push_back(ramp_pose(3.0 * t));  // a = 3 t
  }
  return s;
}

bool same_pose(const Pose& a, const Pose& b, double tol = 1e-12) {
  for (int j = 0; j < kJointCount; ++j) {
    if (joint_tracked(a, j) != joint_tracked(b, j)) return false;
    if (joint_tracked(a, j) && (a.row(j) - b.row(j)).norm() > tol) return false;
  }
  return true;
}

}  // namespace

TEST_CASE("interpolate_pose: linear between rows, exact at rows, untracked outside") {
  const HandSeries s = ramp_series({0.0, 0.1, 0.3});
  CHECK(same_pose(interpolate_pose(s, 0.05), ramp_pose(0.15)));
  CHECK(same_pose(interpolate_pose(s, 0.25), ramp_pose(0.75)));
  CHECK(same_pose(interpolate_pose(s, 0.1), s.pos[1], 0.0));
  CHECK(same_pose(interpolate_pose(s, 0.3), s.pos[2], 0.0));
  CHECK(!any_joint_tracked(interpolate_pose(s, -0.01)));
  CHECK(!any_joint_tracked(interpolate_pose(s, 0.31)));
  CHECK(!any_joint_tracked(interpolate_pose(HandSeries{}, 0.0)));
  // Gap 0.2 s > max_gap 0.15: nothing between 0.1 and 0.3.
  CHECK(!any_joint_tracked(interpolate_pose(s, 0.2, 0.15)));
  CHECK(any_joint_tracked(interpolate_pose(s, 0.2, 0.2)));
}

TEST_CASE("interpolate_pose: a joint missing on either side stays untracked") {
  HandSeries s = ramp_series({0.0, 0.1});
  s.pos[1].row(idx(Joint::IndexTip)).setConstant(std::nan(""));
  const Pose p = interpolate_pose(s, 0.05);
  CHECK(!joint_tracked(p, idx(Joint::IndexTip)));
  CHECK(tracked_joint_count(p) == kJointCount - 1);
  CHECK(joint_tracked(interpolate_pose(s, 0.0), idx(Joint::IndexTip)));  // the row itself
}

TEST_CASE("resample_series: a ramp on an irregular clock lands on the grid exactly") {
  const HandSeries s = ramp_series({0.013, 0.05, 0.09, 0.12, 0.2, 0.231});
  const HandSeries r = resample_series(s, 50.0);
  // Grid k/50 within [0.013, 0.231]: 0.02, 0.04, ..., 0.22 -> 11 points.
  REQUIRE(r.size() == 11);
  for (size_t i = 0; i < r.size(); ++i) {
    CHECK(r.t[i] == doctest::Approx(0.02 * static_cast<double>(i + 1)));
    CHECK(same_pose(r.pos[i], ramp_pose(3.0 * r.t[i]), 1e-12));
  }
  // Endpoints on the grid are included despite rounding (0.1 * 3 != 0.3).
  const HandSeries e = resample_series(ramp_series({0.0, 0.1 * 3}), 10.0);
  CHECK(e.size() == 4);
  // Gaps beyond max_gap give untracked grid rows, not bridged ones.
  const HandSeries g = resample_series(ramp_series({0.0, 1.0}), 10.0, 0.25);
  REQUIRE(g.size() == 11);
  CHECK(any_joint_tracked(g.pos[0]));
  CHECK(!any_joint_tracked(g.pos[5]));
  CHECK(any_joint_tracked(g.pos[10]));
  CHECK_THROWS_AS(resample_series(s, 0.0), std::invalid_argument);
}

TEST_CASE("resample_series_jittered: times within the jitter of the grid from the first row, refused beyond half a period") {
  std::vector<double> times;
  for (int i = 0; i <= 10; ++i) times.push_back(0.01 + 0.1 * i);
  const HandSeries s = ramp_series(times);
  const HandSeries r = resample_series_jittered(s, 40.0, 0.25, 3);
  REQUIRE(r.size() >= 39);
  CHECK(r.size() <= 41);
  for (size_t i = 0; i < r.size(); ++i) {
    const double k = (r.t[i] - 0.01) * 40.0;
    CHECK(std::abs(k - std::round(k)) <= 0.25 + 1e-9);
    if (i > 0) CHECK(r.t[i] > r.t[i - 1]);
    CHECK(same_pose(r.pos[i], ramp_pose(3.0 * r.t[i]), 1e-12));
  }
  // No jitter: the grid from the first row, exactly.
  const HandSeries g = resample_series_jittered(s, 40.0, 0.0, 3);
  REQUIRE(g.size() >= 40);  // the last, 1.01 s, only if rounding keeps it in the span
  for (size_t i = 0; i < g.size(); ++i) CHECK(g.t[i] == doctest::Approx(0.01 + 0.025 * static_cast<double>(i)));
  CHECK_THROWS_AS(resample_series_jittered(s, 40.0, 0.5, 3), std::invalid_argument);
  CHECK_THROWS_AS(resample_series_jittered(s, 0.0, 0.2, 3), std::invalid_argument);
}

TEST_CASE("resample_track: per hand, rate_hz metadata set") {
  Track t;
  t.set_meta("source", "test");
  t.set_meta("rate_hz", "23.5");
  add_hand_series(t, Hand::Left, ramp_series({0.0, 0.04, 0.09}));
  add_hand_series(t, Hand::Right, ramp_series({0.01, 0.05}));
  const Track r = resample_track(t, 100.0);
  CHECK(r.meta("rate_hz") == "100");
  CHECK(r.meta("source") == "test");
  CHECK(hand_series(r, Hand::Left).size() == 10);   // 0.00 .. 0.09
  CHECK(hand_series(r, Hand::Right).size() == 5);   // 0.01 .. 0.05
}

TEST_CASE("mirror: x negated, hands swapped, twice is the identity") {
  const Pose p = ramp_pose(2.0);
  const Pose m = mirror_pose(p);
  CHECK(m(idx(Joint::IndexTip), 0) == -p(idx(Joint::IndexTip), 0));
  CHECK(m(idx(Joint::IndexTip), 1) == p(idx(Joint::IndexTip), 1));
  CHECK(m(idx(Joint::IndexTip), 2) == p(idx(Joint::IndexTip), 2));

  Track t;
  add_hand_series(t, Hand::Left, ramp_series({0.0, 0.1}));
  HandSeries right = ramp_series({0.0, 0.05});
  right.pos[1].row(3).setConstant(std::nan(""));
  add_hand_series(t, Hand::Right, right);
  const Track once = mirror_track(t);
  CHECK(once.meta("mirrored") == "yes");
  CHECK(hand_series(once, Hand::Left).size() == 2);
  CHECK(same_pose(hand_series(once, Hand::Left).pos[1], mirror_pose(right.pos[1]), 0.0));
  CHECK(!joint_tracked(hand_series(once, Hand::Left).pos[1], 3));
  const Track twice = mirror_track(once);
  CHECK(twice.meta("mirrored") == "no");
  REQUIRE(twice.rows.size() == t.rows.size());
  for (size_t i = 0; i < t.rows.size(); ++i) {
    CHECK(twice.rows[i].t == t.rows[i].t);
    CHECK(twice.rows[i].hand == t.rows[i].hand);
    CHECK(same_pose(twice.rows[i].pos, t.rows[i].pos, 0.0));
  }
}

TEST_CASE("hand_size: median wrist -> middle_proximal, normalize scales about the wrist") {
  HandSeries s;
  // Hands of size 0.07, 0.08, 0.10 m (wrist at varying places) and one without a wrist.
  const double sizes[] = {0.07, 0.10, 0.08};
  for (int i = 0; i < 3; ++i) {
    Pose p = ramp_pose(i);
    const Eigen::RowVector3d w = p.row(idx(Joint::Wrist));
    p.row(idx(Joint::MiddleProximal)) = w + sizes[i] * Eigen::RowVector3d(0, 0.6, -0.8);
    s.t.push_back(0.1 * i);
    s.pos.push_back(p);
  }
  Pose no_wrist = ramp_pose(5);
  no_wrist.row(idx(Joint::Wrist)).setConstant(std::nan(""));
  s.t.push_back(0.3);
  s.pos.push_back(no_wrist);
  CHECK(hand_size(s) == doctest::Approx(0.08));
  HandSeries even = s;
  even.pos.erase(even.pos.begin() + 1);
  even.t.erase(even.t.begin() + 1);
  CHECK(hand_size(even) == doctest::Approx(0.075));  // median of 0.07, 0.08
  CHECK(std::isnan(hand_size(HandSeries{})));

  const HandSeries before = s;
  const double scale = normalize_hand_size(s, 0.09);
  CHECK(scale == doctest::Approx(0.09 / 0.08));
  CHECK(hand_size(s) == doctest::Approx(0.09));
  // Wrists stay put; every other joint moves radially from the wrist by `scale`.
  for (size_t i = 0; i < 3; ++i) {
    const Eigen::RowVector3d w = before.pos[i].row(idx(Joint::Wrist));
    CHECK((s.pos[i].row(idx(Joint::Wrist)) - w).norm() == doctest::Approx(0.0));
    for (int j : {idx(Joint::ThumbTip), idx(Joint::LittleTip)})
      CHECK((s.pos[i].row(j) - (w + scale * (before.pos[i].row(j) - w))).norm() < 1e-12);
  }
  // The wrist-less row scales about its centroid, which stays put.
  auto centroid = [](const Pose& p) {
    Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
    int n = 0;
    for (int j = 0; j < kJointCount; ++j)
      if (joint_tracked(p, j)) {
        c += p.row(j);
        ++n;
      }
    return Eigen::RowVector3d(c / n);
  };
  CHECK((centroid(s.pos[3]) - centroid(before.pos[3])).norm() < 1e-12);
  CHECK((s.pos[3].row(0) - centroid(before.pos[3])).norm() ==
        doctest::Approx(scale * (before.pos[3].row(0) - centroid(before.pos[3])).norm()));

  HandSeries empty;
  CHECK(normalize_hand_size(empty, 0.08) == 1.0);
  CHECK_THROWS_AS(normalize_hand_size(s, 0.0), std::invalid_argument);
}

TEST_CASE("normalize_hand_size(Track): per hand") {
  Track t;
  HandSeries l = ramp_series({0.0, 0.1}), r = ramp_series({0.0});
  // ramp_pose: wrist (joint 1) -> middle_proximal (joint 12) = (0.11, -0.11, 0) m.
  const double size = std::sqrt(2.0) * 0.11;
  add_hand_series(t, Hand::Left, l);
  add_hand_series(t, Hand::Right, r);
  const Track n = normalize_hand_size(t, 0.08);
  CHECK(hand_size(hand_series(n, Hand::Left)) == doctest::Approx(0.08));
  CHECK(hand_size(hand_series(n, Hand::Right)) == doctest::Approx(0.08));
  CHECK(std::stod(*n.meta("hand_scale_left")) == doctest::Approx(0.08 / size).epsilon(1e-5));
  CHECK(n.rows.size() == t.rows.size());
}
