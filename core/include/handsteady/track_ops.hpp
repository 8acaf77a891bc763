#pragma once
// Operations on tracks used by training, the CLI and the layer: interpolation,
// resampling to a fixed rate, left<->right mirroring, hand-size normalisation.
#include "handsteady/gap_policy.hpp"
#include "handsteady/track.hpp"

namespace hs {

// Linear interpolation of one hand at time t. A joint is tracked in the result only
// when it is tracked in both bracketing rows and they are at most max_gap_s apart
// (at the exact time of a row, that row's value). Outside [t0, tN]: untracked.
Pose interpolate_pose(const HandSeries& series, double t, double max_gap_s = kInterpolateMaxGapS);

// Each hand resampled on a fixed grid k/rate_hz covering its time span; joints that
// cannot be interpolated (gaps > max_gap_s) stay untracked. Metadata kept, rate_hz set.
HandSeries resample_series(const HandSeries& series, double rate_hz, double max_gap_s = kInterpolateMaxGapS);
Track resample_track(const Track& track, double rate_hz, double max_gap_s = kInterpolateMaxGapS);

// Mirror across the YZ plane (x -> -x) and swap left/right; mirror_track toggles the
// "mirrored: yes|no" metadata.
Pose mirror_pose(const Pose& p);
Track mirror_track(const Track& track);

// Hand size: the median over rows of the wrist -> middle_proximal distance (m);
// NaN when no row has both joints.
double hand_size(const HandSeries& series);
// Scales every pose about its own wrist (rows without a wrist: about the centroid of
// their tracked joints) so hand_size() becomes target_m; throws std::invalid_argument
// for target_m <= 0.
// Returns the scale factor applied (per hand; 1 if the hand has no usable row).
double normalize_hand_size(HandSeries& series, double target_m);
// Per hand; sets "hand_size_m" and "hand_scale_left|right" metadata.
Track normalize_hand_size(const Track& track, double target_m);

}  // namespace hs
