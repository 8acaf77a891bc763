#include "xr_hands.hpp"

#include "handsteady_xr/raw_joints_ext.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <vector>

namespace hs::demo {
namespace {

constexpr const char* kLayer = "XR_APILAYER_NOVENDOR_handsteady";

std::string result_name(XrInstance instance, XrResult r) {
  char name[XR_MAX_RESULT_STRING_SIZE] = {};
  if (XR_FAILED(xrResultToString(instance, r, name))) std::snprintf(name, sizeof name, "%d", r);
  return name;
}

void check(XrInstance instance, XrResult r, const char* what) {
  if (XR_SUCCEEDED(r)) return;
  const std::string name = instance == XR_NULL_HANDLE ? std::to_string(r) : result_name(instance, r);
  throw std::runtime_error(fmt::format("OpenXR: {} failed: {}", what, name));
}

template <class PFN>
PFN proc(XrInstance instance, const char* name) {
  PFN_xrVoidFunction f = nullptr;
  check(instance, xrGetInstanceProcAddr(instance, name, &f), name);
  return reinterpret_cast<PFN>(f);
}

// Whether `layer` (nullptr: the runtime and implicit layers) offers `extension`.
bool offers(const char* layer, std::string_view extension) {
  uint32_t count = 0;
  if (XR_FAILED(xrEnumerateInstanceExtensionProperties(layer, 0, &count, nullptr))) return false;
  std::vector<XrExtensionProperties> props(count, XrExtensionProperties{XR_TYPE_EXTENSION_PROPERTIES, nullptr, {}, 0});
  if (XR_FAILED(xrEnumerateInstanceExtensionProperties(layer, count, &count, props.data()))) return false;
  return std::any_of(props.begin(), props.end(),
                     [&](const XrExtensionProperties& p) { return std::string_view(p.extensionName) == extension; });
}

// Whether XR_ENABLE_API_LAYERS already puts the layer in the chain.
bool layer_enabled_by_environment() {
  const char* env = std::getenv("XR_ENABLE_API_LAYERS");
  return env && std::string_view(env).find(kLayer) != std::string_view::npos;
}

}  // namespace

XrHands::XrHands(const XrHandsOptions& options) : fps_(options.fps) {
  std::vector<const char*> ext = {XR_EXT_HAND_TRACKING_EXTENSION_NAME, XR_MND_HEADLESS_EXTENSION_NAME};
  // For a session whose xrWaitFrame gives no display time (Monado's headless one).
  const bool timespec = offers(nullptr, XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME);
  if (timespec) ext.push_back(XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME);
  std::vector<const char*> layers;
  if (options.want_raw && offers(kLayer, XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME)) {
    ext.push_back(XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME);
    // The extension needs the layer in the chain: ask for it unless the environment does.
    if (!layer_enabled_by_environment()) layers.push_back(kLayer);
  }
  XrInstanceCreateInfo ci{};
  ci.type = XR_TYPE_INSTANCE_CREATE_INFO;
  std::snprintf(ci.applicationInfo.applicationName, XR_MAX_APPLICATION_NAME_SIZE, "handsteady-demo");
  ci.applicationInfo.applicationVersion = 1;
  ci.applicationInfo.apiVersion = XR_CURRENT_API_VERSION;
  ci.enabledExtensionCount = static_cast<uint32_t>(ext.size());
  ci.enabledExtensionNames = ext.data();
  ci.enabledApiLayerCount = static_cast<uint32_t>(layers.size());
  ci.enabledApiLayerNames = layers.data();
  XrResult r = xrCreateInstance(&ci, &instance_);
  if (XR_FAILED(r) && !layers.empty()) {
    // Enabled implicitly already (an implicit manifest): ask for the extension only.
    ci.enabledApiLayerCount = 0;
    r = xrCreateInstance(&ci, &instance_);
  }
  check(XR_NULL_HANDLE, r, "xrCreateInstance");

  XrInstanceProperties ip{XR_TYPE_INSTANCE_PROPERTIES, nullptr, 0, {}};
  if (XR_SUCCEEDED(xrGetInstanceProperties(instance_, &ip))) runtime_name_ = ip.runtimeName;

  XrSystemGetInfo gi{XR_TYPE_SYSTEM_GET_INFO, nullptr, XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY};
  XrSystemId system = XR_NULL_SYSTEM_ID;
  check(instance_, xrGetSystem(instance_, &gi, &system), "xrGetSystem");
  XrSystemHandTrackingPropertiesEXT htp{XR_TYPE_SYSTEM_HAND_TRACKING_PROPERTIES_EXT, nullptr, XR_FALSE};
  XrSystemProperties sp{};
  sp.type = XR_TYPE_SYSTEM_PROPERTIES;
  sp.next = &htp;
  check(instance_, xrGetSystemProperties(instance_, system, &sp), "xrGetSystemProperties");
  if (!htp.supportsHandTracking) throw std::runtime_error("OpenXR: the system does not support hand tracking");

  XrSessionCreateInfo sci{XR_TYPE_SESSION_CREATE_INFO, nullptr, 0, system};
  check(instance_, xrCreateSession(instance_, &sci, &session_), "xrCreateSession (headless)");
  for (int i = 0; i < 1000 && state_ != XR_SESSION_STATE_READY; ++i) poll_events();
  if (state_ != XR_SESSION_STATE_READY) throw std::runtime_error("OpenXR: the session never became READY");
  XrSessionBeginInfo bi{XR_TYPE_SESSION_BEGIN_INFO, nullptr, XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO};
  check(instance_, xrBeginSession(session_, &bi), "xrBeginSession");
  running_ = true;

  XrReferenceSpaceCreateInfo rci{};
  rci.type = XR_TYPE_REFERENCE_SPACE_CREATE_INFO;
  rci.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_LOCAL;
  rci.poseInReferenceSpace.orientation.w = 1.0f;
  check(instance_, xrCreateReferenceSpace(session_, &rci, &local_), "xrCreateReferenceSpace(LOCAL)");

  create_tracker_ = proc<PFN_xrCreateHandTrackerEXT>(instance_, "xrCreateHandTrackerEXT");
  destroy_tracker_ = proc<PFN_xrDestroyHandTrackerEXT>(instance_, "xrDestroyHandTrackerEXT");
  locate_ = proc<PFN_xrLocateHandJointsEXT>(instance_, "xrLocateHandJointsEXT");
  if (timespec)
    convert_timespec_ = proc<PFN_xrConvertTimespecTimeToTimeKHR>(instance_, "xrConvertTimespecTimeToTimeKHR");
  if (std::find_if(ext.begin(), ext.end(), [](const char* e) {
        return std::string_view(e) == XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME;
      }) != ext.end())
    locate_raw_ = proc<PFN_xrLocateRawHandJointsNOVENDOR>(instance_, "xrLocateRawHandJointsNOVENDOR");
  for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
    XrHandTrackerCreateInfoEXT hci{XR_TYPE_HAND_TRACKER_CREATE_INFO_EXT, nullptr, hand, XR_HAND_JOINT_SET_DEFAULT_EXT};
    check(instance_, create_tracker_(session_, &hci, &trackers_[hand - 1]), "xrCreateHandTrackerEXT");
  }
}

