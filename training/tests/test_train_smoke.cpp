// Training data pieces (features, clips, augmentation), the config parser, and a tiny
// two-epoch training run on synthetic motion (no recorded data needed).
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

#include "train_data.hpp"
#include "trainer.hpp"

#include "handsteady/dgn_layers.hpp"
#include "handsteady/error.hpp"
#include "handsteady/hsm_format.hpp"
#include "handsteady/skeleton.hpp"
#include "handsteady/source_revision.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/synth.hpp"
#include "handsteady/track.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

using namespace hs;
using namespace hs::train;

namespace {

std::filesystem::path temp_dir(const std::string& name) {
  auto p = std::filesystem::temp_directory_path() / ("handsteady_train_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(p);
  return p;
}

Pose line_pose(double offset) {
  Pose p;
  for (int j = 0; j < kJointCount; ++j) p.row(j) << 0.01 * j + offset, 1.0, -0.5;
  return p;
}

const char* kTinyConfig = R"({
  "model": {"window": 8, "horizon": 2, "temporal_kernel": 3, "padding": "causal",
            "encoder_channels": [6, 12, 12], "denoise_decoder_channels": [12, 8, 3],
            "predict_decoder_channels": [12, 3], "attention": "A+B+C", "c_variant": "dot"},
  "data": {"synthetic_takes": 4, "synthetic_seconds": 8},
  "augment": {"speed_factors": [0.8, 1.0]},
  "corruption": {"mix": [{"presets": "tracker", "weight": 1}, {"presets": "paper+tremor", "weight": 1}],
                 "val_presets": ["tracker", "paper"]},
  "train": {"seed": 3, "epochs": 2, "denoise_only_epochs": 0, "batch": 16, "windows_per_epoch": 192,
            "lr": [[0, 0.003], [1, 0.002]], "threads": 1},
  "loss": {"smooth": 0.1}
})";

