#pragma once
// Per-tracker filter state in the layer's world-fixed space.
//
// The app's thread hands each new runtime sample over (submit) and answers from what the
// engine last published (answer); it never runs the engine itself when a worker is used.
// The engine (any hs::PoseFilter) sees only plausible joints (joint_gate), new increasing
// sample times at least kMinStep apart, and restarts by itself on a gap, a jump no hand
// can make, time running backwards, or an implausible engine output. After each sample
// it publishes its estimate at that time and along a short path ahead (knots), plus a
// history of past estimates, so any asked time is answered by interpolation.
//
// Execution: Inline runs the engine in the submitting thread (classical filters: a few
// microseconds); Worker runs it on a thread of this tracker, which polls for samples
// every 0.5 ms (no wake-up in the app's call), so an app call costs a copy and an
// interpolation and answers from the state before its own sample (the hand-off: at most
// one runtime sample period of added latency); Lockstep is Worker whose submit
// first waits for the worker to finish earlier samples: the same answers, deterministic
// (tests on simulated clocks, which run frames faster than real time).
//
// The hand-off hides most of its latency: until the worker has processed the app's sample,
// the answer is the published path moved by gain * (sample - path at the sample's time),
// the innovation the engine would see, with the gain the engine itself has shown on past
// samples (least squares of its output change against its input's innovation, per joint;
// not learnt during the blend-in after a restart, where an engine starting up may answer
// its input 1:1).
//
// Locks: in_mu_ guards the input queue, pub_mu_ the pointer to the published state (the
// engine fills a back buffer, then swaps it in); both are held only for copies and reads,
// never across the engine. No heap allocation after construction.
#include "handsteady/filters.hpp"
#include "handsteady/time_series.hpp"
#include "joint_gate.hpp"
#include "layer_config.hpp"

