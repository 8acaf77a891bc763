// libtorch forward (training/src/stgae_torch) vs the Eigen engine's window mode on small
// random models: every padding, attention variant, gates on/off, predict on/off; and each
// engine layer against the torch module of its topology node.
// float64 must agree to 1e-9, float32 to 1e-4 relative (on the offset scale).
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

#include "stgae_torch.hpp"
#include "train_data.hpp"

#include "handsteady/stgae_engine.hpp"
#include "handsteady/stgae_layers.hpp"
#include "handsteady/stgae_topology.hpp"
#include "handsteady/stgae_model.hpp"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

using namespace hs;
using namespace hs::train;

namespace {

// The sizes every small test network shares (either family).
StgaeConfig small_sizes(StgaePadding pad, bool predict) {
  StgaeConfig c;
  c.window = 8;
  c.horizon = 3;
  c.temporal_kernel = 3;
  c.encoder_channels = {6, 8, 8};
  c.denoise_decoder_channels = {8, 8, 3};
  c.predict_decoder_channels = {8, 3};
  c.padding = pad;
  c.predict = predict;
  return c;
}

StgaeConfig small_config(StgaePadding pad, StgaeAttention att, StgaeCVariant cv, bool gates, bool predict) {
  StgaeConfig c = small_sizes(pad, predict);
  c.attention = att;
  c.c_variant = cv;
  c.gates = gates;
  return c;
}

// Random weights with BN statistics far from identity, so that BN handling matters.
StgaeWeights nontrivial_weights(const StgaeConfig& c, uint64_t seed) {
  StgaeWeights w = random_stgae_weights(c, seed);
  std::mt19937_64 rng(seed + 17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto ends = [](const std::string& s, const std::string& e) {
    return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
  };
  for (auto& [name, t] : w.tensors) {
    for (float& v : t.data) {
      if (ends(name, "running_mean")) v = static_cast<float>(u(rng) - 0.5);
      else if (ends(name, "running_var")) v = static_cast<float>(0.3 + 2.0 * u(rng));
      else if (ends(name, "bn.weight")) v = static_cast<float>(0.5 + u(rng));
      else if (ends(name, "bn.bias")) v = static_cast<float>(0.4 * (u(rng) - 0.5));
    }
  }
  return w;
}

// Synthetic hand frames with holes: a few joints missing at times (hole filling is part of
// the function), including never-seen-yet joints at the start.
std::vector<Pose> raw_input(const StgaeConfig& c, int frames, uint64_t seed) {
  const auto flat = synthetic_hand_input(c, frames, seed);
  std::vector<Pose> out(static_cast<size_t>(frames));
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < kJointCount; ++j)
      for (int k = 0; k < 3; ++k) out[static_cast<size_t>(t)](j, k) = flat[static_cast<size_t>((t * kJointCount + j) * 3 + k)];
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int t = 0; t < 3 && t < frames; ++t) out[static_cast<size_t>(t)].row(idx(Joint::IndexTip)).setConstant(nan);
  if (frames > 4) out[4].row(idx(Joint::ThumbDistal)).setConstant(nan);
  if (frames > 5) out[5].row(idx(Joint::Wrist)).setConstant(nan);
  return out;
}

struct TorchResult {
  torch::Tensor denoised, predicted, filled;  // [L, N, 3], [DT, N, 3], [L, N, 3] (float64)
};

TorchResult torch_forward(StgaeNetImpl& net, const std::vector<Pose>& raw, torch::Dtype dtype) {
  const auto L = static_cast<int64_t>(raw.size());
  std::vector<double> feat(static_cast<size_t>(L) * kJointCount * 6), filled(static_cast<size_t>(L) * kJointCount * 3);
  REQUIRE(input_features(raw, net.config.shape_scale_m, net.config.velocity_scale_m, feat.data(), filled.data()));
  auto f = torch::from_blob(feat.data(), {1, L, kJointCount, 6}, torch::kFloat64).to(dtype);
  auto x = torch::from_blob(filled.data(), {1, L, kJointCount, 3}, torch::kFloat64).to(dtype);
  torch::NoGradGuard no_grad;
  const auto out = net.forward(f);
  TorchResult r;
  const auto X = denoised_positions(net.config, x, out);
  r.denoised = X[0].to(torch::kFloat64);
  r.filled = x[0].to(torch::kFloat64).clone();
  if (net.config.predict) r.predicted = predicted_positions(net.config, X, out)[0].to(torch::kFloat64);
  return r;
}