// The message of the InputError a training run stops with ("" when it runs).
std::string train_error(const TrainConfig& config, const TrainOptions& opt) {
  std::ostringstream log;
  try {
    (void)train_stgae(config, opt, log);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The report of a one-epoch run of config (its model written to out).
EpochReport one_epoch(const TrainConfig& config, const std::filesystem::path& out) {
  TrainOptions o;
  o.progress = false;
  o.out = out;
  std::ostringstream log;
  const TrainResult r = train_stgae(config, o, log);
  REQUIRE(r.epochs.size() == 1);
  return r.epochs[0];
}

// The key a config error names ("(no error)" when the config parses).
std::string error_field(const std::string& text) {
  try {
    (void)parse_train_config(text, "cfg.json");
  } catch (const InputError& e) {
    return e.where().field;
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("input features: hole filling and the 6 channels by hand") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Pose> raw{line_pose(0.0), line_pose(0.02), line_pose(0.05)};
  raw[0].row(idx(Joint::IndexTip)).setConstant(nan);  // never seen yet: takes the wrist
  raw[2].row(idx(Joint::ThumbTip)).setConstant(nan);  // holds its last value
  std::vector<double> f(3 * kJointCount * 6), x(3 * kJointCount * 3);
  REQUIRE(input_features(raw, 0.1, 0.01, f.data(), x.data()));
  auto F = [&](int t, int j, int c) { return f[static_cast<size_t>((t * kJointCount + j) * 6 + c)]; };
  auto X = [&](int t, int j, int c) { return x[static_cast<size_t>((t * kJointCount + j) * 3 + c)]; };
  const int w = idx(Joint::Wrist), tip = idx(Joint::IndexTip), thumb = idx(Joint::ThumbTip);
  CHECK(X(0, tip, 0) == doctest::Approx(X(0, w, 0)));
  CHECK(F(0, tip, 0) == doctest::Approx(0.0));
  // Shape: (x - wrist) / 0.1 m; joint j sits 0.01*(j - 1) m from the wrist along x.
  const int m = idx(Joint::IndexProximal);
  CHECK(F(1, m, 0) == doctest::Approx(0.01 * (m - w) / 0.1));
  // Velocity: 0 at t = 0; the line moved 0.02 m between frames 0 and 1 -> 2 units.
  CHECK(F(0, m, 3) == 0.0);
  CHECK(F(1, m, 3) == doctest::Approx(2.0));
  // The first sighting of the index tip is a jump from the wrist.
  CHECK(F(1, tip, 3) == doctest::Approx((0.01 * tip + 0.02 - (0.01 * w + 0.0)) / 0.01));
  // The held thumb tip does not move in frame 2 while the others moved 0.03 m.
  CHECK(F(2, thumb, 3) == 0.0);
  CHECK(X(2, thumb, 0) == doctest::Approx(0.01 * thumb + 0.02));
  CHECK(F(2, m, 3) == doctest::Approx(3.0));
  // A window whose first frame has nothing tracked is not valid input.
  std::vector<Pose> none{untracked_pose(), line_pose(0.0)};
  CHECK_FALSE(input_features(none, 0.1, 0.01, f.data(), x.data()));
}

TEST_CASE("clips are split at untracked frames and resampled per playback speed") {
  HandSeries s;
  for (int i = 0; i < 30; ++i) {
    s.t.push_back(i / 30.0);
    s.pos.push_back(line_pose(0.001 * i));
  }
  s.pos[10] = untracked_pose();
  const ClipSet one = make_clips({s}, 30.0, {1.0}, 5);
  REQUIRE(one.clips.size() == 2);
  CHECK(one.clips[0].size() == 10);
  CHECK(one.clips[1].size() == 19);
  // Twice the speed: half as many frames, each step covers two original frames.
  const ClipSet fast = make_clips({s}, 30.0, {2.0}, 3);
  REQUIRE(fast.clips.size() == 2);
  CHECK(fast.clips[0].size() == 5);
  CHECK(fast.clips[0][1](0, 0) == doctest::Approx(0.002));
}

TEST_CASE("augmented windows keep bone lengths up to the hand-size scale") {
  SynthMotionParams p;
  p.duration_s = 3;
  const ClipSet clips = make_clips({synth_motion(p, Hand::Right, 1)}, 30.0, {1.0}, 10);
  AugmentConfig aug;
  aug.scale_min = aug.scale_max = 1.1;
  aug.mirror_prob = 0.5;
  const WindowSampler sampler(clips, 8, 2, 30.0, aug, {{{}, 1.0}});  // clean input
  std::mt19937_64 rng(5);
  const auto& bones = xr_hand_skeleton().bones;
  for (int i = 0; i < 20; ++i) {
    const Window w = sampler.draw(rng);
    REQUIRE(w.input.size() == 8);
    REQUIRE(w.truth.size() == 10);
    CHECK((w.input[3] - w.truth[3]).norm() == 0.0);  // no corruption in this mix
    // The first bone's length is 1.1x a length found somewhere in the clip.
    const auto [a, b] = bones[3];
    const double len = (w.truth[0].row(a) - w.truth[0].row(b)).norm();
    const double ref = (clips.clips[0][0].row(a) - clips.clips[0][0].row(b)).norm();
    CHECK(len == doctest::Approx(1.1 * ref).epsilon(1e-9));  // synthetic bones are rigid
  }
}

TEST_CASE("corruption chains are seeded and checked") {
  CHECK(parse_preset_chain("tracker+tremor").size() == 2);
  CHECK(parse_preset_chain("clean").empty());
  CHECK_THROWS_AS(parse_preset_chain("tracker+bogus"), std::invalid_argument);
  std::vector<Pose> clean(20, line_pose(0.0));
  const auto a = corrupt_chain(clean, 30.0, {"tremor"}, 9), b = corrupt_chain(clean, 30.0, {"tremor"}, 9);
  CHECK((a[7] - b[7]).norm() == 0.0);
  CHECK((a[7] - clean[7]).norm() > 1e-5);
}

TEST_CASE("clips are split where a joint jumps faster than a hand moves") {
  HandSeries s;
  for (int i = 0; i < 30; ++i) {
    s.t.push_back(i / 30.0);
    s.pos.push_back(line_pose(0.001 * i + (i >= 12 ? 0.5 : 0.0)));  // 0.5 m in one frame: re-acquired
  }
  CHECK(make_clips({s}, 30.0, {1.0}, 5).clips.size() == 1);  // splitting is off by default
  const ClipSet c = make_clips({s}, 30.0, {1.0}, 5, 8.0);
  REQUIRE(c.clips.size() == 2);
  CHECK(c.clips[0].size() == 12);
  CHECK(c.clips[1].size() == 18);
}

TEST_CASE("random corruption: seeded, varied, per-joint strength, dropped joints stay dropped") {
  std::vector<Pose> clean;
  for (int i = 0; i < 60; ++i) clean.push_back(line_pose(0.002 * i));
  const auto a = corrupt_chain(clean, 30.0, {"random"}, 11), b = corrupt_chain(clean, 30.0, {"random"}, 11);
  bool same = true;  // NaN (a dropped joint) equals NaN here
  for (size_t i = 0; i < a.size(); ++i)
    for (int j = 0; j < kJointCount; ++j)
      for (int k = 0; k < 3; ++k) same = same && (a[i](j, k) == b[i](j, k) || (std::isnan(a[i](j, k)) && std::isnan(b[i](j, k))));
  CHECK(same);
  CHECK(parse_preset_chain("random") == std::vector<std::string>{"random"});
  CHECK_THROWS_AS(parse_preset_chain("random+tracker"), std::invalid_argument);
  // Over many seeds: some corruption is strong, some weak, and the per-joint factors differ.
  double lo = 1e9, hi = 0;
  for (uint64_t seed = 0; seed < 40; ++seed) {
    std::mt19937_64 rng(seed);
    const RandomCorruption rc = random_corruption(rng, 30.0);
    REQUIRE(!rc.steps.empty());
    const auto [mn, mx] = std::minmax_element(rc.joint_scale.begin(), rc.joint_scale.end());
    CHECK(*mn >= 0.5);
    CHECK(*mx <= 1.5);
    CHECK(*mx - *mn > 0.1);
    const auto out = apply_random_corruption(clean, 30.0, rc, seed);
    double sum = 0;
    int n = 0;
    for (size_t i = 0; i < out.size(); ++i)
      for (int j = 0; j < kJointCount; ++j)
        if (out[i].row(j).allFinite()) {
          sum += (out[i].row(j) - clean[i].row(j)).norm();
          ++n;
        }
    const double mean = sum / std::max(n, 1);
    lo = std::min(lo, mean);
    hi = std::max(hi, mean);
  }
  CHECK(lo < 1.5e-3);
  CHECK(hi > 5e-3);
  // A joint scale of 0 removes that joint's corruption, NaN drops survive the scaling.
  std::mt19937_64 rng(3);
  RandomCorruption rc = random_corruption(rng, 30.0);
  rc.steps.front().kind = CorruptionKind::Tracker;
  rc.steps.front().tracker = TrackerCorruption{};
  rc.steps.front().tracker.jitter_sd_m = 0.003;
  rc.steps.front().tracker.joint_drop_prob = 0.3;
  rc.steps.resize(1);
  rc.joint_scale.fill(1.0);
  rc.joint_scale[static_cast<size_t>(idx(Joint::IndexTip))] = 0.0;
  const auto out = apply_random_corruption(clean, 30.0, rc, 8);
  int dropped = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    const auto tip = out[i].row(idx(Joint::IndexTip));
    if (tip.allFinite()) CHECK((tip - clean[i].row(idx(Joint::IndexTip))).norm() == 0.0);
    for (int j = 0; j < kJointCount; ++j) dropped += !out[i].row(j).allFinite();
  }
  CHECK(dropped > 100);
}

TEST_CASE("sources are drawn by weight, still and reshaped windows") {
  SynthMotionParams p;
  p.duration_s = 3;
  ClipSet clips;
  clips.append(make_clips({synth_motion(p, Hand::Right, 1)}, 30.0, {1.0}, 10), 3.0);
  clips.append(make_clips({synth_motion(p, Hand::Right, 2)}, 30.0, {1.0}, 10), 1.0);
  REQUIRE(clips.group_weight.size() == 2);
  AugmentConfig aug;
  aug.rotate = false;
  aug.translate_m = 0;
  aug.scale_min = aug.scale_max = 1.0;
  aug.mirror_prob = 0;
  // Which source a window came from: its first frame is a frame of that clip.
  const auto from_first = [&](const Pose& q) {
    for (const auto& f : clips.clips[0])
      if ((f - q).norm() < 1e-12) return 0;
    return 1;
  };
  {
    const WindowSampler sampler(clips, 8, 2, 30.0, aug, {{{}, 1.0}});
    std::mt19937_64 rng(5);
    int first = 0;
    for (int i = 0; i < 400; ++i) first += from_first(sampler.draw(rng).truth[0]) == 0;
    CHECK(first > 260);  // 3:1 -> 300 expected
    CHECK(first < 340);
  }
  {
    AugmentConfig still = aug;
    still.still_prob = 1.0;
    const WindowSampler sampler(clips, 8, 2, 30.0, still, {{{}, 1.0}});
    std::mt19937_64 rng(6);
    const Window w = sampler.draw(rng);
    for (const auto& q : w.truth) CHECK((q - w.truth[0]).norm() == 0.0);
  }
  {
    AugmentConfig shaped = aug;
    shaped.shape_prob = 1.0;
    const WindowSampler sampler(clips, 8, 2, 30.0, shaped, {{{}, 1.0}});
    std::mt19937_64 rng(7);
    const auto& bones = xr_hand_skeleton().bones;
    int changed = 0;
    for (int i = 0; i < 10; ++i) {
      const Window w = sampler.draw(rng);
      const Pose& ref = clips.clips[0][0];
      for (const auto& [a, b] : bones)
        changed += std::abs((w.truth[0].row(a) - w.truth[0].row(b)).norm() - (ref.row(a) - ref.row(b)).norm()) > 1e-4;
    }
    CHECK(changed > 50);
  }
}

TEST_CASE("a slower tracker upsampled by its runtime: samples kept at their frames, joined linearly") {
  // Frame f's pose: every coordinate = f, joint 3 missing at frame 4.
  std::vector<Pose> frames(12);
  for (size_t f = 0; f < frames.size(); ++f) frames[f].setConstant(static_cast<double>(f));
  frames[4].row(3).setConstant(std::nan(""));
  // 30 Hz under 90: a sample every 3 frames from frame 1, held before it.
  const auto up = upsampled_from(frames, 90.0, 30.0, 1.0);
  REQUIRE(up.size() == frames.size());
  CHECK(up[0](0, 0) == doctest::Approx(0.0 + 1.0 * 2.0 / 3.0));  // between the clamped sample at -2 (frame 0) and 1
  CHECK(up[1](0, 0) == 1.0);
  CHECK(up[2](0, 0) == doctest::Approx(2.0));  // a ramp stays a ramp between samples
  CHECK(up[4](0, 0) == 4.0);
  // Frame 7 lies between the samples at 7 and 10: exactly the sample.
  CHECK(up[7](0, 0) == 7.0);
  // Joint 3 is missing at the sample at 4: frames 4-6 take the sample at 7's value.
  CHECK(up[5](3, 0) == 7.0);
  CHECK(up[5](0, 0) == doctest::Approx(5.0));
  CHECK(up[3](3, 0) == 1.0);  // samples 1 and 4: missing at 4, so 1's value

  // Noise between samples is interpolated, not the frame's own: white noise comes out smoother.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Pose> noise(300);
  for (auto& p : noise)
    for (int j = 0; j < kJointCount; ++j)
      for (int c = 0; c < 3; ++c) p(j, c) = n(rng);
  const auto smooth = upsampled_from(noise, 90.0, 45.0, 0.5);
  double d_in = 0, d_out = 0;
  for (size_t f = 1; f < noise.size(); ++f) {
    d_in += (noise[f] - noise[f - 1]).squaredNorm();
    d_out += (smooth[f] - smooth[f - 1]).squaredNorm();
  }
  CHECK(d_out < 0.5 * d_in);
  // At the model's own rate with phase 0 nothing changes.
  const auto same = upsampled_from(noise, 90.0, 90.0, 0.0);
  double diff = 0;
  for (size_t f = 0; f < noise.size(); ++f) diff = std::max(diff, (same[f] - noise[f]).cwiseAbs().maxCoeff());
  CHECK(diff == 0.0);
  // In the sampler: with upsample_prob 1 the window's input differs from the plain corruption.
  SynthMotionParams p;
  p.duration_s = 3;
  ClipSet clips;
  clips.append(make_clips({synth_motion(p, Hand::Right, 1)}, 90.0, {1.0}, 10), 1.0);
  AugmentConfig aug;
  aug.upsample_prob = 1.0;
  const WindowSampler sampler(clips, 24, 5, 90.0, aug, {{{"tracker"}, 1.0}});
  std::mt19937_64 r2(4);
  const Window w = sampler.draw(r2);
  CHECK(w.input.size() == 24);
  CHECK(w.truth.size() == 29);
  const auto c = parse_train_config(R"({"model": {}, "augment": {"upsample_prob": 0.5, "upsample_hz": [30, 72]}})");
  CHECK(c.augment.upsample_prob == 0.5);
  CHECK(c.augment.upsample_max_hz == 72.0);
  CHECK(error_field(R"({"model": {}, "augment": {"upsample_prob": -1}})") == "augment.upsample_prob");
  CHECK(error_field(R"({"model": {}, "augment": {"upsample_hz": [60, 30]}})") == "augment.upsample_hz");
  CHECK(error_field(R"({"model": {}, "train": {"init_matching": true}})") == "train.init_matching");
}

TEST_CASE("data sources in the config: lists, legacy FPHA keys, errors by key") {
  const auto c = parse_train_config(R"({"model": {}, "data": {
      "train": [{"fpha": "/d/fpha", "subjects": [1, 2], "weight": 2}, {"path": "/d/leap", "exclude": ["s04_"]}],
      "val": [{"path": "/d/manip", "include": ["cup1"]}]},
      "augment": {"shape_prob": 0.5, "still_prob": 0.1},
      "train": {"sequence": 24, "predict_frames": 4}, "loss": {"predict_smooth": 0.5, "relative_eps_mm": 0.5}})");
  REQUIRE(c.train_sources.size() == 2);
  CHECK(c.train_sources[0].fpha);
  CHECK(c.train_sources[0].weight == 2.0);
  CHECK(c.train_sources[1].exclude == std::vector<std::string>{"s04_"});
  CHECK(c.val_sources[0].include == std::vector<std::string>{"cup1"});
  CHECK(c.sequence_length() == 24);
  CHECK(c.loss.predict_smooth == 0.5);
  CHECK(c.loss.relative_eps_mm == 0.5);
  const auto legacy = parse_train_config(R"({"model": {}, "data": {"root": "/r", "train_subjects": [3]}})");
  REQUIRE(legacy.train_sources.size() == 1);
  CHECK(legacy.train_sources[0].subjects == std::vector<int>{3});
  CHECK(legacy.val_sources[0].subjects == std::vector<int>{5});
  CHECK(error_field(R"({"model": {}, "data": {"root": "/r", "train": [{"path": "x"}], "val": [{"path": "y"}]}})") == "data");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"path": "x"}]}})") == "data");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"fpha": "x"}], "val": [{"path": "y"}]}})") == "data.train[0].subjects");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"path": "x", "bogus": 1}], "val": [{"path": "y"}]}})") ==
        "data.train[0].bogus");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"path": "x"}], "val": [{"path": "y", "weight": 0}]}})") ==
        "data.val[0].weight");
  CHECK(error_field(R"({"model": {}, "augment": {"still_prob": 2}})") == "augment.still_prob");
  CHECK(error_field(R"({"model": {}, "loss": {"relative_eps_mm": -1}})") == "loss.relative_eps_mm");
  CHECK(error_field(R"({"model": {}, "data": {"split_speed_mps": -1}})") == "data.split_speed_mps");
  CHECK(error_field(R"({"model": {"window": 8}, "train": {"sequence": 4}})") == "train.sequence");
  CHECK(error_field(R"({"model": {"window": 8}, "train": {"sequence": 12, "predict_frames": 12}})") == "train.predict_frames");
  // Files of a source: include/exclude by name, sorted; a missing path is an error naming it.
  const auto dir = temp_dir("sources");
  for (const char* f : {"s01_a.csv", "s04_b.csv", "notes.txt", "m.bvh"}) std::ofstream(dir / f) << "";
  DataSource d;
  d.path = dir;
  d.exclude = {"s04_"};
  const auto files = source_files(d);
  REQUIRE(files.size() == 2);
  CHECK(files[0].filename() == "m.bvh");
  CHECK(files[1].filename() == "s01_a.csv");
  d.path = dir / "missing";
  CHECK_THROWS_AS(source_files(d), InputError);
  std::filesystem::remove_all(dir);
}

