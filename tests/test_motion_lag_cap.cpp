// The lag cap (motion_lag_cap.hpp): on a joint moving faster than its noise explains, an
// answer behind the hand is brought to within half the noise along the motion and left as
// it is across it; slow or still joints, outliers taken back (a bone stretched, or a
// correction unlike lag), missing joints and unmeasured noise are left alone, a fast hand's
// own rows called jumps are not. Through the adapter:
// the shipped model on fast free-air Leap Motion takes.
#include "handsteady/corrupt.hpp"
#include "handsteady/filters.hpp"
#include "handsteady/motion_lag_cap.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/time_series.hpp"
#include "handsteady/track.hpp"
#include "test_support.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <vector>
#include <limits>
#include <span>

namespace {
using hs::kJointCount;
using hs::MotionLagCap;
constexpr double kRate = 90.0;
constexpr double kNoise = 0.001;  // the input's noise RMS, m

struct Row {
  std::array<float, 3 * kJointCount> x{};
  hs::Pose answer = hs::untracked_pose();
  std::array<double, kJointCount> noise2{};
  std::array<double, kJointCount> jump{};
  std::array<bool, kJointCount> stretched{};
};

// Row k of a hand whose joints all move along x at `speed` (m/s), the input exact, the
// answer `lag_s` behind it and 0.3 mm off across the motion (y).
Row moving(int k, double speed, double lag_s) {
  Row r;
  const double t = k / kRate;
  for (int j = 0; j < kJointCount; ++j) {
    const double x = speed * t, y = 0.01 * j;
    r.x[3 * j] = static_cast<float>(x);
    r.x[3 * j + 1] = static_cast<float>(y);
    r.x[3 * j + 2] = 0.0f;
    r.answer.row(j) << speed * (t - lag_s), y + 0.0003, 0.0;
  }
  r.noise2.fill(kNoise * kNoise);
  return r;
}

// Row r's input moved `by` (m) along axis `axis` (0: along the motion, 1: across it), and
// called a jump of that size, as InputNoise would; the answer stays where it was. An
// outlier of one joint stretches a bone it ends (`stretches`); a shift that turns the bone
// instead (the papers' corruption) keeps them.
void outlier(Row& r, int axis, double by, bool stretches = true) {
  for (int j = 0; j < kJointCount; ++j) r.x[static_cast<size_t>(3 * j + axis)] += static_cast<float>(by);
  r.jump.fill(std::abs(by));
  r.stretched.fill(stretches);
}

void observe(MotionLagCap& cap, const Row& r, double jump_share = hs::kMotionCapJumpShare) {
  cap.observe(std::span<const float>(r.x), r.answer, std::span<const double>(r.noise2), std::span<const double>(r.jump),
              std::span<const bool>(r.stretched), jump_share);
}

// The cap after 8 rows of moving(k, speed, 2 ms), the last one changed by `edit`.
template <class Edit>
MotionLagCap after_rows(double speed, Edit&& edit, double jump_share = hs::kMotionCapJumpShare) {
  MotionLagCap cap;
  for (int k = 0; k < 8; ++k) {
    Row r = moving(k, speed, 0.002);
    if (k == 7) edit(r);
    observe(cap, r, jump_share);
  }
  return cap;
}
}  // namespace

TEST_CASE("lag cap: a fast joint's answer behind the hand is held to half the noise along the motion, kept across") {
  MotionLagCap cap;
  constexpr double kSpeed = 1.0, kLag = 0.002;  // 2 mm behind; the bar: 8 * sqrt(2) * 1 mm per two rows (0.51 m/s)
  for (int k = 0; k < 3; ++k) {
    observe(cap, moving(k, kSpeed, kLag));
    CHECK(cap.shift(0, 0) == 0.0);  // three answers needed for the step
  }
  for (int k = 3; k < 10; ++k) {
    observe(cap, moving(k, kSpeed, kLag));
    for (int j = 0; j < kJointCount; ++j) {
      CHECK(cap.shift(j, 0) == doctest::Approx(kSpeed * kLag - hs::kMotionCapFactor * kNoise).epsilon(1e-6));
      CHECK(std::abs(cap.shift(j, 1)) < 1e-6);  // across the motion: as the network answered
      CHECK(std::abs(cap.shift(j, 2)) < 1e-6);
    }
  }
  // An answer ahead of the hand is held the same way.
  MotionLagCap ahead;
  for (int k = 0; k < 6; ++k) observe(ahead, moving(k, kSpeed, -kLag));
  CHECK(ahead.shift(3, 0) == doctest::Approx(-(kSpeed * kLag - hs::kMotionCapFactor * kNoise)).epsilon(1e-6));
}

