// The layer with the Multi-STGAE engine, through the real loader and the replay runtime:
// selected by method (environment or configuration file) or by default when a model is
// found; a small random causal model must give finite answers on the hand's scale with the
// runtime's flags untouched (a random model does not denoise: that is not asserted); a
// corrupt model falls back to the mode's classical filter, which still denoises.
#include "handsteady/stgae_model.hpp"
#include "handsteady/track_ops.hpp"
#include "handsteady_xr/xr_math.hpp"
#include "test_support.hpp"
#include "xr_test_app.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

using namespace hs;
using namespace hs::xrtest;

namespace {

std::filesystem::path random_model(const std::filesystem::path& dir) {
  StgaeConfig c;
  c.window = 6;
  c.horizon = 3;
  c.rate_hz = 30.0;
  c.encoder_channels = {6, 8, 8};
  c.denoise_decoder_channels = {8, 6, 3};
  c.predict_decoder_channels = {8, 6, 3};
  c.temporal_kernel = 3;
  c.padding = StgaePadding::Causal;
  // Small weights: the offsets stay well below the hand's size.
  const auto w = random_stgae_weights(c, 23, 0.5);
  const auto file = dir / "random_causal.hsm";
  save_hsm(file, c, w, make_stgae_reference(c, w, synthetic_hand_input(c, c.window, 4)));
  return file;
}

std::filesystem::path corrupt_model(const std::filesystem::path& dir) {
  const auto file = dir / "corrupt.hsm";
  std::ofstream(file, std::ios::binary) << "HSM1\0\0\0\0 truncated";
  return file;
}

// The engine the layer recorded in its filtered track's metadata (HANDSTEADY_RECORD).
std::string recorded_engine(const std::filesystem::path& dir) {
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().filename().string().find("_filtered.csv") == std::string::npos) continue;
    return read_track_csv(e.path()).meta("filter").value_or("");
  }
  return "";
}

struct Frame {
  XrTime time = 0;
  std::array<Joints, 2> hand;  // [left, right], located in VIEW (moving head) with velocities
};

std::vector<Frame> run_frames(int frames) {
  App app;
  std::vector<Frame> out;
  for (int i = 0; i < frames; ++i) {
    Frame f;
    f.time = app.frame();
    for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) f.hand[hand - 1] = app.locate(hand, app.view, f.time, true);
    out.push_back(f);
  }
  app.shutdown();
  return out;
}

// Each answer succeeds with the runtime's flags, activity and radii; positions finite and
// within max_dev_m of the runtime's; velocities finite wherever flagged valid.
void check_against_runtime(const std::vector<Frame>& layer, const std::vector<Frame>& runtime, double max_dev_m) {
  REQUIRE(layer.size() == runtime.size());
  long compared = 0;
  for (size_t i = 0; i < layer.size(); ++i) {
    REQUIRE(layer[i].time == runtime[i].time);
    for (int h = 0; h < 2; ++h) {
      CAPTURE(i);
      CAPTURE(h);
      const Joints& a = layer[i].hand[h];
      const Joints& b = runtime[i].hand[h];
      REQUIRE(a.result == XR_SUCCESS);
      REQUIRE(a.active == b.active);
      for (int k = 0; k < XR_HAND_JOINT_COUNT_EXT; ++k) {
        CHECK(a.loc[k].locationFlags == b.loc[k].locationFlags);
        CHECK(a.loc[k].radius == b.loc[k].radius);
        CHECK(a.vel[k].velocityFlags == b.vel[k].velocityFlags);
        if (!a.active || !(a.loc[k].locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT)) continue;
        const Eigen::Vector3d pa = xr::to_eigen(a.loc[k].pose.position), pb = xr::to_eigen(b.loc[k].pose.position);
        REQUIRE(pa.allFinite());
        CHECK((pa - pb).norm() < max_dev_m);
        if (a.vel[k].velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT)
          CHECK(xr::to_eigen(a.vel[k].linearVelocity).allFinite());
        ++compared;
      }
    }
  }
  CHECK(compared > static_cast<long>(layer.size()) * 26);
}

}  // namespace

