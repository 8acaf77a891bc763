// The layer through the real loader: app -> loader -> [core validation] -> handsteady ->
// [core validation] -> replay runtime. Each test case runs in its own process (CTest),
// so each may create its own XrInstance (the 1.0.20 loader allows one at a time).
#include "handsteady/skeleton.hpp"
#include "handsteady/source_revision.hpp"
#include "handsteady/track_ops.hpp"
#include "handsteady_xr/xr_math.hpp"
#include "test_support.hpp"
#include "xr_test_app.hpp"
#include "handsteady_xr/raw_joints_ext.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

using namespace hs;
using namespace hs::xrtest;

namespace {

struct Errors {
  std::array<double, 2> sum{}, raw_sum{};
  std::array<long, 2> n{}, raw_n{};
  double mean(int h) const { return n[h] ? sum[h] / static_cast<double>(n[h]) : std::nan(""); }
  double raw_mean(int h) const { return raw_n[h] ? raw_sum[h] / static_cast<double>(raw_n[h]) : std::nan(""); }
};

// Runs `frames` frames; at each, locates both hands in `base` at the display time and
// compares with the clean track at that time. raw: what the runtime replays (the noisy
// track at `raw_time(T)`). Skips the first 30 frames (filter warm-up).
template <class RawTime>
Errors run_and_measure(App& app, const TrackFiles& f, XrSpace base, int frames, RawTime raw_time) {
  Errors e;
  for (int i = 0; i < frames; ++i) {
    const XrTime T = app.frame();
    for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
      const int h = hand - 1;
      const Joints j = app.locate(hand, base, T);
      REQUIRE(j.result == XR_SUCCESS);
      if (i < 30) continue;
      const Pose truth = interpolate_pose(f.clean_series[h], track_time(f, T));
      accumulate_error(j, app.space_pose(base, app.local, T), truth, e.sum[h], e.n[h]);
      accumulate_error(interpolate_pose(f.noisy_series[h], track_time(f, raw_time(T))), truth, e.raw_sum[h],
                       e.raw_n[h]);
    }
  }
  return e;
}

// Predict mode against a runtime that answers its latest sample 40 ms late (no
// runtime-side prediction): the layer predicts 40 ms ahead. Errors at the display time;
// raw = the runtime's stale answer. The engine is whatever the environment selects.
Errors predict_against_stale_runtime(const TrackFiles& f, int frames) {
  set_env("HANDSTEADY_SHIM_FUTURE", "hold");
  set_env("HANDSTEADY_SHIM_LATENCY_MS", "40");
  set_env("HANDSTEADY_MODE", "predict");
  set_env("HANDSTEADY_HORIZON_MS", "40");
  enable_layers({kLayer});
  App app;
  const Errors e = run_and_measure(app, f, app.local, frames, [](XrTime T) { return T - 40'000'000; });
  app.shutdown();
  return e;
}

std::vector<Joints> record_frames(App& app, int frames) {
  std::vector<Joints> out;
  for (int i = 0; i < frames; ++i) {
    const XrTime T = app.frame();
    for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT})
      for (XrSpace s : {app.local, app.view}) out.push_back(app.locate(hand, s, T, true));
  }
  return out;
}

bool identical(const std::vector<Joints>& a, const std::vector<Joints>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].result != b[i].result || a[i].active != b[i].active ||
        std::memcmp(a[i].loc.data(), b[i].loc.data(), sizeof(a[i].loc)) != 0 ||
        std::memcmp(a[i].vel.data(), b[i].vel.data(), sizeof(a[i].vel)) != 0)
      return false;
  return true;
}

std::vector<Joints> run_recorded(int frames) {
  App app;
  auto r = record_frames(app, frames);
  app.shutdown();
  return r;
}

}  // namespace

TEST_CASE("replay runtime without layer answers the noisy track exactly, in every base space") {
  const TrackFiles f = make_tracks("replay", 2.0);
  reset_env(f);
  set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
  App app;
  for (int i = 0; i < 60; ++i) {
    const XrTime T = app.frame();
    for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
      const Pose noisy = interpolate_pose(f.noisy_series[hand - 1], track_time(f, T));
      for (XrSpace base : {app.local, app.stage, app.view}) {
        const Joints j = app.locate(hand, base, T, true);
        REQUIRE(j.result == XR_SUCCESS);
        REQUIRE(j.active == XR_TRUE);
        const xr::Rigid m = xr::to_rigid(app.space_pose(base, app.local, T));
        for (int k = 0; k < kJointCount; ++k) {
          CHECK((j.loc[k].locationFlags & 0x3) == 0x3);
          if (!joint_tracked(noisy, k)) continue;
          const Eigen::Vector3d p = m * xr::to_eigen(j.loc[k].pose.position);
          CHECK((p - noisy.row(k).transpose()).norm() < 1e-5);
          CHECK(j.loc[k].radius > 0.0f);
        }
      }
    }
  }
  app.shutdown();
}

