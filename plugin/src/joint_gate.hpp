#pragma once
// Physically plausible input only. Runtimes send garbage flagged valid and tracked:
// joints at or near the origin, denormals, 1e30, NaN, a single joint far from its hand, a
// whole hand collapsed onto a point or a line.
// Such joints are gated like outliers (marked missing), never fed to the filter; a hand
// that moves in a way no hand can (or comes back somewhere else after a loss) restarts
// the filter instead of being bridged. Pure functions: no state, no allocation.
#include "handsteady/track.hpp"

#include <Eigen/Core>

namespace hs::layer {

struct GateLimits {
  double min_norm_m = 1e-3;         // closer to the space's origin: a zeroed/denormal joint
  double max_norm_m = 100.0;        // farther from the origin: not a hand within tracking range
  double max_from_centre_m = 0.25;  // a joint this far from its hand's median joint is not part of it
  int min_joints = 6;               // fewer plausible joints: no usable observation
  // A hand of at least spread_joints plausible joints spread less than min_spread_m (RMS)
  // along its second principal axis lies on a point or a line: no hand of any proportions
  // does (its knuckles alone span centimetres), a runtime's collapsed hand does. 0: off.
  double min_spread_m = 0.003;
  int spread_joints = 20;
  double max_speed_m_s = 15.0;      // the hand's centre faster than this between samples: a jump
  double jump_slack_m = 0.05;       // ... beyond this distance (tracker noise at tiny time steps)
  double lost_s = 0.12;             // a sample gap longer than this is a loss (20 Hz runtimes: 0.05) ...
  double reacquire_m = 0.05;        // ... and a hand back farther than this plus ...
  double reacquire_m_s = 0.5;       // ... this speed times the gap from where it was lost restarts
                                    // (slower moves are bridged: writing hands drop out briefly)
};

struct GateResult {
  int kept = 0;      // joints left tracked
  int rejected = 0;  // tracked joints marked missing as implausible
  Eigen::Vector3d centre = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());  // median joint
  bool usable() const { return centre.allFinite(); }
};

// Marks implausible joints of `pose` missing (NaN rows), in place. The result's centre is
// the component-wise median of the kept joints, NaN when fewer than min_joints are left
// (the whole pose is then marked missing).
GateResult gate_joints(Pose& pose, const GateLimits& limits = {}) noexcept;

// True when a hand whose centre was at `prev` (dt_s earlier) cannot be the same motion as
// one now at `now`: faster than any hand, or back from a loss somewhere else.
bool hand_jumped(const Eigen::Vector3d& prev, const Eigen::Vector3d& now, double dt_s,
                 const GateLimits& limits = {}) noexcept;

}  // namespace hs::layer
