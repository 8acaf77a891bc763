// HandSteady replay runtime: a minimal headless OpenXR runtime that replays a track CSV
// as XR_EXT_hand_tracking for both hands. Meant for tests and benchmarks of the layer:
// deterministic simulated clock, reference spaces with optional head motion, optional
// live corruption and injected faults. Only xrNegotiateLoaderRuntimeInterface is exported.
#define XR_USE_TIMESPEC
#include <time.h>

#include <openxr/openxr.h>
#include <openxr/openxr_platform.h>
#include <openxr/openxr_reflection.h>

#include "handsteady/corrupt.hpp"
#include "handsteady/skeleton.hpp"
#include "handsteady/track.hpp"
#include "handsteady/track_ops.hpp"
#include "handsteady_xr/hand_tracking_data_source.hpp"
#include "handsteady_xr/loader_negotiation.hpp"
#include "handsteady_xr/ultraleap_forearm.hpp"
#include "handsteady_xr/xr_math.hpp"
#include "shim_actions.hpp"
#include "shim_config.hpp"
#include "shim_hand.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <deque>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace hs::shim {
namespace {

using xr::Rigid;
constexpr XrTime kSimEpochNs = 1'000'000'000;  // XrTime of the track's first row in sim mode
constexpr uint64_t kHandTrackingSystem = 1;
constexpr int kMaxJoints = XR_HAND_FOREARM_JOINT_COUNT_ULTRALEAP;  // the forearm set: the hand's 26, then the elbow

struct SessionData {
  XrSessionState state = XR_SESSION_STATE_UNKNOWN;
  bool running = false;
  bool frame_waited = false;
  bool frame_begun = false;
  bool attached = false;                   // xrAttachSessionActionSets done
  std::array<XrPath, 2> profile{};         // current interaction profile per hand (left, right)
};
struct SpaceData {
  XrSession session;
  XrReferenceSpaceType type;
  Rigid pose_in_ref;  // a reference space's pose in it, or an action space's pose in the action's
  uint64_t action = 0;                     // an action space: its action (else 0)
  XrPath subaction = XR_NULL_PATH;
};
struct ActionData {
  uint64_t set = 0;
  XrActionType type = XR_ACTION_TYPE_POSE_INPUT;
  std::vector<XrPath> subactions;
  std::vector<HandBinding> hand_bindings;  // suggested for the hand interaction profile
};
struct TrackerData {
  XrSession session;
  XrHandEXT hand;
  uint32_t joint_count = XR_HAND_JOINT_COUNT_EXT;  // XR_ULTRALEAP_hand_tracking_forearm's set: 27
  // XR_EXT_hand_tracking_data_source: created with XrHandTrackingDataSourceInfoEXT, and
  // the sources it accepts (without the info: hand tracking only).
  bool source_info = false;
  bool unobstructed = true, controller = false;
};

struct Runtime {
  std::mutex mu;
  bool live = false;
  XrInstance instance = XR_NULL_HANDLE;
  bool ext_hand = false, ext_headless = false, ext_timespec = false, ext_data_source = false, ext_forearm = false,
       ext_capsules = false, ext_aim = false, ext_mesh = false, ext_hand_interaction = false, ext_palm_pose = false;
  ShimConfig cfg;
  std::array<HandSeries, 2> hands;
  std::array<HandSeries, 2> controller_hands;  // the recording uncorrupted, where a controller places it
  TrackClock clock{0.0, kSimEpochNs};  // XrTime -> track time (t0 at epoch)
  XrTime sim_now = kSimEpochNs;
  XrTime mono_at_tick = 0;     // sim clock: CLOCK_MONOTONIC when sim_now last advanced
  int64_t real_offset = 0;     // real clock: XrTime = CLOCK_MONOTONIC - real_offset
  uint64_t next_handle = 0x100;
  std::map<uint64_t, SessionData> sessions;
  std::map<uint64_t, SpaceData> spaces;
  std::map<uint64_t, TrackerData> trackers;
  // The action system: paths (XrPath = index + 1, per instance), action sets (attached or
  // not) and actions; whether hand interaction bindings were suggested.
  std::vector<std::string> paths;
  std::map<uint64_t, bool> action_sets;
  std::map<uint64_t, ActionData> actions;
  bool hand_profile_suggested = false;
  std::deque<XrEventDataBuffer> events;
  bool recenter_announced = false;
};
Runtime& rt() {
  static Runtime r;
  return r;
}

template <class H>
uint64_t id_of(H h) { return reinterpret_cast<uint64_t>(h); }
template <class H>
H handle_of(uint64_t id) { return reinterpret_cast<H>(id); }

XrTime monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<XrTime>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Current runtime time (caller holds the lock).
XrTime now_locked(const Runtime& r) { return r.cfg.real_clock ? monotonic_ns() - r.real_offset : r.sim_now; }

// A CLOCK_MONOTONIC time as this runtime's XrTime. Sim clock: sim_now plus the real time
// since it last advanced, at most one period (a frame's worth of real time maps into it).
XrTime monotonic_to_xr(const Runtime& r, XrTime mono) {
  if (r.cfg.real_clock) return mono - r.real_offset;
  return r.sim_now + std::clamp<XrTime>(mono - r.mono_at_tick, 0, r.cfg.period_ns - 1);
}

double track_time(const Runtime& r, XrTime t) { return r.clock.at(t); }

Rigid yaw_pitch(double yaw, double pitch, const Eigen::Vector3d& pos) {
  Rigid r = Rigid::Identity();
  r.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  r.translation() = pos;
  return r;
}

// LOCAL after the recentring, in the world (= LOCAL before it).
Rigid recentred_local(const Recenter& rc) { return yaw_pitch(rc.yaw_rad, 0.0, rc.offset_m); }

// Pose of a reference space in the world (= LOCAL) frame at track time t (s).
Rigid reference_in_world(const Runtime& r, XrReferenceSpaceType type, double t) {
  constexpr double tau = 2.0 * std::numbers::pi;
  switch (type) {
    case XR_REFERENCE_SPACE_TYPE_STAGE:
      // The floor, 1.5 m below and turned 30 degrees, so conversions are not trivial.
      return yaw_pitch(tau / 12.0, 0.0, Eigen::Vector3d(0.2, -1.5, 0.3));
    case XR_REFERENCE_SPACE_TYPE_VIEW:
      if (!r.cfg.head_motion) return Rigid::Identity();
      // Smooth head motion: a few cm of sway and +-20 degrees of yaw.
      return yaw_pitch(0.35 * std::sin(tau * 0.25 * t), 0.15 * std::sin(tau * 0.35 * t),
                       Eigen::Vector3d(0.08 * std::sin(tau * 0.4 * t), 0.03 * std::sin(tau * 0.7 * t),
                                       0.05 * std::sin(tau * 0.3 * t)));
    case XR_REFERENCE_SPACE_TYPE_LOCAL:
      if (r.cfg.recenter && t >= r.cfg.recenter->at_s) return recentred_local(*r.cfg.recenter);
      return Rigid::Identity();
    default:
      return Rigid::Identity();
  }
}

// The recentring's announcement, once, 0.1 s ahead of it, to every running session.
void announce_recenter(Runtime& r, XrTime now) {
  if (!r.cfg.recenter || r.recenter_announced) return;
  const Recenter& rc = *r.cfg.recenter;
  if (track_time(r, now) < rc.at_s - 0.1) return;
  r.recenter_announced = true;
  for (const auto& [id, s] : r.sessions) {
    if (!s.running) continue;
    XrEventDataBuffer buf{};
    auto* ev = reinterpret_cast<XrEventDataReferenceSpaceChangePending*>(&buf);
    ev->type = XR_TYPE_EVENT_DATA_REFERENCE_SPACE_CHANGE_PENDING;
    ev->next = nullptr;
    ev->session = handle_of<XrSession>(id);
    ev->referenceSpaceType = XR_REFERENCE_SPACE_TYPE_LOCAL;
    ev->changeTime = r.clock.epoch + static_cast<XrTime>(std::llround((rc.at_s - r.clock.t0) * 1e9));
    ev->poseValid = XR_TRUE;
    ev->poseInPreviousSpace = xr::to_xr(recentred_local(rc));
    r.events.push_back(buf);
  }
}

Rigid space_in_world(const Runtime& r, const SpaceData& s, double t) {
  return reference_in_world(r, s.type, t) * s.pose_in_ref;
}

void push_state_event(Runtime& r, XrSession session, XrSessionState state, XrTime time) {
  XrEventDataBuffer buf{};
  auto* ev = reinterpret_cast<XrEventDataSessionStateChanged*>(&buf);
  ev->type = XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED;
  ev->next = nullptr;
  ev->session = session;
  ev->state = state;
  ev->time = time;
  r.events.push_back(buf);
  r.sessions[id_of(session)].state = state;
}

template <class T>
XrResult two_call(uint32_t capacity, uint32_t* count, T* out, const T* values, uint32_t n) {
  if (!count) return XR_ERROR_VALIDATION_FAILURE;
  *count = n;
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < n) return XR_ERROR_SIZE_INSUFFICIENT;
  if (!out) return XR_ERROR_VALIDATION_FAILURE;
  std::copy(values, values + n, out);
  return XR_SUCCESS;
}

