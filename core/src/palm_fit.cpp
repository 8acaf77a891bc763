#include "handsteady/palm_fit.hpp"
#include "handsteady/rigid_fit.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace hs {

namespace {

using V3 = Eigen::Vector3d;

// The running median residual moves this share of itself (at least of the floor) a row.
constexpr double kPalmMedianStep = 0.05;
constexpr double kPalmMedianFloorM = 0.0005;

// The used joint with the largest error above `limit` (P: none).
template <size_t P>
size_t worst_above(const std::array<double, P>& err, const std::array<bool, P>& use, double limit) {
  size_t worst = P;
  for (size_t i = 0; i < P; ++i)
    if (use[i] && err[i] > limit) {
      limit = err[i];
      worst = i;
    }
  return worst;
}

// The used joints off the template's fit by more than cut: the worst left out and the rest
// refitted, up to kPalmMaxOutliers times (every used joint when no fit is possible). `moved`:
// how far each joint is from its template point in the template's frame (what another
// hand's proportions move it by; zero without a fit).
template <size_t P>
std::array<bool, P> off_joints(const std::array<V3, P>& a, const std::array<V3, P>& b, const std::array<bool, P>& use,
                               double cut, std::array<V3, P>& moved) {
  std::array<bool, P> in = use, off{};
  std::array<double, P> resid{};
  moved.fill(V3::Zero());
  Rigid fit;
  for (int left = 0;; ++left) {
    if (!kabsch(a, b, in, fit)) return use;
    for (size_t i = 0; i < P; ++i) resid[i] = use[i] ? (fit.apply(a[i]) - b[i]).norm() : 0.0;
    const size_t worst = worst_above(resid, in, cut);
    if (worst == P || left == kPalmMaxOutliers) break;
    in[worst] = false;
  }
  for (size_t i = 0; i < P; ++i) {
    off[i] = use[i] && resid[i] > cut;
    moved[i] = use[i] ? V3(fit.invert(b[i]) - a[i]) : V3::Zero();
  }
  return off;
}

}  // namespace

// The median over the known joints that have a median of their value v (0: none).
double PalmFit::median_joint(const std::array<double, kP>& v, const std::array<bool, kP>& known) const noexcept {
  std::array<double, kP> sorted{};
  int n = 0;
  for (size_t i = 0; i < kP; ++i)
    if (known[i] && median_n_[i] > 0) sorted[static_cast<size_t>(n++)] = v[i];
  if (n == 0) return 0.0;
  std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.begin() + n);
  return sorted[static_cast<size_t>(n / 2)];
}

void PalmFit::reset() noexcept {
  for (auto& p : tmpl_) p = {0.0, 0.0, 0.0};
  count_.fill(0.0);
  rows_ = 0;
  resid2_ = resid_rows_ = 0.0;
  median_.fill(0.0);
  median_n_.fill(0);
  peak_.fill(0.0);
  off_run_.fill(0);
  unfit_run_ = 0;
  last_scale_ = 0.0;
  check_ = 0;
}

void PalmFit::resume() noexcept {
  // The runs belong to the last take; its scale too (Leap Motion re-measures the hand's
  // size between takes).
  off_run_.fill(0);
  unfit_run_ = 0;
  last_scale_ = 0.0;
  check_ = rows_ > 0 ? 2 : 0;
  check_off_.fill(false);
}

void PalmFit::start(const std::array<V3, kP>& b, const std::array<bool, kP>& have) noexcept {
  reset();
  for (size_t i = 0; i < kP; ++i)
    if (have[i]) {
      tmpl_[i] = {b[i].x(), b[i].y(), b[i].z()};
      count_[i] = 1.0;
    }
  rows_ = 1;
}

void PalmFit::learn(size_t i, const V3& local) noexcept {
  count_[i] = std::min(count_[i] + 1.0, kPalmTemplateRows);
  for (int k = 0; k < 3; ++k) tmpl_[i][static_cast<size_t>(k)] += (local(k) - tmpl_[i][static_cast<size_t>(k)]) / count_[i];
}

