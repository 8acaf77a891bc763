#include "handsteady/tremor_cancel.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hs {

namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kClipAfterRows = 20.0;  // the error RMS is known well enough to clip with
constexpr double kRidge = 1e-3;          // of the window's rows: keeps the 2 x 2 solve regular
// The prominence's sides of the band's lowest and highest peaks are in the spectrum.
static_assert(kTremorMinHz - kTremorProminenceOffHz >= kTremorSpectrumLoHz);
static_assert(kTremorMaxHz * (1.0 + kTremorProminenceOffShare) <= kTremorSpectrumLoHz + kTremorStepHz * (kTremorBins - 1) + 1e-9);
static_assert(kTremorMinHz * kTremorProminenceOffShare <= kTremorProminenceOffHz);  // the share widens only
static_assert(kTremorStartHz >= kTremorMinHz && kTremorStartHz <= kTremorMaxHz);
}  // namespace

// Two critically damped alpha-beta trackers in a row (Brown's double exponential smoothing
// with discount exp(-w dt)); the second's innovation on the first's is the high-passed
// signal. Time-varying with dt, but the same for the signal and the regressors, which is
// all the fit needs.
double TremorCancel::HighPass::step(double s, double dt, double w) noexcept {
  const double theta = std::exp(-w * dt);
  const double alpha = 1.0 - theta * theta, beta = (1.0 - theta) * (1.0 - theta);
  const auto stage = [&](double in, double& px, double& pv) {
    const double predicted = px + pv * dt;
    const double e = in - predicted;
    px = predicted + alpha * e;
    pv += beta * e / dt;
    return e;
  };
  const double e1 = stage(s, x, v);
  return stage(e1, x2, v2);
}

void TremorCancel::reset() noexcept {
  rows_ = 0;
  t0_ = last_t_ = 0.0;
  dt_mean_ = 0.0;
  fit_age_s_ = 0.0;
  spec_age_s_ = 0.0;
  joint_age_s_.fill(-1.0);
  joint_last_t_.fill(0.0);
  for (auto& bin : spec_)
    for (auto& c : bin) c = {0.0, 0.0};
  freq_hz_ = 0.0;
  phase_ = 0.0;
  lock_hz_ = 0.0;
  lock_theta_ = 0.0;
  lock_have_ = false;
  r00_ = r01_ = r11_ = 0.0;
  rows_fit_ = 0.0;
  for (auto& c : b_)
    for (auto& a : c) a = {0.0, 0.0};
  for (auto& c : err2_) c.fill(0.0);
  for (auto& c : res2_) c.fill(0.0);
  gate_.fill(0.0);
}

double TremorCancel::peak_hz(double& prominence) const noexcept {
  const double top = dt_mean_ > 0.0 ? kTremorNyquistShare / dt_mean_ : 0.0;
  const auto power = [&](int k) {
    double p = 0.0;
    for (const auto& c : spec_[static_cast<size_t>(k)]) p += c[0] * c[0] + c[1] * c[1];
    return p;
  };
  const auto hz = [](int k) { return kTremorSpectrumLoHz + kTremorStepHz * k; };
  int best = -1;
  double best_p = 0.0;
  for (int k = 0; k < kTremorBins && hz(k) < std::min(top, kTremorMaxHz + 1e-9); ++k)
    if (hz(k) >= kTremorMinHz - 1e-9)
      if (const double p = power(k); p > best_p) best = k, best_p = p;
  prominence = 0.0;
  if (best < 0) return 0.0;
  // The sides: far enough for the spectrum's resolution (early on, wider), and the low one
  // no lower than the spectrum's first bin.
  const double off_hz = std::max({kTremorProminenceOffHz, kTremorProminenceOffShare * hz(best),
                                  spec_age_s_ > 0.0 ? kTremorResolutionCycles / spec_age_s_ : 1e9});
  const int off = static_cast<int>(std::min<long>(std::lround(off_hz / kTremorStepHz), kTremorBins));
  double side = power(std::max(best - off, 0));
  if (best + off < kTremorBins && hz(best + off) < top) side = std::max(side, power(best + off));
  prominence = side > 0.0 ? best_p / side : 1e9;
  double shift = 0.0;
  if (best + 1 < kTremorBins && hz(best + 1) < top) {
    const double a = power(best - 1), c = power(best + 1), den = a - 2.0 * best_p + c;
    if (den < 0.0) shift = std::clamp(0.5 * (a - c) / den, -0.5, 0.5);
  }
  return hz(best) + kTremorStepHz * shift;
}

