#pragma once
// Every method behind one interface: push timestamped poses (joints may be missing), ask
// for the estimate at any time >= the last input. One FilterConfig names the method and
// carries its parameters, classical (raw, One Euro, DESP, Kalman) or learned (Multi-STGAE:
// stgae_filter.hpp streams it, stgae_offline.hpp runs a centred model in window mode);
// make_filter builds any streaming one. The CLI, the layer, the demo and the benchmark
// all choose their method this way.
// Real-time safe: push/estimate never allocate, never throw.
// Equations, defaults and the handling of gaps: docs/FILTERS.md.
#include "handsteady/gap_policy.hpp"
#include "handsteady/track.hpp"

#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace hs {

struct StgaeModel;  // stgae_model.hpp

// What push() accepts: a finite time after the last accepted one (last NaN: none yet).
inline bool is_next_time(double t, double last) noexcept {
  return std::isfinite(t) && (std::isnan(last) || t > last);
}

class PoseFilter {
 public:
  virtual ~PoseFilter() = default;
  // Forgets everything: the next row starts a new hand.
  virtual void reset() noexcept = 0;
  // Tracking of the same hand resumes (after a gap, or somewhere else): forgets the motion
  // but keeps what it learnt of the hand itself (the palm fit's template, which the new
  // take's first rows check). The same as reset() for a method that learns
  // nothing of the hand. A filter does the same by itself when a tracked row comes more
  // than kModelResetGapS after the last tracked one (untracked rows between do not count).
  virtual void restart() noexcept { reset(); }
  // Feeds one observation. Returns false and leaves the state untouched when t is not
  // finite or not after the last accepted time. NaN rows = joints missing in this frame;
  // non-finite coordinates are treated as missing.
  virtual bool push(double t, const Pose& observed) noexcept = 0;
  // Estimate at time t (t < last input time is treated as the last input time).
  // Joints never observed since reset are NaN.
  // Joints whose last observation is more than FilterConfig::max_gap_s older than the
  // last input time are NaN too (their state has expired: they re-initialise when seen again).
  virtual void estimate(double t, Pose& out) const noexcept = 0;
  // Last accepted time, or NaN before the first push.
  virtual double last_time() const noexcept = 0;
};

// Smoothing factor of a first-order low-pass with cutoff cutoff_hz at sample interval te
// (One Euro's, and the layer's velocity estimate).
double low_pass_alpha(double cutoff_hz, double te) noexcept;

// Stgae and Dgn are the network methods: a model file of that family (StgaeConfig::family;
// Multi-STGAE and its denoise-only STGAE models are "stgae") run by the same engine.
enum class FilterMethod { Raw, OneEuro, Desp, Kalman, Stgae, Dgn };
inline constexpr std::array<FilterMethod, 6> kFilterMethods = {FilterMethod::Raw,    FilterMethod::OneEuro,
                                                               FilterMethod::Desp,   FilterMethod::Kalman,
                                                               FilterMethod::Stgae,  FilterMethod::Dgn};
// "raw", "oneeuro", "desp", "kalman", "stgae", "dgn"; throws std::invalid_argument otherwise.
FilterMethod parse_filter_method(std::string_view name);
std::string_view filter_method_name(FilterMethod m);
constexpr bool is_network(FilterMethod m) noexcept { return m == FilterMethod::Stgae || m == FilterMethod::Dgn; }
// The network method that runs a model of this family.
FilterMethod network_method(const StgaeModel& model) noexcept;
// The shipped model a network method loads when no model file is given (model_path.hpp).
std::string_view default_model_file(FilterMethod m) noexcept;

// Defaults are tuned lightly for hand tracking (metres, ~30 Hz, a few mm of jitter);
// see docs/FILTERS.md.
struct OneEuroParams {
  double min_cutoff_hz = 1.0;
  double beta = 5.0;          // s/m: cutoff grows by beta * speed (speed in m/s)
  double d_cutoff_hz = 1.0;
  // true: one cutoff per joint from the norm of the 3D derivative (Monado's variant);
  // false: an independent filter per coordinate (the original paper).
  bool vec3 = true;
  // One Euro does not predict: estimate(t) is the filtered value at the last
  // observation. true: extrapolate linearly with the filtered derivative instead.
  bool extrapolate = false;
};
struct DespParams {
  double alpha = 0.5;       // smoothing per sample period, in (0, 1)
  double period_s = 0.0;    // 0: the running mean of observed input periods
};
struct KalmanParams {
  double meas_sd_m = 0.005;         // measurement noise
  double accel_psd = 1.0;           // white-acceleration noise q (m^2/s^3)
  double init_speed_sd_mps = 1.0;   // prior sd of the velocity at (re)initialisation
};