TEST_CASE("training config errors name the key") {
  CHECK(error_field(R"({"model": {}, "train": {"epochs": 0}})") == "train.epochs");
  CHECK(error_field(R"({"model": {}, "train": {"epocs": 3}})") == "train.epocs");
  CHECK(error_field(R"({"model": {}, "train": {"lr": [[1, 0.001]]}})") == "train.lr");
  CHECK(error_field(R"({"model": {}, "corruption": {"val_presets": ["nope"]}})") == "corruption.val_presets");
  CHECK(error_field(R"({"model": {}, "data": {"train_subjects": [1, 5]}})") == "data.val_subjects");
  CHECK(error_field(R"({"train": {}})") == "model");
  CHECK(error_field(R"({"model": {"window": "x"}})") == "window");
  // The DGN schedule's keys.
  CHECK(error_field(R"({"model": {}, "train": {"freeze_graph_epochs": 2}})") == "train.freeze_graph_epochs");
  CHECK(error_field(R"({"model": {}, "loss": {"stages": [{"epoch": 0, "bones": 1}]}})") == "loss.stages[0].bones");
  CHECK(error_field(R"({"model": {}, "loss": {"stages": [{"epoch": 0, "bone": -1}]}})") == "loss.stages[0].bone");
  CHECK(error_field(R"({"model": {}, "loss": {"stages": [{"epoch": 3}, {"epoch": 3}]}})") == "loss.stages[1].epoch");
  CHECK(error_field(R"({"model": {}, "loss": {"stages": [{"bone": 1}]}})") == "loss.stages[0]");
  // Fine-tuning keys.
  CHECK(error_field(R"({"model": {}, "train": {"init": 3}})") == "train.init");
  CHECK(error_field(R"({"model": {}, "train": {"freeze": "enc"}})") == "train.freeze");
  CHECK(error_field(R"({"model": {}, "train": {"freeze": ["enc", ""]}})") == "train.freeze");
  // Distillation keys: the teacher, its weight and the marked sources go together.
  const std::string sources = R"("data": {"train": [{"path": "x", "distill": true}], "val": [{"path": "y"}]})";
  CHECK(error_field(R"({"model": {}, "loss": {"distill": 1}})") == "loss.distill");
  CHECK(error_field(R"({"model": {}, "loss": {"stages": [{"epoch": 2, "distill": 1}]}})") == "loss.distill");
  CHECK(error_field(R"({"model": {}, "train": {"teacher": "t.hsm"}, "loss": {"distill": 1}})") == "train.teacher");
  CHECK(error_field(R"({"model": {}, )" + sources + R"(, "train": {"teacher": "t.hsm"}})") == "train.teacher");
  CHECK(error_field(R"({"model": {}, )" + sources + R"(})") == "data.train");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"path": "x", "distill": 1}], "val": [{"path": "y"}]}})") ==
        "data.train[0].distill");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"path": "x"}], "val": [{"path": "y", "distill": true}]}})") ==
        "data.val[0].distill");
  const auto d = parse_train_config(R"({"model": {}, )" + sources + R"(, "train": {"teacher": "t.hsm"}, "loss": {"distill": 2}})");
  CHECK(d.train_sources[0].distill);
  CHECK(d.teacher == "t.hsm");
  CHECK(d.loss.distill == 2.0);
  CHECK(error_field(R"({"model": {}, "loss": {"distill_displacement": 1}})") == "loss.distill");
  CHECK(parse_train_config(R"({"model": {}, )" + sources +
                           R"(, "train": {"teacher": "t.hsm"}, "loss": {"distill_displacement": 3}})")
            .loss.distill_displacement == 3.0);
  CHECK(error_field(R"({"model": {}, "train": {"fixed_norm": 1}})") == "train.fixed_norm");
  CHECK(parse_train_config(R"({"model": {}, "train": {"fixed_norm": true}})").fixed_norm);
  const auto c = parse_train_config(R"({"model": {}, "train": {"lr": [[0, 0.01], [5, 0.001]]}})");
  CHECK(learning_rate(c, 4) == 0.01);
  CHECK(learning_rate(c, 5) == 0.001);
}

