// XR_APILAYER_NOVENDOR_handsteady: denoises (or predicts) XR_EXT_hand_tracking joints.
//
// Per hand tracker the layer creates a LOCAL reference space of its own (world-fixed,
// so head motion never enters the filter), locates the runtime's joints in it and feeds
// the engine (hs::PoseFilter) with new sample times only; each app call is answered by
// estimating at the asked time in that space and converting into the app's base space
// with xrLocateSpace. Joints the runtime does not report as tracked, flags, radii and
// every next chain are the runtime's. See docs/OPENXR_LAYER.md.
//
// Every entry point is noexcept and catches everything: on an internal failure the
// tracker falls back to passing the runtime's data through, and the layer logs once.
#define XR_USE_TIMESPEC
#include <time.h>

#include <openxr/openxr.h>
#include <openxr/openxr_platform.h>

#include "handsteady/source_revision.hpp"
#include "handsteady/track.hpp"
#include "handsteady_xr/hand_tracking_data_source.hpp"
#include "handsteady_xr/loader_negotiation.hpp"
#include "handsteady_xr/raw_joints_ext.h"
#include "handsteady_xr/ultraleap_forearm.hpp"
#include "handsteady_xr/xr_math.hpp"
#include "hand_attachments.hpp"
#include "hand_tuning.hpp"
#include "joint_rewrite.hpp"
#include "layer_config.hpp"
#include "runtime_semantics.hpp"
#include "tracker_filter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <dlfcn.h>
#include <unistd.h>

namespace hs::layer {
namespace {

constexpr const char* kLayerName = "XR_APILAYER_NOVENDOR_handsteady";
// Not in older SDK headers (the extension defines only paths, no structures).
constexpr const char* kHandInteractionExtension = "XR_EXT_hand_interaction";
// The hand interaction profile's poses (`/input/<name>/pose`) and what each moves with: the
// extension's four, XR_EXT_palm_pose's palm and OpenXR 1.1's grip surface (both at the palm).
struct PoseInput {
  const char* name;
  HandPose pose;
};
constexpr std::array<PoseInput, 6> kPoseInputs = {{{"grip", HandPose::Grip},
                                                    {"aim", HandPose::Aim},
                                                    {"pinch_ext", HandPose::Pinch},
                                                    {"poke_ext", HandPose::Poke},
                                                    {"palm_ext", HandPose::Grip},
                                                    {"grip_surface", HandPose::Grip}}};
// The most joints a joint set the layer filters has (Ultraleap's forearm set: the hand's 26 and the elbow).
constexpr uint32_t kMaxJoints = XR_HAND_FOREARM_JOINT_COUNT_ULTRALEAP;
#ifndef HS_LAYER_ISA
#define HS_LAYER_ISA "baseline"  // the compiler's default instruction set
#endif

// ---------------------------------------------------------------- logging

std::atomic<int> g_log_level{static_cast<int>(LogLevel::Warn)};

void log(LogLevel level, std::string_view msg) noexcept {
  if (static_cast<int>(level) > g_log_level.load(std::memory_order_relaxed)) return;
  static constexpr const char* kNames[] = {"off", "error", "warn", "info", "debug"};
  std::fprintf(stderr, "[%s] %s: %.*s\n", kLayerName, kNames[static_cast<int>(level)], static_cast<int>(msg.size()),
               msg.data());
}

// Logs at most once per flag (per process: the layer library is never unloaded).
void log_once(std::atomic<bool>& flag, LogLevel level, std::string_view msg) noexcept {
  if (!flag.exchange(true)) log(level, msg);
}

std::atomic<bool> g_logged_internal{false}, g_logged_world_space{false}, g_logged_locate_space{false},
    g_logged_world_locate{false}, g_logged_record{false}, g_logged_engine{false}, g_logged_space_garbage{false},
    g_logged_latest{false}, g_logged_time{false}, g_logged_repaired{false}, g_logged_garbage{false},
    g_logged_recentre{false}, g_logged_untracked{false}, g_logged_controller{false},
    g_logged_joint_set{false}, g_logged_fb_garbage{false}, g_logged_scale{false},
    g_logged_fit_base{false}, g_logged_hand_pose{false}, g_logged_hand_pose_garbage{false},
    g_logged_hand_pose_ambiguous{false};

// ---------------------------------------------------------------- state

struct InstanceData {
  XrInstance instance = XR_NULL_HANDLE;
  PFN_xrGetInstanceProcAddr GetInstanceProcAddr = nullptr;
  PFN_xrDestroyInstance DestroyInstance = nullptr;
  PFN_xrCreateSession CreateSession = nullptr;
  PFN_xrDestroySession DestroySession = nullptr;
  PFN_xrCreateReferenceSpace CreateReferenceSpace = nullptr;
  PFN_xrDestroySpace DestroySpace = nullptr;
  PFN_xrLocateSpace LocateSpace = nullptr;
  PFN_xrCreateHandTrackerEXT CreateHandTrackerEXT = nullptr;
  PFN_xrDestroyHandTrackerEXT DestroyHandTrackerEXT = nullptr;
  PFN_xrLocateHandJointsEXT LocateHandJointsEXT = nullptr;
  PFN_xrPollEvent PollEvent = nullptr;
  // XR_EXT_hand_interaction: the action functions the layer hooks or calls.
  PFN_xrSuggestInteractionProfileBindings SuggestInteractionProfileBindings = nullptr;
  PFN_xrCreateActionSpace CreateActionSpace = nullptr;
  PFN_xrDestroyAction DestroyAction = nullptr;
  PFN_xrGetCurrentInteractionProfile GetCurrentInteractionProfile = nullptr;
  // The runtime's clock (XR_KHR_convert_timespec_time, enabled by the layer when the
  // runtime has it): dates samples of runtimes that answer their latest pose.
  PFN_xrConvertTimespecTimeToTimeKHR ConvertTimespecTimeToTimeKHR = nullptr;
  bool hand_tracking = false;  // the app enabled XR_EXT_hand_tracking
  bool raw_joints = false;     // the app enabled our XR_NOVENDOR_handsteady_raw_joints
  bool app_timespec = false;   // the app enabled XR_KHR_convert_timespec_time itself
  bool data_source = false;    // the app enabled XR_EXT_hand_tracking_data_source
  bool fb_capsules = false;    // the app enabled XR_FB_hand_tracking_capsules
  bool fb_aim = false;         // the app enabled XR_FB_hand_tracking_aim
  bool fb_mesh = false;        // the app enabled XR_FB_hand_tracking_mesh (its hand scale override)
  // The app enabled XR_EXT_hand_interaction (and the paths below could be made): its
  // profile's poses, located as action spaces, move with the joints.
  bool hand_interaction = false;
  XrPath hand_profile = XR_NULL_PATH;          // /interaction_profiles/ext/hand_interaction_ext
  std::array<XrPath, 2> user_hand{};           // /user/hand/left, /user/hand/right
  // The profile's pose inputs per hand: [hand][kPoseInputs' index].
  std::array<std::array<XrPath, 6>, 2> pose_input{};
  LayerConfig config;
  std::unique_ptr<HandTuning> tuning;  // per-hand smoothing and horizon, live

