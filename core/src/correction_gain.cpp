#include "handsteady/correction_gain.hpp"
#include "handsteady/correction_bound.hpp"
#include "handsteady/time_series.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hs {

void CorrectionGain::reset() noexcept {
  restart();
  s_fr_ = s_lr_ = s_ff_ = s_fl_ = s_ll_ = s_rows_ = 0.0;
  c2_ = c2_rows_ = 0.0;
  gain_fast_ = gain_low_ = 1.0;
  joint_fast2_.fill(0.0);
  joint_low2_.fill(0.0);
  joint_count_.fill(0);
}

void CorrectionGain::restart() noexcept {
  n_ = 0;
  low_.fill(kNaN);
  shift_.fill(0.0);
}

namespace {
// The most of a fast part of mean square mean2 the measured noise may keep: none where it is
// no larger than the network's own roughness, 0.95 of it at 1.2 times that size.
double vouched(double mean2) noexcept {
  constexpr double e2 = kGainOwnRoughnessM * kGainOwnRoughnessM;
  if (!(mean2 > e2)) return 0.0;
  double r = e2 / mean2;
  r *= r;
  r *= r;
  r *= r;
  return 1.0 - r;
}
}  // namespace

// Least squares of (reference - x) on the two parts with each gain in [0, 1]: the 2x2
// normal equations, or projected coordinate descent when their optimum is outside.
void CorrectionGain::solve() noexcept {
  const double det = s_ff_ * s_ll_ - s_fl_ * s_fl_;
  const bool regular = det > 1e-9 * s_ff_ * s_ll_ && det > 0.0;
  double gf = regular ? (s_fr_ * s_ll_ - s_lr_ * s_fl_) / det : 0.0;
  double gl = regular ? (s_lr_ * s_ff_ - s_fr_ * s_fl_) / det : 0.0;
  if (!regular || gf < 0.0 || gf > 1.0 || gl < 0.0 || gl > 1.0) {
    gf = std::clamp(gf, 0.0, 1.0);
    gl = std::clamp(gl, 0.0, 1.0);
    for (int it = 0; it < 4; ++it) {
      if (s_ff_ > 0.0) gf = std::clamp((s_fr_ - gl * s_fl_) / s_ff_, 0.0, 1.0);
      if (s_ll_ > 0.0) gl = std::clamp((s_lr_ - gf * s_fl_) / s_ll_, 0.0, 1.0);
    }
  }
  gain_fast_ = gf;
  gain_low_ = gl;
}