// The file and the field an InputError names ("(no error)" when the file reads).
std::pair<std::string, std::string> file_error(const std::filesystem::path& path) {
  try {
    (void)read_train_config(path);
  } catch (const InputError& e) {
    return {e.where().file, e.where().field};
  }
  return {"(no error)", ""};
}

TEST_CASE("a config file names a base and gives only what it changes (JSON merge patch)") {
  const auto dir = temp_dir("base");
  auto write = [&](const std::string& name, const std::string& text) {
    std::filesystem::create_directories((dir / name).parent_path());
    std::ofstream(dir / name) << text;
    return dir / name;
  };
  write("base.json", R"({"model": {"window": 8, "horizon": 2, "predict_decoder_channels": [64, 16, 3]},
    "train": {"epochs": 5, "lr": [[0, 0.01], [3, 0.001]]}, "loss": {"predict": 0.5, "smooth": 0.2}})");
  // Objects merge key by key, arrays replace whole, null removes (back to the default).
  write("sub/child.json", R"({"base": "../base.json", "train": {"lr": [[0, 0.02]]},
    "model": {"predict_decoder_channels": null}, "loss": {"smooth": 0.3}})");
  const TrainConfig c = read_train_config(dir / "sub/child.json");
  const TrainConfig defaults = parse_train_config(R"({"model": {}})");
  CHECK(c.model.window == 8);
  CHECK(c.model.horizon == 2);
  CHECK(c.model.predict_decoder_channels == defaults.model.predict_decoder_channels);
  CHECK(c.epochs == 5);
  REQUIRE(c.lr.size() == 1);
  CHECK(c.lr[0].second == 0.02);
  CHECK(c.loss.predict == 0.5);
  CHECK(c.loss.smooth == 0.3);
  // The model's meta keeps the resolved recipe, not the patch.
  CHECK(c.json.find("\"base\"") == std::string::npos);
  CHECK(c.json.find("\"window\": 8") != std::string::npos);
  // Bases chain.
  write("grandchild.json", R"({"base": "sub/child.json", "train": {"epochs": 7}})");
  const TrainConfig g = read_train_config(dir / "grandchild.json");
  CHECK(g.epochs == 7);
  CHECK(g.loss.smooth == 0.3);
  CHECK(g.model.window == 8);
  // Errors name the file and the key: a missing base, a cycle, a base that is no path, a
  // bad key in the base itself, and "base" in config text read without a file.
  write("missing.json", R"({"base": "nope.json"})");
  CHECK(file_error(dir / "missing.json").first == (dir / "nope.json").string());
  write("a.json", R"({"base": "b.json"})");
  write("b.json", R"({"base": "a.json"})");
  CHECK(file_error(dir / "a.json") == std::pair<std::string, std::string>{(dir / "b.json").string(), "base"});
  write("self.json", R"({"base": "self.json"})");
  CHECK(file_error(dir / "self.json").second == "base");
  write("number.json", R"({"base": 3, "model": {}})");
  CHECK(file_error(dir / "number.json") == std::pair<std::string, std::string>{(dir / "number.json").string(), "base"});
  write("badbase.json", R"({"model": {}, "train": {"epocs": 3}})");
  write("usesbad.json", R"({"base": "badbase.json"})");
  CHECK(file_error(dir / "usesbad.json").second == "train.epocs");
  CHECK(error_field(R"({"base": "x.json", "model": {}})") == "base");
  std::filesystem::remove_all(dir);
}

