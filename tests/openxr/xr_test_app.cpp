#include "xr_test_app.hpp"

#include "handsteady/synth.hpp"
#include "handsteady_xr/xr_math.hpp"
#include "test_support.hpp"

#include <doctest/doctest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace hs::xrtest {

TrackFiles make_tracks(const std::string& name, double duration_s, double jitter_sd_m, bool with_gap) {
  SynthMotionParams p;
  p.duration_s = duration_s;
  p.rate_hz = 90.0;
  Track clean = synth_track(p, 7);
  if (with_gap) {
    // The right hand leaves the view for a second in the middle.
    for (auto& row : clean.rows)
      if (row.hand == Hand::Right && row.t > 0.4 * duration_s && row.t < 0.4 * duration_s + 1.0)
        row.pos = untracked_pose();
  }
  return make_tracks_from(name, std::move(clean), jitter_sd_m);
}

TrackFiles make_tracks_from(const std::string& name, Track clean, double jitter_sd_m) {
  TrackFiles f;
  f.dir = hs::test::temp_dir("openxr_" + name);
  f.clean = std::move(clean);
  CorruptionConfig c = corruption_preset("tracker");
  c.tracker.jitter_sd_m = jitter_sd_m;
  c.tracker.hand_drop_rate_hz = 0.0;  // dropouts are tested separately (with_gap)
  f.noisy = corrupt_track(f.clean, c, 11);
  f.clean_csv = f.dir / "clean.csv";
  f.noisy_csv = f.dir / "noisy.csv";
  write_track_csv(f.clean, f.clean_csv);
  write_track_csv(f.noisy, f.noisy_csv);
  // Read back what the runtime will read, so truth and replay use identical numbers.
  f.clean = read_track_csv(f.clean_csv);
  f.noisy = read_track_csv(f.noisy_csv);
  for (Hand h : {Hand::Left, Hand::Right}) {
    f.clean_series[static_cast<int>(h)] = hand_series(f.clean, h);
    f.noisy_series[static_cast<int>(h)] = hand_series(f.noisy, h);
  }
  f.t0 = std::min(f.noisy_series[0].t.front(), f.noisy_series[1].t.front());
  return f;
}

void set_env(const char* name, const std::string& value) { ::setenv(name, value.c_str(), 1); }
void unset_env(const char* name) { ::unsetenv(name); }

void reset_env(const TrackFiles& files) {
  for (const char* v : {"XR_API_LAYER_PATH", "XR_ENABLE_API_LAYERS", "XDG_DATA_HOME", "XDG_DATA_DIRS",
                        "XR_CORE_VALIDATION_EXPORT_TYPE", "XR_CORE_VALIDATION_FILE_NAME",
                        "DISABLE_XR_APILAYER_NOVENDOR_handsteady", "HANDSTEADY_CONFIG", "HANDSTEADY_MODE",
                        "HANDSTEADY_METHOD", "HANDSTEADY_MODEL", "HANDSTEADY_HORIZON_MS", "HANDSTEADY_STGAE_PHASES", "HANDSTEADY_LOG",
                        "HANDSTEADY_RECORD", "HANDSTEADY_ISA", "HANDSTEADY_SHIM_CORRUPT", "HANDSTEADY_SHIM_CLOCK",
                        "HANDSTEADY_SHIM_LATENCY_MS", "HANDSTEADY_SHIM_FUTURE", "HANDSTEADY_SHIM_HEAD_MOTION",
                        "HANDSTEADY_SHIM_FAULTS", "HANDSTEADY_SHIM_CONTROLLER", "HANDSTEADY_SHIM_RECENTER",
                        "HANDSTEADY_SHIM_FRAMES", "HANDSTEADY_SHIM_SPACE_VELOCITY", "HANDSTEADY_SHIM_EPOCH_MS",
                        "HANDSTEADY_WORKER", "HANDSTEADY_SMOOTHING",
                        "HANDSTEADY_LEFT_SMOOTHING", "HANDSTEADY_RIGHT_SMOOTHING", "HANDSTEADY_LEFT_HORIZON_MS",
                        "HANDSTEADY_RIGHT_HORIZON_MS", "HANDSTEADY_MAX_HORIZON_MS"})
    unset_env(v);
  // Keep system implicit layers out: the tests choose their layers.
  set_env("XDG_DATA_HOME", (files.dir / "xdg-empty").string());
  set_env("XDG_DATA_DIRS", (files.dir / "xdg-empty").string());
  set_env("XR_RUNTIME_JSON", HS_REPLAY_RUNTIME_JSON);
  set_env("HANDSTEADY_SHIM_TRACK", files.noisy_csv.string());
  set_env("HANDSTEADY_SHIM_CLOCK", "sim:11.111111");
  // The layer-mechanics tests measure the classical engine; without this the layer would
  // pick the shipped model (through the build tree's link to models/). test_openxr_stgae
  // covers that default.
  set_env("HANDSTEADY_METHOD", "oneeuro");
}