TEST_CASE("the replay runtime's hand interaction profile (XR_EXT_hand_interaction): poses from the tracked hand once "
          "synced, paths and bindings checked") {
  const TrackFiles f = make_tracks("replay_actions", 1.0);
  reset_env(f);
  set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
  App app(true, {kHandInteractionExt});
  XrPath p = XR_NULL_PATH;
  for (const char* bad : {"user/hand/left", "/user//hand", "/User/hand", "/user/hand/", "/user/./hand"}) {
    CAPTURE(bad);
    CHECK(xrStringToPath(app.instance, bad, &p) == XR_ERROR_PATH_FORMAT_INVALID);
  }
  const HandInteraction hi(app);
  // Not synced yet: no profile current, the poses not active, their spaces not located.
  XrPath left = XR_NULL_PATH, profile = XR_NULL_PATH;
  REQUIRE(xrStringToPath(app.instance, "/user/hand/left", &left) == XR_SUCCESS);
  REQUIRE(xrStringToPath(app.instance, "/interaction_profiles/ext/hand_interaction_ext", &profile) == XR_SUCCESS);
  XrInteractionProfileState state{XR_TYPE_INTERACTION_PROFILE_STATE, nullptr, XR_NULL_PATH};
  REQUIRE(xrGetCurrentInteractionProfile(app.session, left, &state) == XR_SUCCESS);
  CHECK(state.interactionProfile == XR_NULL_PATH);
  XrTime T = app.frame();
  XrSpaceLocation loc{XR_TYPE_SPACE_LOCATION, nullptr, 0, {{0, 0, 0, 1}, {0, 0, 0}}};
  REQUIRE(xrLocateSpace(hi.spaces[0][kPoke], app.local, T, &loc) == XR_SUCCESS);
  CHECK(loc.locationFlags == 0);
  // Bindings are fixed once attached; a path the profile does not have is refused.
  XrActionSet other = XR_NULL_HANDLE;
  XrActionSetCreateInfo si{XR_TYPE_ACTION_SET_CREATE_INFO, nullptr, "other", "Other", 0};
  REQUIRE(xrCreateActionSet(app.instance, &si, &other) == XR_SUCCESS);
  XrAction value = XR_NULL_HANDLE;
  XrActionCreateInfo ai{XR_TYPE_ACTION_CREATE_INFO, nullptr, "squeeze", XR_ACTION_TYPE_FLOAT_INPUT, 0, nullptr, "Squeeze"};
  REQUIRE(xrCreateAction(other, &ai, &value) == XR_SUCCESS);
  XrPath trigger = XR_NULL_PATH;
  REQUIRE(xrStringToPath(app.instance, "/user/hand/left/input/trigger/value", &trigger) == XR_SUCCESS);
  XrActionSuggestedBinding b{value, trigger};
  const XrInteractionProfileSuggestedBinding sb{XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING, nullptr, profile, 1, &b};
  CHECK(xrSuggestInteractionProfileBindings(app.instance, &sb) == XR_ERROR_PATH_UNSUPPORTED);
  // XR_EXT_palm_pose's palm only where the app enabled that extension (not here).
  XrAction palm = XR_NULL_HANDLE;
  XrActionCreateInfo pi{XR_TYPE_ACTION_CREATE_INFO, nullptr, "palm", XR_ACTION_TYPE_POSE_INPUT, 0, nullptr, "Palm"};
  REQUIRE(xrCreateAction(other, &pi, &palm) == XR_SUCCESS);
  XrPath palm_path = XR_NULL_PATH;
  REQUIRE(xrStringToPath(app.instance, "/user/hand/left/input/palm_ext/pose", &palm_path) == XR_SUCCESS);
  const XrActionSuggestedBinding pb{palm, palm_path};
  const XrInteractionProfileSuggestedBinding psb{XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING, nullptr, profile, 1, &pb};
  CHECK(xrSuggestInteractionProfileBindings(app.instance, &psb) == XR_ERROR_PATH_UNSUPPORTED);
  b.action = hi.actions[kGrip];
  CHECK(xrSuggestInteractionProfileBindings(app.instance, &sb) == XR_ERROR_ACTIONSETS_ALREADY_ATTACHED);
  const XrSessionActionSetsAttachInfo at{XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO, nullptr, 1, &other};
  CHECK(xrAttachSessionActionSets(app.session, &at) == XR_ERROR_ACTIONSETS_ALREADY_ATTACHED);
  // Synced: the profile is current for both hands (announced), its poses where the
  // runtime's joints are.
  hi.sync(app);
  const auto events = app.poll_events();
  CHECK(std::count_if(events.begin(), events.end(), [](const XrEventDataBuffer& e) {
          return e.type == XR_TYPE_EVENT_DATA_INTERACTION_PROFILE_CHANGED;
        }) == 1);
  REQUIRE(xrGetCurrentInteractionProfile(app.session, left, &state) == XR_SUCCESS);
  CHECK(state.interactionProfile == profile);
  for (int i = 0; i < 30; ++i) {
    T = app.frame();
    hi.sync(app);
    for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
      const Joints j = app.locate(hand, app.view, T);
      REQUIRE(j.active);
      const XrActionStateGetInfo gi{XR_TYPE_ACTION_STATE_GET_INFO, nullptr, hi.actions[kPoke], XR_NULL_PATH};
      XrActionStatePose pose{XR_TYPE_ACTION_STATE_POSE, nullptr, XR_FALSE};
      REQUIRE(xrGetActionStatePose(app.session, &gi, &pose) == XR_SUCCESS);
      CHECK(pose.isActive == XR_TRUE);
      const auto joint = [&](int k) { return xr::to_eigen(j.loc[static_cast<size_t>(k)].pose.position); };
      const auto at_pose = [&](XrSpace s) {
        XrSpaceLocation l{XR_TYPE_SPACE_LOCATION, nullptr, 0, {{0, 0, 0, 1}, {0, 0, 0}}};
        REQUIRE(xrLocateSpace(s, app.view, T, &l) == XR_SUCCESS);
        CHECK((l.locationFlags & 0xf) == 0xf);
        return xr::to_eigen(l.pose.position);
      };
      const auto& s = hi.spaces[hand - 1];
      CHECK((at_pose(s[kGrip]) - joint(XR_HAND_JOINT_PALM_EXT)).norm() < 1e-5);
      CHECK((at_pose(s[kAim]) - joint(XR_HAND_JOINT_INDEX_PROXIMAL_EXT)).norm() < 1e-5);
      CHECK((at_pose(s[kPinch]) - 0.5 * (joint(XR_HAND_JOINT_THUMB_TIP_EXT) + joint(XR_HAND_JOINT_INDEX_TIP_EXT))).norm() < 1e-5);
      CHECK((at_pose(s[kPoke]) - joint(XR_HAND_JOINT_INDEX_TIP_EXT)).norm() < 1e-5);
      const xr::Rigid want = xr::to_rigid(j.loc[XR_HAND_JOINT_INDEX_TIP_EXT].pose) * xr::to_rigid(hi.offset);
      CHECK((at_pose(hi.poke_offset[hand - 1]) - want.translation()).norm() < 1e-5);
    }
  }
  app.shutdown();
}

