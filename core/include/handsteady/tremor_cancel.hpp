#pragma once
// Tremor is a quasi-periodic oscillation: a zero-lag canceller for it, learnt per hand.
//
// Tremor (Parkinsonian 4-6 Hz, essential 4-12 Hz, physiological 8-12 Hz) sits too close to
// the hand's voluntary motion for a causal low-pass to remove it without lag. What sets it
// apart is that it persists: many cycles at a slowly wandering frequency. So, as in the
// Fourier linear combiners of surgical tremor cancellation (Riviere's WFLC, Veluvolu's
// BMFLC), the tremor is modelled as an oscillation whose frequency, amplitude and phase are
// learnt online; the model evaluated at the row's own time is the tremor now, and is
// subtracted: no lag.
//
// Voluntary motion is kept out by a fourth-order high-pass at kTremorHighPassHz (constants
// and ramps give no residual, a 0.35 Hz sweep 0.1 % of itself). The frequency: the peak
// of the hand's mean residual's running spectrum (kTremorStepHz bins, memory
// kTremorSpectrumS) between kTremorMinHz and kTremorMaxHz, interpolated between bins. An
// oscillator at that frequency gives the regressors sin and cos of its phase; the same
// high-pass runs over them, with the same (irregular) time steps, so weights fitted to the
// filtered signal are the tremor's own amplitude and phase, at any frame rate. Channels:
// the hand's mean residual (the whole-hand oscillation, its noise averaged over the joints)
// and each joint's residual about it (a finger's part at the same frequency); each has two
// weights per axis, exponentially weighted least squares with a short memory
// (kTremorMemoryS), so that phase and amplitude follow a wandering tremor.
//
// Frequency lock: the spectrum's peak, averaged over kTremorSpectrumS, trails a tremor whose
// frequency wanders (the corruption's by up to 1 Hz over 2-5 s), and
// then the tremor's phase slips against the oscillator's and the short fit chases it. The
// hand channel's fitted phase turns at the difference of the two frequencies; that turning,
// integrated with time constant kTremorLockS (only while the gates let the hand's channel
// through), moves the oscillator's frequency onto the tremor's, at most kTremorLockMaxHz from
// the peak: a phase-locked loop, as in the weighted-frequency Fourier linear combiner. On a
// still hand with the corruption's wandering 4 mm tremor the error left went from about 0.4
// to 0.25 of it (docs/FILTERS.md "Frequency lock").
//
// Only what is tremor-like is cancelled, by three gates:
// - prominence: tremor is a narrow, lasting peak; voluntary motion (handwriting strokes at
//   3-6 Hz, gestures) spreads over the band and comes and goes. The peak's power over the
//   larger of the powers either side, kTremorProminenceOffHz or kTremorProminenceOffShare
//   of the peak's frequency away, whichever is further (the spectrum reaches beyond the
//   band for this), must reach kTremorProminenceLo to count at all, kTremorProminenceHi
//   to count fully. Without this gate the canceller took in-air handwriting for tremor
//   (docs/FILTERS.md "Tremor canceller"). The share: a tremor's frequency wanders over a
//   band that grows with it (8-12 Hz against 4-6 Hz), and a fixed 0.8 Hz left a wandering
//   physiological tremor's own peak on both sides of it;
// - prediction: each channel's estimate is scaled by how much of its residual the weights
//   predicted before they saw it (out of sample: 1 - error power / residual power, full at
//   kTremorGateSpan), so white or correlated jitter and a still hand are left alone.
// - amplitude: tremor is small; a deliberate rhythmic motion (a wave, a wagging finger, a
//   shake) swings centimetres. Where the largest joint's oscillation exceeds
//   kTremorAmplitudeFullM, the cancelling fades, to nothing at kTremorAmplitudeOffM, for
//   the whole hand (cancelling only part of a swing would bend the hand).
// Start: tracking starts often (a hand comes into view) and a take may last 2 s, so the
// warm-ups overlap: the oscillator and its regressors' filter run from the first row (at
// kTremorStartHz until the spectrum has a peak), so the fit can start as soon as the joints'
// residuals do (kTremorJointWarmS after their filters start: sooner, the filters' start
// transients on a fast gesture's first rows read as a peak) and the spectrum resolves one.
// A joint missing for a few rows (a tracker's dropped joints) keeps its filter, which
// resumes with the time since its last row: restarting it at every drop kept joints from
// warming up, and with 5 % of joints dropped per row nothing was cancelled at all.
// Residuals beyond kTremorClip of that error's RMS (outliers, jumps) teach it no more than
// that. Frequencies above kTremorNyquistShare of the input rate are not looked for.
//
// noexcept, no allocation. A PoseFilter decorator in front of any method
// (FilterConfig::tremor_cancel). docs/FILTERS.md "Tremor canceller".
#include "handsteady/skeleton.hpp"
#include "handsteady/track.hpp"

#include <Eigen/Core>

#include <array>

