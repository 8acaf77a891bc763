#pragma once
// The network's lag behind a fast-moving joint, taken out of its answer. Noise has no
// preferred direction, so a denoiser's correction (answer - input) along the joint's own
// motion should be no larger than across it; the network's shortfall on fast motion (it
// answers 1-1.5 ms behind a free-air hand, 2 mm on joints over 1 m/s; docs/STGAE.md "Fast
// free-air motion") is all along it. Where the joint's last answers moved by more than
// kMotionCapSpeedZ times what the input's noise explains of such a step, the correction's
// component along that step is held to kMotionCapFactor times the noise's RMS; across it,
// and on slower joints, nothing changes. Needs the noise measured at the input rate
// (InputNoise: input faster than the model, or one stream on rows slower than it). On a
// row InputNoise calls a jump the cap acts only where the joint's bones kept their lengths
// and the correction looks like lag (mostly along the step, under a share of it); an
// outlier taken back keeps its correction. Per hand, no allocation, noexcept.
#include "handsteady/skeleton.hpp"
#include "handsteady/track.hpp"

#include <array>
#include <span>

namespace hs {

// Chosen on the benchmark's tuning split at 90 Hz and the handwriting demo's ink jerk
// (docs/STGAE.md "The lag cap"): a factor of 0.5 with the speed bar at 2 took the tuning
// split 1.7235 -> 1.7018 mm but the demo's jerk from 0.470 to 0.510 of raw's (over the
// Multi-STGAE v2 issue's 0.5); its pen moves slower than the bar of 8, which keeps the demo
// as it was (0.471) and 60 % of that gain (1.7107 mm, no cell worse).
inline constexpr double kMotionCapFactor = 0.5;
inline constexpr double kMotionCapSpeedZ = 8.0;
// On a jump row that kept the joint's bones: a correction along the step over this share of
// the step is an outlier's (docs/STGAE.md "The lag cap", "On rows called jumps": 1 against
// 0.5 and 2 on the tuning split at 90 Hz; 0.5 before the bones were asked).
inline constexpr double kMotionCapJumpShare = 1.0;
// One stream on rows slower than the model (StgaeFilter's slow rows: 22.4-27.3 Hz under a
// 30 Hz model, HoloLens 2's 23.5 Hz) has the noise measured on its rows too, and the cap
// serves it there (docs/STGAE.md "The lag cap and the gain on slow rows"); but a fast
// hand's step over two such rows is 50-100 mm, under which a 10-50 mm outlier along the
// motion would read as lag. A quarter of the step (about half a row's interval of lag, 21
// ms at 23.5 Hz) kept most of the cap's gain on the tuning split at 23.5 Hz (0.5: as much,
// the outliers put back less far; 0.1: less).
inline constexpr double kMotionCapJumpShareSlowRows = 0.25;

class MotionLagCap {
 public:
  void reset() noexcept;
  // The input row x (3 * kJointCount, joint-major xyz, NaN = missing), the answer at its
  // time without this cap (NaN rows = none), and the input's noise (InputNoise: E|n|^2 per
  // joint, this row's jumps, the joints whose bones it stretched). Sets the shift for
  // answers made from this row. On a jump row, a correction along the step over `jump_share`
  // of it is an outlier's (kMotionCapJumpShare; one stream on slow rows:
  // kMotionCapJumpShareSlowRows).
  void observe(std::span<const float> x, const Pose& answer, std::span<const double> noise2,
               std::span<const double> jump, std::span<const bool> stretched,
               double jump_share = kMotionCapJumpShare) noexcept;
  // Clears the shift (a row without the hand); the answers seen stay.
  void clear() noexcept { shift_.fill(0.0); }
  // What to add to coordinate c of joint j of answers made from the last row (m).
  double shift(int j, int c) const noexcept { return shift_[static_cast<size_t>(3 * j + c)]; }

 private:
  static constexpr size_t kRows = 3;          // the answers kept: the step is the last one's from the third
  std::array<Pose, kRows> answers_{};         // the last answers (with the cap), newest at (n_ - 1) % kRows
  long n_ = 0;                                // rows observed since reset
  std::array<double, 3 * kJointCount> shift_{};
};

}  // namespace hs
