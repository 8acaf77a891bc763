#pragma once
// libtorch implementation of the Multi-STGAE forward pass defined (exactly) in
// core/include/handsteady/stgae_model.hpp. Module and parameter names are chosen so that
// named_parameters()/named_buffers() ARE the .hsm tensor names ("enc.0.gcn.conv.weight",
// "pre.lift.bias", ...): export/import is a name lookup checked against
// hs::stgae_tensor_specs.
//
// Layout: activations are channel-last tensors [B, L frames, N joints, C channels], so every
// 1x1 convolution is a matmul over the last axis. Works in float32 and float64
// (module->to(torch::kFloat64)).
#include "handsteady/stgae_model.hpp"
#include "handsteady/stgae_topology.hpp"

#include <torch/nn/module.h>
#include <torch/types.h>

#include <memory>
#include <string>
#include <vector>

namespace hs::train {

// Shared by every mean over time: causal = moving mean over frames max(0, t-T+1)..t,
// whole = mean over all L frames of the window (broadcast back to every frame).
using TimeMean = StgaeTimeMean;

// PyTorch's default initialisation of conv/linear layers: U(-1/sqrt(fan_in), 1/sqrt(fan_in)).
torch::Tensor default_uniform(std::vector<int64_t> shape, int64_t fan_in);

// W x + b over the last axis; weight [out, in] (PyTorch Conv/Linear layout).
struct Conv1x1Impl : torch::nn::Module {
  Conv1x1Impl(int in, int out, bool bias);
  torch::Tensor forward(const torch::Tensor& x);
  torch::Tensor weight, bias;
};

// BatchNorm over the last axis (eps 1e-5, momentum 0.1); training mode uses the batch
// statistics over all other axes and updates the running ones (unbiased variance).
struct ChannelNormImpl : torch::nn::Module {
  explicit ChannelNormImpl(int channels);
  torch::Tensor forward(const torch::Tensor& x);
  torch::Tensor weight, bias, running_mean, running_var;
};

struct BlockOptions {
  using Pad = StgaeTemporalPad;
  int c_in = 0, c_out = 0, kernel = 1;
  Pad pad = Pad::Causal;
  TimeMean mean = TimeMean::Causal;
  int T = 1;             // window of the causal time means
  bool relu_out = true;  // false for the last block of a decoder
};

// Temporal convolution over frames: weight [Cout, Cin, kt], bias [Cout].
struct TemporalConvImpl : torch::nn::Module {
  TemporalConvImpl(int in, int out, int kernel);
  torch::Tensor weight, bias;
};

// Temporal conv along dim 1 of [B, L, R, C] with the padding's zeros -> [B, L', R, Cout].
torch::Tensor temporal_conv(const torch::Tensor& x, const TemporalConvImpl& conv, StgaeTemporalPad pad);

// One STGCB: y = tcn(gcn(x)) + res(x), with A (+B) (+C) graph aggregation.
struct BlockImpl : torch::nn::Module {
  BlockImpl(const StgaeConfig& config, const BlockOptions& options);
  torch::Tensor forward(const torch::Tensor& f);  // [B, L, N, Cin] -> [B, L', N, Cout]