TEST_CASE("sources and the corruption mix keyed by name: same recipe, a patch changes or drops one entry") {
  const auto listed = parse_train_config(R"({"model": {}, "data": {
      "train": [{"path": "/d/leap", "weight": 1}, {"fpha": "/d/fpha", "subjects": [1, 2], "weight": 2}],
      "val": [{"path": "/d/manip"}]},
      "corruption": {"mix": [{"presets": "tracker", "weight": 3}, {"presets": "paper+tremor", "weight": 1}]}})");
  // Keys that sort the other way round: the order given is the order taken.
  const auto keyed = parse_train_config(R"({"model": {}, "data": {
      "train": {"z_leap": {"path": "/d/leap", "weight": 1}, "a_fpha": {"fpha": "/d/fpha", "subjects": [1, 2], "weight": 2}},
      "val": {"manip": {"path": "/d/manip"}}},
      "corruption": {"mix": {"tracker": 3, "paper+tremor": 1}}})");
  REQUIRE(keyed.train_sources.size() == 2);
  for (size_t i = 0; i < 2; ++i) {
    CHECK(keyed.train_sources[i].path == listed.train_sources[i].path);
    CHECK(keyed.train_sources[i].fpha == listed.train_sources[i].fpha);
    CHECK(keyed.train_sources[i].weight == listed.train_sources[i].weight);
  }
  CHECK(keyed.val_sources[0].path == listed.val_sources[0].path);
  REQUIRE(keyed.mix.size() == 2);
  for (size_t i = 0; i < 2; ++i) {
    CHECK(keyed.mix[i].presets == listed.mix[i].presets);
    CHECK(keyed.mix[i].weight == listed.mix[i].weight);
  }
  // A derived config changes one weight and drops one entry by name; the rest keep their place.
  const auto dir = temp_dir("keyed");
  std::ofstream(dir / "base.json") << R"({"model": {}, "data": {
      "train": {"leap": {"path": "/d/leap"}, "fpha": {"fpha": "/d/fpha", "subjects": [1], "weight": 2}, "bvh": {"path": "/d/b"}},
      "val": {"manip": {"path": "/d/manip"}}},
      "corruption": {"mix": {"tracker": 3, "paper": 2, "tremor": 1}}})";
  std::ofstream(dir / "child.json") << R"({"base": "base.json", "data": {"train": {"fpha": {"weight": 5}, "leap": null}},
      "corruption": {"mix": {"paper": 4, "clean": 0.5}}})";
  const TrainConfig c = read_train_config(dir / "child.json");
  REQUIRE(c.train_sources.size() == 2);
  CHECK(c.train_sources[0].fpha);
  CHECK(c.train_sources[0].weight == 5.0);
  CHECK(c.train_sources[0].subjects == std::vector<int>{1});
  CHECK(c.train_sources[1].path == "/d/b");
  REQUIRE(c.mix.size() == 4);
  CHECK(c.mix[1].presets == std::vector<std::string>{"paper"});
  CHECK(c.mix[1].weight == 4.0);
  CHECK(c.mix[3].presets.empty());  // "clean", added last
  std::filesystem::remove_all(dir);
  // Errors name the entry by its key.
  CHECK(error_field(R"({"model": {}, "data": {"train": {"leap": {"path": "x", "bogus": 1}}, "val": [{"path": "y"}]}})") ==
        "data.train.leap.bogus");
  CHECK(error_field(R"({"model": {}, "data": {"train": {}, "val": [{"path": "y"}]}})") == "data.train");
  CHECK(error_field(R"({"model": {}, "corruption": {"mix": {"nope": 1}}})") == "corruption.mix.nope");
  CHECK(error_field(R"({"model": {}, "corruption": {"mix": {"tracker": "3"}}})") == "corruption.mix.tracker");
  CHECK(error_field(R"({"model": {}, "corruption": {"mix": {"tracker": -1}}})") == "corruption.mix.tracker");
  CHECK(error_field(R"({"model": {}, "corruption": {"mix": 3}})") == "corruption.mix");
  // Found by fuzz_train_config: a number too large for a double was another exception type.
  CHECK_THROWS_AS(parse_train_config(R"({"model": {}, "train": {"grad_clip": 1e3028}})"), InputError);
  // Found by fuzz_train_config (2026-11-27): numbers out of an integer's range were cast
  // (5.6e113 into an int: undefined behaviour; 2^32 + 5 became 5), and a fraction was truncated.
  CHECK(error_field(R"({"model": {}, "data": {"root": "/r", "train_subjects": [5.6e113, 2], "val_subjects": [5]}})") ==
        "data.train_subjects[0]");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"fpha": "/r", "subjects": [1, 4294967297]}],
                        "val": [{"path": "y"}]}})") == "data.train[0].subjects[1]");
  CHECK(error_field(R"({"model": {}, "train": {"lr": [[4294967296, 0.01]]}})") == "train.lr");
  CHECK(error_field(R"({"model": {}, "loss": {"stages": [{"epoch": 4294967296}]}})") == "loss.stages[0].epoch");
  CHECK(error_field(R"({"model": {}, "train": {"epochs": 2.5}})") == "train.epochs");
  CHECK(error_field(R"({"model": {}, "train": {"seed": -1}})") == "train.seed");
  CHECK(error_field(R"({"model": {}, "train": {"seed": 18446744073709551615}})") == "(no error)");
  CHECK(error_field(R"({"model": {}, "augment": {"speed_factors": [1, "2"]}})") == "augment.speed_factors[1]");
}

TEST_CASE("every training config in models/configs reads (bases resolved)") {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(HS_MODEL_CONFIGS)) {
    if (e.path().extension() != ".json") continue;
    CAPTURE(e.path().string());
    CHECK(file_error(e.path()).first == "(no error)");
    ++n;
  }
  CHECK(n >= 5);
  // An ablation is its base with the keys it names changed: the STGAE config is the shipped
  // Multi-STGAE's without the prediction branch.
  const TrainConfig shipped = read_train_config(std::filesystem::path(HS_MODEL_CONFIGS) / "shipped_causal_xr26.json");
  const TrainConfig stgae = read_train_config(std::filesystem::path(HS_MODEL_CONFIGS) / "stgae_causal_xr26.json");
  CHECK(shipped.model.predict);
  CHECK_FALSE(stgae.model.predict);
  CHECK(stgae.model.encoder_channels == shipped.model.encoder_channels);
  CHECK(stgae.epochs == shipped.epochs);
  // A keyed source changed by name: the FPHA-5 ablation is the data ablation with one weight.
  const TrainConfig data = read_train_config(std::filesystem::path(HS_MODEL_CONFIGS) / "ablation_data_xr26.json");
  const TrainConfig fpha5 = read_train_config(std::filesystem::path(HS_MODEL_CONFIGS) / "ablation_data_fpha5_xr26.json");
  REQUIRE(fpha5.train_sources.size() == data.train_sources.size());
  for (size_t i = 0; i < data.train_sources.size(); ++i) {
    CHECK(fpha5.train_sources[i].path == data.train_sources[i].path);
    CHECK(fpha5.train_sources[i].weight == (data.train_sources[i].fpha ? 5.0 : data.train_sources[i].weight));
  }
  CHECK(fpha5.mix.size() == shipped.mix.size());
}

