#pragma once
// A small headless OpenXR app for the tests: app -> real loader -> (layers) -> the
// HandSteady replay runtime. Builds synthetic clean/noisy tracks, sets the loader's and
// the runtime's environment, and measures joint errors against the clean track.
#include <openxr/openxr.h>

#include "handsteady/corrupt.hpp"
#include "handsteady/track.hpp"

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace hs::xrtest {

constexpr XrTime kShimEpochNs = 1'000'000'000;  // XrTime of the track's first row (sim clock)
constexpr const char* kLayer = "XR_APILAYER_NOVENDOR_handsteady";
constexpr const char* kCoreValidation = "XR_APILAYER_LUNARG_core_validation";

struct TrackFiles {
  std::filesystem::path dir, clean_csv, noisy_csv;
  Track clean, noisy;
  std::array<HandSeries, 2> clean_series, noisy_series;  // [XrHandEXT - 1]
  double t0 = 0.0;
};

// Smooth synthetic motion of both hands (90 Hz rows) and a noisy copy: the tracker preset
// with its jitter raised to jitter_sd_m (so that there is noise worth removing).
TrackFiles make_tracks(const std::string& name, double duration_s, double jitter_sd_m = 0.003,
                       bool with_gap = false);
// The same from a given clean track (90 Hz rows): noisy = tracker preset at jitter_sd_m.
TrackFiles make_tracks_from(const std::string& name, Track clean, double jitter_sd_m = 0.003);

// Clears every variable the loader, the layer and the runtime read, then points the
// loader at the replay runtime replaying `noisy_csv` (sim clock at 90 Hz).
void reset_env(const TrackFiles& files);
void set_env(const char* name, const std::string& value);
void unset_env(const char* name);
// XR_API_LAYER_PATH = build-tree layer folder + the system's explicit.d; XR_ENABLE_API_LAYERS.
void enable_layers(const std::vector<std::string>& names);
// An implicit-layer folder under `xdg` (XDG_DATA_HOME) holding the layer's implicit manifest.
void install_implicit_layer(const std::filesystem::path& xdg);

double track_time(const TrackFiles& f, XrTime t);

// xrCreateInstance for the tests' app with these extensions; the loader's result.
XrResult create_instance(const std::vector<const char*>& extensions, XrInstance& instance);

// One xrLocateHandJointsEXT call of `fn` for `count` joints of `tracker` into `loc`, with
// `next` chained to the answer; the call's result, and whether the hand is active into `active`.
XrResult locate_chained(PFN_xrLocateHandJointsEXT fn, XrHandTrackerEXT tracker, XrSpace base, XrTime time, void* next,
                        uint32_t count, XrHandJointLocationEXT* loc, XrBool32& active);

struct Joints {
  XrResult result = XR_ERROR_RUNTIME_FAILURE;
  XrBool32 active = XR_FALSE;
  std::array<XrHandJointLocationEXT, XR_HAND_JOINT_COUNT_EXT> loc{};
  std::array<XrHandJointVelocityEXT, XR_HAND_JOINT_COUNT_EXT> vel{};
};

class App {
 public:
  // Creates instance (XR_EXT_hand_tracking unless hand_tracking is false, XR_MND_headless),
  // system, session (run to FOCUSED), LOCAL/STAGE/VIEW spaces and both hand trackers.
  // extra_extensions are enabled as well (e.g. the layer's raw-joints extension).
  explicit App(bool hand_tracking = true, const std::vector<const char*>& extra_extensions = {});
  ~App();
  App(const App&) = delete;
  App& operator=(const App&) = delete;

  // xrWaitFrame/xrBeginFrame/xrEndFrame; returns the predicted display time.
  XrTime frame();
  // Drains the event queue (as an app does once a frame); returns the events.
  std::vector<XrEventDataBuffer> poll_events();
  Joints locate(XrHandEXT hand, XrSpace base, XrTime time, bool velocities = false, uint32_t joint_count = 26) const;
  // The runtime's own answer through the layer's raw side channel (the App must have been
  // created with XR_NOVENDOR_handsteady_raw_joints).
  Joints locate_raw(XrHandEXT hand, XrSpace base, XrTime time) const;
  // The raw side channel's function, for trackers of the test's own.
  PFN_xrLocateHandJointsEXT raw_locate() const;
  // Pose of `space` in `base` at time (asserts validity).
  XrPosef space_pose(XrSpace space, XrSpace base, XrTime time) const;
  // Ends the session cleanly (STOPPING -> IDLE -> EXITING) and destroys trackers explicitly
  // unless keep_trackers (then xrDestroySession must drop them).
  void shutdown(bool keep_trackers = false);

  XrInstance instance = XR_NULL_HANDLE;
  XrSession session = XR_NULL_HANDLE;
  XrSpace local = XR_NULL_HANDLE, stage = XR_NULL_HANDLE, view = XR_NULL_HANDLE;
  std::array<XrHandTrackerEXT, 2> trackers{};  // [left, right]
  PFN_xrCreateHandTrackerEXT create_tracker = nullptr;
  PFN_xrDestroyHandTrackerEXT destroy_tracker = nullptr;
  PFN_xrLocateHandJointsEXT locate_joints = nullptr;

 private:
  Joints locate_with(PFN_xrLocateHandJointsEXT fn, XrHandEXT hand, XrSpace base, XrTime time, bool velocities,
                     uint32_t joint_count) const;
  void poll_until(XrSessionState state);
  bool shut_ = false;
};

// XR_EXT_hand_interaction's four poses for both hands, set up as an app does: an action
// set, a pose action per input with both hands as subaction paths, the profile's bindings
// (/interaction_profiles/ext/hand_interaction_ext), an action space per hand and pose, and
// one more poke space per hand with `offset` in the action's pose; with `palm`, also
// XR_EXT_palm_pose's palm pose (an action and a space per hand). The App must have been
// created with the extension(s).
constexpr const char* kHandInteractionExt = "XR_EXT_hand_interaction";
constexpr const char* kPalmPoseExt = "XR_EXT_palm_pose";
enum HandPoseIndex { kGrip, kAim, kPinch, kPoke };
struct HandInteraction {
  explicit HandInteraction(const App& app, bool palm = false);
  void sync(const App& app) const;  // xrSyncActions of the set

  XrActionSet set = XR_NULL_HANDLE;
  std::array<XrAction, 4> actions{};               // [HandPoseIndex]
  std::array<std::array<XrSpace, 4>, 2> spaces{};  // [hand - 1][HandPoseIndex]
  std::array<XrSpace, 2> poke_offset{};            // [hand - 1]
  XrAction palm_action = XR_NULL_HANDLE;
  std::array<XrSpace, 2> palm{};                   // [hand - 1]
  // 2 cm along the tip's -Z, turned 30 degrees about its X.
  const XrPosef offset{{0.258819f, 0.0f, 0.0f, 0.965926f}, {0.0f, 0.0f, -0.02f}};
};

// Mean distance (m) between valid joint positions (converted to LOCAL with local_from_base)
// and `truth`, over joints tracked in truth; adds to sum/count.
void accumulate_error(const Joints& j, const XrPosef& local_from_base, const Pose& truth, double& sum, long& count);
// Mean distance between `pose` and `truth` over joints tracked in both.
void accumulate_error(const Pose& pose, const Pose& truth, double& sum, long& count);

}  // namespace hs::xrtest
