// FLOP count of the Multi-STGAE forward pass (definitions: stgae_flops.hpp).
#include "handsteady/stgae_flops.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace hs {

namespace {

constexpr std::int64_t K = 3;

// Multiply-adds of one STGCB: the gcn conv, aggregation and attention items on f_in input
// frames, the attention matrices for `means` distinct time means (gat only), the temporal
// and residual convs for f_out output frames.
std::int64_t block_macs(const StgaeConfig& c, std::int64_t n, std::int64_t cin, std::int64_t cout, std::int64_t kt,
                        std::int64_t f_in, std::int64_t f_out, std::int64_t means) {
  const std::int64_t d = std::max<std::int64_t>(1, cin / 2);
  std::int64_t per_in = n * cin * K * cout + K * n * n * cout;  // gcn conv, aggregation
  std::int64_t per_mean = 0;
  if (c.attention == StgaeAttention::ABC) {
    if (c.c_variant == StgaeCVariant::Dot) per_in += 2 * n * cin * K * d + K * n * n * d;  // q, k; q.k
    else per_mean = n * cin * K * d + 2 * K * n * d;                                      // emb; a . e
  }
  const std::int64_t per_out = n * kt * cout * cout + n * cin * cout;  // temporal conv, residual
  return f_in * per_in + means * per_mean + f_out * per_out;
}

// Multiply-adds of a gate on `frames` frames with `pools` distinct time pools.
std::int64_t gate_macs(std::int64_t n, std::int64_t ch, std::int64_t frames, std::int64_t pools) {
  const std::int64_t hc = std::max<std::int64_t>(1, ch / 2);
  return pools * n * 2 * ch * hc + frames * 2 * ch * hc;
}

StgaeFlops count(const StgaeConfig& c, std::int64_t L) {
  validate_stgae_config(c);
  const bool causal = c.padding == StgaePadding::Causal;
  const std::int64_t n = c.joint_count(), T = c.window, DT = c.horizon, C = c.latent_channels();
  const std::int64_t kt = c.temporal_kernel;
  const std::int64_t means = causal ? L : 1;  // distinct time means over the L frames
  StgaeFlops r;
  const auto& enc = c.encoder_channels;
  for (size_t i = 0; i + 1 < enc.size(); ++i) r.encoder += block_macs(c, n, enc[i], enc[i + 1], kt, L, L, means);
  const auto& den = c.denoise_decoder_channels;
  for (size_t i = 0; i + 1 < den.size(); ++i) r.denoise += block_macs(c, n, den[i], den[i + 1], kt, L, L, means);
  if (c.gates) r.gates += gate_macs(n, C, L, means);
  if (c.predict) {
    if (causal) {
      if (c.gates) r.gates += gate_macs(n, C, 1, 1);  // the newest frame only
      r.predict += n * C * DT * C;                    // pre.lift
    } else {
      if (c.gates) r.gates += gate_macs(n, C, L, 1);
      r.predict += block_macs(c, n, C, C, T - DT + 1, L, DT, 1);  // pre.head, valid padding
    }
    const std::int64_t pkt = causal ? 1 : kt;
    const auto& pre = c.predict_decoder_channels;
    for (size_t i = 0; i + 1 < pre.size(); ++i) r.predict += block_macs(c, n, pre[i], pre[i + 1], pkt, DT, DT, 1);
  }
  r.encoder *= 2;
  r.gates *= 2;
  r.denoise *= 2;
  r.predict *= 2;
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
  if (config.padding == StgaePadding::Centred && config.predict && frames != config.window)
    throw std::invalid_argument("stgae_flops_per_window: the centred prediction model needs exactly " +
                                std::to_string(config.window) + " frames, got " + std::to_string(frames));
  return count(config, frames);
}

}  // namespace hs
