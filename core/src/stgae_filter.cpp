// PoseFilter adapter over the streaming Multi-STGAE engine: irregular input -> model grid.
//
// Input faster than the model (a 90 Hz display over a 30 Hz model) is served by K
// interleaved streams ("phases"): one sub-grid of period 1/(K * rate), tick m going to
// stream m % K, so every stream still sees frames one model period apart, as in training,
// and each input row is answered by a freshly denoised frame instead of a prediction up
// to one model period ahead (whose error shows as a jump at every model tick).
#include "handsteady/correction_bound.hpp"
#include "handsteady/correction_gain.hpp"
#include "handsteady/input_noise.hpp"
#include "handsteady/motion_lag_cap.hpp"
#include "handsteady/oscillation_guard.hpp"
#include "handsteady/prediction_smoothing.hpp"
#include "handsteady/stgae_engine.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/time_series.hpp"
#include "interval_ring.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <vector>

namespace hs {

namespace {

// The output of one stream: the path [denoised at t, predicted 1..DT periods later].
struct PhaseOutput {
  std::vector<float> path, den_prev;
  double t = 0.0;
  bool have = false, have_prev = false;
};

class StgaeFilter final : public PoseFilter {
 public:
  StgaeFilter(std::shared_ptr<const StgaeModel> model, int phases, bool bounded, std::optional<bool> gain, bool smooth,
              bool guard)
      : model_(std::move(model)), fixed_phases_(phases), bounded_(bounded), gain_mode_(gain),
        smoothed_(bounded && smooth), guarded_(bounded && guard) {
    const auto& c = model_->config;
    n_ = c.joint_count();
    if (n_ != kJointCount) throw std::invalid_argument("the STGAE filter needs a 26-joint (xr26) model");
    period_ = 1.0 / c.rate_hz;
    dt_frames_ = c.predict ? c.horizon : 0;
    const size_t fs = static_cast<size_t>(3 * n_);
    prev_.assign(fs, kNaNf);
    cur_.assign(fs, kNaNf);
    interp_.assign(fs, kNaNf);
    for (int k = 0; k < kStgaeMaxPhases; ++k) {
      streams_[static_cast<size_t>(k)] = std::make_unique<StgaeStream<float>>(model_->net);
      auto& o = out_[static_cast<size_t>(k)];
      o.path.assign(fs * static_cast<size_t>(dt_frames_ + 1), kNaNf);
      o.den_prev.assign(fs, kNaNf);
      bounds_[static_cast<size_t>(k)] = CorrectionBound(dt_frames_ + 1);
    }
    smoother_ = PredictionSmoother(dt_frames_ + 1);
    reset();
  }

  void reset() noexcept override { reset_state(false); }
  // The same hand resumes after a tracking gap (the layer): as reset(), but the input's
  // noise keeps what it learnt of the tracker (InputNoise::resume).
  void restart() noexcept override { reset_state(true); }

