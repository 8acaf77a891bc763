// Classical per-joint filters (raw hold, One Euro, DESP, constant-velocity Kalman)
// behind hs::PoseFilter. Equations and choices: docs/FILTERS.md.
//
// All state lives in fixed-size arrays (kJointCount joints x 3 coordinates) so that
// push/estimate never allocate; the parameters are validated once in make_filter so that
// push/estimate have no failure path besides rejecting a bad timestamp.
#include "handsteady/filters.hpp"

#include "handsteady/model_path.hpp"
#include "handsteady/bone_fit.hpp"
#include "handsteady/palm_fit.hpp"
#include "handsteady/rate_choice.hpp"
#include "handsteady/tremor_cancel.hpp"

#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/stgae_offline.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace hs {

namespace {

using Vec3 = Eigen::Vector3d;

// Shared bookkeeping: timestamp checks, per-joint time of last observation, gap expiry.
// Derived supplies init_joint(j, x), update_joint(j, dt, x), predict_joint(j, dt) -> Vec3
// (dt measured from the joint's last observation), on_frame(frame_dt) and clear_state().
template <class Derived>
class JointwiseFilter : public PoseFilter {
 public:
  explicit JointwiseFilter(double max_gap_s) : max_gap_s_(max_gap_s) { clear_common(); }

  void reset() noexcept override {
    clear_common();
    derived().clear_state();
  }

  bool push(double t, const Pose& observed) noexcept override {
    if (!is_next_time(t, last_t_)) return false;
    const bool has_time = !std::isnan(last_t_);
    derived().on_frame(has_time ? t - last_t_ : kNaN);
    for (int j = 0; j < kJointCount; ++j) {
      if (!joint_finite(observed, j)) continue;  // missing joint: keep its state
      const Vec3 x = observed.row(j).transpose();
      const double dt = t - t_obs_[j];
      if (!seen_[j] || dt > max_gap_s_) {
        derived().init_joint(j, x);
      } else {
        derived().update_joint(j, dt, x);
      }
      seen_[j] = true;
      t_obs_[j] = t;
    }
    last_t_ = t;
    return true;
  }

  void estimate(double t, Pose& out) const noexcept override {
    // Earlier (or non-finite) requests mean "now": filters never look back in time.
    const double te = (std::isfinite(t) && t > last_t_) ? t : last_t_;
    for (int j = 0; j < kJointCount; ++j) {
      if (!seen_[j] || last_t_ - t_obs_[j] > max_gap_s_) {
        out.row(j).setConstant(kNaN);
      } else {
        out.row(j) = derived().predict_joint(j, te - t_obs_[j]).transpose();
      }
    }
  }

  double last_time() const noexcept override { return last_t_; }

 protected:
  double max_gap_s() const { return max_gap_s_; }

 private:
  Derived& derived() { return static_cast<Derived&>(*this); }
  const Derived& derived() const { return static_cast<const Derived&>(*this); }
  void clear_common() {
    last_t_ = kNaN;
    seen_.fill(false);
    t_obs_.fill(kNaN);
  }

  double max_gap_s_;
  double last_t_ = kNaN;
  std::array<bool, kJointCount> seen_{};
  std::array<double, kJointCount> t_obs_{};
};

// ---- raw: hold the last observation ----------------------------------------------------
class RawFilter final : public JointwiseFilter<RawFilter> {
 public:
  explicit RawFilter(double max_gap_s) : JointwiseFilter(max_gap_s) {}
  void clear_state() {}
  void on_frame(double) {}
  void init_joint(int j, const Vec3& x) { x_[j] = x; }
  void update_joint(int j, double, const Vec3& x) { x_[j] = x; }
  Vec3 predict_joint(int j, double) const { return x_[j]; }

