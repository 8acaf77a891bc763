#include "joint_rewrite.hpp"

#include "handsteady/rigid_fit.hpp"
#include "handsteady/skeleton.hpp"
#include "joint_gate.hpp"

#include <algorithm>
#include <cmath>

namespace hs::layer {
namespace {
constexpr XrSpaceLocationFlags kTracked = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT;
constexpr double kMaxSpeed = 50.0;         // m/s: no joint of a hand moves faster
constexpr double kMaxAngularSpeed = 1000.0;  // rad/s: beyond noisy joint frames (tracker jitter over 2 cm bones)
constexpr float kDefaultTipRadius = 0.008f;  // a little less than kDefaultRadius at the tips

// A velocity no joint has (non-finite, over 50 m/s or 1000 rad/s) loses its valid bit.
int repair_velocity(XrHandJointVelocityEXT& v) noexcept {
  int changed = 0;
  if ((v.velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) &&
      (!xr::finite(v.linearVelocity) || !(xr::to_eigen(v.linearVelocity).norm() < kMaxSpeed))) {
    v.velocityFlags &= ~static_cast<XrSpaceVelocityFlags>(XR_SPACE_VELOCITY_LINEAR_VALID_BIT);
    ++changed;
  }
  if ((v.velocityFlags & XR_SPACE_VELOCITY_ANGULAR_VALID_BIT) &&
      (!xr::finite(v.angularVelocity) || !(xr::to_eigen(v.angularVelocity).norm() < kMaxAngularSpeed))) {
    v.velocityFlags &= ~static_cast<XrSpaceVelocityFlags>(XR_SPACE_VELOCITY_ANGULAR_VALID_BIT);
    ++changed;
  }
  return changed;
}

// Component-wise median of the usable rows of `p` (NaN when none).
Eigen::Vector3d median_centre(const Pose& p) {
  Pose copy = p;
  GateLimits loose;
  loose.min_norm_m = 0.0;
  loose.max_norm_m = 1e3;
  loose.max_from_centre_m = 1e3;
  loose.min_joints = 1;
  loose.min_spread_m = 0.0;
  return gate_joints(copy, loose).centre;
}
// The plausible joint fewest bones from j, up or down the hand tree (a finger whose base
// is garbage takes its own next joint, not the wrist 10 cm away); on a tie the ancestor.
// -1 when no joint is plausible.
int nearest_plausible(const JointMask& garbage, int j) noexcept {
  int best = -1, best_hops = 0;
  bool best_up = false;
  for (int k = 0; k < kJointCount; ++k) {
    if (garbage[static_cast<size_t>(k)] || k == j) continue;
    const int h = xr_bones_between(j, k);
    const bool up = xr_is_ancestor(k, j);
    if (best < 0 || h < best_hops || (h == best_hops && up && !best_up)) {
      best = k;
      best_hops = h;
      best_up = up;
    }
  }
  return best;
}
}  // namespace

JointMask garbage_joints(const XrHandJointLocationEXT* joints) noexcept {
  // The base space may be anywhere (VIEW, STAGE, an app's space): only the exact origin,
  // denormals and absurd magnitudes are judged by position, the rest by the hand's shape.
  Pose p;
  for (int j = 0; j < kJointCount; ++j) p.row(j) = xr::to_eigen(joints[j].pose.position).transpose();
  GateLimits limits;
  limits.min_norm_m = 1e-9;
  limits.max_norm_m = 1e3;
  limits.min_joints = 1;
  gate_joints(p, limits);  // a hand collapsed onto a point or a line: every joint
  JointMask bad{};
  for (int j = 0; j < kJointCount; ++j) bad[j] = !joint_tracked(p, j);
  return bad;
}

int repair_garbage(const JointMask& garbage, XrHandJointLocationEXT* joints, XrHandJointVelocityEXT* velocities) noexcept {
  const auto& parent = kXrParent;
  int changed = 0;  // a position is taken only from a joint not garbage, never from one repaired here
  JointMask bad_radius{};  // likewise a radius, and only from a joint whose radius is defined (position valid)
  for (int k = 0; k < kJointCount; ++k)
    bad_radius[static_cast<size_t>(k)] =
        !(joints[k].locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) || !radius_usable(joints[k].radius);
  for (int j = 0; j < kJointCount; ++j) {
    XrHandJointLocationEXT& loc = joints[j];
    if (garbage[j]) {
      const int k = nearest_plausible(garbage, j);
      if (k >= 0) {
        loc.pose.position = joints[k].pose.position;
        loc.locationFlags &= ~static_cast<XrSpaceLocationFlags>(XR_SPACE_LOCATION_POSITION_TRACKED_BIT);
      } else {
        // No plausible joint at all (a collapsed hand, every joint garbage): no valid position.
        if (!xr::finite(loc.pose.position)) loc.pose.position = {0.0f, 0.0f, 0.0f};  // a defined value
        loc.locationFlags &= ~static_cast<XrSpaceLocationFlags>(XR_SPACE_LOCATION_POSITION_TRACKED_BIT |
                                                                 XR_SPACE_LOCATION_POSITION_VALID_BIT);
      }
      ++changed;
    }
    if (!xr::usable(loc.pose.orientation)) {
      const int k = parent[j];
      loc.pose.orientation = k >= 0 && k < j && xr::usable(joints[k].pose.orientation) ? joints[k].pose.orientation
                                                                                       : XrQuaternionf{0, 0, 0, 1};
      loc.locationFlags &= ~static_cast<XrSpaceLocationFlags>(XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT);
      ++changed;
    }
    if ((loc.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) && !radius_usable(loc.radius)) {
      const int k = nearest_plausible(bad_radius, j);
      loc.radius = k >= 0 ? joints[k].radius : (is_tip(j) ? kDefaultTipRadius : kDefaultRadius);
      ++changed;
    }
    if (!velocities) continue;
    changed += repair_velocity(velocities[j]);
  }
  return changed;
}

int rewrite_forearm(const XrVector3f& wrist_before, XrHandJointLocationEXT* joints, uint32_t count,
                    XrHandJointVelocityEXT* velocities) noexcept {
  constexpr double kMaxFromWristM = 1.0;  // a forearm is about 25-30 cm
  const XrHandJointLocationEXT& wrist = joints[XR_HAND_JOINT_WRIST_EXT];
  const bool wrist_valid =
      (wrist.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) != 0 && xr::finite(wrist.pose.position);
  const Eigen::Vector3d w = xr::to_eigen(wrist.pose.position);
  // The wrist's correction (none where the runtime's wrist was garbage: no correction is a metre).
  Eigen::Vector3d shift = w - xr::to_eigen(wrist_before);
  if (!wrist_valid || !shift.allFinite() || !(shift.norm() < kMaxFromWristM)) shift.setZero();
  int changed = 0;
  for (uint32_t j = kJointCount; j < count; ++j) {
    XrHandJointLocationEXT& loc = joints[j];
    if (loc.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) {
      const Eigen::Vector3d p = xr::to_eigen(loc.pose.position) + shift;
      const bool garbage = !p.allFinite() || !(p.norm() < 1e3) || (wrist_valid && !((p - w).norm() < kMaxFromWristM));
      if (!garbage) {
        loc.pose.position = xr::to_xr(p);
      } else {
        loc.pose.position = wrist_valid ? wrist.pose.position : XrVector3f{0.0f, 0.0f, 0.0f};
        loc.locationFlags &= ~static_cast<XrSpaceLocationFlags>(
            wrist_valid ? XR_SPACE_LOCATION_POSITION_TRACKED_BIT
                        : XR_SPACE_LOCATION_POSITION_TRACKED_BIT | XR_SPACE_LOCATION_POSITION_VALID_BIT);
        ++changed;
      }
    }
    if (!xr::usable(loc.pose.orientation)) {
      loc.pose.orientation = xr::usable(wrist.pose.orientation) ? wrist.pose.orientation : XrQuaternionf{0, 0, 0, 1};
      loc.locationFlags &= ~static_cast<XrSpaceLocationFlags>(XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT);
      ++changed;
    }
    if ((loc.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) && !radius_usable(loc.radius)) {
      loc.radius = radius_usable(wrist.radius) ? wrist.radius : kDefaultRadius;
      ++changed;
    }
    if (!velocities) continue;
    changed += repair_velocity(velocities[j]);
  }
  return changed;
}

bool fit_base_from_world(const XrHandJointLocationEXT* base_joints, const JointMask& garbage, const Pose& world,
                         xr::Rigid& base_from_world) noexcept {
  std::array<Eigen::Vector3d, kJointCount> a, b;  // world, base
  std::array<bool, kJointCount> use{};
  int n = 0;
  for (int j = 0; j < kJointCount; ++j) {
    const size_t k = static_cast<size_t>(j);
    a[k] = world.row(j).transpose();
    b[k] = xr::to_eigen(base_joints[j].pose.position);
    use[k] = !garbage[k] && (base_joints[j].locationFlags & kTracked) == kTracked && a[k].allFinite() &&
             a[k].norm() < 1e3 && b[k].allFinite() && b[k].norm() < 1e3;
    n += use[k];
  }
  if (n < 4) return false;
  Eigen::Vector3d ca = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < use.size(); ++k)
    if (use[k]) ca += a[k];
  ca /= n;
  double spread = 0.0;
  for (size_t k = 0; k < use.size(); ++k)
    if (use[k]) spread = std::max(spread, (a[k] - ca).norm());
  hs::Rigid r;  // the rotation and translation taking the world's joints onto the base's
  if (!(spread >= 0.01) || !hs::kabsch(a, b, use, r, false)) return false;
  xr::Rigid fit = xr::Rigid::Identity();
  fit.linear() = r.r;
  fit.translation() = r.t;
  for (size_t k = 0; k < use.size(); ++k)
    if (use[k] && !((fit * a[k] - b[k]).norm() < 1e-3)) return false;
  base_from_world = fit;
  return true;
}

