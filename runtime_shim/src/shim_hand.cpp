// The replay runtime's simulated hand (see shim_hand.hpp).
#include "shim_hand.hpp"

#include "handsteady/track_ops.hpp"
#include "handsteady_xr/xr_math.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace hs::shim {

Pose replayed_hand(const HandSeries& series, const ShimConfig& cfg, const TrackClock& clock, XrTime t, XrTime now) {
  if (series.empty()) return untracked_pose();
  switch (cfg.future) {
    case FuturePolicy::Exact: break;
    case FuturePolicy::Hold: t = std::min(t, now); break;
    case FuturePolicy::Latest: t = now; break;
    case FuturePolicy::Extrapolate: {
      // The newest capture available now and the one before, on the capture grid.
      const double period = 1.0 / cfg.capture_hz;
      const double newest = std::floor(clock.at(std::min(t, now) - cfg.capture_latency_ns) / period) * period;
      const Pose a = interpolate_pose(series, newest - period), b = interpolate_pose(series, newest);
      const double ahead = clock.at(t) - newest;
      if (ahead <= 0.0) return interpolate_pose(series, clock.at(t));
      if (!any_joint_tracked(b)) return b;
      Pose out = b + (b - a) * (ahead / period);  // joints missing in a stay missing
      for (int j = 0; j < kJointCount; ++j)
        if (!joint_tracked(a, j) && joint_tracked(b, j)) out.row(j) = b.row(j);
      return out;
    }
  }
  return interpolate_pose(series, clock.at(t));
}

Eigen::Vector3d elbow_position(const Pose& filled) {
  return Eigen::Vector3d(filled.row(idx(Joint::Wrist)).transpose()) + Eigen::Vector3d(0.0, -0.18, 0.18);
}

Pose with_valid_positions(const Pose& p) {
  Pose out = p;
  for (int j = 0; j < kJointCount; ++j) {
    if (joint_tracked(p, j)) continue;
    int k = j;
    while (k >= 0 && !joint_tracked(p, k)) k = kXrParent[static_cast<size_t>(k)];
    if (k < 0) {
      k = 0;
      while (k < kJointCount && !joint_tracked(p, k)) ++k;
    }
    if (k < kJointCount) out.row(j) = p.row(k);
    else out.row(j).setZero();
  }
  return out;
}

std::array<Eigen::Matrix3d, kJointCount> joint_frames(const Pose& p, bool left) {
  std::array<Eigen::Matrix3d, kJointCount> out;
  const Eigen::Vector3d wrist = p.row(idx(Joint::Wrist)).transpose();
  const Eigen::Vector3d index = p.row(idx(Joint::IndexProximal)).transpose();
  const Eigen::Vector3d little = p.row(idx(Joint::LittleProximal)).transpose();
  Eigen::Vector3d back = (little - wrist).cross(index - wrist);
  if (left) back = -back;
  for (int j = 0; j < kJointCount; ++j) {
    out[j].setIdentity();
    const auto [a, b] = kXrFrameBone[j];
    const Eigen::Vector3d bone = (p.row(b) - p.row(a)).transpose();
    if (!bone.allFinite() || bone.norm() < 1e-9 || !back.allFinite()) continue;
    const Eigen::Vector3d z = -bone.normalized();
    Eigen::Vector3d y = back - back.dot(z) * z;
    if (y.norm() < 1e-9) continue;
    y.normalize();
    out[j].col(0) = y.cross(z);
    out[j].col(1) = y;
    out[j].col(2) = z;
  }
  return out;
}

double fault_draw(XrTime t, int a, int b, uint64_t salt) {
  uint64_t x = static_cast<uint64_t>(t) * 0x9E3779B97F4A7C15ull ^ (static_cast<uint64_t>(a) << 40) ^
               (static_cast<uint64_t>(b) << 48) ^ salt;
  x ^= x >> 30; x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27; x *= 0x94D049BB133111EBull;
  x ^= x >> 31;
  return static_cast<double>(x >> 11) * 0x1.0p-53;
}