TEST_CASE("two tiny epochs on synthetic motion: the loss decreases, the model file loads, resume continues") {
  const auto dir = temp_dir("smoke");
  const auto out = dir / "tiny.hsm";
  const TrainConfig config = parse_train_config(kTinyConfig, "tiny");
  TrainOptions opt;
  opt.out = out;
  opt.progress = false;
  std::ostringstream log;
  const TrainResult r = train_stgae(config, opt, log);
  INFO(log.str());
  REQUIRE(r.epochs.size() == 2);
  CHECK(r.epochs[1].train_loss < r.epochs[0].train_loss);
  CHECK(r.epochs[1].val_loss < r.epochs[0].val_loss);
  // Metrics per validation preset (their values are the real run's business).
  REQUIRE(r.epochs[1].val.size() == 2);
  CHECK(r.epochs[1].val[0].predicted_mpjpe_mm.size() == 2);
  const auto model = load_hsm(out, true);  // verifies the engine reproduces the reference
  CHECK(model->config.window == 8);
  CHECK(model->config.meta_json.find("\"epoch\"") != std::string::npos);

  // Resume: one more epoch starts at epoch index 2.
  opt.resume = std::filesystem::path(out.string() + ".ckpt");
  opt.epochs = 3;
  std::ostringstream log2;
  const TrainResult r2 = train_stgae(config, opt, log2);
  REQUIRE(r2.epochs.size() == 1);
  CHECK(r2.epochs[0].epoch == 2);
  CHECK(r2.epochs[0].train_loss < r.epochs[0].train_loss);

  // Longer training sequences with predictions at several frames and their smoothness.
  {
    TrainConfig seq = config;
    seq.sequence = 12;
    seq.predict_frames = 4;
    seq.loss.predict_smooth = 0.5;
    seq.loss.relative_eps_mm = 0.5;
    seq.epochs = 1;
    TrainOptions o;
    o.out = dir / "seq.hsm";
    o.progress = false;
    std::ostringstream l;
    const TrainResult rs = train_stgae(seq, o, l);
    INFO(l.str());
    REQUIRE(rs.epochs.size() == 1);
    CHECK(std::isfinite(rs.epochs[0].val_loss));
    CHECK(load_hsm(o.out, true)->config.window == 8);
  }

  // loss.newest: the newest frame's squared error added with its weight. Started from the
  // trained model at a learning rate that moves nothing, the validation loss (fixed windows,
  // eval mode) grows linearly in the weight, by a positive error.
  {
    TrainConfig nw = config;
    nw.epochs = 1;
    nw.lr = {{0, 1e-12}};
    nw.init = out.string();
    // The term's value at weight 1 (the validation loss at weights 1 and 3 less that at 0),
    // checked positive and linear in the weight.
    double base = 0;
    const auto term = [&](const LossWeights& loss) {
      std::vector<double> val;
      for (double w : {0.0, 1.0, 3.0}) {
        nw.loss = loss;
        nw.loss.newest = w;
        val.push_back(one_epoch(nw, dir / "newest.hsm").val_loss);
      }
      if (base == 0) base = val[0];
      CHECK(val[0] == doctest::Approx(base).epsilon(1e-9));  // the weighting alone adds nothing
      const double t = val[1] - val[0];
      CHECK(t > 1e-4 * val[0]);
      CHECK(val[2] - val[0] == doctest::Approx(3 * t).epsilon(1e-3));
      return t;
    };
    const double plain = term(config.loss);
    // loss.newest_by_speed: each joint's error weighted by the truth's speed over the
    // batch's mean: another value (the error is not independent of the speed: the model
    // lags fast joints).
    LossWeights by_speed = config.loss;
    by_speed.newest_by_speed = true;
    CHECK(std::abs(term(by_speed) - plain) > 1e-3 * plain);
    // loss.newest_relative_eps_mm: each window weighted by 1 / (its input's error + eps^2):
    // another value (the windows' input errors differ: the config's corruption mix).
    LossWeights relative = config.loss;
    relative.newest_relative_eps_mm = 1.0;
    CHECK(std::abs(term(relative) - plain) > 1e-3 * plain);
  }
  // A source marked "newest": false: its windows count zero in the term, still divided by
  // every window, so on the same batches (the flag draws nothing) the term with one source
  // off plus the term with the other off is the term with both on. The training loss, not
  // validation's (validation windows always count), at a learning rate that moves nothing.
  {
    SynthMotionParams mp;
    mp.duration_s = 8;
    for (int k = 0; k < 3; ++k) {
      Track track;
      add_hand_series(track, Hand::Right, synth_motion(mp, Hand::Right, 11 + static_cast<uint64_t>(k)));
      write_track_csv(track, dir / ("src" + std::to_string(k) + ".csv"));
    }
    const auto src = [&](int k) { return (dir / ("src" + std::to_string(k) + ".csv")).string(); };
    std::string text = kTinyConfig;
    const std::string synthetic = R"("data": {"synthetic_takes": 4, "synthetic_seconds": 8})";
    text.replace(text.find(synthetic), synthetic.size(),
                 R"("data": {"train": {"a": {"path": ")" + src(0) + R"("}, "b": {"path": ")" + src(1) +
                     R"("}}, "val": [{"path": ")" + src(2) + R"("}]})");
    TrainConfig files = parse_train_config(text);
    files.epochs = 1;
    files.lr = {{0, 1e-12}};
    files.init = out.string();
    const auto train_term = [&](bool a, bool b) {
      files.train_sources[0].newest = a;
      files.train_sources[1].newest = b;
      double loss[2];
      for (int i = 0; i < 2; ++i) {
        files.loss.newest = i;
        loss[i] = one_epoch(files, dir / "sources.hsm").train_loss;
      }
      return loss[1] - loss[0];
    };
    const double both = train_term(true, true), only_a = train_term(true, false), only_b = train_term(false, true);
    CHECK(both > 1e-4);
    CHECK(only_a > 0.05 * both);
    CHECK(only_b > 0.05 * both);
    CHECK(only_a + only_b == doctest::Approx(both).epsilon(1e-4));
  }
  CHECK(parse_train_config(R"({"model": {}, "loss": {"newest": 2, "stages": [{"epoch": 1, "newest": 0.5}]}})")
            .loss_stages[0]
            .second.newest == 0.5);
  CHECK(error_field(R"({"model": {}, "loss": {"newest": -1}})") == "loss");
  CHECK(parse_train_config(R"({"model": {}, "loss": {"newest": 2, "newest_by_speed": true}})").loss.newest_by_speed);
  CHECK(error_field(R"({"model": {}, "loss": {"newest_by_speed": 1}})") == "loss.newest_by_speed");
  CHECK(error_field(R"({"model": {}, "loss": {"newest_relative_eps_mm": -1}})") == "loss.newest_relative_eps_mm");
  // "newest" per training source: a flag, only for training sources, and only with the term.
  const std::string two = R"("data": {"train": [{"path": "x", "newest": false}, {"path": "z"}], "val": [{"path": "y"}]})";
  CHECK(!parse_train_config(R"({"model": {}, )" + two + R"(, "loss": {"newest": 2}})").train_sources[0].newest);
  CHECK(parse_train_config(R"({"model": {}, )" + two + R"(, "loss": {"newest": 2}})").train_sources[1].newest);
  CHECK(parse_train_config(R"({"model": {}, )" + two + R"(, "loss": {"stages": [{"epoch": 1, "newest": 1}]}})")
            .train_sources.size() == 2);
  CHECK(error_field(R"({"model": {}, )" + two + R"(})") == "data.train");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"path": "x", "newest": false}], "val": [{"path": "y"}]},
                        "loss": {"newest": 1}})") == "data.train");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"path": "x", "newest": 0}], "val": [{"path": "y"}]}})") ==
        "data.train[0].newest");
  CHECK(error_field(R"({"model": {}, "data": {"train": [{"path": "x"}], "val": [{"path": "y", "newest": true}]}})") ==
        "data.val[0].newest");

  // A checkpoint of another architecture is refused.
  TrainConfig other = config;
  other.model.encoder_channels = {6, 10, 12};
  CHECK_THROWS_AS(train_stgae(other, opt, log2), InputError);

  // Fine-tuning (train.init): at a learning rate that hardly moves a weight, one epoch
  // started from the trained model validates like it; started from random weights, not.
  {
    TrainConfig ft = config;
    ft.epochs = 1;
    ft.lr = {{0, 1e-7}};
    TrainOptions o;
    o.progress = false;
    o.out = dir / "random.hsm";
    std::ostringstream l;
    const TrainResult rr = train_stgae(ft, o, l);
    ft.init = out.string();
    o.out = dir / "finetuned.hsm";
    const TrainResult rf = train_stgae(ft, o, l);
    INFO(l.str());
    CHECK(l.str().find("initialised from " + out.string()) != std::string::npos);
    REQUIRE(rf.epochs.size() == 1);
    REQUIRE(rr.epochs.size() == 1);
    CHECK(rf.epochs[0].val_loss < r.epochs[0].val_loss);
    CHECK(rf.epochs[0].val_loss < 0.8 * rr.epochs[0].val_loss);
    // A model of another architecture is refused, naming the file.
    TrainConfig bad = other;
    bad.init = out.string();
    bad.epochs = 1;
    o.out = dir / "bad.hsm";
    std::string msg = train_error(bad, o);
    CHECK(msg.find(out.string()) != std::string::npos);
    CHECK(msg.find("train.init") != std::string::npos);

    // Frozen parts (train.freeze): the encoder and the prediction decoder keep every
    // value, BatchNorm statistics included; the denoising decoder trains.
    ft.lr = {{0, 0.003}};
    ft.freeze = {"enc", "pre"};
    o.out = dir / "den_only.hsm";
    std::ostringstream lf;
    (void)train_stgae(ft, o, lf);
    INFO(lf.str());
    const auto before = load_hsm(out, true), after = load_hsm(o.out, true);
    int same = 0, changed = 0;
    for (const auto& [name, t] : before->weights.tensors) {
      const bool eq = t.data == after->weights.at(name).data;
      if (name.starts_with("enc") || name.starts_with("pre")) {
        CHECK_MESSAGE(eq, name);
        same += eq ? 1 : 0;
      } else {
        changed += eq ? 0 : 1;
      }
    }
    CHECK(same > 10);
    CHECK(changed > 3);
    ft.freeze = {"enc", "decoder"};
    msg = train_error(ft, o);
    CHECK(msg.find("train.freeze") != std::string::npos);
    CHECK(msg.find("decoder") != std::string::npos);

    // train.fixed_norm: every BatchNorm keeps its running statistics; the weights train.
    ft.freeze.clear();
    ft.fixed_norm = true;
    o.out = dir / "fixed_norm.hsm";
    std::ostringstream ln;
    (void)train_stgae(ft, o, ln);
    INFO(ln.str());
    const auto fixed = load_hsm(o.out, true);
    int stats = 0, trained = 0;
    for (const auto& [name, t] : before->weights.tensors) {
      const bool eq = t.data == fixed->weights.at(name).data;
      if (name.ends_with("running_mean") || name.ends_with("running_var")) {
        CHECK_MESSAGE(eq, name);
        ++stats;
      } else {
        trained += eq ? 0 : 1;
      }
    }
    CHECK(stats > 10);
    CHECK(trained > 10);
  }

  // Distillation (train.teacher): trained on the teacher's answers alone (every truth term
  // off), a network from random weights denoises and predicts far better than one that did
  // not learn; with no window marked, the distillation term is zero and it learns nothing.
  {
    TrainConfig ds = config;
    ds.epochs = 2;
    ds.denoise_only_epochs = 1;
    ds.lr = {{0, 0.01}};
    ds.loss.pose = ds.loss.bone = ds.loss.symmetry = ds.loss.smooth = ds.loss.predict = ds.loss.predict_smooth = 0;
    ds.loss.distill = 1;
    ds.teacher = out.string();
    ds.train_sources[0].distill = true;  // synthetic motion: one group, this source's place
    TrainOptions o;
    o.progress = false;
    o.out = dir / "distilled.hsm";
    std::ostringstream l;
    const TrainResult rd = train_stgae(ds, o, l);
    INFO(l.str());
    CHECK(l.str().find("teacher " + out.string()) != std::string::npos);
    ds.train_sources[0].distill = false;
    o.out = dir / "unmarked.hsm";
    const TrainResult ru = train_stgae(ds, o, l);
    REQUIRE(rd.epochs.size() == 2);
    REQUIRE(ru.epochs.size() == 2);
    CHECK(ru.epochs[1].train_loss == 0.0);
    CHECK(rd.epochs[1].train_loss > 0.0);
    // (the validation loss weighs the truth terms only, all 0 here: compare the metrics)
    const auto& vd = rd.epochs[1].val[0];
    const auto& vu = ru.epochs[1].val[0];
    CHECK(vd.denoised_mpjpe_mm < 0.8 * vu.denoised_mpjpe_mm);
    REQUIRE(vd.predicted_mpjpe_mm.size() == 2);
    CHECK(vd.predicted_mpjpe_mm[1] < vu.predicted_mpjpe_mm[1]);
    // The displacement term alone: nothing to learn in the denoising phase, something in
    // the joint one.
    ds.train_sources[0].distill = true;
    ds.loss.distill = 0;
    ds.loss.distill_displacement = 1;
    o.out = dir / "displacement.hsm";
    const TrainResult rm = train_stgae(ds, o, l);
    REQUIRE(rm.epochs.size() == 2);
    CHECK(rm.epochs[0].train_loss == 0.0);
    CHECK(rm.epochs[1].train_loss > 0.0);
    // A teacher of another architecture is refused, naming the file and the key.
    TrainConfig bad = other;
    bad.teacher = out.string();
    bad.loss.distill = 1;
    bad.train_sources[0].distill = true;
    bad.epochs = 1;
    o.out = dir / "bad_teacher.hsm";
    const std::string msg = train_error(bad, o);
    CHECK(msg.find(out.string()) != std::string::npos);
    CHECK(msg.find("train.teacher") != std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

#ifdef HS_CLI_PATH
// A tiny DGN with the three-stage schedule's keys; `freeze` first epochs keep S, T.
std::string tiny_dgn_config(int freeze) {
  return R"({
  "model": {"family": "dgn", "window": 8, "horizon": 2, "temporal_kernel": 3, "padding": "causal",
            "temporal": "tcn", "temporal_layers": 1, "encoder_channels": [6, 8, 8],
            "denoise_decoder_channels": [8, 8, 3], "predict_decoder_channels": [8, 3]},
  "data": {"synthetic_takes": 4, "synthetic_seconds": 8},
  "corruption": {"mix": [{"presets": "tracker", "weight": 1}], "val_presets": ["tracker"]},
  "train": {"seed": 3, "epochs": 1, "denoise_only_epochs": 0, "batch": 16, "windows_per_epoch": 64,
            "lr": [[0, 0.01]], "threads": 1, "freeze_graph_epochs": )" +
         std::to_string(freeze) + R"(},
  "loss": {"bone": 1, "smooth": 0.1, "stages": [{"epoch": 0, "bone": 0.2, "smooth": 0}, {"epoch": 2, "bone": 0.6}]}
})";
}

