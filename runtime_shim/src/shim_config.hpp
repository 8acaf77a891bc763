#pragma once
// Environment configuration of the replay runtime (read at each xrCreateInstance).
// See docs/OPENXR_LAYER.md "Replay runtime" for the variables and their meaning.
#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>

namespace hs::shim {

enum class FuturePolicy {
  Exact,  // a query for time T answers the recorded track at T, even in the future
  Hold,   // T later than the simulated "now" answers the track at now (a runtime without prediction)
  Latest, // any T answers the track at now (its newest pose whatever the time: Monado's remote driver)
  Extrapolate,  // captures at capture_hz, latency_ms old; any T is extrapolated at constant velocity
                // from the last two captures available at now (Quest-style runtime prediction)
};

enum class FrameMode {
  Normal,        // xrWaitFrame predicts the display time; xrBeginFrame/xrEndFrame work
  HeadlessZero,  // Monado's headless session (null compositor): xrWaitFrame returns at once
                 // with predictedDisplayTime 0, xrBeginFrame/xrEndFrame fail (call order)
};

struct FaultRates {
  double nan = 0.0;   // per joint per answered time: position becomes NaN (flags stay valid)
  double huge = 0.0;  // position becomes 1e30
  double quat = 0.0;  // orientation becomes (0,0,0,0)
  double origin = 0.0;  // position becomes the origin or a denormal (flags stay tracked)
  double space = 0.0;   // per xrLocateSpace call: the pose becomes NaN or 1e30 (flags valid)
  double velocity = 0.0;  // per joint: linear velocity becomes 1e6 m/s or NaN (flags valid)
  double radius = 0.0;    // per joint: radius becomes NaN, infinite, negative or 1e30 (position flags valid)
  double collapse = 0.0;  // per hand and answered time: every joint at the palm's position (flags valid)
  double untracked = 0.0; // per hand and answered time: every joint valid but not tracked (inferred)
  double error = 0.0;     // per hand and asked time: xrLocateHandJointsEXT fails (XR_ERROR_RUNTIME_FAILURE)
  double space_error = 0.0;  // per xrLocateSpace call (spaces and time): it fails (XR_ERROR_RUNTIME_FAILURE)
};

// LOCAL recentred once (as a user's "reset view" does): from track time at_s on, LOCAL's
// origin sits at offset_m in the old LOCAL, turned yaw_rad about +Y; the runtime announces
// it with XrEventDataReferenceSpaceChangePending 0.1 s before. STAGE and the hands stay put.
struct Recenter {
  double at_s = 0.0;
  Eigen::Vector3d offset_m = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
};

// A span of track time in which the hand comes from a controller
// (XR_EXT_hand_tracking_data_source's XR_HAND_TRACKING_DATA_SOURCE_CONTROLLER_EXT): the
// recording's pose without corruption, placed offset_m away (a controller's hand sits
// where the controller puts it), as a runtime that switches sources when the user picks
// up a controller.
struct ControllerSpan {
  double from_s = 0.0, to_s = 0.0;
  Eigen::Vector3d offset_m = Eigen::Vector3d(0.0, -0.03, 0.02);
  bool contains(double t) const { return t >= from_s && t < to_s; }
};

struct ShimConfig {
  std::string track_path;        // HANDSTEADY_SHIM_TRACK (empty: hands never active)
  std::string corrupt_preset;    // HANDSTEADY_SHIM_CORRUPT=<preset>:<seed>
  uint64_t corrupt_seed = 0;
  bool real_clock = false;       // HANDSTEADY_SHIM_CLOCK=sim:<period_ms> | real[:<period_ms>]
  int64_t period_ns = 11'111'111;  // 90 Hz
  std::optional<int64_t> epoch_ns;  // HANDSTEADY_SHIM_EPOCH_MS: XrTime at xrCreateInstance
                                    // (none: 1 s on the simulated clock, CLOCK_MONOTONIC on the real one)
  int64_t latency_ns = -1;       // HANDSTEADY_SHIM_LATENCY_MS (display time - now); -1: 2 periods
  FuturePolicy future = FuturePolicy::Exact;  // HANDSTEADY_SHIM_FUTURE=exact|hold|latest|extrapolate[:<capture_hz>:<capture_latency_ms>]
  double capture_hz = 30.0;        // extrapolate: the tracker's capture rate
  int64_t capture_latency_ns = 30'000'000;  // extrapolate: a capture is available this long after its time
  FrameMode frames = FrameMode::Normal;       // HANDSTEADY_SHIM_FRAMES=normal|headless-zero
  bool head_motion = false;      // HANDSTEADY_SHIM_HEAD_MOTION=1
  bool space_velocity = true;    // HANDSTEADY_SHIM_SPACE_VELOCITY=0: xrLocateSpace answers no XrSpaceVelocity
  std::optional<Recenter> recenter;  // HANDSTEADY_SHIM_RECENTER=<track_s>,<dx_m>,<dy_m>,<dz_m>,<yaw_deg>
  std::optional<ControllerSpan> controller;  // HANDSTEADY_SHIM_CONTROLLER=<from_track_s>,<to_track_s>
  FaultRates faults;             // HANDSTEADY_SHIM_FAULTS=nan:<p>,huge:<p>,...,error:<p>,space_error:<p> (FaultRates)
};

// Throws std::invalid_argument naming the variable on malformed values.
ShimConfig shim_config_from_env();

}  // namespace hs::shim
