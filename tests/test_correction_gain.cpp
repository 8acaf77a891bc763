// The correction gain (correction_gain.hpp): a correction that removes noise is kept, one
// that adds its own error is taken back to the input, outliers taken back stay whole; and
// through the adapter, the shipped model on a noise it was not trained on (8-12 Hz tremor at
// 90 Hz) loses most of what it made worse than raw, and the default (auto) is the gain at
// K >= 2 streams and none at one.
#include "handsteady/correction_gain.hpp"
#include "handsteady/corrupt.hpp"
#include "handsteady/import.hpp"
#include "handsteady/metrics.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/synth.hpp"
#include "handsteady/time_series.hpp"
#include "handsteady/track.hpp"
#include "test_support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>

namespace {
using hs::CorrectionGain;
using hs::kJointCount;
constexpr size_t kFs = 3 * kJointCount;
constexpr double kRate = 90.0;

hs::HandSeries moving_hand(double seconds, double rate = kRate) { return hs::test::moving_hand(seconds, rate, 7); }


// 8-12 Hz tremor of `hand_m` (the hand) and half that (the fingers) on `truth`: at 1.5 mm
// a noise the shipped model over-corrects.
hs::HandSeries tremor_8_12(const hs::HandSeries& truth, double hand_m = 0.0015) {
  hs::CorruptionConfig cfg;
  cfg.kind = hs::CorruptionKind::Tremor;
  cfg.tremor.freq_min_hz = 8.0;
  cfg.tremor.freq_max_hz = 12.0;
  cfg.tremor.hand_amplitude_m = hand_m;
  cfg.tremor.finger_amplitude_m = hand_m / 2.0;
  return hs::corrupt_series(truth, cfg, 4);
}

// The Leap tuning subject's first takes (fast free-air motion the network reshapes; not a
// benchmark test set), right hand, concatenated as the benchmark does, at `rate`.
hs::HandSeries leap_tuning_series(double rate) {
  const auto files = hs::test::leap_tuning_takes();
  REQUIRE(files.size() >= 10);
  std::vector<hs::Track> takes;
  std::vector<std::string> names;
  for (const auto& f : files) {
    takes.push_back(hs::read_track_csv(f));
    names.push_back(f.filename().string());
  }
  return hs::resample_series(hs::hand_series(hs::concatenate_takes(takes, names), hs::Hand::Right), rate);
}

std::vector<float> frame_of(const hs::Pose& p) {
  std::vector<float> f(kFs);
  for (int j = 0; j < kJointCount; ++j)
    for (int c = 0; c < 3; ++c) f[static_cast<size_t>(3 * j + c)] = static_cast<float>(p(j, c));
  return f;
}

// Feeds rows (truth + noise from `noisy(i, truth)`) with answers made by
// `denoise(i, truth, input)`, and the measured noise `noise2` (empty: none); returns the mean
// joint error (mm) of input, answer and answer + shift over the rows after `skip`.
struct Errors {
  double input = 0.0, answer = 0.0, gained = 0.0;
};
template <class Noisy, class Denoise>
Errors feed(CorrectionGain& g, const hs::HandSeries& truth, Noisy noisy, Denoise denoise,
            std::span<const double> noise2 = {}, size_t skip = 200, std::span<const double> white2 = {}) {
  Errors e;
  size_t n = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const hs::Pose x = noisy(i, truth.pos[i]);
    const hs::Pose a = denoise(i, truth.pos[i], x);
    const auto xf = frame_of(x);
    g.observe(truth.t[i], xf, std::span<const double>(a.data(), kFs), noise2, white2);
    if (i < skip) continue;
    for (int j = 0; j < kJointCount; ++j) {
      const Eigen::Vector3d shift(g.shift(j, 0), g.shift(j, 1), g.shift(j, 2));
      const Eigen::Vector3d tj = truth.pos[i].row(j).transpose();
      e.input += 1e3 * (Eigen::Vector3d(xf[3 * j], xf[3 * j + 1], xf[3 * j + 2]) - tj).norm();
      e.answer += 1e3 * (a.row(j).transpose() - tj).norm();
      e.gained += 1e3 * (a.row(j).transpose() + shift - tj).norm();
      ++n;
    }
  }
  e.input /= static_cast<double>(n);
  e.answer /= static_cast<double>(n);
  e.gained /= static_cast<double>(n);
  return e;
}

// The same with white noise of sd on every coordinate.
template <class Denoise>
Errors run(CorrectionGain& g, const hs::HandSeries& truth, double sd, Denoise denoise, size_t skip = 200) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, sd);
  return feed(g, truth, [&](size_t, const hs::Pose& t) { return hs::test::jittered(t, rng, noise); }, denoise, {}, skip);
}
}  // namespace

