#pragma once
// The network (Multi-STGAE or DGN, StgaeConfig::family) as a list of nodes, from the configuration alone: the one place
// the topology is written. The tensor specs (stgae_tensor_specs), the FLOP count
// (stgae_flops.hpp), the Eigen engine's net and the libtorch module (training/) are all
// built from it. The function of each node kind: stgae_model.hpp (steps 2-4).
#include "handsteady/stgae_model.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace hs {

enum class StgaeNodeKind {
  Block,  // STGCB (step 2)
  Gate,   // spatio-temporal gate (step 3)
  Lift,   // 1x1 conv C -> DT*C from the newest frame (causal prediction, step 4)
  // DGN (dgn_layers.hpp): each runs on both streams, joints (N rows) and bones (E = N-1).
  DgnBlock,     // vertex update from incident edges, then edge update from end vertices
  DgnTemporal,  // residual temporal conv or LSTM per joint and per bone
  DgnLift,      // the newest latent frame -> DT frames, per stream
};

// Where a node sits in the dataflow of step 4 (nodes of one section run in list order).
enum class StgaeSection {
  Encoder,        // enc blocks on the features
  EncoderGate,    // on the encoder output; its output H feeds both decoders
  Denoise,        // den blocks on H
  PredictGate,    // on H, opens the prediction branch
  PredictInput,   // pre.lift (causal) or pre.head (centred): latent frames -> DT frames
  PredictDecoder, // pre blocks on the DT frames (+ positional encoding)
  Temporal,       // DGN: temporal module between the encoder and both decoders
};

// Temporal padding of a block's temporal conv (step 2d).
enum class StgaeTemporalPad { Causal, Centred, Valid };
// Time means (attention C, gate time pool): over W(t) of each frame, or one over all frames.
enum class StgaeTimeMean { Causal, Whole };
// Frames a node runs on, for a network input of L frames: all L, the newest one only
// (what the causal prediction needs), or the DT predicted frames.
enum class StgaeFrameSpan { Input, Newest, Horizon };

struct StgaeNode {
  StgaeNodeKind kind = StgaeNodeKind::Block;
  StgaeSection section = StgaeSection::Encoder;
  std::string prefix;  // tensor name prefix, e.g. "enc.0.", "enc_gate.", "pre.lift."
  int c_in = 0, c_out = 0;
  int kernel = 1;      // temporal kernel (blocks)
  StgaeTemporalPad pad = StgaeTemporalPad::Causal;
  StgaeTimeMean mean = StgaeTimeMean::Causal;
  StgaeFrameSpan span = StgaeFrameSpan::Input;
  bool linear = false; // last block of a decoder: no ReLU after the temporal conv
  std::vector<TensorSpec> tensors;  // full names, in file order

  // Multiply-adds of this node when the network input has L frames (stgae_flops.hpp says
  // what is counted). `config` is the one the node was made from.
  std::int64_t macs(const StgaeConfig& config, std::int64_t L) const;
};

// Every node, in file (tensor) order; validates the configuration (InputError).
std::vector<StgaeNode> stgae_topology(const StgaeConfig& config);

// Throws InputError (file = source, field = tensor name) when a tensor of the node is
// missing, has another shape, or holds another number of values than its shape says.
void check_node_tensors(const StgaeNode& node, const StgaeWeights& weights, const std::string& source = "");

}  // namespace hs