void copy_name(char* dst, size_t size, std::string_view src) {
  const size_t n = std::min(size - 1, src.size());
  std::memcpy(dst, src.data(), n);
  dst[n] = '\0';
}

// ---------------------------------------------------------------- instance

struct ExtensionInfo {
  const char* name;
  uint32_t version;
};
constexpr std::array<ExtensionInfo, 10> kExtensions = {{
    {kHandInteractionExtension, kHandInteractionSpecVersion},
    {kPalmPoseExtension, kPalmPoseSpecVersion},
    {XR_EXT_HAND_TRACKING_EXTENSION_NAME, XR_EXT_hand_tracking_SPEC_VERSION},
    {XR_EXT_HAND_TRACKING_DATA_SOURCE_EXTENSION_NAME, XR_EXT_hand_tracking_data_source_SPEC_VERSION},
    {XR_ULTRALEAP_HAND_TRACKING_FOREARM_EXTENSION_NAME, XR_ULTRALEAP_hand_tracking_forearm_SPEC_VERSION},
    {XR_FB_HAND_TRACKING_CAPSULES_EXTENSION_NAME, XR_FB_hand_tracking_capsules_SPEC_VERSION},
    {XR_FB_HAND_TRACKING_AIM_EXTENSION_NAME, XR_FB_hand_tracking_aim_SPEC_VERSION},
    {XR_FB_HAND_TRACKING_MESH_EXTENSION_NAME, XR_FB_hand_tracking_mesh_SPEC_VERSION},
    {XR_MND_HEADLESS_EXTENSION_NAME, XR_MND_headless_SPEC_VERSION},
    {XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME, XR_KHR_convert_timespec_time_SPEC_VERSION},
}};

XRAPI_ATTR XrResult XRAPI_CALL EnumerateInstanceExtensionProperties(const char* layerName, uint32_t capacity,
                                                                    uint32_t* count, XrExtensionProperties* props) {
  if (layerName && *layerName) return XR_ERROR_API_LAYER_NOT_PRESENT;
  if (!count) return XR_ERROR_VALIDATION_FAILURE;
  *count = static_cast<uint32_t>(kExtensions.size());
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < kExtensions.size()) return XR_ERROR_SIZE_INSUFFICIENT;
  for (size_t i = 0; i < kExtensions.size(); ++i) {
    props[i].type = XR_TYPE_EXTENSION_PROPERTIES;
    props[i].next = nullptr;
    copy_name(props[i].extensionName, XR_MAX_EXTENSION_NAME_SIZE, kExtensions[i].name);
    props[i].extensionVersion = kExtensions[i].version;
  }
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL EnumerateApiLayerProperties(uint32_t, uint32_t* count, XrApiLayerProperties*) {
  if (!count) return XR_ERROR_VALIDATION_FAILURE;
  *count = 0;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateInstance(const XrInstanceCreateInfo* info, XrInstance* instance) {
  if (!info || !instance || info->type != XR_TYPE_INSTANCE_CREATE_INFO) return XR_ERROR_VALIDATION_FAILURE;
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (r.live) return XR_ERROR_LIMIT_REACHED;
  bool hand = false, headless = false, timespec = false, data_source = false, forearm = false, capsules = false,
       aim = false, mesh = false, hand_interaction = false, palm_pose = false;
  for (uint32_t i = 0; i < info->enabledExtensionCount; ++i) {
    const std::string_view name = info->enabledExtensionNames[i];
    if (name == XR_EXT_HAND_TRACKING_EXTENSION_NAME) hand = true;
    else if (name == XR_EXT_HAND_TRACKING_DATA_SOURCE_EXTENSION_NAME) data_source = true;
    else if (name == XR_ULTRALEAP_HAND_TRACKING_FOREARM_EXTENSION_NAME) forearm = true;
    else if (name == XR_FB_HAND_TRACKING_CAPSULES_EXTENSION_NAME) capsules = true;
    else if (name == XR_FB_HAND_TRACKING_AIM_EXTENSION_NAME) aim = true;
    else if (name == XR_FB_HAND_TRACKING_MESH_EXTENSION_NAME) mesh = true;
    else if (name == kHandInteractionExtension) hand_interaction = true;
    else if (name == kPalmPoseExtension) palm_pose = true;
    else if (name == XR_MND_HEADLESS_EXTENSION_NAME) headless = true;
    else if (name == XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME) timespec = true;
    else return XR_ERROR_EXTENSION_NOT_PRESENT;
  }
  try {
    r.cfg = shim_config_from_env();
    r.hands = {};
    r.controller_hands = {};
    if (!r.cfg.track_path.empty()) {
      Track track = read_track_csv(r.cfg.track_path);
      if (r.cfg.controller) {
        Track placed = track;
        for (TrackRow& row : placed.rows)
          for (int j = 0; j < kJointCount; ++j)
            if (joint_tracked(row.pos, j)) row.pos.row(j) += r.cfg.controller->offset_m.transpose();
        r.controller_hands = {hand_series(placed, Hand::Left), hand_series(placed, Hand::Right)};
      }
      if (!r.cfg.corrupt_preset.empty())
        track = corrupt_track(track, corruption_preset(r.cfg.corrupt_preset), r.cfg.corrupt_seed);
      r.hands = {hand_series(track, Hand::Left), hand_series(track, Hand::Right)};
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "handsteady replay runtime: %s\n", e.what());
    return XR_ERROR_RUNTIME_FAILURE;
  }
  double t0 = std::numeric_limits<double>::infinity();
  for (const auto& s : r.hands)
    if (!s.empty()) t0 = std::min(t0, s.t.front());
  r.clock.t0 = std::isfinite(t0) ? t0 : 0.0;
  const XrTime mono = monotonic_ns();
  r.clock.epoch = r.cfg.epoch_ns.value_or(r.cfg.real_clock ? mono : kSimEpochNs);
  r.real_offset = mono - r.clock.epoch;
  r.sim_now = r.clock.epoch;
  r.mono_at_tick = monotonic_ns();
  r.ext_hand = hand;
  r.ext_headless = headless;
  r.ext_timespec = timespec;
  r.ext_data_source = data_source;
  r.ext_forearm = forearm;
  r.ext_capsules = capsules;
  r.ext_aim = aim;
  r.ext_mesh = mesh;
  r.ext_hand_interaction = hand_interaction;
  r.ext_palm_pose = palm_pose;
  r.sessions.clear();
  r.spaces.clear();
  r.trackers.clear();
  r.paths.clear();
  r.action_sets.clear();
  r.actions.clear();
  r.hand_profile_suggested = false;
  r.events.clear();
  r.recenter_announced = false;
  r.instance = handle_of<XrInstance>(r.next_handle++);
  r.live = true;
  *instance = r.instance;
  return XR_SUCCESS;
}

bool instance_ok(const Runtime& r, XrInstance instance) { return r.live && instance == r.instance; }

XRAPI_ATTR XrResult XRAPI_CALL DestroyInstance(XrInstance instance) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  r.live = false;
  r.sessions.clear();
  r.spaces.clear();
  r.trackers.clear();
  r.paths.clear();
  r.action_sets.clear();
  r.actions.clear();
  r.events.clear();
  r.hands = {};
  r.controller_hands = {};
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProperties(XrInstance instance, XrInstanceProperties* props) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!props || props->type != XR_TYPE_INSTANCE_PROPERTIES) return XR_ERROR_VALIDATION_FAILURE;
  props->runtimeVersion = XR_MAKE_VERSION(0, 1, 0);
  copy_name(props->runtimeName, XR_MAX_RUNTIME_NAME_SIZE, "HandSteady replay runtime");
  return XR_SUCCESS;
}

template <class E>
XrResult enum_to_string(XrInstance instance, E value, char* buffer, size_t size, const char* prefix) {
  Runtime& r = rt();
  {
    std::lock_guard lock(r.mu);
    if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  }
  if (!buffer) return XR_ERROR_VALIDATION_FAILURE;
  const char* name = nullptr;
  if constexpr (std::is_same_v<E, XrResult>) {
#define HS_CASE(n, v) \
  case n: name = #n; break;
    switch (value) { XR_LIST_ENUM_XrResult(HS_CASE) default: break; }
  } else {
    switch (value) { XR_LIST_ENUM_XrStructureType(HS_CASE) default: break; }
#undef HS_CASE
  }
  if (name) copy_name(buffer, size, name);
  else std::snprintf(buffer, size, "%s_%d", prefix, static_cast<int>(value));
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL ResultToString(XrInstance instance, XrResult value, char buffer[XR_MAX_RESULT_STRING_SIZE]) {
  return enum_to_string(instance, value, buffer, XR_MAX_RESULT_STRING_SIZE,
                        value < 0 ? "XR_UNKNOWN_FAILURE" : "XR_UNKNOWN_SUCCESS");
}
XRAPI_ATTR XrResult XRAPI_CALL StructureTypeToString(XrInstance instance, XrStructureType value,
                                                     char buffer[XR_MAX_STRUCTURE_NAME_SIZE]) {
  return enum_to_string(instance, value, buffer, XR_MAX_STRUCTURE_NAME_SIZE, "XR_UNKNOWN_STRUCTURE_TYPE");
}

XRAPI_ATTR XrResult XRAPI_CALL ConvertTimespecTimeToTimeKHR(XrInstance instance, const timespec* ts, XrTime* time) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!ts || !time) return XR_ERROR_VALIDATION_FAILURE;
  // XrTime counts nanoseconds of CLOCK_MONOTONIC (real clock, less the epoch's offset) or
  // of the simulated clock.
  *time = monotonic_to_xr(r, static_cast<XrTime>(ts->tv_sec) * 1'000'000'000 + ts->tv_nsec);
  return *time > 0 ? XR_SUCCESS : XR_ERROR_TIME_INVALID;
}
XRAPI_ATTR XrResult XRAPI_CALL ConvertTimeToTimespecTimeKHR(XrInstance instance, XrTime time, timespec* ts) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!ts) return XR_ERROR_VALIDATION_FAILURE;
  if (time <= 0) return XR_ERROR_TIME_INVALID;
  // The inverse mapping.
  const int64_t ns = r.cfg.real_clock ? time + r.real_offset : r.mono_at_tick + (time - r.sim_now);
  ts->tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  ts->tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL PollEvent(XrInstance instance, XrEventDataBuffer* event) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!event) return XR_ERROR_VALIDATION_FAILURE;
  if (r.events.empty()) return XR_EVENT_UNAVAILABLE;
  *event = r.events.front();
  r.events.pop_front();
  return XR_SUCCESS;
}

