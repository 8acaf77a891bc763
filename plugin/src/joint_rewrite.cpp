#include "joint_rewrite.hpp"

#include <cmath>

namespace hs::layer {

bool garbage_position(const XrVector3f& p) noexcept {
  if (!xr::finite(p)) return true;
  const double n = xr::to_eigen(p).norm();
  return !(n > 1e-9 && n < 1e3);
}

RewriteStats rewrite_joints(const Answer& answer, double smoothing, const xr::Rigid& base_from_world,
                            const BaseMotion& motion, XrHandJointLocationEXT* joints,
                            XrHandJointVelocityEXT* velocities) noexcept {
  constexpr XrSpaceLocationFlags tracked = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT;
  const double w = std::clamp(answer.weight * smoothing, 0.0, 1.0);
  RewriteStats stats;
  std::array<Eigen::Vector3d, kJointCount> raw, fresh;
  std::array<bool, kJointCount> replaced{}, bad{};
  for (int j = 0; j < kJointCount; ++j) {
    const XrHandJointLocationEXT& loc = joints[j];
    bad[j] = garbage_position(loc.pose.position);
    raw[j] = xr::to_eigen(loc.pose.position);
    fresh[j] = raw[j];
    const Eigen::Vector3d e = answer.pose.row(j).transpose();
    if ((loc.locationFlags & tracked) != tracked || !e.allFinite()) continue;
    const Eigen::Vector3d target = base_from_world * e;
    if (!target.allFinite()) continue;
    fresh[j] = bad[j] ? target : Eigen::Vector3d(raw[j] + w * (target - raw[j]));
    replaced[j] = true;
    ++stats.replaced;
    if (bad[j]) ++stats.repaired;
  }
  // Orientations follow their bones: the smallest rotation taking the runtime's bone
  // direction onto the new one, applied to the runtime's orientation (keeps its twist).
  std::array<XrQuaternionf, kJointCount> orient{};
  for (int j = 0; j < kJointCount; ++j) {
    orient[j] = joints[j].pose.orientation;
    const auto [a, b] = xr::kJointBone[j];
    if ((!replaced[a] && !replaced[b]) || bad[a] || bad[b]) continue;
    const Eigen::Vector3d d_raw = raw[b] - raw[a], d_new = fresh[b] - fresh[a];
    if (!d_raw.allFinite() || !d_new.allFinite() || d_raw.norm() < 1e-6 || d_new.norm() < 1e-6 ||
        !xr::usable(orient[j]))
      continue;
    const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(d_raw, d_new) * xr::to_eigen(orient[j]).normalized();
    orient[j] = xr::to_xr(q.normalized());
  }
  for (int j = 0; j < kJointCount; ++j) {
    joints[j].pose.position = xr::to_xr(fresh[j]);
    joints[j].pose.orientation = orient[j];
  }
  if (!velocities) return stats;
  // Linear velocities relative to the base: the estimate's world velocity rotated into
  // the base, plus the base's own motion. Anything non-finite or faster than a hand
  // leaves the runtime's value.
  constexpr double kMaxSpeed = 50.0;
  const Eigen::Matrix3d R = base_from_world.linear();
  for (int j = 0; j < kJointCount; ++j) {
    XrHandJointVelocityEXT& v = velocities[j];
    const Eigen::Vector3d ev = answer.velocity.row(j).transpose();
    if (!replaced[j] || !(v.velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) || !ev.allFinite()) continue;
    Eigen::Vector3d frame = Eigen::Vector3d::Zero();
    if (motion.valid) {
      frame = motion.linear + motion.angular.cross(fresh[j] - base_from_world.translation());
    } else if (motion.world_velocities) {
      const XrHandJointVelocityEXT& wv = motion.world_velocities[j];
      if ((wv.velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) && xr::finite(wv.linearVelocity) &&
          xr::finite(v.linearVelocity)) {
        const Eigen::Vector3d rel = xr::to_eigen(v.linearVelocity) - R * xr::to_eigen(wv.linearVelocity);
        if (rel.norm() < 5.0) frame = rel;  // more is not a head or a base moving: garbage
      }
    }
    const Eigen::Vector3d target = R * ev + frame;
    const Eigen::Vector3d old = xr::to_eigen(v.linearVelocity);
    const bool old_ok = old.allFinite() && old.norm() < kMaxSpeed;
    const Eigen::Vector3d out = old_ok && !bad[j] ? Eigen::Vector3d(old + w * (target - old)) : target;
    if (out.allFinite() && out.norm() < kMaxSpeed) v.linearVelocity = xr::to_xr(out);
  }
  return stats;
}

}  // namespace hs::layer
