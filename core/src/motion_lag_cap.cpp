#include "handsteady/motion_lag_cap.hpp"

#include <Eigen/Core>

#include <cmath>

namespace hs {

void MotionLagCap::reset() noexcept {
  for (Pose& a : answers_) a = untracked_pose();
  n_ = 0;
  shift_.fill(0.0);
}

void MotionLagCap::observe(std::span<const float> x, const Pose& answer, std::span<const double> noise2,
                           std::span<const double> jump, std::span<const bool> stretched,
                           double jump_share) noexcept {
  shift_.fill(0.0);
  Pose capped = answer;
  const bool ready = n_ >= static_cast<long>(kRows) && x.size() >= 3 * kJointCount && noise2.size() >= kJointCount &&
                     jump.size() >= kJointCount;
  if (ready) {
    const Pose& last = answers_[static_cast<size_t>((n_ - 1) % static_cast<long>(kRows))];
    const Pose& third = answers_[static_cast<size_t>(n_ % static_cast<long>(kRows))];  // kRows rows back
    const bool bones = stretched.size() >= kJointCount;  // whether the bones' evidence came
    for (int j = 0; j < kJointCount; ++j) {
      const auto ju = static_cast<size_t>(j);
      const float* xj = x.data() + 3 * ju;
      const Eigen::Vector3d in = Eigen::Vector3f(xj[0], xj[1], xj[2]).cast<double>();
      const Eigen::Vector3d out = answer.row(j).transpose();
      const Eigen::Vector3d step = (last.row(j) - third.row(j)).transpose();
      const double sigma = std::sqrt(noise2[ju]);
      if (!in.allFinite() || !out.allFinite() || !step.allFinite() || !(sigma > 0.0)) continue;
      // The step spans two row intervals: its noise is sqrt(2) sigma.
      const double sn = step.norm();
      if (!(sn > kMotionCapSpeedZ * std::sqrt(2.0) * sigma)) continue;
      const Eigen::Vector3d u = step / sn;
      const Eigen::Vector3d correction = out - in;
      const double along = correction.dot(u), cap = kMotionCapFactor * sigma;
      if (!(std::abs(along) > cap)) continue;
      // A row InputNoise calls a jump is a fast hand's own row (the answer behind or ahead of
      // it along the motion: lag) or an outlier taken back. An outlier of one joint mostly
      // stretches a bone it ends, the hand's motion keeps them all; one that keeps them (a
      // shift that turns its bone) shows in the correction, as large as the outlier and in its
      // direction: kept whole where the correction along the step is over `jump_share` of
      // the step, or mostly across it.
      if (jump[ju] > 0.0 &&
          ((bones && stretched[ju]) || std::abs(along) > jump_share * sn ||
           (correction - along * u).norm() > std::abs(along)))
        continue;
      const Eigen::Vector3d d = -u * (along - std::copysign(cap, along));
      for (int c = 0; c < 3; ++c) shift_[3 * ju + static_cast<size_t>(c)] = d[c];
      capped.row(j) += d.transpose();
    }
  }
  answers_[static_cast<size_t>(n_ % static_cast<long>(kRows))] = capped;
  ++n_;
}

}  // namespace hs