// The network methods (docs/STGAE.md, docs/DGN.md): the model's family must be the
// method's (network_method). Streaming needs a causal model; window mode (`offline`) a
// centred one, and runs over a whole recording (filter_series_with), not as a PoseFilter.
struct StgaeParams {
  std::shared_ptr<const StgaeModel> model;  // required
  std::string source;  // the file it came from (for the summary)
  // Causal models of the same family at other frame rates (distinct from model's and each
  // other's): each input then runs the model whose rate suits it (rate_choice.hpp), model
  // answering until the rate is known. Empty: model alone, at every rate.
  std::vector<std::shared_ptr<const StgaeModel>> rate_models;
  int phases = 0;      // interleaved streams; 0 = input rate / model rate (stgae_filter.hpp)
  bool bounded = true; // false: the network's own answer, without the trust region
  // With bounded: keep only the share of the correction the input's next rows confirm
  // (correction_gain.hpp). Unset (auto): where the noise is measured at the input rate (K >=
  // 2 streams, or one stream on rows slower than the model); true: at every rate (at one
  // stream at the model's rate it gives up the removal of a slow tremor); false: never.
  std::optional<bool> gain;
  bool smooth = false;  // with bounded: predicted displacements smoothed over time (prediction_smoothing.hpp;
                        // opt-in: ~40 % less jitter in the predictions for a few % more error)
  bool guard = true;    // with bounded: the whole hand shaken no more than the input (oscillation_guard.hpp)
  bool offline = false;
};

struct FilterConfig {
  FilterMethod method = FilterMethod::OneEuro;
  OneEuroParams oneeuro;
  DespParams desp;
  KalmanParams kalman;
  StgaeParams stgae;
  // Fit the hand's rigid palm to each row's palm joints before the method sees it
  // (palm_fit.hpp; any method). Unset: on for the network methods (part of their shipped
  // pipeline, with the trust region), off for the classical ones (the baselines).
  std::optional<bool> palm_fit;
  // Move each answer's finger joints towards the bone lengths learnt from the method's
  // answers (bone_fit.hpp; any method). Unset: on for the network methods, off for the
  // classical ones (the baselines).
  std::optional<bool> bone_fit;
  // Cancel quasi-periodic tremor (3.5-12.5 Hz) before the method sees the row, behind the
  // palm fit (tremor_cancel.hpp; any method; opt-in).
  bool tremor_cancel = false;
  // A joint unseen for longer than this (relative to the last input) has no estimate
  // and re-initialises when it reappears (classical methods; the network forgets after
  // kModelResetGapS).
  double max_gap_s = kFilterForgetGapS;
};

// A streaming filter for any method. Throws std::invalid_argument naming the parameter
// when a parameter is out of range, the model is missing or cannot stream, or for
// window mode (stgae.offline: use filter_series_with).
std::unique_ptr<PoseFilter> make_filter(const FilterConfig& config);
// Whether make_filter puts the palm fit in front of the method (config.palm_fit, or its
// default; never for window mode).
bool palm_fit_on(const FilterConfig& config) noexcept;
// Any filter behind the palm fit (what make_filter does when palm_fit_on).
std::unique_ptr<PoseFilter> with_palm_fit(std::unique_ptr<PoseFilter> filter);

// Whether make_filter puts the bone fit behind the method (config.bone_fit, or its
// default; never for window mode).
bool bone_fit_on(const FilterConfig& config) noexcept;
// Any filter with the bone fit behind it (what make_filter does when bone_fit_on).
std::unique_ptr<PoseFilter> with_bone_fit(std::unique_ptr<PoseFilter> filter);

// Any filter behind the tremor canceller (what make_filter does when config.tremor_cancel).
std::unique_ptr<PoseFilter> with_tremor_cancel(std::unique_ptr<PoseFilter> filter);

// The parameters that matter for config.method, "key=value" separated by spaces, e.g.
// "mincutoff=1 beta=5 dcutoff=1 vec3=1 extrapolate=0 max_gap_ms=500" (used for track metadata).
std::string filter_params_summary(const FilterConfig& config);

// Runs a filter causally over one hand: for row i, push (t_i, pos_i) then estimate at
// t_i + horizon_s. Rows where the hand is not tracked stay untracked; in tracked rows a
// missing joint gets the filter's estimate when it has one (else stays NaN).
// With skip_stale (opt-in, CLI `--skip-repeats`), a row that repeats a row that moved
// (repeated_pose, track.hpp) is taken for a runtime's stale answer, not a sample, as the
// OpenXR layer takes it: it is not pushed, and is answered from the estimate at its time.
// One repeat only: a second in a row is pushed, so a hand that stops is held, not
// extrapolated, and a still hand's rows are samples as always. Off by default: a tracker
// that holds its last pose before it loses a fast hand (the HoloLens 2 recordings) is
// then extrapolated on, and a recording cannot say which it was (docs/FILTERS.md).
// The filter is reset first.
HandSeries filter_series(PoseFilter& filter, const HandSeries& series, double horizon_s, bool skip_stale = false);
// The same for several horizons in one pass: one output per horizon, all from the same
// filter states (row i's answers at t_i + h for each h).
std::vector<HandSeries> filter_series(PoseFilter& filter, const HandSeries& series, std::span<const double> horizons_s,
                                      bool skip_stale = false);
// One hand through any method: a streaming filter made for it (filter_series above), or
// a centred model's window mode (stgae.offline, stgae_offline.hpp). Throws as make_filter.
HandSeries filter_series_with(const FilterConfig& config, const HandSeries& series, double horizon_s,
                              bool skip_stale = false);

}  // namespace hs