// ---------------------------------------------------------------- system

XRAPI_ATTR XrResult XRAPI_CALL GetSystem(XrInstance instance, const XrSystemGetInfo* info, XrSystemId* system) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!info || !system || info->type != XR_TYPE_SYSTEM_GET_INFO) return XR_ERROR_VALIDATION_FAILURE;
  if (info->formFactor != XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY) return XR_ERROR_FORM_FACTOR_UNSUPPORTED;
  *system = kHandTrackingSystem;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL GetSystemProperties(XrInstance instance, XrSystemId system, XrSystemProperties* props) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (system != kHandTrackingSystem) return XR_ERROR_SYSTEM_INVALID;
  if (!props || props->type != XR_TYPE_SYSTEM_PROPERTIES) return XR_ERROR_VALIDATION_FAILURE;
  props->systemId = system;
  props->vendorId = 0;
  copy_name(props->systemName, XR_MAX_SYSTEM_NAME_SIZE, "HandSteady replay");
  props->graphicsProperties = {0, 0, 0};
  props->trackingProperties = {XR_FALSE, XR_TRUE};
  for (auto* s = static_cast<XrBaseOutStructure*>(props->next); s; s = s->next)
    if (s->type == XR_TYPE_SYSTEM_HAND_TRACKING_PROPERTIES_EXT)
      reinterpret_cast<XrSystemHandTrackingPropertiesEXT*>(s)->supportsHandTracking = r.ext_hand ? XR_TRUE : XR_FALSE;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL EnumerateViewConfigurations(XrInstance instance, XrSystemId system, uint32_t,
                                                           uint32_t* count, XrViewConfigurationType*) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (system != kHandTrackingSystem) return XR_ERROR_SYSTEM_INVALID;
  if (!count) return XR_ERROR_VALIDATION_FAILURE;
  *count = 0;  // headless: nothing to render
  return XR_SUCCESS;
}

// ---------------------------------------------------------------- session

SessionData* find_session(Runtime& r, XrSession s) {
  auto it = r.sessions.find(id_of(s));
  return it == r.sessions.end() ? nullptr : &it->second;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateSession(XrInstance instance, const XrSessionCreateInfo* info, XrSession* session) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!info || !session || info->type != XR_TYPE_SESSION_CREATE_INFO) return XR_ERROR_VALIDATION_FAILURE;
  if (info->systemId != kHandTrackingSystem) return XR_ERROR_SYSTEM_INVALID;
  if (!r.ext_headless || info->next) return XR_ERROR_GRAPHICS_DEVICE_INVALID;  // headless only
  const XrSession s = handle_of<XrSession>(r.next_handle++);
  r.sessions[id_of(s)] = SessionData{};
  push_state_event(r, s, XR_SESSION_STATE_IDLE, now_locked(r));
  push_state_event(r, s, XR_SESSION_STATE_READY, now_locked(r));
  *session = s;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySession(XrSession session) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!find_session(r, session)) return XR_ERROR_HANDLE_INVALID;
  std::erase_if(r.spaces, [&](const auto& kv) { return kv.second.session == session; });
  std::erase_if(r.trackers, [&](const auto& kv) { return kv.second.session == session; });
  std::erase_if(r.events, [&](const XrEventDataBuffer& e) {
    return e.type == XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED &&
           reinterpret_cast<const XrEventDataSessionStateChanged*>(&e)->session == session;
  });
  r.sessions.erase(id_of(session));
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL BeginSession(XrSession session, const XrSessionBeginInfo* info) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_SESSION_BEGIN_INFO) return XR_ERROR_VALIDATION_FAILURE;
  if (s->running) return XR_ERROR_SESSION_RUNNING;
  if (s->state != XR_SESSION_STATE_READY) return XR_ERROR_SESSION_NOT_READY;
  s->running = true;
  const XrTime t = now_locked(r);
  push_state_event(r, session, XR_SESSION_STATE_SYNCHRONIZED, t);
  push_state_event(r, session, XR_SESSION_STATE_VISIBLE, t);
  push_state_event(r, session, XR_SESSION_STATE_FOCUSED, t);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL RequestExitSession(XrSession session) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!s->running) return XR_ERROR_SESSION_NOT_RUNNING;
  const XrTime t = now_locked(r);
  push_state_event(r, session, XR_SESSION_STATE_VISIBLE, t);
  push_state_event(r, session, XR_SESSION_STATE_SYNCHRONIZED, t);
  push_state_event(r, session, XR_SESSION_STATE_STOPPING, t);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL EndSession(XrSession session) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!s->running) return XR_ERROR_SESSION_NOT_RUNNING;
  if (s->state != XR_SESSION_STATE_STOPPING) return XR_ERROR_SESSION_NOT_STOPPING;
  s->running = false;
  const XrTime t = now_locked(r);
  push_state_event(r, session, XR_SESSION_STATE_IDLE, t);
  push_state_event(r, session, XR_SESSION_STATE_EXITING, t);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL WaitFrame(XrSession session, const XrFrameWaitInfo* info, XrFrameState* state) {
  Runtime& r = rt();
  std::unique_lock lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if ((info && info->type != XR_TYPE_FRAME_WAIT_INFO) || !state || state->type != XR_TYPE_FRAME_STATE)
    return XR_ERROR_VALIDATION_FAILURE;
  if (!s->running) return XR_ERROR_SESSION_NOT_RUNNING;
  if (r.cfg.frames == FrameMode::HeadlessZero) {
    // Monado's headless session (no compositor): xrWaitFrame returns at once, without
    // pacing, and gives no times; no frame counts as waited, so xrBeginFrame and then
    // xrEndFrame fail with XR_ERROR_CALL_ORDER_INVALID. The app times itself
    // (xrConvertTimespecTimeToTimeKHR). The simulated clock still runs.
    if (!r.cfg.real_clock) r.sim_now += r.cfg.period_ns;
    announce_recenter(r, now_locked(r));
    state->predictedDisplayTime = 0;
    state->predictedDisplayPeriod = 0;
    state->shouldRender = XR_FALSE;
    return XR_SUCCESS;
  }
  XrTime now = 0;
  if (r.cfg.real_clock) {
    // Sleep to the next period boundary since the epoch (without holding the lock).
    const int64_t period = r.cfg.period_ns;
    const XrTime epoch = r.clock.epoch;
    const int64_t offset = r.real_offset;
    lock.unlock();
    const XrTime t = monotonic_ns() - offset;
    const XrTime next = epoch + ((t - epoch) / period + 1) * period;
    std::this_thread::sleep_for(std::chrono::nanoseconds(next - t));
    lock.lock();
    s = find_session(r, session);
    if (!s) return XR_ERROR_HANDLE_INVALID;
    now = now_locked(r);
  } else {
    r.sim_now += r.cfg.period_ns;
    r.mono_at_tick = monotonic_ns();
    now = r.sim_now;
  }
  announce_recenter(r, now);
  s->frame_waited = true;
  state->predictedDisplayTime = now + r.cfg.latency_ns;
  state->predictedDisplayPeriod = r.cfg.period_ns;
  state->shouldRender = XR_FALSE;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL BeginFrame(XrSession session, const XrFrameBeginInfo* info) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (info && info->type != XR_TYPE_FRAME_BEGIN_INFO) return XR_ERROR_VALIDATION_FAILURE;
  if (!s->running) return XR_ERROR_SESSION_NOT_RUNNING;
  if (!s->frame_waited) return XR_ERROR_CALL_ORDER_INVALID;
  s->frame_waited = false;
  const bool discarded = s->frame_begun;
  s->frame_begun = true;
  return discarded ? XR_FRAME_DISCARDED : XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL EndFrame(XrSession session, const XrFrameEndInfo* info) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_FRAME_END_INFO) return XR_ERROR_VALIDATION_FAILURE;
  if (!s->running) return XR_ERROR_SESSION_NOT_RUNNING;
  if (!s->frame_begun) return XR_ERROR_CALL_ORDER_INVALID;
  if (info->displayTime <= 0) return XR_ERROR_TIME_INVALID;
  s->frame_begun = false;
  return XR_SUCCESS;
}

