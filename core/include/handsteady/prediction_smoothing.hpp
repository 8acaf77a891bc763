#pragma once
// Smooths a network's predicted displacements over time, so that its predictions do not
// add jitter of their own.
//
// The network predicts each frame ahead afresh, and its displacement (predicted frame -
// denoised frame) moves from one frame to the next by more than the hand's motion does:
// the shipped model's 50 ms predictions were ~4x as jerky as the true motion, its
// denoised frames ~1.6x, even on nearly clean input. A displacement is about a velocity
// times a horizon: it changes slowly while the hand moves steadily, fast when it turns.
// One Euro's rule fits that: each predicted frame's displacement, per joint, goes through
// a first-order low-pass whose cutoff grows with how fast the displacement is changing
// (kPredictionMinCutoffHz + kPredictionBeta * |change| / dt). Every lag on a displacement
// is a lag on the predicted velocity, which costs prediction error on fast motion, so
// the constants are the smoothest whose 50 ms error on the benchmark's tuning split is
// no worse than without. On the test split it still costs a few per cent (most at 30 Hz,
// where one stream has no alternation to average): opt-in (StgaeParams::smooth; the
// sweep and both costs in docs/STGAE.md "Prediction smoothing"). The denoised frame is
// not touched. One state for all of a filter's streams, fed in time order: their
// successive frames are smoothed together rather than alternated. Allocation only at
// construction, noexcept.
#include "handsteady/skeleton.hpp"

#include <span>
#include <vector>

namespace hs {

inline constexpr double kPredictionMinCutoffHz = 1.6;  // cutoff of a displacement that does not change
inline constexpr double kPredictionBeta = 24.0;        // s/m: cutoff gained per m/s of displacement change

class PredictionSmoother {
 public:
  // frames: the network's path length, [denoised, predicted 1 .. frames - 1 periods ahead].
  explicit PredictionSmoother(int frames = 1);
  // Forgets the history (tracking restarted).
  void reset() noexcept;
  // The path made at time t (after the last call's t; 3 * kJointCount floats per frame,
  // joint-major xyz, NaN = missing), its predicted frames rewritten in place as the
  // denoised frame plus the smoothed displacement. A joint's first displacement, or its
  // first after it was missing, is kept as it is.
  void apply(double t, std::span<float> path) noexcept;
  int frames() const noexcept { return frames_; }

 private:
  static constexpr size_t kFs = 3 * kJointCount;
  int frames_ = 1;
  std::vector<double> disp_;  // smoothed displacement per predicted frame, joint and coordinate (NaN: none)
  std::vector<double> t_;     // per predicted frame and joint: the time of its last update
};

}  // namespace hs