  bool push(double t, const Pose& observed) noexcept override {
    if (!is_next_time(t, last_t_)) return false;
    lag_cap_.clear();
    if (!push_row(t, observed)) {  // hand lost in this frame
      guard_.clear();
      return true;
    }
    const bool gain = gaining() && latest_ >= 0;
    const bool cap = bounded_ && measured();
    // Where the gain comes back on (one stream's rows read slower than the model again), the
    // rows it saw before are not the last ones, whose future it checks: it forgets them and
    // keeps its gains, as over a tracking gap. The cap keeps its last answers (starting it
    // over there was worse at 27 Hz: docs/STGAE.md "The lag cap and the gain on slow rows").
    if (gain && !gained_last_row_) gain_.restart();
    gained_last_row_ = gain;
    const bool guard = guarded_ && latest_ >= 0;
    if (!gain && !cap && !guard) return true;
    answer(t, ans_);  // once, for all three
    if (gain) {
      // The noise is measured at the input rate where rows come between a stream's frames
      // (K >= 2) or one stream's rows are slower than the model (the trust region's
      // `measured`); elsewhere one stream's rows are its frames.
      const bool noise = measured();
      gain_.observe(t, std::span<const float>(cur_.data(), cur_.size()),
                    std::span<const double>(ans_.data(), static_cast<size_t>(ans_.size())),
                    noise ? noise_.noise2() : std::span<const double>{},
                    noise ? noise_.smooth2() : std::span<const double>{});
      // From here ans_ is the answer as it goes out, each stage's shift added for the next.
      for (int j = 0; j < n_; ++j)
        for (int c = 0; c < 3; ++c) ans_(j, c) += gain_.shift(j, c);
    }
    if (cap) {
      // The lag cap reads the answer with the gain's shift and the noise measured at the
      // input rate, which one stream's rows give only where they are slower than the model
      // (slow_rows). There a fast hand's two-row step is long enough to pass an outlier as
      // lag on a jump row unless the share is smaller (docs/STGAE.md "The lag cap and the
      // gain on slow rows").
      lag_cap_.observe(std::span<const float>(cur_.data(), cur_.size()), ans_, noise_.noise2(), noise_.jumps(),
                       noise_.stretched(), phases_ >= 2 ? kMotionCapJumpShare : kMotionCapJumpShareSlowRows);
    }
    if (guard) {
      // The guard reads it with the gain's and the cap's shifts (the cap's is zero where it does not act).
      for (int j = 0; j < n_; ++j)
        for (int c = 0; c < 3; ++c) ans_(j, c) += lag_cap_.shift(j, c);
      guard_.observe(std::span<const float>(cur_.data(), cur_.size()), ans_);
    } else {
      guard_.clear();
    }
    return true;
  }

  // Whether the correction gain acts now (with the trust region): where it is on, and in
  // auto only where the noise is measured at the input rate (without that floor, at one
  // stream it takes the network's removal of a slow tremor back as motion). The streams
  // only fall to one through restart_grid, which restarts the gain; one stream's slow rows
  // come and go with the rate's median, and where they come back push() restarts it.
  bool gaining() const noexcept {
    return bounded_ && gain_mode_ != false && (gain_mode_ == true || measured());
  }

  // One accepted row into the streams; false when it has no joint.
  bool push_row(double t, const Pose& observed) noexcept {
    last_t_ = t;
    bool any = false;
    for (int j = 0; j < n_; ++j) {
      const bool ok = joint_finite(observed, j);
      for (int c = 0; c < 3; ++c) cur_[static_cast<size_t>(3 * j + c)] = ok ? static_cast<float>(observed(j, c)) : kNaNf;
      if (ok) seen_t_[static_cast<size_t>(j)] = t;
      any = any || ok;
    }
    if (!any) return false;  // hand lost in this frame: nothing to resample
    // A tracking gap longer than kModelResetGapS: the history no longer describes the hand
    // (the sampling rate still does).
    const bool gap = have_grid_ && t - last_valid_t_ > kModelResetGapS;
    if (gap) noise_.resume();
    noise_.push(t, std::span<const float>(cur_.data(), cur_.size()));
    if (gap) restart_grid();
    else if (have_grid_) intervals_.record(t - last_valid_t_);
    last_valid_t_ = t;
    if (!have_grid_) {
      start_grid(t);
      return true;
    }
    const double median = intervals_.median();  // once a row: the mode, the rate watch, the lock spacing
    if (valid_rows_ < kRateRows) {
      if (++valid_rows_ == kRateRows) choose_mode(mode_for(median));
    } else if (rate_changed(median)) {  // the runtime's rate is not what the first rows said: start over
      restart_grid();
      start_grid(t);
      return true;
    }
    if (locked_) {
      // A locked stream's frames are K samples apart (an interval / split_ when split), not
      // one model period: the network predicts in frames, so its path is read at that
      // spacing (at 23.5 Hz under a 30 Hz model, reading it in model periods answered 50 ms
      // with the frame 64 ms ahead).
      lock_spacing_ = median / split_;
      frame_period_ = std::clamp(phases_ * median / split_, kLockMin * period_, kLockMax * period_);
      push_locked(t);
    } else {
      // Every sub-grid tick in (prev_t_, t] gets the linearly interpolated frame. Ticks are
      // t0 + m * sub_period (no accumulated rounding), and a tick a hair after t counts
      // as at t (kTickToleranceS, time_series.hpp).
      while (grid_t0_ + static_cast<double>(ticks_ + 1) * sub_period_ <= t + kTickToleranceS) {
        ++ticks_;
        const double tick = grid_t0_ + static_cast<double>(ticks_) * sub_period_;
        push_interpolated(static_cast<int>(ticks_ % phases_), tick, t);
      }
    }
    prev_ = cur_;
    prev_t_ = t;
    return true;
  }