TEST_CASE("denoise: both hands closer to the clean track than the raw replay, in LOCAL, STAGE and moving VIEW") {
  const TrackFiles f = make_tracks("denoise", 5.0);
  for (const std::string space : {"local", "stage", "view"}) {
    CAPTURE(space);
    reset_env(f);
    set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
    enable_layers({kLayer});
    App app;
    const XrSpace base = space == "local" ? app.local : space == "stage" ? app.stage : app.view;
    const Errors e = run_and_measure(app, f, base, 400, [](XrTime T) { return T; });
    for (int h = 0; h < 2; ++h) {
      MESSAGE(space << " hand " << h << ": layer " << e.mean(h) * 1e3 << " mm, raw " << e.raw_mean(h) * 1e3 << " mm");
      CHECK(e.n[h] > 300 * 20);
      CHECK(e.mean(h) < 0.9 * e.raw_mean(h));
    }
    app.shutdown();
  }
}

TEST_CASE("raw-joints extension: the runtime's joints beside the filtered ones") {
  const TrackFiles f = make_tracks("rawext", 2.0);
  reset_env(f);
  // Without the layer the loader refuses the extension: only the layer provides it.
  {
    XrInstanceCreateInfo ci{};
    ci.type = XR_TYPE_INSTANCE_CREATE_INFO;
    std::snprintf(ci.applicationInfo.applicationName, XR_MAX_APPLICATION_NAME_SIZE, "handsteady-test");
    ci.applicationInfo.apiVersion = XR_CURRENT_API_VERSION;
    const char* ext[] = {XR_EXT_HAND_TRACKING_EXTENSION_NAME, XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME};
    ci.enabledExtensionCount = 2;
    ci.enabledExtensionNames = ext;
    XrInstance inst = XR_NULL_HANDLE;
    CHECK(xrCreateInstance(&ci, &inst) == XR_ERROR_EXTENSION_NOT_PRESENT);
  }
  // Core validation below the layer: what the layer sends down stays valid.
  enable_layers({kLayer, kCoreValidation});
  const auto log = f.dir / "core_validation_rawext.txt";
  std::filesystem::remove(log);
  set_env("XR_CORE_VALIDATION_EXPORT_TYPE", "text");
  set_env("XR_CORE_VALIDATION_FILE_NAME", log.string());
  for (const std::string mode : {"denoise", "off"}) {
    CAPTURE(mode);
    set_env("HANDSTEADY_MODE", mode);
    uint32_t count = 0;
    REQUIRE(xrEnumerateInstanceExtensionProperties(kLayer, 0, &count, nullptr) == XR_SUCCESS);
    std::vector<XrExtensionProperties> props(count, XrExtensionProperties{XR_TYPE_EXTENSION_PROPERTIES, nullptr, {}, 0});
    REQUIRE(xrEnumerateInstanceExtensionProperties(kLayer, count, &count, props.data()) == XR_SUCCESS);
    CHECK(std::any_of(props.begin(), props.end(), [](const XrExtensionProperties& p) {
      return std::string_view(p.extensionName) == XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME;
    }));
    App app(true, {XR_NOVENDOR_HANDSTEADY_RAW_JOINTS_EXTENSION_NAME});
    PFN_xrVoidFunction fn = nullptr;
    REQUIRE(xrGetInstanceProcAddr(app.instance, "xrLocateRawHandJointsNOVENDOR", &fn) == XR_SUCCESS);
    const auto locate_raw = reinterpret_cast<PFN_xrLocateRawHandJointsNOVENDOR>(fn);
    double raw_err = 0.0, filtered_diff = 0.0;
    long n = 0;
    for (int i = 0; i < 120; ++i) {
      const XrTime T = app.frame();
      for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
        const Pose noisy = interpolate_pose(f.noisy_series[hand - 1], track_time(f, T));
        const Joints filtered = app.locate(hand, app.local, T);
        std::array<XrHandJointLocationEXT, XR_HAND_JOINT_COUNT_EXT> loc{};
        XrHandJointLocationsEXT out{XR_TYPE_HAND_JOINT_LOCATIONS_EXT, nullptr, XR_FALSE, XR_HAND_JOINT_COUNT_EXT, loc.data()};
        const XrHandJointsLocateInfoEXT li{XR_TYPE_HAND_JOINTS_LOCATE_INFO_EXT, nullptr, app.local, T};
        REQUIRE(locate_raw(app.trackers[hand - 1], &li, &out) == XR_SUCCESS);
        REQUIRE(out.isActive == XR_TRUE);
        for (int k = 0; k < kJointCount; ++k) {
          if (!joint_tracked(noisy, k)) continue;
          const Eigen::Vector3d raw = xr::to_eigen(loc[k].pose.position);
          raw_err = std::max(raw_err, (raw - noisy.row(k).transpose()).norm());
          filtered_diff += (raw - xr::to_eigen(filtered.loc[k].pose.position)).norm();
          ++n;
        }
      }
    }
    CHECK(n > 100 * 40);
    CHECK(raw_err < 1e-5);  // exactly the runtime's replay of the noisy track
    if (mode == "denoise") CHECK(filtered_diff / static_cast<double>(n) > 1e-4);  // and the layer did filter
    else CHECK(filtered_diff / static_cast<double>(n) < 1e-7);
    app.shutdown();
  }
  CHECK(hs::test::slurp(log).find("VALID_ERROR") == std::string::npos);
}