// ---------------------------------------------------------------- the hand's joints

// Joint positions and frames of world hand w (every joint placed: with_valid_positions)
// in a space whose pose in the world is base_in_world; the elbow (the forearm set's 27th
// joint) takes the wrist's frame.
void joints_in(const Rigid& base_in_world, const Pose& filled, bool left, std::array<Eigen::Vector3d, kMaxJoints>& pos,
               std::array<Eigen::Matrix3d, kMaxJoints>& rot) {
  const Rigid world_to_base = base_in_world.inverse();
  const auto frames = joint_frames(filled, left);
  for (int j = 0; j < kJointCount; ++j) {
    pos[j] = world_to_base * Eigen::Vector3d(filled.row(j).transpose());
    rot[j] = world_to_base.linear() * frames[j];
  }
  pos[kJointCount] = world_to_base * elbow_position(filled);
  rot[kJointCount] = rot[idx(Joint::Wrist)];
}

// A joint of the set is tracked with its recorded joint (the elbow: with the wrist).
bool set_joint_tracked(const Pose& w, int j) { return joint_tracked(w, j < kJointCount ? j : idx(Joint::Wrist)); }

// The answer's joint locations from joints_in's positions and frames: every joint valid,
// tracked where recorded, the joints' radii.
void fill_locations(const std::array<Eigen::Vector3d, kMaxJoints>& pos, const std::array<Eigen::Matrix3d, kMaxJoints>& rot,
                    const Pose& world, uint32_t count, XrHandJointLocationEXT* out) {
  for (int j = 0; j < static_cast<int>(count); ++j) {
    XrHandJointLocationEXT& loc = out[j];
    loc.pose.position = xr::to_xr(pos[j]);
    loc.pose.orientation = xr::to_xr(Eigen::Quaterniond(rot[j]).normalized());
    loc.radius = j < kJointCount ? joint_radius(j) : kElbowRadiusM;
    loc.locationFlags = XR_SPACE_LOCATION_ORIENTATION_VALID_BIT | XR_SPACE_LOCATION_POSITION_VALID_BIT;
    if (set_joint_tracked(world, j))
      loc.locationFlags |= XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT;
  }
}

// The tracked hand h (0 left) at `time` in the world, its 26 joints as its tracker answers
// them (faults included): what the hand interaction profile's poses are derived from.
// False when no hand is tracked then (or a controller holds it).
bool world_joints(const Runtime& r, int h, XrTime time, std::array<XrHandJointLocationEXT, kJointCount>& out) {
  if (r.cfg.controller && r.cfg.controller->contains(track_time(r, time))) return false;
  const Pose world = replayed_hand(r.hands[static_cast<size_t>(h)], r.cfg, r.clock, time, now_locked(r));
  if (!any_joint_tracked(world)) return false;
  std::array<Eigen::Vector3d, kMaxJoints> pos;
  std::array<Eigen::Matrix3d, kMaxJoints> rot;
  joints_in(Rigid::Identity(), with_valid_positions(world), h == 0, pos, rot);
  fill_locations(pos, rot, world, kJointCount, out.data());
  inject_joint_faults(r.cfg.faults, time, h, out.data(), nullptr);
  return true;
}

// ---------------------------------------------------------------- spaces

// A pose an app may give a space: a finite position, a unit orientation (within 1e-3 in
// squared norm); else XR_ERROR_POSE_INVALID.
bool valid_pose(const XrPosef& p) {
  const XrQuaternionf& q = p.orientation;
  const float n = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  return xr::finite(p.position) && std::isfinite(n) && std::fabs(n - 1.0f) <= 1e-3f;
}

constexpr std::array<XrReferenceSpaceType, 3> kSpaceTypes = {
    XR_REFERENCE_SPACE_TYPE_VIEW, XR_REFERENCE_SPACE_TYPE_LOCAL, XR_REFERENCE_SPACE_TYPE_STAGE};

XRAPI_ATTR XrResult XRAPI_CALL EnumerateReferenceSpaces(XrSession session, uint32_t capacity, uint32_t* count,
                                                        XrReferenceSpaceType* spaces) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!find_session(r, session)) return XR_ERROR_HANDLE_INVALID;
  return two_call(capacity, count, spaces, kSpaceTypes.data(), static_cast<uint32_t>(kSpaceTypes.size()));
}

XRAPI_ATTR XrResult XRAPI_CALL CreateReferenceSpace(XrSession session, const XrReferenceSpaceCreateInfo* info,
                                                    XrSpace* space) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!find_session(r, session)) return XR_ERROR_HANDLE_INVALID;
  if (!info || !space || info->type != XR_TYPE_REFERENCE_SPACE_CREATE_INFO) return XR_ERROR_VALIDATION_FAILURE;
  if (std::find(kSpaceTypes.begin(), kSpaceTypes.end(), info->referenceSpaceType) == kSpaceTypes.end())
    return XR_ERROR_REFERENCE_SPACE_UNSUPPORTED;
  if (!valid_pose(info->poseInReferenceSpace)) return XR_ERROR_POSE_INVALID;
  const XrSpace s = handle_of<XrSpace>(r.next_handle++);
  r.spaces[id_of(s)] = SpaceData{session, info->referenceSpaceType, xr::to_rigid(info->poseInReferenceSpace)};
  *space = s;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySpace(XrSpace space) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  return r.spaces.erase(id_of(space)) ? XR_SUCCESS : XR_ERROR_HANDLE_INVALID;
}

std::string_view path_string(const Runtime& r, XrPath path) {
  return path >= 1 && path <= r.paths.size() ? std::string_view(r.paths[path - 1]) : std::string_view();
}

// Which hand's pose input an action space stands for now: the first hand (left, then
// right) its subaction path allows whose current profile is the hand interaction profile
// and to which its action is bound as a pose. nullopt: not active.
std::optional<HandBinding> action_space_input(const Runtime& r, const SpaceData& s) {
  const auto session = r.sessions.find(id_of(s.session));
  const auto action = r.actions.find(s.action);
  if (session == r.sessions.end() || action == r.actions.end()) return std::nullopt;
  for (int h = 0; h < 2; ++h) {
    if (s.subaction != XR_NULL_PATH && user_hand(path_string(r, s.subaction)) != h) continue;
    if (path_string(r, session->second.profile[static_cast<size_t>(h)]) != kHandInteractionProfile) continue;
    for (const HandBinding& b : action->second.hand_bindings)
      if (b.hand == h && is_pose(b.input)) return b;
  }
  return std::nullopt;
}

// A space's pose in the world at `time`; false where it cannot be located (an action
// space whose input is not active, or whose hand is not tracked then).
bool space_world_pose(const Runtime& r, const SpaceData& s, XrTime time, Rigid& out) {
  if (s.action == 0) {
    out = space_in_world(r, s, track_time(r, time));
    return true;
  }
  const auto input = action_space_input(r, s);
  std::array<XrHandJointLocationEXT, kJointCount> joints{};
  if (!input || !world_joints(r, input->hand, time, joints)) return false;
  out = xr::to_rigid(hand_input_pose(joints.data(), input->input)) * s.pose_in_ref;
  return true;
}

XRAPI_ATTR XrResult XRAPI_CALL LocateSpace(XrSpace space, XrSpace baseSpace, XrTime time, XrSpaceLocation* location) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  const auto a = r.spaces.find(id_of(space));
  const auto b = r.spaces.find(id_of(baseSpace));
  if (a == r.spaces.end() || b == r.spaces.end()) return XR_ERROR_HANDLE_INVALID;
  if (!location || location->type != XR_TYPE_SPACE_LOCATION) return XR_ERROR_VALIDATION_FAILURE;
  if (time <= 0) return XR_ERROR_TIME_INVALID;
  // Injected fault: the call fails now and then.
  if (r.cfg.faults.space_error > 0.0 &&
      fault_draw(time, static_cast<int>(id_of(space) & 0xff), static_cast<int>(id_of(baseSpace) & 0xff), 14) <
          r.cfg.faults.space_error)
    return XR_ERROR_RUNTIME_FAILURE;
  const double t = track_time(r, time);
  Rigid a_world, b_world;
  if (!space_world_pose(r, a->second, time, a_world) || !space_world_pose(r, b->second, time, b_world)) {
    location->locationFlags = 0;
    location->pose = XrPosef{{0.0f, 0.0f, 0.0f, 1.0f}, {0.0f, 0.0f, 0.0f}};
    for (auto* s = static_cast<XrBaseOutStructure*>(location->next); s; s = s->next)
      if (s->type == XR_TYPE_SPACE_VELOCITY) reinterpret_cast<XrSpaceVelocity*>(s)->velocityFlags = 0;
    return XR_SUCCESS;
  }
  location->pose = xr::to_xr(b_world.inverse() * a_world);
  location->locationFlags = XR_SPACE_LOCATION_ORIENTATION_VALID_BIT | XR_SPACE_LOCATION_POSITION_VALID_BIT |
                            XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT;
  // Injected fault: an impossible pose flagged valid (alternately NaN and 1e30).
  if (r.cfg.faults.space > 0.0 && space != baseSpace &&
      fault_draw(time, static_cast<int>(id_of(space) & 0xff), static_cast<int>(id_of(baseSpace) & 0xff), 4) <
          r.cfg.faults.space) {
    const float bad = fault_draw(time, 0, 0, 5) < 0.5 ? std::numeric_limits<float>::quiet_NaN() : 1e30f;
    location->pose.position = {bad, bad, bad};
  }
  for (auto* s = static_cast<XrBaseOutStructure*>(location->next); s; s = s->next) {
    if (s->type != XR_TYPE_SPACE_VELOCITY) continue;
    auto* v = reinterpret_cast<XrSpaceVelocity*>(s);
    v->velocityFlags = 0;
    // Action spaces: no velocities (the poses derived from the hand are given without).
    if (!r.cfg.space_velocity || a->second.action != 0 || b->second.action != 0) continue;
    // As real runtimes do: the space's origin and rotation relative to the base, in the
    // base's axes (central difference of the relative pose over +-1 ms).
    constexpr double h = 1e-3;
    const auto rel = [&](double u) {
      return Rigid(space_in_world(r, b->second, u).inverse() * space_in_world(r, a->second, u));
    };
    const Rigid p = rel(t + h), m = rel(t - h);
    const Eigen::AngleAxisd turn(Eigen::Matrix3d(p.linear() * m.linear().transpose()));
    v->linearVelocity = xr::to_xr(Eigen::Vector3d((p.translation() - m.translation()) / (2.0 * h)));
    v->angularVelocity = xr::to_xr(Eigen::Vector3d(turn.axis() * turn.angle() / (2.0 * h)));
    v->velocityFlags = XR_SPACE_VELOCITY_LINEAR_VALID_BIT | XR_SPACE_VELOCITY_ANGULAR_VALID_BIT;
  }
  return XR_SUCCESS;
}