void enable_layers(const std::vector<std::string>& names) {
  set_env("XR_API_LAYER_PATH", std::string(HS_LAYER_DIR) + ":/usr/share/openxr/1/api_layers/explicit.d");
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ":") + n;
  set_env("XR_ENABLE_API_LAYERS", list);
}

void install_implicit_layer(const std::filesystem::path& xdg) {
  const auto dir = xdg / "openxr" / "1" / "api_layers" / "implicit.d";
  std::filesystem::create_directories(dir);
  std::filesystem::copy_file(HS_LAYER_IMPLICIT_MANIFEST, dir / "XrApiLayer_handsteady.json",
                             std::filesystem::copy_options::overwrite_existing);
  set_env("XDG_DATA_HOME", xdg.string());
}

double track_time(const TrackFiles& f, XrTime t) { return f.t0 + static_cast<double>(t - kShimEpochNs) * 1e-9; }

namespace {
template <class PFN>
PFN proc(XrInstance instance, const char* name) {
  PFN_xrVoidFunction fn = nullptr;
  REQUIRE(xrGetInstanceProcAddr(instance, name, &fn) == XR_SUCCESS);
  REQUIRE(reinterpret_cast<void*>(fn) != nullptr);
  return reinterpret_cast<PFN>(fn);
}
}  // namespace

XrResult create_instance(const std::vector<const char*>& extensions, XrInstance& instance) {
  XrInstanceCreateInfo ci{};
  ci.type = XR_TYPE_INSTANCE_CREATE_INFO;
  std::snprintf(ci.applicationInfo.applicationName, XR_MAX_APPLICATION_NAME_SIZE, "handsteady-test");
  ci.applicationInfo.apiVersion = XR_CURRENT_API_VERSION;
  ci.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  ci.enabledExtensionNames = extensions.data();
  return xrCreateInstance(&ci, &instance);
}