void PalmFit::apply(Pose& pose) noexcept {
  std::array<V3, kP> b, a;
  std::array<bool, kP> have{}, known{}, use{};
  int n_have = 0, n_use = 0;
  for (size_t i = 0; i < kP; ++i) {
    const int j = kPalmJoints[i];
    b[i] = pose.row(j).transpose();
    have[i] = b[i].allFinite();
    n_have += have[i];
    a[i] = V3(tmpl_[i][0], tmpl_[i][1], tmpl_[i][2]);
    known[i] = count_[i] > 0.0;
    use[i] = have[i] && known[i];
    n_use += use[i];
  }
  if (n_have < kPalmMinPoints) return;
  if (rows_ == 0) {  // the first row sets the template
    start(b, have);
    return;
  }
  if (n_use < kPalmMinPoints) return;
  // Joints that do not move with the palm in this tracker (their median residual far
  // above the median joint's; a median, so a joint that often jumps is not taken for one;
  // or their peak median far above the median joint's peak, so a joint that rests a while
  // is not taken for rigid) are neither fitted nor answered: they pass through.
  const double rigid_limit = std::hypot(kPalmRigidFactor * median_joint(median_, known), kPalmRigidFloorM);
  const double loose_limit = std::hypot(kPalmRigidFactor * median_joint(peak_, known), kPalmRigidFloorM);
  std::array<bool, kP> rigid{}, loose{};
  for (size_t i = 0; i < kP; ++i) {
    loose[i] = peak_[i] > loose_limit;
    rigid[i] = known[i] && !(median_n_[i] >= kPalmMinRows && (median_[i] > rigid_limit || loose[i]));
  }
  n_use = 0;
  for (size_t i = 0; i < kP; ++i) {
    use[i] = use[i] && rigid[i];
    n_use += use[i];
  }
  if (n_use < kPalmMinPoints) return;
  // Outliers leave the fit one at a time, the worst first, and the rest are refitted
  // (robust to a few joints that jumped: one 30 mm jump pulls a least-squares fit of 11
  // points by ~3 mm, so a single cut after one fit would drop good joints too). The first
  // to leave are those whose distances to the others disagree with the template (several
  // large jumps in one row can pull a fit so far that its worst joint is a good one); the
  // rest leave by their residual. Joints that left by distance come back if the final fit
  // agrees with them. Before the residual is known, a fixed cut: an infinite one would let
  // the first rows' outliers into the template and the residual scale.
  const double scale = resid_rows_ >= 1.0 ? std::sqrt(resid2_) : kPalmFirstCutM / kPalmOutlier;
  const double cut = std::max(kPalmOutlier * scale, kPalmOutlierFloorM);
  // A resumed take: is this the hand the template learnt? A row that fits it but for one
  // joint is; otherwise the row passes unchanged and the next decides: two joints or more
  // off in both rows, each moved the same way (within the cut), are another hand (or one
  // its tracker re-measured), which starts a new template. A tracker's outliers (the
  // `paper` corruption's shifts of up to a fifth of the joints) seldom hit the same joint
  // twice running, and when they do, not by the same offset: counting the same joints
  // alone started a new template from a row of outliers in 3 % of FPHA's takes.
  if (check_ > 0) {
    std::array<V3, kP> moved{};
    const std::array<bool, kP> off = off_joints(a, b, use, cut, moved);
    int n_off = 0, n_both = 0;
    for (size_t i = 0; i < kP; ++i) {
      n_off += off[i];
      n_both += off[i] && check_off_[i] && (moved[i] - check_moved_[i]).norm() <= cut;
    }
    if (check_ == 2 && n_off > 1) {
      check_off_ = off;
      check_moved_ = moved;
      check_ = 1;
      return;
    }
    check_ = 0;
    if (n_both > 1) {
      start(b, have);
      return;
    }
  }
  std::array<double, kP> score{};
  distance_scores(a, b, use, last_scale_, score);
  const std::array<bool, kP> candidate = use;
  int n_in = n_use, left = 0;
  // Leaves joint i out of the fit; false when too many disagree: no fit this row. Many
  // such rows running: the hand is not the one the template learnt (a tracker that
  // changed its shape), so it is learnt anew.
  auto leave = [&](size_t i) {
    if (left == kPalmMaxOutliers || n_in <= kPalmMinPoints) {
      if (++unfit_run_ >= kPalmRestartRows) reset();
      return false;
    }
    use[i] = false;
    --n_in;
    ++left;
    return true;
  };
  for (size_t w; (w = worst_above(score, use, cut)) != kP;)
    if (!leave(w)) return;
  Rigid fit;
  std::array<double, kP> resid{};
  for (;;) {
    if (!kabsch(a, b, use, fit)) return;
    for (size_t i = 0; i < kP; ++i) resid[i] = use[i] ? (fit.apply(a[i]) - b[i]).norm() : 0.0;
    const size_t w = worst_above(resid, use, cut);
    if (w == kP) break;
    if (!leave(w)) return;
  }
  bool back = false;
  for (size_t i = 0; i < kP; ++i)
    if (candidate[i] && !use[i] && (fit.apply(a[i]) - b[i]).squaredNorm() <= cut * cut) {
      use[i] = back = true;
      ++n_in;
    }
  if (back && !kabsch(a, b, use, fit)) return;
  unfit_run_ = 0;
  last_scale_ = fit.s;
  // Learn: the inliers (and joints the template does not know yet) in the template's frame;
  // every present joint's median residual; the inliers' squared residual (winsorised at the
  // cut) for the next row's scale. An outlier several rows running is a template point
  // learnt wrong, or a shape the tracker changed: it is learnt anew from this row.
  double rs = 0.0;
  for (size_t i = 0; i < kP; ++i) {
    if (!have[i]) continue;
    const V3 local = fit.invert(b[i]);
    if (!known[i]) {
      learn(i, local);
      continue;
    }
    const double e = (fit.apply(a[i]) - b[i]).norm();
    // Running median (a stochastic step towards it, relative to its size).
    median_[i] += kPalmMedianStep * std::max(median_[i], kPalmMedianFloorM) * (e > median_[i] ? 1.0 : -1.0);
    median_[i] = std::max(median_[i], 0.0);
    median_n_[i] = std::min(median_n_[i] + 1, 1 << 20);
    peak_[i] = std::max(median_[i], peak_[i] * (1.0 - 1.0 / kPalmLooseRows));
    if (use[i]) rs += std::min(e * e, cut * cut);
    if (use[i] || !rigid[i]) {
      off_run_[i] = 0;
      learn(i, local);
    } else if (++off_run_[i] >= kPalmRelearnRows) {  // an outlier this row
      tmpl_[i] = {local.x(), local.y(), local.z()};
      count_[i] = 1.0;
      off_run_[i] = 0;
    }
  }
  resid_rows_ = std::min(resid_rows_ + 1.0, kPalmTemplateRows);
  resid2_ += (rs / n_in - resid2_) / resid_rows_;
  ++rows_;
  if (rows_ <= kPalmMinRows) return;
  // Answer: every rigid palm joint the template knows, where the fit puts it. A joint that
  // is not rigid here keeps its own position, unless it is far off its usual place (an
  // outlier against its own median residual, or a loose joint's peak: one that rested
  // has a median of nothing): there the fit's is nearer.
  for (size_t i = 0; i < kP; ++i) {
    const V3 p = fit.apply(a[i]);
    const double usual = loose[i] ? peak_[i] : median_[i];
    if (rigid[i] || (known[i] && have[i] && (p - b[i]).norm() > std::max(cut, kPalmOutlier * usual)))
      pose.row(kPalmJoints[i]) = p.transpose();
  }
}

}  // namespace hs
