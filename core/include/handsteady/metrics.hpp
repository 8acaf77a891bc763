#pragma once
// Quality measures (definitions in docs/METRICS.md). Units: mm, mm^2, mm/frame^2, ms.
#include "handsteady/skeleton.hpp"
#include "handsteady/track.hpp"

#include <span>
#include <vector>

namespace hs {

// Frame-aligned sequences (same length, else std::invalid_argument); joints untracked in
// either are skipped. A measure with nothing to compare is NaN.
double e_pos_mm2(std::span<const Pose> truth, std::span<const Pose> est);   // MSE over coords
double mpjpe_mm(std::span<const Pose> truth, std::span<const Pose> est);    // mean joint distance
// Mean over frames and edges of (length(est) - length(truth))^2.
double edge_length_error_mm2(std::span<const Pose> truth, std::span<const Pose> est, std::span<const Edge> edges);
double e_bon_mm2(std::span<const Pose> truth, std::span<const Pose> est);  // bones of the XR hand
double e_sym_mm2(std::span<const Pose> truth, std::span<const Pose> est);  // symmetry edges
// Mean ||d2 est - d2 truth|| and mean ||d2 est|| (second differences per frame).
double accel_error_mm(std::span<const Pose> truth, std::span<const Pose> est);
double jitter_mm(std::span<const Pose> est);
// Lag of est behind truth, from the cross-correlation of joint velocities, in frames
// (sub-frame by a parabolic fit); positive = est is late. Searched over +-max_lag frames.
double lag_frames(std::span<const Pose> truth, std::span<const Pose> est, int max_lag);

struct Metrics {
  size_t frames = 0;          // frames compared (estimate rows with a joint in common)
  size_t joint_samples = 0;   // joint positions compared
  size_t rows_outside = 0;    // estimate rows skipped: t + horizon outside the truth
  size_t rows_untracked = 0;  // estimate rows skipped: no joint tracked in both
  double e_pos_mm2 = 0, mpjpe_mm = 0, e_bon_mm2 = 0, e_sym_mm2 = 0;
  double accel_error_mm = 0, jitter_mm = 0, truth_jitter_mm = 0;
  double lag_frames = 0;      // in estimate rows
  double frame_period_ms = 0; // median estimate row period, converts lag_frames to lag_ms
  double lag_ms = 0;
  double horizon_ms = 0;
};

// Compares the estimate track with the truth per hand: the estimate row at t against
// the truth interpolated at t + horizon_s (rows whose target time is outside the truth
// are skipped, and counted). Both hands pooled. A "frame" for the temporal measures is
// one estimate row (irregular timestamps are taken as given); the lag is searched over
// +-0.5 s worth of rows.
Metrics evaluate_tracks(const Track& truth, const Track& est, double horizon_s = 0.0);

}  // namespace hs
