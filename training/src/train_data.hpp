#pragma once
// Training data for Multi-STGAE (no libtorch here): clean clips at the model rate,
// windows of T input + DT target frames cut from them, augmentation (rotation,
// translation, hand size, mirroring, playback speed) and on-the-fly corruption.
#include "handsteady/corrupt.hpp"
#include "handsteady/track.hpp"

#include <array>

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

namespace hs::train {

// One entry of the corruption mix: presets applied in sequence (e.g. tracker then
// tremor); an empty list means the clean window is the input; {"random"} a fresh
// domain-randomised corruption per window (random_corruption below).
struct CorruptionMixEntry {
  std::vector<std::string> presets;
  double weight = 1.0;
};
// "tracker+tremor" -> {"tracker", "tremor"}; "clean" or "" -> {}; "random" -> {"random"}
// (not chained with others). Checks the names.
std::vector<std::string> parse_preset_chain(const std::string& text);

struct AugmentConfig {
  bool rotate = true;              // uniformly random global rotation (all axes)
  double translate_m = 0.5;        // uniform +-translate_m per axis
  double scale_min = 0.85;         // hand size scaling about the wrist
  double scale_max = 1.15;
  double mirror_prob = 0.5;        // x -> -x: a left hand from a right one
  // Playback speeds (rate jitter): each take is also resampled as if recorded this much
  // faster (>1) or slower (<1), so the model sees a range of motion speeds per frame.
  std::vector<double> speed_factors{1.0};
  // Other hands (hand_shape.hpp), drawn per window with this probability: each bone x
  // 1 +- up to 20 %, and, a third of the time each, the wrist up to 3 cm towards the arm,
  // the palm at the finger-base centroid, the thumb metacarpal up to 40 % to the wrist.
  double shape_prob = 0.0;
  // Still hands: the window is one of its frames held (then corrupted as any other).
  double still_prob = 0.0;
  // A slower tracker whose runtime answers at the model's rate: with this probability the
  // corrupted window is sampled at a tracker rate drawn from [upsample_min_hz,
  // upsample_max_hz] (random phase) and linearly interpolated back to the model's frames,
  // as a runtime interpolating its 30-60 Hz tracker for 90 Hz display times does (noise
  // then smooth between samples, sharp at them, in a pattern of the two rates).
  double upsample_prob = 0.0;
  double upsample_min_hz = 30.0, upsample_max_hz = 60.0;
};

// The frames a runtime interpolating a tracker at tracker_hz gives at rate_hz: samples of
// `frames` at phase + k * rate_hz / tracker_hz (the nearest frame's pose), joined linearly
// (a joint missing at one end takes the other end's value; at both, it stays missing).
std::vector<Pose> upsampled_from(const std::vector<Pose>& frames, double rate_hz, double tracker_hz, double phase);

// Where training or validation hands come from. FPHA: `path` is the dataset root and
// `subjects` the subject numbers (right hands). Otherwise `path` is a track CSV or BVH
// file, or a folder whose .csv/.bvh files are all read (both hands); a file is kept when
// its name contains one of `include` (if any) and none of `exclude`.
struct DataSource {
  std::filesystem::path path;
  std::vector<int> subjects;
  bool fpha = false;
  std::vector<std::string> include, exclude;
  double weight = 1.0;  // share of the training windows drawn from this source
  // Its windows are also taught the teacher model's answers (train.teacher, loss.distill).
  bool distill = false;
  // Its windows count in loss.newest (false: the term skips them, e.g. object-holding
  // mocap, whose tremor the term would teach the network to follow).
  bool newest = true;
};
inline DataSource fpha_source(const std::filesystem::path& root, std::vector<int> subjects) {
  DataSource d;
  d.path = root;
  d.subjects = std::move(subjects);
  d.fpha = true;
  return d;
}
// The selected files of a non-FPHA source, sorted (InputError if none).
std::vector<std::filesystem::path> source_files(const DataSource& source);
std::vector<HandSeries> load_source(const DataSource& source);

// Clean clips at the model rate; every joint of every frame tracked. group: the source
// of each clip (windows are drawn per source by weight).
struct ClipSet {
  std::vector<std::vector<Pose>> clips;
  std::vector<int> group;
  std::vector<double> group_weight;
  size_t frames() const;
  void append(ClipSet&& other, double weight);  // other as one more group
};

// Resamples each series at rate_hz for each playback speed and splits it at frames
// with an untracked joint, and (split_speed_mps > 0) where a joint moves faster than
// that between two frames: a tracker re-acquiring the hand (Leap Motion's recordings
// have such jumps) is not motion to learn. Pieces shorter than min_frames are dropped.
ClipSet make_clips(const std::vector<HandSeries>& series, double rate_hz, const std::vector<double>& speed_factors,
                   int min_frames, double split_speed_mps = 0.0);
// Right hands of FPHA takes under root/Subject_<s> for each subject (InputError if a
// subject directory is missing).
std::vector<HandSeries> load_fpha_subjects(const std::filesystem::path& root, const std::vector<int>& subjects);

// One training window: the corrupted input (T frames, NaN = untracked) and the clean
// truth (T + DT frames; the last DT are the prediction targets).
struct Window {
  std::vector<Pose> input;
  std::vector<Pose> truth;
  int group = 0;  // the training source it was drawn from (ClipSet group)
};

// A domain-randomised corruption for one window at rate_hz: white or AR(1) jitter
// (0.2-6 mm, time constant 20-200 ms), tremor (3.5-12 Hz, 0.3-6 mm), outliers, missing
// joints and hand dropouts, quantisation, each present with its own probability and
// random strength; then every joint's deviation scaled by its own factor in [0.5, 1.5].
struct RandomCorruption {
  std::vector<CorruptionConfig> steps;
  std::array<double, kJointCount> joint_scale{};
};
RandomCorruption random_corruption(std::mt19937_64& rng, double rate_hz);
std::vector<Pose> apply_random_corruption(const std::vector<Pose>& clean, double rate_hz, const RandomCorruption& rc,
                                          uint64_t seed);

// Random windows: a source by weight, then a uniform start in it.
class WindowSampler {
 public:
  WindowSampler(const ClipSet& clips, int window, int horizon, double rate_hz, AugmentConfig augment,
                std::vector<CorruptionMixEntry> mix);
  size_t window_count() const;
  Window draw(std::mt19937_64& rng) const;

