#pragma once
// The libtorch forward of a Multi-STGAE model on one window (training/src/stgae_torch),
// behind an interface without torch types, so only torch_window.cpp includes torch.
#include "handsteady/stgae_model.hpp"
#include "handsteady/track.hpp"

#include <memory>
#include <vector>

namespace hs::bench {

class TorchWindow {
 public:
  // Builds the torch module from the model's configuration and weights (float32, eval
  // mode, one intra-op and one inter-op thread) and the input features of `raw` (one
  // window of raw poses; batch 1). Throws when the input is not valid.
  TorchWindow(const StgaeModel& model, const std::vector<Pose>& raw);
  ~TorchWindow();
  TorchWindow(const TorchWindow&) = delete;
  TorchWindow& operator=(const TorchWindow&) = delete;

  // One forward under NoGradGuard: offsets, then denoised and predicted positions.
  void forward();
  // Positions of the last forward, frame-major then joint then xyz (metres).
  std::vector<float> denoised() const;
  std::vector<float> predicted() const;
  // "libtorch 1.13.1, 1 thread"
  static std::string describe();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hs::bench