// What makes a shipped model reproducible from its record: at one revision the same config,
// seed and thread count give the same weights, bit for bit, on one host; another seed gives
// others (so the comparison can tell); the meta names the revision and the CPU kernels that
// order the sums (docs/TRAINING.md "Reproducibility").
TEST_CASE("training repeats bit for bit at one revision (same config, seed, threads), and its meta names the revision and CPU kernels") {
  const auto dir = temp_dir("repeat");
  TrainConfig config = parse_train_config(kTinyConfig, "tiny");
  config.epochs = 1;
  const auto weights_of = [&](const TrainConfig& c, const std::string& name) {
    (void)one_epoch(c, dir / name);
    return read_hsm_file(dir / name);
  };
  const HsmContents a = weights_of(config, "a.hsm");
  const HsmContents b = weights_of(config, "b.hsm");
  TrainConfig other = config;
  other.seed += 1;
  const HsmContents c = weights_of(other, "c.hsm");
  REQUIRE(!a.weights.tensors.empty());
  REQUIRE(a.weights.tensors.size() == b.weights.tensors.size());
  int same_as_other_seed = 0;
  for (const auto& [name, t] : a.weights.tensors) {
    CAPTURE(name);
    CHECK(b.weights.at(name).data == t.data);
    same_as_other_seed += c.weights.at(name).data == t.data ? 1 : 0;
  }
  // The initial weights and the batches are the seed's draws: (almost) every tensor differs.
  CHECK(same_as_other_seed < static_cast<int>(a.weights.tensors.size()) / 10);
  const std::string revision = source_revision();
  CHECK(!revision.empty());
  CHECK(a.config.meta_json.find("\"source\"") != std::string::npos);
  CHECK(a.config.meta_json.find("\"" + revision + "\"") != std::string::npos);
  // The kernels that order the sums (another host may pick others): libtorch's capability
  // as it reports it, and the BLAS.
  CHECK(a.config.meta_json.find("\"cpu_kernels\"") != std::string::npos);
  CHECK(a.config.meta_json.find("\"aten_cpu_capability\"") != std::string::npos);
  CHECK(a.config.meta_json.find("\"aten_cpu_capability\": \"unknown\"") == std::string::npos);
}

