// The layer's real-time path through the real loader: once a tracker runs, an
// xrLocateHandJointsEXT call allocates nothing, anywhere in the process (the layer, the
// loader's trampoline, the replay runtime, the layer's worker thread). Its own executable:
// allocation_counting.hpp replaces the process's allocation functions.
#include "allocation_counting.hpp"
#include "xr_test_app.hpp"

#include <doctest/doctest.h>

#include <array>
#include <string>

using namespace hs;
using namespace hs::xrtest;

namespace {

// One answer with everything an app may chain: velocities, Meta's capsules, aim and hand
// scale (overridden). Each frame also syncs and locates XR_EXT_hand_interaction's poses.
struct Answer {
  std::array<XrHandJointLocationEXT, XR_HAND_JOINT_COUNT_EXT> loc{};
  std::array<XrHandJointVelocityEXT, XR_HAND_JOINT_COUNT_EXT> vel{};
  XrHandTrackingCapsulesStateFB capsules{};
  XrHandTrackingAimStateFB aim{};
  XrHandTrackingScaleFB scale{};
};

XrResult locate_all(const App& app, XrHandEXT hand, XrTime time, Answer& a) {
  a.scale = {XR_TYPE_HAND_TRACKING_SCALE_FB, nullptr, 0.0f, 0.0f, XR_TRUE, 1.1f};
  a.aim.type = XR_TYPE_HAND_TRACKING_AIM_STATE_FB;
  a.aim.next = &a.scale;
  a.capsules.type = XR_TYPE_HAND_TRACKING_CAPSULES_STATE_FB;
  a.capsules.next = &a.aim;
  XrHandJointVelocitiesEXT vel{XR_TYPE_HAND_JOINT_VELOCITIES_EXT, &a.capsules, XR_HAND_JOINT_COUNT_EXT, a.vel.data()};
  XrBool32 active = XR_FALSE;
  return locate_chained(app.locate_joints, app.trackers[hand - 1], app.view, time, &vel, XR_HAND_JOINT_COUNT_EXT,
                        a.loc.data(), active);
}

}  // namespace

TEST_CASE("once a tracker runs, locating its joints and poses allocates nothing (layer, loader, runtime, worker)") {
  // Counted over whole frames (xrWaitFrame/xrBeginFrame/xrEndFrame included), so that the
  // worker's steps between the app's calls count too. Malloc and operator new both
  // (operator new alone in sanitizer builds, which interpose malloc themselves).
  const TrackFiles f = make_tracks("alloc", 3.0);
  // stgae: the shipped model on its worker thread (the default), and the worker in lockstep
  // (each step done before the app's call returns, so every step falls in the count).
  for (const std::string engine : {"classical", "stgae", "stgae-lockstep"})
    for (const std::string mode : {"denoise", "predict"})
      for (const bool faults : {false, true}) {
        CAPTURE(engine);
        CAPTURE(mode);
        CAPTURE(faults);
        reset_env(f);
        set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
        if (faults)
          set_env("HANDSTEADY_SHIM_FAULTS",
                  "nan:0.02,huge:0.02,quat:0.02,origin:0.02,radius:0.05,velocity:0.05,collapse:0.02,space:0.02");
        set_env("HANDSTEADY_MODE", mode);
        if (engine == "classical") set_env("HANDSTEADY_METHOD", mode == "predict" ? "kalman" : "oneeuro");
        else unset_env("HANDSTEADY_METHOD");  // the shipped model, the default
        if (engine == "stgae-lockstep") set_env("HANDSTEADY_WORKER", "lockstep");
        enable_layers({kLayer});
        App app(true, {XR_FB_HAND_TRACKING_CAPSULES_EXTENSION_NAME, XR_FB_HAND_TRACKING_AIM_EXTENSION_NAME,
                       XR_FB_HAND_TRACKING_MESH_EXTENSION_NAME, kHandInteractionExt});
        const HandInteraction hi(app);
        Answer a;
        long failed = 0, answered = 0;
        // A frame: the hand interaction poses synced and located, before the joints on odd
        // frames (the layer then answers for the hand first) and after them on even ones.
        const auto frame = [&](int i, bool count) {
          const XrTime T = app.frame();
          hi.sync(app);
          for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
            const auto poses = [&] {
              for (XrSpace s : hi.spaces[hand - 1]) {
                XrSpaceLocation loc{XR_TYPE_SPACE_LOCATION, nullptr, 0, {{0, 0, 0, 1}, {0, 0, 0}}};
                failed += xrLocateSpace(s, app.view, T, &loc) != XR_SUCCESS;
              }
            };
            if (i % 2 == 1) poses();
            failed += locate_all(app, hand, T, a) != XR_SUCCESS;
            if (i % 2 == 0) poses();
            answered += count;
          }
        };
        for (int i = 0; i < 60; ++i) frame(i, false);  // warm: the engine's first answers, every log said once
        test::g_allocations = 0;
        test::g_counting = true;
        for (int i = 0; i < 150; ++i) frame(i, true);
        test::g_counting = false;
        const long allocations = test::g_allocations;
        const std::string what = engine + " " + mode + (faults ? " with faults" : "");
        MESSAGE(what << ": " << allocations << " allocations in "
                       << answered << " answers (malloc counted: " << HS_COUNT_MALLOC << ")");
        CHECK(failed == 0);
        CHECK(allocations == 0);
        app.shutdown();
      }
}
