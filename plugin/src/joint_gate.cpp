#include "joint_gate.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace hs::layer {

GateResult gate_joints(Pose& pose, const GateLimits& limits) noexcept {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  GateResult r;
  std::array<bool, kJointCount> ok{};
  int n = 0;
  for (int j = 0; j < kJointCount; ++j) {
    if (!joint_tracked(pose, j)) continue;
    const Eigen::Vector3d p = pose.row(j).transpose();
    const double norm = p.norm();
    ok[j] = p.allFinite() && norm >= limits.min_norm_m && norm <= limits.max_norm_m;
    if (ok[j]) ++n;
    else ++r.rejected;
  }
  Eigen::Vector3d centre = Eigen::Vector3d::Constant(nan);
  if (n >= limits.min_joints) {
    // Component-wise median: a few wild joints cannot move it.
    std::array<double, kJointCount> v{};
    for (int k = 0; k < 3; ++k) {
      int m = 0;
      for (int j = 0; j < kJointCount; ++j)
        if (ok[j]) v[m++] = pose(j, k);
      std::nth_element(v.begin(), v.begin() + m / 2, v.begin() + m);
      centre[k] = v[m / 2];
    }
    for (int j = 0; j < kJointCount; ++j)
      if (ok[j] && (pose.row(j).transpose() - centre).norm() > limits.max_from_centre_m) {
        ok[j] = false;
        --n;
        ++r.rejected;
      }
  }
  bool collapsed = false;
  if (n >= limits.min_joints && limits.min_spread_m > 0.0 && n >= limits.spread_joints) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int j = 0; j < kJointCount; ++j)
      if (ok[j]) mean += pose.row(j).transpose();
    mean /= static_cast<double>(n);
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int j = 0; j < kJointCount; ++j)
      if (ok[j]) {
        const Eigen::Vector3d d = pose.row(j).transpose() - mean;
        cov += d * d.transpose();
      }
    cov /= static_cast<double>(n);
    // Ascending eigenvalues: [1] is the variance along the second principal axis.
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov, Eigen::EigenvaluesOnly).eigenvalues();
    collapsed = !(ev[1] >= limits.min_spread_m * limits.min_spread_m);
  }
  if (n < limits.min_joints || collapsed) {
    r.rejected += n;
    n = 0;
    ok.fill(false);
    centre.setConstant(nan);
  }
  for (int j = 0; j < kJointCount; ++j)
    if (!ok[j]) pose.row(j).setConstant(nan);
  r.kept = n;
  r.centre = centre;
  return r;
}

bool hand_jumped(const Eigen::Vector3d& prev, const Eigen::Vector3d& now, double dt_s, const GateLimits& limits) noexcept {
  if (!prev.allFinite() || !now.allFinite() || !(dt_s >= 0.0)) return false;
  const double d = (now - prev).norm();
  if (d > limits.max_speed_m_s * dt_s + limits.jump_slack_m) return true;
  return dt_s > limits.lost_s && d > limits.reacquire_m + limits.reacquire_m_s * dt_s;
}

}  // namespace hs::layer