template <class S>
hs::StgaeOutput<S> engine_forward(const StgaeConfig& c, const StgaeWeights& w, const std::vector<Pose>& raw) {
  const auto net = make_stgae_net<S>(c, w);
  StgaeFrames<S> in(static_cast<Eigen::Index>(raw.size()), 3 * kJointCount);
  for (size_t t = 0; t < raw.size(); ++t)
    for (int j = 0; j < kJointCount; ++j)
      for (int k = 0; k < 3; ++k) in(static_cast<Eigen::Index>(t), 3 * j + k) = static_cast<S>(raw[t](j, k));
  return stgae_window_forward(*net, in);
}

// Largest |torch - engine| over all values.
template <class S>
double max_diff(const torch::Tensor& t, const StgaeFrames<S>& e) {
  const auto tc = t.contiguous();
  REQUIRE(tc.numel() == e.size());
  const double* p = tc.data_ptr<double>();
  double m = 0.0;
  for (Eigen::Index i = 0; i < e.size(); ++i) m = std::max(m, std::abs(p[i] - static_cast<double>(e.data()[i])));
  return m;
}

// Largest |engine offset| in shape_scale units: the scale the float tolerance is relative to.
template <class S>
double max_offset(const torch::Tensor& base, const StgaeFrames<S>& e, double scale) {
  const auto bc = base.contiguous();
  const double* p = bc.data_ptr<double>();
  double m = 0.0;
  for (Eigen::Index i = 0; i < e.size(); ++i) m = std::max(m, std::abs(static_cast<double>(e.data()[i]) - p[i]) / scale);
  return m;
}

// The whole network: torch (float64, float32) against the engine's window mode on `raw`,
// and export giving back exactly the imported float32 weights.
void check_network_parity(const StgaeConfig& c, const StgaeWeights& w, const std::vector<Pose>& raw) {
  const auto L = static_cast<int64_t>(raw.size());
  StgaeNetImpl net(c);
  import_weights(net, w);
  net.eval();
  const StgaeWeights back = export_weights(net);
  for (const auto& [name, t] : w.tensors) {
    CAPTURE(name);
    CHECK(back.at(name).data == t.data);
  }
  net.to(torch::kFloat64);
  const auto t64 = torch_forward(net, raw, torch::kFloat64);
  const auto e64 = engine_forward<double>(c, w, raw);
  CHECK(max_diff(t64.denoised, e64.denoised) <= 1e-9);
  // The comparison is not vacuous: the model changes its input.
  CHECK(max_offset(t64.filled, e64.denoised, c.shape_scale_m) > 1e-3);
  if (c.predict) {
    REQUIRE(e64.predicted.rows() == c.horizon);
    CHECK(max_diff(t64.predicted, e64.predicted) <= 1e-9);
  }
  net.to(torch::kFloat32);
  const auto t32 = torch_forward(net, raw, torch::kFloat32);
  const auto e32 = engine_forward<float>(c, w, raw);
  const double scale = std::max(1.0, max_offset(t64.filled, e64.denoised, c.shape_scale_m));
  CHECK(max_diff(t32.denoised, e32.denoised) / c.shape_scale_m <= 1e-4 * scale);
  if (c.predict) {
    const double pscale = std::max(1.0, max_offset(t64.filled.narrow(0, L - 1, 1).expand({c.horizon, kJointCount, 3}),
                                                    e64.predicted, c.shape_scale_m));
    CHECK(max_diff(t32.predicted, e32.predicted) / c.shape_scale_m <= 1e-4 * pscale);
  }
}

