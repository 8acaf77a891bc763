#pragma once
// Seeded, reproducible corruption of clean tracks (ground truth is never modified).
//  paper   - Algorithm 1 of the STGAE paper (shift, occlusion, Optimize bone lengths).
//  tracker - live tracker noise: jitter, dropped joints, whole-hand dropouts, joint jumps
//            (statistics measured on the HoloLens 2 recordings, docs/CORRUPTION.md).
//  tremor  - 4-6 Hz Parkinsonian or 8-12 Hz physiological oscillation of hand and fingers.
//  hand-jitter - the whole hand displaced by white jitter, row by row (common-mode error).
// Random numbers come from std::mt19937_64 (whose sequence the standard fixes) through
// our own uniform/normal transforms, so a seed gives the same output on every run.
#include "handsteady/track.hpp"

#include <cstdint>
#include <string_view>

namespace hs {

struct PaperCorruption {
  double sigma_s = 0.1;    // shift probability scale
  double sigma_o = 0.1;    // occlusion probability scale
  double beta_m = 0.050;   // shift amplitude (uniform +-beta), metres, for a reference hand
  // Hand-size normalisation (step 1 of Algorithm 1): beta is scaled by
  // hand_size / reference_hand_m (hand size = median wrist -> middle_proximal distance).
  // 0 disables the scaling.
  double reference_hand_m = 0.09;
  bool optimize = true;    // the Optimize bone-length step
};

struct TrackerCorruption {
  double jitter_sd_m = 0.0;        // white noise per coordinate
  double jitter_ar1 = 0.0;         // row-to-row correlation of the jitter, [0, 1)
  double joint_drop_prob = 0.0;    // per joint per row
  double hand_drop_rate_hz = 0.0;  // whole-hand dropout starts per second
  double hand_drop_mean_s = 0.0;   // mean dropout duration (exponential)
  double jump_prob = 0.0;          // per joint per row: a one-row jump
  double jump_sd_m = 0.0;          // jump size (per coordinate SD)
  double quantize_m = 0.0;         // output rounding (0 = none)
  // Outliers: per joint per row an outlier starts with outlier_prob: the joint is pushed
  // by a uniform [outlier_min_m, outlier_max_m] step in a random direction for 1 to
  // outlier_max_rows rows (uniform). Its own random stream: the fields above draw the same.
  double outlier_prob = 0.0;
  double outlier_min_m = 0.010, outlier_max_m = 0.050;
  int outlier_max_rows = 3;
  // Whole-hand jitter: one displacement per row added to every joint (the common-mode
  // error of a tracker that fits a whole hand model per frame; per coordinate SD, the
  // same AR(1) correlation as the joints' jitter). Its own random stream.
  double hand_jitter_sd_m = 0.0;
};

struct TremorCorruption {
  double freq_min_hz = 4.0, freq_max_hz = 6.0;
  double hand_amplitude_m = 0.004;    // whole-hand oscillation amplitude
  double finger_amplitude_m = 0.002;  // extra per-finger oscillation amplitude (at the tip)
};

enum class CorruptionKind { Paper, Tracker, Tremor };

struct CorruptionConfig {
  CorruptionKind kind = CorruptionKind::Tracker;
  PaperCorruption paper;
  TrackerCorruption tracker;
  TremorCorruption tremor;
};

// "paper", "tracker", "tremor" (= Parkinsonian), "tremor-physiological", "hand-jitter"
// (whole-hand jitter only, chained with another preset: "hand-jitter+tracker"); throws
// std::invalid_argument.
CorruptionConfig corruption_preset(std::string_view name);

// Throws std::invalid_argument naming the parameter when a value is out of range
// (negative SDs/rates, probabilities outside [0, 1], freq_min > freq_max, ...).
void validate_corruption(const CorruptionConfig& config);

// Corrupts every row of both hands; untracked input stays untracked.
// Each hand uses its own sub-seed derived from seed; metadata is copied unchanged.
Track corrupt_track(const Track& clean, const CorruptionConfig& config, uint64_t seed);
// The same on one hand's series (used by training on the fly).
HandSeries corrupt_series(const HandSeries& clean, const CorruptionConfig& config, uint64_t seed);

// The paper's Optimize step on one frame (exposed for tests): joints two or more hops
// from the root are visited parent-first; each is first moved by its parent's correction
// (the displacement Optimize applied to the parent), then placed on the ray from the
// parent towards it at the parent-child bone length of `clean`. Joints one hop away and
// the root are left as they are. Joints untracked in either pose are left as they are.
Pose paper_optimize(const Pose& clean, const Pose& shifted);

}  // namespace hs