// ---------------------------------------------------------------- hand tracking

XRAPI_ATTR XrResult XRAPI_CALL CreateHandTrackerEXT(XrSession session, const XrHandTrackerCreateInfoEXT* info,
                                                    XrHandTrackerEXT* tracker) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!find_session(r, session)) return XR_ERROR_HANDLE_INVALID;
  if (!info || !tracker || info->type != XR_TYPE_HAND_TRACKER_CREATE_INFO_EXT) return XR_ERROR_VALIDATION_FAILURE;
  if (info->hand != XR_HAND_LEFT_EXT && info->hand != XR_HAND_RIGHT_EXT) return XR_ERROR_VALIDATION_FAILURE;
  const bool forearm = r.ext_forearm && info->handJointSet == XR_HAND_JOINT_SET_HAND_WITH_FOREARM_ULTRALEAP;
  if (info->handJointSet != XR_HAND_JOINT_SET_DEFAULT_EXT && !forearm) return XR_ERROR_VALIDATION_FAILURE;
  TrackerData data{session, info->hand};
  if (forearm) data.joint_count = XR_HAND_FOREARM_JOINT_COUNT_ULTRALEAP;
  if (r.ext_data_source)
    for (auto* c = static_cast<const XrBaseInStructure*>(info->next); c; c = c->next) {
      if (c->type != XR_TYPE_HAND_TRACKING_DATA_SOURCE_INFO_EXT) continue;
      // The extension's valid usage: at least one source, each once, each one it defines.
      const auto* ds = reinterpret_cast<const XrHandTrackingDataSourceInfoEXT*>(c);
      if (ds->requestedDataSourceCount == 0 || !ds->requestedDataSources) return XR_ERROR_VALIDATION_FAILURE;
      data.source_info = true;
      data.unobstructed = data.controller = false;
      for (uint32_t i = 0; i < ds->requestedDataSourceCount; ++i) {
        const XrHandTrackingDataSourceEXT v = ds->requestedDataSources[i];
        bool* accepted = v == XR_HAND_TRACKING_DATA_SOURCE_UNOBSTRUCTED_EXT ? &data.unobstructed
                         : v == XR_HAND_TRACKING_DATA_SOURCE_CONTROLLER_EXT ? &data.controller
                                                                             : nullptr;
        if (!accepted || *accepted) return XR_ERROR_VALIDATION_FAILURE;  // unknown or repeated
        *accepted = true;
      }
    }
  const XrHandTrackerEXT t = handle_of<XrHandTrackerEXT>(r.next_handle++);
  r.trackers[id_of(t)] = data;
  *tracker = t;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroyHandTrackerEXT(XrHandTrackerEXT tracker) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  return r.trackers.erase(id_of(tracker)) ? XR_SUCCESS : XR_ERROR_HANDLE_INVALID;
}

XRAPI_ATTR XrResult XRAPI_CALL LocateHandJointsEXT(XrHandTrackerEXT tracker, const XrHandJointsLocateInfoEXT* info,
                                                   XrHandJointLocationsEXT* out) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  const auto tr = r.trackers.find(id_of(tracker));
  if (tr == r.trackers.end()) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_HAND_JOINTS_LOCATE_INFO_EXT || !out ||
      out->type != XR_TYPE_HAND_JOINT_LOCATIONS_EXT || !out->jointLocations)
    return XR_ERROR_VALIDATION_FAILURE;
  const uint32_t count = tr->second.joint_count;
  if (out->jointCount != count) return XR_ERROR_VALIDATION_FAILURE;
  const auto base = r.spaces.find(id_of(info->baseSpace));
  if (base == r.spaces.end()) return XR_ERROR_HANDLE_INVALID;
  if (info->time <= 0) return XR_ERROR_TIME_INVALID;
  const bool action_base = base->second.action != 0;  // joints in an action space: not offered here
  XrHandJointVelocitiesEXT* vel = nullptr;
  XrHandTrackingDataSourceStateEXT* source = nullptr;
  XrHandTrackingCapsulesStateFB* capsules = nullptr;
  XrHandTrackingAimStateFB* aim = nullptr;
  XrHandTrackingScaleFB* scale = nullptr;
  for (auto* s = static_cast<XrBaseOutStructure*>(out->next); s; s = s->next) {
    if (s->type == XR_TYPE_HAND_TRACKING_SCALE_FB && r.ext_mesh) scale = reinterpret_cast<XrHandTrackingScaleFB*>(s);
    if (s->type == XR_TYPE_HAND_TRACKING_CAPSULES_STATE_FB && r.ext_capsules)
      capsules = reinterpret_cast<XrHandTrackingCapsulesStateFB*>(s);
    if (s->type == XR_TYPE_HAND_TRACKING_AIM_STATE_FB && r.ext_aim) aim = reinterpret_cast<XrHandTrackingAimStateFB*>(s);
    if (s->type == XR_TYPE_HAND_JOINT_VELOCITIES_EXT) vel = reinterpret_cast<XrHandJointVelocitiesEXT*>(s);
    if (s->type == XR_TYPE_HAND_TRACKING_DATA_SOURCE_STATE_EXT && r.ext_data_source)
      source = reinterpret_cast<XrHandTrackingDataSourceStateEXT*>(s);
  }
  if (vel && (vel->jointCount != count || !vel->jointVelocities)) return XR_ERROR_VALIDATION_FAILURE;
  // The extension: the state only for a tracker created with the sources it accepts.
  if (source && !tr->second.source_info) return XR_ERROR_VALIDATION_FAILURE;
  // XR_FB_hand_tracking_mesh: the hand at the scale the app asks for (the track's own is 1).
  double hand_scale = 1.0;
  if (scale && scale->overrideHandScale) {
    if (!(std::isfinite(scale->overrideValueInput) && scale->overrideValueInput > 0.0f))
      return XR_ERROR_VALIDATION_FAILURE;
    hand_scale = scale->overrideValueInput;
  }
  if (scale) {
    scale->sensorOutput = 1.0f;
    scale->currentOutput = static_cast<float>(hand_scale);
  }

  const XrHandEXT hand = tr->second.hand;
  // Injected fault: the call fails now and then (the same hand and time fail every time).
  if (r.cfg.faults.error > 0.0 && fault_draw(info->time, hand == XR_HAND_LEFT_EXT ? 0 : 1, 0, 15) < r.cfg.faults.error)
    return XR_ERROR_RUNTIME_FAILURE;
  const XrTime now = now_locked(r);
  // The source at the asked time, and whether the tracker accepts it (else no hand).
  const bool from_controller = r.cfg.controller && r.cfg.controller->contains(track_time(r, info->time));
  const bool accepted = from_controller ? tr->second.controller : tr->second.unobstructed;
  const auto& series = (from_controller ? r.controller_hands : r.hands)[hand == XR_HAND_LEFT_EXT ? 0 : 1];
  const Pose world = accepted && !action_base
                         ? scaled_about_wrist(replayed_hand(series, r.cfg, r.clock, info->time, now), hand_scale)
                         : untracked_pose();
  if (source) {
    source->isActive = accepted ? XR_TRUE : XR_FALSE;
    source->dataSource =
        from_controller ? XR_HAND_TRACKING_DATA_SOURCE_CONTROLLER_EXT : XR_HAND_TRACKING_DATA_SOURCE_UNOBSTRUCTED_EXT;
  }
  if (!any_joint_tracked(world)) {
    out->isActive = XR_FALSE;
    if (aim) aim->status = 0;
    for (uint32_t j = 0; j < out->jointCount; ++j) out->jointLocations[j].locationFlags = 0;
    if (vel)
      for (uint32_t j = 0; j < vel->jointCount; ++j) vel->jointVelocities[j].velocityFlags = 0;
    return XR_SUCCESS;
  }
  // Joint poses in the base space at time t: positions, and frames from the positions.
  auto joints_in_base = [&](XrTime t, const Pose& w, std::array<Eigen::Vector3d, kMaxJoints>& pos,
                            std::array<Eigen::Matrix3d, kMaxJoints>& rot) {
    joints_in(space_in_world(r, base->second, track_time(r, t)), with_valid_positions(w), hand == XR_HAND_LEFT_EXT, pos,
              rot);
  };
  std::array<Eigen::Vector3d, kMaxJoints> pos;
  std::array<Eigen::Matrix3d, kMaxJoints> rot;
  joints_in_base(info->time, world, pos, rot);
  out->isActive = XR_TRUE;
  fill_locations(pos, rot, world, count, out->jointLocations);
  if (vel) {
    // Central differences over +-2 ms of the joints relative to the base space.
    constexpr XrTime h = 2'000'000;
    std::array<Eigen::Vector3d, kMaxJoints> p0, p1;
    std::array<Eigen::Matrix3d, kMaxJoints> r0, r1;
    // The later time saturates near INT64_MAX (apps may ask any time).
    const XrTime t0 = info->time - h;
    const XrTime t1 = info->time > std::numeric_limits<XrTime>::max() - h ? info->time : info->time + h;
    const Pose w0 = scaled_about_wrist(replayed_hand(series, r.cfg, r.clock, t0, now), hand_scale),
               w1 = scaled_about_wrist(replayed_hand(series, r.cfg, r.clock, t1, now), hand_scale);
    joints_in_base(t0, w0, p0, r0);
    joints_in_base(t1, w1, p1, r1);
    for (int j = 0; j < static_cast<int>(count); ++j) {
      XrHandJointVelocityEXT& v = vel->jointVelocities[j];
      v.velocityFlags = 0;
      if (!set_joint_tracked(w0, j) || !set_joint_tracked(w1, j)) continue;
      const double dt = 2.0 * static_cast<double>(h) * 1e-9;
      v.linearVelocity = xr::to_xr(Eigen::Vector3d((p1[j] - p0[j]) / dt));
      const Eigen::AngleAxisd d(Eigen::Matrix3d(r1[j] * r0[j].transpose()));
      v.angularVelocity = xr::to_xr(Eigen::Vector3d(d.axis() * (d.angle() / dt)));
      v.velocityFlags = XR_SPACE_VELOCITY_LINEAR_VALID_BIT | XR_SPACE_VELOCITY_ANGULAR_VALID_BIT;
    }
  }
  inject_joint_faults(r.cfg.faults, info->time, hand == XR_HAND_LEFT_EXT ? 0 : 1, out->jointLocations,
                      vel ? vel->jointVelocities : nullptr);
  if (capsules) fill_capsules(out->jointLocations, *capsules);
  if (aim) fill_aim(out->jointLocations, *aim);
  return XR_SUCCESS;
}