  void estimate(double t, Pose& out) const noexcept override {
    answer(t, out);
    if (std::isnan(last_t_)) return;
    // The correction gain, the lag cap and the oscillation guard are a denoiser's: their
    // shifts fade out over one model period ahead, so predictions keep the network's path
    // (the input's noise the gain's shift lets through made the 50 ms predictions jerkier:
    // docs/STGAE.md "Correction gain"). The cap's and the guard's shifts are zero where
    // they do not act.
    const double w = std::max(0.0, 1.0 - (std::max(t, last_t_) - last_t_) / period_);
    if (w <= 0.0) return;
    const bool gain = gaining();
    for (int j = 0; j < n_; ++j)
      for (int c = 0; c < 3; ++c)
        out(j, c) += w * ((gain ? gain_.shift(j, c) : 0.0) + lag_cap_.shift(j, c) + guard_.shift(c));
  }

  // The streams' answer at t, before the correction gain.
  void answer(double t, Pose& out) const noexcept {
    out = untracked_pose();
    if (latest_ < 0 || std::isnan(last_t_)) return;
    const double tq = std::max(t, last_t_);
    // The newest stream's path, averaged with the one before it at half weight: the
    // streams' residual errors are partly independent, so answering from one stream after
    // the other alternates between them at the input rate; averaging two damps that at the
    // cost of 1/K period of age in a third of the answer.
    for (int back = 0; back < std::min(2, phases_); ++back) {
      const int k = (latest_ - back + phases_) % phases_;
      const PhaseOutput& p = out_[static_cast<size_t>(k)];
      if (back > 0 && !p.have) continue;
      for (int j = 0; j < n_; ++j) {
        if (last_t_ - seen_t_[static_cast<size_t>(j)] > kModelResetGapS) continue;  // expired / never seen
        const double w = older_w_[static_cast<size_t>(j)];
        for (int c = 0; c < 3; ++c)
          out(j, c) = back == 0 ? path_at(p, tq, 3 * j + c) : (out(j, c) + w * path_at(p, tq, 3 * j + c)) / (1.0 + w);
      }
    }
    // A grid that has framed one row (its start) knows nothing of the motion: its path
    // holds that row. The rows before its first tick (two at 90 Hz under a 30 Hz model) are
    // answered by themselves; held, the answer froze for those rows and then jumped by the
    // hand's motion since (docs/STGAE.md "Start").
    if (ticks_ > 0 || last_t_ <= frame_t_ + kTickToleranceS) return;
    for (int j = 0; j < n_; ++j) {
      const float* x = cur_.data() + 3 * j;
      if (!finite_xyz(x)) continue;
      for (int c = 0; c < 3; ++c) out(j, c) = static_cast<double>(x[c]);
    }
  }