// The hand channel's fitted oscillation on axis a is w_a0 sin(phase) + w_a1 cos(phase) =
// A_a sin(phase + theta): theta turns at the tremor's frequency less the oscillator's. The
// axes share theta up to a sign (one direction of shaking), so it is read mod pi from the
// sum of the squared phasors. Its turning rate is integrated into lock_hz_ as far as `gate`
// (the hand channel's gates) trusts the fit.
void TremorCancel::lock(double dt, double gate, const std::array<std::array<double, 2>, 3>& w) noexcept {
  double re = 0.0, im = 0.0;
  for (const auto& wa : w) {
    re += wa[0] * wa[0] - wa[1] * wa[1];
    im += 2.0 * wa[0] * wa[1];
  }
  if (!std::isfinite(re) || !std::isfinite(im) || (re == 0.0 && im == 0.0)) return;  // no phase to read
  const double theta = 0.5 * std::atan2(im, re);
  if (lock_have_ && dt > 0.0) {
    const double turn = 0.5 * std::remainder(2.0 * (theta - lock_theta_), kTwoPi);  // mod pi
    const double k = std::min(1.0, dt / kTremorLockS) * std::clamp(gate, 0.0, 1.0);
    lock_hz_ = std::clamp(lock_hz_ + k * turn / (kTwoPi * dt), -kTremorLockMaxHz, kTremorLockMaxHz);
    // The oscillator stays in the band searched (and under the input's Nyquist share).
    const double hi = std::min(kTremorMaxHz, dt_mean_ > 0.0 ? kTremorNyquistShare / dt_mean_ : kTremorMaxHz);
    lock_hz_ = std::clamp(freq_hz_ + lock_hz_, kTremorMinHz, std::max(kTremorMinHz, hi)) - freq_hz_;
  }
  lock_theta_ = theta;
  lock_have_ = true;
}

