// Quality measures (docs/METRICS.md).
#include "handsteady/metrics.hpp"

#include "handsteady/track_ops.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace hs {
namespace {

constexpr double kMm = 1000.0;

// Sum and count, so per-hand results can be pooled before dividing.
struct Mean {
  double sum = 0.0;
  size_t n = 0;
  void add(double v) {
    sum += v;
    ++n;
  }
  void merge(const Mean& o) {
    sum += o.sum;
    n += o.n;
  }
  double value() const { return n > 0 ? sum / static_cast<double>(n) : kNaN; }
};

void require_same_length(std::span<const Pose> a, std::span<const Pose> b, const char* what) {
  if (a.size() != b.size())
    throw std::invalid_argument(std::string(what) + ": truth and estimate differ in length (" +
                                std::to_string(a.size()) + " vs " + std::to_string(b.size()) + ")");
}

bool both_tracked(const Pose& a, const Pose& b, int j) { return joint_tracked(a, j) && joint_tracked(b, j); }

// Per coordinate squared error (mm^2); one sample per coordinate.
Mean squared_error(std::span<const Pose> truth, std::span<const Pose> est) {
  Mean m;
  for (size_t f = 0; f < truth.size(); ++f)
    for (int j = 0; j < kJointCount; ++j)
      if (both_tracked(truth[f], est[f], j))
        for (int k = 0; k < 3; ++k) {
          const double d = (est[f](j, k) - truth[f](j, k)) * kMm;
          m.add(d * d);
        }
  return m;
}

Mean joint_distance(std::span<const Pose> truth, std::span<const Pose> est) {
  Mean m;
  for (size_t f = 0; f < truth.size(); ++f)
    for (int j = 0; j < kJointCount; ++j)
      if (both_tracked(truth[f], est[f], j)) m.add((est[f].row(j) - truth[f].row(j)).norm() * kMm);
  return m;
}

Mean edge_error(std::span<const Pose> truth, std::span<const Pose> est, std::span<const Edge> edges) {
  Mean m;
  for (size_t f = 0; f < truth.size(); ++f)
    for (auto [a, b] : edges) {
      if (a < 0 || b < 0 || a >= kJointCount || b >= kJointCount)
        throw std::invalid_argument("edge_length_error_mm2: joint index out of range");
      if (!both_tracked(truth[f], est[f], a) || !both_tracked(truth[f], est[f], b)) continue;
      const double lt = (truth[f].row(a) - truth[f].row(b)).norm();
      const double le = (est[f].row(a) - est[f].row(b)).norm();
      const double d = (le - lt) * kMm;
      m.add(d * d);
    }
  return m;
}

// Second difference of joint j at frame f (needs f-1, f, f+1 tracked), metres.
bool second_difference(std::span<const Pose> s, size_t f, int j, Eigen::RowVector3d& out) {
  if (!joint_tracked(s[f - 1], j) || !joint_tracked(s[f], j) || !joint_tracked(s[f + 1], j)) return false;
  out = s[f + 1].row(j) - 2.0 * s[f].row(j) + s[f - 1].row(j);
  return true;
}

Mean accel_error(std::span<const Pose> truth, std::span<const Pose> est) {
  Mean m;
  Eigen::RowVector3d at, ae;
  for (size_t f = 1; f + 1 < truth.size(); ++f)
    for (int j = 0; j < kJointCount; ++j)
      if (second_difference(truth, f, j, at) && second_difference(est, f, j, ae)) m.add((ae - at).norm() * kMm);
  return m;
}

Mean jitter(std::span<const Pose> est) {
  Mean m;
  Eigen::RowVector3d a;
  for (size_t f = 1; f + 1 < est.size(); ++f)
    for (int j = 0; j < kJointCount; ++j)
      if (second_difference(est, f, j, a)) m.add(a.norm() * kMm);
  return m;
}

// Cross-correlation of velocities, C(tau) = mean over (t, joint, coord) of
// v_truth(t) * v_est(t + tau), for tau in [-max_lag, max_lag].
struct CrossCorrelation {
  int max_lag = 0;
  std::vector<Mean> c;
  explicit CrossCorrelation(int lag) : max_lag(lag), c(static_cast<size_t>(2 * lag + 1)) {}
};

// Velocities flattened, frame after frame: 3 * kJointCount values per frame, zero where
// the joint is missing in either frame, and 1/0 per joint for whether it is there.
struct Velocities {
  long n = 0;
  std::vector<double> v, valid;
};
// Into out, reusing its storage (the benchmark evaluates many long tracks per thread).
void velocities(std::span<const Pose> s, Velocities& out) {
  out.n = s.empty() ? 0 : static_cast<long>(s.size()) - 1;
  out.v.assign(static_cast<size_t>(out.n) * 3 * kJointCount, 0.0);
  out.valid.assign(static_cast<size_t>(out.n) * kJointCount, 0.0);
  for (long f = 0; f < out.n; ++f) {
    const Pose d = s[static_cast<size_t>(f) + 1] - s[static_cast<size_t>(f)];  // NaN where either is missing
    for (int j = 0; j < kJointCount; ++j) {
      if (std::isnan(d(j, 0))) continue;
      out.valid[static_cast<size_t>(f * kJointCount + j)] = 1.0;
      for (int k = 0; k < 3; ++k) out.v[static_cast<size_t>((f * kJointCount + j) * 3 + k)] = d(j, k);
    }
  }
}

// C(tau) pools the products of the joints present at t in the truth and at t + tau in the
// estimate. With the missing ones zeroed, its sum over t is one dot product of the two
// flattened sequences offset by tau frames (and its count one of the presence flags), so
// each lag costs a single vectorised pass.
void accumulate_xcorr(std::span<const Pose> truth, std::span<const Pose> est, CrossCorrelation& xc) {
  thread_local Velocities vt, ve;
  velocities(truth, vt);
  velocities(est, ve);
  const long n = vt.n;
  using Seq = Eigen::Map<const Eigen::VectorXd>;
  constexpr long kV = 3 * kJointCount;
  for (int tau = -xc.max_lag; tau <= xc.max_lag; ++tau) {
    const long t0 = std::max(0L, -static_cast<long>(tau)), t1 = std::min(n, n - static_cast<long>(tau));
    if (t1 <= t0) continue;
    const long len = t1 - t0, u0 = t0 + tau;
    Mean& m = xc.c[static_cast<size_t>(tau + xc.max_lag)];
    m.sum += Seq(vt.v.data() + t0 * kV, len * kV).dot(Seq(ve.v.data() + u0 * kV, len * kV));
    const double pairs = Seq(vt.valid.data() + t0 * kJointCount, len * kJointCount)
                             .dot(Seq(ve.valid.data() + u0 * kJointCount, len * kJointCount));
    m.n += 3 * static_cast<size_t>(std::llround(pairs));
  }
}

// Arg-max of the correlation with a parabola through the peak and its neighbours.
double peak_lag(const CrossCorrelation& xc) {
  int best = -1;
  double best_v = -std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < xc.c.size(); ++i)
    if (xc.c[i].n > 0 && xc.c[i].value() > best_v) {
      best_v = xc.c[i].value();
      best = static_cast<int>(i);
    }
  if (best < 0) return kNaN;
  double delta = 0.0;
  if (best > 0 && best + 1 < static_cast<int>(xc.c.size()) && xc.c[static_cast<size_t>(best - 1)].n > 0 &&
      xc.c[static_cast<size_t>(best + 1)].n > 0) {
    const double cm = xc.c[static_cast<size_t>(best - 1)].value(), cp = xc.c[static_cast<size_t>(best + 1)].value();
    const double denom = cm - 2.0 * best_v + cp;
    if (denom < 0.0) delta = std::clamp(0.5 * (cm - cp) / denom, -0.5, 0.5);
  }
  return static_cast<double>(best - xc.max_lag) + delta;
}

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

