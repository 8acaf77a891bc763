#pragma once
// Multi-STGAE training (libtorch inside trainer.cpp; this interface is torch-free so the
// CLI command does not compile the torch headers). docs/TRAINING.md describes the config.
#include "train_config.hpp"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hs::train {

struct PresetMetrics {
  std::string preset;
  size_t windows = 0;
  double input_mpjpe_mm = 0, denoised_mpjpe_mm = 0;  // all frames of each window
  double denoised_last_mpjpe_mm = 0;                 // newest frame (the live output)
  double input_ebon_mm2 = 0, denoised_ebon_mm2 = 0;
  std::vector<double> predicted_mpjpe_mm;            // per future frame
  double hold_mpjpe_mm = 0;                          // last filled input frame held, at DT
};

struct EpochReport {
  int epoch = 0;              // 0-based
  bool joint_phase = false;   // false = denoise-only step
  double lr = 0, train_loss = 0, val_loss = 0, seconds = 0;
  std::vector<PresetMetrics> val;
  bool best = false;
};

struct TrainOptions {
  std::filesystem::path out;                    // best model (.hsm); checkpoint out + ".ckpt"
  std::optional<std::filesystem::path> resume;  // checkpoint to continue from
  std::optional<int> epochs;                    // overrides train.epochs
  std::optional<int> threads;                   // overrides train.threads
  bool progress = true;                         // progress bar with ETA on stderr
};

struct TrainResult {
  std::vector<EpochReport> epochs;  // this run's epochs
  int best_epoch = -1;
  double best_val_loss = 0;
};

TrainResult train_stgae(const TrainConfig& config, const TrainOptions& options, std::ostream& log);

}  // namespace hs::train
