#include "tracker_filter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <pthread.h>
#include <sched.h>

namespace hs::layer {
namespace {

double reset_gap_s(const LayerConfig& c) {
  return is_network(c.filter.method) ? std::min(c.filter.max_gap_s, kModelResetGapS) : c.filter.max_gap_s;
}

// How far past its newest processed sample the engine answers: the largest horizon a
// hand may be given in predict mode, plus the hand-off and a few missed samples.
double max_ahead_s(const LayerConfig& c) {
  const double horizon = c.mode == Mode::Predict ? static_cast<double>(c.max_horizon_ns) * 1e-9 : 0.0;
  return horizon + 0.1;
}

Execution execution(const LayerConfig& c) {
  // The network runs off the app's thread; classical filters cost less than the hand-off.
  const bool network = is_network(c.filter.method);
  switch (c.worker) {
    case WorkerMode::Inline: return Execution::Inline;
    case WorkerMode::Worker: return Execution::Worker;
    case WorkerMode::Lockstep: return network ? Execution::Lockstep : Execution::Inline;
    case WorkerMode::Auto: break;
  }
  return network ? Execution::Worker : Execution::Inline;
}

// A run that started before `change` (a world space moved, a hand from another source;
// 0: none) does not reach time t at or after it.
bool run_predates(XrTime change, XrTime t, XrTime run_start) noexcept {
  return change > 0 && t >= change && run_start < change;
}

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

}  // namespace

TrackerFilter::TrackerFilter(std::unique_ptr<PoseFilter> engine, double reset_gap_s, double max_ahead_s, Execution exec)
    : exec_(exec),
      reset_gap_ns_(reset_gap_s * 1e9),
      max_ahead_ns_(static_cast<XrTime>(std::max(max_ahead_s, 0.01) * 1e9)),
      engine_(std::move(engine)),
      state_(std::make_unique<Published>()),
      back_(std::make_unique<Published>()),
      front_(std::make_unique<Published>()) {
  state_->step = (max_ahead_ns_ + kKnots - 2) / (kKnots - 1);
  state_->velocity.setConstant(kNaN);
  if (exec_ != Execution::Inline) {
    worker_ = std::thread([this] { run_worker(); });
    // A batch thread does not preempt the thread that wakes it: the app's call returns
    // before the worker takes the core (2-core machines, busy headset CPUs).
    sched_param param{};
    param.sched_priority = 0;
    pthread_setschedparam(worker_.native_handle(), SCHED_BATCH, &param);
  }
}

TrackerFilter::TrackerFilter(const LayerConfig& config)
    : TrackerFilter(make_filter(config.filter), reset_gap_s(config), max_ahead_s(config), execution(config)) {}

TrackerFilter::~TrackerFilter() {
  if (!worker_.joinable()) return;
  {
    std::lock_guard lock(in_mu_);
    stop_ = true;
  }
  in_cv_.notify_all();
  idle_cv_.notify_all();
  worker_.join();
}

bool TrackerFilter::update(XrTime sample_time, const Pose* observed, XrTime query_time, Answer& out) noexcept {
  if (exec_ == Execution::Inline) {
    if (observed) submit(sample_time, *observed);
    return answer(query_time, nullptr, out);
  }
  // The app's sample as the engine will see it (gated), for the innovation correction.
  Sample pending{sample_time, observed ? *observed : Pose(), Eigen::Vector3d::Zero()};
  bool usable = false;
  if (observed) {
    const GateResult gate = gate_joints(pending.pose, limits_);
    usable = gate.usable();
    pending.centre = gate.centre;
  }
  if (exec_ == Execution::Lockstep) {
    // The state the worker has when it keeps up: every earlier sample processed.
    std::unique_lock lock(in_mu_);
    idle_cv_.wait(lock, [&] { return (q_count_ == 0 && !busy_) || stop_; });
  }
  // Answer first, then wake the worker: the answer never waits for it.
  const bool ok = answer(query_time, usable ? &pending : nullptr, out);
  if (observed) submit(sample_time, *observed);
  return ok;
}

void TrackerFilter::submit(XrTime t, const Pose& observed) noexcept {
  if (exec_ == Execution::Inline) {
    std::lock_guard lock(engine_mu_);
    process(Sample{t, observed, Eigen::Vector3d::Zero()});
    return;
  }
  {
    std::lock_guard lock(in_mu_);
    // A full queue (the worker fell behind) drops its oldest sample: the newest matter.
    const int slot = (q_head_ + q_count_) % kQueue;
    queue_[slot].t = t;
    queue_[slot].pose = observed;
    if (q_count_ < kQueue) ++q_count_;
    else q_head_ = (q_head_ + 1) % kQueue;
    if (exec_ == Execution::Worker) submitted_ = std::chrono::steady_clock::now();
  }
  // The asynchronous worker polls (kPollActive): waking a thread on another core costs an
  // inter-processor interrupt, tens of microseconds on a VM, in the app's call. Lockstep
  // (tests on simulated clocks) wakes it at once.
  if (exec_ == Execution::Lockstep) in_cv_.notify_one();
}

void TrackerFilter::run_worker() noexcept {
  auto last_sample = std::chrono::steady_clock::now();
  for (;;) {
    {
      std::unique_lock lock(in_mu_);
      const auto ready = [&] { return q_count_ > 0 || stop_; };
      if (exec_ == Execution::Lockstep) {
        in_cv_.wait(lock, ready);
      } else {
        // Poll while the hand is tracked; back off once no sample came for a while.
        for (;;) {
          while (!ready()) {
            const bool idle = std::chrono::steady_clock::now() - last_sample > kIdleAfter;
            in_cv_.wait_for(lock, idle ? kPollIdle : kPollActive, ready);
          }
          if (stop_) break;
          const auto settled = submitted_ + kSettle;
          const auto now = std::chrono::steady_clock::now();
          if (now >= settled) break;
          in_cv_.wait_for(lock, settled - now, [&] { return stop_; });
        }
      }
      if (stop_) return;
      taken_ = queue_[q_head_];
      q_head_ = (q_head_ + 1) % kQueue;
      --q_count_;
      busy_ = true;
    }
    process(taken_);
    last_sample = std::chrono::steady_clock::now();
    {
      std::lock_guard lock(in_mu_);
      busy_ = false;
    }
    idle_cv_.notify_all();
  }
}

void TrackerFilter::restart(XrTime t, bool same_hand) noexcept {
  if (same_hand) engine_->restart();
  else engine_->reset();
  running_ = true;
  behind_ = 0;
  epoch_ = start_ = last_ = t;
  state_->start = t;
  state_->hist.clear();
  state_->velocity.setConstant(kNaN);
}

void TrackerFilter::process(const Sample& s) noexcept {
  Pose obs = s.pose;
  const GateResult gate = gate_joints(obs, limits_);
  if (!gate.usable()) return;  // nothing plausible: not a sample
  // Beyond a quarter of XrTime's range no runtime dates a sample (year 2082 on a Unix
  // clock); refusing such times keeps the path's knot times from overflowing.
  if (s.t <= 0 || s.t > std::numeric_limits<XrTime>::max() / 4) return;
  const XrTime change = space_change_.load(std::memory_order_acquire);
  const XrTime source = source_change_.load(std::memory_order_acquire);
  if (!running_) {
    restart(s.t, false);
  } else {
    const XrTime dt = s.t - last_;  // both positive: no overflow
    if (dt < kMinStep) {
      // A repeat or an older time (apps may ask the past) is not a new sample. Only when
      // times stay far behind the last sample has the clock been reset (or one far-future
      // time got in): then start over rather than ignore every later sample.
      if (static_cast<double>(-dt) <= reset_gap_ns_ || ++behind_ < 3) return;
      restart(s.t, false);
    } else if (run_predates(source, s.t, start_)) {
      // The hand from another source (back from a controller): a new hand, not motion.
      restart(s.t, false);
    } else if (static_cast<double>(dt) > reset_gap_ns_ ||
               hand_jumped(centre_, gate.centre, static_cast<double>(dt) * 1e-9, limits_) ||
               run_predates(change, s.t, start_)) {
      // Lost for too long, somewhere no hand could have moved to, or the world space moved
      // under the run (a recentred LOCAL): the motion starts over, what the engine learnt
      // of the hand's shape is kept (and checked).
      restart(s.t, true);
    }
  }
  // What the engine had predicted for this sample: its response to the innovation is the
  // gain of the hand-off correction.
  Published& st = *state_;
  Pose pred;
  const bool have_pred = st.valid && s.t != start_ && st.path_at(s.t, max_ahead_ns_, pred);
  if (!engine_->push(seconds(s.t), obs)) return;
  bool first = s.t == start_;
  last_ = s.t;
  behind_ = 0;
  centre_ = gate.centre;

  Pose est;
  engine_->estimate(seconds(s.t), est);
  // An engine far from what it was just given has gone wrong: start over from the input.
  for (int j = 0; j < kJointCount; ++j) {
    const bool wild = joint_tracked(obs, j) && !std::isnan(est(j, 0)) &&
                      !((est.row(j) - obs.row(j)).norm() <= kMaxDeviationM);
    if (wild) {
      restart(s.t, false);
      engine_->push(0.0, obs);
      engine_->estimate(0.0, est);
      first = true;
      break;
    }
  }
  // Not while the engine starts up (the blend-in after a restart, its first sample and a
  // restart above included): its first answers are its input (core/src/stgae_filter.cpp),
  // a response it does not keep.
  const bool starting = static_cast<double>(s.t - start_) * 1e-9 < kBlendS;
  if (have_pred && !starting) {
    for (int j = 0; j < kJointCount; ++j) {
      const Eigen::RowVector3d d = obs.row(j) - pred.row(j), r = est.row(j) - pred.row(j);
      const double den = d.squaredNorm();
      if (!d.allFinite() || !r.allFinite() || den < 1e-8) continue;  // under 0.1 mm: no information
      const double g = std::clamp(r.dot(d) / den, 0.0, 1.0);
      double& gain = st.gain[j];
      gain = std::isfinite(gain) ? gain + kGainRate * (g - gain) : g;
    }
  }
  // Velocity: finite differences of consecutive estimates, low-passed. Samples may be a
  // millisecond apart (apps asking from several threads), so no single difference is ever
  // taken as the velocity: an unknown one starts from rest, and a joint missing for a
  // sample keeps its velocity rather than becoming unknown again.
  if (!first && st.hist.size() > 0) {
    const Pose& prev = st.hist.newest_pose();
    const double dt = static_cast<double>(s.t - st.hist.newest()) * 1e-9;
    const double a = low_pass_alpha(kVelocityCutoffHz, dt);
    for (int j = 0; j < kJointCount; ++j)
      for (int k = 0; k < 3; ++k) {
        const double d = (est(j, k) - prev(j, k)) / dt;
        double& v = st.velocity(j, k);
        if (!std::isfinite(d)) continue;
        const double before = std::isfinite(v) ? v : 0.0;
        v = before + a * (d - before);
      }
  }
  st.hist.push(s.t, est);
  st.path[0] = est;
  for (int k = 1; k < kKnots; ++k) engine_->estimate(seconds(s.t + k * st.step), st.path[k]);
  st.t0 = s.t;
  st.centre = gate.centre;
  st.valid = true;
  publish();
}

void TrackerFilter::publish() noexcept {
  *back_ = *state_;
  std::lock_guard lock(pub_mu_);
  std::swap(front_, back_);
}

bool TrackerFilter::Published::path_at(XrTime t, XrTime max_ahead, Pose& out) const noexcept {
  if (t < t0 || t - t0 > max_ahead) return false;
  const XrTime ahead = t - t0;
  const PathPlace at = path_place(static_cast<double>(ahead) / static_cast<double>(step), kKnots - 1);
  const double w = static_cast<double>(ahead - at.seg * step) / static_cast<double>(step);  // in integer time: exact
  lerp_pose(path[static_cast<size_t>(at.seg)], path[static_cast<size_t>(at.seg + 1)], w, out);
  return true;
}

bool TrackerFilter::answer(XrTime q, const Sample* pending, Answer& out) const noexcept {
  std::lock_guard lock(pub_mu_);
  const Published& p = *front_;
  out.corrected = false;
  if (!p.valid || q <= 0) return false;
  // The published run is in the world space as it was before a change that applies at q,
  // or of the hand from its source before another took over.
  if (run_predates(space_change_.load(std::memory_order_acquire), q, p.start) ||
      run_predates(source_change_.load(std::memory_order_acquire), q, p.start))
    return false;
  if (q >= p.t0) {
    if (!p.path_at(q, max_ahead_ns_, out.pose)) return false;
    out.how = q == p.t0 ? TimeAnswer::Exact : TimeAnswer::Predicted;
    Pose pred;
    if (pending && pending->t > p.t0 && p.path_at(pending->t, max_ahead_ns_, pred)) {
      // A sample from a hand somewhere else (re-acquired, jumped): the published state is
      // not about it. Pass the runtime through until the engine has restarted on it.
      if (hand_jumped(p.centre, pending->centre, static_cast<double>(pending->t - p.t0) * 1e-9, limits_)) return false;
      for (int j = 0; j < kJointCount; ++j) {
        const Eigen::RowVector3d d = pending->pose.row(j) - pred.row(j);
        if (d.allFinite() && out.pose.row(j).allFinite() && std::isfinite(p.gain[j])) out.pose.row(j) += p.gain[j] * d;
      }
      out.corrected = true;
    }
  } else {
    out.how = p.hist.at(q, out.pose);
    if (out.how == TimeAnswer::None) return false;
  }
  out.velocity = p.velocity;
  out.centre = p.centre;
  out.weight = smoothstep(static_cast<double>(p.t0 - p.start) * 1e-9 / kBlendS);
  return true;
}

}  // namespace hs::layer
