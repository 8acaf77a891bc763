// The tremor canceller (tremor_cancel.hpp): a steady oscillation on a moving hand is taken
// out without lag, the corruption's wandering whole-hand and finger tremor in good part, at
// any rate and with irregular times; voluntary strokes at tremor frequencies, deliberate
// rhythmic motion of centimetres, recorded handwriting, a clean moving hand, white jitter
// and a still hand are left (almost) alone; dropped joints do not stop it; missing joints stay
// missing; no allocation; and make_filter puts it in front of a method only when asked.
#include "allocation_counting.hpp"
#include "handsteady/corrupt.hpp"
#include "handsteady/filters.hpp"
#include "handsteady/synth.hpp"
#include "handsteady/tremor_cancel.hpp"
#include "test_support.hpp"

#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>

namespace {
using hs::Pose;
using hs::TremorCancel;

hs::HandSeries moving_hand(double seconds, double rate_hz, bool irregular = false, uint64_t seed = 11) {
  hs::SynthMotionParams p;
  p.duration_s = seconds;
  p.rate_hz = rate_hz;
  hs::HandSeries s = hs::synth_motion(p, hs::Hand::Right, seed);
  if (irregular) {  // row k at (k + u) / rate, u in +-0.2 (the poses stay: truth and input share them)
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> u(-0.2, 0.2);
    for (size_t k = 1; k + 1 < s.size(); ++k) s.t[k] += u(rng) / rate_hz;
  }
  return s;
}

hs::HandSeries with_tremor(const hs::HandSeries& clean, double lo_hz, double hi_hz, double hand_m, uint64_t seed) {
  hs::CorruptionConfig c;
  c.kind = hs::CorruptionKind::Tremor;
  c.tremor = {lo_hz, hi_hz, hand_m, 0.5 * hand_m};
  return hs::corrupt_series(clean, c, seed);
}

// Mean joint distance (mm) over rows from `from_s` on (to `to_s`).
double mean_error_mm(const hs::HandSeries& a, const hs::HandSeries& truth, double from_s, double to_s = 1e9) {
  double s = 0.0;
  int n = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a.t[i] - a.t.front() < from_s || a.t[i] - a.t.front() >= to_s) continue;
    for (int j = 0; j < hs::kJointCount; ++j) {
      if (!hs::joint_tracked(a.pos[i], j)) continue;
      s += (a.pos[i].row(j) - truth.pos[i].row(j)).norm();
      ++n;
    }
  }
  return 1e3 * s / n;
}

// RMS (mm) over rows from `from_s` on of each joint's error about the hand's mean error: the
// part of the error that bends the hand (a finger's own tremor, or one the canceller adds).
double bend_error_mm(const hs::HandSeries& a, const hs::HandSeries& truth, double from_s) {
  double s = 0.0;
  int n = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a.t[i] - a.t.front() < from_s) continue;
    Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
    int m = 0;
    for (int j = 0; j < hs::kJointCount; ++j)
      if (hs::joint_tracked(a.pos[i], j)) mean += a.pos[i].row(j) - truth.pos[i].row(j), ++m;
    if (m == 0) continue;
    mean /= m;
    for (int j = 0; j < hs::kJointCount; ++j)
      if (hs::joint_tracked(a.pos[i], j)) s += (a.pos[i].row(j) - truth.pos[i].row(j) - mean).squaredNorm(), ++n;
  }
  return 1e3 * std::sqrt(s / n);
}

hs::HandSeries cancelled(const hs::HandSeries& in) {
  TremorCancel tc;
  hs::HandSeries out = in;
  for (size_t i = 0; i < out.size(); ++i) tc.apply(out.t[i], out.pos[i]);
  return out;
}

// The whole hand moved by amp_m sin(2 pi hz t) along x.
hs::HandSeries oscillated(hs::HandSeries s, double amp_m, double hz) {
  for (size_t i = 0; i < s.size(); ++i)
    for (int j = 0; j < hs::kJointCount; ++j) s.pos[i](j, 0) += amp_m * std::sin(2.0 * std::numbers::pi * hz * s.t[i]);
  return s;
}

}  // namespace

TEST_CASE("Tremor canceller: a steady 5.2 Hz oscillation on a moving hand is taken out without lag") {
  const hs::HandSeries truth = moving_hand(10.0, 90.0);
  const hs::HandSeries noisy = oscillated(truth, 0.004, 5.2);
  TremorCancel tc;
  hs::HandSeries out = noisy;
  for (size_t i = 0; i < out.size(); ++i) tc.apply(out.t[i], out.pos[i]);
  const double before = mean_error_mm(noisy, truth, 5.0), after = mean_error_mm(out, truth, 5.0);
  MESSAGE("5.2 Hz, 4 mm: " << before << " -> " << after << " mm, following " << tc.frequency_hz() << " Hz");
  CHECK(after < 0.1 * before);
  CHECK(std::abs(tc.frequency_hz() - 5.2) < 0.1);
}

