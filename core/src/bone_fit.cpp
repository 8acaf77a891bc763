#include "handsteady/bone_fit.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace hs {

namespace {
using V3 = Eigen::Vector3d;

V3 joint(const Pose& p, int j) { return p.row(j).transpose(); }

bool chain_finite(const Pose& p, const std::array<int, 4>& chain) {
  for (int j : chain)
    if (!joint_finite(p, j)) return false;
  return true;
}

// The tip's signed distance from the plane of the chain's first three joints (normal
// along bone 0 x bone 1), and with `grad` its gradient with respect to joints 1-3 (the root
// is fixed). false where the first two bones are too close to a line for the plane to be
// known (a straight finger: any tip is in some plane).
bool tip_plane_offset(const std::array<V3, 4>& x, double& s, std::array<V3, 3>* grad, double min_sin = kPlaneMinSin,
                      double* sine = nullptr) {
  const V3 a = x[1] - x[0], b = x[2] - x[1], d = x[3] - x[2];
  const V3 m = a.cross(b);
  const double mn = m.norm(), ab = a.norm() * b.norm();
  if (!(mn >= min_sin * ab) || !(mn > 1e-12)) return false;
  if (sine) *sine = mn / ab;
  const V3 n = m / mn;
  s = n.dot(d);
  if (grad) {
    // ds/da = b x d_perp / |m|, ds/db = d_perp x a / |m|, ds/dd = n; a = x1 - x0, b = x2 - x1, d = x3 - x2.
    const V3 dp = (d - s * n) / mn;
    const V3 ga = b.cross(dp), gb = dp.cross(a);
    (*grad)[0] = ga - gb;
    (*grad)[1] = gb - n;
    (*grad)[2] = n;
  }
  return std::isfinite(s);
}

std::array<V3, 4> chain_points(const Pose& p, const std::array<int, 4>& chain) {
  std::array<V3, 4> x;
  for (size_t i = 0; i < 4; ++i) x[i] = joint(p, chain[i]);
  return x;
}
}  // namespace

void BoneFit::reset() noexcept {
  bones_ = {};
  planes_ = {};
  last_t_ = 0.0;
  rows_ = 0;
  take_rows_ = 0;
}

void BoneFit::resume() noexcept {
  // The take's first answers set the means anew (a tracker may re-measure the hand).
  for (auto& chain : bones_)
    for (Stat& b : chain) {
      b.has_last = false;
      b.seen = 0;
    }
  for (Stat& p : planes_) {
    p.has_last = false;
    p.seen = 0;
  }
  take_rows_ = 0;
}

void BoneFit::Stat::learn(double v, bool step, double a) noexcept {
  // The running means start as plain means over the first answers.
  const double share = std::max(a, 1.0 / double(++seen));
  if (!known) {
    mean = v;
    known = true;
  } else {
    const double d = v - mean;
    total += share * (std::min(d * d, kBoneVarCapM2) - total);
    if (step && has_last) {
      const double st = v - last;
      fast += std::max(a, 1.0 / double(++steps)) * (std::min(0.5 * st * st, kBoneVarCapM2) - fast);
    }
    mean += share * std::clamp(d, -kBoneClipM, kBoneClipM);
  }
  // The base of the next step; a row after a pause (over kBoneStepGapS, not long enough
  // for a take) measures no step and is no base either: the row after it starts anew.
  has_last = step || !has_last;
  last = v;
}

double BoneFit::Stat::weight() const noexcept {
  if (!(total > 0.0)) return 0.0;
  return std::clamp(fast / total, 0.0, 1.0);
}

void BoneFit::learn(double t, const Pose& answer) noexcept {
  if (!std::isfinite(t)) return;
  const double dt = rows_ > 0 ? t - last_t_ : 0.0;
  if (rows_ > 0 && !(dt > 0.0)) return;  // an answer at the same time teaches nothing new
  std::array<bool, kFingerChains.size()> have{};
  for (size_t c = 0; c < kFingerChains.size(); ++c) have[c] = chain_finite(answer, kFingerChains[c]);
  if (std::none_of(have.begin(), have.end(), [](bool h) { return h; })) return;  // an untracked answer teaches nothing (and is no row)
  const bool step = rows_ > 0 && dt <= kBoneStepGapS;
  // The share of the running means a row moves, by time, so any rate learns alike; after
  // a gap, no more than a row's.
  const double a = rows_ > 0 ? 1.0 - std::exp(-std::min(dt, kBoneStepGapS) / kBoneTauS) : 1.0;
  for (size_t c = 0; c < kFingerChains.size(); ++c) {
    const auto& chain = kFingerChains[c];
    if (!have[c]) {
      for (Stat& b : bones_[c]) b.has_last = false;
      planes_[c].has_last = false;
      continue;
    }
    for (size_t i = 0; i < 3; ++i) {
      const double len = (joint(answer, chain[i + 1]) - joint(answer, chain[i])).norm();
      if (std::isfinite(len) && len > 0.0) bones_[c][i].learn(len, step, a);
    }
    double s = 0.0;
    if (tip_plane_offset(chain_points(answer, chain), s, nullptr)) planes_[c].learn(s, step, a);
    else planes_[c].has_last = false;  // no plane this row: the next one measures no step
  }
  last_t_ = t;
  ++rows_;
  ++take_rows_;
}