TEST_CASE("lag cap: slow and still joints, jumps, missing joints and unmeasured noise are left alone") {
  auto last_shift = [](double speed, auto&& edit) {
    const MotionLagCap cap = after_rows(speed, edit);
    double m = 0.0;
    for (int j = 0; j < kJointCount; ++j)
      for (int c = 0; c < 3; ++c) m = std::max(m, std::abs(cap.shift(j, c)));
    return m;
  };
  const auto none = [](Row&) {};
  CHECK(last_shift(1.0, none) > 0.001);  // the case below each check differs from
  CHECK(last_shift(0.3, none) == 0.0);   // under the bar: a slow hand's correction is the network's to make
  CHECK(last_shift(0.0, none) == 0.0);
  CHECK(last_shift(1.0, [](Row& r) { outlier(r, 0, 0.02); }) == 0.0);  // an outlier taken back stays whole
  CHECK(last_shift(1.0, [](Row& r) { r.noise2.fill(0.0); }) == 0.0);
  CHECK(last_shift(1.0, [](Row& r) { r.x.fill(std::numeric_limits<float>::quiet_NaN()); }) == 0.0);
  CHECK(last_shift(1.0, [](Row& r) { r.answer = hs::untracked_pose(); }) == 0.0);
  // Cleared (a row without the hand) and reset: no shift.
  MotionLagCap cap;
  for (int k = 0; k < 8; ++k) observe(cap, moving(k, 1.0, 0.002));
  REQUIRE(cap.shift(0, 0) > 0.001);
  cap.clear();
  CHECK(cap.shift(0, 0) == 0.0);
  cap.reset();
  observe(cap, moving(8, 1.0, 0.002));
  CHECK(cap.shift(0, 0) == 0.0);
}

TEST_CASE("lag cap on a row InputNoise calls a jump: the fast hand's own row is capped, an outlier taken back is not") {
  // A fast hand's rows leave the quadratic through the rows before them by more than the
  // noise explains, so InputNoise calls some of them jumps; the answer's lag there is lag.
  const auto shift_x = [](auto&& edit) { return after_rows(1.0, edit).shift(4, 0); };
  const double capped = 0.002 - hs::kMotionCapFactor * kNoise;
  CHECK(shift_x([](Row&) {}) == doctest::Approx(capped).epsilon(1e-6));
  CHECK(shift_x([](Row& r) { r.jump.fill(0.004); }) == doctest::Approx(capped).epsilon(1e-6));
  // A row that is no jump is capped whatever its bones did (InputNoise found no outlier).
  CHECK(shift_x([](Row& r) { r.stretched.fill(true); }) == doctest::Approx(capped).epsilon(1e-6));
  // Outliers the answer takes back that stretched a bone stay whole at any size and in any
  // direction, 8 mm along the motion (well under the joint's 22 mm step: two rows at 1 m/s,
  // where the correction alone reads as lag) as 20 mm along, against or across it.
  CHECK(shift_x([](Row& r) { outlier(r, 0, -0.008); }) == 0.0);
  CHECK(shift_x([](Row& r) { outlier(r, 0, 0.02); }) == 0.0);
  CHECK(shift_x([](Row& r) { outlier(r, 0, -0.02); }) == 0.0);
  CHECK(shift_x([](Row& r) { outlier(r, 1, 0.02); }) == 0.0);
  // Outliers that kept the bones are told by the correction: over the step along the motion,
  // or mostly across it, whole ...
  CHECK(shift_x([](Row& r) { outlier(r, 0, 0.03, false); }) == 0.0);
  CHECK(shift_x([](Row& r) { outlier(r, 0, -0.03, false); }) == 0.0);
  CHECK(shift_x([](Row& r) { outlier(r, 1, 0.02, false); }) == 0.0);
  // ... and the rule's limit: one along the motion under the step reads as lag (or lead),
  // and is capped like it.
  CHECK(shift_x([](Row& r) { outlier(r, 0, -0.008, false); }) < -0.005);
  CHECK(shift_x([](Row& r) { outlier(r, 0, 0.015, false); }) > 0.012);
  // One stream on slow rows asks for a quarter of the step: those two stay whole there, the
  // hand's own lag (2 mm of a 22 mm step) is capped as before.
  const auto slow_x = [](auto&& edit) { return after_rows(1.0, edit, hs::kMotionCapJumpShareSlowRows).shift(4, 0); };
  CHECK(slow_x([](Row& r) { outlier(r, 0, -0.008, false); }) == 0.0);
  CHECK(slow_x([](Row& r) { outlier(r, 0, 0.015, false); }) == 0.0);
  CHECK(slow_x([](Row& r) { r.jump.fill(0.004); }) == doctest::Approx(capped).epsilon(1e-6));
}

