#pragma once
// The layer's answer to the app, as a pure function: the runtime's joints in the app's
// base space are moved to the engine's estimate (world space, converted with
// base_from_world), weighted by answer.weight * smoothing; orientations follow their
// bones; linear velocities become the estimate's. Joints the runtime does not report
// tracked keep the runtime's data; a tracked joint whose runtime position is garbage
// (non-finite, absurd) takes the estimate whole. No allocation, no runtime calls.
#include "handsteady_xr/xr_math.hpp"
#include "tracker_filter.hpp"

#include <openxr/openxr.h>

namespace hs::layer {

// Motion of the layer's world space seen from the base space (from XrSpaceVelocity), or
// the runtime's own joint velocities in both spaces at the same time (their difference
// is the base motion); with neither, the base is taken as still relative to the world.
struct BaseMotion {
  bool valid = false;
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();   // m/s of the world origin, base frame
  Eigen::Vector3d angular = Eigen::Vector3d::Zero();  // rad/s, base frame
  const XrHandJointVelocityEXT* world_velocities = nullptr;  // runtime's, world space, same time
};

struct RewriteStats {
  int replaced = 0;       // joints moved to the estimate
  int repaired = 0;       // of which the runtime's position was garbage
  bool diverged = false;  // the estimate is not where the runtime's hand is: nothing replaced
};

// A joint's radius where its position is valid: no joint of a human hand is 10 cm thick,
// and a NaN or negative one breaks what an app computes with it. 0 (against
// XR_EXT_hand_tracking, which asks for a positive radius) is a runtime that gives none:
// kept, not replaced by an invented one. The fallback where no joint's radius is usable:
// about a finger's half-thickness.
inline constexpr float kMaxRadius = 0.1f;
inline constexpr float kDefaultRadius = 0.01f;
inline bool radius_usable(float r) noexcept { return r >= 0.0f && r < kMaxRadius; }  // false for NaN too

// Joints of the runtime's answer whose position no hand can have (non-finite, at the
// exact origin or denormal, beyond 1 km, far from the rest of the hand; all of a hand
// collapsed onto a point or a line), flagged tracked.
using JointMask = std::array<bool, kJointCount>;
JointMask garbage_joints(const XrHandJointLocationEXT* joints) noexcept;

// The base space's pose in the layer's world space from the runtime's answers of the same
// hand at the same time in both (the app's in the base, `world` in the world): the rigid
// fit of the joints tracked and not garbage in both. For when xrLocateSpace fails. False
// unless at least 4 joints, spread over 1 cm or more, fit within 1 mm.
bool fit_base_from_world(const XrHandJointLocationEXT* base_joints, const JointMask& garbage, const Pose& world,
                         xr::Rigid& base_from_world) noexcept;

// max_offset_m: an estimate whose hand centre is farther than this from the runtime's
// (a hand re-acquired elsewhere that the engine has not seen yet) replaces nothing.
// While the engine blends in after a (re)start (answer.weight < 1) its offset from the
// runtime's joint is also capped at max_offset_m / 3 per joint: a cold engine's
// prediction is not trusted. Garbage joints the estimate replaces are cleared from `garbage`.
RewriteStats rewrite_joints(const Answer& answer, double smoothing, const xr::Rigid& base_from_world,
                            const BaseMotion& motion, JointMask& garbage, double max_offset_m,
                            XrHandJointLocationEXT* joints, XrHandJointVelocityEXT* velocities) noexcept;

// What the app gets is never garbage, even where the layer passes the runtime through:
// a garbage position becomes that of the plausible joint fewest bones away (up or down the
// hand tree, the ancestor on a tie; valid, no longer tracked; with none plausible, as
// in a hand collapsed onto a point, the position is no longer valid: it stays where it is
// if finite, else becomes the origin),
// an unusable orientation its parent's (likewise), a radius no hand has (non-finite,
// negative, 10 cm or more) where the position is valid that of the joint fewest bones
// away with a usable one (a default where none has; 0, a runtime giving none, is kept),
// a non-finite or impossible velocity loses its valid bit. Returns the number of repairs.
int repair_garbage(const JointMask& garbage, XrHandJointLocationEXT* joints, XrHandJointVelocityEXT* velocities) noexcept;

// The joints a joint set adds after the hand's 26 (Ultraleap's elbow, joints[26..count)),
// once the hand's are rewritten and repaired: each moves with the wrist's correction
// (wrist_before: the runtime's wrist), so that the forearm keeps its length and direction,
// and is never garbage: a position no forearm has (non-finite, beyond 1 km, a metre or
// more from the wrist) becomes the wrist's (not tracked; not valid without a valid
// wrist), an unusable orientation or radius the wrist's, an impossible velocity loses
// its valid bit. Returns the number of repairs.
int rewrite_forearm(const XrVector3f& wrist_before, XrHandJointLocationEXT* joints, uint32_t count,
                    XrHandJointVelocityEXT* velocities) noexcept;

}  // namespace hs::layer
