#pragma once
// What runtimes compute from their own joints and hand to the app beside them: Meta's
// extensions chained to an answer (XR_FB_hand_tracking_capsules: colliders along the
// bones; XR_FB_hand_tracking_aim: the pointer pose and pinch strengths), and the poses of
// XR_EXT_hand_interaction's profile (grip, aim, pinch, poke), located as action spaces.
// Kept with the joints the layer answers: where the layer moves a joint, what hangs on it
// moves with it, so an app's colliders, pointer and poke stay on the hand it draws. Never
// garbage, as the joints are not. No allocation, no runtime calls.
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

// The pose inputs of XR_EXT_hand_interaction's profile (`/input/<name>/pose`), which a
// runtime derives from the tracked hand (the palm's, XR_EXT_palm_pose's `palm_ext` and
// OpenXR 1.1's `grip_surface`, move as the grip).
enum class HandPose { None, Grip, Aim, Pinch, Poke };

// An action space's location of such a pose (`loc`: the runtime's, in the base space the
// joints were answered in; pose_in_action: the space's offset in the action's pose) moves
// with the joints it sits on: grip with the palm's rigid change, poke with the index tip's;
// aim with the palm's position change (direction kept, as move_aim); pinch with the mean
// position change of the thumb's and index finger's tips (orientation kept). A location
// flagged valid that no hand has (non-finite, an unusable orientation, beyond 1 km, or the
// action's own pose 50 cm from the answered palm) loses its valid and tracked bits.
// Returns 1 for such a repair, else 0.
int move_hand_pose(HandPose pose, const JointsBefore& before, const XrHandJointLocationEXT* after,
                   const XrPosef& pose_in_action, XrSpaceLocation& loc) noexcept;

}  // namespace hs::layer