double e_pos_mm2(std::span<const Pose> truth, std::span<const Pose> est) {
  require_same_length(truth, est, "e_pos_mm2");
  return squared_error(truth, est).value();
}

double mpjpe_mm(std::span<const Pose> truth, std::span<const Pose> est) {
  require_same_length(truth, est, "mpjpe_mm");
  return joint_distance(truth, est).value();
}

double edge_length_error_mm2(std::span<const Pose> truth, std::span<const Pose> est, std::span<const Edge> edges) {
  require_same_length(truth, est, "edge_length_error_mm2");
  return edge_error(truth, est, edges).value();
}

double e_bon_mm2(std::span<const Pose> truth, std::span<const Pose> est) {
  return edge_length_error_mm2(truth, est, xr_hand_skeleton().bones);
}

double e_sym_mm2(std::span<const Pose> truth, std::span<const Pose> est) {
  return edge_length_error_mm2(truth, est, xr_hand_skeleton().symmetry);
}

double accel_error_mm(std::span<const Pose> truth, std::span<const Pose> est) {
  require_same_length(truth, est, "accel_error_mm");
  return accel_error(truth, est).value();
}

double jitter_mm(std::span<const Pose> est) { return jitter(est).value(); }

double lag_frames(std::span<const Pose> truth, std::span<const Pose> est, int max_lag) {
  require_same_length(truth, est, "lag_frames");
  if (max_lag < 1) throw std::invalid_argument("lag_frames: max_lag must be >= 1");
  CrossCorrelation xc(max_lag);
  accumulate_xcorr(truth, est, xc);
  return peak_lag(xc);
}