// XR_FB_hand_tracking_mesh: the skeleton only (no vertices, no indices): the joints'
// bind poses from the hand's first fully tracked row, its wrist at the origin, the frames
// and radii the tracker answers with, the parents of the joint tree.
XRAPI_ATTR XrResult XRAPI_CALL GetHandMeshFB(XrHandTrackerEXT tracker, XrHandTrackingMeshFB* mesh) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  const auto tr = r.trackers.find(id_of(tracker));
  if (tr == r.trackers.end()) return XR_ERROR_HANDLE_INVALID;
  if (!mesh || mesh->type != XR_TYPE_HAND_TRACKING_MESH_FB) return XR_ERROR_VALIDATION_FAILURE;
  mesh->jointCountOutput = kJointCount;
  mesh->vertexCountOutput = 0;
  mesh->indexCountOutput = 0;
  if (mesh->jointCapacityInput == 0) return XR_SUCCESS;
  if (mesh->jointCapacityInput < static_cast<uint32_t>(kJointCount)) return XR_ERROR_SIZE_INSUFFICIENT;
  if (!mesh->jointBindPoses || !mesh->jointRadii || !mesh->jointParents) return XR_ERROR_VALIDATION_FAILURE;
  const bool left = tr->second.hand == XR_HAND_LEFT_EXT;
  const HandSeries& series = r.hands[left ? 0 : 1];
  Pose bind = untracked_pose();
  for (const Pose& p : series.pos)
    if (p.allFinite()) {
      bind = p;
      break;
    }
  bind = with_valid_positions(bind);
  if (!bind.allFinite()) bind.setZero();
  const Eigen::RowVector3d wrist = bind.row(idx(Joint::Wrist));
  for (int j = 0; j < kJointCount; ++j) bind.row(j) -= wrist;
  const auto frames = joint_frames(bind, left);
  for (int j = 0; j < kJointCount; ++j) {
    mesh->jointBindPoses[j].position = xr::to_xr(Eigen::Vector3d(bind.row(j).transpose()));
    mesh->jointBindPoses[j].orientation = xr::to_xr(Eigen::Quaterniond(frames[static_cast<size_t>(j)]).normalized());
    mesh->jointRadii[j] = joint_radius(j);
    const int parent = kXrParent[static_cast<size_t>(j)];
    mesh->jointParents[j] = parent < 0 ? XR_HAND_JOINT_MAX_ENUM_EXT : static_cast<XrHandJointEXT>(parent);
  }
  return XR_SUCCESS;
}

// ---------------------------------------------------------------- actions

// The action system, enough for XR_EXT_hand_interaction's profile: paths, action sets and
// actions, suggested bindings (that profile's inputs; the simple controller's accepted and
// never current), attaching, syncing (which makes the hand interaction profile current
// for both hands once its bindings are attached, announced by an event), and action
// spaces, located from the tracked hand (space_world_pose). Action states: poses only
// (active while their space could be located); boolean, float and vector states are
// inactive, haptics do nothing.

XRAPI_ATTR XrResult XRAPI_CALL StringToPath(XrInstance instance, const char* pathString, XrPath* path) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!pathString || !path) return XR_ERROR_VALIDATION_FAILURE;
  const std::string_view str(pathString);
  if (!well_formed_path(str)) return XR_ERROR_PATH_FORMAT_INVALID;
  for (size_t i = 0; i < r.paths.size(); ++i)
    if (r.paths[i] == str) {
      *path = i + 1;
      return XR_SUCCESS;
    }
  if (r.paths.size() >= 65536) return XR_ERROR_PATH_COUNT_EXCEEDED;
  r.paths.emplace_back(str);
  *path = r.paths.size();
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL PathToString(XrInstance instance, XrPath path, uint32_t capacity, uint32_t* count,
                                            char* buffer) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  const std::string_view str = path_string(r, path);
  if (str.empty()) return XR_ERROR_PATH_INVALID;
  return two_call(capacity, count, buffer, std::string(str).c_str(), static_cast<uint32_t>(str.size() + 1));
}

XRAPI_ATTR XrResult XRAPI_CALL CreateActionSet(XrInstance instance, const XrActionSetCreateInfo* info,
                                               XrActionSet* actionSet) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!info || !actionSet || info->type != XR_TYPE_ACTION_SET_CREATE_INFO) return XR_ERROR_VALIDATION_FAILURE;
  if (!well_formed_path(std::string("/") + info->actionSetName)) return XR_ERROR_PATH_FORMAT_INVALID;
  if (info->localizedActionSetName[0] == '\0') return XR_ERROR_LOCALIZED_NAME_INVALID;
  const uint64_t id = r.next_handle++;
  r.action_sets[id] = false;
  *actionSet = handle_of<XrActionSet>(id);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroyActionSet(XrActionSet actionSet) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!r.action_sets.erase(id_of(actionSet))) return XR_ERROR_HANDLE_INVALID;
  std::erase_if(r.actions, [&](const auto& kv) { return kv.second.set == id_of(actionSet); });
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateAction(XrActionSet actionSet, const XrActionCreateInfo* info, XrAction* action) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  const auto set = r.action_sets.find(id_of(actionSet));
  if (set == r.action_sets.end()) return XR_ERROR_HANDLE_INVALID;
  if (!info || !action || info->type != XR_TYPE_ACTION_CREATE_INFO) return XR_ERROR_VALIDATION_FAILURE;
  if (set->second) return XR_ERROR_ACTIONSETS_ALREADY_ATTACHED;
  if (!well_formed_path(std::string("/") + info->actionName)) return XR_ERROR_PATH_FORMAT_INVALID;
  if (info->localizedActionName[0] == '\0') return XR_ERROR_LOCALIZED_NAME_INVALID;
  switch (info->actionType) {
    case XR_ACTION_TYPE_BOOLEAN_INPUT: case XR_ACTION_TYPE_FLOAT_INPUT: case XR_ACTION_TYPE_VECTOR2F_INPUT:
    case XR_ACTION_TYPE_POSE_INPUT: case XR_ACTION_TYPE_VIBRATION_OUTPUT: break;
    default: return XR_ERROR_VALIDATION_FAILURE;
  }
  if (info->countSubactionPaths > 0 && !info->subactionPaths) return XR_ERROR_VALIDATION_FAILURE;
  ActionData data;
  data.set = set->first;
  data.type = info->actionType;
  for (uint32_t i = 0; i < info->countSubactionPaths; ++i) {
    const XrPath p = info->subactionPaths[i];
    if (path_string(r, p).empty()) return XR_ERROR_PATH_INVALID;
    if (!user_hand(path_string(r, p))) return XR_ERROR_PATH_UNSUPPORTED;
    if (std::find(data.subactions.begin(), data.subactions.end(), p) != data.subactions.end())
      return XR_ERROR_PATH_UNSUPPORTED;  // "duplicate": the spec's valid usage
    data.subactions.push_back(p);
  }
  const uint64_t id = r.next_handle++;
  r.actions[id] = std::move(data);
  *action = handle_of<XrAction>(id);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroyAction(XrAction action) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  return r.actions.erase(id_of(action)) ? XR_SUCCESS : XR_ERROR_HANDLE_INVALID;
}