TEST_CASE("Tremor canceller: the corruption's wandering tremor on a moving hand, at several rates") {
  struct Case {
    double lo, hi, amp_m, rate;
    double at_most;  // share of the tremor's error left
  };
  // 8-12 Hz: its wandering peak is wide; 0.76 of it was left while the prominence's sides
  // were a fixed 0.8 Hz away.
  for (const Case c : {Case{4, 6, 0.004, 90, 0.6}, Case{4, 6, 0.004, 30, 0.6}, Case{8, 12, 0.002, 90, 0.6},
                       Case{8, 12, 0.002, 60, 0.6}, Case{4, 6, 0.003, 60, 0.6}}) {
    const hs::HandSeries truth = moving_hand(20.0, c.rate, true);
    const hs::HandSeries noisy = with_tremor(truth, c.lo, c.hi, c.amp_m, 7);
    const hs::HandSeries out = cancelled(noisy);
    const double before = mean_error_mm(noisy, truth, 5.0);
    const double after = mean_error_mm(out, truth, 5.0);
    // The fingers' own part (half the hand's amplitude, each finger at its own frequency,
    // the oscillator at the hand's): the joints' channels must not bend the hand more than
    // the tremor did.
    const double bend_before = bend_error_mm(noisy, truth, 5.0), bend_after = bend_error_mm(out, truth, 5.0);
    MESSAGE(c.lo << "-" << c.hi << " Hz, " << c.amp_m * 1e3 << " mm at " << c.rate << " Hz: " << before << " -> "
                 << after << " mm; the hand bent by " << bend_before << " -> " << bend_after << " mm");
    CHECK(after < c.at_most * before);
    CHECK(bend_after <= bend_before);
  }
}

TEST_CASE("Tremor canceller: the frequency lock follows a wandering tremor on a still hand") {
  // The corruption's 4-6 Hz tremor (4 mm whole hand, 2 mm fingers; the frequency wanders
  // +-0.5 Hz over 4-10 s) on a hand that holds still, 60 Hz. The spectrum's peak over 2 s
  // trails the wandering, and without the lock the short fit chased the slipping phase:
  // 0.39 and 0.45 of the error were left (checked with kTremorLockS set to 1e9), 0.24 and
  // 0.27 with it.
  hs::HandSeries truth = moving_hand(20.0, 60.0);
  for (size_t i = 1; i < truth.size(); ++i) truth.pos[i] = truth.pos[0];
  for (const uint64_t seed : {1u, 7u}) {
    const hs::HandSeries noisy = with_tremor(truth, 4.0, 6.0, 0.004, seed);
    const hs::HandSeries out = cancelled(noisy);
    const double before = mean_error_mm(noisy, truth, 3.0), after = mean_error_mm(out, truth, 3.0);
    MESSAGE("seed " << seed << ": " << before << " -> " << after << " mm (" << after / before << " of it left)");
    CHECK(after < 0.33 * before);
  }
}

TEST_CASE("Tremor canceller: it starts within a second of tracking starting") {
  // Hands come into view and leave all the time, and a take may last two seconds (FPHA's
  // do): a canceller that needs 1.5 s to start misses most of them. Ten 2 s takes of a
  // moving hand with the corruption's 4-6 Hz tremor, each a new hand; the error over each
  // take's second second. With the warm-ups in a row (joints, then oscillator, then fit)
  // and the prominence's fixed sides, 0.69 of it was left there.
  for (const double rate : {90.0, 30.0}) {
    double before = 0.0, after = 0.0;
    for (uint64_t seed = 1; seed <= 10; ++seed) {
      const hs::HandSeries truth = moving_hand(2.0, rate, false, 100 + seed);
      const hs::HandSeries noisy = with_tremor(truth, 4.0, 6.0, 0.004, seed);
      before += mean_error_mm(noisy, truth, 1.0, 2.0);
      after += mean_error_mm(cancelled(noisy), truth, 1.0, 2.0);
    }
    MESSAGE("4-6 Hz, 4 mm at " << rate << " Hz, from 1 to 2 s after the start: " << before / 10 << " -> " << after / 10
                                << " mm");
    CHECK(after < 0.45 * before);
  }
}