#include <openxr/openxr.h>

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace hs::layer {

using Velocity = Pose;  // m/s per joint, NaN = unknown

enum class Execution { Inline, Worker, Lockstep };

struct Answer {
  Pose pose;          // engine estimate (world), NaN rows = unknown
  Velocity velocity;  // its velocity, NaN = unknown
  // Weight of the estimate against the runtime's joints, 0..1: ramps up after each
  // (re)start so that the first answers are the runtime's and there is no transient.
  double weight = 0.0;
  bool corrected = false;  // moved by the innovation of a sample the engine has not processed yet
  // Exact: the estimate at the newest processed sample or a kept one; Interpolated: between
  // kept ones; Predicted: along the published path ahead.
  TimeAnswer how = TimeAnswer::None;
  // The median joint of the engine's newest input (world): where the engine's hand is.
  Eigen::Vector3d centre = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
};

class TrackerFilter {
 public:
  // Throws std::invalid_argument for a bad filter configuration (at tracker creation).
  TrackerFilter(std::unique_ptr<PoseFilter> engine, double reset_gap_s, double max_ahead_s, Execution exec);
  // The layer's engine from its configuration: make_filter(config.filter) (Multi-STGAE:
  // the model is shared, loaded once per instance; this tracker gets its own streams).
  explicit TrackerFilter(const LayerConfig& config);
  ~TrackerFilter();
  TrackerFilter(const TrackerFilter&) = delete;
  TrackerFilter& operator=(const TrackerFilter&) = delete;

  // Hands a runtime sample (world space, NaN rows = missing; nullptr: none) at
  // sample_time to the engine, then answers at query_time from the published estimate.
  // Samples not newer than the last by kMinStep are ignored (repeats, concurrent callers);
  // one older by more than the reset gap restarts the engine (time went back). Returns
  // false (pass the runtime's data through) when there is no estimate yet, the time is
  // older than the kept history, or further ahead of the newest processed sample than
  // the published path reaches.
  bool update(XrTime sample_time, const Pose* observed, XrTime query_time, Answer& out) noexcept;

  // The runtime moves the layer's world space (LOCAL recentred, XrEventDataReferenceSpaceChangePending)
  // at change_time: the first sample from then on restarts the engine (the same hand, in
  // the new space), and until it has, queries from then on pass the runtime through
  // rather than answer from the old space. Any thread; the newest announcement counts.
  void space_changed(XrTime change_time) noexcept { space_change_.store(change_time, std::memory_order_release); }

  // The runtime's hand came from another source (a controller, XR_EXT_hand_tracking_data_source),
  // or at another scale the app asked for (XR_FB_hand_tracking_mesh), after time `after`:
  // the first sample newer than it restarts the engine as a new hand (another source places
  // and shapes the hand its own way), and until it has, queries after it pass the runtime
  // through. Any thread; the newest call counts.
  void source_changed(XrTime after) noexcept {
    source_change_.store(after < std::numeric_limits<XrTime>::max() ? after + 1 : after, std::memory_order_release);
  }

  static constexpr XrTime kMinStep = 1'000'000;        // 1 ms: closer samples are repeats
  static constexpr int kHistory = 32;                  // past estimates kept for older queries
  static constexpr int kQueue = 8;                     // samples waiting for the worker
  static constexpr int kKnots = 33;                    // path points ahead of the newest sample
  static constexpr double kBlendS = 0.25;              // blend-in after a (re)start
  static constexpr double kMaxDeviationM = 0.3;        // engine this far from its input: restart
  static constexpr double kVelocityCutoffHz = 5.0;     // low-pass of the output's finite differences
  static constexpr double kGainRate = 0.05;            // EMA rate of the engine's gain estimate
  // The asynchronous worker's polling: every kPollActive while samples come, every
  // kPollIdle once none came for kIdleAfter (a lost hand, an unused motion range).
  static constexpr std::chrono::microseconds kPollActive{500};
  static constexpr std::chrono::milliseconds kPollIdle{20};
  static constexpr std::chrono::milliseconds kIdleAfter{500};
  // The worker starts a step no sooner than this after the newest sample came: apps ask
  // both hands (and often two times) back to back, and a network step running beside
  // those calls slows them (shared caches, SMT siblings). Far below a frame.
  static constexpr std::chrono::microseconds kSettle{300};

 private:
  struct Sample {
    XrTime t = 0;
    Pose pose;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // the gate's median joint (pending samples)
  };
  static constexpr std::array<double, kJointCount> filled(double v) {
    std::array<double, kJointCount> a{};
    for (auto& x : a) x = v;
    return a;
  }
  // What the engine published after its newest sample.
  struct Published {
    bool valid = false;
    XrTime t0 = 0;         // newest processed sample
    XrTime start = 0;      // sample that (re)started the current run
    XrTime step = 0;       // knot spacing
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // median joint of the newest input
    std::array<Pose, kKnots> path;  // estimate at t0 + k * step
    Velocity velocity;
    PoseHistory<kHistory, XrTime> hist;  // past estimates, at their sample times
    // The engine's response to innovation, per joint (NaN: not measured yet).
    std::array<double, kJointCount> gain = filled(std::numeric_limits<double>::quiet_NaN());
    // The path at time t (t0 <= t <= t0 + max ahead), false beyond.
    bool path_at(XrTime t, XrTime max_ahead, Pose& out) const noexcept;
  };

  void submit(XrTime t, const Pose& observed) noexcept;
  // pending: a sample (gated) the published state does not include yet, or nullptr.
  bool answer(XrTime query_time, const Sample* pending, Answer& out) const noexcept;
  void process(const Sample& s) noexcept;  // engine thread only
  // Engine thread only. same_hand: the engine keeps what it learnt of the hand (PoseFilter::restart).
  void restart(XrTime t, bool same_hand) noexcept;
  void publish() noexcept;                 // engine thread only
  void run_worker() noexcept;
  double seconds(XrTime t) const { return static_cast<double>(t - epoch_) * 1e-9; }

  const Execution exec_;
  const double reset_gap_ns_;
  const XrTime max_ahead_ns_;
  GateLimits limits_;

  // Input (any app thread -> engine).
  mutable std::mutex in_mu_;
  std::condition_variable in_cv_, idle_cv_;
  std::array<Sample, kQueue> queue_;
  int q_head_ = 0, q_count_ = 0;
  bool busy_ = false, stop_ = false;
  std::chrono::steady_clock::time_point submitted_{};  // when the newest sample came (under in_mu_)
  Sample taken_;  // worker's copy of the sample it processes

  // Engine state (engine thread only: the worker, or the submitter under engine_mu_).
  std::mutex engine_mu_;
  std::unique_ptr<PoseFilter> engine_;
  bool running_ = false;
  int behind_ = 0;  // consecutive samples far older than the last: time was reset
  XrTime epoch_ = 0, last_ = 0, start_ = 0;
  Eigen::Vector3d centre_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::unique_ptr<Published> state_;  // the engine's own copy, updated per sample
  std::unique_ptr<Published> back_;   // filled from state_, then swapped with front_

  // Published (engine -> any app thread).
  mutable std::mutex pub_mu_;
  std::unique_ptr<Published> front_;

  std::atomic<XrTime> space_change_{0};  // the world space's newest announced change (0: none)
  std::atomic<XrTime> source_change_{0};  // samples from then on are from a new source (0: none)

  std::thread worker_;
};

}  // namespace hs::layer
