// FLOP count of the Multi-STGAE forward pass against a count done by hand on a tiny
// configuration (xr26: N = 26 joints, K = 3 subsets, N*N = 676).
#include "handsteady/stgae_flops.hpp"

#include "handsteady/stgae_topology.hpp"

#include <doctest/doctest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace {

// Encoder 6 -> 4, denoiser 4 -> 3, predictor 4 -> 3, T = 4, DT = 2, kt = 3, A+B+C dot, gates.
hs::StgaeConfig tiny(hs::StgaePadding pad) {
  hs::StgaeConfig c;
  c.window = 4;
  c.horizon = 2;
  c.temporal_kernel = 3;
  c.encoder_channels = {6, 4};
  c.denoise_decoder_channels = {4, 3};
  c.predict_decoder_channels = {4, 3};
  c.padding = pad;
  c.attention = hs::StgaeAttention::ABC;
  c.c_variant = hs::StgaeCVariant::Dot;
  c.gates = true;
  c.predict = true;
  return c;
}

// Multiply-adds by hand, per frame (1 MAC = 2 FLOP):
// enc.0 (6 -> 4, d = 3): gcn 26*6*12 = 1872, aggregation 3*676*4 = 8112,
//   q/k 2*26*6*9 = 2808, scores 3*676*3 = 6084, tcn 26*3*4*4 = 1248, res 26*6*4 = 624
//   -> 20748
// den.0 (4 -> 3, d = 2): gcn 26*4*9 = 936, aggregation 3*676*3 = 6084, q/k 2*26*4*6 = 1248,
//   scores 3*676*2 = 4056, tcn 26*3*3*3 = 702, res 26*4*3 = 312 -> 13338
// gate (C = 4, hc = 2): time branch 26*(4*2 + 2*4) = 416, joint branch 4*2 + 2*4 = 16 -> 432
// pre.lift 26*4*(2*4) = 832
// pre.0 (4 -> 3, kt 1) on DT = 2 frames: 2*(936 + 6084 + 1248 + 4056 + 26*1*3*3 + 312) = 25740
constexpr std::int64_t kEnc = 20748, kDen = 13338, kGate = 432, kLift = 832, kPre = 25740;

}  // namespace

TEST_CASE("streaming FLOPs of a tiny causal model match the hand count") {
  const auto f = hs::stgae_flops_per_frame(tiny(hs::StgaePadding::Causal));
  CHECK(f.encoder == 2 * kEnc);
  CHECK(f.gates == 2 * 2 * kGate);  // enc_gate + pre_gate
  CHECK(f.denoise == 2 * kDen);
  CHECK(f.predict == 2 * (kLift + kPre));
  CHECK(f.total() == 2 * (kEnc + 2 * kGate + kDen + kLift + kPre));
  CHECK(f.total() == 123044);
}

TEST_CASE("causal window FLOPs: every frame through encoder, gate and denoiser, one prediction") {
  const auto c = tiny(hs::StgaePadding::Causal);
  const auto w = hs::stgae_flops_per_window(c, 4);
  CHECK(w.encoder == 2 * 4 * kEnc);
  CHECK(w.gates == 2 * (4 * kGate + kGate));  // enc_gate on 4 frames, pre_gate on the newest
  CHECK(w.denoise == 2 * 4 * kDen);
  CHECK(w.predict == 2 * (kLift + kPre));
  const auto one = hs::stgae_flops_per_window(c, 1);
  const auto frame = hs::stgae_flops_per_frame(c);
  CHECK(one.total() == frame.total());
  // Longer windows: linear in the frame count except the prediction.
  const auto w40 = hs::stgae_flops_per_window(c, 40);
  CHECK(w40.encoder == 10 * w.encoder);
  CHECK(w40.predict == w.predict);
}

TEST_CASE("centred window FLOPs: pre.head with valid padding, time means once per window") {
  const auto w = hs::stgae_flops_per_window(tiny(hs::StgaePadding::Centred), 4);
  CHECK(w.encoder == 2 * 4 * kEnc);
  CHECK(w.denoise == 2 * 4 * kDen);
  // Gates: time branch once (416), joint branch per frame (4*16), for enc_gate and pre_gate.
  CHECK(w.gates == 2 * 2 * (416 + 4 * 16));
  // pre.head (4 -> 4, d = 2, kt = T - DT + 1 = 3) on 4 frames, 2 output frames:
  //   gcn 4*26*4*12 = 4992, aggregation 4*3*676*4 = 32448, q/k 4*2*26*4*6 = 4992,
  //   scores 4*3*676*2 = 16224, tcn 2*26*3*16 = 2496, res 2*26*4*4 = 832 -> 61984
  // pre.0 with kt = 3 on 2 frames: 25740 - 2*26*9 (kt 1 tcn) + 2*26*3*9 (kt 3 tcn) = 26676
  CHECK(w.predict == 2 * (61984 + 26676));
  CHECK_THROWS_AS(hs::stgae_flops_per_frame(tiny(hs::StgaePadding::Centred)), std::invalid_argument);
  CHECK_THROWS_AS(hs::stgae_flops_per_window(tiny(hs::StgaePadding::Centred), 5), std::invalid_argument);
}

TEST_CASE("attention variants and gates change the count as expected") {
  auto c = tiny(hs::StgaePadding::Causal);
  const auto dot = hs::stgae_flops_per_frame(c);
  c.c_variant = hs::StgaeCVariant::Gat;
  // enc.0 gat: embedding 26*6*9 = 1404, scores 2*3*26*3 = 468 replace q/k + q.k (8892).
  CHECK(hs::stgae_flops_per_frame(c).encoder == dot.encoder - 2 * 8892 + 2 * (1404 + 468));
  c.attention = hs::StgaeAttention::AB;
  CHECK(hs::stgae_flops_per_frame(c).encoder == dot.encoder - 2 * 8892);
  c.gates = false;
  CHECK(hs::stgae_flops_per_frame(c).gates == 0);
  c.predict = false;
  CHECK(hs::stgae_flops_per_frame(c).predict == 0);
  CHECK_THROWS_AS(hs::stgae_flops_per_window(c, 0), std::invalid_argument);
}

TEST_CASE("the topology lists every node once, in file order, and its counts sum to the totals") {
  for (auto pad : {hs::StgaePadding::Causal, hs::StgaePadding::Centred}) {
    const auto c = tiny(pad);
    const auto nodes = hs::stgae_topology(c);
    std::vector<std::string> prefixes;
    std::vector<std::string> names;
    for (const auto& n : nodes) {
      prefixes.push_back(n.prefix);
      for (const auto& t : n.tensors) {
        CHECK(t.name.rfind(n.prefix, 0) == 0);
        names.push_back(t.name);
      }
    }
    const bool causal = pad == hs::StgaePadding::Causal;
    CHECK(prefixes == std::vector<std::string>{"enc.0.", "den.0.", "enc_gate.", "pre_gate.",
                                               causal ? "pre.lift." : "pre.head.", "pre.0."});
    std::vector<std::string> spec_names;
    for (const auto& s : hs::stgae_tensor_specs(c)) spec_names.push_back(s.name);
    CHECK(names == spec_names);
    std::int64_t macs = 0;
    for (const auto& n : nodes) macs += n.macs(c, c.window);
    CHECK(2 * macs == hs::stgae_flops_per_window(c, c.window).total());
    CHECK(nodes[1].linear);
    CHECK_FALSE(nodes[0].linear);
  }
}
