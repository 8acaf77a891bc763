#pragma once
// libtorch modules of the directed-graph refinement network (forward pass defined exactly
// in core/include/handsteady/dgn_layers.hpp). Registered by StgaeNetImpl (stgae_torch.hpp)
// under the tensor name prefixes, so that named_parameters() are the .hsm names.
// Activations are channel-last: joints [B, L, N, C], bones [B, L, E, C].
#include "stgae_torch.hpp"

#include "handsteady/dgn_layers.hpp"

#include <utility>

namespace hs::train {

struct DgnBlockImpl : torch::nn::Module {
  DgnBlockImpl(const dgn::DgnGraph& graph, int c_in, int c_out, bool linear);
  std::pair<torch::Tensor, torch::Tensor> forward(const torch::Tensor& v, const torch::Tensor& e);
  bool linear;
  torch::Tensor S, T;  // [N, E], learnable (frozen by the trainer in the first stage)
  std::shared_ptr<Conv1x1Impl> v_conv, e_conv;
  std::shared_ptr<ChannelNormImpl> v_bn, e_bn;
};

// One direction of an LSTM over dim 1 of [B, L, R, C]: parameters w_ih [4H, C], w_hh
// [4H, H], bias [4H] (PyTorch gate order i, f, g, o).
struct DgnLstmImpl : torch::nn::Module {
  DgnLstmImpl(int c_in, int hidden);
  torch::Tensor forward(const torch::Tensor& x, bool backward);  // -> [B, L, R, H]
  torch::Tensor w_ih, w_hh, bias;
};

// One temporal layer on one stream (v or e).
struct DgnStreamTemporalImpl : torch::nn::Module {
  DgnStreamTemporalImpl(const StgaeConfig& config, const StgaeNode& node);
  torch::Tensor forward(const torch::Tensor& x);
  StgaeTemporalPad pad;
  std::shared_ptr<TemporalConvImpl> conv;
  std::shared_ptr<ChannelNormImpl> bn;
  std::shared_ptr<DgnLstmImpl> fwd, bwd;
};

struct DgnTemporalImpl : torch::nn::Module {
  DgnTemporalImpl(const StgaeConfig& config, const StgaeNode& node);
  std::shared_ptr<DgnStreamTemporalImpl> v, e;
};

struct DgnLiftImpl : torch::nn::Module {
  DgnLiftImpl(int channels, int horizon);
  std::shared_ptr<Conv1x1Impl> v, e;
};

}  // namespace hs::train