namespace {
bool v3_build_mapped() {
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line))
    if (line.find("libXrApiLayer_handsteady_v3") != std::string::npos) return true;
  return false;
}
}  // namespace

TEST_CASE("the layer hands over to its x86-64-v3 build on a CPU that has it") {
#ifndef HS_LAYER_V3_BUILT
  MESSAGE("skipped: this build has no x86-64-v3 layer (HS_LAYER_V3 off, as in the sanitizer builds, HS_ARCH set or not x86-64)");
#else
  const TrackFiles f = make_tracks("isa", 3.0);
  reset_env(f);
  unset_env("HANDSTEADY_ISA");
  enable_layers({kLayer});
  App app;
  const Errors e = run_and_measure(app, f, app.local, 250, [](XrTime T) { return T; });
  for (int h = 0; h < 2; ++h) CHECK(e.mean(h) < 0.9 * e.raw_mean(h));
  app.shutdown();
  __builtin_cpu_init();
  CHECK(v3_build_mapped() == (__builtin_cpu_supports("x86-64-v3") != 0));
#endif
}

// What a bug report quotes: the info line at xrCreateInstance names the build and the
// source revision (the layer's own copy of it, which must be this build's).
TEST_CASE("the layer's info log names its build and the source revision it was built from") {
  const TrackFiles f = make_tracks("revision", 1.0);
  reset_env(f);
  set_env("HANDSTEADY_LOG", "info");
  enable_layers({kLayer});
  const auto log = f.dir / "stderr.txt";
  {
    test::StderrToFile to_log(log);
    App app;
    app.shutdown();
  }
  const std::string text = hs::test::slurp(log);
  INFO(text);
  CHECK(text.find(std::string(" build of revision ") + hs::source_revision() + ", mode ") != std::string::npos);
}

TEST_CASE("the layer's baseline build runs when asked (HANDSTEADY_ISA=baseline)") {
  const TrackFiles f = make_tracks("isa_base", 3.0);
  if (v3_build_mapped()) {
    MESSAGE("skipped: the v3 build is already loaded in this process (layers stay loaded)");
    return;
  }
  reset_env(f);
  set_env("HANDSTEADY_ISA", "baseline");
  enable_layers({kLayer});
  App app;
  const Errors e = run_and_measure(app, f, app.local, 250, [](XrTime T) { return T; });
  for (int h = 0; h < 2; ++h) CHECK(e.mean(h) < 0.9 * e.raw_mean(h));
  app.shutdown();
  CHECK_FALSE(v3_build_mapped());
}

TEST_CASE("denoise: the same time in several base spaces gives the same world positions") {
  const TrackFiles f = make_tracks("spaces", 2.0);
  reset_env(f);
  set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
  enable_layers({kLayer});
  App app;
  for (int i = 0; i < 100; ++i) {
    const XrTime T = app.frame();
    // Ask in VIEW first (moving), then LOCAL and STAGE: all must agree once in LOCAL.
    const Joints v = app.locate(XR_HAND_RIGHT_EXT, app.view, T);
    const Joints l = app.locate(XR_HAND_RIGHT_EXT, app.local, T);
    const Joints s = app.locate(XR_HAND_RIGHT_EXT, app.stage, T);
    const xr::Rigid mv = xr::to_rigid(app.space_pose(app.view, app.local, T));
    const xr::Rigid ms = xr::to_rigid(app.space_pose(app.stage, app.local, T));
    for (int k = 0; k < kJointCount; ++k) {
      const Eigen::Vector3d pl = xr::to_eigen(l.loc[k].pose.position);
      CHECK((mv * xr::to_eigen(v.loc[k].pose.position) - pl).norm() < 1e-4);
      CHECK((ms * xr::to_eigen(s.loc[k].pose.position) - pl).norm() < 1e-4);
      // Orientations stay unit quaternions and follow the same rotation.
      const Eigen::Quaterniond ql = xr::to_eigen(l.loc[k].pose.orientation);
      const Eigen::Quaterniond qv(mv.rotation() * xr::to_eigen(v.loc[k].pose.orientation).toRotationMatrix());
      CHECK(std::abs(ql.norm() - 1.0) < 1e-4);
      CHECK(std::abs(std::abs(ql.dot(qv)) - 1.0) < 1e-4);
    }
  }
  app.shutdown();
}