  // The value of coordinate i on a stream's path at time tq.
  double path_at(const PhaseOutput& p, double tq, int coord) const noexcept {
    const double s = (tq - p.t) / frame_period_;  // stream frames after its denoised frame
    const auto fs = static_cast<size_t>(3 * n_);
    const auto i = static_cast<size_t>(coord);
    if (dt_frames_ > 0) {
      // Piecewise linear through [denoised, predicted 0, 1, ...]; beyond the last point, its last segment continues.
      const PathPlace at = path_place(s, dt_frames_);
      return lerp_value(p.path[static_cast<size_t>(at.seg) * fs + i], p.path[static_cast<size_t>(at.seg + 1) * fs + i], at.f);
    }
    // Denoise only: the trend of the last two denoised frames, at most one period ahead.
    const auto d = static_cast<double>(p.path[i]);
    const double slope = p.have_prev ? d - static_cast<double>(p.den_prev[i]) : 0.0;
    return d + std::min(s, 1.0) * slope;
  }

  double last_time() const noexcept override { return last_t_; }

 private:
  // reset() (another hand, or none before) and restart() (the same hand after a gap: the
  // input's noise keeps what it learnt of the tracker).
  void reset_state(bool same_tracker) noexcept {
    restart_grid();
    gain_.reset();
    lag_cap_.reset();
    if (same_tracker) noise_.resume();
    else noise_.reset();
    intervals_.reset();
    mismatch_rows_ = 0;
    last_t_ = std::numeric_limits<double>::quiet_NaN();
    last_valid_t_ = -std::numeric_limits<double>::infinity();
    seen_t_.fill(-std::numeric_limits<double>::infinity());
  }

  // Rows seen before the phase count is first chosen, from the median of their intervals.
  static constexpr int kRateRows = 4;
  // The rate is then watched over the median of the last kRateWindow intervals; a mode
  // that differs from the running one for kRateStreak rows in a row replaces it (a first
  // interval stretched by tracking start, a runtime changing its rate).
  static constexpr int kRateWindow = 16;
  static constexpr int kRateStreak = 8;
  static constexpr double kRateHysteresis = 1.1;
  static constexpr double kOlderPhaseWeight = 0.5;
  // The older stream's share is its prediction 1/K period ahead, which the trust region
  // holds only within reach of constant velocity: per joint, its weight is
  // kOlderPhaseWeight * min(1, kOlderAgreementFactor * E|n|^2 / E|d|^2), d the newest
  // stream's denoised frame less the older stream's path at its time (a running mean over
  // about kOlderAgreementFrames frames) and E|n|^2 the input's noise (InputNoise): streams
  // that disagree by far more than the noise explains disagree by the older one's
  // prediction error (fast, nearly clean motion), which averaging would put in a third of
  // the answer. 16: the smallest factor that keeps the demo's ink jerk under half of raw's
  // (docs/STGAE.md "Where the rest of the low-noise loss is").
  static constexpr double kOlderAgreementFactor = 16.0;
  static constexpr double kOlderAgreementFrames = 30.0;
  // Sample intervals of 0.6-1.34 sub-periods lock. The top is the fastest speed factor the
  // shipped models were trained on (1.33; locking 20 Hz, 1.5, made a synthetic hand's 50 ms
  // answers twice as far off). Below 1 a frame's motion is that of a slower hand, which
  // the model handles: under 0.67, the least K = round(rate ratio) leaves, so that 40-45 Hz
  // (0.67-0.75, between the K = 1 and K = 2 bands) locks too, and a mode running at 45 Hz
  // (one stream at 0.67 periods) stays locked while irregular times move its median
  // (rate_changed). With slower input split (mode_for), every rate up to 200 Hz locks.
  static constexpr double kLockMin = 0.6, kLockMax = 1.34;

