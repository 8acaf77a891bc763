// The oscillation guard (oscillation_guard.hpp): an answer whose whole hand shakes more than
// the input's has its whole-hand correction scaled back towards the input, the per-joint
// rest and answers that shake less left alone; missing joints do not move the mean; and
// through the adapter, the shipped model on a whole-hand 10 Hz oscillation at 30 Hz (which
// it makes larger) loses much of what it added, while its removal of a 5 Hz one stays.
#include "handsteady/corrupt.hpp"
#include "handsteady/metrics.hpp"
#include "handsteady/oscillation_guard.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/synth.hpp"
#include "test_support.hpp"

#include <cmath>
#include <numbers>
#include <vector>

namespace {
using hs::kJointCount;
using hs::OscillationGuard;
constexpr size_t kFs = 3 * kJointCount;

hs::HandSeries moving_hand(double seconds, double rate) { return hs::test::moving_hand(seconds, rate, 7); }

std::vector<float> frame_of(const hs::Pose& p) {
  std::vector<float> f(kFs);
  for (int j = 0; j < kJointCount; ++j)
    for (int c = 0; c < 3; ++c) f[static_cast<size_t>(3 * j + c)] = static_cast<float>(p(j, c));
  return f;
}

// The whole hand moved by a 10 Hz oscillation of amplitude a (m) along x and y at time t.
hs::Pose shaken(hs::Pose p, double t, double a) {
  const double w = 2.0 * std::numbers::pi * 10.0 * t;
  for (int j = 0; j < kJointCount; ++j) {
    p(j, 0) += a * std::sin(w);
    p(j, 1) += a * std::cos(w);
  }
  return p;
}

// A fixed per-joint correction (the network's own, say bone lengths): the guard leaves it.
double offset(int j, int c) { return 1e-4 * static_cast<double>((j * 3 + c) % 7 - 3); }
}  // namespace

TEST_CASE("oscillation guard: an answer shaking the whole hand more than the input is taken back towards it") {
  const auto truth = moving_hand(4.0, 30.0);
  OscillationGuard g;
  double err_input = 0.0, err_answer = 0.0, err_guarded = 0.0, kept_min = 1.0;
  size_t n = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const double t = truth.t[i];
    const hs::Pose x = shaken(truth.pos[i], t, 0.003);
    hs::Pose a = shaken(truth.pos[i], t, 0.0045);  // the oscillation 1.5 x larger
    for (int j = 0; j < kJointCount; ++j)
      for (int c = 0; c < 3; ++c) a(j, c) += offset(j, c);
    g.observe(frame_of(x), a);
    // The shift is the same for every joint and moves the whole-hand correction towards the
    // input, never past it.
    Eigen::Vector3d mean_corr = Eigen::Vector3d::Zero(), shift(g.shift(0), g.shift(1), g.shift(2));
    for (int j = 0; j < kJointCount; ++j) mean_corr += (a.row(j) - x.row(j)).transpose() / kJointCount;
    CHECK((mean_corr + shift).norm() <= mean_corr.norm() + 1e-12);
    CHECK(g.kept() >= 0.0);
    CHECK(g.kept() <= 1.0);
    // Rows 0 and 1 give no difference; it acts from the kGuardWarmRows-th on (row 9).
    if (i <= static_cast<size_t>(hs::kGuardWarmRows)) CHECK(g.kept() == 1.0);
    if (i == static_cast<size_t>(hs::kGuardWarmRows) + 1) CHECK(g.kept() < 1.0);
    if (i < 30) continue;
    kept_min = std::min(kept_min, g.kept());
    for (int j = 0; j < kJointCount; ++j) {
      const Eigen::Vector3d tj = truth.pos[i].row(j).transpose(), aj = a.row(j).transpose();
      err_input += (x.row(j).transpose() - tj).norm();
      err_answer += (aj - tj).norm();
      err_guarded += (aj + shift - tj).norm();
      ++n;
    }
  }
  const auto rows = static_cast<double>(n);
  INFO("mean error: input " << 1e3 * err_input / rows << " mm, answer " << 1e3 * err_answer / rows << " mm, guarded "
                            << 1e3 * err_guarded / rows << " mm; least share kept " << kept_min);
  // Energies 2.25 x the input's: (1 / 2.25)^4 = 4 % of the whole-hand correction kept, so
  // the answer is back near the input (its per-joint offsets stay).
  CHECK(kept_min < 0.1);
  CHECK(err_answer > 1.4 * err_input);
  CHECK(err_guarded - err_input < 0.1 * (err_answer - err_input));
}

