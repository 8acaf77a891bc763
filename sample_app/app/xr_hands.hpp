#pragma once
// The demo's OpenXR side: one instance (XR_EXT_hand_tracking, XR_MND_headless and, when
// the HandSteady layer offers it, its raw-joints side channel), a headless session run
// to FOCUSED, a LOCAL space and a tracker per hand. The demo renders on its own
// (OSMesa or a GLFW window), so it needs no graphics binding: any runtime with
// XR_MND_headless works (the replay runtime in CI, Monado on a desktop).
#include <openxr/openxr.h>

#include "handsteady/track.hpp"

#include <array>
#include <string>

namespace hs::demo {

struct XrHandsOptions {
  bool want_raw = true;  // enable XR_NOVENDOR_handsteady_raw_joints when the layer offers it
};

class XrHands {
 public:
  // Throws std::runtime_error naming the failing call and its XrResult.
  explicit XrHands(const XrHandsOptions& options);
  ~XrHands();
  XrHands(const XrHands&) = delete;
  XrHands& operator=(const XrHands&) = delete;

  // xrWaitFrame + xrBeginFrame; returns the predicted display time. Also polls events.
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
  XrInstance instance_ = XR_NULL_HANDLE;
  XrSession session_ = XR_NULL_HANDLE;
  XrSpace local_ = XR_NULL_HANDLE;
  std::array<XrHandTrackerEXT, 2> trackers_{};  // [left, right]
  PFN_xrCreateHandTrackerEXT create_tracker_ = nullptr;
  PFN_xrDestroyHandTrackerEXT destroy_tracker_ = nullptr;
  PFN_xrLocateHandJointsEXT locate_ = nullptr;
  PFN_xrLocateHandJointsEXT locate_raw_ = nullptr;  // same signature (raw_joints_ext.h)
  XrSessionState state_ = XR_SESSION_STATE_UNKNOWN;
  bool running_ = false;
  bool ended_ = false;
  std::string runtime_name_;
};

}  // namespace hs::demo