  // One stream locked on rows more than this many model periods apart (under 27 Hz under a
  // 30 Hz model: HoloLens 2's 23.5 Hz) bounds its corrections by the noise measured on its
  // rows (where that is under kMeasuredNoiseMaxRms), not by its frames' second difference:
  // frames 1.2-1.34 periods apart on a fast hand are mostly motion there, the radius opened
  // by it and the network's lag behind a fast move went through for rows after it. Not at
  // the model's rate, where FPHA's `paper` and 50 ms rows lost, nor on split intervals
  // (20 Hz), where the Leap low-noise cells did (docs/STGAE.md "One stream on slow rows").
  // The lag cap and the correction gain act there too, on that noise (measured()).
  static constexpr double kSlowRowsPeriods = 1.1;
  bool slow_rows() const noexcept {
    return phases_ == 1 && locked_ && split_ == 1 && lock_spacing_ > kSlowRowsPeriods * period_;
  }
  // Whether InputNoise measures the noise on rows apart from the streams' frames: K >= 2
  // streams, or one stream on slow rows. The correction gain (auto) and the lag cap act
  // only there: they need that noise (docs/STGAE.md "The lag cap and the gain on slow rows").
  bool measured() const noexcept { return phases_ >= 2 || slow_rows(); }

  // How the adapter frames input of one sampling interval.
  struct RateMode {
    int phases = 1;
    bool locked = false;
    int split = 1;  // locked frames per sample interval (input slower than the band, or 45-52 Hz)
    bool operator==(const RateMode&) const = default;
  };

  // Locked to the samples: each sample is a frame at its own time, so the answer at a
  // sample is a frame denoised there, not one extrapolated from a grid tick up to a period
  // earlier (with irregular times that extrapolation dominated the error: FPHA subject 5,
  // tracker preset, 30 Hz +-20 %: 1.40 mm on the grid, 1.02 locked, `handsteady benchmark
  // --quick`; docs/STGAE.md). Samples missed (an interval of n sub-periods) get
  // n - 1 interpolated frames; a sample under half a sub-period after the last frame is
  // answered from the path, not framed.
  void push_locked(double t) noexcept {
    const double f0 = frame_t_, d = t - f0;
    const long n = std::lround(d / lock_spacing_);
    if (n < 1) return;
    for (long k = 1; k <= n; ++k) {
      const double tick = k == n ? t : f0 + static_cast<double>(k) * d / static_cast<double>(n);
      ++ticks_;
      push_interpolated(static_cast<int>(ticks_ % phases_), tick, t);
    }
  }

  // Pushes the frame at `tick` in (prev_t_, t], linear between the last sample and this one.
  void push_interpolated(int phase, double tick, double t) noexcept {
    const double a = std::clamp((tick - prev_t_) / (t - prev_t_), 0.0, 1.0);
    // A joint one sample misses: the nearer sample's (missing if it is the one missing it).
    lerp_frame<float, float>(prev_, cur_, a, OneSided::Nearer, interp_);
    push_frame(phase, interp_, tick);
  }

  void restart_grid() noexcept {
    for (auto& stream : streams_) stream->reset();
    for (auto& b : bounds_) b.reset();
    smoother_.reset();
    gain_.restart();
    lag_cap_.reset();
    guard_.reset();  // the history no longer describes the hand: its energies neither
    for (PhaseOutput& o : out_) o.have = o.have_prev = false;
    older_w_.fill(kOlderPhaseWeight);
    disagree2_.fill(0.0);
    disagree_count_.fill(0);
    have_grid_ = false;
    locked_ = false;
    latest_ = -1;
  }