TEST_CASE("oscillation guard: an answer that shakes less, or only corrects joints apart, is left as it is") {
  const auto truth = moving_hand(4.0, 30.0);
  OscillationGuard calm, apart;
  for (size_t i = 0; i < truth.size(); ++i) {
    const hs::Pose x = shaken(truth.pos[i], truth.t[i], 0.003);
    hs::Pose a = shaken(truth.pos[i], truth.t[i], 0.001);  // the oscillation a third
    calm.observe(frame_of(x), a);
    // The input's whole-hand motion, half the joints moved one way and half the other at
    // 15 Hz (jerky, but the mean does not move).
    hs::Pose b = x;
    for (int j = 0; j < kJointCount; ++j)
      for (int c = 0; c < 3; ++c) b(j, c) += (j % 2 == 0 ? 1e-3 : -1e-3) * (i % 2 == 0 ? 1.0 : -1.0);
    apart.observe(frame_of(x), b);
    for (int c = 0; c < 3; ++c) {
      CHECK(calm.shift(c) == 0.0);
      CHECK(std::abs(apart.shift(c)) < 1e-12);
    }
  }
}

TEST_CASE("oscillation guard: missing joints neither move the mean nor leave NaN, a row without the hand clears") {
  const auto truth = moving_hand(3.0, 30.0);
  OscillationGuard g, full;
  for (size_t i = 0; i < truth.size(); ++i) {
    const hs::Pose x = shaken(truth.pos[i], truth.t[i], 0.003);
    const hs::Pose a = shaken(truth.pos[i], truth.t[i], 0.0045);
    full.observe(frame_of(x), a);
    // Joint 7 missing in every third row (input and answer), joint 12 in the input alone
    // every other row: each is left out of the rows that miss it.
    hs::Pose xm = x, am = a;
    if (i % 3 == 0) xm.row(7).setConstant(hs::kNaN), am.row(7).setConstant(hs::kNaN);
    if (i % 2 == 0) xm.row(12).setConstant(hs::kNaN);
    g.observe(frame_of(xm), am);
    for (int c = 0; c < 3; ++c) {
      REQUIRE(std::isfinite(g.shift(c)));
      // The same oscillation on every joint: the mean over fewer joints is the same.
      CHECK(std::abs(g.shift(c) - full.shift(c)) < 1e-4);
    }
  }
  CHECK(g.kept() < 0.5);
  // Fewer than kGuardMinJoints joints: nothing to judge the whole hand by.
  hs::Pose few = hs::untracked_pose();
  for (int j = 0; j < hs::kGuardMinJoints - 1; ++j) few.row(j) = truth.pos.back().row(j);
  g.observe(frame_of(few), few);
  for (int c = 0; c < 3; ++c) CHECK(g.shift(c) == 0.0);
  g.clear();
  CHECK(g.kept() == 1.0);
  for (int c = 0; c < 3; ++c) CHECK(g.shift(c) == 0.0);
}

TEST_CASE("oscillation guard through the adapter: the shipped model's overshoot of a whole-hand 10 Hz oscillation at 30 Hz, much of it taken back") {
  const auto model = hs::test::shipped_model();
  const auto truth = moving_hand(20.0, 30.0);
  for (const double hz : {10.0, 5.0}) {
    hs::CorruptionConfig cfg;  // a 3 mm oscillation of the whole hand, fingers still
    cfg.kind = hs::CorruptionKind::Tremor;
    cfg.tremor.freq_min_hz = hz - 0.2;
    cfg.tremor.freq_max_hz = hz + 0.2;
    cfg.tremor.hand_amplitude_m = 0.003;
    cfg.tremor.finger_amplitude_m = 0.0;
    const auto noisy = hs::corrupt_series(truth, cfg, 3);
    auto guarded = hs::make_stgae_filter(model, 0.0);
    auto unguarded = hs::make_stgae_filter(model, 0.0, 0, true, std::nullopt, false, false);
    const double raw = hs::mpjpe_mm(truth.pos, noisy.pos);
    const double with = hs::mpjpe_mm(truth.pos, hs::filter_series(*guarded, noisy, 0.0).pos);
    const double without = hs::mpjpe_mm(truth.pos, hs::filter_series(*unguarded, noisy, 0.0).pos);
    INFO(hz << " Hz: raw " << raw << " mm, guarded " << with << " mm, without the guard " << without << " mm");
    if (hz > 8.0) {
      CHECK(without > 1.08 * raw);  // the case this guards: the network makes it larger
      CHECK(with - raw < 0.7 * (without - raw));
    } else {
      CHECK(without < 0.95 * raw);  // the network removes a 5 Hz oscillation ...
      CHECK(with < without + 0.01);  // ... and the guard leaves that
    }
  }
}