namespace hs {

inline constexpr double kTremorMinHz = 3.5;            // the band searched for the tremor's frequency
inline constexpr double kTremorMaxHz = 12.5;
inline constexpr double kTremorStepHz = 0.1;           // the spectrum's bins
inline constexpr double kTremorSpectrumLoHz = 2.5;     // ... from here (below the band, for the prominence)
inline constexpr int kTremorBins = 121;                // ... to 14.5 Hz
inline constexpr double kTremorSpectrumS = 2.0;        // memory of the running spectrum
inline constexpr double kTremorProminenceOffHz = 0.8;  // prominence: the peak's power over the larger at +-this,
inline constexpr double kTremorProminenceOffShare = 0.16;  // ... or at +-this share of the peak's frequency, if further
inline constexpr double kTremorResolutionCycles = 1.0;  // ... or at +-this / the spectrum's length, if further
inline constexpr double kTremorProminenceLo = 5.0;     // ... below this, nothing is cancelled
inline constexpr double kTremorProminenceHi = 20.0;    // ... from this on, all of it
inline constexpr double kTremorNyquistShare = 0.4;     // frequencies looked for: below this share of the input rate
inline constexpr double kTremorMemoryS = 0.2;          // memory of the amplitude and phase fit
inline constexpr double kTremorHighPassHz = 2.0;       // the high-pass that keeps voluntary motion out
inline constexpr double kTremorStartHz = 5.0;          // the oscillator's frequency until the spectrum has a peak
inline constexpr double kTremorJointWarmS = 0.6;       // a joint's residual is used this long after its filter starts
inline constexpr double kTremorFitWarmS = 0.6;         // ... and the regressors' filter this long after the oscillator
inline constexpr double kTremorJointHoldS = 0.1;       // a joint missing no longer than this keeps its filter
inline constexpr double kTremorGateSpan = 0.3;         // prediction gain at which a channel counts fully
inline constexpr double kTremorClip = 3.0;             // residuals clipped at this many RMS of the error
inline constexpr double kTremorAmplitudeFullM = 0.015; // amplitude: cancelled fully up to this (m; 3 cm peak to peak)
inline constexpr double kTremorAmplitudeOffM = 0.025;  // ... and not at all from this
inline constexpr double kTremorLockS = 0.2;            // time constant of the frequency lock
inline constexpr double kTremorLockMaxHz = 1.0;        // ... which moves the oscillator at most this far from the peak
inline constexpr int kTremorMinJoints = 5;             // joints the hand's mean needs

class TremorCancel {
 public:
  TremorCancel() { reset(); }
  // Forgets everything (a new hand).
  void reset() noexcept;
  // Learns from the row at time t (after the last one) and subtracts the tremor it has
  // learnt from its tracked joints. Missing joints (NaN) stay missing.
  void apply(double t, Pose& pose) noexcept;
  // The tremor frequency it follows (Hz; 0: none found yet).
  double frequency_hz() const noexcept { return freq_hz_ > 0.0 ? freq_hz_ + lock_hz_ : 0.0; }

 private:
  static constexpr int kChannels = 1 + kJointCount;  // the hand's mean, then each joint about it
  struct HighPass {  // (s^2 / (s + w)^2)^2: removes constants, ramps and slow curves
    double x = 0.0, v = 0.0, x2 = 0.0, v2 = 0.0;
    void start(double s) noexcept { *this = {s, 0.0, 0.0, 0.0}; }
    double step(double s, double dt, double w) noexcept;
  };
  // The spectrum's peak in the band (Hz; 0: none) and its prominence.
  double peak_hz(double& prominence) const noexcept;
  // The frequency lock, from the hand channel's weights per axis (sin, cos) after this row.
  void lock(double dt, double gate, const std::array<std::array<double, 2>, 3>& w) noexcept;

  double t0_ = 0.0, last_t_ = 0.0;
  int rows_ = 0;
  double dt_mean_ = 0.0;
  double fit_age_s_ = 0.0;                         // since the regressors' filter started
  double spec_age_s_ = 0.0;                        // time the spectrum holds
  std::array<std::array<HighPass, 3>, kJointCount> sig_hp_{};
  std::array<double, kJointCount> joint_age_s_{};  // since each joint's filter started (-1: none yet)
  std::array<double, kJointCount> joint_last_t_{}; // ... and its last row
  // The hand's running spectrum: per bin and axis, sum lambda^k r e^{-i w t} (re, im).
  std::array<std::array<std::array<double, 2>, 3>, kTremorBins> spec_{};
  double freq_hz_ = 0.0;                           // the spectrum's peak (0: none yet; the oscillator runs at kTremorStartHz)
  double phase_ = 0.0;                             // the oscillator's phase (rad)
  double lock_hz_ = 0.0;                           // ... its frequency less the peak's (the lock)
  double lock_theta_ = 0.0;                        // ... the hand channel's fitted phase, mod pi, last row
  bool lock_have_ = false;                         // ... whether lock_theta_ is set
  std::array<HighPass, 2> reg_hp_{};               // the high-pass of its sin and cos
  std::array<double, 2> u_{};                      // ... this row
  // The weighted least squares: R = sum lambda^k u u^T (2 x 2), b per channel and axis.
  double r00_ = 0.0, r01_ = 0.0, r11_ = 0.0;
  std::array<std::array<std::array<double, 2>, 3>, kChannels> b_{};
  std::array<std::array<double, 3>, kChannels> err2_{}, res2_{};  // a-priori error and residual power
  std::array<double, kChannels> gate_{};
  double rows_fit_ = 0.0;                          // sum lambda^k: rows in the fit's window
};

}  // namespace hs