  // K = the input rate over the model rate, rounded, 1..kStgaeMaxPhases (unless fixed);
  // intervals of kLockMin..kLockMax sub-periods lock the frames to the samples
  // (push_locked); other rates (20 Hz under a 30 Hz model) stay on the fixed grid.
  RateMode mode_for(double dt) const noexcept {
    RateMode m;
    m.phases = fixed_phases_ > 0 ? fixed_phases_
                                 : std::clamp(static_cast<int>(std::lround(std::min(period_ / dt, 100.0))), 1, kStgaeMaxPhases);
    double r = dt * m.phases / period_;  // each stream's frame spacing in model periods, unsplit
    // Two streams at 1.5-1.73 model rates (45-52 Hz under a 30 Hz model) see the hand up to
    // 1.33 x faster than it moves, the edge of the speeds the model was trained on. One
    // stream more on intervals split in two (a frame halfway, one at the sample) sees it
    // at 0.87-1 x: taken where that is nearer 1 by ratio. At twice the rate three streams
    // run on frames as far apart, so a tracker that halves its rate under load (Leap
    // Motion's 96 and 48 Hz) changes only the split, and the streams keep their history
    // (docs/STGAE.md "Three streams on split intervals").
    if (fixed_phases_ == 0 && m.phases >= 2 && m.phases < kStgaeMaxPhases) {
      const double more = dt * (m.phases + 1) / period_;
      if (r * (0.5 * more) > 1.0) {
        ++m.phases;
        m.split = 2;
        r = more;
      }
    }
    // Input slower than the band (under 22 Hz): each interval split into frames in the band,
    // the last at the sample, so a sample is still answered by a frame at its own time
    // instead of from a grid tick up to a period before it.
    if (m.phases == 1 && r > kLockMax) m.split = static_cast<int>(std::ceil(std::min(r, 100.0) / kLockMax));
    m.locked = r / m.split >= kLockMin && r / m.split <= kLockMax;
    return m;
  }

  // The first choice, while the grid runs one stream. Stream 0 keeps its history: its
  // ticks t0 + k * period stay on the finer sub-grid (m = k * K).
  void choose_mode(RateMode m) noexcept {
    ticks_ *= m.phases / phases_;
    phases_ = m.phases;
    sub_period_ = period_ / phases_;
    locked_ = m.locked;
    split_ = m.split;
    lock_spacing_ = sub_period_;
    frame_period_ = period_;
  }

  // A grid from sample t. With the rate known (a restart after a gap, or a new rate), in
  // its mode at once; otherwise with one stream until kRateRows rows have been seen.
  void start_grid(double t) noexcept {
    grid_t0_ = t;
    ticks_ = 0;
    phases_ = fixed_phases_ > 0 ? fixed_phases_ : 1;
    sub_period_ = period_ / phases_;
    locked_ = false;
    split_ = 1;
    lock_spacing_ = sub_period_;
    frame_period_ = period_;
    valid_rows_ = 1;
    mismatch_rows_ = 0;
    if (intervals_.seen >= kRateRows - 1) {
      choose_mode(mode_for(intervals_.median()));
      valid_rows_ = kRateRows;
    }
    push_frame(0, cur_, t);
    prev_ = cur_;
    prev_t_ = t;
    have_grid_ = true;
  }

  // Whether a full window of intervals (median: theirs) has asked for another mode kRateStreak rows in a row.
  // A locked mode is kept while the median still locks in it and a median kRateHysteresis
  // times longer or shorter would choose it: at a rate between two modes (75 Hz: two
  // streams at 0.8 periods or three at 1.2) irregular times would otherwise flip the mode,
  // and each flip restarts the streams; further off (two streams at 1.33 periods, chosen by
  // the first rows of a 47 Hz input) the mode it asks for is taken. A locked mode that only
  // splits its intervals differently is taken up without a restart: the streams keep their
  // history (a log near 22 Hz, 1.34 periods, crosses that edge often).
  bool rate_changed(double median) noexcept {
    if (!intervals_.full()) return false;
    const RateMode running{phases_, locked_, split_};
    const double r = median * phases_ / (period_ * split_);
    const bool still_locks = locked_ && r >= kLockMin && r <= kLockMax &&
                             (mode_for(median * kRateHysteresis) == running || mode_for(median / kRateHysteresis) == running);
    const RateMode want = mode_for(median);
    mismatch_rows_ = still_locks || want == running ? 0 : mismatch_rows_ + 1;
    if (mismatch_rows_ < kRateStreak) return false;
    if (want.locked && locked_ && want.phases == phases_) {
      split_ = want.split;
      mismatch_rows_ = 0;
      return false;
    }
    return true;
  }