const char* pad_name(StgaePadding p) { return p == StgaePadding::Causal ? "causal" : "centred"; }
const char* att_name(StgaeAttention a, StgaeCVariant v) {
  if (a == StgaeAttention::A) return "A";
  if (a == StgaeAttention::AB) return "A+B";
  return v == StgaeCVariant::Dot ? "A+B+C dot" : "A+B+C gat";
}

struct Variant {
  StgaeAttention att;
  StgaeCVariant cv;
};
const Variant kVariants[] = {{StgaeAttention::A, StgaeCVariant::Dot},
                             {StgaeAttention::AB, StgaeCVariant::Dot},
                             {StgaeAttention::ABC, StgaeCVariant::Dot},
                             {StgaeAttention::ABC, StgaeCVariant::Gat}};

}  // namespace

TEST_CASE("torch forward matches the Eigen window mode (float64 1e-9, float32 1e-4)") {
  torch::manual_seed(1);
  uint64_t seed = 100;
  for (const auto pad : {StgaePadding::Causal, StgaePadding::Centred})
    for (const auto& v : kVariants)
      for (const bool gates : {false, true})
        for (const bool predict : {false, true}) {
          const StgaeConfig c = small_config(pad, v.att, v.cv, gates, predict);
          CAPTURE(pad_name(pad));
          CAPTURE(att_name(v.att, v.cv));
          CAPTURE(gates);
          CAPTURE(predict);
          const StgaeWeights w = nontrivial_weights(c, ++seed);
          // Causal models run on sequences longer than T (moving time means, conv history);
          // the centred predictor needs exactly T frames.
          const int L = (pad == StgaePadding::Causal) ? 2 * c.window + 3 : (predict ? c.window : c.window + 2);
          const auto raw = raw_input(c, L, seed);

          check_network_parity(c, w, raw);
        }
}

// The training forward's predictions at its last P frames against the engine's window mode
// over the frames up to each of them (float64, 1e-9).
void check_p_frame_predictions(const StgaeConfig& c, uint64_t seed) {
  const StgaeWeights w = nontrivial_weights(c, seed);
  const int L = 2 * c.window + 3, P = 4;
  const auto raw = raw_input(c, L, seed);
  StgaeNetImpl net(c);
  import_weights(net, w);
  net.eval();
  net.to(torch::kFloat64);
  std::vector<double> feat(static_cast<size_t>(L) * kJointCount * 6), filled(static_cast<size_t>(L) * kJointCount * 3);
  REQUIRE(input_features(raw, c.shape_scale_m, c.velocity_scale_m, feat.data(), filled.data()));
  const auto f = torch::from_blob(feat.data(), {1, L, kJointCount, 6}, torch::kFloat64);
  const auto x = torch::from_blob(filled.data(), {1, L, kJointCount, 3}, torch::kFloat64);
  torch::NoGradGuard no_grad;
  const auto out = net.forward(f, P);
  const auto Y = predicted_positions(c, denoised_positions(c, x, out), out);
  REQUIRE(Y.dim() == 5);
  REQUIRE(Y.size(1) == P);
  for (int p = 0; p < P; ++p) {
    CAPTURE(p);
    // The prediction at frame L - P + p is window mode over the frames up to it.
    const std::vector<Pose> prefix(raw.begin(), raw.begin() + (L - P + p + 1));
    CHECK(max_diff(Y[0][p], engine_forward<double>(c, w, prefix).predicted) <= 1e-9);
  }
  CHECK_THROWS_AS(net.forward(f, L + 1), std::invalid_argument);
}

TEST_CASE("predictions at the last P frames (training) are the engine's prediction at each of those frames") {
  check_p_frame_predictions(small_config(StgaePadding::Causal, StgaeAttention::ABC, StgaeCVariant::Dot, true, true), 77);
}