RewriteStats rewrite_joints(const Answer& answer, double smoothing, const xr::Rigid& base_from_world,
                            const BaseMotion& motion, JointMask& garbage, double max_offset_m,
                            XrHandJointLocationEXT* joints, XrHandJointVelocityEXT* velocities) noexcept {
  const JointMask bad = garbage;
  constexpr XrSpaceLocationFlags tracked = kTracked;
  const double w = std::clamp(answer.weight * smoothing, 0.0, 1.0);
  RewriteStats stats;
  {
    // The estimate must be about the hand the runtime shows.
    Pose raw_base;
    for (int j = 0; j < kJointCount; ++j)
      raw_base.row(j) = bad[j] || (joints[j].locationFlags & tracked) != tracked
                            ? Eigen::RowVector3d::Constant(std::nan(""))
                            : Eigen::RowVector3d(xr::to_eigen(joints[j].pose.position).transpose());
    const Eigen::Vector3d a = base_from_world * answer.centre, b = median_centre(raw_base);
    if (a.allFinite() && b.allFinite() && (a - b).norm() > max_offset_m) {
      stats.diverged = true;
      return stats;
    }
  }
  std::array<Eigen::Vector3d, kJointCount> raw, fresh;
  std::array<bool, kJointCount> replaced{};
  for (int j = 0; j < kJointCount; ++j) {
    const XrHandJointLocationEXT& loc = joints[j];
    raw[j] = xr::to_eigen(loc.pose.position);
    fresh[j] = raw[j];
    const Eigen::Vector3d e = answer.pose.row(j).transpose();
    if ((loc.locationFlags & tracked) != tracked || !e.allFinite()) continue;
    const Eigen::Vector3d target = base_from_world * e;
    if (!target.allFinite()) continue;
    Eigen::Vector3d offset = target - raw[j];
    if (answer.weight < 1.0 && offset.norm() > max_offset_m / 3.0) offset *= max_offset_m / 3.0 / offset.norm();
    fresh[j] = bad[j] ? target : Eigen::Vector3d(raw[j] + w * offset);
    replaced[j] = true;
    ++stats.replaced;
    if (bad[j]) ++stats.repaired;
    garbage[j] = false;
  }
  // Orientations follow their bones: the smallest rotation taking the runtime's bone
  // direction onto the new one, applied to the runtime's orientation (keeps its twist).
  std::array<XrQuaternionf, kJointCount> orient{};
  for (int j = 0; j < kJointCount; ++j) {
    orient[j] = joints[j].pose.orientation;
    const auto [a, b] = kXrFrameBone[j];
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
  // leaves the runtime's value (repair_garbage judges that).
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