namespace {
// The Leap tuning subject's swipes (fast free-air motion; not a benchmark test set)
// resampled to `rate` with the tracker preset's noise, through the adapter with the shipped
// model; over the joint rows moving faster than 1 m/s: the answer's mean component along
// the motion (behind: negative) and its mean size, its error and raw's (mm).
struct SwipeLag {
  double along = 0.0, abs_along = 0.0, err = 0.0, raw_err = 0.0;
  long n = 0;
};
SwipeLag swipes_at(double rate) {
  const auto model = hs::test::shipped_model();
  const auto takes = hs::test::leap_tuning_takes("swipe");
  REQUIRE(takes.size() >= 2);
  SwipeLag s;
  for (const auto& take : takes) {
    const hs::HandSeries truth = hs::resample_series(hs::hand_series(hs::read_track_csv(take), hs::Hand::Right), rate);
    const hs::HandSeries noisy = hs::corrupt_series(truth, hs::corruption_preset("tracker"), 1);
    auto f = hs::make_stgae_filter(model, 0.0);
    const hs::HandSeries out = hs::filter_series(*f, noisy, 0.0);
    for (size_t i = 1; i + 1 < truth.size(); ++i)
      for (int j = 0; j < kJointCount; ++j) {
        const Eigen::Vector3d v = (truth.pos[i + 1].row(j) - truth.pos[i - 1].row(j)).transpose() / (truth.t[i + 1] - truth.t[i - 1]);
        const Eigen::Vector3d e = (out.pos[i].row(j) - truth.pos[i].row(j)).transpose();
        const Eigen::Vector3d r = (noisy.pos[i].row(j) - truth.pos[i].row(j)).transpose();
        if (!v.allFinite() || !e.allFinite() || !r.allFinite() || !(v.norm() > 1.0)) continue;
        s.along += e.dot(v.normalized());
        s.abs_along += std::abs(e.dot(v.normalized()));
        s.err += e.norm();
        s.raw_err += r.norm();
        ++s.n;
      }
  }
  REQUIRE(s.n > 100);
  const double k = 1e3 / static_cast<double>(s.n);
  s.along *= k;
  s.abs_along *= k;
  s.err *= k;
  s.raw_err *= k;
  MESSAGE(takes.size() << " takes at " << rate << " Hz, " << s.n << " joint rows over 1 m/s: answered " << s.along
                       << " mm along the motion (" << s.abs_along << " mm in size), error " << s.err << " mm (raw " << s.raw_err << " mm)");
  return s;
}
}  // namespace

TEST_CASE("lag cap through the adapter: the shipped model on fast free-air takes at 90 Hz falls less far behind") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  // At 90 Hz the adapter runs K = 3 streams, without the palm fit. Without the cap
  // (kMotionCapFactor 1e9) its joints moving over 1 m/s were answered 1.02 mm behind the hand
  // on average, 1.54 mm off (raw 0.98); with it 0.44 mm behind, 1.13 mm off (2026-11-30); with the
  // adapter of 2026-12-05 0.36 / 1.11, and the cap on the hand's own jump rows too 0.35 / 1.09.
  const SwipeLag s = swipes_at(90.0);
  CHECK(s.along > -0.7);
  CHECK(s.err < 1.3);
}

TEST_CASE("lag cap through the adapter: one stream on rows slower than the model (23.5 Hz) answers a fast hand closer") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  // HoloLens 2's rate: one stream, whose rows measure the noise (slow rows). There the
  // network's answer on a fast hand is as often ahead of it (a swipe that stops) as behind.
  // Without the cap (2026-12-06) 0.80 mm along the motion in size (-0.03 in sign), 1.28 mm
  // off (raw 0.98); with it 0.69 (+0.01) and 1.20.
  const SwipeLag s = swipes_at(23.5);
  CHECK(s.abs_along < 0.74);
  CHECK(s.err < 1.24);
}
