#pragma once
// Arithmetic cost of the Multi-STGAE forward pass (the function of stgae_model.hpp) from
// the configuration alone, for benchmarks (training/bench/) and capacity planning.
//
// Unit: floating-point operations of the matrix products, 2 per multiply-add. Counted,
// each product once per value the forward pass defines (N joints, K = 3 subsets,
// d = max(1, C_in/2), per block and frame):
//   gcn conv N*C_in*K*C_out, graph aggregation K*N*N*C_out, temporal conv N*kt*C_out^2
//   (all kt taps, also where causal padding supplies zeros), residual conv N*C_in*C_out;
//   attention C "dot": projections 2*N*C_in*K*d and scores K*N*N*d per frame;
//   attention C "gat": embedding N*C_in*K*d and scores 2*K*N*d per distinct time mean;
//   gates: N*2*C*hc per distinct time pool, 2*C*hc per frame (joint pool);
//   causal prediction: pre.lift N*C*DT*C.
// Not counted (each O(N*C) or O(K*N*N) per frame, small next to the products): biases,
// folded BatchNorm, activations, softmax, time means, hole filling and input features.
// "Per distinct value": in a centred window the time means (gat embedding, gate time
// branch) are one value for the whole window; the causal prediction needs the
// prediction gate only at the newest frame. An implementation that recomputes such a
// value (as the window engine does) does more work than is counted here.
#include "handsteady/stgae_model.hpp"

#include <cstdint>

namespace hs {

struct StgaeFlops {
  std::int64_t encoder = 0;  // enc blocks (DGN: and the temporal layers)
  std::int64_t gates = 0;    // enc_gate and pre_gate
  std::int64_t denoise = 0;  // den blocks
  std::int64_t predict = 0;  // pre.lift (causal) or pre.head (centred), and the pre blocks
  std::int64_t total() const noexcept { return encoder + gates + denoise + predict; }
};

// One streaming step (hs::StgaeStream::push) of a causal model: the newest frame through
// every block from the cached history, and the prediction (if any). The same for every
// frame. Throws std::invalid_argument for a centred model (it does not stream) and
// InputError for an invalid configuration.
StgaeFlops stgae_flops_per_frame(const StgaeConfig& config);

// Window mode (hs::stgae_window_forward) over `frames` >= 1 frames: encoder, encoder gate
// and denoising decoder on every frame, the prediction once (from the newest frame when
// causal, from the whole window when centred; a centred model that predicts needs
// frames = window). For a causal model, stgae_flops_per_window(c, 1) equals
// stgae_flops_per_frame(c). Throws std::invalid_argument for a bad frame count.
StgaeFlops stgae_flops_per_window(const StgaeConfig& config, int frames);

}  // namespace hs
