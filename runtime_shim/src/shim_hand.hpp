#pragma once
// The replay runtime's simulated hand: which recorded pose its tracker reports for a
// query time under each time semantics, the joints' frames and radii, and the garbage
// injected as faults. Pure functions of the track, the configuration and the times (no
// handles, no clock, no lock).
#include <openxr/openxr.h>

#include "handsteady/skeleton.hpp"
#include "handsteady/track.hpp"
#include "shim_actions.hpp"
#include "shim_config.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>

namespace hs::shim {

// XrTime on the runtime's clock -> time in the track (s).
struct TrackClock {
  double t0 = 0.0;      // track time at epoch
  XrTime epoch = 0;
  double at(XrTime t) const { return t0 + static_cast<double>(t - epoch) * 1e-9; }
};

// The hand the tracker reports at query time t when the runtime's clock reads now, under
// cfg.future (world coordinates; untracked joints NaN; an empty series: untracked).
Pose replayed_hand(const HandSeries& series, const ShimConfig& cfg, const TrackClock& clock, XrTime t, XrTime now);

// Every joint placed: an untracked joint at its nearest tracked ancestor (so that an active
// hand reports every joint valid, as XR_EXT_hand_tracking requires), else any tracked one.
Pose with_valid_positions(const Pose& p);

// Joint frames from positions: -Z along the joint's bone (kXrFrameBone), +Y out of the
// back of the hand; identity where a bone is degenerate.
std::array<Eigen::Matrix3d, kJointCount> joint_frames(const Pose& p, bool left);

inline float joint_radius(int j) { return is_tip(j) ? 0.008f : 0.01f; }

// XR_ULTRALEAP_hand_tracking_forearm's elbow, for a pose with every joint placed: 25 cm
// below and behind the wrist, moving with it (a forearm taken from the hand's own axis
// would swing centimetres with every millimetre of the replayed track's noise).
Eigen::Vector3d elbow_position(const Pose& filled);
constexpr float kElbowRadiusM = 0.035f;

// Deterministic uniform [0, 1) from (time, a, b, salt): faults repeat for repeated queries.
double fault_draw(XrTime t, int a, int b, uint64_t salt);

// Garbage a buggy runtime might produce in a joint answer, flags untouched (FaultRates).
void inject_joint_faults(const FaultRates& f, XrTime t, int hand, XrHandJointLocationEXT* joints,
                         XrHandJointVelocityEXT* velocities);

// XR_FB_hand_tracking_capsules and XR_FB_hand_tracking_aim, computed from the answered
// joints (faults included, as a runtime computes them from its own): a capsule per bone
// of the thumb (metacarpal, proximal, distal) and of each finger (metacarpal to distal),
// from its joint to the next, its joint's radius; the aim at the index finger's proximal
// joint, oriented as the palm, valid with the hand, pinch strengths from the thumb tip's
// distance to each fingertip (1 at 1 cm, 0 from 5 cm; pinching from 0.9).
void fill_capsules(const XrHandJointLocationEXT* joints, XrHandTrackingCapsulesStateFB& capsules);
void fill_aim(const XrHandJointLocationEXT* joints, XrHandTrackingAimStateFB& aim);

// XR_FB_hand_tracking_mesh's scale: the hand scaled about its wrist (rows without a wrist:
// about the palm; untracked joints stay NaN).
Pose scaled_about_wrist(const Pose& p, double scale);

// The pose input's pose from the hand's answered joints (the 26 of the default set, in the
// space they are answered in): grip and palm (XR_EXT_palm_pose) at the palm; aim at the index finger's proximal joint,
// oriented as the palm (as XR_FB_hand_tracking_aim here); pinch between the thumb's and the
// index finger's tips, oriented as the aim; poke at the index tip, its frame. Garbage
// joints give a garbage pose (a runtime computing from its own faulty joints).
XrPosef hand_input_pose(const XrHandJointLocationEXT* joints, HandInput input);

}  // namespace hs::shim
