#pragma once
// How much of a denoiser's correction to keep, learnt online from the input's own future.
//
// A network trained on some noise over-corrects on noise and hands it has not seen (the
// shipped model is worse than raw on 8-12 Hz tremor and on Leap handwriting), and no
// fixed gain suits every tracker. For white-ish noise the input's *future* rows carry an
// unbiased check: a reference for row t extrapolated back from rows t+1..t+3 (the
// quadratic through them) has noise independent of everything the causal answer at t
// used, so the least-squares gain g of the correction c = answer - input against
// (reference - input) estimates -E[c n] / E[c^2], the share of the correction that
// removes noise. Noise that the next rows predict (slow, correlated drift; tremor slow
// next to the row rate) looks like motion to this check, and the gain falls towards the
// input there.
//
// The correction is split into a low band (its running mean over kGainBandS) and the
// rest, each with its own gain in [0, 1] (the network's high-frequency corrections, which
// remove jitter, and its slow ones, which carry its offsets, are not equally right). Only
// corrections within kGainClip times their running RMS are scaled, fading to none at twice
// that: an outlier or a shifted joint taken back is kept whole. The sums are pooled over
// the hand's joints and the last ~kGainRows rows; the gains apply once kGainMinRows rows
// have shown them (before, the answer is unchanged), are kept across tracking gaps (the
// tracker stays the same) and forgotten by reset(). noexcept, no allocation.
//
// Where the input's noise is measured at the input rate (InputNoise, E|n|^2 per joint),
// the share of each band of a joint's correction that noise explains is kept whatever the
// gains say: min(1, kGainNoiseShare * E|n|^2 / E|b|^2) of band b, E|b|^2 that band's mean
// square over about kGainNoiseRows rows. The check above takes correlated (80 ms) jitter
// for motion and gave its removal back; the rigidity part of InputNoise sees that jitter,
// so its removal stays. Each band against its own size: the fast part is mostly jitter
// removed, and a floor against the whole correction kept too little of it and too much of
// the low band (with it, the demo's Parkinsonian ink kept its tremor: jerk 1564 m/s^3
// against 996 per band). With this floor the gain is the adapter's default where the
// noise is measured (stgae_filter.hpp). A fast part no larger than the network's own
// roughness on clean input (kGainOwnRoughnessM) is no evidence of noise removed: on nearly
// clean input the measured noise and that roughness are of a size, and the floor kept it
// whole. Such a fast part gets no floor (the gains alone judge it), fading in to nearly all
// of it (0.95) at 1.2 times that size. The low band keeps its floor: the correction's slow
// part is where a slow tremor's removal lives, which the check cannot see. So does the fast
// part of rows further apart than kGainBandS (one stream at 22-27 Hz), which carries that
// removal too. But white noise's removal is mostly fast: through the low band's one-pole
// mean (a = 1 - exp(-dt / kGainBandS) a row) it keeps a / (2 - a) of its power, 0.18 at 90
// Hz. So the low band's floor counts the share of the noise that the smoothness measure sees
// (white, `white2`) at that share and the rest (what only the bones see: slow noise) whole;
// counted whole, the noise of a clean recording (its own jitter, a resampling's kinks) kept
// the network's slow offsets.
// docs/STGAE.md "Correction gain".
#include "handsteady/skeleton.hpp"

#include <array>
#include <span>

namespace hs {

inline constexpr double kGainRows = 180.0;      // rows in the running sums
inline constexpr double kGainMinRows = 20.0;    // rows of evidence before the gains apply
inline constexpr double kGainBandS = 0.03;      // time constant of the correction's low band (s)
inline constexpr double kGainClip = 3.0;        // corrections beyond this many RMS are scaled less
inline constexpr double kGainClipFloorM = 1e-4; // the clip's least scale (a still hand corrects nothing)
inline constexpr double kGainMaxSpanS = 0.2;    // a row's reference needs its 3 rows within this
inline constexpr double kGainNoiseShare = 1.0;  // the measured noise's share of each band kept (see above)
inline constexpr double kGainNoiseRows = 30.0;  // rows in each joint's mean square correction
// The RMS of the fast part of a joint's correction under which the measured noise keeps
// none of it (m): the shipped network's answers on clean free-air input are 18-23 % rougher
// than the input, and its error on the benchmark's clean cells is 0.07-0.31 mm a joint. The
// floor's share is capped by 1 - (kGainOwnRoughnessM^2 / E|f|^2)^8: 0.78 at 1.1 times it,
// 0.95 at 1.2 times. docs/STGAE.md "The network's own roughness gets no floor".
inline constexpr double kGainOwnRoughnessM = 3e-4;

class CorrectionGain {
 public:
  CorrectionGain() { reset(); }
  // Forgets everything (a new track).
  void reset() noexcept;
  // A tracking gap: forgets the rows (no reference across the gap), keeps the gains.
  void restart() noexcept;
  // One input row at time t (increasing): the input x and the denoiser's answer for it
  // (3 * kJointCount each, joint-major xyz, NaN = missing). Updates the gains from the row
  // three back, and the shift for answers made from this row. noise2: the input's noise
  // per joint (m^2, kJointCount; empty where it is not measured at the input rate); white2:
  // the part of it the smoothness measure sees (InputNoise::smooth2; empty: none of it).
  void observe(double t, std::span<const float> x, std::span<const double> answer,
               std::span<const double> noise2 = {}, std::span<const double> white2 = {}) noexcept;
  // What to add to coordinate c of joint j's answer at the last row: minus the part of its
  // correction the gains do not keep (0 where the joint was missing).
  double shift(int j, int c) const noexcept { return shift_[static_cast<size_t>(3 * j + c)]; }
  // The gains in [0, 1] of the correction's fast part and of its low band (1 before the
  // rows have shown them).
  double gain_fast() const noexcept { return gain_fast_; }
  double gain_low() const noexcept { return gain_low_; }

 private:
  static constexpr size_t kFs = 3 * kJointCount;
  static constexpr long kRing = 4;  // the row and the three after it
  struct Row {
    double t = 0.0;
    std::array<float, kFs> x{};
    std::array<double, kFs> c{};    // the scaled part of the correction (NaN: missing)
    std::array<double, kFs> low{};  // its low band
  };
  void solve() noexcept;

  std::array<Row, kRing> rows_{};
  long n_ = 0;  // rows since restart
  double last_t_ = 0.0;
  std::array<double, kFs> low_{};  // the low band's running mean per coordinate (NaN: restart)
  // Running sums over the fast (f) and low (l) parts and r = reference - x.
  double s_fr_ = 0.0, s_lr_ = 0.0, s_ff_ = 0.0, s_fl_ = 0.0, s_ll_ = 0.0;
  double s_rows_ = 0.0;             // running count of rows that contributed
  double c2_ = 0.0, c2_rows_ = 0.0; // running mean of |c|^2 per joint (the clip's scale)
  double gain_fast_ = 1.0, gain_low_ = 1.0;
  // Each joint's mean square fast part and low band of its correction (noise2 given).
  std::array<double, kJointCount> joint_fast2_{}, joint_low2_{};
  std::array<int, kJointCount> joint_count_{};
  std::array<double, kFs> shift_{};
};

}  // namespace hs
