#pragma once
// What Meta's hand extensions chain to an answer, computed by the runtime from its own
// joints (XR_FB_hand_tracking_capsules: colliders along the bones; XR_FB_hand_tracking_aim:
// the pointer pose and pinch strengths), kept with the joints the layer answers: where the
// layer moves a joint, what hangs on it moves with it, so an app's colliders and pointer
// stay on the hand it draws. Never garbage, as the joints are not. No allocation, no
// runtime calls.
#include "joint_rewrite.hpp"

#include <openxr/openxr.h>

#include <array>

namespace hs::layer {

// The runtime's joints as it answered them, before the layer changed anything, and which
// of them were garbage (garbage_joints).
struct JointsBefore {
  std::array<XrHandJointLocationEXT, kJointCount> loc;
  JointMask garbage{};
};

// Each capsule moves with its joint's rigid change (runtime's pose -> the app's answer):
// the capsule keeps the runtime's length and radius and lies along the answered bone.
// A capsule no hand has (a point non-finite, beyond 1 km or 30 cm from its joint; a joint
// that is no hand joint) collapses onto its joint's answered position, valid or not (the
// palm's where the joint is unknown or its position no place: non-finite, beyond 1 km);
// a radius no hand has (non-finite, negative, 10 cm or more) becomes its joint's. Returns
// the number of repairs.
int move_capsules(const JointsBefore& before, const XrHandJointLocationEXT* after,
                  XrHandTrackingCapsulesStateFB& capsules) noexcept;

// The aim pose moves with the palm's correction (the runtime's ray direction is kept: the
// runtime derives it from more than the hand, a shoulder model, so only its origin rides
// on the hand). An aim flagged valid whose pose no hand has (non-finite, unusable
// orientation, beyond 1 km or 50 cm from the palm) loses its valid bit and takes the
// palm's answered pose; pinch strengths outside [0, 1] are clamped (NaN: 0). Returns the
// number of repairs.
int move_aim(const JointsBefore& before, const XrHandJointLocationEXT* after, XrHandTrackingAimStateFB& aim) noexcept;

}  // namespace hs::layer