void BoneFit::apply(Pose& pose, const JointMask* observed) const noexcept {
  if (take_rows_ < kBoneMinRows) return;
  using M49 = Eigen::Matrix<double, 4, 9>;
  using V9 = Eigen::Matrix<double, 9, 1>;
  for (size_t c = 0; c < kFingerChains.size(); ++c) {
    const auto& chain = kFingerChains[c];
    if (!chain_finite(pose, chain)) continue;
    // How readily each joint moves (the inverse of its weight in the least squares): a
    // joint the method filled in (missing from its input) gives way first.
    V9 give;
    for (size_t k = 1; k < 4; ++k)
      give.segment<3>(Eigen::Index(3 * (k - 1))).setConstant(observed && !(*observed)[size_t(chain[k])] ? kBoneFilledGive : 1.0);
    const std::array<V3, 4> y = chain_points(pose, chain);
    std::array<V3, 4> x = y;
    // Each bone's target: its length now moved towards the learnt one by its weight; the
    // tip's offset from the finger's plane likewise.
    Eigen::Vector4d target = Eigen::Vector4d::Zero();
    bool any = false;
    for (size_t i = 0; i < 3; ++i) {
      const double now = (y[i + 1] - y[i]).norm();
      const double w = weight(c, i);  // 0 for a bone not yet seen (no variance learnt)
      target[Eigen::Index(i)] = now + w * (bones_[c][i].mean - now);
      any = any || w > 0.0;
    }
    // The plane's pull fades in with the chain's bend (kPlaneFadeSin), so a finger bent
    // near the threshold does not switch it on and off from row to row (a jerk).
    const double wp = plane_weight(c);
    double s_now = 0.0, sine = 0.0;
    const bool plane = wp > 0.0 && tip_plane_offset(y, s_now, nullptr, kPlaneFadeSin[0], &sine);
    if (plane) {
      const double fade = std::clamp((sine - kPlaneFadeSin[0]) / (kPlaneFadeSin[1] - kPlaneFadeSin[0]), 0.0, 1.0);
      target[3] = s_now + fade * wp * (planes_[c].mean - s_now);
    }
    if (!any && !plane) continue;
    V9 yv;
    for (size_t k = 1; k < 4; ++k) yv.segment<3>(Eigen::Index(3 * (k - 1))) = y[k];
    bool ok = true;
    for (int it = 0; it < kBoneIterations && ok; ++it) {
      // Rows 0-2, bone i: u_i . (x_{i+1} - x_i) = target_i, u_i the bone's direction at the
      // last step; row 3: the plane offset linearised at the last step. The root x_0 is
      // fixed. x = y - D A^T (A D A^T)^-1 (A y - b), D = diag(give).
      M49 A = M49::Zero();
      Eigen::Vector4d b = target;
      for (size_t i = 0; i < 3; ++i) {
        const V3 d = x[i + 1] - x[i];
        const double n = d.norm();
        if (!(n > 1e-9)) {
          ok = false;
          break;
        }
        const V3 u = d / n;
        A.block<1, 3>(Eigen::Index(i), Eigen::Index(3 * i)) = u.transpose();
        if (i >= 1) A.block<1, 3>(Eigen::Index(i), Eigen::Index(3 * (i - 1))) = -u.transpose();
        b[Eigen::Index(i)] += i >= 1 ? 0.0 : u.dot(x[0]);  // the fixed root's share
      }
      if (!ok) break;
      std::array<V3, 3> grad;
      double s = 0.0;
      const bool row3 = plane && tip_plane_offset(x, s, &grad, 0.5 * kPlaneFadeSin[0]);
      V9 xv;
      for (size_t k = 1; k < 4; ++k) xv.segment<3>(Eigen::Index(3 * (k - 1))) = x[k];
      if (row3) {
        // The plane is met by turning it (joints 1 and 2), not by moving the tip: the tip is
        // what users watch (a pen, a pointer), and the plane's orientation carries the noise
        // of the joints that span it. Moving the tip too made the demo test's pen 5 % jerkier
        // (18 % with the model in the app's thread).
        for (size_t k = 0; k < 2; ++k) A.block<1, 3>(3, Eigen::Index(3 * k)) = grad[k].transpose();
        b[3] = target[3] - s + A.row(3).dot(xv);
      }
      Eigen::Matrix4d m = A * give.asDiagonal() * A.transpose();
      Eigen::Vector4d g = A * yv - b;
      if (!row3) {
        m(3, 3) = 1.0;
        g[3] = 0.0;
      }
      const Eigen::Vector4d lambda = m.ldlt().solve(g);
      if (!lambda.allFinite()) {
        ok = false;
        break;
      }
      const V9 nx = yv - give.asDiagonal() * (A.transpose() * lambda);
      for (size_t k = 1; k < 4; ++k) x[k] = nx.segment<3>(Eigen::Index(3 * (k - 1)));
    }
    if (!ok) continue;
    for (size_t i = 1; i < 4; ++i) pose.row(chain[i]) = x[i].transpose();
  }
}

}  // namespace hs