  // The runtime's now, or 0 when it has no clock the layer can read.
  XrTime now() const noexcept {
    if (!ConvertTimespecTimeToTimeKHR) return 0;
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    XrTime t = 0;
    return XR_SUCCEEDED(ConvertTimespecTimeToTimeKHR(instance, &ts, &t)) ? t : 0;
  }
};

// What an app saw, raw (world space, at sample times) and filtered (at asked times).
struct Recording {
  std::mutex mu;
  HandSeries raw, filtered;
};

struct TrackerData {
  std::shared_ptr<const InstanceData> inst;
  XrHandTrackerEXT handle = XR_NULL_HANDLE;
  XrSession session = XR_NULL_HANDLE;
  XrHandEXT hand = XR_HAND_RIGHT_EXT;
  uint32_t joint_count = XR_HAND_JOINT_COUNT_EXT;  // its joint set's: the hand's 26, then any more (the elbow)
  XrSpace world = XR_NULL_HANDLE;  // the layer's world-fixed space (LOCAL)
  // One state per joint motion range (XR_EXT_hand_joints_motion_range).
  std::array<std::unique_ptr<TrackerFilter>, 2> filters;
  // How the runtime answers times, and the last world sample per motion range (repeats of
  // a runtime that holds its newest pose are not new samples). Guarded by sample_mu.
  std::mutex sample_mu;
  SemanticsProbe probe;
  std::array<Pose, 2> last_sample;
  std::atomic<TimeSemantics> semantics{TimeSemantics::History};  // probe's verdict, read without the lock
  std::atomic<XrTime> last_stamp{0};  // date of the newest sample fed (0: none yet)
  std::atomic<bool> passthrough{false};
  // Created accepting a controller as the hand's source (XR_EXT_hand_tracking_data_source):
  // each answer's source is asked for, and a controller's hand passes through.
  bool controller_source = false;
  // The hand scale the app last asked the runtime for (XR_FB_hand_tracking_mesh's
  // override; 0: the runtime's own): another scale is another hand's shape.
  std::atomic<float> scale_asked{0.0f};
  std::unique_ptr<Recording> recording;
  int serial = 0;
  // The last answer handed to the app, where it enabled XR_EXT_hand_interaction: the
  // runtime's joints and the layer's, for the poses derived from the hand at that time and
  // base space. Guarded by answer_mu (copies only, never held across the engine).
  std::mutex answer_mu;
  XrTime answer_time = 0;
  XrSpace answer_base = XR_NULL_HANDLE;
  bool answer_plain = false;  // asked with no next chain in the info and none in the answer but what the layer moves
  JointsBefore answer_before;
  std::array<XrHandJointLocationEXT, kJointCount> answer_after{};
};

// An action space the app created for an action bound to a pose of the hand interaction
// profile, or one it may be bound to later (bindings are suggested per profile, any time
// before the session attaches its action sets).
struct ActionSpaceData {
  std::shared_ptr<const InstanceData> inst;
  XrSession session = XR_NULL_HANDLE;
  XrAction action = XR_NULL_HANDLE;
  int hand = -1;  // its subaction path's hand (0 left, 1 right), -1: none given
  XrPosef pose_in_action{};
};

struct Registry {
  std::shared_mutex mu;
  std::unordered_map<XrInstance, std::shared_ptr<InstanceData>> instances;
  std::unordered_map<XrSession, std::shared_ptr<InstanceData>> sessions;
  std::unordered_map<XrHandTrackerEXT, std::shared_ptr<TrackerData>> trackers;
  // XR_EXT_hand_interaction: the pose each action is bound to per hand in its profile, and
  // the action spaces of actions that may be.
  std::unordered_map<XrAction, std::array<HandPose, 2>> hand_actions;
  std::unordered_map<XrSpace, ActionSpaceData> action_spaces;
  int tracker_serial = 0;
};
// Never destroyed: the loader never unloads layers, and app threads may still call in at exit.
Registry& reg() {
  static Registry* r = new Registry;
  return *r;
}

template <class Map, class Key>
auto find_shared(Map& map, Key key) -> typename Map::mapped_type {
  std::shared_lock lock(reg().mu);
  auto it = map.find(key);
  return it == map.end() ? nullptr : it->second;
}

// The instance of a hand tracker or session the registry does not hold (its state could
// not be made: it passes through): the loader allows one live instance per process, the
// one with hand tracking. nullptr when there is none.
// The functions the layer's hand hooks call down to (hooked only when all are there).
bool has_hand_functions(const InstanceData& d) noexcept {
  return d.hand_tracking && d.CreateHandTrackerEXT && d.DestroyHandTrackerEXT && d.LocateHandJointsEXT &&
         d.CreateSession && d.DestroySession;
}

std::shared_ptr<const InstanceData> hand_instance() noexcept {
  std::shared_lock lock(reg().mu);
  for (const auto& [handle, d] : reg().instances)
    if (has_hand_functions(*d)) return d;
  return nullptr;
}

// ---------------------------------------------------------------- recording

void write_recording(const TrackerData& t) noexcept {
  if (!t.recording) return;
  try {
    std::lock_guard lock(t.recording->mu);
    const std::filesystem::path dir(t.inst->config.record_dir);
    std::filesystem::create_directories(dir);
    const Hand hand = t.hand == XR_HAND_LEFT_EXT ? Hand::Left : Hand::Right;
    const std::string stem = fmt::format("handsteady_{}_{}_{}", ::getpid(), t.serial, hand_name(hand));
    for (const auto& [series, kind] : {std::pair{&t.recording->raw, "raw"}, std::pair{&t.recording->filtered, "filtered"}}) {
      Track track;
      track.set_meta("source", fmt::format("{} {} (world-fixed LOCAL space of the layer)", kLayerName, kind));
      track.set_meta("mode", mode_name(t.inst->config.mode));
      track.set_meta("filter", engine_name(t.inst->config));
      add_hand_series(track, hand, *series);
      write_track_csv(track, dir / (stem + "_" + kind + ".csv"));
    }
  } catch (const std::exception& e) {
    log_once(g_logged_record, LogLevel::Error, fmt::format("recording not written: {}", e.what()));
  } catch (...) {
    log_once(g_logged_record, LogLevel::Error, "recording not written");
  }
}

void append_row(HandSeries& s, XrTime t, const Pose& p) {
  const double ts = static_cast<double>(t) * 1e-9;
  if (!s.t.empty() && !(ts > s.t.back())) return;  // tracks need increasing times
  s.t.push_back(ts);
  s.pos.push_back(p);
}

// ---------------------------------------------------------------- hand tracking hooks

template <class T, XrStructureType Type>
T* find_in_chain(void* next) {
  for (auto* s = static_cast<XrBaseOutStructure*>(next); s; s = s->next)
    if (s->type == Type) return reinterpret_cast<T*>(s);
  return nullptr;
}
template <class T, XrStructureType Type>
const T* find_in_chain(const void* next) {
  for (auto* s = static_cast<const XrBaseInStructure*>(next); s; s = s->next)
    if (s->type == Type) return reinterpret_cast<const T*>(s);
  return nullptr;
}

// Whether a runtime's answer came from a controller (XR_EXT_hand_tracking_data_source).
bool from_controller(const XrHandTrackingDataSourceStateEXT& s) noexcept {
  return s.isActive && s.dataSource == XR_HAND_TRACKING_DATA_SOURCE_CONTROLLER_EXT;
}

// Whether a tracker's creation chain accepts a controller as the hand's source.
bool accepts_controller(const void* create_next) noexcept {
  const auto* ds =
      find_in_chain<XrHandTrackingDataSourceInfoEXT, XR_TYPE_HAND_TRACKING_DATA_SOURCE_INFO_EXT>(create_next);
  if (!ds || !ds->requestedDataSources) return false;
  for (uint32_t i = 0; i < ds->requestedDataSourceCount; ++i)
    if (ds->requestedDataSources[i] == XR_HAND_TRACKING_DATA_SOURCE_CONTROLLER_EXT) return true;
  return false;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateHandTrackerEXT(XrSession session, const XrHandTrackerCreateInfoEXT* info,
                                                    XrHandTrackerEXT* tracker) noexcept {
  const auto inst = find_shared(reg().sessions, session);
  if (!inst) {
    const auto any = hand_instance();  // a session unknown here: its trackers pass through
    return any ? any->CreateHandTrackerEXT(session, info, tracker) : XR_ERROR_HANDLE_INVALID;
  }
  const XrResult res = inst->CreateHandTrackerEXT(session, info, tracker);
  if (XR_FAILED(res)) return res;
  try {
    auto t = std::make_shared<TrackerData>();
    t->inst = inst;
    t->handle = *tracker;
    t->session = session;
    t->hand = info->hand;
    t->controller_source = inst->data_source && accepts_controller(info->next);
    if (info->handJointSet == XR_HAND_JOINT_SET_HAND_WITH_FOREARM_ULTRALEAP) {
      t->joint_count = XR_HAND_FOREARM_JOINT_COUNT_ULTRALEAP;
    } else if (info->handJointSet != XR_HAND_JOINT_SET_DEFAULT_EXT) {
      t->passthrough = true;
      log_once(g_logged_joint_set, LogLevel::Warn,
               fmt::format("hand joint set {} is unknown to the layer: its joints pass through unfiltered",
                           static_cast<int>(info->handJointSet)));
    }
    for (auto& p : t->last_sample) p = untracked_pose();
    XrReferenceSpaceCreateInfo sci{};
    sci.type = XR_TYPE_REFERENCE_SPACE_CREATE_INFO;
    sci.referenceSpaceType = XR_REFERENCE_SPACE_TYPE_LOCAL;
    sci.poseInReferenceSpace.orientation.w = 1.0f;
    const XrResult sres = inst->CreateReferenceSpace ? inst->CreateReferenceSpace(session, &sci, &t->world)
                                                     : XR_ERROR_FUNCTION_UNSUPPORTED;
    if (XR_FAILED(sres)) {
      t->world = XR_NULL_HANDLE;
      t->passthrough = true;
      log_once(g_logged_world_space, LogLevel::Warn,
               fmt::format("cannot create a LOCAL space (result {}): hand joints pass through unfiltered",
                           static_cast<int>(sres)));
    } else {
      try {
        for (auto& f : t->filters) f = std::make_unique<TrackerFilter>(inst->config);
      } catch (const std::invalid_argument& e) {
        t->passthrough = true;
        log_once(g_logged_engine, LogLevel::Error, fmt::format("filter configuration rejected: {}; passing through", e.what()));
      }
    }
    if (!inst->config.record_dir.empty()) {
      t->recording = std::make_unique<Recording>();
      t->recording->raw.t.reserve(1 << 14);
      t->recording->raw.pos.reserve(1 << 14);
      t->recording->filtered.t.reserve(1 << 14);
      t->recording->filtered.pos.reserve(1 << 14);
    }
    std::unique_lock lock(reg().mu);
    t->serial = ++reg().tracker_serial;
    reg().trackers[*tracker] = std::move(t);
  } catch (...) {
    // The tracker works, unfiltered: without a registry entry the other hooks pass through.
    log_once(g_logged_internal, LogLevel::Error, "internal failure creating tracker state: passing through");
  }
  return res;
}

void release_tracker(const TrackerData& t) noexcept {
  write_recording(t);
  if (t.world != XR_NULL_HANDLE && t.inst->DestroySpace) t.inst->DestroySpace(t.world);
}

std::shared_ptr<TrackerData> take_tracker(XrHandTrackerEXT tracker) noexcept {
  std::unique_lock lock(reg().mu);
  auto it = reg().trackers.find(tracker);
  if (it == reg().trackers.end()) return nullptr;
  auto t = std::move(it->second);
  reg().trackers.erase(it);
  return t;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroyHandTrackerEXT(XrHandTrackerEXT tracker) noexcept {
  const auto t = take_tracker(tracker);
  if (!t) {
    const auto inst = hand_instance();  // unknown here: the runtime judges the handle
    return inst ? inst->DestroyHandTrackerEXT(tracker) : XR_ERROR_HANDLE_INVALID;
  }
  release_tracker(*t);
  return t->inst->DestroyHandTrackerEXT(tracker);
}

// Valid and tracked joints go to the engine; joint_gate then judges whether they are plausible.
bool position_tracked(const XrHandJointLocationEXT& j) {
  constexpr XrSpaceLocationFlags need = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT;
  return (j.locationFlags & need) == need;
}

// An active hand the runtime only infers: positions valid, none tracked (some runtimes
// report a hand they cannot see, or one driven by a controller, this way).
bool none_tracked_but_valid(const XrHandJointLocationEXT* joints) noexcept {
  bool valid = false;
  for (int j = 0; j < kJointCount; ++j) {
    if (position_tracked(joints[j])) return false;
    valid = valid || (joints[j].locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) != 0;
  }
  return valid;
}

// The runtime's joints of tracker t in the layer's world space at `time` (NaN rows: not
// tracked). Velocities into `vel` when given. False when the runtime fails.
bool locate_world(const TrackerData& t, const XrHandJointsLocateInfoEXT& app_info, XrTime time, Pose& pose,
                  std::array<XrHandJointVelocityEXT, kMaxJoints>* vel, const XrHandTrackingScaleFB* app_scale) noexcept {
  std::array<XrHandJointLocationEXT, kMaxJoints> wj{};
  XrHandJointVelocitiesEXT wv{XR_TYPE_HAND_JOINT_VELOCITIES_EXT, nullptr, t.joint_count, vel ? vel->data() : nullptr};
  XrHandJointLocationsEXT wl{XR_TYPE_HAND_JOINT_LOCATIONS_EXT, vel ? &wv : nullptr, XR_FALSE, t.joint_count, wj.data()};
  // Where the hand may come from a controller, which source this answer is from.
  XrHandTrackingDataSourceStateEXT source{XR_TYPE_HAND_TRACKING_DATA_SOURCE_STATE_EXT, wl.next, XR_FALSE,
                                          XR_HAND_TRACKING_DATA_SOURCE_UNOBSTRUCTED_EXT};
  if (t.controller_source) wl.next = &source;
  // The hand at the scale the app asked the runtime for, as in the app's answers.
  XrHandTrackingScaleFB scale{XR_TYPE_HAND_TRACKING_SCALE_FB, wl.next, 0.0f, 0.0f, XR_FALSE, 0.0f};
  if (app_scale) {
    scale.overrideHandScale = app_scale->overrideHandScale;
    scale.overrideValueInput = app_scale->overrideValueInput;
    wl.next = &scale;
  }
  XrHandJointsLocateInfoEXT wi{XR_TYPE_HAND_JOINTS_LOCATE_INFO_EXT, app_info.next, t.world, time};
  const XrResult res = t.inst->LocateHandJointsEXT(t.handle, &wi, &wl);
  if (XR_FAILED(res)) {
    log_once(g_logged_world_locate, LogLevel::Warn,
             fmt::format("runtime failed to locate joints in the layer's space (result {}): no sample; answered "
                         "from the filter's estimate while it reaches, else passing through",
                         static_cast<int>(res)));
    return false;
  }
  // A controller's hand is no sample of the tracked hand (when predicting, the time asked
  // may be before the tracker took over again).
  const bool tracked_hand = !from_controller(source);
  for (int j = 0; j < kJointCount; ++j) {
    if (wl.isActive && tracked_hand && position_tracked(wj[j])) pose.row(j) = xr::to_eigen(wj[j].pose.position).transpose();
    else pose.row(j).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return true;
}

// The layer's world space in the app's base space at `time`, with the world's motion seen
// from the base. False (pass through) for a failed call or a pose no runtime can mean,
// even flagged valid: non-finite, 10 km away, a non-unit orientation.
bool locate_base(const InstanceData& inst, XrSpace world, XrSpace base, XrTime time, xr::Rigid& base_from_world,
                 BaseMotion& motion) noexcept {
  XrSpaceVelocity vel{};
  vel.type = XR_TYPE_SPACE_VELOCITY;
  XrSpaceLocation loc{};
  loc.type = XR_TYPE_SPACE_LOCATION;
  loc.next = &vel;
  const XrResult res = inst.LocateSpace(world, base, time, &loc);
  constexpr XrSpaceLocationFlags need = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_ORIENTATION_VALID_BIT;
  if (XR_FAILED(res)) {
    log_once(g_logged_locate_space, LogLevel::Warn,
             fmt::format("xrLocateSpace failed (result {}): the base located from the runtime's joints, else passing "
                         "through",
                         static_cast<int>(res)));
    return false;
  }
  if ((loc.locationFlags & need) != need) return false;
  if (!xr::finite(loc.pose.position) || !(xr::to_eigen(loc.pose.position).norm() < 1e4) ||
      !xr::usable(loc.pose.orientation)) {
    log_once(g_logged_space_garbage, LogLevel::Warn,
             "xrLocateSpace answered an impossible pose flagged valid: the base located from the runtime's joints, "
             "else passing through");
    return false;
  }
  base_from_world = xr::to_rigid(loc.pose);
  constexpr XrSpaceVelocityFlags both = XR_SPACE_VELOCITY_LINEAR_VALID_BIT | XR_SPACE_VELOCITY_ANGULAR_VALID_BIT;
  motion.valid = (vel.velocityFlags & both) == both && xr::finite(vel.linearVelocity) &&
                 xr::finite(vel.angularVelocity) && xr::to_eigen(vel.linearVelocity).norm() < 20.0 &&
                 xr::to_eigen(vel.angularVelocity).norm() < 50.0;
  if (motion.valid) {
    motion.linear = xr::to_eigen(vel.linearVelocity);
    motion.angular = xr::to_eigen(vel.angularVelocity);
  }
  return true;
}

// The runtime's answer to the app (base space) in the layer's world space: what
// locate_world would answer at the same time, up to float rounding. Garbage rows: NaN.
void world_from_answer(const XrHandJointLocationEXT* joints, const JointMask& garbage, const xr::Rigid& world_from_base,
                       Pose& pose) noexcept {
  for (int j = 0; j < kJointCount; ++j) {
    if (position_tracked(joints[j]) && !garbage[j])
      pose.row(j) = (world_from_base * xr::to_eigen(joints[j].pose.position)).transpose();
    else
      pose.row(j).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
}

// Replaces the runtime's answer in `out` (already filled for the app) by the engine's.
// Returns without touching `out` whenever something needed is missing. app_scale: the
// app's XrHandTrackingScaleFB in `out`'s chain (XR_FB_hand_tracking_mesh), or nullptr.
void filter_answer(TrackerData& t, const XrHandJointsLocateInfoEXT& info, XrHandJointLocationsEXT& out,
                   const XrHandTrackingScaleFB* app_scale, JointMask& garbage) noexcept {
  const InstanceData& inst = *t.inst;
  const auto* range =
      find_in_chain<XrHandJointsMotionRangeInfoEXT, XR_TYPE_HAND_JOINTS_MOTION_RANGE_INFO_EXT>(info.next);
  const int state_index =
      range && range->handJointsMotionRange == XR_HAND_JOINTS_MOTION_RANGE_CONFORMING_TO_CONTROLLER_EXT ? 1 : 0;
  TrackerFilter* filter = t.filters[state_index].get();
  if (!filter) return;
  auto* app_vel = find_in_chain<XrHandJointVelocitiesEXT, XR_TYPE_HAND_JOINT_VELOCITIES_EXT>(out.next);
  if (app_vel && (app_vel->jointCount != t.joint_count || !app_vel->jointVelocities)) app_vel = nullptr;
  const int hand = t.hand == XR_HAND_LEFT_EXT ? 0 : 1;
  const bool predict = inst.config.mode == Mode::Predict;
  const XrTime horizon = predict ? inst.tuning->horizon_ns(hand) : 0;
  const TimeSemantics semantics = t.semantics.load(std::memory_order_relaxed);

  // The runtime's joints in the world-fixed space, asked `horizon` early when predicting
  // so that the engine extrapolates from real data (a runtime answering the asked time).
  XrTime sample_time = info.time;
  if (horizon > 0 && info.time - horizon > 0) sample_time = info.time - horizon;
  const bool same_time = sample_time == info.time;
  bool probe = false;
  {
    std::lock_guard lock(t.sample_mu);
    probe = t.probe.due();
  }
  // At the asked time the app's answer is the sample: taken to the world space with one
  // xrLocateSpace instead of a second joint query (a third of the layer's cost per call).
  // A probe compares two runtime answers bit for bit, and the runtime's world velocities
  // are needed where the base's motion is unknown: those ask the runtime again.
  xr::Rigid base_from_world;
  BaseMotion motion;
  bool based = false, base_tried = false;
  std::array<XrHandJointVelocityEXT, kMaxJoints> wvj{};
  Pose observed;
  bool have_sample = false;
  if (same_time && !probe) {
    based = locate_base(inst, t.world, info.baseSpace, info.time, base_from_world, motion);
    base_tried = true;
    if (based && (motion.valid || !app_vel)) {
      world_from_answer(out.jointLocations, garbage, base_from_world.inverse(), observed);
      have_sample = true;
    }
  }
  // A query of the layer's own that the runtime fails is no sample: the engine answers from
  // what it has, as in a frame without a new sample, while its path reaches.
  const bool world_sampled =
      have_sample || locate_world(t, info, sample_time, observed, app_vel && same_time ? &wvj : nullptr, app_scale);
  if (!world_sampled) observed.setConstant(std::numeric_limits<double>::quiet_NaN());
  const bool any = any_joint_tracked(observed);

  // Is this a new sample, and what time is it from? Probe the runtime's time semantics now and then.
  // The runtime's clock is read only where it matters: a latest-pose runtime, or a time
  // far from the last sample's (the app's time chaos).
  const XrTime last_stamp = t.last_stamp.load(std::memory_order_relaxed);
  const XrTime from_last = sample_time - last_stamp;  // both positive: no overflow
  const bool far_time = last_stamp == 0 || from_last > 1'000'000'000 || from_last < -1'000'000'000;
  const XrTime now = semantics == TimeSemantics::Latest || far_time ? inst.now() : 0;
  bool fresh = false;
  {
    std::lock_guard lock(t.sample_mu);
    fresh = any && !repeated_pose(observed, t.last_sample[state_index]);
    if (any) t.last_sample[state_index] = observed;
  }
  if (probe && any && sample_time - SemanticsProbe::kProbeOffsetNs > 0) {
    Pose earlier;
    if (locate_world(t, info, sample_time - SemanticsProbe::kProbeOffsetNs, earlier, nullptr, app_scale)) {
      std::lock_guard lock(t.sample_mu);
      t.probe.vote(observed, earlier, fresh);
      t.semantics.store(t.probe.semantics(), std::memory_order_relaxed);
      if (t.probe.semantics() == TimeSemantics::Latest)
        log_once(g_logged_latest, LogLevel::Info,
                 fmt::format("the runtime answers its latest pose whatever the time asked: samples are dated by {}",
                             inst.ConvertTimespecTimeToTimeKHR ? "the runtime's clock"
                                                               : "the asked time (no XR_KHR_convert_timespec_time)"));
    }
  }
  XrTime stamp = sample_time, query = info.time;
  if (semantics == TimeSemantics::Latest && now > 0) {
    // Its newest pose is from about now: extrapolate from there by at most the horizon.
    stamp = now;
    query = std::min(info.time, now + horizon);
  }
  // With a clock, a sample dated more than a second away from now is the app's time chaos
  // (0, far future, far past): it is not fed; the engine's answer then decides.
  if (now > 0 && (stamp - now > 1'000'000'000 || stamp - now < -1'000'000'000)) {
    fresh = false;
    log_once(g_logged_time, LogLevel::Info, "a hand query far from the runtime's now: not fed to the filter");
  }
  if (fresh) t.last_stamp.store(stamp, std::memory_order_relaxed);
  Answer answer;
  const bool have = filter->update(stamp, fresh ? &observed : nullptr, query, answer);
  if (t.recording) {
    std::lock_guard lock(t.recording->mu);
    if (fresh) append_row(t.recording->raw, stamp, observed);
    if (have) append_row(t.recording->filtered, query, answer.pose);
  }
  if (!have) return;

  if (!base_tried) based = locate_base(inst, t.world, info.baseSpace, info.time, base_from_world, motion);
  bool world_velocities = same_time;  // wvj holds the runtime's world velocities at the asked time
  if (!based) {
    // xrLocateSpace failed or answered garbage: the base's pose from the runtime's joints
    // at the asked time in both spaces (the world's: the sample itself, or one more query).
    Pose world_now;
    const Pose* at_time = same_time && world_sampled ? &observed : nullptr;
    if (!at_time && locate_world(t, info, info.time, world_now, app_vel ? &wvj : nullptr, app_scale)) {
      at_time = &world_now;
      world_velocities = app_vel != nullptr;
    }
    if (!at_time || !fit_base_from_world(out.jointLocations, garbage, *at_time, base_from_world)) return;
    motion = BaseMotion{};
    log_once(g_logged_fit_base, LogLevel::Info,
             "xrLocateSpace failed: the app's base space located from the runtime's joints in both spaces");
  }
  if (!motion.valid && world_velocities) motion.world_velocities = wvj.data();
  // Where the runtime's hand is not where the engine's is (re-acquired elsewhere, not yet
  // seen by the engine), the runtime's answer stands: no hand moves 8 cm beyond its
  // prediction in one answer.
  const double max_offset = 0.08 + 3.0 * static_cast<double>(std::max<XrTime>(info.time - stamp, 0)) * 1e-9;
  const RewriteStats stats = rewrite_joints(answer, inst.tuning->smoothing(hand), base_from_world, motion, garbage,
                                            max_offset, out.jointLocations,
                                            app_vel ? app_vel->jointVelocities : nullptr);
  if (stats.repaired > 0)
    log_once(g_logged_repaired, LogLevel::Warn,
             "the runtime reported impossible joint positions as tracked: answered with the filter's estimate");
}

// The runtime's hand is another from now on (another source, another scale): every
// motion range's engine restarts on the first sample after the last one fed.
void restart_as_new_hand(TrackerData& t) noexcept {
  const XrTime last = t.last_stamp.load(std::memory_order_relaxed);
  for (const auto& f : t.filters)
    if (f) f->source_changed(last);
}

// A query whose answer is the joints alone: no motion range or other structure asked for,
// no joint velocities (their own estimate) wanted.
bool plain_query(const XrHandJointsLocateInfoEXT& info, const XrHandJointLocationsEXT& out) noexcept {
  return !info.next &&
         !find_in_chain<XrHandJointVelocitiesEXT, XR_TYPE_HAND_JOINT_VELOCITIES_EXT>(static_cast<void*>(out.next));
}

// An app that enabled XR_EXT_hand_interaction asks again at the time and in the base space
// of the last answer, and the runtime answers as then: that answer again. The hand's poses
// may have been located first (the layer answers for the hand then, hand_answer), and on
// the network's worker a second answer at the same time would differ (the first is the
// engine's estimate corrected by the new sample, the next its output for it): the joints
// the app draws must be those its poke and pinch sit on.
bool repeat_answer(TrackerData& t, const XrHandJointsLocateInfoEXT& info, const JointsBefore& before,
                   XrHandJointLocationsEXT& out) noexcept {
  if (!t.inst->hand_interaction || !plain_query(info, out)) return false;
  std::lock_guard lock(t.answer_mu);
  if (!t.answer_plain || t.answer_time != info.time || t.answer_base != info.baseSpace ||
      std::memcmp(before.loc.data(), t.answer_before.loc.data(), sizeof(before.loc)) != 0)
    return false;
  std::copy_n(t.answer_after.begin(), kJointCount, out.jointLocations);
  return true;
}

XRAPI_ATTR XrResult XRAPI_CALL LocateHandJointsEXT(XrHandTrackerEXT tracker, const XrHandJointsLocateInfoEXT* info,
                                                   XrHandJointLocationsEXT* out) noexcept {
  const auto t = find_shared(reg().trackers, tracker);
  if (!t) {
    const auto inst = hand_instance();  // unknown here: unfiltered, the runtime judges the handle
    return inst ? inst->LocateHandJointsEXT(tracker, info, out) : XR_ERROR_HANDLE_INVALID;
  }
  // Which source the runtime's hand comes from, where it may be a controller: from the
  // app's own state structure, else from one the layer puts at the head of the chain for
  // the call (the tracker accepts sources, so the runtime takes it), the app's chain
  // restored after.
  XrHandTrackingDataSourceStateEXT own{XR_TYPE_HAND_TRACKING_DATA_SOURCE_STATE_EXT, nullptr, XR_FALSE,
                                       XR_HAND_TRACKING_DATA_SOURCE_UNOBSTRUCTED_EXT};
  const XrHandTrackingDataSourceStateEXT* source = nullptr;
  void* const app_next = out ? out->next : nullptr;
  if (t->controller_source && out) {
    source = find_in_chain<XrHandTrackingDataSourceStateEXT, XR_TYPE_HAND_TRACKING_DATA_SOURCE_STATE_EXT>(out->next);
    if (!source) {
      own.next = out->next;
      out->next = &own;
      source = &own;
    }
  }
  const XrResult res = t->inst->LocateHandJointsEXT(tracker, info, out);
  if (source == &own) out->next = app_next;
  // The runtime validated the arguments; an inactive hand has nothing to filter.
  if (XR_FAILED(res) || t->passthrough.load(std::memory_order_relaxed) || !out->isActive ||
      out->jointCount != t->joint_count)
    return res;
  try {
    const XrVector3f wrist_before = out->jointLocations[XR_HAND_JOINT_WRIST_EXT].pose.position;
    JointMask garbage = garbage_joints(out->jointLocations);
    // Meta's capsules and aim, computed by the runtime from its joints, move with them.
    auto* capsules = t->inst->fb_capsules
                         ? find_in_chain<XrHandTrackingCapsulesStateFB, XR_TYPE_HAND_TRACKING_CAPSULES_STATE_FB>(out->next)
                         : nullptr;
    auto* aim = t->inst->fb_aim ? find_in_chain<XrHandTrackingAimStateFB, XR_TYPE_HAND_TRACKING_AIM_STATE_FB>(out->next)
                                : nullptr;
    JointsBefore before;
    if (capsules || aim || t->inst->hand_interaction) {
      std::copy_n(out->jointLocations, kJointCount, before.loc.begin());
      before.garbage = garbage;
    }
    // A controller's hand (its pose, fingers from buttons and touch) has no tracker noise
    // to remove, and a network taught on tracked hands would only smooth its deliberate
    // snaps: it passes through, and the hand back from the tracker is a new one.
    if (source && from_controller(*source)) {
      log_once(g_logged_controller, LogLevel::Info,
               "the runtime's hand comes from a controller (XR_EXT_hand_tracking_data_source): passed through "
               "unfiltered; filtering restarts when it comes from hand tracking again");
      restart_as_new_hand(*t);
    } else {
      // A hand scale the app asks for anew (XR_FB_hand_tracking_mesh) reshapes the hand at
      // once: a new hand for the engine, which otherwise bridges the jump as motion.
      const auto* scale = t->inst->fb_mesh
                              ? find_in_chain<XrHandTrackingScaleFB, XR_TYPE_HAND_TRACKING_SCALE_FB>(out->next)
                              : nullptr;
      const float asked = scale && scale->overrideHandScale ? scale->overrideValueInput : 0.0f;
      const float before_asked = t->scale_asked.exchange(asked, std::memory_order_relaxed);
      if (!(std::abs(asked - before_asked) < 1e-4f)) {
        log_once(g_logged_scale, LogLevel::Info,
                 "the app changed the hand scale it asks the runtime for (XR_FB_hand_tracking_mesh): filtering "
                 "restarts at the new scale");
        restart_as_new_hand(*t);
      }
      // Checked only until said: no joint scan per call once logged.
      if (!g_logged_untracked.load(std::memory_order_relaxed) && none_tracked_but_valid(out->jointLocations))
        log_once(g_logged_untracked, LogLevel::Info,
                 "the runtime reported an active hand with valid joints but none tracked (no "
                 "XR_SPACE_LOCATION_POSITION_TRACKED_BIT): the layer filters tracked joints only, such answers pass "
                 "through unfiltered");
      if (!repeat_answer(*t, *info, before, *out)) filter_answer(*t, *info, *out, scale, garbage);
    }
    // Whatever the layer could not replace is never handed over as garbage.
    auto* vel = find_in_chain<XrHandJointVelocitiesEXT, XR_TYPE_HAND_JOINT_VELOCITIES_EXT>(out->next);
    if (vel && (vel->jointCount != t->joint_count || !vel->jointVelocities)) vel = nullptr;
    int repaired = repair_garbage(garbage, out->jointLocations, vel ? vel->jointVelocities : nullptr);
    // A set's joints beyond the hand (the elbow) follow the wrist.
    if (t->joint_count > XR_HAND_JOINT_COUNT_EXT)
      repaired += rewrite_forearm(wrist_before, out->jointLocations, t->joint_count, vel ? vel->jointVelocities : nullptr);
    if (repaired > 0)
      log_once(g_logged_garbage, LogLevel::Warn,
               "the runtime reported impossible joint data as valid: positions replaced by a neighbour's (not "
               "tracked), radii by a neighbour's, velocities marked invalid");
    int fb_repaired = 0;
    if (capsules) fb_repaired += move_capsules(before, out->jointLocations, *capsules);
    if (aim) fb_repaired += move_aim(before, out->jointLocations, *aim);
    if (fb_repaired > 0)
      log_once(g_logged_fb_garbage, LogLevel::Warn,
               "the runtime's hand capsules or aim (XR_FB_hand_tracking_capsules, XR_FB_hand_tracking_aim) were "
               "impossible: capsules collapsed onto their joint, the aim marked invalid, pinch strengths clamped");
    if (t->inst->hand_interaction) {
      std::lock_guard lock(t->answer_mu);
      t->answer_time = info->time;
      t->answer_base = info->baseSpace;
      t->answer_plain = plain_query(*info, *out);
      t->answer_before = before;
      std::copy_n(out->jointLocations, kJointCount, t->answer_after.begin());
    }
  } catch (...) {
    t->passthrough = true;
    log_once(g_logged_internal, LogLevel::Error, "internal failure while filtering: this tracker passes through");
  }
  return res;
}

// ---------------------------------------------------------------- XR_EXT_hand_interaction

// The runtime derives the hand interaction profile's poses (grip, aim, pinch, poke) from
// its own joints; the app gets them by locating action spaces. Where the layer moves the
// joints, those poses move with them (hand_attachments.hpp move_hand_pose), so that a
// poke or a pinch ray meets what the app draws, predicted or not.

// The pose input of the hand interaction profile a binding path is: its hand and pose.
std::optional<std::pair<int, HandPose>> hand_pose_input(const InstanceData& d, XrPath path) noexcept {
  for (size_t h = 0; h < 2; ++h)
    for (size_t k = 0; k < kPoseInputs.size(); ++k)
      if (d.pose_input[h][k] == path) return std::pair{static_cast<int>(h), kPoseInputs[k].pose};
  return std::nullopt;
}

XRAPI_ATTR XrResult XRAPI_CALL SuggestInteractionProfileBindings(
    XrInstance instance, const XrInteractionProfileSuggestedBinding* suggested) noexcept {
  const auto inst = find_shared(reg().instances, instance);
  if (!inst || !inst->SuggestInteractionProfileBindings) return XR_ERROR_HANDLE_INVALID;
  const XrResult res = inst->SuggestInteractionProfileBindings(instance, suggested);
  // (A runtime that let an invalid suggestion through is not followed into it.)
  if (XR_FAILED(res) || !suggested || !suggested->suggestedBindings || suggested->interactionProfile != inst->hand_profile)
    return res;
  try {
    // A suggestion replaces the profile's earlier one (the loader allows one instance).
    std::unique_lock lock(reg().mu);
    reg().hand_actions.clear();
    for (uint32_t i = 0; i < suggested->countSuggestedBindings; ++i) {
      const XrActionSuggestedBinding& b = suggested->suggestedBindings[i];
      if (const auto input = hand_pose_input(*inst, b.binding))
        reg().hand_actions[b.action][static_cast<size_t>(input->first)] = input->second;
    }
  } catch (...) {
    log_once(g_logged_internal, LogLevel::Error, "internal failure recording hand interaction bindings");
  }
  return res;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateActionSpace(XrSession session, const XrActionSpaceCreateInfo* info,
                                                 XrSpace* space) noexcept {
  const auto inst = find_shared(reg().sessions, session);
  if (!inst) {
    const auto any = hand_instance();  // a session unknown here: the runtime judges the handle
    return any && any->CreateActionSpace ? any->CreateActionSpace(session, info, space) : XR_ERROR_HANDLE_INVALID;
  }
  const XrResult res = inst->CreateActionSpace(session, info, space);
  if (XR_FAILED(res) || !info || !space) return res;
  int hand = -1;
  if (info->subactionPath != XR_NULL_PATH) {
    if (info->subactionPath == inst->user_hand[0]) hand = 0;
    else if (info->subactionPath == inst->user_hand[1]) hand = 1;
    else return res;  // not a hand's
  }
  try {
    std::unique_lock lock(reg().mu);
    reg().action_spaces[*space] = ActionSpaceData{inst, session, info->action, hand, info->poseInActionSpace};
  } catch (...) {
    log_once(g_logged_internal, LogLevel::Error, "internal failure recording an action space: it passes through");
  }
  return res;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySpace(XrSpace space) noexcept {
  std::shared_ptr<const InstanceData> inst;
  {
    std::unique_lock lock(reg().mu);
    const auto it = reg().action_spaces.find(space);
    if (it != reg().action_spaces.end()) {
      inst = it->second.inst;
      reg().action_spaces.erase(it);
    }
  }
  if (!inst) inst = hand_instance();
  return inst && inst->DestroySpace ? inst->DestroySpace(space) : XR_ERROR_HANDLE_INVALID;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroyAction(XrAction action) noexcept {
  {
    std::unique_lock lock(reg().mu);
    reg().hand_actions.erase(action);
  }
  const auto inst = hand_instance();
  return inst && inst->DestroyAction ? inst->DestroyAction(action) : XR_ERROR_HANDLE_INVALID;
}

// Whether hand h's current interaction profile is the hand interaction profile: its poses
// then come from the tracked hand (other profiles' come from controllers).
bool hand_profile_current(const InstanceData& d, XrSession session, int h) noexcept {
  XrInteractionProfileState state{XR_TYPE_INTERACTION_PROFILE_STATE, nullptr, XR_NULL_PATH};
  return d.GetCurrentInteractionProfile(session, d.user_hand[static_cast<size_t>(h)], &state) == XR_SUCCESS &&
         state.interactionProfile == d.hand_profile;
}

// The runtime's joints and the layer's answered at `time` in `base`, where the app was
// answered there last.
bool cached_answer(TrackerData& t, XrSpace base, XrTime time, JointsBefore& before,
                   std::array<XrHandJointLocationEXT, kJointCount>& after) noexcept {
  std::lock_guard lock(t.answer_mu);
  if (t.answer_time != time || t.answer_base != base) return false;
  before = t.answer_before;
  after = t.answer_after;
  return true;
}

// The layer's answer for the app's tracker of `hand` in `session` at `time` in `base`: the
// last one handed over there, else the one the app would get now (asked through the
// layer's own hook, which keeps it). False when the layer has none (no such tracker, an
// inactive hand, a tracker passing through).
bool hand_answer(XrSession session, int hand, XrSpace base, XrTime time, JointsBefore& before,
                 std::array<XrHandJointLocationEXT, kJointCount>& after) noexcept {
  std::shared_ptr<TrackerData> t;
  {
    std::shared_lock lock(reg().mu);
    const XrHandEXT which = hand == 0 ? XR_HAND_LEFT_EXT : XR_HAND_RIGHT_EXT;
    for (const auto& [handle, d] : reg().trackers)
      if (d->session == session && d->hand == which && !d->passthrough.load(std::memory_order_relaxed)) {
        t = d;
        break;
      }
  }
  if (!t) return false;
  if (cached_answer(*t, base, time, before, after)) return true;
  std::array<XrHandJointLocationEXT, kMaxJoints> joints{};
  XrHandJointLocationsEXT out{XR_TYPE_HAND_JOINT_LOCATIONS_EXT, nullptr, XR_FALSE, t->joint_count, joints.data()};
  const XrHandJointsLocateInfoEXT info{XR_TYPE_HAND_JOINTS_LOCATE_INFO_EXT, nullptr, base, time};
  return XR_SUCCEEDED(LocateHandJointsEXT(t->handle, &info, &out)) && cached_answer(*t, base, time, before, after);
}

// An action space of a hand interaction pose, located by the runtime: moved with the
// layer's answer for its hand at that time, never garbage.
void move_action_space(const ActionSpaceData& as, const std::array<HandPose, 2>& poses, XrSpace base, XrTime time,
                       XrSpaceLocation& loc) noexcept {
  // Not located: nothing to move (and the runtime locates an action's pose only once the
  // app attached its actions: the profile is asked for only then).
  if (!(loc.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT)) return;
  const InstanceData& d = *as.inst;
  int hand = as.hand;
  if (hand < 0) {
    // No subaction path: the runtime picks among the hands the action is bound to.
    const bool left = poses[0] != HandPose::None && hand_profile_current(d, as.session, 0);
    const bool right = poses[1] != HandPose::None && hand_profile_current(d, as.session, 1);
    if (left && right)
      log_once(g_logged_hand_pose_ambiguous, LogLevel::Info,
               "an action space of a hand interaction pose bound to both hands, created without a subaction path: "
               "the layer cannot tell which hand the runtime locates, its pose is the runtime's");
    hand = left && !right ? 0 : right && !left ? 1 : -1;
  } else if (poses[static_cast<size_t>(hand)] == HandPose::None || !hand_profile_current(d, as.session, hand)) {
    hand = -1;
  }
  if (hand < 0) return;
  JointsBefore before;
  std::array<XrHandJointLocationEXT, kJointCount> after{};
  if (!hand_answer(as.session, hand, base, time, before, after)) {
    // No answer of the layer's: the runtime's joints stand, the pose is only judged.
    for (auto& j : after) j.pose.position = {std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f};
    before.loc = after;
  } else {
    log_once(g_logged_hand_pose, LogLevel::Info,
             "hand interaction poses (XR_EXT_hand_interaction) move with the joints the layer answers");
  }
  if (move_hand_pose(poses[static_cast<size_t>(hand)], before, after.data(), as.pose_in_action, loc) > 0)
    log_once(g_logged_hand_pose_garbage, LogLevel::Warn,
             "the runtime located a hand interaction pose no hand has (XR_EXT_hand_interaction): marked not valid");
}

XRAPI_ATTR XrResult XRAPI_CALL LocateSpace(XrSpace space, XrSpace baseSpace, XrTime time,
                                           XrSpaceLocation* location) noexcept {
  ActionSpaceData as;
  std::array<HandPose, 2> poses{};
  {
    std::shared_lock lock(reg().mu);
    const auto it = reg().action_spaces.find(space);
    if (it != reg().action_spaces.end()) {
      as = it->second;
      const auto a = reg().hand_actions.find(as.action);
      if (a != reg().hand_actions.end()) poses = a->second;
    }
  }
  const auto inst = as.inst ? as.inst : hand_instance();
  if (!inst) return XR_ERROR_HANDLE_INVALID;
  const XrResult res = inst->LocateSpace(space, baseSpace, time, location);
  if (!as.inst || XR_FAILED(res) || !location || (poses[0] == HandPose::None && poses[1] == HandPose::None))
    return res;
  try {
    move_action_space(as, poses, baseSpace, time, *location);
  } catch (...) {
    log_once(g_logged_internal, LogLevel::Error, "internal failure moving a hand interaction pose: passed through");
  }
  return res;
}

// XR_NOVENDOR_handsteady_raw_joints: the runtime's answer, untouched. Trackers are
// registered only when the layer filters (mode not off); otherwise the call goes to the
// one live instance (the loader allows one per process) that enabled the extension.
XRAPI_ATTR XrResult XRAPI_CALL LocateRawHandJointsNOVENDOR(XrHandTrackerEXT tracker,
                                                           const XrHandJointsLocateInfoEXT* info,
                                                           XrHandJointLocationsEXT* out) noexcept {
  std::shared_ptr<const InstanceData> inst;
  if (const auto t = find_shared(reg().trackers, tracker)) {
    inst = t->inst;
  } else {
    std::shared_lock lock(reg().mu);
    for (const auto& [handle, d] : reg().instances)
      if (d->raw_joints && d->LocateHandJointsEXT) inst = d;
  }
  if (!inst || !inst->LocateHandJointsEXT) return XR_ERROR_HANDLE_INVALID;
  return inst->LocateHandJointsEXT(tracker, info, out);
}

// The app's events, untouched. A pending change of LOCAL (a recentring: the layer's world
// space moves) restarts the session's filters at its change time, so that no run mixes
// the old space with the new and no answer converts one into the other.
XRAPI_ATTR XrResult XRAPI_CALL PollEvent(XrInstance instance, XrEventDataBuffer* event) noexcept {
  const auto inst = find_shared(reg().instances, instance);
  if (!inst || !inst->PollEvent) return XR_ERROR_HANDLE_INVALID;
  const XrResult res = inst->PollEvent(instance, event);
  if (res != XR_SUCCESS || !event || event->type != XR_TYPE_EVENT_DATA_REFERENCE_SPACE_CHANGE_PENDING) return res;
  const auto& ev = *reinterpret_cast<const XrEventDataReferenceSpaceChangePending*>(event);
  if (ev.referenceSpaceType != XR_REFERENCE_SPACE_TYPE_LOCAL) return res;
  try {
    std::shared_lock lock(reg().mu);
    for (const auto& [handle, t] : reg().trackers)
      if (t->session == ev.session)
        for (const auto& f : t->filters)
          if (f) f->space_changed(ev.changeTime);
  } catch (...) {
    log_once(g_logged_internal, LogLevel::Error, "internal failure handling a recentring: filters go on");
    return res;
  }
  log_once(g_logged_recentre, LogLevel::Info,
           "the runtime moves LOCAL (recentring): hand filters restart from the runtime's joints at the change");
  return res;
}

// ---------------------------------------------------------------- session / instance hooks

XRAPI_ATTR XrResult XRAPI_CALL CreateSession(XrInstance instance, const XrSessionCreateInfo* info,
                                             XrSession* session) noexcept {
  const auto inst = find_shared(reg().instances, instance);
  if (!inst) return XR_ERROR_HANDLE_INVALID;
  const XrResult res = inst->CreateSession(instance, info, session);
  if (XR_SUCCEEDED(res)) {
    try {
      std::unique_lock lock(reg().mu);
      reg().sessions[*session] = inst;
    } catch (...) {
      log_once(g_logged_internal, LogLevel::Error, "internal failure recording a session: its trackers pass through");
    }
  }
  return res;
}

// Trackers are children of the session: the runtime destroys them with it.
std::vector<std::shared_ptr<TrackerData>> take_trackers(auto&& belongs) noexcept {
  std::vector<std::shared_ptr<TrackerData>> taken;
  try {
    std::unique_lock lock(reg().mu);
    for (auto it = reg().trackers.begin(); it != reg().trackers.end();) {
      if (belongs(*it->second)) {
        taken.push_back(std::move(it->second));
        it = reg().trackers.erase(it);
      } else {
        ++it;
      }
    }
  } catch (...) {
  }
  return taken;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySession(XrSession session) noexcept {
  const auto inst = find_shared(reg().sessions, session);
  if (!inst) {
    const auto any = hand_instance();  // unknown here: the runtime judges the handle
    return any ? any->DestroySession(session) : XR_ERROR_HANDLE_INVALID;
  }
  for (const auto& t : take_trackers([&](const TrackerData& d) { return d.session == session; })) release_tracker(*t);
  {
    std::unique_lock lock(reg().mu);
    reg().sessions.erase(session);
    std::erase_if(reg().action_spaces, [&](const auto& kv) { return kv.second.session == session; });
  }
  return inst->DestroySession(session);
}

XRAPI_ATTR XrResult XRAPI_CALL DestroyInstance(XrInstance instance) noexcept {
  const auto inst = find_shared(reg().instances, instance);
  if (!inst) return XR_ERROR_HANDLE_INVALID;
  for (const auto& t : take_trackers([&](const TrackerData& d) { return d.inst == inst; })) write_recording(*t);
  {
    std::unique_lock lock(reg().mu);
    std::erase_if(reg().sessions, [&](const auto& kv) { return kv.second == inst; });
    std::erase_if(reg().action_spaces, [&](const auto& kv) { return kv.second.inst == inst; });
    if (inst->hand_interaction) reg().hand_actions.clear();
    reg().instances.erase(instance);
  }
  return inst->DestroyInstance(instance);
}

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char* name,
                                                   PFN_xrVoidFunction* fn) noexcept {
  if (!fn || !name) return XR_ERROR_VALIDATION_FAILURE;
  const auto inst = find_shared(reg().instances, instance);
  if (!inst) {
    *fn = nullptr;
    return XR_ERROR_HANDLE_INVALID;
  }
  const std::string_view n(name);
  auto ours = [&](auto f) {
    *fn = reinterpret_cast<PFN_xrVoidFunction>(f);
    return XR_SUCCESS;
  };
  if (n == "xrGetInstanceProcAddr") return ours(&GetInstanceProcAddr);
  if (n == "xrDestroyInstance") return ours(&DestroyInstance);
  // The layer enabled XR_KHR_convert_timespec_time for its own clock; an app that did not
  // enable it must not get its functions.
  if (!inst->app_timespec && (n == "xrConvertTimespecTimeToTimeKHR" || n == "xrConvertTimeToTimespecTimeKHR")) {
    *fn = nullptr;
    return XR_ERROR_FUNCTION_UNSUPPORTED;
  }
  if (n == "xrLocateRawHandJointsNOVENDOR") {
    if (!inst->raw_joints || !inst->LocateHandJointsEXT) {
      *fn = nullptr;
      return XR_ERROR_FUNCTION_UNSUPPORTED;
    }
    return ours(&LocateRawHandJointsNOVENDOR);
  }
  if (inst->hand_tracking && inst->config.mode != Mode::Off) {
    // Hooked only when the app enabled XR_EXT_hand_tracking and the runtime has them.
    if (has_hand_functions(*inst)) {
      if (n == "xrCreateSession") return ours(&CreateSession);
      if (n == "xrDestroySession") return ours(&DestroySession);
      if (n == "xrCreateHandTrackerEXT") return ours(&CreateHandTrackerEXT);
      if (n == "xrDestroyHandTrackerEXT") return ours(&DestroyHandTrackerEXT);
      if (n == "xrLocateHandJointsEXT") return ours(&LocateHandJointsEXT);
      if (n == "xrPollEvent" && inst->PollEvent) return ours(&PollEvent);
      if (inst->hand_interaction) {
        if (n == "xrSuggestInteractionProfileBindings") return ours(&SuggestInteractionProfileBindings);
        if (n == "xrCreateActionSpace") return ours(&CreateActionSpace);
        if (n == "xrDestroySpace") return ours(&DestroySpace);
        if (n == "xrDestroyAction") return ours(&DestroyAction);
        if (n == "xrLocateSpace") return ours(&LocateSpace);
      }
    }
  }
  return inst->GetInstanceProcAddr(instance, name, fn);
}

template <class PFN>
void load(const InstanceData& d, const char* name, PFN& dst) {
  PFN_xrVoidFunction f = nullptr;
  if (XR_SUCCEEDED(d.GetInstanceProcAddr(d.instance, name, &f))) dst = reinterpret_cast<PFN>(f);
  else dst = nullptr;
}

// XR_EXT_hand_interaction's functions and paths for the layer; false (its poses pass
// through) where the runtime lacks one. May throw (allocation): the caller catches.
bool load_hand_interaction(InstanceData& d) {
  PFN_xrStringToPath to_path = nullptr;
  load(d, "xrStringToPath", to_path);
  load(d, "xrSuggestInteractionProfileBindings", d.SuggestInteractionProfileBindings);
  load(d, "xrCreateActionSpace", d.CreateActionSpace);
  load(d, "xrDestroyAction", d.DestroyAction);
  load(d, "xrGetCurrentInteractionProfile", d.GetCurrentInteractionProfile);
  bool ok = to_path && d.SuggestInteractionProfileBindings && d.CreateActionSpace && d.DestroyAction &&
            d.GetCurrentInteractionProfile;
  const auto path = [&](const char* str, XrPath& out) { ok = ok && to_path(d.instance, str, &out) == XR_SUCCESS; };
  path("/interaction_profiles/ext/hand_interaction_ext", d.hand_profile);
  constexpr std::array<const char*, 2> kHands = {"/user/hand/left", "/user/hand/right"};
  for (size_t h = 0; h < 2; ++h) {
    path(kHands[h], d.user_hand[h]);
    for (size_t k = 0; k < kPoseInputs.size(); ++k)
      path(fmt::format("{}/input/{}/pose", kHands[h], kPoseInputs[k].name).c_str(), d.pose_input[h][k]);
  }
  if (!ok)
    log(LogLevel::Warn, "the runtime lacks the action functions or paths of XR_EXT_hand_interaction: its poses pass "
                        "through as the runtime locates them");
  return ok;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateApiLayerInstance(const XrInstanceCreateInfo* info,
                                                      const XrApiLayerCreateInfo* layerInfo,
                                                      XrInstance* instance) noexcept {
  if (!info || !layerInfo || !instance || !layerInfo->nextInfo ||
      layerInfo->structType != XR_LOADER_INTERFACE_STRUCT_API_LAYER_CREATE_INFO ||
      layerInfo->nextInfo->structType != XR_LOADER_INTERFACE_STRUCT_API_LAYER_NEXT_INFO ||
      std::strcmp(layerInfo->nextInfo->layerName, kLayerName) != 0 || !layerInfo->nextInfo->nextCreateApiLayerInstance ||
      !layerInfo->nextInfo->nextGetInstanceProcAddr)
    return XR_ERROR_INITIALIZATION_FAILED;
  XrApiLayerCreateInfo down = *layerInfo;
  down.nextInfo = layerInfo->nextInfo->next;
  // Our own extension is ours to answer: the layers and runtime below never see it.
  std::vector<const char*> down_extensions;
  bool raw_joints = false, app_timespec = false, hand_tracking = false, data_source = false, fb_capsules = false,
       fb_aim = false, fb_mesh = false, hand_interaction = false;
  try {
    for (uint32_t i = 0; i < info->enabledExtensionCount; ++i) {
      const std::string_view name(info->enabledExtensionNames[i]);
      if (name == XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME) {
        raw_joints = true;
        continue;
      }
      if (name == XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME) app_timespec = true;
      if (name == XR_EXT_HAND_TRACKING_EXTENSION_NAME) hand_tracking = true;
      if (name == XR_EXT_HAND_TRACKING_DATA_SOURCE_EXTENSION_NAME) data_source = true;
      if (name == XR_FB_HAND_TRACKING_CAPSULES_EXTENSION_NAME) fb_capsules = true;
      if (name == XR_FB_HAND_TRACKING_AIM_EXTENSION_NAME) fb_aim = true;
      if (name == XR_FB_HAND_TRACKING_MESH_EXTENSION_NAME) fb_mesh = true;
      if (name == kHandInteractionExtension) hand_interaction = true;
      down_extensions.push_back(info->enabledExtensionNames[i]);
    }
    // The runtime's clock for the layer, when the runtime has it (else created without).
    if (!app_timespec) down_extensions.push_back(XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME);
  } catch (...) {
    return XR_ERROR_OUT_OF_MEMORY;
  }
  XrInstanceCreateInfo down_info = *info;
  down_info.enabledExtensionCount = static_cast<uint32_t>(down_extensions.size());
  down_info.enabledExtensionNames = down_extensions.data();
  XrResult res = layerInfo->nextInfo->nextCreateApiLayerInstance(&down_info, &down, instance);
  bool have_timespec = XR_SUCCEEDED(res);
  if (res == XR_ERROR_EXTENSION_NOT_PRESENT && !app_timespec) {
    down_info.enabledExtensionCount -= 1;
    res = layerInfo->nextInfo->nextCreateApiLayerInstance(&down_info, &down, instance);
    have_timespec = false;
  }
  if (XR_FAILED(res)) return res;
  try {
    auto d = std::make_shared<InstanceData>();
    d->instance = *instance;
    d->GetInstanceProcAddr = layerInfo->nextInfo->nextGetInstanceProcAddr;
    load(*d, "xrDestroyInstance", d->DestroyInstance);
    load(*d, "xrCreateSession", d->CreateSession);
    load(*d, "xrDestroySession", d->DestroySession);
    load(*d, "xrCreateReferenceSpace", d->CreateReferenceSpace);
    load(*d, "xrDestroySpace", d->DestroySpace);
    load(*d, "xrLocateSpace", d->LocateSpace);
    load(*d, "xrPollEvent", d->PollEvent);
    d->hand_tracking = hand_tracking;
    d->data_source = data_source;
    d->fb_capsules = fb_capsules;
    d->fb_aim = fb_aim;
    d->fb_mesh = fb_mesh;
    d->raw_joints = raw_joints && d->hand_tracking;
    d->app_timespec = app_timespec;
    if (have_timespec) load(*d, "xrConvertTimespecTimeToTimeKHR", d->ConvertTimespecTimeToTimeKHR);
    if (d->hand_tracking) {
      load(*d, "xrCreateHandTrackerEXT", d->CreateHandTrackerEXT);
      load(*d, "xrDestroyHandTrackerEXT", d->DestroyHandTrackerEXT);
      load(*d, "xrLocateHandJointsEXT", d->LocateHandJointsEXT);
    }
    if (d->hand_tracking && hand_interaction) d->hand_interaction = load_hand_interaction(*d);
    LoadedConfig loaded = load_layer_config();
    d->config = std::move(loaded.config);
    g_log_level = static_cast<int>(d->config.log_level);
    for (const auto& w : loaded.warnings) log(LogLevel::Warn, fmt::format("configuration: {} (ignored)", w));
    for (const auto& m : loaded.engine_messages) log(m.level, m.text);
    d->tuning = std::make_unique<HandTuning>(d->config, [](const std::string& text, bool warning) {
      if (warning) log(LogLevel::Warn, fmt::format("configuration: {} (ignored)", text));
      else log(LogLevel::Info, text);
    });
    if (!d->DestroyInstance || !d->LocateSpace || !d->CreateReferenceSpace || !d->DestroySpace) {
      log(LogLevel::Warn, "runtime lacks core space functions: passing everything through");
      d->config.mode = Mode::Off;
    }
    log(LogLevel::Info, fmt::format("{} build of revision {}, mode {}, engine {}, horizon {} ms, hand tracking {}",
                                    HS_LAYER_ISA, hs::source_revision(),
                                    mode_name(d->config.mode),
                                    engine_name(d->config),
                                    static_cast<double>(d->config.horizon_ns) * 1e-6,
                                    d->hand_tracking ? "enabled by the app" : "not enabled by the app"));
    if (!d->config.model_path.empty() && !is_network(d->config.filter.method))
      log(LogLevel::Info, fmt::format("model '{}' is not used by the classical engines", d->config.model_path));
    std::unique_lock lock(reg().mu);
    reg().instances[*instance] = std::move(d);
  } catch (...) {
    PFN_xrVoidFunction f = nullptr;
    if (XR_SUCCEEDED(layerInfo->nextInfo->nextGetInstanceProcAddr(*instance, "xrDestroyInstance", &f)) && f)
      reinterpret_cast<PFN_xrDestroyInstance>(f)(*instance);
    *instance = XR_NULL_HANDLE;
    return XR_ERROR_RUNTIME_FAILURE;
  }
  return res;
}

}  // namespace
}  // namespace hs::layer

#ifdef HS_LAYER_V3_FILE
namespace hs::layer {
namespace {
using NegotiateFn = XrResult(XRAPI_PTR*)(const XrNegotiateLoaderInfo*, const char*, XrNegotiateApiLayerRequest*);
std::atomic<bool> g_logged_variant{false};

// This baseline build hands the loader over to the x86-64-v3 build beside it (AVX2/FMA:
// the Multi-STGAE step about 1.8x faster) when the CPU has that level. Only this file's
// negotiate function runs before the check, in code built for any x86-64; the other
// build is loaded only on a CPU that can run it. HANDSTEADY_ISA=baseline keeps this one.
NegotiateFn faster_build() noexcept {
  const char* isa = std::getenv("HANDSTEADY_ISA");
  if (isa && std::string_view(isa) == "baseline") return nullptr;
  __builtin_cpu_init();
  if (!__builtin_cpu_supports("x86-64-v3")) return nullptr;
  Dl_info info{};
  if (dladdr(reinterpret_cast<const void*>(&faster_build), &info) == 0 || !info.dli_fname) return nullptr;
  const std::string path = (std::filesystem::path(info.dli_fname).parent_path() / HS_LAYER_V3_FILE).string();
  void* lib = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!lib) {
    const char* err = dlerror();
    log_once(g_logged_variant, LogLevel::Warn,
             fmt::format("x86-64-v3 build not loaded ({}): using the baseline build", err ? err : path));
    return nullptr;
  }
  return reinterpret_cast<NegotiateFn>(dlsym(lib, "xrNegotiateLoaderApiLayerInterface"));
}
}  // namespace
}  // namespace hs::layer
#endif

extern "C" __attribute__((visibility("default"))) XrResult XRAPI_CALL xrNegotiateLoaderApiLayerInterface(
    const XrNegotiateLoaderInfo* loaderInfo, const char* layerName, XrNegotiateApiLayerRequest* request) {
  if (!loaderInfo || !request || loaderInfo->structType != XR_LOADER_INTERFACE_STRUCT_LOADER_INFO ||
      loaderInfo->structVersion != XR_LOADER_INFO_STRUCT_VERSION || loaderInfo->structSize != sizeof(XrNegotiateLoaderInfo) ||
      request->structType != XR_LOADER_INTERFACE_STRUCT_API_LAYER_REQUEST ||
      request->structVersion != XR_API_LAYER_INFO_STRUCT_VERSION ||
      request->structSize != sizeof(XrNegotiateApiLayerRequest))
    return XR_ERROR_INITIALIZATION_FAILED;
  if (layerName && std::strcmp(layerName, hs::layer::kLayerName) != 0) return XR_ERROR_INITIALIZATION_FAILED;
#ifdef HS_LAYER_V3_FILE
  static const auto faster = hs::layer::faster_build();
  if (faster) return faster(loaderInfo, layerName, request);
#endif
  if (loaderInfo->minInterfaceVersion > XR_CURRENT_LOADER_API_LAYER_VERSION ||
      loaderInfo->maxInterfaceVersion < XR_CURRENT_LOADER_API_LAYER_VERSION)
    return XR_ERROR_INITIALIZATION_FAILED;
  request->layerInterfaceVersion = XR_CURRENT_LOADER_API_LAYER_VERSION;
  request->layerApiVersion = XR_CURRENT_API_VERSION;
  request->getInstanceProcAddr = &hs::layer::GetInstanceProcAddr;
  request->createApiLayerInstance = &hs::layer::CreateApiLayerInstance;
  return XR_SUCCESS;
}