TEST_CASE("a one-weight change is visible to the parity comparison") {
  for (const auto pad : {StgaePadding::Causal, StgaePadding::Centred}) {
    const StgaeConfig c = small_config(pad, StgaeAttention::ABC, StgaeCVariant::Dot, true, true);
    const StgaeWeights w = nontrivial_weights(c, 7);
    StgaeWeights w2 = w;
    w2.tensors.at("enc.0.B").data[5] += 1e-3f;
    const auto raw = raw_input(c, c.window, 3);
    StgaeNetImpl net(c);
    import_weights(net, w2);
    net.eval();
    net.to(torch::kFloat64);
    const auto t = torch_forward(net, raw, torch::kFloat64);
    const auto e = engine_forward<double>(c, w, raw);
    CHECK(max_diff(t.denoised, e.denoised) > 1e-7);
  }
}

TEST_CASE("training-mode BatchNorm differs from eval mode, eval mode is what is exported") {
  const StgaeConfig c = small_config(StgaePadding::Causal, StgaeAttention::AB, StgaeCVariant::Dot, true, true);
  const StgaeWeights w = nontrivial_weights(c, 9);
  StgaeNetImpl net(c);
  import_weights(net, w);
  net.to(torch::kFloat64);
  const auto raw = raw_input(c, c.window, 4);
  net.train();
  const auto tt = torch_forward(net, raw, torch::kFloat64);  // also updates running stats
  net.eval();
  const auto e = engine_forward<double>(c, w, raw);
  CHECK(max_diff(tt.denoised, e.denoised) > 1e-6);
  // The running statistics moved (momentum 0.1), so re-exported weights differ from w.
  const auto back = export_weights(net);
  CHECK(back.at("enc.0.gcn.bn.running_mean").data != w.at("enc.0.gcn.bn.running_mean").data);
}

TEST_CASE("import rejects weights of another shape") {
  const StgaeConfig c = small_config(StgaePadding::Causal, StgaeAttention::AB, StgaeCVariant::Dot, false, false);
  StgaeWeights w = random_stgae_weights(c, 1);
  w.tensors.at("enc.0.res.conv.weight").shape = {8, 5};
  StgaeNetImpl net(c);
  CHECK_THROWS_AS(import_weights(net, w), InputError);
}

// ---- per layer: each engine layer (stgae_layers.hpp) against the torch module of its node ----

namespace {

// [1, L, N, C] float64 activations, roughly unit scale.
torch::Tensor random_activations(int64_t L, int64_t C, uint64_t seed) {
  torch::manual_seed(seed);
  return torch::randn({1, L, kJointCount, C}, torch::kFloat64);
}

// [1, L, N, C] -> (L*N) x C, row t*N + v (the engine's window layout).
stgae::Mat<double> to_engine(const torch::Tensor& t) {
  const auto c = t.contiguous();
  const int64_t C = c.size(-1), rows = c.numel() / C;
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(c.data_ptr<double>(), rows, C);
}

double max_diff(const torch::Tensor& t, const stgae::Mat<double>& e) {
  return (to_engine(t) - e).cwiseAbs().maxCoeff();
}

// Streams the window X frame by frame through layer.step from a reset state; the largest
// difference from the window's output Y.
template <class Layer, class State>
double step_vs_forward(const Layer& layer, State& st, const stgae::Mat<double>& X, const stgae::Mat<double>& Y, int64_t L) {
  st.reset();
  double worst = 0.0;
  for (int t = 0; t < L; ++t) {
    const stgae::Mat<double> xt = X.middleRows(t * kJointCount, kJointCount);
    layer.step(st, xt, t);
    worst = std::max(worst, (st.out - Y.middleRows(t * kJointCount, kJointCount)).cwiseAbs().maxCoeff());
  }
  return worst;
}

}  // namespace