  BlockOptions opt;
  int K = 3, N = 0, d = 1;
  StgaeAttention attention;
  StgaeCVariant c_variant;
  torch::Tensor A;  // [K, N, N], double; not a parameter (fixed by the skeleton)
  torch::Tensor B;  // [K, N, N] learnable (attention A+B, A+B+C)
  std::shared_ptr<torch::nn::Module> gcn, tcn, res, att;
  std::shared_ptr<Conv1x1Impl> gcn_conv, res_conv, att_q, att_k, att_emb;
  std::shared_ptr<ChannelNormImpl> gcn_bn, tcn_bn, res_bn;
  std::shared_ptr<TemporalConvImpl> tcn_conv;
  torch::Tensor att_a;  // [K, 2d] (gat)
};

struct GateImpl : torch::nn::Module {
  GateImpl(int channels, TimeMean mean, int T);
  torch::Tensor forward(const torch::Tensor& x);  // [B, L, N, C] -> same
  TimeMean mean;
  int T;
  std::shared_ptr<torch::nn::Module> shared, time, joint;
  std::shared_ptr<Conv1x1Impl> shared_conv, time_conv, joint_conv;
  std::shared_ptr<ChannelNormImpl> shared_bn, bn;
};

struct TorchOutput {
  torch::Tensor denoised_offset;   // D: [B, L, N, 3]; Xhat = x + shape_scale_m * D
  // Q: [B, DT, N, 3]; Yhat = Xhat[L-1] + shape_scale_m * Q (undefined if !predict). With
  // pred_frames P > 1 (training): [B, P, DT, N, 3], the prediction made at each of the
  // last P frames, Yhat[p] = Xhat[L-P+p] + shape_scale_m * Q[p] (the streaming answers).
  torch::Tensor predicted_offset;
};

struct DgnBlockImpl;
struct DgnTemporalImpl;
struct DgnLiftImpl;

// The network of either family (config.family): one module per node of
// hs::stgae_topology, registered under its prefix.
struct StgaeNetImpl : torch::nn::Module {
  explicit StgaeNetImpl(const StgaeConfig& config);
  // features: [B, L, N, 6] (hs::train::input_features); centred models need L = T when
  // predicting, causal ones take any L >= 1.
  TorchOutput forward(const torch::Tensor& features, int pred_frames = 1);

  StgaeConfig config;
  std::shared_ptr<torch::nn::Module> enc, den, pre;
  std::vector<std::shared_ptr<BlockImpl>> enc_blocks, den_blocks, pre_blocks;
  std::shared_ptr<BlockImpl> pre_head;     // centred only
  std::shared_ptr<Conv1x1Impl> pre_lift;   // causal only
  std::shared_ptr<GateImpl> enc_gate, pre_gate;
  // family dgn (dgn_torch.hpp)
  std::shared_ptr<torch::nn::Module> tmp;
  std::vector<std::shared_ptr<DgnBlockImpl>> dgn_enc, dgn_den, dgn_pre;
  std::vector<std::shared_ptr<DgnTemporalImpl>> dgn_tmp;
  std::shared_ptr<DgnLiftImpl> dgn_lift;
  torch::Tensor bone_source, bone_target;  // [E] joint indices (long)
  torch::Tensor bone_path;                 // [N, E]: 1 where bone e lies on the path root -> j
  int64_t root = 0;

 private:
  TorchOutput dgn_forward(const torch::Tensor& features, int pred_frames);
  // D = (D_v + D_v[root] + path D_e) / 2 over the last two axes' joints/bones.
  torch::Tensor dgn_combine(const torch::Tensor& dv, const torch::Tensor& de) const;
};

// Positions from the offsets: Xhat = x + s*D, Yhat = Xhat[L-1] + s*Q ([B, L|DT, N, 3]).
torch::Tensor denoised_positions(const StgaeConfig& config, const torch::Tensor& x, const TorchOutput& out);
torch::Tensor predicted_positions(const StgaeConfig& config, const torch::Tensor& denoised, const TorchOutput& out);

// Every tensor of the spec, read from the module (float32 copies). Throws
// std::logic_error when the module and hs::stgae_tensor_specs disagree on a name or shape.
StgaeWeights export_weights(StgaeNetImpl& net);
// Copies weights (checked with hs::check_stgae_weights) into the module, keeping its dtype.
void import_weights(StgaeNetImpl& net, const StgaeWeights& weights);
// Copies the tensors of `weights` whose name and shape the module's spec has (a model of
// another configuration: a part changed, the rest kept); returns the spec's names it left
// as they were, none found or of another shape.
std::vector<std::string> import_matching_weights(StgaeNetImpl& net, const StgaeWeights& weights);

// Moving or whole-window mean over dim 1 (frames) of a [B, L, ...] tensor.
torch::Tensor time_mean(const torch::Tensor& x, TimeMean mean, int T);
// Sinusoidal positional encoding [DT, C] in the given dtype.
torch::Tensor positional_encoding(int frames, int channels, torch::Dtype dtype);

}  // namespace hs::train