App::App(bool hand_tracking, const std::vector<const char*>& extra_extensions) {
  std::vector<const char*> ext = {XR_MND_HEADLESS_EXTENSION_NAME};
  if (hand_tracking) ext.push_back(XR_EXT_HAND_TRACKING_EXTENSION_NAME);
  ext.insert(ext.end(), extra_extensions.begin(), extra_extensions.end());
  REQUIRE(create_instance(ext, instance) == XR_SUCCESS);

  XrSystemGetInfo gi{};
  gi.type = XR_TYPE_SYSTEM_GET_INFO;
  gi.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
  XrSystemId system = XR_NULL_SYSTEM_ID;
  REQUIRE(xrGetSystem(instance, &gi, &system) == XR_SUCCESS);
  XrSystemHandTrackingPropertiesEXT htp{};
  htp.type = XR_TYPE_SYSTEM_HAND_TRACKING_PROPERTIES_EXT;
  XrSystemProperties sp{};
  sp.type = XR_TYPE_SYSTEM_PROPERTIES;
  sp.next = &htp;
  REQUIRE(xrGetSystemProperties(instance, system, &sp) == XR_SUCCESS);
  CHECK(htp.supportsHandTracking == (hand_tracking ? XR_TRUE : XR_FALSE));

  XrSessionCreateInfo sci{};
  sci.type = XR_TYPE_SESSION_CREATE_INFO;
  sci.systemId = system;
  REQUIRE(xrCreateSession(instance, &sci, &session) == XR_SUCCESS);
  poll_until(XR_SESSION_STATE_READY);
  XrSessionBeginInfo bi{};
  bi.type = XR_TYPE_SESSION_BEGIN_INFO;
  bi.primaryViewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
  REQUIRE(xrBeginSession(session, &bi) == XR_SUCCESS);
  poll_until(XR_SESSION_STATE_FOCUSED);

  for (auto [type, space] : {std::pair{XR_REFERENCE_SPACE_TYPE_LOCAL, &local},
                             std::pair{XR_REFERENCE_SPACE_TYPE_STAGE, &stage},
                             std::pair{XR_REFERENCE_SPACE_TYPE_VIEW, &view}}) {
    XrReferenceSpaceCreateInfo rci{};
    rci.type = XR_TYPE_REFERENCE_SPACE_CREATE_INFO;
    rci.referenceSpaceType = type;
    rci.poseInReferenceSpace.orientation.w = 1.0f;
    REQUIRE(xrCreateReferenceSpace(session, &rci, space) == XR_SUCCESS);
  }
  if (!hand_tracking) return;
  create_tracker = proc<PFN_xrCreateHandTrackerEXT>(instance, "xrCreateHandTrackerEXT");
  destroy_tracker = proc<PFN_xrDestroyHandTrackerEXT>(instance, "xrDestroyHandTrackerEXT");
  locate_joints = proc<PFN_xrLocateHandJointsEXT>(instance, "xrLocateHandJointsEXT");
  for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
    XrHandTrackerCreateInfoEXT hci{};
    hci.type = XR_TYPE_HAND_TRACKER_CREATE_INFO_EXT;
    hci.hand = hand;
    hci.handJointSet = XR_HAND_JOINT_SET_DEFAULT_EXT;
    REQUIRE(create_tracker(session, &hci, &trackers[hand - 1]) == XR_SUCCESS);
  }
}

void App::poll_until(XrSessionState state) {
  for (int i = 0; i < 100; ++i) {
    XrEventDataBuffer ev{};
    ev.type = XR_TYPE_EVENT_DATA_BUFFER;
    const XrResult r = xrPollEvent(instance, &ev);
    REQUIRE(XR_SUCCEEDED(r));
    if (r == XR_EVENT_UNAVAILABLE) break;
    if (ev.type == XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED &&
        reinterpret_cast<const XrEventDataSessionStateChanged*>(&ev)->state == state)
      return;
  }
  FAIL("session never reached state " << state);
}

std::vector<XrEventDataBuffer> App::poll_events() {
  std::vector<XrEventDataBuffer> out;
  for (;;) {
    XrEventDataBuffer ev{};
    ev.type = XR_TYPE_EVENT_DATA_BUFFER;
    const XrResult r = xrPollEvent(instance, &ev);
    REQUIRE(XR_SUCCEEDED(r));
    if (r == XR_EVENT_UNAVAILABLE) return out;
    out.push_back(ev);
  }
}

XrTime App::frame() {
  XrFrameWaitInfo wi{};
  wi.type = XR_TYPE_FRAME_WAIT_INFO;
  XrFrameState fs{};
  fs.type = XR_TYPE_FRAME_STATE;
  REQUIRE(xrWaitFrame(session, &wi, &fs) == XR_SUCCESS);
  CHECK(fs.shouldRender == XR_FALSE);
  XrFrameBeginInfo bi{};
  bi.type = XR_TYPE_FRAME_BEGIN_INFO;
  REQUIRE(xrBeginFrame(session, &bi) == XR_SUCCESS);
  XrFrameEndInfo ei{};
  ei.type = XR_TYPE_FRAME_END_INFO;
  ei.displayTime = fs.predictedDisplayTime;
  ei.environmentBlendMode = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
  REQUIRE(xrEndFrame(session, &ei) == XR_SUCCESS);
  return fs.predictedDisplayTime;
}

Joints App::locate(XrHandEXT hand, XrSpace base, XrTime time, bool velocities, uint32_t joint_count) const {
  return locate_with(locate_joints, hand, base, time, velocities, joint_count);
}