void CorrectionGain::observe(double t, std::span<const float> x, std::span<const double> answer,
                             std::span<const double> noise2, std::span<const double> white2) noexcept {
  if (x.size() < kFs || answer.size() < kFs || !std::isfinite(t)) return;
  Row& row = rows_[static_cast<size_t>(n_ % kRing)];
  row.t = t;
  std::copy(x.begin(), x.begin() + kFs, row.x.begin());
  // The correction's part to scale: all of it within clip, none beyond twice that. The
  // scale is winsorised, so that outliers do not set it.
  const double clip = c2_rows_ >= 1.0 ? std::max(kGainClip * std::sqrt(c2_), kGainClipFloorM)
                                      : std::numeric_limits<double>::infinity();
  const double dt = n_ > 0 ? t - last_t_ : std::numeric_limits<double>::infinity();
  const double a = 1.0 - std::exp(-dt / kGainBandS);
  // The fast part is the answers' roughness only where the low band spans more than a row.
  const bool rough_rows = dt < kGainBandS;
  double c2_sum = 0.0;
  int c2_n = 0;
  for (size_t o = 0; o < kFs; o += 3) {
    double* c = row.c.data() + o;
    double* low = low_.data() + o;
    if (!finite_xyz(row.x.data() + o) || !finite_xyz(answer.data() + o)) {
      for (size_t k = 0; k < 3; ++k) c[k] = low[k] = row.low[o + k] = kNaN;
      continue;
    }
    double n2 = 0.0;
    for (size_t k = 0; k < 3; ++k) {
      c[k] = answer[o + k] - static_cast<double>(row.x[o + k]);
      n2 += c[k] * c[k];
    }
    c2_sum += std::min(n2, 4.0 * clip * clip);
    ++c2_n;
    const double n = std::sqrt(n2);
    const double part = n <= clip ? 1.0 : std::max(0.0, 2.0 - n / clip);
    double fast2 = 0.0, low2 = 0.0;
    for (size_t k = 0; k < 3; ++k) {
      c[k] *= part;
      low[k] = std::isfinite(low[k]) ? low[k] + a * (c[k] - low[k]) : c[k];
      row.low[o + k] = low[k];
      fast2 += (c[k] - low[k]) * (c[k] - low[k]);
      low2 += low[k] * low[k];
    }
    if (noise2.size() >= kJointCount) {
      const size_t j = o / 3;
      const double w = running_weight(joint_count_[j], kGainNoiseRows);
      joint_fast2_[j] += w * (fast2 - joint_fast2_[j]);
      joint_low2_[j] += w * (low2 - joint_low2_[j]);
    }
  }
  if (c2_n > 0) {
    c2_rows_ = std::min(c2_rows_ + 1.0, kGainRows);
    c2_ += (c2_sum / c2_n - c2_) / c2_rows_;
  }
  last_t_ = t;
  // The row three back against the quadratic back from the three rows since.
  if (n_ >= kRing - 1) {
    const Row& r0 = rows_[static_cast<size_t>((n_ - 3) % kRing)];
    const Row& r1 = rows_[static_cast<size_t>((n_ - 2) % kRing)];
    const Row& r2 = rows_[static_cast<size_t>((n_ - 1) % kRing)];
    if (t - r0.t <= kGainMaxSpanS) {
      const auto w = quadratic_weights(r0.t, r1.t, r2.t, t);
      double fr = 0.0, lr = 0.0, ff = 0.0, fl = 0.0, ll = 0.0;
      bool any = false;
      for (size_t o = 0; o < kFs; o += 3) {
        if (!finite_xyz(r0.c.data() + o) || !finite_xyz(r1.x.data() + o) || !finite_xyz(r2.x.data() + o) ||
            !finite_xyz(row.x.data() + o))
          continue;
        for (size_t k = 0; k < 3; ++k) {
          const double ref = w[0] * static_cast<double>(r1.x[o + k]) + w[1] * static_cast<double>(r2.x[o + k]) +
                             w[2] * static_cast<double>(row.x[o + k]);
          const double r = ref - static_cast<double>(r0.x[o + k]);
          const double low = r0.low[o + k], fast = r0.c[o + k] - low;
          fr += fast * r;
          lr += low * r;
          ff += fast * fast;
          fl += fast * low;
          ll += low * low;
        }
        any = true;
      }
      if (any) {
        const double keep = 1.0 - 1.0 / kGainRows;
        s_fr_ = keep * s_fr_ + fr;
        s_lr_ = keep * s_lr_ + lr;
        s_ff_ = keep * s_ff_ + ff;
        s_fl_ = keep * s_fl_ + fl;
        s_ll_ = keep * s_ll_ + ll;
        s_rows_ = keep * s_rows_ + 1.0;
        if (s_rows_ >= kGainMinRows) solve();
      }
    }
  }
  // What the gains take back of each band, less the share of it the measured noise explains
  // (none of a fast part no larger than the network's own roughness: vouched(); of the low
  // band, the white part of the noise only at the share its removal keeps through the band).
  const bool measured = noise2.size() >= kJointCount;
  const bool split = measured && white2.size() >= kJointCount;
  const double white_low = a / (2.0 - a);
  for (size_t o = 0; o < kFs; o += 3) {
    const size_t j = o / 3;
    const bool floor = measured && noise2[j] >= 0.0;
    const double explained_fast = floor ? explained_share(joint_fast2_[j], kGainNoiseShare * noise2[j]) : 0.0;
    const double kept_fast = rough_rows ? std::min(vouched(joint_fast2_[j]), explained_fast) : explained_fast;
    const double white = floor && split ? std::clamp(white2[j], 0.0, noise2[j]) : 0.0;
    const double low_noise2 = floor ? noise2[j] - white + white_low * white : 0.0;
    const double kept_low = floor ? explained_share(joint_low2_[j], kGainNoiseShare * low_noise2) : 0.0;
    for (size_t i = o; i < o + 3; ++i)
      shift_[i] = std::isfinite(row.c[i]) ? -(1.0 - kept_fast) * (1.0 - gain_fast_) * (row.c[i] - row.low[i]) -
                                                (1.0 - kept_low) * (1.0 - gain_low_) * row.low[i]
                                          : 0.0;
  }
  ++n_;
}

}  // namespace hs
