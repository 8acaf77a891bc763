#include "hand_attachments.hpp"

#include "handsteady_xr/xr_math.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

namespace hs::layer {
namespace {
constexpr double kMaxNormM = 1e3;            // as garbage_joints: no hand is a kilometre away
constexpr double kMaxCapsuleFromJointM = 0.3;  // a capsule spans one bone, at most ~10 cm
constexpr double kMaxAimFromPalmM = 0.5;     // the aim's origin is on or near the hand

bool position_usable(const XrHandJointLocationEXT& loc) noexcept {
  return (loc.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) && xr::finite(loc.pose.position);
}

// The rigid change the layer made to joint j (identity where there is none to tell: the
// runtime's joint garbage or without a position). Orientation changes count only where
// both orientations are usable; otherwise the change is the translation alone.
xr::Rigid joint_change(const JointsBefore& before, const XrHandJointLocationEXT* after, int j) noexcept {
  const XrHandJointLocationEXT& a = before.loc[static_cast<size_t>(j)];
  const XrHandJointLocationEXT& b = after[j];
  xr::Rigid change = xr::Rigid::Identity();
  if (before.garbage[static_cast<size_t>(j)] || !position_usable(a) || !position_usable(b)) return change;
  constexpr XrSpaceLocationFlags oriented = XR_SPACE_LOCATION_ORIENTATION_VALID_BIT;
  if ((a.locationFlags & oriented) && (b.locationFlags & oriented) && xr::usable(a.pose.orientation) &&
      xr::usable(b.pose.orientation)) {
    change = xr::to_rigid(b.pose) * xr::to_rigid(a.pose).inverse();
  } else {
    change.translation() = xr::to_eigen(b.pose.position) - xr::to_eigen(a.pose.position);
  }
  return change.matrix().allFinite() ? change : xr::Rigid::Identity();
}

// Where a capsule or the aim is judged from, and collapses onto: a joint's answered
// position, even one not valid (a collapsed hand's), while it is a place at all.
std::optional<Eigen::Vector3d> place(const XrHandJointLocationEXT& loc) noexcept {
  const Eigen::Vector3d p = xr::to_eigen(loc.pose.position);
  return p.allFinite() && p.norm() < kMaxNormM ? std::optional<Eigen::Vector3d>(p) : std::nullopt;
}

bool plausible_near(const Eigen::Vector3d& p, const std::optional<Eigen::Vector3d>& anchor, double max_from) noexcept {
  return p.allFinite() && p.norm() < kMaxNormM && (!anchor || (p - *anchor).norm() < max_from);
}
}  // namespace

int move_capsules(const JointsBefore& before, const XrHandJointLocationEXT* after,
                  XrHandTrackingCapsulesStateFB& capsules) noexcept {
  int changed = 0;
  for (XrHandCapsuleFB& c : capsules.capsules) {
    const int j = static_cast<int>(c.joint);
    const bool known = j >= 0 && j < kJointCount;
    const XrHandJointLocationEXT& joint = after[known ? j : XR_HAND_JOINT_PALM_EXT];
    const xr::Rigid change = known ? joint_change(before, after, j) : xr::Rigid::Identity();
    std::optional<Eigen::Vector3d> anchor = place(joint);  // else the palm's
    if (!anchor) anchor = place(after[XR_HAND_JOINT_PALM_EXT]);
    bool plausible = known;
    std::array<Eigen::Vector3d, XR_FB_HAND_TRACKING_CAPSULE_POINT_COUNT> moved;
    for (size_t k = 0; k < moved.size(); ++k) {
      moved[k] = change * xr::to_eigen(c.points[k]);
      plausible = plausible && plausible_near(moved[k], anchor, kMaxCapsuleFromJointM);
    }
    if (plausible) {
      for (size_t k = 0; k < moved.size(); ++k) c.points[k] = xr::to_xr(moved[k]);
    } else {
      for (XrVector3f& p : c.points) p = anchor ? xr::to_xr(*anchor) : XrVector3f{0.0f, 0.0f, 0.0f};
      ++changed;
    }
    if (!radius_usable(c.radius)) {
      c.radius = radius_usable(joint.radius) ? joint.radius : kDefaultRadius;
      ++changed;
    }
  }
  return changed;
}

int move_aim(const JointsBefore& before, const XrHandJointLocationEXT* after, XrHandTrackingAimStateFB& aim) noexcept {
  int changed = 0;
  for (float* s : {&aim.pinchStrengthIndex, &aim.pinchStrengthMiddle, &aim.pinchStrengthRing, &aim.pinchStrengthLittle}) {
    const float v = std::isnan(*s) ? 0.0f : std::clamp(*s, 0.0f, 1.0f);
    if (!(v == *s)) {
      *s = v;
      ++changed;
    }
  }
  if (!(aim.status & XR_HAND_TRACKING_AIM_VALID_BIT_FB)) return changed;
  const XrHandJointLocationEXT& palm = after[XR_HAND_JOINT_PALM_EXT];
  // The palm's position change (a rigid change's translation is not: it carries the rotation about the origin).
  const xr::Rigid change = joint_change(before, after, XR_HAND_JOINT_PALM_EXT);
  const Eigen::Vector3d palm_before = xr::to_eigen(before.loc[XR_HAND_JOINT_PALM_EXT].pose.position);
  Eigen::Vector3d shift = change * palm_before - palm_before;
  if (!shift.allFinite()) shift.setZero();  // a garbage palm: no change to tell
  const Eigen::Vector3d moved = xr::to_eigen(aim.aimPose.position) + shift;
  const std::optional<Eigen::Vector3d> anchor = place(palm);
  if (xr::usable(aim.aimPose.orientation) && plausible_near(moved, anchor, kMaxAimFromPalmM)) {
    aim.aimPose.position = xr::to_xr(moved);
    return changed;
  }
  aim.status &= ~static_cast<XrHandTrackingAimFlagsFB>(XR_HAND_TRACKING_AIM_VALID_BIT_FB);
  aim.aimPose.position = anchor ? xr::to_xr(*anchor) : XrVector3f{0.0f, 0.0f, 0.0f};
  aim.aimPose.orientation = xr::usable(palm.pose.orientation) ? palm.pose.orientation : XrQuaternionf{0, 0, 0, 1};
  return changed + 1;
}

int move_hand_pose(HandPose pose, const JointsBefore& before, const XrHandJointLocationEXT* after,
                   const XrPosef& pose_in_action, XrSpaceLocation& loc) noexcept {
  constexpr XrSpaceLocationFlags kAll = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT |
                                        XR_SPACE_LOCATION_ORIENTATION_VALID_BIT |
                                        XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT;
  if (pose == HandPose::None || !(loc.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT)) return 0;
  const bool oriented = (loc.locationFlags & XR_SPACE_LOCATION_ORIENTATION_VALID_BIT) != 0;
  Eigen::Vector3d p = xr::to_eigen(loc.pose.position);
  Eigen::Quaterniond q = xr::to_eigen(loc.pose.orientation);
  const bool usable = p.allFinite() && p.norm() < kMaxNormM && (!oriented || xr::usable(loc.pose.orientation));
  if (usable) {
    // The position change of joint j (a rigid change's translation is not: it carries the rotation about the origin).
    const auto shift = [&](int j) {
      const Eigen::Vector3d at = xr::to_eigen(before.loc[static_cast<size_t>(j)].pose.position);
      const Eigen::Vector3d d = joint_change(before, after, j) * at - at;
      return d.allFinite() ? d : Eigen::Vector3d::Zero();
    };
    if (pose == HandPose::Grip || pose == HandPose::Poke) {
      const xr::Rigid change =
          joint_change(before, after, pose == HandPose::Grip ? XR_HAND_JOINT_PALM_EXT : XR_HAND_JOINT_INDEX_TIP_EXT);
      p = change * p;
      if (oriented) q = Eigen::Quaterniond(change.rotation()) * q.normalized();
    } else if (pose == HandPose::Aim) {
      p += shift(XR_HAND_JOINT_PALM_EXT);
    } else {
      p += 0.5 * (shift(XR_HAND_JOINT_THUMB_TIP_EXT) + shift(XR_HAND_JOINT_INDEX_TIP_EXT));
    }
    // The action's own pose (without the app's offset in it) is on or near the hand.
    const xr::Rigid located = xr::to_rigid(XrPosef{oriented ? xr::to_xr(q) : XrQuaternionf{0, 0, 0, 1}, xr::to_xr(p)});
    const Eigen::Vector3d origin = (located * xr::to_rigid(pose_in_action).inverse()).translation();
    const std::optional<Eigen::Vector3d> palm = place(after[XR_HAND_JOINT_PALM_EXT]);
    if (plausible_near(origin, palm, kMaxAimFromPalmM)) {
      loc.pose.position = xr::to_xr(p);
      if (oriented) loc.pose.orientation = xr::to_xr(q.normalized());
      return 0;
    }
  }
  loc.locationFlags &= ~kAll;
  return 1;
}

}  // namespace hs::layer