TEST_CASE("correction gain: a correction that removes the noise is kept") {
  CorrectionGain g;
  const auto truth = moving_hand(8.0);
  const Errors e = run(g, truth, 0.0015, [](size_t, const hs::Pose& t, const hs::Pose&) { return t; });
  INFO("gains " << g.gain_fast() << " / " << g.gain_low() << "; errors " << e.input << " " << e.answer << " " << e.gained);
  CHECK(g.gain_fast() > 0.85);
  CHECK(e.gained < 0.25 * e.input);
}

TEST_CASE("correction gain: a correction that adds its own error is taken back to the input") {
  CorrectionGain g;
  const auto truth = moving_hand(8.0);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> wrong(0.0, 0.0015);
  const Errors e = run(g, truth, 0.0015, [&](size_t, const hs::Pose&, const hs::Pose& x) {
    return hs::test::jittered(x, rng, wrong);
  });
  INFO("gains " << g.gain_fast() << " / " << g.gain_low() << "; errors " << e.input << " " << e.answer << " " << e.gained);
  CHECK(g.gain_fast() < 0.15);
  CHECK(e.answer > 1.3 * e.input);
  CHECK(e.gained < 1.08 * e.input);
}

TEST_CASE("correction gain: correlated jitter's removal is kept where the measured noise explains it") {
  // 80 ms AR(1) jitter of 1.5 mm per axis: the next three rows (33 ms at 90 Hz) carry most
  // of it, so the check takes it for motion and the gain gives its removal back. With the
  // input's noise measured per joint (what InputNoise's rigidity reading sees), the share
  // of each band of the correction it explains stays: here all of it, as neither band of an
  // exact correction is larger than the noise. A denoiser that adds an error of its own 3
  // times the noise is still taken back to near the input.
  const auto truth = moving_hand(8.0);
  constexpr double kSd = 0.0015;
  const std::vector<double> noise2(kJointCount, 3.0 * kSd * kSd);
  // The project's correlated jitter (the benchmark's `correlated` family), the same for each run.
  hs::CorruptionConfig jitter;
  jitter.tracker.jitter_sd_m = kSd;
  jitter.tracker.jitter_ar1 = std::exp(-1.0 / (kRate * 0.08));
  const hs::HandSeries noisy_series = hs::corrupt_series(truth, jitter, 13);
  const auto correlated = [&](size_t i, const hs::Pose&) { return noisy_series.pos[i]; };
  const auto exact = [](size_t, const hs::Pose& t, const hs::Pose&) { return t; };
  std::mt19937_64 rng(5);
  std::normal_distribution<double> own(0.0, 3.0 * kSd);
  const auto adds_own = [&](size_t, const hs::Pose&, const hs::Pose& x) { return hs::test::jittered(x, rng, own); };
  CorrectionGain plain, measured, wrong;
  const Errors ep = feed(plain, truth, correlated, exact);
  const Errors em = feed(measured, truth, correlated, exact, noise2);
  const Errors ew = feed(wrong, truth, correlated, adds_own, noise2);
  INFO("errors (input answer gained): unmeasured " << ep.input << " " << ep.answer << " " << ep.gained << "; measured "
                                                   << em.gained << "; own error " << ew.input << " " << ew.answer << " "
                                                   << ew.gained << "; gains " << plain.gain_fast() << " / "
                                                   << plain.gain_low());
  CHECK(ep.gained > 0.5 * ep.input);  // the check alone gives most of the removal back
  // The measured noise keeps the removal whole.
  CHECK(em.gained < 0.1 * em.input);
  // Of a wrong correction each band keeps at most the share the noise could explain (its
  // mean square then at most E|n|^2): here the low band's 0.6 (white error is mostly fast),
  // the fast part's 0.14; 3.50 mm against 7.59 for the answer, the input 2.42.
  CHECK(ew.answer > 2.0 * ew.input);
  CHECK(ew.gained < 1.6 * ew.input);
  CHECK(ew.gained < 0.5 * ew.answer);
}