 private:
  const ClipSet* clips_;
  int T_, DT_;
  double rate_hz_;
  AugmentConfig augment_;
  std::vector<CorruptionMixEntry> mix_;
  std::vector<double> mix_cdf_;
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> starts_;  // per group: (clip, first frame)
  std::vector<double> group_cdf_;
};

// Fixed validation windows: every clip cut with the given stride, no augmentation,
// corrupted by the preset chain with seeds derived from seed and the window index.
std::vector<Window> fixed_windows(const ClipSet& clips, int window, int horizon, int stride, double rate_hz,
                                  const std::vector<std::string>& presets, uint64_t seed);

// Input of the model for a window of raw poses (stgae_model.hpp, step 1): hole-filled
// positions (a missing joint holds its last valid position; a joint not seen yet takes the
// wrist, else the palm, else the mean of the seen joints) and the 6 features per joint
// (wrist-relative shape / shape_scale_m, per-frame displacement / velocity_scale_m).
// features: frames*N*6, filled: frames*N*3 doubles (frame-major). Returns false when
// the first frame has no tracked joint (not valid input).
bool input_features(const std::vector<Pose>& raw, double shape_scale_m, double velocity_scale_m, double* features,
                    double* filled);

// Corrupts poses (frames at rate_hz) by a chain of presets, or by a random corruption
// drawn from the seed when the chain is {"random"}.
std::vector<Pose> corrupt_chain(const std::vector<Pose>& clean, double rate_hz, const std::vector<std::string>& presets,
                                uint64_t seed);

}  // namespace hs::train