  void push_frame(int phase, const std::vector<float>& frame, double t) noexcept {
    auto& stream = *streams_[static_cast<size_t>(phase)];
    PhaseOutput& o = out_[static_cast<size_t>(phase)];
    frame_t_ = t;
    if (o.have) {
      std::copy(o.path.begin(), o.path.begin() + static_cast<std::ptrdiff_t>(o.den_prev.size()), o.den_prev.begin());
      o.have_prev = true;
    }
    if (!stream.push(std::span<const float>(frame.data(), frame.size()))) return;
    const auto den = stream.denoised();
    std::copy(den.begin(), den.end(), o.path.begin());
    for (int i = 0; i < dt_frames_; ++i) {
      const auto p = stream.predicted(i);
      std::copy(p.begin(), p.end(), o.path.begin() + static_cast<std::ptrdiff_t>((static_cast<size_t>(i) + 1) * p.size()));
    }
    if (bounded_) {
      // Input faster than the model: its rows measure the noise apart from the motion
      // (InputNoise); at the model's rate there is nothing finer than the stream's frames.
      // One stream on rows slower than the model reads them too (slow_rows). Joints whose
      // measured noise is over kMeasuredNoiseMaxRms keep the stream's own radius, at K >= 2
      // streams only where that noise is no Gaussian in shape (the `paper` preset's shifts;
      // docs/STGAE.md "Heavy-tailed noise at K >= 2 streams").
      auto& bound = bounds_[static_cast<size_t>(phase)];
      // One stream's frames are the input's rows: a row that follows a re-fit (a jump that
      // kept its bones and stayed) is answered from the input and its jump is no noise,
      // unless the joint's noise is a heavy tail of shifts (the `paper` preset's keep their
      // bones too, and one may last a second row; docs/STGAE.md "Rows after a re-fit"). At
      // K >= 2 streams the measured radius already closes there (InputNoise's jump is 0),
      // and a stream's last frame is K rows back, not the re-fit's row. A joint whose bones are
      // off their length is no motion with its hand: an outlier, taken back on the rows it
      // lasts (CorrectionBound::RowEvidence::stretched).
      if (phases_ >= 2) {
        bound.apply(frame, o.path, {.noise2 = noise_.noise2(), .jump = noise_.jumps(),
                                    .measured_max_rms = kMeasuredNoiseMaxRms, .shape = noise_.shapes()});
      } else {
        std::array<bool, kJointCount> refit{};
        for (size_t j = 0; j < kJointCount; ++j)
          refit[j] = noise_.followed()[j] && noise_.shapes()[j] >= kMeasuredNoiseMinShape;
        CorrectionBound::RowEvidence row{.followed = refit, .stretched = noise_.stretched(),
                                         .followed_hand = noise_.hand_refit()};
        if (slow_rows()) {  // only there is the noise measured
          row.noise2 = noise_.noise2();
          row.jump = noise_.jumps();
          row.measured_max_rms = kMeasuredNoiseMaxRms;
        }
        bound.apply(frame, o.path, row);
      }
    }
    if (smoothed_) smoother_.apply(t, o.path);
    if (bounded_ && phases_ >= 2 && latest_ >= 0 && latest_ != phase && out_[static_cast<size_t>(latest_)].have)
      weigh_older(o, out_[static_cast<size_t>(latest_)], t);
    o.t = t;
    o.have = true;
    // A stream started later (once the rate is known) answers from its first frame, as
    // stream 0 did: held back until it had a window of history, the rows it would have
    // answered were extrapolated from an older stream for the first T periods of every
    // (re)start, which cost more than its short history (docs/STGAE.md).
    latest_ = phase;
  }

  // The older stream's weight per joint from how far `newest` (its denoised frame at t)
  // and `older` (its path at t) disagree, against the input's noise.
  void weigh_older(const PhaseOutput& newest, const PhaseOutput& older, double t) noexcept {
    const auto n2 = noise_.noise2();
    for (int j = 0; j < n_ && static_cast<size_t>(j) < n2.size(); ++j) {
      const auto ju = static_cast<size_t>(j);
      double d2 = 0.0;
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(newest.path[static_cast<size_t>(3 * j + c)]) - path_at(older, t, 3 * j + c);
        d2 += d * d;
      }
      if (!std::isfinite(d2)) continue;  // a joint missing in either: keep the weight it had
      disagree2_[ju] += running_weight(disagree_count_[ju], kOlderAgreementFrames) * (d2 - disagree2_[ju]);
      older_w_[ju] = kOlderPhaseWeight * explained_share(disagree2_[ju], kOlderAgreementFactor * n2[ju]);
    }
  }