TEST_CASE("correction gain: a rough correction no larger than the network's own roughness gets no floor from the measured noise") {
  // Nearly clean input (0.1 mm white noise per axis, measured): a denoiser whose correction
  // is a white error of its own of that size (its fast part under kGainOwnRoughnessM) was
  // kept whole by the floor (the measured noise explains all of a correction no larger than
  // it); now the check alone judges that fast part and takes it back (the low band, a
  // small share of white error, keeps its floor). An exact denoiser of the same noise is
  // still kept: the check sees white noise removed.
  const auto truth = moving_hand(8.0);
  constexpr double kSd = 0.0001;
  const std::vector<double> noise2(kJointCount, 3.0 * kSd * kSd);
  std::normal_distribution<double> noise(0.0, kSd), own(0.0, kSd);
  // The measured noise on `t`, and a denoiser that adds its own white error (the same seeds each call).
  const auto adds_own = [&](CorrectionGain& g, const hs::HandSeries& t) {
    std::mt19937_64 noise_rng(11), own_rng(5);
    return feed(g, t, [&](size_t, const hs::Pose& p) { return hs::test::jittered(p, noise_rng, noise); },
                [&](size_t, const hs::Pose&, const hs::Pose& x) { return hs::test::jittered(x, own_rng, own); }, noise2);
  };
  CorrectionGain wrong, exact;
  const Errors ew = adds_own(wrong, truth);
  std::mt19937_64 noise_rng(12);
  const Errors ee = feed(exact, truth, [&](size_t, const hs::Pose& t) { return hs::test::jittered(t, noise_rng, noise); },
                         [](size_t, const hs::Pose& t, const hs::Pose&) { return t; }, noise2);
  INFO("own error (input answer gained) " << ew.input << " " << ew.answer << " " << ew.gained << "; exact " << ee.input
                                          << " " << ee.answer << " " << ee.gained << "; gains " << wrong.gain_fast() << " / "
                                          << wrong.gain_low());
  CHECK(ew.answer > 1.3 * ew.input);
  CHECK(ew.gained - ew.input < 0.3 * (ew.answer - ew.input));  // 0.174 mm, input 0.159, answer 0.225
  CHECK(ee.gained < 0.3 * ee.input);
  // Rows further apart than the low band's time constant (one stream at 23.5 Hz): a row's
  // fast part carries a slow tremor's removal there too, and the floor keeps it as before.
  CorrectionGain slow;
  const Errors es = adds_own(slow, moving_hand(20.0, 23.5));
  INFO("at 23.5 Hz (input answer gained) " << es.input << " " << es.answer << " " << es.gained);
  CHECK(es.gained > 0.95 * es.answer);
}

TEST_CASE("correction gain: a slow error of the denoiser's own is not kept as white noise's removal") {
  // 0.5 mm white noise per axis, measured, and a denoiser that takes it out exactly but puts
  // each joint 0.4 mm off (a fixed offset: the network's own placement of a joint). Counted
  // whole, the measured noise explained all of the correction's low band, offset included
  // (its mean square, 0.18 of the noise's through the band plus the offset's, is under the
  // noise's). Counted as white (the smoothness measure saw it all), the noise explains only
  // the share its removal keeps through the band, and the gains take the offset back. Slow
  // noise (measured by the bones alone, no white part) still explains it all.
  const auto truth = moving_hand(8.0);
  constexpr double kSd = 0.0005;
  const std::vector<double> noise2(kJointCount, 3.0 * kSd * kSd);
  std::mt19937_64 dir_rng(3);
  std::normal_distribution<double> unit(0.0, 1.0);
  hs::Pose offset(kJointCount, 3);
  for (int j = 0; j < kJointCount; ++j) {
    const Eigen::Vector3d d(unit(dir_rng), unit(dir_rng), unit(dir_rng));
    offset.row(j) = 0.0004 * d.normalized().transpose();
  }
  const auto offset_exact = [&](size_t, const hs::Pose& t, const hs::Pose&) { return hs::Pose(t + offset); };
  const auto run_with = [&](CorrectionGain& g, std::span<const double> white2) {
    std::mt19937_64 rng(11);
    std::normal_distribution<double> noise(0.0, kSd);
    return feed(g, truth, [&](size_t, const hs::Pose& t) { return hs::test::jittered(t, rng, noise); }, offset_exact,
                noise2, 200, white2);
  };
  CorrectionGain whole, white, slow;
  const Errors ew = run_with(whole, {});
  const Errors et = run_with(white, noise2);
  const std::vector<double> none(kJointCount, 0.0);
  const Errors es = run_with(slow, none);
  INFO("errors (input answer gained): counted whole " << ew.input << " " << ew.answer << " " << ew.gained << "; white "
                                                      << et.gained << "; slow " << es.gained << "; gains "
                                                      << white.gain_fast() << " / " << white.gain_low());
  CHECK(ew.gained > 0.9 * ew.answer);  // the offset kept
  CHECK(es.gained == doctest::Approx(ew.gained).epsilon(1e-9));
  CHECK(et.gained < 0.8 * ew.gained);  // 0.30 mm against 0.40 (the input 0.80)
}

