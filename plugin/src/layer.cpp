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
#include <openxr/openxr.h>

#include "handsteady/track.hpp"
#include "handsteady_xr/loader_negotiation.hpp"
#include "handsteady_xr/raw_joints_ext.h"
#include "handsteady_xr/xr_math.hpp"
#include "layer_config.hpp"
#include "tracker_filter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
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
    g_logged_world_locate{false}, g_logged_record{false}, g_logged_engine{false};

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
  bool hand_tracking = false;  // the app enabled XR_EXT_hand_tracking
  bool raw_joints = false;     // the app enabled our XR_NOVENDOR_handsteady_raw_joints
  LayerConfig config;
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
  XrSpace world = XR_NULL_HANDLE;  // the layer's world-fixed space (LOCAL)
  // One state per joint motion range (XR_EXT_hand_joints_motion_range).
  std::array<std::unique_ptr<TrackerFilter>, 2> filters;
  std::atomic<bool> passthrough{false};
  std::unique_ptr<Recording> recording;
  int serial = 0;
};

struct Registry {
  std::shared_mutex mu;
  std::unordered_map<XrInstance, std::shared_ptr<InstanceData>> instances;
  std::unordered_map<XrSession, std::shared_ptr<InstanceData>> sessions;
  std::unordered_map<XrHandTrackerEXT, std::shared_ptr<TrackerData>> trackers;
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

XRAPI_ATTR XrResult XRAPI_CALL CreateHandTrackerEXT(XrSession session, const XrHandTrackerCreateInfoEXT* info,
                                                    XrHandTrackerEXT* tracker) noexcept {
  const auto inst = find_shared(reg().sessions, session);
  if (!inst || !inst->CreateHandTrackerEXT) return XR_ERROR_HANDLE_INVALID;
  const XrResult res = inst->CreateHandTrackerEXT(session, info, tracker);
  if (XR_FAILED(res)) return res;
  try {
    auto t = std::make_shared<TrackerData>();
    t->inst = inst;
    t->handle = *tracker;
    t->session = session;
    t->hand = info->hand;
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
  if (!t) return XR_ERROR_HANDLE_INVALID;
  release_tracker(*t);
  return t->inst->DestroyHandTrackerEXT(tracker);
}

bool position_usable(const XrHandJointLocationEXT& j) {
  constexpr XrSpaceLocationFlags need = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT;
  if ((j.locationFlags & need) != need || !xr::finite(j.pose.position)) return false;
  // Absurd magnitudes are runtime garbage, not hands.
  constexpr float kMax = 1000.0f;
  return std::fabs(j.pose.position.x) < kMax && std::fabs(j.pose.position.y) < kMax && std::fabs(j.pose.position.z) < kMax;
}

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

// Replaces the runtime's answer in `out` (already filled for the app) by the engine's.
// Returns without touching `out` whenever something needed is missing.
void filter_answer(TrackerData& t, const XrHandJointsLocateInfoEXT& info, XrHandJointLocationsEXT& out) noexcept {
  const InstanceData& inst = *t.inst;
  const auto* range =
      find_in_chain<XrHandJointsMotionRangeInfoEXT, XR_TYPE_HAND_JOINTS_MOTION_RANGE_INFO_EXT>(info.next);
  const int state_index =
      range && range->handJointsMotionRange == XR_HAND_JOINTS_MOTION_RANGE_CONFORMING_TO_CONTROLLER_EXT ? 1 : 0;
  TrackerFilter* filter = t.filters[state_index].get();
  if (!filter) return;
  auto* app_vel = find_in_chain<XrHandJointVelocitiesEXT, XR_TYPE_HAND_JOINT_VELOCITIES_EXT>(out.next);
  if (app_vel && (app_vel->jointCount != XR_HAND_JOINT_COUNT_EXT || !app_vel->jointVelocities)) app_vel = nullptr;

  // The runtime's joints in the world-fixed space at the sample time (= the asked time
  // when denoising; horizon earlier when predicting, so the engine extrapolates).
  XrTime sample_time = info.time;
  if (inst.config.mode == Mode::Predict && info.time - inst.config.horizon_ns > 0)
    sample_time = info.time - inst.config.horizon_ns;
  std::array<XrHandJointLocationEXT, XR_HAND_JOINT_COUNT_EXT> wj{};
  std::array<XrHandJointVelocityEXT, XR_HAND_JOINT_COUNT_EXT> wvj{};
  XrHandJointVelocitiesEXT wv{XR_TYPE_HAND_JOINT_VELOCITIES_EXT, nullptr, XR_HAND_JOINT_COUNT_EXT, wvj.data()};
  XrHandJointLocationsEXT wl{XR_TYPE_HAND_JOINT_LOCATIONS_EXT, app_vel ? &wv : nullptr, XR_FALSE,
                             XR_HAND_JOINT_COUNT_EXT, wj.data()};
  XrHandJointsLocateInfoEXT wi{XR_TYPE_HAND_JOINTS_LOCATE_INFO_EXT, info.next, t.world, sample_time};
  const XrResult wres = inst.LocateHandJointsEXT(t.handle, &wi, &wl);
  if (XR_FAILED(wres)) {
    log_once(g_logged_world_locate, LogLevel::Warn,
             fmt::format("runtime failed to locate joints in the layer's space (result {}): passing through",
                         static_cast<int>(wres)));
    return;
  }
  Pose observed;
  bool any = false;
  for (int j = 0; j < kJointCount; ++j) {
    if (wl.isActive && position_usable(wj[j])) {
      observed.row(j) = xr::to_eigen(wj[j].pose.position).transpose();
      any = true;
    } else {
      observed.row(j).setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  }
  Pose est;
  Velocity est_vel;
  const bool have = filter->update(sample_time, any ? &observed : nullptr, info.time, est, est_vel);
  if (t.recording) {
    std::lock_guard lock(t.recording->mu);
    if (any) append_row(t.recording->raw, sample_time, observed);
    if (have) append_row(t.recording->filtered, info.time, est);
  }
  if (!have) return;

  // World-fixed space -> the app's base space at the asked time.
  XrSpaceLocation wloc{};
  wloc.type = XR_TYPE_SPACE_LOCATION;
  const XrResult lres = inst.LocateSpace(t.world, info.baseSpace, info.time, &wloc);
  constexpr XrSpaceLocationFlags need = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_ORIENTATION_VALID_BIT;
  if (XR_FAILED(lres) || (wloc.locationFlags & need) != need || !xr::finite(wloc.pose.position) ||
      !xr::usable(wloc.pose.orientation)) {
    if (XR_FAILED(lres))
      log_once(g_logged_locate_space, LogLevel::Warn,
               fmt::format("xrLocateSpace failed (result {}): passing through", static_cast<int>(lres)));
    return;
  }
  const xr::Rigid base_from_world = xr::to_rigid(wloc.pose);

  // New positions: joints the runtime reports tracked take the engine's estimate.
  std::array<Eigen::Vector3d, kJointCount> raw, fresh;
  std::array<bool, kJointCount> replaced{};
  for (int j = 0; j < kJointCount; ++j) {
    const XrHandJointLocationEXT& loc = out.jointLocations[j];
    raw[j] = xr::to_eigen(loc.pose.position);
    fresh[j] = raw[j];
    constexpr XrSpaceLocationFlags tracked = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT;
    const Eigen::Vector3d e = est.row(j).transpose();
    if ((loc.locationFlags & tracked) == tracked && e.allFinite()) {
      fresh[j] = base_from_world * e;
      replaced[j] = true;
    }
  }
  // Orientations follow their bones: the smallest rotation taking the runtime's bone
  // direction onto the new one, applied to the runtime's orientation (keeps its twist).
  std::array<XrQuaternionf, kJointCount> orient{};
  for (int j = 0; j < kJointCount; ++j) {
    orient[j] = out.jointLocations[j].pose.orientation;
    const auto [a, b] = xr::kJointBone[j];
    if (!replaced[a] && !replaced[b]) continue;
    const Eigen::Vector3d d_raw = raw[b] - raw[a], d_new = fresh[b] - fresh[a];
    if (!d_raw.allFinite() || !d_new.allFinite() || d_raw.norm() < 1e-6 || d_new.norm() < 1e-6 ||
        !xr::usable(orient[j]))
      continue;
    const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(d_raw, d_new) * xr::to_eigen(orient[j]).normalized();
    orient[j] = xr::to_xr(q.normalized());
  }
  for (int j = 0; j < kJointCount; ++j) {
    out.jointLocations[j].pose.position = xr::to_xr(fresh[j]);
    out.jointLocations[j].pose.orientation = orient[j];
  }
  // Linear velocities: the runtime's (relative to the base space, so base motion stays
  // in) plus the difference between the engine's world velocity and the runtime's.
  if (app_vel && wl.isActive) {
    for (int j = 0; j < kJointCount; ++j) {
      XrHandJointVelocityEXT& v = app_vel->jointVelocities[j];
      const Eigen::Vector3d ev = est_vel.row(j).transpose();
      if (!replaced[j] || !(v.velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) ||
          !(wvj[j].velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) || !ev.allFinite() ||
          !xr::finite(wvj[j].linearVelocity) || !xr::finite(v.linearVelocity))
        continue;
      const Eigen::Vector3d dv = base_from_world.linear() * (ev - xr::to_eigen(wvj[j].linearVelocity));
      v.linearVelocity = xr::to_xr(Eigen::Vector3d(xr::to_eigen(v.linearVelocity) + dv));
    }
  }
}

XRAPI_ATTR XrResult XRAPI_CALL LocateHandJointsEXT(XrHandTrackerEXT tracker, const XrHandJointsLocateInfoEXT* info,
                                                   XrHandJointLocationsEXT* out) noexcept {
  const auto t = find_shared(reg().trackers, tracker);
  if (!t) return XR_ERROR_HANDLE_INVALID;
  const XrResult res = t->inst->LocateHandJointsEXT(tracker, info, out);
  // The runtime validated the arguments; an inactive hand has nothing to filter.
  if (XR_FAILED(res) || t->passthrough.load(std::memory_order_relaxed) || !out->isActive ||
      out->jointCount != XR_HAND_JOINT_COUNT_EXT)
    return res;
  try {
    filter_answer(*t, *info, *out);
  } catch (...) {
    t->passthrough = true;
    log_once(g_logged_internal, LogLevel::Error, "internal failure while filtering: this tracker passes through");
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
  if (!inst) return XR_ERROR_HANDLE_INVALID;
  for (const auto& t : take_trackers([&](const TrackerData& d) { return d.session == session; })) release_tracker(*t);
  {
    std::unique_lock lock(reg().mu);
    reg().sessions.erase(session);
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
  if (n == "xrLocateRawHandJointsNOVENDOR") {
    if (!inst->raw_joints || !inst->LocateHandJointsEXT) {
      *fn = nullptr;
      return XR_ERROR_FUNCTION_UNSUPPORTED;
    }
    return ours(&LocateRawHandJointsNOVENDOR);
  }
  if (inst->hand_tracking && inst->config.mode != Mode::Off) {
    // Hooked only when the app enabled XR_EXT_hand_tracking and the runtime has them.
    const bool have = inst->CreateHandTrackerEXT && inst->DestroyHandTrackerEXT && inst->LocateHandJointsEXT &&
                      inst->CreateSession && inst->DestroySession;
    if (have) {
      if (n == "xrCreateSession") return ours(&CreateSession);
      if (n == "xrDestroySession") return ours(&DestroySession);
      if (n == "xrCreateHandTrackerEXT") return ours(&CreateHandTrackerEXT);
      if (n == "xrDestroyHandTrackerEXT") return ours(&DestroyHandTrackerEXT);
      if (n == "xrLocateHandJointsEXT") return ours(&LocateHandJointsEXT);
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
  bool raw_joints = false;
  try {
    for (uint32_t i = 0; i < info->enabledExtensionCount; ++i) {
      if (std::string_view(info->enabledExtensionNames[i]) == XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME)
        raw_joints = true;
      else
        down_extensions.push_back(info->enabledExtensionNames[i]);
    }
  } catch (...) {
    return XR_ERROR_OUT_OF_MEMORY;
  }
  XrInstanceCreateInfo down_info = *info;
  down_info.enabledExtensionCount = static_cast<uint32_t>(down_extensions.size());
  down_info.enabledExtensionNames = down_extensions.data();
  const XrResult res = layerInfo->nextInfo->nextCreateApiLayerInstance(&down_info, &down, instance);
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
    for (uint32_t i = 0; i < info->enabledExtensionCount; ++i)
      if (std::string_view(info->enabledExtensionNames[i]) == XR_EXT_HAND_TRACKING_EXTENSION_NAME) d->hand_tracking = true;
    d->raw_joints = raw_joints && d->hand_tracking;
    if (d->hand_tracking) {
      load(*d, "xrCreateHandTrackerEXT", d->CreateHandTrackerEXT);
      load(*d, "xrDestroyHandTrackerEXT", d->DestroyHandTrackerEXT);
      load(*d, "xrLocateHandJointsEXT", d->LocateHandJointsEXT);
    }
    LoadedConfig loaded = load_layer_config();
    d->config = std::move(loaded.config);
    g_log_level = static_cast<int>(d->config.log_level);
    for (const auto& w : loaded.warnings) log(LogLevel::Warn, fmt::format("configuration: {} (ignored)", w));
    for (const auto& m : loaded.engine_messages) log(m.level, m.text);
    if (!d->DestroyInstance || !d->LocateSpace || !d->CreateReferenceSpace || !d->DestroySpace) {
      log(LogLevel::Warn, "runtime lacks core space functions: passing everything through");
      d->config.mode = Mode::Off;
    }
    log(LogLevel::Info, fmt::format("{} build, mode {}, engine {}, horizon {} ms, hand tracking {}", HS_LAYER_ISA,
                                    mode_name(d->config.mode),
                                    engine_name(d->config),
                                    static_cast<double>(d->config.horizon_ns) * 1e-6,
                                    d->hand_tracking ? "enabled by the app" : "not enabled by the app"));
    if (!d->config.model_path.empty() && d->config.engine != Engine::Stgae)
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
