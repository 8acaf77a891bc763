#pragma once
// A parametric right hand (forward kinematics over the 26-joint XR skeleton) and smooth,
// seeded synthetic motion: the "small example the project makes itself" for demos and
// tests that must not depend on recorded data. Not a substitute for real recordings.
#include "handsteady/track.hpp"

#include <Eigen/Geometry>

#include <cstdint>

namespace hs {

// Flexion per finger (thumb, index, middle, ring, little) in radians: how far each
// finger is curled (0 = straight). Spread in radians between adjacent fingers.
struct HandArticulation {
  std::array<double, 5> curl{};
  double spread = 0.12;
};

struct HandShapeParams {
  double scale = 1.0;  // 1 = an adult hand (wrist -> middle_proximal ~ 95 mm)
};

// Right hand in its local frame: wrist at origin, fingers along -Z (forward), palm
// facing -Y (down), thumb towards -X. Metres.
Pose synth_hand_pose(const HandArticulation& art, const HandShapeParams& shape = {});

// Moves the local pose: p_world = rotation * p_local + position.
Pose transform_pose(const Pose& local, const Eigen::Quaterniond& rotation, const Eigen::Vector3d& position);

struct SynthMotionParams {
  double duration_s = 10.0;
  double rate_hz = 30.0;
  double reach_m = 0.12;        // amplitude of the wrist's smooth path
  double speed_hz = 0.35;       // dominant frequency of the motion
  double rotation_rad = 0.5;    // amplitude of wrist rotation
};

// One hand of smooth motion (sums of low-frequency sinusoids with seeded phases):
// translation, rotation and finger curl all vary. Left hands are the mirror image.
HandSeries synth_motion(const SynthMotionParams& params, Hand hand, uint64_t seed);
// Both hands, as a track with "source: synthetic ..." metadata.
Track synth_track(const SynthMotionParams& params, uint64_t seed);

}  // namespace hs