TEST_CASE("denoise: orientations follow the new bone directions, velocities stay consistent") {
  const TrackFiles f = make_tracks("orient", 3.0);
  reset_env(f);
  enable_layers({kLayer});
  App app;
  double vel_err_sum = 0.0, raw_vel_err_sum = 0.0;
  long vn = 0;
  for (int i = 0; i < 200; ++i) {
    const XrTime T = app.frame();
    const Joints j = app.locate(XR_HAND_RIGHT_EXT, app.local, T, true);
    REQUIRE(j.active == XR_TRUE);
    if (i < 30) continue;
    for (int k = 0; k < kJointCount; ++k) {
      const auto [a, b] = kXrFrameBone[k];
      const Eigen::Vector3d bone = xr::to_eigen(j.loc[b].pose.position) - xr::to_eigen(j.loc[a].pose.position);
      if (bone.norm() < 1e-3) continue;
      // The joint's -Z axis points along its (new) bone, as the runtime's did along its own.
      const Eigen::Vector3d minus_z = -(xr::to_eigen(j.loc[k].pose.orientation) * Eigen::Vector3d::UnitZ());
      CHECK(minus_z.dot(bone.normalized()) > 0.999);
      // Velocity against the clean track's finite difference.
      const double t = track_time(f, T);
      const Eigen::Vector3d vt =
          ((interpolate_pose(f.clean_series[1], t + 0.01).row(k) - interpolate_pose(f.clean_series[1], t - 0.01).row(k)) /
           0.02).transpose();
      const Eigen::Vector3d vr =
          ((interpolate_pose(f.noisy_series[1], t + 0.002).row(k) - interpolate_pose(f.noisy_series[1], t - 0.002).row(k)) /
           0.004).transpose();
      if (!vt.allFinite() || !vr.allFinite()) continue;
      REQUIRE((j.vel[k].velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) != 0);
      vel_err_sum += (xr::to_eigen(j.vel[k].linearVelocity) - vt).norm();
      raw_vel_err_sum += (vr - vt).norm();
      ++vn;
    }
  }
  REQUIRE(vn > 1000);
  MESSAGE("velocity error: layer " << vel_err_sum / static_cast<double>(vn) << " m/s, raw "
                                   << raw_vel_err_sum / static_cast<double>(vn) << " m/s");
  CHECK(vel_err_sum < raw_vel_err_sum);
  app.shutdown();
}

// In a moving base space the app's velocity is the hand's plus the base's own motion. The
// layer takes the base's motion from XrSpaceVelocity when the runtime gives it, else from
// the runtime's joint velocities in both spaces; either way it must match the truth.
TEST_CASE("denoise in a moving VIEW: velocities include the base's motion, with and without XrSpaceVelocity") {
  const TrackFiles f = make_tracks("viewvel", 3.0);
  for (const std::string space_velocity : {"1", "0"}) {
    CAPTURE(space_velocity);
    reset_env(f);
    set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
    set_env("HANDSTEADY_SHIM_SPACE_VELOCITY", space_velocity);
    enable_layers({kLayer});
    App app;
    double err = 0.0, raw_err = 0.0, still_err = 0.0;
    long n = 0;
    for (int i = 0; i < 200; ++i) {
      const XrTime T = app.frame();
      const Joints j = app.locate(XR_HAND_RIGHT_EXT, app.view, T, true);
      REQUIRE(j.active == XR_TRUE);
      if (i < 30) continue;
      // Positions in VIEW at T +- h from the clean and the noisy track.
      const auto in_view = [&](const HandSeries& s, XrTime t, int k) {
        const xr::Rigid view_from_local = xr::to_rigid(app.space_pose(app.local, app.view, t));
        return Eigen::Vector3d(view_from_local * interpolate_pose(s, track_time(f, t)).row(k).transpose());
      };
      constexpr XrTime h = 10'000'000, hr = 2'000'000;
      for (int k = 0; k < kJointCount; ++k) {
        const Eigen::Vector3d vt = (in_view(f.clean_series[1], T + h, k) - in_view(f.clean_series[1], T - h, k)) / 0.02;
        const Eigen::Vector3d vr = (in_view(f.noisy_series[1], T + hr, k) - in_view(f.noisy_series[1], T - hr, k)) / 0.004;
        if (!vt.allFinite() || !vr.allFinite()) continue;
        REQUIRE((j.vel[k].velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) != 0);
        const Eigen::Vector3d v = xr::to_eigen(j.vel[k].linearVelocity);
        err += (v - vt).norm();
        raw_err += (vr - vt).norm();
        // What a layer ignoring the head would answer: the hand's motion alone, in VIEW's axes.
        const xr::Rigid view_from_local = xr::to_rigid(app.space_pose(app.local, app.view, T));
        const Eigen::Vector3d hand_only =
            view_from_local.linear() *
            Eigen::Vector3d((interpolate_pose(f.clean_series[1], track_time(f, T + h)).row(k) -
                             interpolate_pose(f.clean_series[1], track_time(f, T - h)).row(k))
                                .transpose() /
                            0.02);
        still_err += (hand_only - vt).norm();
        ++n;
      }
    }
    REQUIRE(n > 1000);
    const double dn = static_cast<double>(n);
    MESSAGE("VIEW velocity error: layer " << err / dn << " m/s, raw " << raw_err / dn << " m/s, head ignored "
                                          << still_err / dn << " m/s");
    CHECK(err < raw_err);
    CHECK(err < 0.5 * still_err);  // the base's motion is in the answer
    app.shutdown();
  }
}

TEST_CASE("predict: error at the display time below the runtime's stale answer") {
  const TrackFiles f = make_tracks("predict", 5.0, 0.001);
  reset_env(f);
  set_env("HANDSTEADY_METHOD", "kalman");  // the classical predictor (One Euro does not predict)
  const Errors e = predict_against_stale_runtime(f, 400);
  for (int h = 0; h < 2; ++h) {
    MESSAGE("hand " << h << ": predicted " << e.mean(h) * 1e3 << " mm, runtime " << e.raw_mean(h) * 1e3 << " mm");
    CHECK(e.mean(h) < 0.9 * e.raw_mean(h));
  }
}