TEST_CASE("Tremor canceller: voluntary strokes at tremor frequencies are not tremor") {
  // 1 cm strokes at 3-6 Hz, each lasting two cycles in its own direction (in-air writing
  // is like this): predictable from cycle to cycle, but no lasting peak. Without the
  // prominence gate the canceller took 4.1 mm of them away.
  const hs::HandSeries truth = moving_hand(20.0, 90.0);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> fr(3.0, 6.0), comp(-1.0, 1.0);
  hs::HandSeries writing = truth;
  double phase = 0.0, until = 0.0, hz = 4.0;
  Eigen::Vector3d dir = Eigen::Vector3d::UnitX();
  for (size_t i = 0; i < writing.size(); ++i) {
    const double t = writing.t[i];
    if (t >= until) {  // the next stroke
      hz = fr(rng);
      dir = Eigen::Vector3d(comp(rng), comp(rng), comp(rng)).normalized();
      until = t + 2.0 / hz;
    }
    if (i > 0) phase += 2.0 * std::numbers::pi * hz * (t - writing.t[i - 1]);
    for (int j = 0; j < hs::kJointCount; ++j) writing.pos[i].row(j) += 0.01 * std::sin(phase) * dir.transpose();
  }
  const double moved = mean_error_mm(cancelled(writing), writing, 2.0);
  MESSAGE("strokes moved by " << moved << " mm");
  CHECK(moved < 0.3);
}

TEST_CASE("Tremor canceller: deliberate rhythmic motion of centimetres is not tremor") {
  // A wave of the whole hand and a wagging index finger at tremor frequencies are narrow,
  // lasting peaks that the fit predicts: only their size tells them from tremor.
  const hs::HandSeries truth = moving_hand(10.0, 90.0);
  const hs::HandSeries wave = oscillated(truth, 0.04, 4.0);
  const double wave_moved = mean_error_mm(cancelled(wave), wave, 2.0);
  hs::HandSeries wag = truth;
  const int tip = static_cast<int>(hs::Joint::IndexTip);
  for (size_t i = 0; i < wag.size(); ++i)  // the finger's joints swing more the further out they are
    for (int j = tip - 3; j <= tip; ++j)
      wag.pos[i](j, 1) += 0.01 * (j - tip + 4) * std::sin(2.0 * std::numbers::pi * 4.5 * wag.t[i]);
  const double wag_moved = mean_error_mm(cancelled(wag), wag, 2.0);
  // The same oscillations as tremor of 12 mm are still taken out.
  const hs::HandSeries shake = oscillated(truth, 0.012, 4.0);
  const double shake_left = mean_error_mm(cancelled(shake), truth, 5.0), shake_was = mean_error_mm(shake, truth, 5.0);
  MESSAGE("40 mm wave moved by " << wave_moved << " mm, 40 mm finger wag by " << wag_moved << " mm; 12 mm tremor "
          << shake_was << " -> " << shake_left << " mm");
  CHECK(wave_moved < 0.3);
  CHECK(wag_moved < 0.3);
  CHECK(shake_left < 0.2 * shake_was);
}

TEST_CASE("Tremor canceller: recorded in-air handwriting is not tremor") {
  // Every FMKit handwriting recording (Leap Motion, ~115 Hz; repeated words, strokes at
  // 3-6 Hz of centimetres): before the amplitude gate the canceller moved one of them by
  // 2.1 mm on average, and the benchmark's Leap handwriting cells got up to 2.8 x worse.
  HS_SKIP_WITHOUT_SHARED_DATA();
  const auto dir = hs::test::shared_data() / "leap" / "fmkit_handwriting";
  REQUIRE(std::filesystem::is_directory(dir));
  int hands = 0;
  double worst = 0.0;
  std::string worst_file;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() != ".csv") continue;
    const hs::Track track = hs::read_track_csv(e.path());
    for (const hs::Hand h : {hs::Hand::Left, hs::Hand::Right}) {
      const hs::HandSeries s = hs::hand_series(track, h);
      if (s.size() < 100) continue;
      ++hands;
      if (const double moved = mean_error_mm(cancelled(s), s, 0.0); moved > worst) worst = moved, worst_file = e.path().filename().string();
    }
  }
  MESSAGE(hands << " recorded hands, moved by at most " << worst << " mm (" << worst_file << ")");
  CHECK(hands >= 20);
  CHECK(worst < 0.1);
}

