#pragma once
// Per-tracker filter state in the layer's world-fixed space: feeds the engine (any
// hs::PoseFilter) with new, increasing sample times only, and answers any asked time:
// at or after the last sample from the engine (denoised, or predicted when the engine
// extrapolates), before it from a short history of the engine's past outputs.
//
// Thread safety: one mutex per tracker, held only for push/estimate of one pose and a
// copy (microseconds for the classical filters, one streaming model step for Multi-STGAE);
// runtime calls happen outside it.
// No heap allocation after construction.
#include "handsteady/filters.hpp"
#include "layer_config.hpp"

#include <openxr/openxr.h>

#include <array>
#include <atomic>
#include <memory>
#include <mutex>

namespace hs::layer {

using Velocity = Pose;  // m/s per joint, NaN = unknown

class TrackerFilter {
 public:
  // Throws std::invalid_argument for a bad filter configuration (at tracker creation).
  explicit TrackerFilter(const FilterConfig& config);
  // The layer's engine: Multi-STGAE over config.model (shared, loaded once per instance;
  // this tracker gets its own stream state) or the classical config.filter.
  explicit TrackerFilter(const LayerConfig& config);

  // Feeds `observed` (world space, NaN rows = missing) sampled at sample_time when that
  // time is newer than every earlier sample, then estimates at query_time.
  // observed == nullptr: nothing to feed (hand inactive). Returns false when there is no
  // answer for query_time (no data yet, older than the kept history, or further ahead of
  // the last sample than the engine's gap plus the prediction horizon — a hand coming back
  // after a loss — rather than extrapolating stale state): pass through.
  bool update(XrTime sample_time, const Pose* observed, XrTime query_time, Pose& out, Velocity& velocity) noexcept;

  static constexpr int kHistory = 64;  // past outputs kept for queries older than the last sample

 private:
  TrackerFilter(std::unique_ptr<PoseFilter> filter, double reset_gap_s, double max_ahead_s);
  double seconds(XrTime t) const { return static_cast<double>(t - epoch_) * 1e-9; }
  bool from_history(XrTime t, Pose& out) const noexcept;

  std::mutex mu_;
  std::unique_ptr<PoseFilter> filter_;
  double reset_gap_ns_;
  double max_ahead_ns_;  // answers at most this far after the last sample
  bool has_epoch_ = false;
  XrTime epoch_ = 0;
  XrTime last_ = 0;  // last accepted sample time
  // Ring of (time, engine output at that time) at accepted sample times.
  std::array<XrTime, kHistory> hist_t_{};
  std::unique_ptr<std::array<Pose, kHistory>> hist_pose_;
  int hist_head_ = 0, hist_count_ = 0;
  // Velocity of the engine's output: finite differences of consecutive outputs, low-passed
  // (first order, kVelocityCutoffHz) so that residual jitter is not amplified. NaN = unknown.
  static constexpr double kVelocityCutoffHz = 5.0;
  Velocity velocity_;
};

}  // namespace hs::layer