TEST_CASE("DGN training: loss stages apply from their epoch, the first stage keeps S and T at D^-1 S0, D^-1 T0") {
  const TrainConfig frozen = parse_train_config(tiny_dgn_config(1), "dgn");
  // Stages: each from its epoch on, unnamed weights from the base; validation keeps the base.
  CHECK(frozen.loss_at(0).bone == 0.2);
  CHECK(frozen.loss_at(0).smooth == 0.0);
  CHECK(frozen.loss_at(1).bone == 0.2);
  CHECK(frozen.loss_at(2).bone == 0.6);
  CHECK(frozen.loss_at(2).smooth == 0.1);
  CHECK(frozen.loss_at(7).pose == frozen.loss.pose);
  CHECK(frozen.loss.bone == 1.0);

  const auto dir = temp_dir("dgn");
  // The incidence matrices of the trained model against their initial values.
  auto graph_change = [&](const TrainConfig& config, const std::string& name) {
    TrainOptions opt;
    opt.out = dir / name;
    opt.progress = false;
    std::ostringstream log;
    (void)train_stgae(config, opt, log);
    const auto model = load_hsm(opt.out, true);
    const dgn::DgnGraph g = dgn::dgn_graph(model->config);
    double change = 0.0;
    int matrices = 0;
    for (const auto& [key, t] : model->weights.tensors) {
      const bool is_s = key.ends_with(".S"), is_t = key.ends_with(".T");
      if (!is_s && !is_t) continue;
      ++matrices;
      const Eigen::MatrixXd& init = is_s ? g.S : g.T;
      REQUIRE(t.data.size() == static_cast<size_t>(init.size()));
      for (int r = 0; r < init.rows(); ++r)
        for (int c = 0; c < init.cols(); ++c)
          change = std::max(change, std::abs(static_cast<double>(t.data[static_cast<size_t>(r * init.cols() + c)]) - init(r, c)));
    }
    CHECK(matrices > 0);
    return change;
  };
  CHECK(graph_change(frozen, "frozen.hsm") <= 1e-6);  // float32 in the file
  CHECK(graph_change(parse_train_config(tiny_dgn_config(0), "dgn"), "free.hsm") > 1e-4);
  std::filesystem::remove_all(dir);
}

TEST_CASE("handsteady train runs from the command line and reports bad configs") {
  const auto dir = temp_dir("cli");
  {
    std::ofstream f(dir / "tiny.json");
    f << kTinyConfig;
    std::ofstream g(dir / "bad.json");
    g << R"({"model": {}, "train": {"batch": 1}})";
  }
  auto run = [](const std::string& args) {
    const std::string cmd = std::string("\"") + HS_CLI_PATH + "\" " + args + " > /dev/null 2>&1";
    const int rc = std::system(cmd.c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  };
  CHECK(run("train --config " + (dir / "tiny.json").string() + " --out " + (dir / "m.hsm").string() +
            " --epochs 1 --quiet") == 0);
  CHECK(std::filesystem::exists(dir / "m.hsm"));
  CHECK(std::filesystem::exists(dir / "m.hsm.ckpt"));
  CHECK(run("train --config " + (dir / "bad.json").string() + " --out " + (dir / "n.hsm").string()) == 2);
  CHECK_FALSE(std::filesystem::exists(dir / "n.hsm"));
  std::filesystem::remove_all(dir);
}
#endif