// The layer's default engine, the shipped Multi-STGAE model (30 Hz) found through the
// build tree's link to models/, asked at 90 Hz: it runs interleaved streams (docs/STGAE.md
// "Streaming at any rate"), so it must beat the raw replay here, not just give finite answers.
TEST_CASE("default engine (shipped model) at 90 Hz: denoise closer than raw, predict below the stale answer") {
  const TrackFiles f = make_tracks("shipped", 7.0);
  std::array<double, 2> one_stream{};
  for (const std::string phases : {"1", ""}) {  // HANDSTEADY_STGAE_PHASES=1, then unset (the default)
    reset_env(f);
    unset_env("HANDSTEADY_METHOD");  // no configuration: the shipped model
    // The simulated clock runs faster than real time: the worker answers in lockstep, as
    // in real time when it keeps up (the hand-off is measured on the real clock below).
    set_env("HANDSTEADY_WORKER", "lockstep");
    if (!phases.empty()) set_env("HANDSTEADY_STGAE_PHASES", phases);
    enable_layers({kLayer});
    App app;
    const Errors e = run_and_measure(app, f, app.local, 600, [](XrTime T) { return T; });
    for (int h = 0; h < 2; ++h) {
      MESSAGE("denoise (phases '" << phases << "') hand " << h << ": layer " << e.mean(h) * 1e3 << " mm, raw "
                                  << e.raw_mean(h) * 1e3 << " mm");
      if (!phases.empty()) {
        one_stream[static_cast<size_t>(h)] = e.mean(h);
        continue;
      }
      CHECK(e.mean(h) < 0.8 * e.raw_mean(h));
      CHECK(e.mean(h) < 0.8 * one_stream[static_cast<size_t>(h)]);  // the setting is read, and the default is better
    }
    app.shutdown();
  }
  {
    reset_env(f);
    unset_env("HANDSTEADY_METHOD");
    set_env("HANDSTEADY_WORKER", "lockstep");
    const Errors e = predict_against_stale_runtime(f, 600);
    for (int h = 0; h < 2; ++h) {
      MESSAGE("predict hand " << h << ": layer " << e.mean(h) * 1e3 << " mm, runtime " << e.raw_mean(h) * 1e3 << " mm");
      CHECK(e.mean(h) < 0.9 * e.raw_mean(h));
    }
  }
}

TEST_CASE("disabled layer is an exact passthrough (disable_environment, mode off, config file)") {
  const TrackFiles f = make_tracks("passthrough", 1.5);
  reset_env(f);
  set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
  const auto baseline = run_recorded(60);
  REQUIRE(baseline.front().active == XR_TRUE);

  install_implicit_layer(f.dir / "xdg");
  set_env("DISABLE_XR_APILAYER_NOVENDOR_handsteady", "1");
  CHECK(identical(run_recorded(60), baseline));
  unset_env("DISABLE_XR_APILAYER_NOVENDOR_handsteady");

  set_env("HANDSTEADY_MODE", "off");
  CHECK(identical(run_recorded(60), baseline));
  unset_env("HANDSTEADY_MODE");

  const auto cfg = f.dir / "off.json";
  std::ofstream(cfg) << R"({"mode": "off", "log_level": "warn"})";
  set_env("HANDSTEADY_CONFIG", cfg.string());
  CHECK(identical(run_recorded(60), baseline));
  // The environment overrides the file.
  set_env("HANDSTEADY_MODE", "denoise");
  CHECK_FALSE(identical(run_recorded(60), baseline));
  unset_env("HANDSTEADY_MODE");
  unset_env("HANDSTEADY_CONFIG");

  // Enabled implicitly with no configuration at all: it filters.
  CHECK_FALSE(identical(run_recorded(60), baseline));
}

TEST_CASE("bad configuration is reported and ignored: the layer still denoises") {
  const TrackFiles f = make_tracks("badconfig", 3.0);
  reset_env(f);
  const auto cfg = f.dir / "bad.json";
  std::ofstream(cfg) << R"({"mode": "sideways", "horizon_ms": "soon", "oneeuro": {"beta": -3})";  // invalid JSON too
  set_env("HANDSTEADY_CONFIG", cfg.string());
  set_env("HANDSTEADY_METHOD", "no-such-filter");
  set_env("HANDSTEADY_MODEL", (f.dir / "no-such-model.hsm").string());  // the default engine cannot load either
  set_env("HANDSTEADY_LOG", "off");
  enable_layers({kLayer});
  App app;
  const Errors e = run_and_measure(app, f, app.local, 250, [](XrTime T) { return T; });
  for (int h = 0; h < 2; ++h) CHECK(e.mean(h) < 0.9 * e.raw_mean(h));
  app.shutdown();
}

TEST_CASE("configuration file selects the engine and its parameters") {
  const TrackFiles f = make_tracks("config", 3.0);
  reset_env(f);
  unset_env("HANDSTEADY_METHOD");  // the environment would override the file
  enable_layers({kLayer});
  // "raw" holds the last sample: exactly the runtime's answer at the asked time.
  const auto cfg = f.dir / "raw.json";
  std::ofstream(cfg) << R"({"mode": "denoise", "method": "raw"})";
  set_env("HANDSTEADY_CONFIG", cfg.string());
  App app;
  for (int i = 0; i < 50; ++i) {
    const XrTime T = app.frame();
    const Joints j = app.locate(XR_HAND_LEFT_EXT, app.local, T);
    const Pose noisy = interpolate_pose(f.noisy_series[0], track_time(f, T));
    for (int k = 0; k < kJointCount; ++k)
      if (joint_tracked(noisy, k)) CHECK((xr::to_eigen(j.loc[k].pose.position) - noisy.row(k).transpose()).norm() < 1e-5);
  }
  app.shutdown();
}

