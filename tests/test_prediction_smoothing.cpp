// The prediction smoother (prediction_smoothing.hpp): a steady displacement passes
// unchanged, a noisy one is smoothed, a turn is followed within a few frames, the denoised
// frame is never touched, a missing joint starts afresh; and through the adapter, the
// shipped model's predictions on a noisy moving hand lose most of their own jitter.
#include "handsteady/corrupt.hpp"
#include "handsteady/metrics.hpp"
#include "handsteady/prediction_smoothing.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/synth.hpp"
#include "test_support.hpp"

#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <vector>

namespace {
using hs::kJointCount;
using hs::PredictionSmoother;
constexpr size_t kFs = 3 * kJointCount;
constexpr double kDt = 1.0 / 90.0;
constexpr int kFrames = 3;  // denoised + 2 predicted

// A path whose denoised frame is `base` (every joint at the same point, moved along x by
// t) and whose predicted frame f is base + f * disp (+ noise).
std::vector<float> make_path(double t, const std::array<double, 3>& disp, double noise_sd = 0.0,
                             std::mt19937_64* rng = nullptr) {
  std::normal_distribution<double> noise(0.0, noise_sd);
  std::vector<float> path(kFrames * kFs);
  for (size_t j = 0; j < kJointCount; ++j)
    for (size_t c = 0; c < 3; ++c) {
      const double base = (c == 0 ? 0.3 * t : 0.1) + 0.01 * static_cast<double>(j);
      path[3 * j + c] = static_cast<float>(base);
      for (size_t f = 1; f < kFrames; ++f)
        path[f * kFs + 3 * j + c] =
            static_cast<float>(base + static_cast<double>(f) * disp[c] + (rng ? noise(*rng) : 0.0));
    }
  return path;
}

// Frame f's displacement of joint j, coordinate c.
double disp_of(const std::vector<float>& path, size_t f, size_t j, size_t c) {
  return static_cast<double>(path[f * kFs + 3 * j + c]) - static_cast<double>(path[3 * j + c]);
}

}  // namespace

TEST_CASE("prediction smoothing: a steady displacement passes unchanged, the denoised frame is never touched") {
  PredictionSmoother s(kFrames);
  CHECK(s.frames() == kFrames);
  for (int i = 0; i < 50; ++i) {
    const double t = i * kDt;
    auto path = make_path(t, {0.01, -0.002, 0.0});
    const auto in = path;
    s.apply(t, path);
    for (size_t k = 0; k < path.size(); ++k) CHECK(path[k] == doctest::Approx(in[k]).epsilon(1e-6));
    for (size_t k = 0; k < kFs; ++k) CHECK(path[k] == in[k]);  // bit for bit
  }
}

TEST_CASE("prediction smoothing: noise on the displacement is reduced") {
  PredictionSmoother s(kFrames);
  std::mt19937_64 rng(3);
  const std::array<double, 3> disp{0.01, 0.0, 0.005};
  double in2 = 0.0, out2 = 0.0;
  for (int i = 0; i < 400; ++i) {
    const double t = i * kDt;
    auto path = make_path(t, disp, 0.0005, &rng);  // the size of the shipped model's frame-to-frame noise
    const auto in = path;
    s.apply(t, path);
    for (size_t k = 0; k < kFs; ++k) REQUIRE(path[k] == in[k]);
    if (i < 100) continue;
    for (size_t j = 0; j < kJointCount; ++j)
      for (size_t c = 0; c < 3; ++c) {
        in2 += std::pow(disp_of(in, 2, j, c) - 2.0 * disp[c], 2);
        out2 += std::pow(disp_of(path, 2, j, c) - 2.0 * disp[c], 2);
      }
  }
  INFO("rms error of the displacement: input " << std::sqrt(in2) << ", smoothed " << std::sqrt(out2));
  // Its rms error under half the input's (a larger noise raises the cutoff: it looks like a turn).
  CHECK(out2 < 0.5 * 0.5 * in2);
}

TEST_CASE("prediction smoothing: a turn is followed within a few frames, not at the slow cutoff") {
  PredictionSmoother s(kFrames);
  for (int i = 0; i < 60; ++i) {
    auto path = make_path(i * kDt, {0.02, 0.0, 0.0});
    s.apply(i * kDt, path);
  }
  // The hand reverses: each displacement flips sign at once.
  double after3 = 0.0;
  for (int i = 60; i < 63; ++i) {
    auto path = make_path(i * kDt, {-0.02, 0.0, 0.0});
    s.apply(i * kDt, path);
    after3 = disp_of(path, 1, 5, 0);
  }
  // A plain low-pass at kPredictionMinCutoffHz would still be near +0.02 m (alpha ~0.1 a frame).
  INFO("frame 1's displacement 3 frames after the turn: " << after3 << " m (target -0.02)");
  CHECK(after3 < -0.016);  // 90 % of the reversal (a plain low-pass: under 30 %)
}

