#pragma once
// Poses over time, written once: the tolerance that puts a sample on a grid tick, linear
// interpolation of frames with an explicit rule for joints one side misses, reading a
// path of points one period apart ([denoised, predicted...]) at any time, and a
// fixed-size history that answers a time exactly, by interpolation, or not at all
// (Monado's m_relation_history is the pattern). How long a gap may be bridged: gap_policy.hpp.
// Users: the metrics, training and replay (interpolate_pose, resampling), the Multi-STGAE adapter (grid frames,
// path answers), its window mode, the layer's published estimates.
#include "handsteady/gap_policy.hpp"
#include "handsteady/track.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>

namespace hs {

// Whether one joint's xyz in a joint-major frame is there (a missing joint is NaN).
template <class T>
bool finite_xyz(const T* p) noexcept {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

// Lagrange weights of the quadratic through times t1, t2, t3, evaluated at t0 (distinct
// times): a point extrapolated from three samples at their own times.
inline std::array<double, 3> quadratic_weights(double t0, double t1, double t2, double t3) noexcept {
  return {(t0 - t2) * (t0 - t3) / ((t1 - t2) * (t1 - t3)), (t0 - t1) * (t0 - t3) / ((t2 - t1) * (t2 - t3)),
          (t0 - t1) * (t0 - t2) / ((t3 - t1) * (t3 - t2))};
}

// The weight of the next sample in a running mean over about `samples` samples: a plain
// mean while fewer have been seen. Advances the count.
inline double running_weight(int& count, double samples) noexcept {
  const double w = std::max(1.0 / (count + 1), 1.0 / samples);
  count = std::min(count + 1, 1 << 20);
  return w;
}

// A grid tick up to this long after a sample counts as at it: recorded times are rounded
// (1/30 s written to 9 decimals), and a tick a hair after its sample must be answered by
// that sample, not by the next one (which would turn every answer into an extrapolation).
inline constexpr double kTickToleranceS = 1e-6;

// What an interpolated joint is when only one of the two bracketing frames has it.
enum class OneSided {
  Drop,    // missing: nothing is invented (interpolate_pose, the layer's history)
  Nearer,  // the nearer frame's value, missing when that one misses it (streaming frames)
  Either,  // whichever frame has it (window mode: the model fills only real holes)
};

// out = a + w (b - a) per joint, for frames of joints x 3 values (joint-major xyz, NaN x =
// joint missing); w in [0, 1]. The difference is taken in the input's precision.
template <class In, class Out>
void lerp_frame(std::span<const In> a, std::span<const In> b, double w, OneSided rule, std::span<Out> out) noexcept {
  for (size_t o = 0; o + 2 < out.size(); o += 3) {
    const bool ha = !std::isnan(a[o]), hb = !std::isnan(b[o]);
    for (size_t i = o; i < o + 3; ++i) {
      if (ha && hb) {
        out[i] = static_cast<Out>(static_cast<double>(a[i]) + w * static_cast<double>(b[i] - a[i]));
      } else if (rule == OneSided::Drop || (!ha && !hb)) {
        out[i] = std::numeric_limits<Out>::quiet_NaN();
      } else if (rule == OneSided::Nearer) {
        out[i] = static_cast<Out>(w < 0.5 ? a[i] : b[i]);
      } else {
        out[i] = static_cast<Out>(ha ? a[i] : b[i]);
      }
    }
  }
}
// Poses (double): (1 - w) a + w b per joint, missing where either misses the joint
// (OneSided::Drop, the only rule poses need).
inline void lerp_pose(const Pose& a, const Pose& b, double w, Pose& out) noexcept {
  for (int j = 0; j < kJointCount; ++j) {
    if (joint_tracked(a, j) && joint_tracked(b, j)) out.row(j) = (1.0 - w) * a.row(j) + w * b.row(j);
    else out.row(j).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
}

// a + f (b - a) in double, for values stored in any precision.
template <class T>
double lerp_value(T a, T b, double f) noexcept {
  const auto x = static_cast<double>(a);
  return x + f * (static_cast<double>(b) - x);
}

// Where time s (in periods after point 0) falls on a path of points 0..last one period
// apart (last >= 1): between point seg and seg + 1 at fraction f. Before point 0 the first
// segment continues backwards, after the last point the last one continues forwards.
struct PathPlace {
  int seg = 0;
  double f = 0.0;
};
inline PathPlace path_place(double s, int last) noexcept {
  const int seg = std::clamp(static_cast<int>(std::floor(s)), 0, last - 1);
  return {seg, s - seg};
}

// How a time was answered (m_relation_history's flags, without orientations).
enum class TimeAnswer { None, Exact, Interpolated, Predicted };

// The last N poses at increasing times (a ring, no allocation), answered at any time
// between the oldest and the newest: exactly at a kept time, else linearly between the two
// around it (joints one of them misses: missing). Time is any ordered number (seconds,
// XrTime nanoseconds).
template <int N, class Time>
class PoseHistory {
 public:
  void clear() noexcept { count_ = 0; }
  int size() const noexcept { return count_; }
  // Times must increase; an older or equal one is refused (false).
  bool push(Time t, const Pose& p) noexcept {
    if (count_ > 0 && !(t > time_[index(0)])) return false;
    head_ = (head_ + 1) % N;
    time_[static_cast<size_t>(head_)] = t;
    pose_[static_cast<size_t>(head_)] = p;
    count_ = std::min(count_ + 1, N);
    return true;
  }
  // The newest entry (size() > 0).
  Time newest() const noexcept { return time_[index(0)]; }
  const Pose& newest_pose() const noexcept { return pose_[index(0)]; }
  TimeAnswer at(Time q, Pose& out) const noexcept {
    // Newest to oldest: entries a (older) <= q <= b (newer).
    for (int n = 0; n < count_; ++n) {
      const size_t b = index(n);
      if (q == time_[b]) {
        out = pose_[b];
        return TimeAnswer::Exact;
      }
      if (n + 1 >= count_ || q > time_[b]) continue;
      const size_t a = index(n + 1);
      if (q < time_[a]) continue;
      if (q == time_[a]) {
        out = pose_[a];
        return TimeAnswer::Exact;
      }
      const double w = static_cast<double>(q - time_[a]) / static_cast<double>(time_[b] - time_[a]);
      lerp_pose(pose_[a], pose_[b], w, out);
      return TimeAnswer::Interpolated;
    }
    return TimeAnswer::None;
  }

 private:
  size_t index(int back) const noexcept { return static_cast<size_t>((head_ - back + 2 * N) % N); }
  std::array<Time, N> time_{};
  std::array<Pose, N> pose_{};
  int head_ = N - 1, count_ = 0;
};

// A hand over time (HandSeries), with the gap policy explicit.
// Linear interpolation of one hand at time t. A joint is tracked in the result only
// when it is tracked in both bracketing rows and they are at most max_gap_s apart
// (at the exact time of a row, that row's value). Outside [t0, tN]: untracked.
Pose interpolate_pose(const HandSeries& series, double t, double max_gap_s = kInterpolateMaxGapS);

// Each hand resampled on a fixed grid k/rate_hz covering its time span; joints that
// cannot be interpolated (gaps > max_gap_s) stay untracked. Metadata kept, rate_hz set.
HandSeries resample_series(const HandSeries& series, double rate_hz, double max_gap_s = kInterpolateMaxGapS);
Track resample_track(const Track& track, double rate_hz, double max_gap_s = kInterpolateMaxGapS);

// A tracker's jittering clock: each hand at times t0 + (k + u_k) / rate_hz from its first
// row t0, u_k uniform in [-jitter, jitter] (0 <= jitter < 0.5, so times stay increasing),
// seeded; the hand interpolated there (gaps as above). The benchmark's irregular input
// rates (jitter 0.2) and `handsteady resample --jitter`. The track version seeds each hand
// with seed + 17 * hand (Left 0, Right 1).
HandSeries resample_series_jittered(const HandSeries& series, double rate_hz, double jitter, uint64_t seed,
                                    double max_gap_s = kInterpolateMaxGapS);
Track resample_track_jittered(const Track& track, double rate_hz, double jitter, uint64_t seed,
                              double max_gap_s = kInterpolateMaxGapS);

}  // namespace hs