TEST_CASE("stgae by HANDSTEADY_METHOD, denoise and predict: finite answers, runtime flags kept, engine used") {
  const TrackFiles f = make_tracks("stgae", 3.0, 0.003, true);  // the right hand leaves for 1 s
  const auto model = random_model(f.dir);
  reset_env(f);
  set_env("HANDSTEADY_WORKER", "lockstep");  // simulated clock: deterministic hand-off
  set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
  const auto runtime = run_frames(200);
  for (const std::string mode : {"denoise", "predict"}) {
    CAPTURE(mode);
    const auto rec = f.dir / ("rec_" + mode);
    std::filesystem::remove_all(rec);
    reset_env(f);
    set_env("HANDSTEADY_WORKER", "lockstep");  // simulated clock: deterministic hand-off
  set_env("HANDSTEADY_WORKER", "lockstep");  // simulated clock: deterministic hand-off
    set_env("HANDSTEADY_SHIM_HEAD_MOTION", "1");
    set_env("HANDSTEADY_METHOD", "stgae");
    set_env("HANDSTEADY_MODEL", model.string());
    set_env("HANDSTEADY_MODE", mode);
    set_env("HANDSTEADY_RECORD", rec.string());
    enable_layers({kLayer});
    const auto layer = run_frames(200);
    check_against_runtime(layer, runtime, 0.15);
    CHECK(recorded_engine(rec) == "stgae");
    // Not a passthrough: the engine changed the answers.
    double moved = 0.0;
    for (size_t i = 50; i < layer.size(); ++i)
      moved = std::max(moved, (xr::to_eigen(layer[i].hand[0].loc[5].pose.position) -
                               xr::to_eigen(runtime[i].hand[0].loc[5].pose.position)).norm());
    CHECK(moved > 1e-4);
  }
}

TEST_CASE("stgae chosen by the configuration file, and by default when HANDSTEADY_MODEL names a model") {
  const TrackFiles f = make_tracks("stgae_config", 1.0);
  const auto model = random_model(f.dir);
  const auto cfg = f.dir / "stgae.json";
  std::ofstream(cfg) << R"({"mode": "denoise", "method": "stgae", "model": ")" << model.string() << R"("})";
  for (const bool by_file : {true, false}) {
    CAPTURE(by_file);
    const auto rec = f.dir / (by_file ? "rec_file" : "rec_default");
    std::filesystem::remove_all(rec);
    reset_env(f);
    set_env("HANDSTEADY_WORKER", "lockstep");  // simulated clock: deterministic hand-off
  set_env("HANDSTEADY_WORKER", "lockstep");  // simulated clock: deterministic hand-off
    unset_env("HANDSTEADY_METHOD");  // these cases test the layer's own choice of engine
    if (by_file) set_env("HANDSTEADY_CONFIG", cfg.string());
    else set_env("HANDSTEADY_MODEL", model.string());  // no method: a model is found -> stgae
    set_env("HANDSTEADY_RECORD", rec.string());
    enable_layers({kLayer});
    const auto layer = run_frames(40);
    for (const Frame& fr : layer)
      for (const Joints& j : fr.hand) REQUIRE(j.result == XR_SUCCESS);
    CHECK(recorded_engine(rec) == "stgae");
  }
}

TEST_CASE("a corrupt model falls back to the mode's classical filter, which still denoises") {
  const TrackFiles f = make_tracks("stgae_corrupt", 4.0);
  const auto bad = corrupt_model(f.dir);
  for (const bool explicit_method : {true, false}) {
    CAPTURE(explicit_method);
    const auto rec = f.dir / (explicit_method ? "rec_method" : "rec_default");
    std::filesystem::remove_all(rec);
    reset_env(f);
    set_env("HANDSTEADY_WORKER", "lockstep");  // simulated clock: deterministic hand-off
  set_env("HANDSTEADY_WORKER", "lockstep");  // simulated clock: deterministic hand-off
    unset_env("HANDSTEADY_METHOD");  // these cases test the layer's own choice of engine
    if (explicit_method) set_env("HANDSTEADY_METHOD", "stgae");
    set_env("HANDSTEADY_MODEL", bad.string());
    set_env("HANDSTEADY_LOG", "off");
    set_env("HANDSTEADY_RECORD", rec.string());
    enable_layers({kLayer});
    {
      App app;
      double sum = 0.0, raw_sum = 0.0;
      long n = 0, raw_n = 0;
      for (int i = 0; i < 300; ++i) {
        const XrTime T = app.frame();
        for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
          const Joints j = app.locate(hand, app.local, T);
          REQUIRE(j.result == XR_SUCCESS);
          if (i < 30) continue;
          const Pose truth = interpolate_pose(f.clean_series[hand - 1], track_time(f, T));
          accumulate_error(j, XrPosef{{0, 0, 0, 1}, {0, 0, 0}}, truth, sum, n);
          accumulate_error(interpolate_pose(f.noisy_series[hand - 1], track_time(f, T)), truth, raw_sum, raw_n);
        }
      }
      app.shutdown();
      REQUIRE(n > 0);
      MESSAGE("fallback " << sum / static_cast<double>(n) * 1e3 << " mm, raw " << raw_sum / static_cast<double>(raw_n) * 1e3
                          << " mm");
      CHECK(sum / static_cast<double>(n) < 0.9 * raw_sum / static_cast<double>(raw_n));
    }
    CHECK(recorded_engine(rec) == "oneeuro");
  }
}
