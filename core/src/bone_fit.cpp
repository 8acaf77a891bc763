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
}  // namespace

void BoneFit::reset() noexcept {
  bones_ = {};
  last_t_ = 0.0;
  rows_ = 0;
  take_rows_ = 0;
}

void BoneFit::resume() noexcept {
  for (auto& chain : bones_)
    for (Bone& b : chain) {
      b.last = 0.0;
      b.seen = 0;  // the take's first answers set the lengths anew (a tracker may re-measure the hand)
    }
  take_rows_ = 0;
}

double BoneFit::weight(size_t c, size_t b) const noexcept {
  const Bone& bone = bones_[c][b];
  if (!(bone.total > 0.0)) return 0.0;
  return std::clamp(bone.fast / bone.total, 0.0, 1.0);
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
      for (Bone& b : bones_[c]) b.last = 0.0;
      continue;
    }
    for (size_t i = 0; i < 3; ++i) {
      Bone& b = bones_[c][i];
      const double len = (joint(answer, chain[i + 1]) - joint(answer, chain[i])).norm();
      if (!std::isfinite(len) || len <= 0.0) continue;
      // The running means start as plain means over the bone's first answers.
      const double share = std::max(a, 1.0 / double(++b.seen));
      if (b.length == 0.0) {
        b.length = len;
      } else {
        const double d = len - b.length;
        b.total += share * (std::min(d * d, kBoneVarCapM2) - b.total);
        if (step && b.last > 0.0) {
          const double s = len - b.last;
          b.fast += std::max(a, 1.0 / double(++b.steps)) * (std::min(0.5 * s * s, kBoneVarCapM2) - b.fast);
        }
        b.length += share * std::clamp(d, -kBoneClipM, kBoneClipM);
      }
      // The base of the next step; a row after a pause (over kBoneStepGapS, not long enough
      // for a take) measures no step and is no base either: the row after it starts anew.
      if (step || b.last == 0.0) b.last = len;
      else b.last = 0.0;
    }
  }
  last_t_ = t;
  ++rows_;
  ++take_rows_;
}

void BoneFit::apply(Pose& pose, const JointMask* observed) const noexcept {
  if (take_rows_ < kBoneMinRows) return;
  for (size_t c = 0; c < kFingerChains.size(); ++c) {
    const auto& chain = kFingerChains[c];
    if (!chain_finite(pose, chain)) continue;
    // How readily each joint moves (the inverse of its weight in the least squares): a
    // joint the method filled in (missing from its input) gives way first.
    std::array<double, 4> give{};
    for (size_t k = 1; k < 4; ++k)
      give[k] = observed && !(*observed)[size_t(chain[k])] ? kBoneFilledGive : 1.0;
    std::array<V3, 4> y, x;
    for (size_t i = 0; i < 4; ++i) y[i] = x[i] = joint(pose, chain[i]);
    // Each bone's target: its length now moved towards the learnt one by its weight.
    std::array<double, 3> target{};
    bool any = false;
    for (size_t i = 0; i < 3; ++i) {
      const double now = (y[i + 1] - y[i]).norm();
      const double w = weight(c, i);  // 0 for a bone not yet seen (no variance learnt)
      target[i] = now + w * (bones_[c][i].length - now);
      any = any || w > 0.0;
    }
    if (!any) continue;
    bool ok = true;
    for (int it = 0; it < kBoneIterations && ok; ++it) {
      // Constraint i: u_i . (x_{i+1} - x_i) = target_i, u_i the bone's direction at the last
      // step; the root x_0 is fixed. x = y - D A^T (A D A^T)^-1 (A y - target), D = diag(give).
      std::array<V3, 3> u;
      for (size_t i = 0; i < 3; ++i) {
        const V3 d = x[i + 1] - x[i];
        const double n = d.norm();
        if (!(n > 1e-9)) ok = false;
        u[i] = ok ? V3(d / n) : V3::Zero();
      }
      if (!ok) break;
      // A D A^T: constraint i holds x_{i+1} (+u_i) and x_i (-u_i, i >= 1).
      Eigen::Matrix3d m;
      const double c01 = -give[1] * u[0].dot(u[1]), c12 = -give[2] * u[1].dot(u[2]);
      m << give[1], c01, 0.0,
           c01, give[1] + give[2], c12,
           0.0, c12, give[2] + give[3];
      Eigen::Vector3d g;
      for (int i = 0; i < 3; ++i) g[i] = u[size_t(i)].dot(y[size_t(i) + 1] - y[size_t(i)]) - target[size_t(i)];
      const Eigen::Vector3d lambda = m.ldlt().solve(g);
      if (!lambda.allFinite()) {
        ok = false;
        break;
      }
      for (size_t k = 1; k < 4; ++k) {
        V3 push = lambda[Eigen::Index(k - 1)] * u[k - 1];
        if (k < 3) push -= lambda[Eigen::Index(k)] * u[k];
        x[k] = y[k] - give[k] * push;
      }
    }
    if (!ok) continue;
    for (size_t i = 1; i < 4; ++i) pose.row(chain[i]) = x[i].transpose();
  }
}

}  // namespace hs