Metrics evaluate_tracks(const Track& truth, const Track& est, double horizon_s) {
  if (!std::isfinite(horizon_s)) throw std::invalid_argument("evaluate_tracks: horizon must be finite");
  Metrics m;
  m.horizon_ms = horizon_s * kMm;

  struct Aligned {
    std::vector<Pose> truth, est;
  };
  std::vector<Aligned> hands;
  std::vector<double> periods;
  for (Hand h : {Hand::Left, Hand::Right}) {
    const HandSeries ts = hand_series(truth, h), es = hand_series(est, h);
    for (size_t i = 1; i < es.size(); ++i) periods.push_back(es.t[i] - es.t[i - 1]);
    Aligned a;
    for (size_t i = 0; i < es.size(); ++i) {
      const double target = es.t[i] + horizon_s;
      Pose tp = untracked_pose();
      if (ts.empty() || target < ts.t.front() || target > ts.t.back()) {
        ++m.rows_outside;
      } else {
        tp = interpolate_pose(ts, target);
        bool common = false;
        for (int j = 0; j < kJointCount && !common; ++j) common = both_tracked(tp, es.pos[i], j);
        if (common) ++m.frames;
        else ++m.rows_untracked;
      }
      // Skipped rows stay in the sequence as untracked, so no difference spans them.
      a.truth.push_back(tp);
      a.est.push_back(es.pos[i]);
    }
    hands.push_back(std::move(a));
  }

  const double period = median(periods);
  m.frame_period_ms = period * kMm;
  const int max_lag = std::isfinite(period) && period > 0.0
                          ? std::clamp(static_cast<int>(std::ceil(0.5 / period)), 2, 120)
                          : 2;
  Mean se, dist, bon, sym, acc, jit, tjit;
  CrossCorrelation xc(max_lag);
  for (const Aligned& a : hands) {
    se.merge(squared_error(a.truth, a.est));
    dist.merge(joint_distance(a.truth, a.est));
    bon.merge(edge_error(a.truth, a.est, xr_hand_skeleton().bones));
    sym.merge(edge_error(a.truth, a.est, xr_hand_skeleton().symmetry));
    acc.merge(accel_error(a.truth, a.est));
    // Jitter of the estimate only where it was compared, so both jitters cover the same rows.
    std::vector<Pose> est_compared = a.est;
    for (size_t i = 0; i < est_compared.size(); ++i)
      if (!any_joint_tracked(a.truth[i])) est_compared[i] = untracked_pose();
    jit.merge(jitter(est_compared));
    tjit.merge(jitter(a.truth));
    accumulate_xcorr(a.truth, a.est, xc);
  }
  m.joint_samples = dist.n;
  m.e_pos_mm2 = se.value();
  m.mpjpe_mm = dist.value();
  m.e_bon_mm2 = bon.value();
  m.e_sym_mm2 = sym.value();
  m.accel_error_mm = acc.value();
  m.jitter_mm = jit.value();
  m.truth_jitter_mm = tjit.value();
  m.lag_frames = peak_lag(xc);
  m.lag_ms = m.lag_frames * m.frame_period_ms;
  return m;
}

}  // namespace hs