TEST_CASE("the replay runtime refuses a configuration it cannot use, naming the variable") {
  const TrackFiles f = make_tracks("shimenv", 0.5);
  const auto log = f.dir / "shimenv_stderr.txt";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"HANDSTEADY_SHIM_CORRUPT", "tracker:inf"}, {"HANDSTEADY_SHIM_CORRUPT", "tracker:1e30"},
      {"HANDSTEADY_SHIM_CORRUPT", "tracker:-1"},  {"HANDSTEADY_SHIM_CONTROLLER", "2,1"},
      {"HANDSTEADY_SHIM_CONTROLLER", "1"},        {"HANDSTEADY_SHIM_CONTROLLER", "0,nan"},
      // A yaw whose conversion to radians overflowed (found by fuzz_replay_env), an offset beyond 1 km.
      {"HANDSTEADY_SHIM_RECENTER", "2,0.06,0,0,1e308"}, {"HANDSTEADY_SHIM_RECENTER", "2,1e4,0,0,8"},
      {"HANDSTEADY_SHIM_FAULTS", "error:2"}};
  for (const auto& [name, value] : bad) {
    CAPTURE(name);
    CAPTURE(value);
    reset_env(f);
    set_env(name.c_str(), value);
    XrInstance instance = XR_NULL_HANDLE;
    XrResult res = XR_SUCCESS;
    {
      test::StderrToFile to_log(log);
      res = create_instance({XR_MND_HEADLESS_EXTENSION_NAME}, instance);
    }
    CHECK(res == XR_ERROR_RUNTIME_FAILURE);
    if (XR_SUCCEEDED(res)) xrDestroyInstance(instance);
    CHECK(hs::test::slurp(log).find(name + ":") != std::string::npos);
  }
}

TEST_CASE("without XR_EXT_hand_tracking the layer hooks nothing") {
  const TrackFiles f = make_tracks("noext", 1.0);
  reset_env(f);
  enable_layers({kLayer});
  App app(false);
  PFN_xrVoidFunction fn = nullptr;
  CHECK(xrGetInstanceProcAddr(app.instance, "xrLocateHandJointsEXT", &fn) == XR_ERROR_FUNCTION_UNSUPPORTED);
  CHECK(reinterpret_cast<void*>(fn) == nullptr);
  app.frame();
  app.shutdown();
}

// Core validation writes its file only when it has something to say: each run ends with
// one deliberately bad call (from the app) so that the file proves validation was active;
// that call's messages must be the only errors.
bool only_expected_errors(const std::string& text, int& bad_call_errors) {
  std::istringstream in(text);
  std::string line;
  bool ok = true;
  bad_call_errors = 0;
  while (std::getline(in, line)) {
    if (line.find("VALID_ERROR") == std::string::npos) continue;
    if (line.find("VUID-XrSpaceLocation-type-type") != std::string::npos ||
        line.find("VUID-xrLocateSpace-location-parameter") != std::string::npos) {
      ++bad_call_errors;
    } else {
      MESSAGE("unexpected: " << line);
      ok = false;
    }
  }
  return ok;
}

void bad_call(const App& app, XrTime T) {
  XrSpaceLocation loc{};  // type left 0
  CHECK(XR_FAILED(xrLocateSpace(app.view, app.local, T, &loc)));
}

TEST_CASE("core validation above and below the layer reports no error") {
  const TrackFiles f = make_tracks("validation", 2.0);
  for (bool above : {true, false}) {
    CAPTURE(above);
    reset_env(f);
    const auto log = f.dir / (above ? "cv_above.txt" : "cv_below.txt");
    std::filesystem::remove(log);
    set_env("XR_CORE_VALIDATION_EXPORT_TYPE", "text");
    set_env("XR_CORE_VALIDATION_FILE_NAME", log.string());
    set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
    if (above) enable_layers({kCoreValidation, kLayer});
    else enable_layers({kLayer, kCoreValidation});
    {
      // With XR_EXT_hand_interaction's poses too (the layer hooks actions and spaces then).
      App app(true, {kHandInteractionExt});
      const HandInteraction hi(app);
      XrTime T = 0;
      for (int i = 0; i < 100; ++i) {
        T = app.frame();
        hi.sync(app);
        for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT})
          for (XrSpace s : {app.local, app.stage, app.view}) {
            CHECK(app.locate(hand, s, T, i % 2 == 0).result == XR_SUCCESS);
            XrSpaceLocation loc{XR_TYPE_SPACE_LOCATION, nullptr, 0, {{0, 0, 0, 1}, {0, 0, 0}}};
            CHECK(xrLocateSpace(hi.spaces[hand - 1][i % 4], s, T, &loc) == XR_SUCCESS);
          }
      }
      bad_call(app, T);
      // Session destroyed with its trackers alive: the implicit destruction path.
      app.shutdown(true);
    }
    int bad = 0;
    CHECK(only_expected_errors(hs::test::slurp(log), bad));
    CHECK(bad > 0);
  }
}

TEST_CASE("core validation catches a bad call (the check above can fail)") {
  const TrackFiles f = make_tracks("validation_neg", 1.0);
  reset_env(f);
  const auto log = f.dir / "cv_neg.txt";
  std::filesystem::remove(log);
  set_env("XR_CORE_VALIDATION_EXPORT_TYPE", "text");
  set_env("XR_CORE_VALIDATION_FILE_NAME", log.string());
  enable_layers({kCoreValidation, kLayer});
  {
    App app;
    const XrTime T = app.frame();
    bad_call(app, T);
    // And an error of another kind: a hand-joint locate with a wrong structure type.
    std::array<XrHandJointLocationEXT, XR_HAND_JOINT_COUNT_EXT> loc{};
    XrHandJointLocationsEXT out{};
    out.jointCount = XR_HAND_JOINT_COUNT_EXT;
    out.jointLocations = loc.data();
    XrHandJointsLocateInfoEXT info{};
    info.type = XR_TYPE_HAND_JOINTS_LOCATE_INFO_EXT;
    info.baseSpace = app.local;
    info.time = T;
    CHECK(XR_FAILED(app.locate_joints(app.trackers[0], &info, &out)));
    app.shutdown();
  }
  int bad = 0;
  CHECK_FALSE(only_expected_errors(hs::test::slurp(log), bad));
  CHECK(bad > 0);
}