XRAPI_ATTR XrResult XRAPI_CALL SuggestInteractionProfileBindings(
    XrInstance instance, const XrInteractionProfileSuggestedBinding* suggested) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  if (!suggested || suggested->type != XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING ||
      suggested->countSuggestedBindings == 0 || !suggested->suggestedBindings)
    return XR_ERROR_VALIDATION_FAILURE;
  const std::string_view profile = path_string(r, suggested->interactionProfile);
  if (profile.empty()) return XR_ERROR_PATH_INVALID;
  const bool hand_profile = r.ext_hand_interaction && profile == kHandInteractionProfile;
  if (!hand_profile && profile != kSimpleControllerProfile) return XR_ERROR_PATH_UNSUPPORTED;
  std::map<uint64_t, std::vector<HandBinding>> bound;
  for (uint32_t i = 0; i < suggested->countSuggestedBindings; ++i) {
    const XrActionSuggestedBinding& b = suggested->suggestedBindings[i];
    const auto action = r.actions.find(id_of(b.action));
    if (action == r.actions.end()) return XR_ERROR_HANDLE_INVALID;
    if (r.action_sets[action->second.set]) return XR_ERROR_ACTIONSETS_ALREADY_ATTACHED;
    const std::string_view path = path_string(r, b.binding);
    if (path.empty()) return XR_ERROR_PATH_INVALID;
    if (!hand_profile) continue;  // the simple controller's: accepted, never current
    const auto hb = hand_binding(path);
    if (!hb || (hb->input == HandInput::PalmPose && !r.ext_palm_pose)) return XR_ERROR_PATH_UNSUPPORTED;
    if (is_pose(hb->input) != (action->second.type == XR_ACTION_TYPE_POSE_INPUT)) return XR_ERROR_PATH_UNSUPPORTED;
    bound[action->first].push_back(*hb);
  }
  if (!hand_profile) return XR_SUCCESS;
  // Each suggestion replaces the profile's earlier one.
  for (auto& [id, a] : r.actions) {
    const auto it = bound.find(id);
    a.hand_bindings = it == bound.end() ? std::vector<HandBinding>{} : it->second;
  }
  r.hand_profile_suggested = true;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL AttachSessionActionSets(XrSession session, const XrSessionActionSetsAttachInfo* info) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO || info->countActionSets == 0 || !info->actionSets)
    return XR_ERROR_VALIDATION_FAILURE;
  if (s->attached) return XR_ERROR_ACTIONSETS_ALREADY_ATTACHED;
  for (uint32_t i = 0; i < info->countActionSets; ++i)
    if (!r.action_sets.count(id_of(info->actionSets[i]))) return XR_ERROR_HANDLE_INVALID;
  for (uint32_t i = 0; i < info->countActionSets; ++i) r.action_sets[id_of(info->actionSets[i])] = true;
  s->attached = true;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL GetCurrentInteractionProfile(XrSession session, XrPath topLevelUserPath,
                                                            XrInteractionProfileState* state) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!state || state->type != XR_TYPE_INTERACTION_PROFILE_STATE) return XR_ERROR_VALIDATION_FAILURE;
  if (!s->attached) return XR_ERROR_ACTIONSET_NOT_ATTACHED;
  const std::string_view user = path_string(r, topLevelUserPath);
  if (user.empty()) return XR_ERROR_PATH_INVALID;
  const auto hand = user_hand(user);
  if (!hand) return XR_ERROR_PATH_UNSUPPORTED;
  state->interactionProfile = s->profile[static_cast<size_t>(*hand)];
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL SyncActions(XrSession session, const XrActionsSyncInfo* info) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_ACTIONS_SYNC_INFO || (info->countActiveActionSets > 0 && !info->activeActionSets))
    return XR_ERROR_VALIDATION_FAILURE;
  if (!s->attached) return XR_ERROR_ACTIONSET_NOT_ATTACHED;
  for (uint32_t i = 0; i < info->countActiveActionSets; ++i) {
    const auto set = r.action_sets.find(id_of(info->activeActionSets[i].actionSet));
    if (set == r.action_sets.end()) return XR_ERROR_HANDLE_INVALID;
    if (!set->second) return XR_ERROR_ACTIONSET_NOT_ATTACHED;
  }
  if (s->state != XR_SESSION_STATE_FOCUSED) return XR_SESSION_NOT_FOCUSED;
  if (!r.hand_profile_suggested || s->profile[0] != XR_NULL_PATH) return XR_SUCCESS;
  for (size_t i = 0; i < r.paths.size(); ++i)
    if (r.paths[i] == kHandInteractionProfile) s->profile = {i + 1, i + 1};
  XrEventDataBuffer buf{};
  auto* ev = reinterpret_cast<XrEventDataInteractionProfileChanged*>(&buf);
  ev->type = XR_TYPE_EVENT_DATA_INTERACTION_PROFILE_CHANGED;
  ev->next = nullptr;
  ev->session = session;
  r.events.push_back(buf);
  return XR_SUCCESS;
}

// Whether an action was created with this subaction path (none given: any).
bool allows_subaction(const ActionData& a, XrPath subaction) {
  return subaction == XR_NULL_PATH || std::find(a.subactions.begin(), a.subactions.end(), subaction) != a.subactions.end();
}

// The action of an action-state query, checked against its subaction path.
XrResult checked_action(Runtime& r, XrSession session, const XrActionStateGetInfo* info, XrActionType type,
                        const ActionData*& action) {
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_ACTION_STATE_GET_INFO) return XR_ERROR_VALIDATION_FAILURE;
  const auto it = r.actions.find(id_of(info->action));
  if (it == r.actions.end()) return XR_ERROR_HANDLE_INVALID;
  if (!r.action_sets[it->second.set] || !s->attached) return XR_ERROR_ACTIONSET_NOT_ATTACHED;
  if (it->second.type != type) return XR_ERROR_ACTION_TYPE_MISMATCH;
  if (!allows_subaction(it->second, info->subactionPath)) return XR_ERROR_PATH_UNSUPPORTED;
  action = &it->second;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL GetActionStatePose(XrSession session, const XrActionStateGetInfo* info,
                                                  XrActionStatePose* state) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  const ActionData* action = nullptr;
  const XrResult res = checked_action(r, session, info, XR_ACTION_TYPE_POSE_INPUT, action);
  if (XR_FAILED(res)) return res;
  if (!state || state->type != XR_TYPE_ACTION_STATE_POSE) return XR_ERROR_VALIDATION_FAILURE;
  SpaceData probe{session, XR_REFERENCE_SPACE_TYPE_VIEW, Rigid::Identity(), id_of(info->action), info->subactionPath};
  state->isActive = action_space_input(r, probe) ? XR_TRUE : XR_FALSE;
  return XR_SUCCESS;
}

template <class State>
XrResult inactive_state(XrSession session, const XrActionStateGetInfo* info, XrActionType type, XrStructureType st,
                        State* state) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  const ActionData* action = nullptr;
  const XrResult res = checked_action(r, session, info, type, action);
  if (XR_FAILED(res)) return res;
  if (!state || state->type != st) return XR_ERROR_VALIDATION_FAILURE;
  void* next = state->next;
  *state = State{};
  state->type = st;
  state->next = next;
  return XR_SUCCESS;
}
XRAPI_ATTR XrResult XRAPI_CALL GetActionStateBoolean(XrSession session, const XrActionStateGetInfo* info,
                                                     XrActionStateBoolean* state) {
  return inactive_state(session, info, XR_ACTION_TYPE_BOOLEAN_INPUT, XR_TYPE_ACTION_STATE_BOOLEAN, state);
}
XRAPI_ATTR XrResult XRAPI_CALL GetActionStateFloat(XrSession session, const XrActionStateGetInfo* info,
                                                   XrActionStateFloat* state) {
  return inactive_state(session, info, XR_ACTION_TYPE_FLOAT_INPUT, XR_TYPE_ACTION_STATE_FLOAT, state);
}
XRAPI_ATTR XrResult XRAPI_CALL GetActionStateVector2f(XrSession session, const XrActionStateGetInfo* info,
                                                      XrActionStateVector2f* state) {
  return inactive_state(session, info, XR_ACTION_TYPE_VECTOR2F_INPUT, XR_TYPE_ACTION_STATE_VECTOR2F, state);
}

