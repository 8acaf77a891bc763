#include "tracker_filter.hpp"

#include "handsteady/stgae_engine.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace hs::layer {

TrackerFilter::TrackerFilter(std::unique_ptr<PoseFilter> filter, double reset_gap_s, double max_ahead_s)
    : filter_(std::move(filter)),
      reset_gap_ns_(reset_gap_s * 1e9),
      max_ahead_ns_(max_ahead_s * 1e9),
      hist_pose_(std::make_unique<std::array<Pose, kHistory>>()) {
  velocity_.setConstant(std::numeric_limits<double>::quiet_NaN());
}

TrackerFilter::TrackerFilter(const FilterConfig& config)
    : TrackerFilter(make_filter(config), config.max_gap_s, std::numeric_limits<double>::infinity()) {}

namespace {
std::unique_ptr<PoseFilter> make_layer_engine(const LayerConfig& c) {
  if (c.engine == Engine::Stgae && c.model) {
    // The horizon only matters for validation here: estimates are asked at explicit times.
    const double horizon_s = c.mode == Mode::Predict ? static_cast<double>(c.horizon_ns) * 1e-9 : 0.0;
    return make_stgae_filter(c.model, horizon_s, c.stgae_phases);
  }
  return make_filter(c.filter);
}
}  // namespace

namespace {
// How far past its last sample the engine may answer: its own gap (after which its state
// has expired) plus the horizon the layer samples early by in predict mode.
double max_ahead_s(const LayerConfig& c) {
  const double gap = c.engine == Engine::Stgae ? std::min(c.filter.max_gap_s, kStgaeGapResetS) : c.filter.max_gap_s;
  return gap + (c.mode == Mode::Predict ? static_cast<double>(c.horizon_ns) * 1e-9 : 0.0);
}
}  // namespace

TrackerFilter::TrackerFilter(const LayerConfig& config)
    : TrackerFilter(make_layer_engine(config), config.filter.max_gap_s, max_ahead_s(config)) {}

bool TrackerFilter::from_history(XrTime t, Pose& out) const noexcept {
  // Newest to oldest: find consecutive entries a (older) <= t <= b (newer).
  for (int k = 0; k + 1 < hist_count_; ++k) {
    const int ib = (hist_head_ - 1 - k + 2 * kHistory) % kHistory;
    const int ia = (ib - 1 + kHistory) % kHistory;
    const XrTime ta = hist_t_[ia], tb = hist_t_[ib];
    if (t > tb) return false;
    if (t < ta) continue;
    const double w = tb > ta ? static_cast<double>(t - ta) / static_cast<double>(tb - ta) : 1.0;
    out = (1.0 - w) * (*hist_pose_)[ia] + w * (*hist_pose_)[ib];  // NaN rows stay NaN
    return true;
  }
  if (hist_count_ > 0 && t == hist_t_[(hist_head_ - 1 + kHistory) % kHistory]) {
    out = (*hist_pose_)[(hist_head_ - 1 + kHistory) % kHistory];
    return true;
  }
  return false;
}

bool TrackerFilter::update(XrTime sample_time, const Pose* observed, XrTime query_time, Pose& out,
                           Velocity& velocity) noexcept {
  std::lock_guard lock(mu_);
  if (observed && (!has_epoch_ || sample_time > last_)) {
    if (!has_epoch_) {
      epoch_ = sample_time;
      has_epoch_ = true;
    } else if (hist_count_ > 0 && static_cast<double>(sample_time - last_) > reset_gap_ns_) {
      // Hand lost for longer than the engine's gap: start over rather than bridge the gap.
      filter_->reset();
      hist_count_ = 0;
      velocity_.setConstant(std::numeric_limits<double>::quiet_NaN());
    }
    if (filter_->push(seconds(sample_time), *observed)) {
      last_ = sample_time;
      Pose& slot = (*hist_pose_)[hist_head_];
      filter_->estimate(seconds(sample_time), slot);
      hist_t_[hist_head_] = sample_time;
      if (hist_count_ > 0) {
        const int prev = (hist_head_ - 1 + kHistory) % kHistory;
        const double dt = static_cast<double>(sample_time - hist_t_[prev]) * 1e-9;
        const double a = dt / (dt + 1.0 / (2.0 * std::numbers::pi * kVelocityCutoffHz));
        for (int j = 0; j < kJointCount; ++j)
          for (int k = 0; k < 3; ++k) {
            const double d = (slot(j, k) - (*hist_pose_)[prev](j, k)) / dt;
            double& v = velocity_(j, k);
            if (!std::isfinite(d)) v = std::numeric_limits<double>::quiet_NaN();
            else v = std::isfinite(v) ? v + a * (d - v) : d;
          }
      }
      hist_head_ = (hist_head_ + 1) % kHistory;
      if (hist_count_ < kHistory) ++hist_count_;
    }
  }
  if (hist_count_ == 0) return false;

  bool ok = true;
  if (query_time >= last_) {
    if (static_cast<double>(query_time - last_) > max_ahead_ns_) return false;
    filter_->estimate(seconds(query_time), out);
  } else {
    ok = from_history(query_time, out);
  }

  velocity = velocity_;
  return ok;
}

}  // namespace hs::layer