TEST_CASE("correction gain: an outlier taken back stays whole, nothing changes before the rows show the gain") {
  CorrectionGain g;
  const auto truth = moving_hand(6.0);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> wrong(0.0, 0.001);
  constexpr int kJoint = 9;
  double worst_outlier_mm = 0.0;
  int outliers = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    hs::Pose x = truth.pos[i];
    hs::Pose a = hs::test::jittered(x, rng, wrong);  // the denoiser's own error
    const bool outlier = i > 100 && i % 37 == 0;
    if (outlier) {
      x(kJoint, 0) += 0.03;          // a 30 mm jump...
      a.row(kJoint) = truth.pos[i].row(kJoint);  // ...that the denoiser takes back
    }
    g.observe(truth.t[i], frame_of(x), std::span<const double>(a.data(), kFs));
    if (static_cast<double>(i) + 4.0 < hs::kGainMinRows) {
      for (int j = 0; j < kJointCount; ++j)
        for (int c = 0; c < 3; ++c) REQUIRE(g.shift(j, c) == 0.0);
    }
    if (outlier) {
      ++outliers;
      const Eigen::Vector3d out = a.row(kJoint).transpose() +
                                  Eigen::Vector3d(g.shift(kJoint, 0), g.shift(kJoint, 1), g.shift(kJoint, 2));
      worst_outlier_mm = std::max(worst_outlier_mm, 1e3 * (out - truth.pos[i].row(kJoint).transpose()).norm());
    }
  }
  INFO("gains " << g.gain_fast() << " / " << g.gain_low());
  CHECK(g.gain_fast() < 0.3);  // the everyday correction is not trusted...
  CHECK(outliers > 5);
  CHECK(worst_outlier_mm < 3.0);  // ...but the outlier's is kept (the input was 30 mm off)
}

TEST_CASE("correction gain: missing joints are not shifted, restart keeps the gains, reset forgets them") {
  CorrectionGain g;
  const auto truth = moving_hand(3.0);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> wrong(0.0, 0.002);
  for (size_t i = 0; i < truth.size(); ++i) {
    const hs::Pose a = hs::test::jittered(truth.pos[i], rng, wrong);
    auto x = frame_of(truth.pos[i]);
    if (i + 1 == truth.size()) x[3 * 4] = std::numeric_limits<float>::quiet_NaN();  // joint 4 lost
    g.observe(truth.t[i], x, std::span<const double>(a.data(), kFs));
  }
  const double gf = g.gain_fast();
  CHECK(gf < 0.2);
  CHECK(std::abs(g.shift(5, 0)) > 0.0);
  for (int c = 0; c < 3; ++c) CHECK(g.shift(4, c) == 0.0);
  g.restart();
  CHECK(g.gain_fast() == gf);
  for (int c = 0; c < 3; ++c) CHECK(g.shift(5, c) == 0.0);
  g.reset();
  CHECK(g.gain_fast() == 1.0);
  CHECK(g.gain_low() == 1.0);
}

TEST_CASE("correction gain through the adapter: the shipped model on 8-12 Hz tremor at 90 Hz, most of its harm taken back") {
  const auto model = hs::test::shipped_model();
  const auto truth = moving_hand(20.0);
  const auto noisy = tremor_8_12(truth);
  auto bounded = hs::make_stgae_filter(model, 0.0, 0, true, false);
  auto gained = hs::make_stgae_filter(model, 0.0, 0, true, true);
  auto unbounded_gain = hs::make_stgae_filter(model, 0.0, 0, false, true);  // the gain needs the trust region
  const double raw = hs::mpjpe_mm(truth.pos, noisy.pos);
  const double with_gain = hs::mpjpe_mm(truth.pos, hs::filter_series(*gained, noisy, 0.0).pos);
  const double without = hs::mpjpe_mm(truth.pos, hs::filter_series(*bounded, noisy, 0.0).pos);
  const double alone = hs::mpjpe_mm(truth.pos, hs::filter_series(*unbounded_gain, noisy, 0.0).pos);
  INFO("raw " << raw << " mm, with the gain " << with_gain << " mm, without " << without << " mm, the network alone "
              << alone << " mm");
  CHECK(alone > 1.1 * raw);  // the case this guards: the network makes this noise worse
  // The trust region alone now takes back most of what the network adds over raw (since the
  // older stream's prediction no longer enters where the streams disagree beyond the noise,
  // and its one-period prediction is blended with the denoised velocity: 0.99 mm, the
  // network alone 1.51, raw 0.98 with the shipped model; before, above 1.1 x raw), and the
  // gain, which took back more than half of it before, no longer adds to that (0.99 mm
  // with it): it must not undo it.
  CHECK(without - raw < 0.2 * (alone - raw));
  CHECK(with_gain - raw < 0.1 * (alone - raw));
}