TEST_CASE("Tremor canceller: a clean moving hand, white jitter and a still hand are left alone") {
  const hs::HandSeries truth = moving_hand(20.0, 90.0);
  CHECK(mean_error_mm(cancelled(truth), truth, 0.0) < 0.05);
  // White jitter: nothing periodic, so (almost) nothing subtracted.
  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0.0, 0.0015);
  hs::HandSeries noisy = truth;
  for (Pose& p : noisy.pos) p = hs::test::jittered(p, rng, noise);
  const double before = mean_error_mm(noisy, truth, 2.0), after = mean_error_mm(cancelled(noisy), truth, 2.0);
  MESSAGE("1.5 mm white jitter: " << before << " -> " << after << " mm");
  CHECK(after < 1.02 * before);
  // A still hand stays exactly still.
  hs::HandSeries still = truth;
  for (Pose& p : still.pos) p = truth.pos.front();
  const hs::HandSeries out = cancelled(still);
  double worst = 0.0;
  for (size_t i = 0; i < out.size(); ++i) worst = std::max(worst, (out.pos[i] - still.pos[i]).cwiseAbs().maxCoeff());
  CHECK(worst < 1e-9);
}

TEST_CASE("Tremor canceller: a tracker that drops joints now and then") {
  // Each joint lost in 5 % of rows (a few rows at most): the joints' filters wait over the
  // gaps. While a drop restarted its joint's filter, hardly any joint stayed the 0.6 s it
  // needs to count, and nothing was cancelled (2.69 -> 2.69 mm).
  const hs::HandSeries truth = moving_hand(20.0, 90.0, true);
  hs::HandSeries noisy = with_tremor(truth, 4, 6, 0.004, 7);
  std::mt19937_64 rng(5);
  std::bernoulli_distribution drop(0.05);
  for (Pose& p : noisy.pos)
    for (int j = 0; j < hs::kJointCount; ++j)
      if (drop(rng)) p.row(j).setConstant(NAN);
  const hs::HandSeries out = cancelled(noisy);
  const double before = mean_error_mm(noisy, truth, 5.0), after = mean_error_mm(out, truth, 5.0);
  MESSAGE("4-6 Hz, 4 mm at 90 Hz, 5 % of joints dropped: " << before << " -> " << after << " mm");
  CHECK(after < 0.6 * before);
}

TEST_CASE("Tremor canceller: missing joints stay missing, a repeated time is refused, reset forgets, no allocation") {
  const hs::HandSeries truth = moving_hand(6.0, 90.0);
  hs::HandSeries noisy = with_tremor(truth, 4, 6, 0.004, 3);
  for (size_t i = 0; i < noisy.size(); i += 7) noisy.pos[i].row(hs::idx(hs::Joint::IndexTip)).setConstant(NAN);
  TremorCancel tc;
  hs::test::g_allocations = 0;
  hs::test::g_counting = true;
  bool kept = true;
  for (size_t i = 0; i < noisy.size(); ++i) {
    Pose row = noisy.pos[i];
    tc.apply(noisy.t[i], row);
    kept = kept && row.array().isNaN().count() == noisy.pos[i].array().isNaN().count();
  }
  hs::test::g_counting = false;
  CHECK(kept);
  CHECK(hs::test::g_allocations.load() == 0);
  CHECK(tc.frequency_hz() > 3.0);
  Pose row = noisy.pos.back();
  tc.apply(noisy.t.back(), row);
  CHECK(row == noisy.pos.back());
  tc.reset();
  CHECK(tc.frequency_hz() == 0.0);
}

TEST_CASE("Tremor canceller: through make_filter only when asked") {
  const hs::HandSeries truth = moving_hand(12.0, 90.0);
  const hs::HandSeries noisy = with_tremor(truth, 4, 6, 0.004, 5);
  hs::FilterConfig c;
  c.method = hs::FilterMethod::Raw;
  const auto plain = hs::make_filter(c);
  CHECK(mean_error_mm(hs::filter_series(*plain, noisy, 0.0), noisy, 0.0) < 1e-9);
  CHECK(hs::filter_params_summary(c).find("tremor_cancel") == std::string::npos);
  c.tremor_cancel = true;
  CHECK(hs::filter_params_summary(c).find("tremor_cancel=1") != std::string::npos);
  const auto f = hs::make_filter(c);
  const double before = mean_error_mm(noisy, truth, 5.0);
  const double after = mean_error_mm(hs::filter_series(*f, noisy, 0.0), truth, 5.0);
  MESSAGE("raw with the canceller: " << before << " -> " << after << " mm");
  CHECK(after < 0.7 * before);
  c.stgae.offline = true;
  c.method = hs::FilterMethod::Stgae;
  CHECK_THROWS_AS(hs::filter_series_with(c, noisy, 0.0), std::invalid_argument);
}