TEST_CASE("prediction smoothing: a missing joint stays missing and starts afresh, reset forgets") {
  PredictionSmoother s(kFrames);
  for (int i = 0; i < 20; ++i) {
    auto path = make_path(i * kDt, {0.01, 0.0, 0.0});
    s.apply(i * kDt, path);
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  auto gap = make_path(20 * kDt, {0.01, 0.0, 0.0});
  for (size_t c = 0; c < 3; ++c) gap[kFs + 3 * 4 + c] = nan;  // joint 4 missing in predicted frame 1
  s.apply(20 * kDt, gap);
  CHECK(std::isnan(gap[kFs + 3 * 4]));
  CHECK(disp_of(gap, 1, 3, 0) == doctest::Approx(0.01).epsilon(1e-4));
  // Back with another displacement: taken as it is (no stale state), the others smoothed.
  auto back = make_path(21 * kDt, {0.03, 0.0, 0.0});
  const auto in = back;
  s.apply(21 * kDt, back);
  CHECK(disp_of(back, 1, 4, 0) == doctest::Approx(disp_of(in, 1, 4, 0)).epsilon(1e-5));
  CHECK(disp_of(back, 1, 3, 0) < disp_of(in, 1, 3, 0) - 1e-3);
  // reset(): the next path is taken as it is.
  s.reset();
  auto fresh = make_path(22 * kDt, {-0.05, 0.0, 0.0});
  const auto fin = fresh;
  s.apply(22 * kDt, fresh);
  for (size_t k = 0; k < fresh.size(); ++k) CHECK(fresh[k] == fin[k]);
  // A denoise-only path (one frame) is left alone.
  PredictionSmoother one(1);
  std::vector<float> den(kFs, 0.5f);
  one.apply(0.0, den);
  for (const float v : den) CHECK(v == 0.5f);
}

TEST_CASE("prediction smoothing through the adapter: the shipped model's predictions on a noisy moving hand") {
  const auto model = hs::test::shipped_model();
  hs::SynthMotionParams p;
  p.duration_s = 12.0;
  p.rate_hz = 90.0;
  const auto truth = hs::synth_motion(p, hs::Hand::Right, 7);
  hs::CorruptionConfig cfg;  // white jitter only
  cfg.kind = hs::CorruptionKind::Tracker;
  cfg.tracker.jitter_sd_m = 0.0015;
  const auto noisy = hs::corrupt_series(truth, cfg, 5);
  constexpr int kAhead = 4;  // rows: the prediction at t_i + 4/90 s is scored against row i + 4
  const double horizon = kAhead / p.rate_hz;
  auto smoothed = hs::make_stgae_filter(model, 0.0, 0, true, std::nullopt, true);
  auto rough = hs::make_stgae_filter(model, 0.0);
  const auto a = hs::filter_series(*smoothed, noisy, horizon);
  const auto b = hs::filter_series(*rough, noisy, horizon);
  const size_t n = truth.size() - kAhead;
  const std::span<const hs::Pose> future(truth.pos.data() + kAhead, n);
  const std::span<const hs::Pose> pa(a.pos.data(), n), pb(b.pos.data(), n);
  const double jt = hs::jitter_mm(future), ja = hs::jitter_mm(pa), jb = hs::jitter_mm(pb);
  const double ea = hs::mpjpe_mm(future, pa), eb = hs::mpjpe_mm(future, pb);
  INFO("44 ms ahead: jitter truth " << jt << ", smoothed " << ja << ", unsmoothed " << jb << " mm; error smoothed " << ea
                                    << ", unsmoothed " << eb << " mm");
  CHECK(ja < 0.75 * jb);
  CHECK(ea < 1.1 * eb);
  // The denoised answers (H = 0) are not made worse.
  auto s0 = hs::make_stgae_filter(model, 0.0, 0, true, std::nullopt, true);
  auto r0 = hs::make_stgae_filter(model, 0.0);
  const double e0s = hs::mpjpe_mm(truth.pos, hs::filter_series(*s0, noisy, 0.0).pos);
  const double e0r = hs::mpjpe_mm(truth.pos, hs::filter_series(*r0, noisy, 0.0).pos);
  INFO("H = 0: smoothed " << e0s << ", unsmoothed " << e0r << " mm");
  CHECK(e0s < 1.02 * e0r);
}