TEST_CASE("correction gain through the adapter: on 0.5 mm tremor at 90 Hz the network's own roughness is not kept as noise removed") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  // Low tremor (0.5 mm, 8-12 Hz) on the Leap tuning takes at 90 Hz, three streams, the gain
  // auto: the network removes little of it and adds roughness of its own; the measured
  // noise, of that roughness's size, kept it whole (the floor) until a fast part under
  // kGainOwnRoughnessM got none. Raw 0.332 mm, the adapter 0.390 before, 0.373 since
  // (2026-12-06).
  const auto model = hs::test::shipped_model();
  const auto truth = leap_tuning_series(90.0);
  const auto noisy = tremor_8_12(truth, 0.0005);
  auto f = hs::make_stgae_filter(model, 0.0, 0, true, std::nullopt);
  const double raw = hs::mpjpe_mm(truth.pos, noisy.pos);
  const double out = hs::mpjpe_mm(truth.pos, hs::filter_series(*f, noisy, 0.0).pos);
  MESSAGE("90 Hz: raw " << raw << " mm, the adapter " << out << " mm");
  CHECK(out < 1.15 * raw);
}

TEST_CASE("correction gain through the adapter: auto is the gain where the noise is measured (K >= 2), none at one stream at the model's rate") {
  // The shipped model on 8-12 Hz tremor (which it over-corrects, so the gain acts): auto
  // must answer exactly as `on` at 90 Hz (three streams) and exactly as `off` at 30 Hz (one
  // stream), and `on` and `off` differ at both rates, so the comparison can fail. The streams
  // are fixed (with them found from the input rate, auto starts its gain once the rate is
  // known, after the first rows, and `on` already in them).
  const auto model = hs::test::shipped_model();
  for (const double rate : {90.0, 30.0}) {
    const auto truth = moving_hand(6.0, rate);
    const auto noisy = tremor_8_12(truth);
    auto run = [&](std::optional<bool> gain) {
      auto f = hs::make_stgae_filter(model, 0.0, static_cast<int>(rate / 30.0), true, gain);
      return hs::filter_series(*f, noisy, 0.0).pos;
    };
    const auto automatic = run(std::nullopt), on = run(true), off = run(false);
    double auto_on = 0.0, auto_off = 0.0, on_off = 0.0;
    for (size_t i = 0; i < automatic.size(); ++i) {
      auto_on = std::max(auto_on, (automatic[i] - on[i]).cwiseAbs().maxCoeff());
      auto_off = std::max(auto_off, (automatic[i] - off[i]).cwiseAbs().maxCoeff());
      on_off = std::max(on_off, (on[i] - off[i]).cwiseAbs().maxCoeff());
    }
    INFO(rate << " Hz: largest difference auto-on " << auto_on << ", auto-off " << auto_off << ", on-off " << on_off << " m");
    CHECK(on_off > 1e-5);  // the gain acts at both rates when on
    if (rate > 60.0) CHECK(auto_on == 0.0);
    else CHECK(auto_off == 0.0);
  }
}

TEST_CASE("correction gain through the adapter: one stream on rows slower than the model measures the noise, and auto gains there") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  // At 23.5 Hz under the 30 Hz model (HoloLens 2's rate) one stream's rows are slower than
  // its frames and InputNoise measures the noise on them (the adapter's slow rows): auto
  // gains there, with that noise as the floor. The Leap tuning subject's first takes (fast
  // free-air motion the network reshapes; not a benchmark test set), concatenated as the
  // benchmark does, at 23.5 Hz with 0.5 mm of 8-12 Hz tremor: off 0.66 mm, auto 0.58, raw
  // 0.33 (0.60 before a fast part under kGainOwnRoughnessM got no floor; the network's own
  // floor is above this noise, the gain takes part back).
  const auto model = hs::test::shipped_model();
  const auto truth = leap_tuning_series(23.5);
  const auto noisy = tremor_8_12(truth, 0.0005);
  auto run = [&](std::optional<bool> gain) {
    auto f = hs::make_stgae_filter(model, 0.0, 0, true, gain);
    return hs::mpjpe_mm(truth.pos, hs::filter_series(*f, noisy, 0.0).pos);
  };
  const double automatic = run(std::nullopt), off = run(false);
  MESSAGE("23.5 Hz: raw " << hs::mpjpe_mm(truth.pos, noisy.pos) << " mm, auto " << automatic
                       << " mm, off " << off << " mm");
  CHECK(automatic < 0.95 * off);
}
