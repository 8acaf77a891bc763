#pragma once
// Operations on tracks used by training, the CLI and the layer: left<->right mirroring,
// hand-size normalisation; interpolation and resampling live in time_series.hpp.
#include "handsteady/time_series.hpp"
#include "handsteady/track.hpp"

namespace hs {

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