TEST_CASE("every engine layer matches the torch module of its node in float64, and streams as it windows") {
  struct Variant {
    StgaeAttention att;
    StgaeCVariant cv;
  };
  uint64_t seed = 500;
  for (const auto pad : {StgaePadding::Causal, StgaePadding::Centred})
    for (const Variant v : {Variant{StgaeAttention::A, StgaeCVariant::Dot}, Variant{StgaeAttention::AB, StgaeCVariant::Dot},
                            Variant{StgaeAttention::ABC, StgaeCVariant::Dot}, Variant{StgaeAttention::ABC, StgaeCVariant::Gat}}) {
      const StgaeConfig c = small_config(pad, v.att, v.cv, true, true);
      CAPTURE(pad_name(pad));
      CAPTURE(att_name(v.att, v.cv));
      const StgaeWeights w = nontrivial_weights(c, ++seed);
      StgaeNetImpl net(c);
      import_weights(net, w);
      net.eval();
      net.to(torch::kFloat64);
      const auto modules = net.named_modules("", /*include_self=*/false);
      torch::NoGradGuard no_grad;
      for (const StgaeNode& node : stgae_topology(c)) {
        CAPTURE(node.prefix);
        const auto* found = modules.find(node.prefix.substr(0, node.prefix.size() - 1));
        REQUIRE(found != nullptr);
        const std::shared_ptr<torch::nn::Module> mod = *found;
        // Longer than T for causal nodes: the moving means and the conv history wrap.
        const int64_t L = node.span == StgaeFrameSpan::Horizon ? c.horizon
                          : node.mean == StgaeTimeMean::Causal  ? 2 * c.window + 3
                                                                : c.window;
        const auto x = random_activations(L, node.c_in, ++seed);
        const stgae::Mat<double> X = to_engine(x);
        stgae::Mat<double> Y;
        switch (node.kind) {
          case StgaeNodeKind::Block: {
            const stgae::BlockLayer<double> layer(c, node, w);
            typename stgae::BlockLayer<double>::Workspace ws;
            layer.forward(static_cast<int>(L), X, Y, ws);
            CHECK(max_diff(std::dynamic_pointer_cast<BlockImpl>(mod)->forward(x), Y) <= 1e-9);
            if (node.mean == StgaeTimeMean::Causal && node.pad == StgaeTemporalPad::Causal) {
              auto st = layer.make_state();
              for (int pass = 0; pass < 2; ++pass) CHECK(step_vs_forward(layer, st, X, Y, L) <= 1e-9);  // the second after reset()
            }
            break;
          }
          case StgaeNodeKind::Gate: {
            const stgae::GateLayer<double> layer(c, node, w);
            typename stgae::GateLayer<double>::Workspace ws;
            layer.forward(static_cast<int>(L), X, Y, ws);
            CHECK(max_diff(std::dynamic_pointer_cast<GateImpl>(mod)->forward(x), Y) <= 1e-9);
            if (node.mean == StgaeTimeMean::Causal) {
              auto st = layer.make_state();
              CHECK(step_vs_forward(layer, st, X, Y, L) <= 1e-9);
            }
            break;
          }
          case StgaeNodeKind::Lift: {
            const stgae::LiftLayer<double> layer(c, node, w);
            layer.forward(static_cast<int>(L), X, Y);
            const int64_t C = node.c_in, DT = node.c_out / node.c_in;
            const auto z = std::dynamic_pointer_cast<Conv1x1Impl>(mod)
                               ->forward(x.select(1, L - 1))
                               .view({1, kJointCount, DT, C})
                               .permute({0, 2, 1, 3});
            CHECK(max_diff(z, Y) <= 1e-9);
            break;
          }
          case StgaeNodeKind::DgnBlock:
          case StgaeNodeKind::DgnTemporal:
          case StgaeNodeKind::DgnLift: FAIL("a Multi-STGAE topology holds no DGN node");
        }
        CHECK(Y.cwiseAbs().maxCoeff() > 1e-3);  // not vacuous
      }
    }
}

// ---- the DGN family (dgn_layers.hpp, dgn_torch.hpp) ----

#include "dgn_torch.hpp"

#include "handsteady/dgn_layers.hpp"

