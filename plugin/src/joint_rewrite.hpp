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
  int replaced = 0;  // joints moved to the estimate
  int repaired = 0;  // of which the runtime's position was garbage
};

RewriteStats rewrite_joints(const Answer& answer, double smoothing, const xr::Rigid& base_from_world,
                            const BaseMotion& motion, XrHandJointLocationEXT* joints,
                            XrHandJointVelocityEXT* velocities) noexcept;

// A position the runtime cannot mean: non-finite, at the exact origin, or beyond 1 km.
bool garbage_position(const XrVector3f& p) noexcept;

}  // namespace hs::layer