 private:
  std::array<Vec3, kJointCount> x_{};
};

// ---- One Euro (Casiez et al. 2012) ------------------------------------------------------
class OneEuroFilter final : public JointwiseFilter<OneEuroFilter> {
 public:
  OneEuroFilter(const OneEuroParams& p, double max_gap_s) : JointwiseFilter(max_gap_s), p_(p) {}
  void clear_state() {}
  void on_frame(double) {}
  void init_joint(int j, const Vec3& x) {
    x_[j] = x;
    dx_[j].setZero();
  }
  void update_joint(int j, double te, const Vec3& x) {
    // Derivative against the previous *filtered* value (reference implementation since 2023).
    const double ad = low_pass_alpha(p_.d_cutoff_hz, te);
    dx_[j] = ad * (x - x_[j]) / te + (1.0 - ad) * dx_[j];
    if (p_.vec3) {
      const double a = low_pass_alpha(p_.min_cutoff_hz + p_.beta * dx_[j].norm(), te);
      x_[j] = a * x + (1.0 - a) * x_[j];
    } else {
      for (int k = 0; k < 3; ++k) {
        const double a = low_pass_alpha(p_.min_cutoff_hz + p_.beta * std::abs(dx_[j][k]), te);
        x_[j][k] = a * x[k] + (1.0 - a) * x_[j][k];
      }
    }
  }
  Vec3 predict_joint(int j, double dt) const { return p_.extrapolate ? Vec3(x_[j] + dt * dx_[j]) : x_[j]; }

 private:
  OneEuroParams p_;
  std::array<Vec3, kJointCount> x_{};
  std::array<Vec3, kJointCount> dx_{};
};

// ---- DESP (LaViola 2003) -----------------------------------------------------------------
// One update per input sample with a fixed alpha (alpha is "per sample period"); the
// prediction horizon is converted to sample periods with the nominal period.
class DespFilter final : public JointwiseFilter<DespFilter> {
 public:
  DespFilter(const DespParams& p, double max_gap_s) : JointwiseFilter(max_gap_s), p_(p) {}
  void clear_state() {
    period_sum_ = 0.0;
    period_count_ = 0;
  }
  void on_frame(double frame_dt) {
    // Gaps (hand lost) would inflate the mean period; they re-initialise joints anyway.
    if (std::isfinite(frame_dt) && frame_dt <= max_gap_s()) {
      period_sum_ += frame_dt;
      ++period_count_;
    }
  }
  void init_joint(int j, const Vec3& x) {
    s_[j] = x;
    s2_[j] = x;
  }
  void update_joint(int j, double, const Vec3& x) {
    s_[j] = p_.alpha * x + (1.0 - p_.alpha) * s_[j];
    s2_[j] = p_.alpha * s_[j] + (1.0 - p_.alpha) * s2_[j];
  }
  Vec3 predict_joint(int j, double dt) const {
    const double period = nominal_period();
    // Without a known period only one sample has been seen, where S == S2 and tau is moot.
    const double tau = period > 0.0 ? dt / period : 0.0;
    const double k = p_.alpha * tau / (1.0 - p_.alpha);
    return (2.0 + k) * s_[j] - (1.0 + k) * s2_[j];
  }
  double nominal_period() const {
    if (p_.period_s > 0.0) return p_.period_s;
    return period_count_ > 0 ? period_sum_ / static_cast<double>(period_count_) : 0.0;
  }

 private:
  DespParams p_;
  double period_sum_ = 0.0;
  long period_count_ = 0;
  std::array<Vec3, kJointCount> s_{};
  std::array<Vec3, kJointCount> s2_{};
};

// ---- constant-velocity Kalman, per axis ----------------------------------------------------
// The three axes of a joint share dt, H, Q and R, so their 2x2 covariances are identical:
// one covariance per joint is stored and updated.
class KalmanFilter final : public JointwiseFilter<KalmanFilter> {
 public:
  KalmanFilter(const KalmanParams& p, double max_gap_s)
      : JointwiseFilter(max_gap_s), p_(p), r_(p.meas_sd_m * p.meas_sd_m) {}
  void clear_state() {}
  void on_frame(double) {}
  void init_joint(int j, const Vec3& x) {
    pos_[j] = x;
    vel_[j].setZero();
    cov_[j] = {r_, 0.0, p_.init_speed_sd_mps * p_.init_speed_sd_mps};
  }
  void update_joint(int j, double dt, const Vec3& x) {
    // Predict: F = [[1, dt], [0, 1]], Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]].
    pos_[j] += dt * vel_[j];
    Cov& c = cov_[j];
    const double q = p_.accel_psd;
    const double p00 = c.pp + 2.0 * dt * c.pv + dt * dt * c.vv + q * dt * dt * dt / 3.0;
    const double p01 = c.pv + dt * c.vv + q * dt * dt / 2.0;
    const double p11 = c.vv + q * dt;
    // Update with H = [1, 0].
    const double s = p00 + r_;
    const double k0 = p00 / s;
    const double k1 = p01 / s;
    const Vec3 innovation = x - pos_[j];
    pos_[j] += k0 * innovation;
    vel_[j] += k1 * innovation;
    c = {(1.0 - k0) * p00, (1.0 - k0) * p01, p11 - k1 * p01};
  }
  Vec3 predict_joint(int j, double dt) const { return pos_[j] + dt * vel_[j]; }

