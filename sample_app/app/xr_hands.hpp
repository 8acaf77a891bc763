#pragma once
// The demo's OpenXR side: one instance (XR_EXT_hand_tracking, XR_MND_headless,
// XR_KHR_convert_timespec_time when offered and, when the HandSteady layer offers it, its
// raw-joints side channel), a headless session run to FOCUSED, a LOCAL space and a
// tracker per hand. The demo renders on its own (OSMesa or a GLFW window), so it needs no
// graphics binding: any runtime with XR_MND_headless works (the replay runtime in CI,
// Monado on a desktop). Monado's headless session gives no display times and refuses
// xrBeginFrame: the frames are then timed here (frame_clock.hpp) and not submitted.
#include "frame_clock.hpp"

#include "handsteady/track.hpp"

#include <array>
#include <optional>
#include <string>

namespace hs::demo {

struct XrHandsOptions {
  bool want_raw = true;  // enable XR_NOVENDOR_handsteady_raw_joints when the layer offers it
  double fps = 90.0;     // frame rate when xrWaitFrame gives no display time
};

class XrHands {
 public:
  // Throws std::runtime_error naming the failing call and its XrResult.
  explicit XrHands(const XrHandsOptions& options);
  ~XrHands();
  XrHands(const XrHands&) = delete;
  XrHands& operator=(const XrHands&) = delete;

  // xrWaitFrame + xrBeginFrame; returns the predicted display time, or when xrWaitFrame
  // gives none, paces the loop at options.fps and returns CLOCK_MONOTONIC's next frame
  // time (XR_KHR_convert_timespec_time; throws without it). A refused xrBeginFrame or
  // xrEndFrame (a session without compositor) is reported once and the app carries on;
  // a lost session or instance throws. Also polls events.
  XrTime begin_frame();
  void end_frame(XrTime display_time);
  // Joints in LOCAL at `time` as the app receives them (through every layer), or the
  // runtime's own answer via the layer's side channel (raw = true). Untracked or invalid
  // joints are NaN rows; an inactive hand is all NaN.
  Pose locate(Hand hand, XrTime time, bool raw) const;
  bool has_raw() const { return locate_raw_ != nullptr; }
  bool running() const { return running_; }
  std::string runtime_name() const { return runtime_name_; }
  // Requests exit and runs the session down (STOPPING -> IDLE -> EXITING).
  void shutdown();

 private:
  void poll_events();
  // Throws for a lost session or instance; reports any other failure of `what` once.
  void frame_call_failed(XrResult r, const char* what, bool& reported);
  XrInstance instance_ = XR_NULL_HANDLE;
  XrSession session_ = XR_NULL_HANDLE;
  XrSpace local_ = XR_NULL_HANDLE;
  std::array<XrHandTrackerEXT, 2> trackers_{};  // [left, right]
  PFN_xrCreateHandTrackerEXT create_tracker_ = nullptr;
  PFN_xrDestroyHandTrackerEXT destroy_tracker_ = nullptr;
  PFN_xrLocateHandJointsEXT locate_ = nullptr;
  PFN_xrLocateHandJointsEXT locate_raw_ = nullptr;  // same signature (raw_joints_ext.h)
  PFN_xrConvertTimespecTimeToTimeKHR convert_timespec_ = nullptr;
  double fps_;
  std::optional<FrameClock> clock_;  // made when xrWaitFrame first gives no display time
  bool frame_begun_ = false;
  bool begin_reported_ = false, end_reported_ = false;
  XrSessionState state_ = XR_SESSION_STATE_UNKNOWN;
  bool running_ = false;
  bool ended_ = false;
  std::string runtime_name_;
};

}  // namespace hs::demo