void inject_joint_faults(const FaultRates& f, XrTime t, int h, XrHandJointLocationEXT* joints,
                         XrHandJointVelocityEXT* velocities) {
  if (f.nan <= 0.0 && f.huge <= 0.0 && f.quat <= 0.0 && f.origin <= 0.0 && f.velocity <= 0.0 && f.radius <= 0.0 &&
      f.collapse <= 0.0 && f.untracked <= 0.0)
    return;
  if (fault_draw(t, h, 0, 13) < f.untracked)  // a runtime reporting only its inferred hand
    for (int j = 0; j < kJointCount; ++j)
      joints[j].locationFlags &= ~static_cast<XrSpaceLocationFlags>(XR_SPACE_LOCATION_POSITION_TRACKED_BIT |
                                                                    XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT);
  if (fault_draw(t, h, 0, 12) < f.collapse)
    for (int j = 1; j < kJointCount; ++j) joints[j].pose.position = joints[0].pose.position;
  for (int j = 0; j < kJointCount; ++j) {
    XrHandJointLocationEXT& loc = joints[j];
    if (fault_draw(t, h, j, 1) < f.nan) loc.pose.position.x = kNaNf;
    if (fault_draw(t, h, j, 2) < f.huge) loc.pose.position = {1e30f, -1e30f, 1e30f};
    if (fault_draw(t, h, j, 3) < f.quat) loc.pose.orientation = {0.f, 0.f, 0.f, 0.f};
    if (fault_draw(t, h, j, 6) < f.origin)
      loc.pose.position = fault_draw(t, h, j, 7) < 0.5 ? XrVector3f{0.f, 0.f, 0.f} : XrVector3f{1e-40f, 0.f, -1e-40f};
    if (fault_draw(t, h, j, 10) < f.radius) {
      constexpr float kRadii[4] = {kNaNf, std::numeric_limits<float>::infinity(), -0.01f, 1e30f};
      loc.radius = kRadii[std::min(3, static_cast<int>(fault_draw(t, h, j, 11) * 4.0))];
    }
    if (velocities && fault_draw(t, h, j, 8) < f.velocity)
      velocities[j].linearVelocity =
          fault_draw(t, h, j, 9) < 0.5 ? XrVector3f{1e6f, -1e6f, 1e6f} : XrVector3f{kNaNf, 0.f, 0.f};
  }
}

Pose scaled_about_wrist(const Pose& p, double scale) {
  if (scale == 1.0) return p;
  const int root = joint_tracked(p, idx(Joint::Wrist)) ? idx(Joint::Wrist) : idx(Joint::Palm);
  if (!joint_tracked(p, root)) return p;
  const Eigen::RowVector3d c = p.row(root);
  Pose out = p;
  for (int j = 0; j < kJointCount; ++j) out.row(j) = c + (p.row(j) - c) * scale;
  return out;
}

void fill_capsules(const XrHandJointLocationEXT* joints, XrHandTrackingCapsulesStateFB& capsules) {
  constexpr std::array<int, XR_FB_HAND_TRACKING_CAPSULE_COUNT> kBones = {
      XR_HAND_JOINT_THUMB_METACARPAL_EXT,  XR_HAND_JOINT_THUMB_PROXIMAL_EXT,       XR_HAND_JOINT_THUMB_DISTAL_EXT,
      XR_HAND_JOINT_INDEX_METACARPAL_EXT,  XR_HAND_JOINT_INDEX_PROXIMAL_EXT,       XR_HAND_JOINT_INDEX_INTERMEDIATE_EXT,
      XR_HAND_JOINT_INDEX_DISTAL_EXT,      XR_HAND_JOINT_MIDDLE_METACARPAL_EXT,    XR_HAND_JOINT_MIDDLE_PROXIMAL_EXT,
      XR_HAND_JOINT_MIDDLE_INTERMEDIATE_EXT, XR_HAND_JOINT_MIDDLE_DISTAL_EXT,      XR_HAND_JOINT_RING_METACARPAL_EXT,
      XR_HAND_JOINT_RING_PROXIMAL_EXT,     XR_HAND_JOINT_RING_INTERMEDIATE_EXT,    XR_HAND_JOINT_RING_DISTAL_EXT,
      XR_HAND_JOINT_LITTLE_METACARPAL_EXT, XR_HAND_JOINT_LITTLE_PROXIMAL_EXT,      XR_HAND_JOINT_LITTLE_INTERMEDIATE_EXT,
      XR_HAND_JOINT_LITTLE_DISTAL_EXT};
  for (size_t i = 0; i < kBones.size(); ++i) {
    XrHandCapsuleFB& c = capsules.capsules[i];
    const int j = kBones[i];
    c.joint = static_cast<XrHandJointEXT>(j);
    c.points[0] = joints[j].pose.position;
    c.points[1] = joints[j + 1].pose.position;
    c.radius = joints[j].radius;
  }
}