 private:
  struct Cov {
    double pp = 0.0, pv = 0.0, vv = 0.0;
  };
  KalmanParams p_;
  double r_;
  std::array<Vec3, kJointCount> pos_{};
  std::array<Vec3, kJointCount> vel_{};
  std::array<Cov, kJointCount> cov_{};
};

// A stage that rewrites each row before the method sees it, learnt per hand: the palm fit
// (palm_fit.hpp: the palm joints fitted to the hand's rigid palm) or the tremor canceller
// (tremor_cancel.hpp). A tracking gap (kModelResetGapS without a tracked row, whatever
// untracked rows come between: gap_policy.hpp) starts a new take: the palm fit keeps its
// template, which the take's first rows check (the same person's hand usually comes
// back); the canceller starts anew (its oscillator's phase does not carry over a gap).
// The gap rule of gap_policy.hpp for a stage: a tracked row more than kModelResetGapS after
// the last tracked one (untracked rows between do not count) starts a new take.
class TakeClock {
 public:
  // For a tracked row at t: whether it starts a new take (never the first since clear()).
  bool starts_take(double t) noexcept {
    const bool gap = t - last_tracked_ > kModelResetGapS;  // false while last_tracked_ is NaN
    last_tracked_ = t;
    return gap;
  }
  void clear() noexcept { last_tracked_ = kNaN; }

 private:
  double last_tracked_ = kNaN;  // the last tracked row (NaN: none since clear())
};

inline void apply_stage(PalmFit& fit, double, Pose& row) noexcept { fit.apply(row); }
inline void apply_stage(TremorCancel& cancel, double t, Pose& row) noexcept { cancel.apply(t, row); }
inline void resume_stage(PalmFit& fit) noexcept { fit.resume(); }
inline void resume_stage(TremorCancel& cancel) noexcept { cancel.reset(); }

template <class Stage>
class StageFilter final : public PoseFilter {
 public:
  explicit StageFilter(std::unique_ptr<PoseFilter> inner) : inner_(std::move(inner)) {}
  void reset() noexcept override {
    stage_.reset();
    inner_->reset();
    takes_.clear();
  }
  void restart() noexcept override {
    resume_stage(stage_);
    inner_->restart();
    takes_.clear();
  }
  bool push(double t, const Pose& observed) noexcept override {
    if (!is_next_time(t, inner_->last_time())) return false;  // the stage learns from no row the filter refuses
    if (any_joint_finite(observed) && takes_.starts_take(t)) resume_stage(stage_);
    row_ = observed;
    apply_stage(stage_, t, row_);
    return inner_->push(t, row_);
  }
  void estimate(double t, Pose& out) const noexcept override { inner_->estimate(t, out); }
  double last_time() const noexcept override { return inner_->last_time(); }

 private:
  std::unique_ptr<PoseFilter> inner_;
  Stage stage_;
  Pose row_ = untracked_pose();
  TakeClock takes_;
};

// The bone fit (bone_fit.hpp) behind a method: it learns from the method's answer at each
// tracked row it accepts and moves every answer's finger joints, at any time asked, a joint
// missing from the last row giving way first. A tracking gap (gap_policy.hpp) starts a take,
// as for the stages in front (BoneFit::resume: the lengths learnt anew, the noise kept).
class BoneFitFilter final : public PoseFilter {
 public:
  explicit BoneFitFilter(std::unique_ptr<PoseFilter> inner) : inner_(std::move(inner)) {}
  void reset() noexcept override {
    fit_.reset();
    inner_->reset();
    takes_.clear();
  }
  void restart() noexcept override {
    fit_.resume();
    inner_->restart();
    takes_.clear();
  }
  bool push(double t, const Pose& observed) noexcept override {
    if (!inner_->push(t, observed)) return false;
    if (!any_joint_finite(observed)) return true;  // the method's answer without a row holds or predicts: nothing to learn
    if (takes_.starts_take(t)) fit_.resume();
    for (int j = 0; j < kJointCount; ++j) observed_[size_t(j)] = joint_finite(observed, j);
    inner_->estimate(t, answer_);
    fit_.learn(t, answer_);
    return true;
  }
  void estimate(double t, Pose& out) const noexcept override {
    inner_->estimate(t, out);
    fit_.apply(out, &observed_);
  }
  double last_time() const noexcept override { return inner_->last_time(); }