XrHands::~XrHands() {
  try {
    shutdown();
  } catch (...) {
  }
  for (XrHandTrackerEXT& t : trackers_)
    if (t != XR_NULL_HANDLE && destroy_tracker_) destroy_tracker_(t);
  if (local_ != XR_NULL_HANDLE) xrDestroySpace(local_);
  if (session_ != XR_NULL_HANDLE) xrDestroySession(session_);
  if (instance_ != XR_NULL_HANDLE) xrDestroyInstance(instance_);
}

void XrHands::poll_events() {
  for (;;) {
    XrEventDataBuffer ev{};
    ev.type = XR_TYPE_EVENT_DATA_BUFFER;
    const XrResult r = xrPollEvent(instance_, &ev);
    check(instance_, r, "xrPollEvent");
    if (r == XR_EVENT_UNAVAILABLE) return;
    if (ev.type == XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED)
      state_ = reinterpret_cast<const XrEventDataSessionStateChanged&>(ev).state;
    else if (ev.type == XR_TYPE_EVENT_DATA_INSTANCE_LOSS_PENDING)
      running_ = false;
  }
}

void XrHands::frame_call_failed(XrResult r, const char* what, bool& reported) {
  if (r == XR_ERROR_SESSION_LOST || r == XR_ERROR_INSTANCE_LOST) check(instance_, r, what);
  if (reported) return;
  reported = true;
  fmt::print("demo: {} failed ({}): no frame reaches the runtime's compositor (a headless session); "
             "the hands and ink carry on\n",
             what, result_name(instance_, r));
}