namespace {

StgaeConfig small_dgn(StgaePadding pad, DgnTemporal temporal, bool predict) {
  StgaeConfig c = small_sizes(pad, predict);
  c.family = StgaeFamily::Dgn;
  c.gates = false;
  c.temporal = temporal;
  return c;
}

const char* temporal_name(DgnTemporal t) { return t == DgnTemporal::Tcn ? "tcn" : "lstm"; }

// (L*R) x C engine rows of one stream, from [1, L, R, C].
stgae::Mat<double> rows_of(const torch::Tensor& t) { return to_engine(t); }

}  // namespace

TEST_CASE("DGN: torch forward matches the Eigen window mode (float64 1e-9, float32 1e-4), export = import") {
  uint64_t seed = 900;
  for (const auto pad : {StgaePadding::Causal, StgaePadding::Centred})
    for (const auto temporal : {DgnTemporal::Tcn, DgnTemporal::Lstm})
      for (const bool predict : {false, true}) {
        const StgaeConfig c = small_dgn(pad, temporal, predict);
        CAPTURE(pad_name(pad));
        CAPTURE(temporal_name(temporal));
        CAPTURE(predict);
        const StgaeWeights w = nontrivial_weights(c, ++seed);
        const int L = pad == StgaePadding::Causal ? 2 * c.window + 3 : c.window + 2;
        const auto raw = raw_input(c, L, seed);
        check_network_parity(c, w, raw);
      }
}

TEST_CASE("DGN: predictions at the last P frames (training) are the engine's prediction at each of those frames") {
  for (const auto temporal : {DgnTemporal::Tcn, DgnTemporal::Lstm}) {
    CAPTURE(temporal_name(temporal));
    check_p_frame_predictions(small_dgn(StgaePadding::Causal, temporal, true), 78);
  }
}