 private:
  std::unique_ptr<PoseFilter> inner_;
  BoneFit fit_;
  JointMask observed_{};  // the joints of the last tracked row
  Pose answer_ = untracked_pose();
  TakeClock takes_;
};

void require(bool ok, std::string_view what, double value) {
  if (!ok) throw std::invalid_argument(fmt::format("{}, got {}", what, value));
}

}  // namespace

double low_pass_alpha(double cutoff_hz, double te) noexcept {
  const double tau = 1.0 / (2.0 * std::numbers::pi * cutoff_hz);
  return 1.0 / (1.0 + tau / te);
}

FilterMethod parse_filter_method(std::string_view name) {
  for (FilterMethod m : kFilterMethods) {
    if (name == filter_method_name(m)) return m;
  }
  throw std::invalid_argument(fmt::format("unknown filter method '{}' (raw, oneeuro, desp, kalman, stgae, dgn)", name));
}

std::string_view filter_method_name(FilterMethod m) {
  switch (m) {
    case FilterMethod::Raw: return "raw";
    case FilterMethod::OneEuro: return "oneeuro";
    case FilterMethod::Desp: return "desp";
    case FilterMethod::Kalman: return "kalman";
    case FilterMethod::Stgae: return "stgae";
    case FilterMethod::Dgn: return "dgn";
  }
  return "unknown";
}

std::string_view default_model_file(FilterMethod m) noexcept {
  return m == FilterMethod::Dgn ? kDgnModelFile : kDefaultModelFile;
}

FilterMethod network_method(const StgaeModel& model) noexcept {
  return model.config.family == StgaeFamily::Dgn ? FilterMethod::Dgn : FilterMethod::Stgae;
}

namespace {
// The network's streaming filter: one adapter, or one per model rate behind the choice by
// input rate (rate_choice.hpp). Every model must be of the method's family.
std::unique_ptr<PoseFilter> make_network_filter(const FilterConfig& c) {
  const StgaeParams& p = c.stgae;
  if (p.offline)
    throw std::invalid_argument("network window mode (offline) runs over a whole recording, not as a streaming filter");
  // Every model it runs must be of the method's family (`which` names it in the error).
  const auto require_family = [&](const StgaeModel& m, const std::string& which) {
    if (network_method(m) != c.method)
      throw std::invalid_argument(fmt::format("method {} needs models of its family; {} is a {} model",
                                              filter_method_name(c.method), which,
                                              filter_method_name(network_method(m))));
  };
  if (p.model) require_family(*p.model, p.source);
  // The bone fit behind each model's adapter, so that each learns from its own model's
  // answers (an input gets exactly the answers of its model alone).
  const auto adapter = [&](const std::shared_ptr<const StgaeModel>& m) {
    auto f = make_stgae_filter(m, 0.0, p.phases, p.bounded, p.gain, p.smooth, p.guard);
    return bone_fit_on(c) ? with_bone_fit(std::move(f)) : std::move(f);
  };
  if (p.rate_models.empty()) return adapter(p.model);
  if (!p.model) throw std::invalid_argument("network method: rate models need a model to pair with");
  std::vector<RateFilter> by_rate;
  by_rate.push_back({p.model->config.rate_hz, adapter(p.model)});
  for (size_t i = 0; i < p.rate_models.size(); ++i) {
    const auto& m = p.rate_models[i];
    if (!m) throw std::invalid_argument("network method: rate model " + std::to_string(i + 1) + " is missing");
    require_family(*m, "rate model " + std::to_string(i + 1));
    by_rate.push_back({m->config.rate_hz, adapter(m)});
  }
  return make_rate_chosen_filter(std::move(by_rate));
}

std::unique_ptr<PoseFilter> make_method_filter(const FilterConfig& c) {
  switch (c.method) {
    case FilterMethod::Raw:
      return std::make_unique<RawFilter>(c.max_gap_s);
    case FilterMethod::OneEuro: {
      const OneEuroParams& p = c.oneeuro;
      require(p.min_cutoff_hz > 0.0 && std::isfinite(p.min_cutoff_hz), "One Euro mincutoff must be positive (Hz)",
              p.min_cutoff_hz);
      require(p.beta >= 0.0 && std::isfinite(p.beta), "One Euro beta must be >= 0", p.beta);
      require(p.d_cutoff_hz > 0.0 && std::isfinite(p.d_cutoff_hz), "One Euro dcutoff must be positive (Hz)",
              p.d_cutoff_hz);
      return std::make_unique<OneEuroFilter>(p, c.max_gap_s);
    }
    case FilterMethod::Desp: {
      const DespParams& p = c.desp;
      require(p.alpha > 0.0 && p.alpha < 1.0, "DESP alpha must be in (0, 1)", p.alpha);
      require(p.period_s >= 0.0 && std::isfinite(p.period_s), "DESP period must be >= 0 (0 = observed mean)",
              p.period_s);
      return std::make_unique<DespFilter>(p, c.max_gap_s);
    }
    case FilterMethod::Kalman: {
      const KalmanParams& p = c.kalman;
      require(p.meas_sd_m > 0.0 && std::isfinite(p.meas_sd_m), "Kalman measurement sd must be positive (m)",
              p.meas_sd_m);
      require(p.accel_psd > 0.0 && std::isfinite(p.accel_psd), "Kalman acceleration PSD must be positive",
              p.accel_psd);
      require(p.init_speed_sd_mps > 0.0 && std::isfinite(p.init_speed_sd_mps),
              "Kalman initial speed sd must be positive (m/s)", p.init_speed_sd_mps);
      return std::make_unique<KalmanFilter>(p, c.max_gap_s);
    }
    case FilterMethod::Stgae:
    case FilterMethod::Dgn:
      return make_network_filter(c);
  }
  throw std::invalid_argument("unknown filter method");
}
}  // namespace