XrTime XrHands::begin_frame() {
  poll_events();
  XrFrameState fs{XR_TYPE_FRAME_STATE, nullptr, 0, 0, XR_FALSE};
  XrFrameWaitInfo wi{XR_TYPE_FRAME_WAIT_INFO, nullptr};
  check(instance_, xrWaitFrame(session_, &wi, &fs), "xrWaitFrame");
  XrTime time = fs.predictedDisplayTime;
  if (time <= 0) {
    // No display time and, on Monado's headless session, no pacing either: time the
    // frames ourselves, or the loop would spin.
    if (!clock_) {
      if (!convert_timespec_)
        throw std::runtime_error("OpenXR: xrWaitFrame gives no display time and the runtime lacks "
                                 "XR_KHR_convert_timespec_time to time the frames otherwise");
      clock_.emplace(instance_, convert_timespec_, fps_);
      fmt::print("demo: xrWaitFrame gives no display time (a headless session): frames timed at {:g} Hz from "
                 "CLOCK_MONOTONIC through xrConvertTimespecTimeToTimeKHR\n",
                 fps_);
    }
    time = clock_->next();
  }
  XrFrameBeginInfo bi{XR_TYPE_FRAME_BEGIN_INFO, nullptr};
  const XrResult r = xrBeginFrame(session_, &bi);
  frame_begun_ = XR_SUCCEEDED(r);
  if (!frame_begun_) frame_call_failed(r, "xrBeginFrame", begin_reported_);
  return time;
}

void XrHands::end_frame(XrTime display_time) {
  if (!frame_begun_) return;  // ending a frame that never began is a call-order error
  frame_begun_ = false;
  XrFrameEndInfo ei{XR_TYPE_FRAME_END_INFO, nullptr, display_time, XR_ENVIRONMENT_BLEND_MODE_OPAQUE, 0, nullptr};
  const XrResult r = xrEndFrame(session_, &ei);
  if (XR_FAILED(r)) frame_call_failed(r, "xrEndFrame", end_reported_);
}

Pose XrHands::locate(Hand hand, XrTime time, bool raw) const {
  Pose p = untracked_pose();
  const PFN_xrLocateHandJointsEXT fn = raw ? locate_raw_ : locate_;
  if (!fn) return p;
  std::array<XrHandJointLocationEXT, XR_HAND_JOINT_COUNT_EXT> loc{};
  XrHandJointLocationsEXT out{XR_TYPE_HAND_JOINT_LOCATIONS_EXT, nullptr, XR_FALSE, XR_HAND_JOINT_COUNT_EXT, loc.data()};
  const XrHandJointsLocateInfoEXT li{XR_TYPE_HAND_JOINTS_LOCATE_INFO_EXT, nullptr, local_, time};
  const XrHandTrackerEXT tracker = trackers_[hand == Hand::Left ? 0 : 1];
  if (XR_FAILED(fn(tracker, &li, &out)) || !out.isActive) return p;
  constexpr XrSpaceLocationFlags valid = XR_SPACE_LOCATION_POSITION_VALID_BIT;
  for (int j = 0; j < kJointCount; ++j) {
    const XrVector3f& v = loc[j].pose.position;
    if ((loc[j].locationFlags & valid) && std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z))
      p.row(j) << v.x, v.y, v.z;
  }
  return p;
}

void XrHands::shutdown() {
  if (ended_ || session_ == XR_NULL_HANDLE) return;
  ended_ = true;
  if (!running_) return;
  check(instance_, xrRequestExitSession(session_), "xrRequestExitSession");
  for (int i = 0; i < 1000 && state_ != XR_SESSION_STATE_STOPPING; ++i) poll_events();
  check(instance_, xrEndSession(session_), "xrEndSession");
  for (int i = 0; i < 1000 && state_ != XR_SESSION_STATE_EXITING; ++i) poll_events();
  running_ = false;
}

}  // namespace hs::demo
