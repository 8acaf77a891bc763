#pragma once
// Training data for Multi-STGAE (no libtorch here): clean clips at the model rate,
// windows of T input + DT target frames cut from them, augmentation (rotation,
// translation, hand size, mirroring, playback speed) and on-the-fly corruption.
#include "handsteady/track.hpp"

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

namespace hs::train {

// One entry of the corruption mix: presets applied in sequence (e.g. tracker then
// tremor); an empty list means the clean window is the input.
struct CorruptionMixEntry {
  std::vector<std::string> presets;
  double weight = 1.0;
};
// "tracker+tremor" -> {"tracker", "tremor"}; "clean" or "" -> {}. Checks the names.
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
};

// Clean clips at the model rate; every joint of every frame tracked.
struct ClipSet {
  std::vector<std::vector<Pose>> clips;
  size_t frames() const;
};

// Resamples each series at rate_hz for each playback speed and splits it at frames
// with an untracked joint; pieces shorter than min_frames are dropped.
ClipSet make_clips(const std::vector<HandSeries>& series, double rate_hz, const std::vector<double>& speed_factors,
                   int min_frames);
// Right hands of FPHA takes under root/Subject_<s> for each subject (InputError if a
// subject directory is missing).
std::vector<HandSeries> load_fpha_subjects(const std::filesystem::path& root, const std::vector<int>& subjects);

// One training window: the corrupted input (T frames, NaN = untracked) and the clean
// truth (T + DT frames; the last DT are the prediction targets).
struct Window {
  std::vector<Pose> input;
  std::vector<Pose> truth;
};

// Uniformly random windows over all start positions of all clips.
class WindowSampler {
 public:
  WindowSampler(const ClipSet& clips, int window, int horizon, double rate_hz, AugmentConfig augment,
                std::vector<CorruptionMixEntry> mix);
  size_t window_count() const { return starts_.size(); }
  Window draw(std::mt19937_64& rng) const;

 private:
  const ClipSet* clips_;
  int T_, DT_;
  double rate_hz_;
  AugmentConfig augment_;
  std::vector<CorruptionMixEntry> mix_;
  std::vector<double> mix_cdf_;
  std::vector<std::pair<uint32_t, uint32_t>> starts_;  // (clip, first frame)
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

// Corrupts poses (frames at rate_hz) by a chain of presets.
std::vector<Pose> corrupt_chain(const std::vector<Pose>& clean, double rate_hz, const std::vector<std::string>& presets,
                                uint64_t seed);

}  // namespace hs::train