TEST_CASE("DGN: every engine layer matches the torch module of its node in float64, and streams as it windows") {
  uint64_t seed = 1500;
  const int N = kJointCount, E = kJointCount - 1;
  for (const auto pad : {StgaePadding::Causal, StgaePadding::Centred})
    for (const auto temporal : {DgnTemporal::Tcn, DgnTemporal::Lstm}) {
      const StgaeConfig c = small_dgn(pad, temporal, true);
      CAPTURE(pad_name(pad));
      CAPTURE(temporal_name(temporal));
      const StgaeWeights w = nontrivial_weights(c, ++seed);
      StgaeNetImpl net(c);
      import_weights(net, w);
      net.eval();
      net.to(torch::kFloat64);
      const auto modules = net.named_modules("", /*include_self=*/false);
      torch::NoGradGuard no_grad;
      const bool causal = pad == StgaePadding::Causal;
      for (const StgaeNode& node : stgae_topology(c)) {
        CAPTURE(node.prefix);
        const auto* found = modules.find(node.prefix.substr(0, node.prefix.size() - 1));
        REQUIRE(found != nullptr);
        const std::shared_ptr<torch::nn::Module> mod = *found;
        const int64_t L = node.span == StgaeFrameSpan::Horizon ? c.horizon : 2 * c.window + 3;
        torch::manual_seed(++seed);
        const auto xv = torch::randn({1, L, N, node.c_in}, torch::kFloat64);
        const auto xe = torch::randn({1, L, E, node.c_in}, torch::kFloat64);
        const stgae::Mat<double> XV = rows_of(xv), XE = rows_of(xe);
        switch (node.kind) {
          case StgaeNodeKind::DgnBlock: {
            const dgn::DgnBlockLayer<double> layer(c, node, w);
            typename dgn::DgnBlockLayer<double>::Workspace ws;
            stgae::Mat<double> YV, YE;
            layer.forward(static_cast<int>(L), XV, XE, YV, YE, ws);
            const auto [tv, te] = std::dynamic_pointer_cast<DgnBlockImpl>(mod)->forward(xv, xe);
            CHECK(max_diff(tv, YV) <= 1e-9);
            CHECK(max_diff(te, YE) <= 1e-9);
            CHECK(YE.cwiseAbs().maxCoeff() > 1e-3);
            auto st = layer.make_state();
            const stgae::Mat<double> fv = XV.bottomRows(N), fe = XE.bottomRows(E);
            layer.step(st, fv, fe);
            CHECK((st.v - YV.bottomRows(N)).cwiseAbs().maxCoeff() <= 1e-12);
            CHECK((st.e - YE.bottomRows(E)).cwiseAbs().maxCoeff() <= 1e-12);
            break;
          }
          case StgaeNodeKind::DgnTemporal: {
            const auto tm = std::dynamic_pointer_cast<DgnTemporalImpl>(mod);
            for (const bool bones : {false, true}) {
              CAPTURE(bones);
              const int rows = bones ? E : N;
              const dgn::DgnTemporalLayer<double> layer(c, node, w, bones ? "e." : "v.", rows);
              const stgae::Mat<double>& X = bones ? XE : XV;
              stgae::Mat<double> Y;
              layer.forward(static_cast<int>(L), X, Y);
              CHECK(max_diff((bones ? tm->e : tm->v)->forward(bones ? xe : xv), Y) <= 1e-9);
              CHECK((Y - X).cwiseAbs().maxCoeff() > 1e-3);  // the layer adds something
              if (causal) {
                auto st = layer.make_state();
                for (int pass = 0; pass < 2; ++pass) {  // the second after reset()
                  st.reset();
                  double worst = 0.0;
                  for (int t = 0; t < L; ++t) {
                    const stgae::Mat<double> xt = X.middleRows(t * rows, rows);
                    layer.step(st, xt, t);
                    worst = std::max(worst, (st.out - Y.middleRows(t * rows, rows)).cwiseAbs().maxCoeff());
                  }
                  CHECK(worst <= 1e-12);
                }
              }
            }
            break;
          }
          case StgaeNodeKind::DgnLift: {
            const dgn::DgnLiftLayer<double> layer(c, node, w);
            stgae::Mat<double> ZV, ZE;
            layer.forward(static_cast<int>(L), XV, XE, ZV, ZE);
            const auto lm = std::dynamic_pointer_cast<DgnLiftImpl>(mod);
            const int64_t C = node.c_in, DT = c.horizon;
            const auto zv = lm->v->forward(xv.select(1, L - 1)).view({1, N, DT, C}).permute({0, 2, 1, 3});
            const auto ze = lm->e->forward(xe.select(1, L - 1)).view({1, E, DT, C}).permute({0, 2, 1, 3});
            CHECK(max_diff(zv, ZV) <= 1e-9);
            CHECK(max_diff(ze, ZE) <= 1e-9);
            break;
          }
          default: FAIL("a DGN topology holds DGN nodes only");
        }
      }
    }
}

TEST_CASE("DGN: the incidence matrices start as D^-1 S0, D^-1 T0 and the bone stream chains from the root") {
  const StgaeConfig c = small_dgn(StgaePadding::Causal, DgnTemporal::Tcn, false);
  const dgn::DgnGraph g = dgn::dgn_graph(c);
  REQUIRE(g.e == g.n - 1);
  // Every row of S + T sums to 1 (each vertex's incident bones share its degree).
  CHECK(((g.S + g.T).rowwise().sum().array() - 1.0).abs().maxCoeff() <= 1e-12);
  // Offsets that are a pure bone change at one bone move that bone's subtree by half.
  stgae::Mat<double> dv = stgae::Mat<double>::Zero(g.n, 3), de = stgae::Mat<double>::Zero(g.e, 3), d;
  const int b = g.bone_of[static_cast<size_t>(idx(Joint::IndexProximal))];
  de(b, 0) = 1.0;
  dgn::dgn_combine(g, 1, dv, de, d);
  CHECK(d(idx(Joint::IndexProximal), 0) == doctest::Approx(0.5));
  CHECK(d(idx(Joint::IndexTip), 0) == doctest::Approx(0.5));
  CHECK(d(idx(Joint::MiddleTip), 0) == doctest::Approx(0.0));
  CHECK(d(idx(Joint::IndexMetacarpal), 0) == doctest::Approx(0.0));
}