  std::shared_ptr<const StgaeModel> model_;
  int fixed_phases_ = 0;  // 0 = from the input rate
  std::array<std::unique_ptr<StgaeStream<float>>, kStgaeMaxPhases> streams_;
  std::array<PhaseOutput, kStgaeMaxPhases> out_;
  std::array<CorrectionBound, kStgaeMaxPhases> bounds_;  // one per stream: its frames are a period apart
  bool bounded_ = true;
  std::optional<bool> gain_mode_;  // the correction gain: unset = auto (measured()), true = at every rate, false = off
  bool smoothed_ = false;
  PredictionSmoother smoother_;  // one for all streams (smoothed_): their frames in time order
  CorrectionGain gain_;          // how much of the answer's correction to keep (gaining())
  bool gained_last_row_ = false;  // whether gain_ observed the last row with the hand
  MotionLagCap lag_cap_;         // the correction along a fast joint's motion, held (bounded_, measured())
  bool guarded_ = true;
  OscillationGuard guard_;       // the whole hand shaken no more than the input (guarded_)
  InputNoise noise_;             // the input's noise at the input rate, for the trust region
  std::array<double, kJointCount> older_w_{};       // the older stream's weight per joint
  std::array<double, kJointCount> disagree2_{};     // mean squared disagreement of the two newest streams, m^2
  std::array<int, kJointCount> disagree_count_{};
  Pose ans_ = untracked_pose();  // the answer at the last row (push: the stages' shifts added in turn)
  int n_ = 0, dt_frames_ = 0, phases_ = 1, latest_ = -1, valid_rows_ = 0, mismatch_rows_ = 0;
  IntervalRing<kRateWindow> intervals_;  // the last sample intervals (s)
  double period_ = 1.0 / 30.0, sub_period_ = 1.0 / 30.0;
  double frame_period_ = 1.0 / 30.0;  // time between a stream's frames: period_, or K intervals when locked
  double lock_spacing_ = 1.0 / 30.0;  // locked: the nominal time between frames, the median interval / split_
  int split_ = 1;
  std::vector<float> prev_, cur_, interp_;
  std::array<double, kJointCount> seen_t_{};
  bool have_grid_ = false, locked_ = false;
  double grid_t0_ = 0.0, prev_t_ = 0.0, frame_t_ = 0.0;
  long ticks_ = 0;
  double last_t_ = std::numeric_limits<double>::quiet_NaN();
  double last_valid_t_ = 0.0;
};

}  // namespace

std::unique_ptr<PoseFilter> make_stgae_filter(std::shared_ptr<const StgaeModel> model, double horizon_s, int phases,
                                              bool bounded, std::optional<bool> gain, bool smooth, bool guard) {
  if (!model || !model->net) throw std::invalid_argument("make_stgae_filter: no model");
  if (model->config.padding != StgaePadding::Causal)
    throw std::invalid_argument("make_stgae_filter: streaming needs a causal model (this one is centred)");
  if (!(horizon_s >= 0.0) || !std::isfinite(horizon_s))
    throw std::invalid_argument("make_stgae_filter: the horizon must be >= 0 s");
  if (phases < 0 || phases > kStgaeMaxPhases)
    throw std::invalid_argument("make_stgae_filter: phases must be 0 (from the input rate) to " +
                                std::to_string(kStgaeMaxPhases));
  return std::make_unique<StgaeFilter>(std::move(model), phases, bounded, gain, smooth, guard);
}

}  // namespace hs
