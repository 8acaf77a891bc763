#pragma once
// The training recipe: network, data, augmentation, corruption, schedule and losses, read
// from JSON (docs/TRAINING.md "Config file"). Torch-free (train_config.cpp).
#include "train_data.hpp"

#include "handsteady/stgae_model.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hs::train {

// Loss weights; every term is in cm^2 (positions) so the weights are comparable.
struct LossWeights {
  double pose = 1.0;      // MSE of the denoised window
  // MSE of the window's newest denoised frame, the one a stream answers (the pose term
  // gives it 1/T of its weight; its error along the motion is the stream's lag).
  double newest = 0.0;
  // The newest term per joint weighted by the truth joint's speed at that frame (divided by
  // the batch's mean speed), to spend it where lag is: on fast joints. Tried, not shipped:
  // it passes more tremor on moving hands (models/MODEL.md).
  bool newest_by_speed = false;
  // > 0: the newest term alone weighted per window like relative_eps_mm (1 / (the input's
  // mean squared joint error + this^2), mean 1 per batch), to spend it where the input is
  // clean and lag is most of the error. Tried, not shipped: as above (models/MODEL.md).
  double newest_relative_eps_mm = 0.0;
  double bone = 1.0;      // (bone length error)^2 of the denoised window
  double symmetry = 0.1;  // (symmetry edge length error)^2
  double smooth = 0.0;    // (acceleration error)^2 of the denoised window
  double predict = 0.2;   // MSE of the predicted frames (second phase only)
  // (acceleration error)^2 of the predictions (second phase only): along each predicted
  // path (the last two denoised frames, then the predicted ones) and, with
  // train.predict_frames >= 3, of each horizon's prediction from frame to frame.
  double predict_smooth = 0.0;
  // > 0: the denoising terms of each window are weighted by 1 / (its input's mean squared
  // joint error + relative_eps_mm^2), normalised to mean 1 per batch; 0: plain means.
  double relative_eps_mm = 0.0;
  // (denoised and, second phase, predicted positions - the teacher's)^2 on the windows of
  // sources marked "distill", averaged over every window of the batch (train.teacher).
  double distill = 0.0;
  // (predicted displacement from the denoised frame - the teacher's)^2 on the same windows
  // (second phase): the teacher's motion ahead, whatever the denoised frame it starts from.
  double distill_displacement = 0.0;
  bool distills() const { return distill > 0 || distill_displacement > 0; }
};

struct TrainConfig {
  StgaeConfig model;
  // Data: the sources (relative paths are relative to the working directory): by default
  // FPHA subjects 1-4 to train and 5 to validate; or synthetic motion when
  // synthetic_takes > 0 (tests, no data needed).
  std::vector<DataSource> train_sources{fpha_source("../shared/data/fpha", {1, 2, 3, 4})};
  std::vector<DataSource> val_sources{fpha_source("../shared/data/fpha", {5})};
  double split_speed_mps = 0.0;  // make_clips: split clips at joints faster than this (0 = off)
  int synthetic_takes = 0;
  double synthetic_seconds = 20.0;
  AugmentConfig augment;
  std::vector<CorruptionMixEntry> mix;        // training corruption
  std::vector<std::string> val_presets{"tracker", "paper"};
  uint64_t val_seed = 5;
  int val_stride = 0;                          // frames between validation windows; 0 = T
  // Optimisation.
  uint64_t seed = 1;
  int epochs = 30;
  int denoise_only_epochs = 8;                 // first step of the two-step schedule
  int batch = 64;
  int windows_per_epoch = 16384;
  // Frames per training sequence (>= model.window; 0 = the window). Longer sequences
  // train the streaming answers (every frame past the window is one) and their
  // smoothness from frame to frame.
  int sequence = 0;
  int predict_frames = 1;                      // last frames of a sequence that predict
  int sequence_length() const { return sequence > 0 ? sequence : model.window; }
  std::vector<std::pair<int, double>> lr{{0, 1e-3}};  // (first epoch, rate), piecewise constant
  double grad_clip = 5.0;                      // max global gradient norm (0 = off)
  // DGN: the incidence matrices S, T stay at their initial values for these first epochs
  // (the first stage of the published three-stage schedule).
  int freeze_graph_epochs = 0;
  // A model file (.hsm, relative to the working directory) whose weights the network starts
  // from instead of random ones (fine-tuning); its network configuration must equal
  // `model`. Empty: random. A resumed run takes its weights from the checkpoint instead.
  std::string init;
  // With init: the model file may have another network configuration (of the same family
  // and skeleton); tensors whose names and shapes match are copied, the others keep their
  // random start (a changed part, e.g. a narrower prediction decoder), and the log names them.
  bool init_matching = false;
  // Parameters whose names (the .hsm tensor names, e.g. "enc.0.gcn.conv.weight") start
  // with one of these prefixes are not trained, and their BatchNorm statistics are not
  // updated: {"enc", "pre"} trains the denoising decoder alone. Each must name some.
  std::vector<std::string> freeze;
  // A model file (.hsm) of the same network configuration whose answers the windows of
  // sources marked "distill" are also taught (loss.distill): a fine-tune on new data that
  // keeps the teacher's behaviour on the data it was fitted to. Empty: none.
  std::string teacher;
  // BatchNorm layers normalise with their running statistics in training too, and keep
  // them: a fine-tune keeps the model's normalisation (with other data in the batches, the
  // batch statistics, and the running ones they update, are not those it was fitted with).
  bool fixed_norm = false;
  LossWeights loss;
  // Training-loss weights from an epoch on ("loss.stages"); validation always uses `loss`,
  // so that validation losses stay comparable across stages.
  std::vector<std::pair<int, LossWeights>> loss_stages;
  LossWeights loss_at(int epoch) const;
  int threads = 0;                             // torch intra-op threads, 0 = default
  std::string json;                            // the config text, kept in the model's meta
};

// JSON (docs/TRAINING.md): {"model": {...StgaeConfig...}, "data": {...}, "augment": {...},
// "corruption": {...}, "train": {...}, "loss": {...}}. Unknown keys, wrong types and bad
// values throw InputError naming the source and the key path.
TrainConfig parse_train_config(std::string_view json, const std::string& source = "");
// A file may name {"base": "other.json"} (relative to its folder) and give only what it
// changes: applied to the base as a JSON merge patch (RFC 7386: objects merge, arrays and
// values replace, null removes); bases chain, a cycle is an error. `json` keeps the result.
TrainConfig read_train_config(const std::filesystem::path& path);
double learning_rate(const TrainConfig& config, int epoch);

}  // namespace hs::train