PFN_xrLocateHandJointsEXT App::raw_locate() const {
  PFN_xrVoidFunction fn = nullptr;
  REQUIRE(xrGetInstanceProcAddr(instance, "xrLocateRawHandJointsNOVENDOR", &fn) == XR_SUCCESS);
  return reinterpret_cast<PFN_xrLocateHandJointsEXT>(fn);
}

Joints App::locate_raw(XrHandEXT hand, XrSpace base, XrTime time) const {
  return locate_with(raw_locate(), hand, base, time, false, XR_HAND_JOINT_COUNT_EXT);
}

XrResult locate_chained(PFN_xrLocateHandJointsEXT fn, XrHandTrackerEXT tracker, XrSpace base, XrTime time, void* next,
                        uint32_t count, XrHandJointLocationEXT* loc, XrBool32& active) {
  XrHandJointLocationsEXT out{XR_TYPE_HAND_JOINT_LOCATIONS_EXT, next, XR_FALSE, count, loc};
  XrHandJointsLocateInfoEXT info{XR_TYPE_HAND_JOINTS_LOCATE_INFO_EXT, nullptr, base, time};
  const XrResult res = fn(tracker, &info, &out);
  active = out.isActive;
  return res;
}

Joints App::locate_with(PFN_xrLocateHandJointsEXT fn, XrHandEXT hand, XrSpace base, XrTime time, bool velocities,
                        uint32_t joint_count) const {
  Joints j;
  XrHandJointVelocitiesEXT vel{XR_TYPE_HAND_JOINT_VELOCITIES_EXT, nullptr, XR_HAND_JOINT_COUNT_EXT, j.vel.data()};
  j.result = locate_chained(fn, trackers[hand - 1], base, time, velocities ? &vel : nullptr, joint_count, j.loc.data(),
                            j.active);
  return j;
}

XrPosef App::space_pose(XrSpace space, XrSpace base, XrTime time) const {
  XrSpaceLocation loc{};
  loc.type = XR_TYPE_SPACE_LOCATION;
  REQUIRE(xrLocateSpace(space, base, time, &loc) == XR_SUCCESS);
  REQUIRE((loc.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) != 0);
  return loc.pose;
}

void App::shutdown(bool keep_trackers) {
  if (shut_) return;
  shut_ = true;
  if (!keep_trackers && destroy_tracker)
    for (auto& t : trackers) CHECK(destroy_tracker(t) == XR_SUCCESS);
  CHECK(xrRequestExitSession(session) == XR_SUCCESS);
  poll_until(XR_SESSION_STATE_STOPPING);
  CHECK(xrEndSession(session) == XR_SUCCESS);
  poll_until(XR_SESSION_STATE_EXITING);
  for (XrSpace s : {local, stage, view}) CHECK(xrDestroySpace(s) == XR_SUCCESS);
  CHECK(xrDestroySession(session) == XR_SUCCESS);
  CHECK(xrDestroyInstance(instance) == XR_SUCCESS);
}

App::~App() {
  if (!shut_ && instance != XR_NULL_HANDLE) xrDestroyInstance(instance);
}

void accumulate_error(const Joints& j, const XrPosef& local_from_base, const Pose& truth, double& sum, long& count) {
  const xr::Rigid m = xr::to_rigid(local_from_base);
  for (int k = 0; k < kJointCount; ++k) {
    if (!joint_tracked(truth, k) || !(j.loc[k].locationFlags & XR_SPACE_LOCATION_POSITION_TRACKED_BIT)) continue;
    const Eigen::Vector3d p = m * xr::to_eigen(j.loc[k].pose.position);
    sum += (p - truth.row(k).transpose()).norm();
    ++count;
  }
}

void accumulate_error(const Pose& pose, const Pose& truth, double& sum, long& count) {
  for (int k = 0; k < kJointCount; ++k) {
    if (!joint_tracked(truth, k) || !joint_tracked(pose, k)) continue;
    sum += (pose.row(k) - truth.row(k)).norm();
    ++count;
  }
}

namespace {
XrPath to_path(XrInstance instance, const std::string& str) {
  XrPath p = XR_NULL_PATH;
  REQUIRE(xrStringToPath(instance, str.c_str(), &p) == XR_SUCCESS);
  return p;
}
}  // namespace