std::unique_ptr<PoseFilter> make_filter(const FilterConfig& c) {
  require(c.max_gap_s > 0.0 && std::isfinite(c.max_gap_s), "max gap must be positive", c.max_gap_s);
  auto f = make_method_filter(c);
  if (bone_fit_on(c) && !is_network(c.method)) f = with_bone_fit(std::move(f));  // the networks': behind each model
  if (c.tremor_cancel) f = with_tremor_cancel(std::move(f));
  return palm_fit_on(c) ? with_palm_fit(std::move(f)) : std::move(f);
}

std::unique_ptr<PoseFilter> with_tremor_cancel(std::unique_ptr<PoseFilter> filter) {
  return std::make_unique<StageFilter<TremorCancel>>(std::move(filter));
}

bool palm_fit_on(const FilterConfig& c) noexcept {
  if (is_network(c.method) && c.stgae.offline) return false;  // window mode has none
  return c.palm_fit.value_or(is_network(c.method));
}

bool bone_fit_on(const FilterConfig& c) noexcept {
  if (is_network(c.method) && c.stgae.offline) return false;  // window mode has none
  return c.bone_fit.value_or(is_network(c.method));
}

std::unique_ptr<PoseFilter> with_bone_fit(std::unique_ptr<PoseFilter> filter) {
  return std::make_unique<BoneFitFilter>(std::move(filter));
}

std::unique_ptr<PoseFilter> with_palm_fit(std::unique_ptr<PoseFilter> filter) {
  return std::make_unique<StageFilter<PalmFit>>(std::move(filter));
}

// " rate_models=90" (their rates, comma-separated), or nothing.
static std::string rate_models_summary(const StgaeParams& p) {
  if (p.rate_models.empty()) return "";
  std::string s = " rate_models=";
  for (size_t i = 0; i < p.rate_models.size(); ++i)
    s += (i ? "," : "") + (p.rate_models[i] ? fmt::format("{}", p.rate_models[i]->config.rate_hz) : std::string("?"));
  return s;
}