XRAPI_ATTR XrResult XRAPI_CALL ApplyHapticFeedback(XrSession session, const XrHapticActionInfo* info,
                                                   const XrHapticBaseHeader*) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!find_session(r, session)) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_HAPTIC_ACTION_INFO) return XR_ERROR_VALIDATION_FAILURE;
  return r.actions.count(id_of(info->action)) ? XR_SUCCESS : XR_ERROR_HANDLE_INVALID;
}
XRAPI_ATTR XrResult XRAPI_CALL StopHapticFeedback(XrSession session, const XrHapticActionInfo* info) {
  return ApplyHapticFeedback(session, info, nullptr);
}

XRAPI_ATTR XrResult XRAPI_CALL EnumerateBoundSourcesForAction(XrSession session,
                                                              const XrBoundSourcesForActionEnumerateInfo* info,
                                                              uint32_t capacity, uint32_t* count, XrPath* sources) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  SessionData* s = find_session(r, session);
  if (!s) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_BOUND_SOURCES_FOR_ACTION_ENUMERATE_INFO) return XR_ERROR_VALIDATION_FAILURE;
  const auto it = r.actions.find(id_of(info->action));
  if (it == r.actions.end()) return XR_ERROR_HANDLE_INVALID;
  if (!s->attached) return XR_ERROR_ACTIONSET_NOT_ATTACHED;
  // Sources are the bound input paths; as paths the app did not make they are not listed
  // here (no path is created behind the app's back): none.
  return two_call<XrPath>(capacity, count, sources, nullptr, 0);
}

XRAPI_ATTR XrResult XRAPI_CALL GetInputSourceLocalizedName(XrSession session,
                                                           const XrInputSourceLocalizedNameGetInfo* info,
                                                           uint32_t, uint32_t*, char*) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!find_session(r, session)) return XR_ERROR_HANDLE_INVALID;
  if (!info || info->type != XR_TYPE_INPUT_SOURCE_LOCALIZED_NAME_GET_INFO) return XR_ERROR_VALIDATION_FAILURE;
  return XR_ERROR_PATH_INVALID;  // no source is ever enumerated (above)
}

XRAPI_ATTR XrResult XRAPI_CALL CreateActionSpace(XrSession session, const XrActionSpaceCreateInfo* info,
                                                 XrSpace* space) {
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!find_session(r, session)) return XR_ERROR_HANDLE_INVALID;
  if (!info || !space || info->type != XR_TYPE_ACTION_SPACE_CREATE_INFO) return XR_ERROR_VALIDATION_FAILURE;
  const auto it = r.actions.find(id_of(info->action));
  if (it == r.actions.end()) return XR_ERROR_HANDLE_INVALID;
  if (it->second.type != XR_ACTION_TYPE_POSE_INPUT) return XR_ERROR_ACTION_TYPE_MISMATCH;
  if (!allows_subaction(it->second, info->subactionPath)) return XR_ERROR_PATH_UNSUPPORTED;
  if (!valid_pose(info->poseInActionSpace)) return XR_ERROR_POSE_INVALID;
  const XrSpace s = handle_of<XrSpace>(r.next_handle++);
  r.spaces[id_of(s)] = SpaceData{session, XR_REFERENCE_SPACE_TYPE_VIEW, xr::to_rigid(info->poseInActionSpace),
                                 it->first, info->subactionPath};
  *space = s;
  return XR_SUCCESS;
}

// ---------------------------------------------------------------- dispatch

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char* name, PFN_xrVoidFunction* fn);

struct Entry {
  std::string_view name;
  PFN_xrVoidFunction fn;
  int extension;  // 0 core, 1 hand tracking, 2 timespec, 3 hand mesh (XR_FB_hand_tracking_mesh)
};
#define HS_ENTRY(name, ext) {"xr" #name, reinterpret_cast<PFN_xrVoidFunction>(&name), ext}
const Entry kEntries[] = {
    HS_ENTRY(GetInstanceProcAddr, 0), HS_ENTRY(EnumerateInstanceExtensionProperties, 0),
    HS_ENTRY(EnumerateApiLayerProperties, 0), HS_ENTRY(CreateInstance, 0), HS_ENTRY(DestroyInstance, 0),
    HS_ENTRY(GetInstanceProperties, 0), HS_ENTRY(ResultToString, 0), HS_ENTRY(StructureTypeToString, 0),
    HS_ENTRY(PollEvent, 0), HS_ENTRY(GetSystem, 0), HS_ENTRY(GetSystemProperties, 0),
    HS_ENTRY(EnumerateViewConfigurations, 0), HS_ENTRY(CreateSession, 0), HS_ENTRY(DestroySession, 0),
    HS_ENTRY(BeginSession, 0), HS_ENTRY(EndSession, 0), HS_ENTRY(RequestExitSession, 0), HS_ENTRY(WaitFrame, 0),
    HS_ENTRY(BeginFrame, 0), HS_ENTRY(EndFrame, 0), HS_ENTRY(EnumerateReferenceSpaces, 0),
    HS_ENTRY(CreateReferenceSpace, 0), HS_ENTRY(DestroySpace, 0), HS_ENTRY(LocateSpace, 0),
    HS_ENTRY(CreateHandTrackerEXT, 1), HS_ENTRY(DestroyHandTrackerEXT, 1), HS_ENTRY(LocateHandJointsEXT, 1),
    HS_ENTRY(ConvertTimespecTimeToTimeKHR, 2), HS_ENTRY(ConvertTimeToTimespecTimeKHR, 2), HS_ENTRY(GetHandMeshFB, 3),
    HS_ENTRY(StringToPath, 0), HS_ENTRY(PathToString, 0), HS_ENTRY(CreateActionSet, 0), HS_ENTRY(DestroyActionSet, 0),
    HS_ENTRY(CreateAction, 0), HS_ENTRY(DestroyAction, 0), HS_ENTRY(SuggestInteractionProfileBindings, 0),
    HS_ENTRY(AttachSessionActionSets, 0), HS_ENTRY(GetCurrentInteractionProfile, 0), HS_ENTRY(SyncActions, 0),
    HS_ENTRY(GetActionStateBoolean, 0), HS_ENTRY(GetActionStateFloat, 0), HS_ENTRY(GetActionStateVector2f, 0),
    HS_ENTRY(GetActionStatePose, 0), HS_ENTRY(ApplyHapticFeedback, 0), HS_ENTRY(StopHapticFeedback, 0),
    HS_ENTRY(EnumerateBoundSourcesForAction, 0), HS_ENTRY(GetInputSourceLocalizedName, 0),
    HS_ENTRY(CreateActionSpace, 0),
};
#undef HS_ENTRY

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char* name, PFN_xrVoidFunction* fn) {
  if (!fn) return XR_ERROR_VALIDATION_FAILURE;
  *fn = nullptr;
  if (!name) return XR_ERROR_VALIDATION_FAILURE;
  const std::string_view n(name);
  if (instance == XR_NULL_HANDLE) {
    // Before an instance exists only these may be asked for.
    if (n == "xrEnumerateInstanceExtensionProperties" || n == "xrEnumerateApiLayerProperties" ||
        n == "xrCreateInstance" || n == "xrGetInstanceProcAddr") {
      for (const Entry& e : kEntries)
        if (e.name == n) *fn = e.fn;
      return XR_SUCCESS;
    }
    return XR_ERROR_HANDLE_INVALID;
  }
  Runtime& r = rt();
  std::lock_guard lock(r.mu);
  if (!instance_ok(r, instance)) return XR_ERROR_HANDLE_INVALID;
  for (const Entry& e : kEntries) {
    if (e.name != n) continue;
    if ((e.extension == 1 && !r.ext_hand) || (e.extension == 2 && !r.ext_timespec) || (e.extension == 3 && !r.ext_mesh))
      break;
    *fn = e.fn;
    return XR_SUCCESS;
  }
  return XR_ERROR_FUNCTION_UNSUPPORTED;
}

}  // namespace
}  // namespace hs::shim

extern "C" __attribute__((visibility("default"))) XrResult XRAPI_CALL
xrNegotiateLoaderRuntimeInterface(const XrNegotiateLoaderInfo* loaderInfo, XrNegotiateRuntimeRequest* request) {
  if (!loaderInfo || !request || loaderInfo->structType != XR_LOADER_INTERFACE_STRUCT_LOADER_INFO ||
      loaderInfo->structVersion != XR_LOADER_INFO_STRUCT_VERSION || loaderInfo->structSize != sizeof(XrNegotiateLoaderInfo) ||
      request->structType != XR_LOADER_INTERFACE_STRUCT_RUNTIME_REQUEST ||
      request->structVersion != XR_RUNTIME_INFO_STRUCT_VERSION || request->structSize != sizeof(XrNegotiateRuntimeRequest))
    return XR_ERROR_INITIALIZATION_FAILED;
  if (loaderInfo->minInterfaceVersion > XR_CURRENT_LOADER_RUNTIME_VERSION ||
      loaderInfo->maxInterfaceVersion < XR_CURRENT_LOADER_RUNTIME_VERSION)
    return XR_ERROR_INITIALIZATION_FAILED;
  request->runtimeInterfaceVersion = XR_CURRENT_LOADER_RUNTIME_VERSION;
  request->runtimeApiVersion = XR_CURRENT_API_VERSION;
  request->getInstanceProcAddr = &hs::shim::GetInstanceProcAddr;
  return XR_SUCCESS;
}
