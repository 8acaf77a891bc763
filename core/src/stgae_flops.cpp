// FLOP count of the Multi-STGAE forward pass (definitions: stgae_flops.hpp): the sum of
// the topology's node counts (stgae_topology.hpp), 2 FLOPs per multiply-add.
#include "handsteady/stgae_flops.hpp"

#include "handsteady/stgae_topology.hpp"

#include <stdexcept>
#include <string>

namespace hs {

namespace {

StgaeFlops count(const StgaeConfig& c, std::int64_t L) {
  StgaeFlops r;
  for (const StgaeNode& node : stgae_topology(c)) {
    const std::int64_t flops = 2 * node.macs(c, L);
    switch (node.section) {
      case StgaeSection::Encoder:
      case StgaeSection::Temporal: r.encoder += flops; break;
      case StgaeSection::EncoderGate:
      case StgaeSection::PredictGate: r.gates += flops; break;
      case StgaeSection::Denoise: r.denoise += flops; break;
      case StgaeSection::PredictInput:
      case StgaeSection::PredictDecoder: r.predict += flops; break;
    }
  }
  return r;
}

}  // namespace

StgaeFlops stgae_flops_per_frame(const StgaeConfig& config) {
  if (config.padding != StgaePadding::Causal)
    throw std::invalid_argument("stgae_flops_per_frame: streaming needs a causal model (this one is centred)");
  return count(config, 1);
}

StgaeFlops stgae_flops_per_window(const StgaeConfig& config, int frames) {
  if (frames < 1) throw std::invalid_argument("stgae_flops_per_window: frames must be >= 1");
  if (config.centred_head() && frames != config.window)
    throw std::invalid_argument("stgae_flops_per_window: the centred prediction model needs exactly " +
                                std::to_string(config.window) + " frames, got " + std::to_string(frames));
  return count(config, frames);
}

}  // namespace hs