std::string filter_params_summary(const FilterConfig& c) {
  const std::string fit = std::string(palm_fit_on(c) ? " palm_fit=1" : "") + (bone_fit_on(c) ? " bone_fit=1" : "") +
                          (c.tremor_cancel ? " tremor_cancel=1" : "");
  std::string s;
  switch (c.method) {
    case FilterMethod::Raw:
      break;
    case FilterMethod::OneEuro:
      s = fmt::format("mincutoff={} beta={} dcutoff={} vec3={:d} extrapolate={:d} ", c.oneeuro.min_cutoff_hz,
                      c.oneeuro.beta, c.oneeuro.d_cutoff_hz, c.oneeuro.vec3, c.oneeuro.extrapolate);
      break;
    case FilterMethod::Desp:
      s = c.desp.period_s > 0.0 ? fmt::format("alpha={} period_ms={} ", c.desp.alpha, c.desp.period_s * 1e3)
                                : fmt::format("alpha={} period_ms=auto ", c.desp.alpha);
      break;
    case FilterMethod::Kalman:
      s = fmt::format("meas_sd_mm={} accel_psd={} init_speed_sd_mps={} ", c.kalman.meas_sd_m * 1e3,
                      c.kalman.accel_psd, c.kalman.init_speed_sd_mps);
      break;
    case FilterMethod::Stgae:
    case FilterMethod::Dgn: {
      // The network forgets after kModelResetGapS, whatever max_gap_s says: no max_gap_ms.
      const StgaeParams& p = c.stgae;
      if (!p.model) return fmt::format("model={} (not loaded)", p.source);
      const StgaeConfig& m = p.model->config;
      return fmt::format("model={} rate_hz={} window={} horizon_frames={} padding={} mode={} phases={}{}{}{}{}", p.source,
                         m.rate_hz, m.window, m.predict ? m.horizon : 0,
                         m.padding == StgaePadding::Causal ? "causal" : "centred",
                         p.offline ? "offline" : "streaming", p.phases == 0 ? std::string("auto") : std::to_string(p.phases),
                         p.bounded ? "" : " unbounded", p.bounded && p.gain ? (*p.gain ? " gain" : " no-gain") : "",
                         p.bounded && p.smooth && !p.offline ? " smoothed" : "",
                         p.bounded && !p.guard && !p.offline ? " unguarded" : "") + rate_models_summary(p) + fit;
    }
  }
  return s + fmt::format("max_gap_ms={}", c.max_gap_s * 1e3) + fit;
}

std::vector<HandSeries> filter_series(PoseFilter& filter, const HandSeries& series, std::span<const double> horizons_s,
                                      bool skip_stale) {
  filter.reset();
  std::vector<HandSeries> out(horizons_s.size());
  for (HandSeries& o : out) {
    o.t = series.t;
    o.pos.resize(series.size(), untracked_pose());
  }
  const auto tracked = [&](size_t i) { return any_joint_tracked(series.pos[i]); };
  for (size_t i = 0; i < series.size(); ++i) {
    // A stale answer (the row before repeated after it moved) teaches the filter nothing;
    // pushed, it would read as the hand stopping and starting again.
    const bool stale = skip_stale && i >= 2 && tracked(i) && tracked(i - 1) && tracked(i - 2) &&
                       repeated_pose(series.pos[i], series.pos[i - 1]) &&
                       !repeated_pose(series.pos[i - 1], series.pos[i - 2]);
    const bool accepted = stale ? series.t[i] > filter.last_time() : filter.push(series.t[i], series.pos[i]);
    // Untracked rows stay untracked; a rejected timestamp has nothing new to report.
    if (!accepted || !tracked(i)) continue;
    for (size_t h = 0; h < horizons_s.size(); ++h) filter.estimate(series.t[i] + horizons_s[h], out[h].pos[i]);
  }
  return out;
}

HandSeries filter_series_with(const FilterConfig& config, const HandSeries& series, double horizon_s, bool skip_stale) {
  if (is_network(config.method) && config.stgae.offline) {
    if (skip_stale) throw std::invalid_argument("skipping stale rows streams; window mode (offline) has none");
    if (config.palm_fit.value_or(false))
      throw std::invalid_argument("the palm fit streams; window mode (offline) has none");
    if (config.tremor_cancel)
      throw std::invalid_argument("the tremor canceller streams; window mode (offline) has none");
    if (!config.stgae.model) throw std::invalid_argument("network method: no model");
    return stgae_offline_series(*config.stgae.model, series, horizon_s);
  }
  const std::unique_ptr<PoseFilter> filter = make_filter(config);
  return filter_series(*filter, series, horizon_s, skip_stale);
}

HandSeries filter_series(PoseFilter& filter, const HandSeries& series, double horizon_s, bool skip_stale) {
  return std::move(filter_series(filter, series, std::span<const double>(&horizon_s, 1), skip_stale).front());
}

}  // namespace hs
