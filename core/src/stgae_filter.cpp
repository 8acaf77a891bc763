// PoseFilter adapter over the streaming Multi-STGAE engine: irregular input -> model grid.
#include "handsteady/stgae_engine.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace hs {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

class StgaeFilter final : public PoseFilter {
 public:
  explicit StgaeFilter(std::shared_ptr<const StgaeModel> model) : model_(std::move(model)), stream_(model_->net) {
    const auto& c = model_->config;
    n_ = c.joint_count();
    if (n_ != kJointCount) throw std::invalid_argument("the STGAE filter needs a 26-joint (xr26) model");
    period_ = 1.0 / c.rate_hz;
    dt_frames_ = c.predict ? c.horizon : 0;
    const size_t fs = static_cast<size_t>(3 * n_);
    prev_.assign(fs, kNaN);
    cur_.assign(fs, kNaN);
    interp_.assign(fs, kNaN);
    den_prev_.assign(fs, kNaN);
    path_.assign(fs * static_cast<size_t>(dt_frames_ + 1), kNaN);
    seen_t_.fill(-std::numeric_limits<double>::infinity());
    reset();
  }

  void reset() noexcept override {
    stream_.reset();
    have_grid_ = false;
    have_model_frame_ = false;
    have_den_prev_ = false;
    last_t_ = std::numeric_limits<double>::quiet_NaN();
    last_valid_t_ = -std::numeric_limits<double>::infinity();
    seen_t_.fill(-std::numeric_limits<double>::infinity());
  }

  bool push(double t, const Pose& observed) noexcept override {
    if (!std::isfinite(t) || (!std::isnan(last_t_) && t <= last_t_)) return false;
    last_t_ = t;
    bool any = false;
    for (int j = 0; j < n_; ++j) {
      const bool ok = std::isfinite(observed(j, 0)) && std::isfinite(observed(j, 1)) && std::isfinite(observed(j, 2));
      for (int c = 0; c < 3; ++c) cur_[static_cast<size_t>(3 * j + c)] = ok ? static_cast<float>(observed(j, c)) : kNaN;
      if (ok) seen_t_[static_cast<size_t>(j)] = t;
      any = any || ok;
    }
    if (!any) return true;  // hand lost in this frame: nothing to resample
    // A tracking gap longer than kStgaeGapResetS: the history no longer describes the hand.
    if (have_grid_ && t - last_valid_t_ > kStgaeGapResetS) {
      stream_.reset();
      have_grid_ = false;
      have_model_frame_ = false;
      have_den_prev_ = false;
    }
    last_valid_t_ = t;
    if (!have_grid_) {
      grid_t0_ = t;  // the grid starts at the first sample
      ticks_ = 0;
      tick_ = t;
      push_frame(cur_, t);
      prev_ = cur_;
      prev_t_ = t;
      have_grid_ = true;
      return true;
    }
    // Every grid tick in (prev_t_, t] gets the linearly interpolated frame. Ticks are
    // t0 + k * period (no accumulated rounding), and a tick up to 1 us after t counts as
    // at t: input on the model grid, written with rounded times (e.g. 1/30 s to 9
    // decimals), must give the tick's frame now, not one row later (which would turn every
    // answer into a one-period extrapolation).
    constexpr double kTickToleranceS = 1e-6;
    while (grid_t0_ + static_cast<double>(ticks_ + 1) * period_ <= t + kTickToleranceS) {
      ++ticks_;
      tick_ = grid_t0_ + static_cast<double>(ticks_) * period_;
      const double a = std::clamp((tick_ - prev_t_) / (t - prev_t_), 0.0, 1.0);
      for (int j = 0; j < n_; ++j) {
        const auto o = static_cast<size_t>(3 * j);
        const bool pv = !std::isnan(prev_[o]), cv = !std::isnan(cur_[o]);
        for (int c = 0; c < 3; ++c) {
          const size_t i = o + static_cast<size_t>(c);
          if (pv && cv) interp_[i] = static_cast<float>(static_cast<double>(prev_[i]) + a * static_cast<double>(cur_[i] - prev_[i]));
          else interp_[i] = a < 0.5 ? prev_[i] : cur_[i];  // the nearer sample (NaN if it misses the joint)
        }
      }
      push_frame(interp_, tick_);
    }
    prev_ = cur_;
    prev_t_ = t;
    return true;
  }

