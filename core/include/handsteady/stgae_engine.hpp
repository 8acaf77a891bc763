#pragma once
// Multi-STGAE and DGN inference in Eigen (the family is the config's): window mode (whole sequence at once, the training graph)
// and streaming mode (causal model, one frame at a time from ring buffers, constant cost
// per frame, no allocation after construction). The function computed is documented in
// stgae_model.hpp; design notes in docs/STGAE.md.
#include "handsteady/stgae_model.hpp"

#include <Eigen/Core>

#include <memory>
#include <span>
#include <vector>

namespace hs {

// A sequence of frames: row t = frame t, column 3*j + c (joint j, coordinate c), metres.
template <class Scalar>
using StgaeFrames = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

template <class Scalar>
struct StgaeOutput {
  StgaeFrames<Scalar> denoised;   // L x 3N
  StgaeFrames<Scalar> predicted;  // DT x 3N, frames after the last input frame (0 rows if !predict)
};

// Prepared parameters: BN folded into the convolutions, A + B precomputed. Immutable,
// shared by any number of engines (one per hand).
template <class Scalar>
class StgaeNet {
 public:
  StgaeNet(const StgaeConfig& config, const StgaeWeights& weights);  // checks the weights
  ~StgaeNet();
  StgaeNet(const StgaeNet&) = delete;
  StgaeNet& operator=(const StgaeNet&) = delete;
  const StgaeConfig& config() const noexcept;
  struct Impl;  // defined in core/src/stgae_engine.cpp
  const Impl& impl() const noexcept { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

template <class Scalar>
std::shared_ptr<const StgaeNet<Scalar>> make_stgae_net(const StgaeConfig& config, const StgaeWeights& weights);

// Window mode over L >= 1 frames of raw positions (NaN = missing joint). Centred model
// with predict: L must equal the window T (the published head). Throws InputError when
// the first frame has no valid joint or the length is wrong.
template <class Scalar>
StgaeOutput<Scalar> stgae_window_forward(const StgaeNet<Scalar>& net, const StgaeFrames<Scalar>& input);

// Streaming mode (causal models only; std::invalid_argument otherwise).
template <class Scalar>
class StgaeStream {
 public:
  explicit StgaeStream(std::shared_ptr<const StgaeNet<Scalar>> net);
  ~StgaeStream();
  StgaeStream(const StgaeStream&) = delete;
  StgaeStream& operator=(const StgaeStream&) = delete;

  // Forgets all history (the next frame is t = 0 of a new sequence).
  void reset() noexcept;
  // One frame of raw positions, 3N values (joint-major xyz, metres, NaN = missing).
  // Returns false (state unchanged) when no joint of this frame or of any earlier frame
  // since reset is valid. Never allocates.
  bool push(std::span<const Scalar> frame) noexcept;
  // Outputs of the last successful push: the denoised current frame (3N values) and the
  // predicted frame i = 0..DT-1 (i = 0 is one model period after the current frame).
  std::span<const Scalar> denoised() const noexcept;
  std::span<const Scalar> predicted(int i) const noexcept;
  long frames_pushed() const noexcept;  // since reset
  const StgaeConfig& config() const noexcept;

  struct State;  // per-stream buffers and layer states, core/src/stgae_engine.cpp

 private:
  std::shared_ptr<const StgaeNet<Scalar>> net_;
  std::unique_ptr<State> s_;
};

extern template class StgaeNet<float>;
extern template class StgaeNet<double>;
extern template class StgaeStream<float>;
extern template class StgaeStream<double>;

}  // namespace hs