TEST_CASE("many create/destroy cycles: state starts afresh each time") {
  const TrackFiles f = make_tracks("cycles", 1.0);
  reset_env(f);
  enable_layers({kLayer});
  std::vector<Joints> first;
  for (int cycle = 0; cycle < 25; ++cycle) {
    App app;
    std::vector<Joints> seen;
    for (int i = 0; i < 8; ++i) {
      const XrTime T = app.frame();
      seen.push_back(app.locate(XR_HAND_RIGHT_EXT, app.local, T, true));
    }
    if (cycle == 0) first = seen;
    else CHECK(identical(seen, first));
    // Half the cycles let xrDestroySession drop the trackers.
    app.shutdown(cycle % 2 == 1);
  }
}

TEST_CASE("repeated, older and irregular times, hands lost and found, NaN and garbage from the runtime") {
  const TrackFiles f = make_tracks("faults", 6.0, 0.003, true);
  reset_env(f);
  set_env("HANDSTEADY_SHIM_FAULTS", "nan:0.01,huge:0.01,quat:0.01");
  set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
  enable_layers({kLayer});
  App app;
  long valid = 0, sane = 0, lost_frames = 0, found_again = 0;
  double err_sum = 0.0, raw_sum = 0.0;
  long err_n = 0, raw_n = 0;
  XrTime prev = 0;
  for (int i = 0; i < 540; ++i) {
    const XrTime T = app.frame();
    // The display time, repeated, older, and irregular (between frames), in several spaces.
    const XrTime times[] = {T, T, T - 30'000'000, prev > 0 ? prev + (T - prev) / 3 : T, T - 1'000'000'000, T};
    for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
      const int h = hand - 1;
      for (size_t q = 0; q < std::size(times); ++q) {
        const XrSpace base = q % 3 == 0 ? app.local : q % 3 == 1 ? app.view : app.stage;
        const Joints j = app.locate(hand, base, times[q], q % 2 == 0);
        REQUIRE(j.result == XR_SUCCESS);
        if (!j.active) {
          for (const auto& l : j.loc) CHECK(l.locationFlags == 0);
          continue;
        }
        const Pose truth = interpolate_pose(f.clean_series[h], track_time(f, times[q]));
        const xr::Rigid m = xr::to_rigid(app.space_pose(base, app.local, times[q]));
        for (int k = 0; k < kJointCount; ++k) {
          if (!joint_tracked(truth, k) || !(j.loc[k].locationFlags & XR_SPACE_LOCATION_POSITION_TRACKED_BIT)) continue;
          ++valid;
          const Eigen::Vector3d p = m * xr::to_eigen(j.loc[k].pose.position);
          if (p.allFinite() && (p - truth.row(k).transpose()).norm() < 0.05) ++sane;
        }
      }
      // Error at the display time only, once the faults are behind the first 30 frames.
      const Joints j = app.locate(hand, app.local, T);
      const Pose truth = interpolate_pose(f.clean_series[h], track_time(f, T));
      if (h == 1 && !j.active) ++lost_frames;
      if (h == 1 && j.active && lost_frames > 0 && found_again == 0) found_again = i;
      if (i > 30 && j.active) {
        for (int k = 0; k < kJointCount; ++k) {
          const Eigen::Vector3d p = xr::to_eigen(j.loc[k].pose.position);
          if (!joint_tracked(truth, k) || !p.allFinite()) continue;
          err_sum += (p - truth.row(k).transpose()).norm();
          ++err_n;
        }
        const Pose noisy = interpolate_pose(f.noisy_series[h], track_time(f, T));
        accumulate_error(noisy, truth, raw_sum, raw_n);
      }
    }
    prev = T;
  }
  MESSAGE("valid joints " << valid << ", within 5 cm of the truth " << sane << "; lost frames " << lost_frames);
  CHECK(lost_frames > 60);         // the right hand was gone for about a second
  CHECK(found_again > 0);
  // Garbage joints the engine has a state for are replaced: nearly all answers are sane.
  CHECK(static_cast<double>(sane) > 0.995 * static_cast<double>(valid));
  CHECK(err_n > 10000);
  CHECK(err_sum / static_cast<double>(err_n) < 0.9 * raw_sum / static_cast<double>(raw_n));
  app.shutdown();
}

TEST_CASE("invalid arguments reach the app with the runtime's error") {
  const TrackFiles f = make_tracks("invalid", 1.0);
  reset_env(f);
  enable_layers({kLayer});
  App app;
  const XrTime T = app.frame();
  CHECK(app.locate(XR_HAND_LEFT_EXT, app.local, T, false, 25).result == XR_ERROR_VALIDATION_FAILURE);
  CHECK(app.locate(XR_HAND_LEFT_EXT, app.local, 0).result == XR_ERROR_TIME_INVALID);
  CHECK(app.locate(XR_HAND_LEFT_EXT, app.local, T).result == XR_SUCCESS);
  app.shutdown();
}

TEST_CASE("record option writes raw and filtered track CSVs") {
  const TrackFiles f = make_tracks("record", 2.0);
  reset_env(f);
  const auto dir = f.dir / "rec";
  std::filesystem::remove_all(dir);
  set_env("HANDSTEADY_RECORD", dir.string());
  enable_layers({kLayer});
  {
    App app;
    for (int i = 0; i < 90; ++i) {
      const XrTime T = app.frame();
      for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) app.locate(hand, app.view, T);
    }
    app.shutdown();
  }
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const Track t = read_track_csv(e.path());
    CHECK(t.rows.size() == 90);
    ++files;
  }
  CHECK(files == 4);
}