  void estimate(double t, Pose& out) const noexcept override {
    out = untracked_pose();
    if (!have_model_frame_ || std::isnan(last_t_)) return;
    const double tq = std::max(t, last_t_);
    // Position along the path [denoised at model_t_, predicted 0, 1, ...] in model periods.
    const double s = (tq - model_t_) / period_;
    const auto fs = static_cast<size_t>(3 * n_);
    for (int j = 0; j < n_; ++j) {
      if (last_t_ - seen_t_[static_cast<size_t>(j)] > kStgaeGapResetS) continue;  // expired / never seen
      for (int c = 0; c < 3; ++c) {
        const size_t i = static_cast<size_t>(3 * j + c);
        double v;
        if (dt_frames_ > 0) {
          // Piecewise linear through the points; beyond the last one, its last segment continues.
          const int last = dt_frames_;
          const int seg = std::clamp(static_cast<int>(std::floor(s)), 0, last - 1);
          const double f = s - seg;
          const auto p0 = static_cast<double>(path_[static_cast<size_t>(seg) * fs + i]);
          const auto p1 = static_cast<double>(path_[static_cast<size_t>(seg + 1) * fs + i]);
          v = p0 + f * (p1 - p0);
        } else {
          // Denoise only: the trend of the last two denoised frames, at most one period ahead.
          const auto d = static_cast<double>(path_[i]);
          const double slope = have_den_prev_ ? d - static_cast<double>(den_prev_[i]) : 0.0;
          v = d + std::min(s, 1.0) * slope;
        }
        out(j, c) = v;
      }
    }
  }

  double last_time() const noexcept override { return last_t_; }

 private:
  void push_frame(const std::vector<float>& frame, double t) noexcept {
    if (have_model_frame_) {
      for (size_t i = 0; i < den_prev_.size(); ++i) den_prev_[i] = path_[i];
      have_den_prev_ = true;
    }
    if (!stream_.push(std::span<const float>(frame.data(), frame.size()))) return;
    const auto den = stream_.denoised();
    std::copy(den.begin(), den.end(), path_.begin());
    for (int i = 0; i < dt_frames_; ++i) {
      const auto p = stream_.predicted(i);
      std::copy(p.begin(), p.end(), path_.begin() + static_cast<std::ptrdiff_t>((static_cast<size_t>(i) + 1) * p.size()));
    }
    model_t_ = t;
    have_model_frame_ = true;
  }

  std::shared_ptr<const StgaeModel> model_;
  StgaeStream<float> stream_;
  int n_ = 0, dt_frames_ = 0;
  double period_ = 1.0 / 30.0;
  std::vector<float> prev_, cur_, interp_, den_prev_, path_;
  std::array<double, kJointCount> seen_t_{};
  bool have_grid_ = false, have_model_frame_ = false, have_den_prev_ = false;
  double grid_t0_ = 0.0, tick_ = 0.0, prev_t_ = 0.0, model_t_ = 0.0;
  long ticks_ = 0;
  double last_t_ = std::numeric_limits<double>::quiet_NaN();
  double last_valid_t_ = 0.0;
};

}  // namespace

std::unique_ptr<PoseFilter> make_stgae_filter(std::shared_ptr<const StgaeModel> model, double horizon_s) {
  if (!model || !model->net) throw std::invalid_argument("make_stgae_filter: no model");
  if (model->config.padding != StgaePadding::Causal)
    throw std::invalid_argument("make_stgae_filter: streaming needs a causal model (this one is centred)");
  if (!(horizon_s >= 0.0) || !std::isfinite(horizon_s))
    throw std::invalid_argument("make_stgae_filter: the horizon must be >= 0 s");
  return std::make_unique<StgaeFilter>(std::move(model));
}

}  // namespace hs