void TremorCancel::apply(double t, Pose& pose) noexcept {
  const double dt = rows_ > 0 ? t - last_t_ : 0.0;
  if (rows_ > 0 && !(dt > 0.0)) return;  // not after the last row: nothing to learn from
  if (rows_ == 0) t0_ = t;
  last_t_ = t;
  ++rows_;
  if (rows_ == 2) dt_mean_ = dt;
  else if (rows_ > 2) dt_mean_ += 0.05 * (dt - dt_mean_);
  const double tau = t - t0_;  // time from the first row, so that sin keeps its precision
  const double w_hp = kTwoPi * kTremorHighPassHz;

  // The joints' residuals; a joint's filter starts when it appears.
  std::array<Eigen::Vector3d, kJointCount> r;
  Eigen::Vector3d hand = Eigen::Vector3d::Zero();
  int warm = 0;
  std::array<bool, kJointCount> use{};
  for (int j = 0; j < kJointCount; ++j) {
    const size_t js = static_cast<size_t>(j);
    if (!joint_finite(pose, j)) continue;  // its filter waits (kTremorJointHoldS)
    auto& hp = sig_hp_[js];
    const double jdt = t - joint_last_t_[js];
    joint_last_t_[js] = t;
    if (joint_age_s_[js] < 0.0 || rows_ == 1 || jdt > kTremorJointHoldS) {
      for (int a = 0; a < 3; ++a) hp[static_cast<size_t>(a)].start(pose(j, a));
      joint_age_s_[js] = 0.0;
      continue;
    }
    for (int a = 0; a < 3; ++a) r[js](a) = hp[static_cast<size_t>(a)].step(pose(j, a), jdt, w_hp);
    joint_age_s_[js] += jdt;
    if (joint_age_s_[js] >= kTremorJointWarmS) {
      use[js] = true;
      hand += r[js];
      ++warm;
    }
  }
  // The oscillator and its regressors' filter run on every row from the first, so that
  // the filter has settled when a peak is found and the weights learnt stay in phase with
  // the tremor over rows too sparse to learn from.
  const double osc_hz = frequency_hz();
  phase_ = std::remainder(phase_ + kTwoPi * (osc_hz > 0.0 ? osc_hz : kTremorStartHz) * dt, kTwoPi);  // dt 0 on the first row
  const std::array<double, 2> x{std::sin(phase_), std::cos(phase_)};
  for (size_t i = 0; i < 2; ++i) {
    if (rows_ == 1) reg_hp_[i].start(x[i]);
    else u_[i] = reg_hp_[i].step(x[i], dt, w_hp);
  }
  if (rows_ == 1) return;
  fit_age_s_ += dt;
  if (warm < kTremorMinJoints) return;
  hand /= warm;

  // The hand's running spectrum, and the oscillator at its peak.
  const double ls = std::exp(-dt / kTremorSpectrumS);
  spec_age_s_ += dt;
  // Each bin's phasor e^{i w_k tau}, from the first by rotation: two sin/cos pairs a row, not one a bin.
  double pc = std::cos(kTwoPi * kTremorSpectrumLoHz * tau), ps = std::sin(kTwoPi * kTremorSpectrumLoHz * tau);
  const double step_c = std::cos(kTwoPi * kTremorStepHz * tau), step_s = std::sin(kTwoPi * kTremorStepHz * tau);
  for (int k = 0; k < kTremorBins; ++k) {
    if (k > 0) {
      const double rc = pc * step_c - ps * step_s;
      ps = ps * step_c + pc * step_s;
      pc = rc;
    }
    for (int a = 0; a < 3; ++a) {
      auto& z = spec_[static_cast<size_t>(k)][static_cast<size_t>(a)];
      z[0] = ls * z[0] + hand(a) * pc;
      z[1] = ls * z[1] - hand(a) * ps;
    }
  }
  double prominence = 0.0;
  if (const double f = peak_hz(prominence); f > 0.0) freq_hz_ = f;
  if (freq_hz_ == 0.0) return;
  const double prom_gate = std::clamp((prominence - kTremorProminenceLo) / (kTremorProminenceHi - kTremorProminenceLo), 0.0, 1.0);
  if (fit_age_s_ < kTremorFitWarmS) return;  // the regressors' filter settles

  // Weights w = (R + ridge)^-1 b, 2 x 2.
  const double lw = std::exp(-dt / kTremorMemoryS);
  const auto weights = [&](const std::array<double, 2>& b) {
    const double ridge = kRidge * rows_fit_;
    const double a00 = r00_ + ridge, a11 = r11_ + ridge, det = a00 * a11 - r01_ * r01_;
    if (!(det > 0.0)) return std::array<double, 2>{0.0, 0.0};
    return std::array<double, 2>{(a11 * b[0] - r01_ * b[1]) / det, (a00 * b[1] - r01_ * b[0]) / det};
  };
  // Each channel's a-priori prediction of its residual (the weights before this row):
  // its error against the residual's own power is the channel's gate; the error's RMS
  // also clips what an outlier may teach.
  const auto learn = [&](int c, const Eigen::Vector3d& res) {
    const size_t cs = static_cast<size_t>(c);
    double e2 = 0.0, r2 = 0.0;
    for (int a = 0; a < 3; ++a) {
      auto& b = b_[cs][static_cast<size_t>(a)];
      const auto w = weights(b);
      const double pred = w[0] * u_[0] + w[1] * u_[1];
      double v = res(a);
      double& err2 = err2_[cs][static_cast<size_t>(a)];
      if (rows_fit_ > kClipAfterRows) {
        const double rms = std::sqrt(err2 / rows_fit_);
        v = std::clamp(v, pred - kTremorClip * rms, pred + kTremorClip * rms);
      }
      const double e = v - pred;
      err2 = lw * err2 + e * e;
      res2_[cs][static_cast<size_t>(a)] = lw * res2_[cs][static_cast<size_t>(a)] + v * v;
      e2 += err2;
      r2 += res2_[cs][static_cast<size_t>(a)];
      b = {lw * b[0] + u_[0] * v, lw * b[1] + u_[1] * v};
    }
    gate_[cs] = r2 > 0.0 ? std::clamp((1.0 - e2 / r2) / kTremorGateSpan, 0.0, 1.0) : 0.0;
  };
  learn(0, hand);
  lock(dt, prom_gate * gate_[0], {weights(b_[0][0]), weights(b_[0][1]), weights(b_[0][2])});
  for (int j = 0; j < kJointCount; ++j) {
    const size_t cs = static_cast<size_t>(1 + j);
    if (use[static_cast<size_t>(j)]) learn(1 + j, r[static_cast<size_t>(j)] - hand);
    else  // a row without it: as if its residual were zero (R learns this row too)
      for (auto& b : b_[cs]) b = {lw * b[0], lw * b[1]};
  }
  r00_ = lw * r00_ + u_[0] * u_[0];
  r01_ = lw * r01_ + u_[0] * u_[1];
  r11_ = lw * r11_ + u_[1] * u_[1];
  rows_fit_ = lw * rows_fit_ + 1.0;

  // Cancel: the tremor now, from the weights learnt so far. Each channel's weights, and
  // the part of them its gates let through; a joint's oscillation is the hand's plus its own.
  using Weights = std::array<std::array<std::array<double, 2>, 3>, kChannels>;
  Weights w{}, cancel{};
  for (size_t c = 0; c < kChannels; ++c)
    for (size_t a = 0; a < 3; ++a) {
      w[c][a] = weights(b_[c][a]);
      for (size_t i = 0; i < 2; ++i) cancel[c][a][i] = prom_gate * gate_[c] * w[c][a][i];
    }
  const auto of_joint = [&](const Weights& m, size_t j, size_t a, size_t i) {
    return m[0][a][i] + (use[j] ? m[1 + j][a][i] : 0.0);
  };
  // The amplitude gate, from the largest joint's oscillation before the other gates.
  double amp2_max = 0.0;
  for (int j = 0; j < kJointCount; ++j) {
    if (!joint_finite(pose, j)) continue;
    double amp2 = 0.0;
    for (size_t a = 0; a < 3; ++a)
      for (size_t i = 0; i < 2; ++i) {
        const double v = of_joint(w, static_cast<size_t>(j), a, i);
        amp2 += v * v;
      }
    amp2_max = std::max(amp2_max, amp2);
  }
  const double amp_gate = std::clamp((kTremorAmplitudeOffM - std::sqrt(amp2_max)) / (kTremorAmplitudeOffM - kTremorAmplitudeFullM), 0.0, 1.0);
  if (amp_gate <= 0.0) return;
  for (int j = 0; j < kJointCount; ++j) {
    if (!joint_finite(pose, j)) continue;
    for (size_t a = 0; a < 3; ++a) {
      const size_t js = static_cast<size_t>(j);
      const double d = of_joint(cancel, js, a, 0) * x[0] + of_joint(cancel, js, a, 1) * x[1];
      pose(j, static_cast<int>(a)) -= amp_gate * d;
    }
  }
}

}  // namespace hs