void fill_aim(const XrHandJointLocationEXT* joints, XrHandTrackingAimStateFB& aim) {
  aim.status = XR_HAND_TRACKING_AIM_COMPUTED_BIT_FB | XR_HAND_TRACKING_AIM_VALID_BIT_FB;
  aim.aimPose.position = joints[XR_HAND_JOINT_INDEX_PROXIMAL_EXT].pose.position;
  aim.aimPose.orientation = joints[XR_HAND_JOINT_PALM_EXT].pose.orientation;
  const Eigen::Vector3d thumb = xr::to_eigen(joints[XR_HAND_JOINT_THUMB_TIP_EXT].pose.position);
  const std::array<std::pair<float*, XrHandTrackingAimFlagsFB>, 4> fingers = {{
      {&aim.pinchStrengthIndex, XR_HAND_TRACKING_AIM_INDEX_PINCHING_BIT_FB},
      {&aim.pinchStrengthMiddle, XR_HAND_TRACKING_AIM_MIDDLE_PINCHING_BIT_FB},
      {&aim.pinchStrengthRing, XR_HAND_TRACKING_AIM_RING_PINCHING_BIT_FB},
      {&aim.pinchStrengthLittle, XR_HAND_TRACKING_AIM_LITTLE_PINCHING_BIT_FB},
  }};
  constexpr std::array<int, 4> kTips = {XR_HAND_JOINT_INDEX_TIP_EXT, XR_HAND_JOINT_MIDDLE_TIP_EXT,
                                        XR_HAND_JOINT_RING_TIP_EXT, XR_HAND_JOINT_LITTLE_TIP_EXT};
  for (size_t i = 0; i < kTips.size(); ++i) {
    const double d = (xr::to_eigen(joints[kTips[i]].pose.position) - thumb).norm();
    // NaN stays NaN: a runtime computing from garbage joints.
    const float s = static_cast<float>(d < 0.01 ? 1.0 : d > 0.05 ? 0.0 : (0.05 - d) / 0.04);
    *fingers[i].first = std::isnan(d) ? kNaNf : s;
    if (s >= 0.9f) aim.status |= fingers[i].second;
  }
}

XrPosef hand_input_pose(const XrHandJointLocationEXT* joints, HandInput input) {
  const XrPosef& palm = joints[XR_HAND_JOINT_PALM_EXT].pose;
  switch (input) {
    case HandInput::GripPose:
    case HandInput::PalmPose: return palm;
    case HandInput::PokePose: return joints[XR_HAND_JOINT_INDEX_TIP_EXT].pose;
    case HandInput::PinchPose: {
      const Eigen::Vector3d mid = 0.5 * (xr::to_eigen(joints[XR_HAND_JOINT_THUMB_TIP_EXT].pose.position) +
                                         xr::to_eigen(joints[XR_HAND_JOINT_INDEX_TIP_EXT].pose.position));
      return XrPosef{palm.orientation, xr::to_xr(mid)};
    }
    default: return XrPosef{palm.orientation, joints[XR_HAND_JOINT_INDEX_PROXIMAL_EXT].pose.position};
  }
}

}  // namespace hs::shim