HandInteraction::HandInteraction(const App& app, bool with_palm) {
  constexpr std::array<const char*, 4> kNames = {"grip", "aim", "pinch_ext", "poke_ext"};
  XrActionSetCreateInfo si{XR_TYPE_ACTION_SET_CREATE_INFO, nullptr, "hands", "Hands", 0};
  REQUIRE(xrCreateActionSet(app.instance, &si, &set) == XR_SUCCESS);
  const std::array<XrPath, 2> hands = {to_path(app.instance, "/user/hand/left"), to_path(app.instance, "/user/hand/right")};
  std::vector<XrActionSuggestedBinding> bindings;
  for (size_t k = 0; k < actions.size(); ++k) {
    XrActionCreateInfo ai{XR_TYPE_ACTION_CREATE_INFO, nullptr, "", XR_ACTION_TYPE_POSE_INPUT, 2, hands.data(), ""};
    std::snprintf(ai.actionName, sizeof(ai.actionName), "%s", kNames[k]);
    std::snprintf(ai.localizedActionName, sizeof(ai.localizedActionName), "%s", kNames[k]);
    REQUIRE(xrCreateAction(set, &ai, &actions[k]) == XR_SUCCESS);
    for (const char* side : {"left", "right"})
      bindings.push_back(
          {actions[k], to_path(app.instance, std::string("/user/hand/") + side + "/input/" + kNames[k] + "/pose")});
  }
  if (with_palm) {
    XrActionCreateInfo ai{XR_TYPE_ACTION_CREATE_INFO, nullptr, "palm", XR_ACTION_TYPE_POSE_INPUT, 2, hands.data(), "Palm"};
    REQUIRE(xrCreateAction(set, &ai, &palm_action) == XR_SUCCESS);
    for (const char* side : {"left", "right"})
      bindings.push_back({palm_action, to_path(app.instance, std::string("/user/hand/") + side + "/input/palm_ext/pose")});
  }
  const XrInteractionProfileSuggestedBinding sb{XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING, nullptr,
                                                to_path(app.instance, "/interaction_profiles/ext/hand_interaction_ext"),
                                                static_cast<uint32_t>(bindings.size()), bindings.data()};
  REQUIRE(xrSuggestInteractionProfileBindings(app.instance, &sb) == XR_SUCCESS);
  const XrSessionActionSetsAttachInfo at{XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO, nullptr, 1, &set};
  REQUIRE(xrAttachSessionActionSets(app.session, &at) == XR_SUCCESS);
  for (size_t h = 0; h < 2; ++h) {
    for (size_t k = 0; k < actions.size(); ++k) {
      const XrActionSpaceCreateInfo ci{XR_TYPE_ACTION_SPACE_CREATE_INFO, nullptr, actions[k], hands[h],
                                       {{0, 0, 0, 1}, {0, 0, 0}}};
      REQUIRE(xrCreateActionSpace(app.session, &ci, &spaces[h][k]) == XR_SUCCESS);
    }
    const XrActionSpaceCreateInfo ci{XR_TYPE_ACTION_SPACE_CREATE_INFO, nullptr, actions[kPoke], hands[h], offset};
    REQUIRE(xrCreateActionSpace(app.session, &ci, &poke_offset[h]) == XR_SUCCESS);
    if (with_palm) {
      const XrActionSpaceCreateInfo pi{XR_TYPE_ACTION_SPACE_CREATE_INFO, nullptr, palm_action, hands[h],
                                       {{0, 0, 0, 1}, {0, 0, 0}}};
      REQUIRE(xrCreateActionSpace(app.session, &pi, &palm[h]) == XR_SUCCESS);
    }
  }
}

void HandInteraction::sync(const App& app) const {
  const XrActiveActionSet active{set, XR_NULL_PATH};
  const XrActionsSyncInfo si{XR_TYPE_ACTIONS_SYNC_INFO, nullptr, 1, &active};
  REQUIRE(xrSyncActions(app.session, &si) == XR_SUCCESS);
}

}  // namespace hs::xrtest
