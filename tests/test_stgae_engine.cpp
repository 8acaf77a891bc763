// Multi-STGAE engine: streaming vs window parity, float vs double, no allocation per
// frame, translation equivariance, hand-computed tiny models, the PoseFilter adapter.
#include "handsteady/stgae_engine.hpp"
#include "handsteady/stgae_filter.hpp"

#include "handsteady/skeleton.hpp"
#include "allocation_counting.hpp"
#include "test_support.hpp"

#include <cmath>
#include <cstdlib>
#include <random>

namespace {

using hs::StgaeConfig;

StgaeConfig small_causal(hs::StgaeCVariant cv = hs::StgaeCVariant::Dot, bool gates = true, bool predict = true) {
  StgaeConfig c;
  c.window = 4;
  c.horizon = 2;
  c.encoder_channels = {6, 8, 8};
  c.denoise_decoder_channels = {8, 6, 3};
  c.predict_decoder_channels = {8, 6, 3};
  c.temporal_kernel = 3;
  c.padding = hs::StgaePadding::Causal;
  c.attention = hs::StgaeAttention::ABC;
  c.c_variant = cv;
  c.gates = gates;
  c.predict = predict;
  return c;
}

// A small DGN (dgn_layers.hpp) of the given temporal module and padding.
StgaeConfig small_dgn(hs::DgnTemporal temporal, bool predict = true, hs::StgaePadding pad = hs::StgaePadding::Causal) {
  StgaeConfig c;
  c.family = hs::StgaeFamily::Dgn;
  c.gates = false;
  c.window = 4;
  c.horizon = 2;
  c.encoder_channels = {6, 6, 8};
  c.denoise_decoder_channels = {8, 6, 3};
  c.predict_decoder_channels = {8, 6, 3};
  c.temporal_kernel = 3;
  c.temporal = temporal;
  c.temporal_layers = 2;
  c.padding = pad;
  c.predict = predict;
  return c;
}

template <class S>
hs::StgaeFrames<S> frames_from(const std::vector<float>& v, int n) {
  const auto L = static_cast<Eigen::Index>(v.size()) / (3 * n);
  hs::StgaeFrames<S> f(L, 3 * n);
  for (Eigen::Index i = 0; i < f.size(); ++i) f.data()[i] = static_cast<S>(v[static_cast<size_t>(i)]);
  return f;
}

// Synthetic input with holes: a few joints missing in some frames, one joint missing at first.
std::vector<float> holey_input(const StgaeConfig& c, int frames, std::uint64_t seed) {
  auto v = hs::synthetic_hand_input(c, frames, seed);
  const int n = c.joint_count();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  auto kill = [&](int t, int j) {
    for (int k = 0; k < 3; ++k) v[static_cast<size_t>((t * n + j) * 3 + k)] = nan;
  };
  for (int t = 0; t < 3 && t < frames; ++t) kill(t, 10);  // never seen at the start
  if (frames > 6) {
    kill(5, 3);
    kill(6, 3);
    kill(6, hs::idx(hs::Joint::Wrist));
  }
  return v;
}

double max_abs_diff(std::span<const float> a, const float* b) {
  double m = 0.0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(static_cast<double>(a[i]) - static_cast<double>(b[i])));
  return m;
}

}  // namespace

TEST_CASE("streaming equals window mode on small causal models") {
  struct Variant {
    hs::StgaeCVariant cv;
    bool gates, predict;
    hs::StgaeAttention att;
  };
  const Variant variants[] = {{hs::StgaeCVariant::Dot, true, true, hs::StgaeAttention::ABC},
                              {hs::StgaeCVariant::Gat, true, true, hs::StgaeAttention::ABC},
                              {hs::StgaeCVariant::Dot, false, false, hs::StgaeAttention::ABC},
                              {hs::StgaeCVariant::Dot, false, true, hs::StgaeAttention::AB}};
  for (const auto& var : variants) {
    auto c = small_causal(var.cv, var.gates, var.predict);
    c.attention = var.att;
    CAPTURE(hs::to_json(c));
    const auto w = hs::random_stgae_weights(c, 7, 1.5);
    const auto net = hs::make_stgae_net<float>(c, w);
    const int n = c.joint_count();
    const int L = 13;  // > 3 windows, so every ring wraps
    const auto input = holey_input(c, L, 3);
    const auto all = hs::stgae_window_forward(*net, frames_from<float>(input, n));
    hs::StgaeStream<float> stream(net);
    for (int t = 0; t < L; ++t) {
      REQUIRE(stream.push(std::span<const float>(input.data() + static_cast<size_t>(t * 3 * n), static_cast<size_t>(3 * n))));
      CHECK(max_abs_diff(stream.denoised(), all.denoised.row(t).data()) <= 1e-5);
      if (c.predict && (t == 2 || t == 7 || t == L - 1)) {
        // The prediction at frame t is window mode over the frames up to t.
        std::vector<float> prefix(input.begin(), input.begin() + static_cast<std::ptrdiff_t>((t + 1) * 3 * n));
        const auto part = hs::stgae_window_forward(*net, frames_from<float>(prefix, n));
        for (int i = 0; i < c.horizon; ++i) CHECK(max_abs_diff(stream.predicted(i), part.predicted.row(i).data()) <= 1e-5);
      }
    }
    // Holes are filled and the model really changes the positions.
    CHECK(all.denoised.allFinite());
    double moved = 0.0;
    for (Eigen::Index i = 0; i < all.denoised.size(); ++i)
      if (std::isfinite(input[static_cast<size_t>(i)]))
        moved = std::max(moved, std::abs(static_cast<double>(all.denoised.data()[i] - input[static_cast<size_t>(i)])));
    CHECK(moved > 1e-3);
    // reset() starts a new sequence: the same input gives the same outputs again.
    stream.reset();
    for (int t = 0; t < 5; ++t) stream.push(std::span<const float>(input.data() + static_cast<size_t>(t * 3 * n), static_cast<size_t>(3 * n)));
    CHECK(max_abs_diff(stream.denoised(), all.denoised.row(4).data()) <= 1e-5);
  }
}

TEST_CASE("DGN: streaming equals window mode (temporal conv and LSTM), also after reset") {
  for (const auto temporal : {hs::DgnTemporal::Tcn, hs::DgnTemporal::Lstm})
    for (const bool predict : {true, false}) {
      const auto c = small_dgn(temporal, predict);
      CAPTURE(hs::to_json(c));
      const auto net = hs::make_stgae_net<double>(c, hs::random_stgae_weights(c, 9, 1.5));
      const int n = c.joint_count();
      const int L = 13;
      const auto input = holey_input(c, L, 3);
      const auto all = hs::stgae_window_forward(*net, frames_from<double>(input, n));
      hs::StgaeStream<double> stream(net);
      auto frame = [&](int t) {
        static thread_local std::vector<double> f;
        f.assign(input.begin() + t * 3 * n, input.begin() + (t + 1) * 3 * n);
        return std::span<const double>(f);
      };
      auto diff = [](std::span<const double> a, const double* b) {
        double m = 0.0;
        for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
        return m;
      };
      for (int pass = 0; pass < 2; ++pass) {
        stream.reset();
        for (int t = 0; t < L; ++t) {
          REQUIRE(stream.push(frame(t)));
          CHECK(diff(stream.denoised(), all.denoised.row(t).data()) <= 1e-12);
          if (predict && (t == 2 || t == L - 1)) {
            std::vector<float> prefix(input.begin(), input.begin() + static_cast<std::ptrdiff_t>((t + 1) * 3 * n));
            const auto part = hs::stgae_window_forward(*net, frames_from<double>(prefix, n));
            for (int i = 0; i < c.horizon; ++i) CHECK(diff(stream.predicted(i), part.predicted.row(i).data()) <= 1e-12);
          }
        }
      }
      double moved = 0.0;
      for (Eigen::Index i = 0; i < all.denoised.size(); ++i)
        if (std::isfinite(input[static_cast<size_t>(i)]))
          moved = std::max(moved, std::abs(all.denoised.data()[i] - static_cast<double>(input[static_cast<size_t>(i)])));
      CHECK(moved > 1e-3);
    }
}

TEST_CASE("DGN: the centred model (bidirectional LSTM) runs in window mode only, and its past depends on its future") {
  const auto c = small_dgn(hs::DgnTemporal::Lstm, true, hs::StgaePadding::Centred);
  const auto net = hs::make_stgae_net<double>(c, hs::random_stgae_weights(c, 4, 1.5));
  CHECK_THROWS_AS(hs::StgaeStream<double>{net}, std::invalid_argument);
  const int n = c.joint_count();
  const auto input = holey_input(c, 10, 2);
  const auto all = hs::stgae_window_forward(*net, frames_from<double>(input, n));
  std::vector<float> prefix(input.begin(), input.begin() + 5 * 3 * n);
  const auto part = hs::stgae_window_forward(*net, frames_from<double>(prefix, n));
  CHECK((all.denoised.row(2) - part.denoised.row(2)).cwiseAbs().maxCoeff() > 1e-6);
  CHECK(all.predicted.rows() == c.horizon);
}

TEST_CASE("float and double window modes agree (causal and centred)") {
  for (auto pad : {hs::StgaePadding::Causal, hs::StgaePadding::Centred}) {
    auto c = small_causal();
    c.padding = pad;
    c.window = 6;
    const auto w = hs::random_stgae_weights(c, 11, 1.0);
    const int n = c.joint_count();
    const auto input = holey_input(c, c.window, 5);
    const auto yf = hs::stgae_window_forward(*hs::make_stgae_net<float>(c, w), frames_from<float>(input, n));
    const auto yd = hs::stgae_window_forward(*hs::make_stgae_net<double>(c, w), frames_from<double>(input, n));
    CHECK((yf.denoised.cast<double>() - yd.denoised).cwiseAbs().maxCoeff() <= 1e-5);
    CHECK((yf.predicted.cast<double>() - yd.predicted).cwiseAbs().maxCoeff() <= 1e-5);
    CHECK(yd.predicted.rows() == c.horizon);
    CHECK(yd.denoised.allFinite());
  }
}

TEST_CASE("translating the input translates every output by the same vector") {
  for (auto pad : {hs::StgaePadding::Causal, hs::StgaePadding::Centred}) {
    for (auto cv : {hs::StgaeCVariant::Dot, hs::StgaeCVariant::Gat}) {
      auto c = small_causal(cv);
      c.padding = pad;
      c.window = 5;
      const auto w = hs::random_stgae_weights(c, 21, 1.0);
      const auto net = hs::make_stgae_net<double>(c, w);
      const int n = c.joint_count();
      auto input = holey_input(c, c.window, 9);
      const auto x = frames_from<double>(input, n);
      hs::StgaeFrames<double> moved = x;
      const double shift[3] = {0.37, -1.25, 2.5};
      for (Eigen::Index i = 0; i < moved.size(); ++i) moved.data()[i] += shift[i % 3];
      const auto a = hs::stgae_window_forward(*net, x);
      const auto b = hs::stgae_window_forward(*net, moved);
      for (Eigen::Index t = 0; t < a.denoised.rows(); ++t)
        for (Eigen::Index k = 0; k < a.denoised.cols(); ++k) CHECK(b.denoised(t, k) - a.denoised(t, k) == doctest::Approx(shift[k % 3]).epsilon(1e-9));
      for (Eigen::Index t = 0; t < a.predicted.rows(); ++t)
        for (Eigen::Index k = 0; k < a.predicted.cols(); ++k) CHECK(b.predicted(t, k) - a.predicted(t, k) == doctest::Approx(shift[k % 3]).epsilon(1e-9));
    }
  }
}

namespace {
// All-zero weights with identity-like BN (weight 1, bias 0, mean 0, var 1).
hs::StgaeWeights zero_weights(const StgaeConfig& c) {
  hs::StgaeWeights w;
  for (const auto& s : hs::stgae_tensor_specs(c)) {
    hs::Tensor t;
    t.shape = s.shape;
    const bool one = s.name.ends_with("bn.weight") || s.name.ends_with("running_var");
    t.data.assign(s.numel(), one ? 1.0f : 0.0f);
    w.tensors.emplace(s.name, std::move(t));
  }
  return w;
}
}  // namespace

TEST_CASE("a tiny hand-computed model: gcn layout, graph orientation, causal temporal taps, offset output") {
  // enc: one block 6 -> 1 whose gcn takes channel 0 (x - wrist_x) / 0.1 into subset 1 (bones) and
  // whose temporal conv copies tap 0 (the OLDEST of kt = 3 frames). den: one block 1 -> 3 whose
  // residual copies the latent into the x offset. B[1][palm][thumb_tip] = 1 adds an asymmetric edge.
  StgaeConfig c;
  c.window = 4;
  c.encoder_channels = {6, 1};
  c.denoise_decoder_channels = {1, 3};
  c.temporal_kernel = 3;
  c.attention = hs::StgaeAttention::AB;
  c.gates = false;
  c.predict = false;
  auto w = zero_weights(c);
  const int n = hs::kJointCount;
  const int palm = hs::idx(hs::Joint::Palm), wrist = hs::idx(hs::Joint::Wrist), tip = hs::idx(hs::Joint::ThumbTip);
  w.tensors.at("enc.0.gcn.conv.weight").data[1 * 6 + 0] = 1.0f;  // row k*Cout + c = 1, input channel 0
  w.tensors.at("enc.0.B").data[static_cast<size_t>((1 * n + palm) * n + tip)] = 1.0f;
  w.tensors.at("enc.0.tcn.conv.weight").data[0] = 1.0f;  // [0][0][tap 0]
  w.tensors.at("den.0.res.conv.weight").data[0] = 1.0f;  // output channel 0 (x) <- latent
  const auto net = hs::make_stgae_net<double>(c, w);

  // Three frames; joint u's x coordinate relative to the wrist varies per frame.
  const int L = 3;
  hs::StgaeFrames<double> in(L, 3 * n);
  for (int t = 0; t < L; ++t)
    for (int j = 0; j < n; ++j) {
      in(t, 3 * j + 0) = 0.5 + 0.01 * j * (t + 1);
      in(t, 3 * j + 1) = 1.0 - 0.002 * j;
      in(t, 3 * j + 2) = -0.3 + 0.001 * t;
    }
  const auto y = hs::stgae_window_forward(*net, in);
  const auto A1 = hs::hand_partition(hs::xr_hand_skeleton()).A[1];
  const double s = 1.0 / std::sqrt(1.0 + 1e-5);  // every BN: 1 / sqrt(var + eps)
  for (int t = 0; t < L; ++t) {
    for (int v = 0; v < n; ++v) {
      // Latent of frame t uses frame t-2 (tap 0 of a causal kernel 3), zero padding before.
      double e = 0.0;
      if (t >= 2) {
        const int src = t - 2;
        double g = 0.0;
        for (int u = 0; u < n; ++u) {
          const double f0 = (in(src, 3 * u) - in(src, 3 * wrist)) / 0.1;
          const double h = std::max(0.0, s * f0);
          const double m = A1(u, v) + (u == palm && v == tip ? 1.0 : 0.0);
          g += h * m;
        }
        e = std::max(0.0, s * g);
      }
      const double expect_x = in(t, 3 * v) + 0.1 * s * e;  // den residual BN scale s
      CHECK(y.denoised(t, 3 * v) == doctest::Approx(expect_x).epsilon(1e-12));
      CHECK(y.denoised(t, 3 * v + 1) == doctest::Approx(in(t, 3 * v + 1)).epsilon(1e-12));
    }
  }
  // The asymmetric edge reaches the thumb tip from the palm, not the other way round.
  CHECK(y.denoised(2, 3 * tip) > in(2, 3 * tip) + 0.01);
  // Streaming computes the same.
  hs::StgaeStream<double> st(net);
  for (int t = 0; t < L; ++t) {
    REQUIRE(st.push(std::span<const double>(in.row(t).data(), static_cast<size_t>(3 * n))));
    for (int k = 0; k < 3 * n; ++k) CHECK(st.denoised()[static_cast<size_t>(k)] == doctest::Approx(y.denoised(t, k)).epsilon(1e-12));
  }
}

TEST_CASE("hole filling: a joint never seen takes the wrist, a lost joint holds its last value") {
  StgaeConfig c = small_causal();
  c.predict = false;
  auto w = zero_weights(c);  // all-zero offsets: the output is the filled input
  const auto net = hs::make_stgae_net<double>(c, w);
  const int n = hs::kJointCount;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  hs::StgaeFrames<double> in(2, 3 * n);
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < 3; ++k) in(0, 3 * j + k) = in(1, 3 * j + k) = 0.1 * j + k;
  for (int k = 0; k < 3; ++k) {
    in(0, 3 * 7 + k) = nan;  // joint 7 missing at first
    in(1, 3 * 9 + k) = nan;  // joint 9 lost in frame 1
    in(1, 3 * 1 + k) += 1.0;  // wrist moves
  }
  const auto y = hs::stgae_window_forward(*net, in);
  // BN of zero convs with bias 0 and mean 0 gives exactly zero offsets.
  for (int k = 0; k < 3; ++k) {
    CHECK(y.denoised(0, 3 * 7 + k) == doctest::Approx(in(0, 3 * 1 + k)));
    CHECK(y.denoised(1, 3 * 9 + k) == doctest::Approx(in(0, 3 * 9 + k)));
  }
  hs::StgaeFrames<double> empty = hs::StgaeFrames<double>::Constant(1, 3 * n, nan);
  CHECK_THROWS_AS(hs::stgae_window_forward(*net, empty), hs::InputError);
  hs::StgaeStream<double> st(net);
  CHECK_FALSE(st.push(std::span<const double>(empty.data(), static_cast<size_t>(3 * n))));
  CHECK(st.frames_pushed() == 0);
}

TEST_CASE("no heap allocation per frame after warm-up") {
  using hs::test::g_allocations, hs::test::g_counting;
  const auto c = small_causal(hs::StgaeCVariant::Dot, true, true);
  const auto net = hs::make_stgae_net<float>(c, hs::random_stgae_weights(c, 5, 1.0));
  auto cg = small_causal(hs::StgaeCVariant::Gat, true, true);
  const auto netg = hs::make_stgae_net<float>(cg, hs::random_stgae_weights(cg, 6, 1.0));
  const int n = c.joint_count();
  const auto input = holey_input(c, 40, 4);
  hs::StgaeStream<float> a(net), b(netg);
  // The DGN streams: temporal conv and LSTM.
  const auto ct = small_dgn(hs::DgnTemporal::Tcn), cl = small_dgn(hs::DgnTemporal::Lstm);
  hs::StgaeStream<float> d1(hs::make_stgae_net<float>(ct, hs::random_stgae_weights(ct, 7, 1.0)));
  hs::StgaeStream<float> d2(hs::make_stgae_net<float>(cl, hs::random_stgae_weights(cl, 8, 1.0)));
  auto frame = [&](int t) { return std::span<const float>(input.data() + static_cast<size_t>(t * 3 * n), static_cast<size_t>(3 * n)); };
  for (int t = 0; t < 5; ++t) a.push(frame(t)), b.push(frame(t)), d1.push(frame(t)), d2.push(frame(t));
  g_allocations = 0;
  g_counting = true;
  bool ok = true;
  for (int t = 5; t < 40; ++t) ok = a.push(frame(t)) && b.push(frame(t)) && d1.push(frame(t)) && d2.push(frame(t)) && ok;
  a.reset();
  d1.reset();
  d2.reset();
  ok = a.push(frame(0)) && d1.push(frame(0)) && d2.push(frame(0)) && ok;
  g_counting = false;
  CHECK(ok);
  CHECK(g_allocations.load() == 0);
  const std::string counted = HS_COUNT_MALLOC ? "yes" : "no (sanitizer build: operator new only)";
  MESSAGE("malloc counted too: " << counted);
  // The counter works: an allocation while counting is seen.
  g_counting = true;
  auto* p = new std::vector<int>(100);
  g_counting = false;
  delete p;
  CHECK(g_allocations.load() >= 1);
}

TEST_CASE("window mode checks its input, streaming needs a causal model") {
  auto c = small_causal();
  c.padding = hs::StgaePadding::Centred;
  const auto net = hs::make_stgae_net<double>(c, hs::random_stgae_weights(c, 1));
  const int n = c.joint_count();
  const auto in = frames_from<double>(hs::synthetic_hand_input(c, c.window + 1, 1), n);
  CHECK_THROWS_AS(hs::stgae_window_forward(*net, in), hs::InputError);  // centred head needs L = T
  CHECK_THROWS_AS(hs::stgae_window_forward(*net, hs::StgaeFrames<double>(2, 3 * n - 3)), hs::InputError);
  CHECK_THROWS_AS(hs::StgaeStream<double>{net}, std::invalid_argument);
}

namespace {
std::shared_ptr<const hs::StgaeModel> small_model(const StgaeConfig& c, std::uint64_t seed) {
  auto w = hs::random_stgae_weights(c, seed, 1.0);
  auto ref = hs::make_stgae_reference(c, w, hs::synthetic_hand_input(c, c.window, seed));
  return hs::make_stgae_model(c, std::move(w), std::move(ref));
}
hs::Pose pose_at(const std::vector<float>& v, int t) {
  hs::Pose p;
  for (int j = 0; j < hs::kJointCount; ++j)
    for (int k = 0; k < 3; ++k) p(j, k) = static_cast<double>(v[static_cast<size_t>((t * hs::kJointCount + j) * 3 + k)]);
  return p;
}
// The largest coordinate difference between an answer and a stream's frame.
double pose_diff(const hs::Pose& out, std::span<const float> frame) {
  double worst = 0.0;
  for (size_t i = 0; i < frame.size(); ++i)
    worst = std::max(worst, std::abs(out(static_cast<int>(i / 3), static_cast<int>(i % 3)) - static_cast<double>(frame[i])));
  return worst;
}
}  // namespace

// The adapter tests below run unbounded (no trust region, correction_bound.hpp): they check
// the resampling against the raw streams; test_correction_bound.cpp checks the bound.
TEST_CASE("PoseFilter adapter: resampling onto the model grid, horizons, gaps") {
  const auto c = small_causal();
  const auto model = small_model(c, 3);
  const double dt = 1.0 / c.rate_hz;
  const auto src = hs::synthetic_hand_input(c, 12, 8);

  // Input exactly on the model grid: the filter pushes each frame once, so it reproduces the stream.
  auto f = hs::make_stgae_filter(model, 0.0, 0, false);
  hs::StgaeStream<float> ref(model->net);
  hs::Pose out;
  for (int t = 0; t < 12; ++t) {
    REQUIRE(f->push(1.0 + t * dt, pose_at(src, t)));
    ref.push(std::span<const float>(src.data() + static_cast<size_t>(t * 78), 78));
    f->estimate(1.0 + t * dt, out);
    for (int j = 0; j < hs::kJointCount; ++j)
      for (int k = 0; k < 3; ++k) CHECK(out(j, k) == doctest::Approx(static_cast<double>(ref.denoised()[static_cast<size_t>(3 * j + k)])).epsilon(1e-6));
    // Half a period ahead: halfway to the first predicted frame.
    f->estimate(1.0 + (t + 0.5) * dt, out);
    const double mid = 0.5 * (static_cast<double>(ref.denoised()[0]) + static_cast<double>(ref.predicted(0)[0]));
    CHECK(out(0, 0) == doctest::Approx(mid).epsilon(1e-6));
    f->estimate(1.0 + (t + 2.0) * dt, out);  // the second predicted frame
    CHECK(out(0, 0) == doctest::Approx(static_cast<double>(ref.predicted(1)[0])).epsilon(1e-6));
  }
  CHECK_FALSE(f->push(1.0, pose_at(src, 0)));  // time must increase
  CHECK(f->last_time() == doctest::Approx(1.0 + 11 * dt));

  // At twice the model rate with one stream, every other input sample lands on the grid.
  auto g = hs::make_stgae_filter(model, 0.0, 1, false);
  for (int t = 0; t < 6; ++t) {
    g->push(1.0 + t * dt, pose_at(src, t));
    if (t + 1 < 6) {
      hs::Pose half = 0.5 * (pose_at(src, t) + pose_at(src, t + 1));
      g->push(1.0 + (t + 0.5) * dt, half);
    }
  }
  f = hs::make_stgae_filter(model, 0.0, 0, false);
  for (int t = 0; t < 6; ++t) f->push(1.0 + t * dt, pose_at(src, t));
  hs::Pose a, b;
  f->estimate(1.0 + 5 * dt, a);
  g->estimate(1.0 + 5 * dt, b);
  CHECK((a - b).cwiseAbs().maxCoeff() <= 1e-5);

  // A gap longer than kModelResetGapS resets: afterwards the filter behaves like a fresh one.
  auto h = hs::make_stgae_filter(model, 0.0);
  for (int t = 0; t < 6; ++t) h->push(1.0 + t * dt, pose_at(src, t));
  h->push(1.0 + 6 * dt, hs::untracked_pose());  // hand lost
  h->estimate(1.0 + 6 * dt, a);
  CHECK(a.allFinite());  // still within the gap tolerance
  const double t0 = 1.0 + 6 * dt + hs::kModelResetGapS + 0.05;
  auto fresh = hs::make_stgae_filter(model, 0.0);
  for (int t = 0; t < 4; ++t) {
    h->push(t0 + t * dt, pose_at(src, 6 + t));
    fresh->push(t0 + t * dt, pose_at(src, 6 + t));
  }
  h->estimate(t0 + 3 * dt, a);
  fresh->estimate(t0 + 3 * dt, b);
  CHECK((a - b).cwiseAbs().maxCoeff() <= 1e-9);

  // Before any input: nothing to report. Centred models and negative horizons are refused.
  auto e = hs::make_stgae_filter(model, 0.05);
  e->estimate(0.0, a);
  CHECK_FALSE(hs::any_joint_tracked(a));
  CHECK_THROWS_AS(hs::make_stgae_filter(model, -0.1), std::invalid_argument);
  CHECK_THROWS_AS(hs::make_stgae_filter(model, 0.0, -1), std::invalid_argument);
  CHECK_THROWS_AS(hs::make_stgae_filter(model, 0.0, hs::kStgaeMaxPhases + 1), std::invalid_argument);
  auto cc = c;
  cc.padding = hs::StgaePadding::Centred;
  CHECK_THROWS_AS(hs::make_stgae_filter(small_model(cc, 2), 0.0), std::invalid_argument);
}

TEST_CASE("PoseFilter adapter: on-grid input with rounded timestamps gives each tick's frame at its row") {
  // Tracks store times to 9 decimals, so k/30 s arrives up to 0.5 ns before the exact tick.
  // Each row must still be answered with its own model frame (not a one-period
  // extrapolation from the previous one, the bug this guards against).
  const auto c = small_causal();
  const auto model = small_model(c, 3);
  const double dt = 1.0 / c.rate_hz;
  constexpr int kFrames = 90;
  const auto src = hs::synthetic_hand_input(c, kFrames, 21);
  auto f = hs::make_stgae_filter(model, 0.0, 0, false);
  hs::StgaeStream<float> ref(model->net);
  hs::Pose out;
  int exact = 0;
  for (int t = 0; t < kFrames; ++t) {
    const double ts = std::round((1234.5678 + t * dt) * 1e9) * 1e-9;
    REQUIRE(f->push(ts, pose_at(src, t)));
    ref.push(std::span<const float>(src.data() + static_cast<size_t>(t * 78), 78));
    f->estimate(ts, out);
    double worst = 0.0;
    for (int j = 0; j < hs::kJointCount; ++j)
      for (int k = 0; k < 3; ++k)
        worst = std::max(worst, std::abs(out(j, k) - static_cast<double>(ref.denoised()[static_cast<size_t>(3 * j + k)])));
    CHECK(worst < 1e-5);
    exact += worst < 1e-5 ? 1 : 0;
  }
  CHECK(exact == kFrames);
}

TEST_CASE("PoseFilter adapter: input 3x the model rate runs 3 interleaved streams") {
  // Row n goes to stream n % 3, so each stream sees frames one model period apart. The
  // answer at row n: the newest stream's denoised frame, averaged at half weight with the
  // previous stream's path one third of a period after its frame. Every stream answers
  // from its first frame (none waits for a window of history).
  const auto c = small_causal();
  const auto model = small_model(c, 5);
  const double dt = 1.0 / c.rate_hz / 3.0;
  constexpr int kRows = 60;
  const auto src = hs::synthetic_hand_input(c, kRows, 31);
  auto f = hs::make_stgae_filter(model, 0.0, 3, false);
  std::array<std::unique_ptr<hs::StgaeStream<float>>, 3> ref;
  for (auto& r : ref) r = std::make_unique<hs::StgaeStream<float>>(model->net);
  const auto along = [](const hs::StgaeStream<float>& r, size_t i, double s) {  // path at s periods
    const auto d = static_cast<double>(r.denoised()[i]);
    return d + s * (static_cast<double>(r.predicted(0)[i]) - d);
  };
  hs::Pose out;
  int averaged = 0;
  for (int n = 0; n < kRows; ++n) {
    CAPTURE(n);
    const double t = 2.0 + n * dt;
    REQUIRE(f->push(t, pose_at(src, n)));
    ref[static_cast<size_t>(n % 3)]->push(std::span<const float>(src.data() + static_cast<size_t>(n * 78), 78));
    f->estimate(t, out);
    const auto& now = *ref[static_cast<size_t>(n % 3)];
    const auto& before = *ref[static_cast<size_t>((n + 2) % 3)];
    const bool have_before = n >= 1;  // the previous stream has a frame
    double worst = 0.0;
    for (size_t i = 0; i < 78; ++i) {
      const double expect =
          have_before ? (along(now, i, 0.0) + 0.5 * along(before, i, 1.0 / 3.0)) / 1.5 : along(now, i, 0.0);
      worst = std::max(worst, std::abs(out(static_cast<int>(i / 3), static_cast<int>(i % 3)) - expect));
    }
    CHECK(worst < 1e-5);
    averaged += have_before ? 1 : 0;
  }
  CHECK(averaged == kRows - 1);

  // Phases from the input rate: 30 Hz input keeps one stream (identical answers), 90 Hz
  // input switches to three after the first rows and ends up answering like a filter
  // started with three.
  const auto run = [&](int phases, double step, int rows) {
    auto g = hs::make_stgae_filter(model, 0.0, phases, false);
    for (int n = 0; n < rows; ++n) g->push(2.0 + n * step, pose_at(src, n));
    hs::Pose o;
    g->estimate(2.0 + (rows - 1) * step, o);
    return o;
  };
  CHECK((run(0, 3 * dt, 20) - run(1, 3 * dt, 20)).cwiseAbs().maxCoeff() == 0.0);
  const hs::Pose a90 = run(0, dt, kRows), one90 = run(1, dt, kRows), three90 = run(3, dt, kRows);
  MESSAGE("90 Hz input, auto vs 3 streams " << (a90 - three90).cwiseAbs().maxCoeff() << " m, vs 1 stream "
                                            << (a90 - one90).cwiseAbs().maxCoeff() << " m");
  CHECK((a90 - three90).cwiseAbs().maxCoeff() < 0.1 * (a90 - one90).cwiseAbs().maxCoeff());
}

TEST_CASE("PoseFilter adapter: irregular times near the model rate lock the frames to the samples") {
  // Runtimes date samples irregularly. On a fixed grid each answer would be extrapolated
  // from a tick up to a period earlier; locked, each sample is a model frame at its own
  // time, a missed sample is bridged by an interpolated frame, and a sample less than half
  // a period after the last frame is answered from the path without becoming a frame.
  const auto c = small_causal();
  const auto model = small_model(c, 7);
  const double dt = 1.0 / c.rate_hz;
  constexpr int kRows = 30;
  const auto src = hs::synthetic_hand_input(c, kRows, 41);
  const auto frame = [&](int n) { return std::span<const float>(src.data() + static_cast<size_t>(n * 78), 78); };
  auto f = hs::make_stgae_filter(model, 0.0, 0, false);
  hs::StgaeStream<float> ref(model->net);
  double t = 1.0;
  hs::Pose out;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(0.8, 1.2);
  std::vector<double> intervals;
  double prev_t = t;
  const auto expect_denoised = [&](const char* what) {
    CAPTURE(what);
    CHECK(pose_diff(out, ref.denoised()) < 1e-6);
  };
  for (int n = 0; n < kRows; ++n) {
    CAPTURE(n);
    if (n == 0) {
    } else if (n < 4) {
      t += dt;  // the rate is measured on the first rows
    } else if (n == 12) {  // one sample missed: two periods
      t += 2.0 * dt;
      std::vector<float> mid(78);
      for (size_t i = 0; i < 78; ++i)
        mid[i] = static_cast<float>(static_cast<double>(frame(n - 1)[i]) + 0.5 * static_cast<double>(frame(n)[i] - frame(n - 1)[i]));
      ref.push(std::span<const float>(mid));
    } else {
      t += jitter(rng) * dt;
    }
    REQUIRE(f->push(t, pose_at(src, n)));
    ref.push(frame(n));
    f->estimate(t, out);
    expect_denoised("each sample is a frame");
    if (n > 0) intervals.push_back(t - prev_t);
    prev_t = t;
    if (n == 20) {  // a sample 0.3 periods later: not a frame, the path 0.3 periods on
      REQUIRE(f->push(t + 0.3 * dt, pose_at(src, 0)));
      intervals.push_back(0.3 * dt);
      f->estimate(t + 0.3 * dt, out);
      // The path's frames are the samples' median interval apart (the last 16).
      std::vector<double> last(intervals.end() - 16, intervals.end());
      std::nth_element(last.begin(), last.begin() + 8, last.end());
      const double spacing = last[8];
      CHECK(spacing > 0.85 * dt);
      CHECK(spacing < 1.15 * dt);
      const auto d = static_cast<double>(ref.denoised()[5]);
      CHECK(out(1, 2) == doctest::Approx(d + 0.3 * dt / spacing * (static_cast<double>(ref.predicted(0)[5]) - d)).epsilon(1e-6));
    }
  }
}

TEST_CASE("PoseFilter adapter: the input rate is watched, not only guessed from the first rows") {
  // A runtime that starts at 30 Hz and goes on at 90 Hz (or whose first intervals are
  // stretched by tracking start): once the median of the last intervals has asked for
  // three locked streams long enough, the adapter starts over in that mode and then
  // answers exactly like a filter that saw only the 90 Hz rows (the small model's streams
  // remember a window of frames, so both depend on the same last frames).
  const auto c = small_causal();
  const auto model = small_model(c, 9);
  const double period = 1.0 / c.rate_hz;
  constexpr int kSlow = 30, kFast = 150;
  const auto src = hs::synthetic_hand_input(c, kSlow + kFast, 43);
  auto switched = hs::make_stgae_filter(model, 0.0, 0, false);
  auto fast_only = hs::make_stgae_filter(model, 0.0, 0, false);
  auto one = hs::make_stgae_filter(model, 0.0, 1, false);
  double t = 1.0;
  for (int n = 0; n < kSlow + kFast; ++n) {
    t += n < kSlow ? period : period / 3.0;
    REQUIRE(switched->push(t, pose_at(src, n)));
    REQUIRE(one->push(t, pose_at(src, n)));
    if (n >= kSlow) REQUIRE(fast_only->push(t, pose_at(src, n)));
  }
  hs::Pose a, b, o;
  switched->estimate(t, a);
  fast_only->estimate(t, b);
  one->estimate(t, o);
  MESSAGE("after the switch: vs a filter started at 90 Hz " << (a - b).cwiseAbs().maxCoeff() << " m, vs one stream "
                                                            << (a - o).cwiseAbs().maxCoeff() << " m");
  CHECK((a - b).cwiseAbs().maxCoeff() < 1e-6);
  CHECK((a - o).cwiseAbs().maxCoeff() > 1e-4);
}

TEST_CASE("PoseFilter adapter: input slower than the model locks too, its intervals split into frames in the band") {
  // 23 Hz under a 30 Hz model (a HoloLens 2 log): frames 1.3 periods apart are what a
  // model trained at speed factor 1.33 has seen, so each sample is a frame at its own time.
  // 42 Hz: one stream at 0.71 periods (two would be 1.43), between the bands of K = 1 and
  // K = 2; a frame's motion is a slower hand's, so it locks as well. 20 Hz (1.5 periods)
  // and 12 Hz (2.5): each interval is split into 2 frames, the last at the sample, so the
  // stream sees frames 0.75 and 1.25 periods apart and a sample is still answered by a frame
  // at its own time (on the grid it was answered from a tick up to a period before).
  const auto c = small_causal();
  const auto model = small_model(c, 11);
  const double period = 1.0 / c.rate_hz;
  const int kRows = 4 + 3 * c.window + 12;
  const auto src = hs::synthetic_hand_input(c, kRows, 47);
  const auto answers_are_frames = [&](double step, int split) {
    auto f = hs::make_stgae_filter(model, 0.0, 0, false);
    hs::StgaeStream<float> ref(model->net);
    hs::Pose out;
    std::vector<float> mid(78);
    double worst = 0.0;
    for (int n = 0; n < kRows; ++n) {
      REQUIRE(f->push(1.0 + n * step, pose_at(src, n)));
      for (int k = 1; n > 0 && k < split; ++k) {
        const double a = static_cast<double>(k) / split;
        for (size_t i = 0; i < 78; ++i) {
          const auto x0 = static_cast<double>(src[static_cast<size_t>((n - 1) * 78) + i]);
          const auto x1 = static_cast<double>(src[static_cast<size_t>(n * 78) + i]);
          mid[i] = static_cast<float>(x0 + a * (x1 - x0));
        }
        ref.push(std::span<const float>(mid));
      }
      ref.push(std::span<const float>(src.data() + static_cast<size_t>(n * 78), 78));
      f->estimate(1.0 + n * step, out);
      if (n < 4 + 3 * c.window) continue;  // the first rows run on the grid until the rate is known, and are remembered a while
      worst = std::max(worst, pose_diff(out, ref.denoised()));
    }
    return worst;
  };
  CHECK(answers_are_frames(1.3 * period, 1) < 1e-6);
  CHECK(answers_are_frames(0.71 * period, 1) < 1e-6);
  CHECK(answers_are_frames(1.5 * period, 2) < 1e-6);
  CHECK(answers_are_frames(2.5 * period, 2) < 1e-6);
  CHECK(answers_are_frames(1.5 * period, 1) > 1e-4);  // the check can fail: unsplit frames differ
}

TEST_CASE("PoseFilter adapter: at a rate on the edge between two modes, irregular times keep the running mode") {
  // 45 Hz under a 30 Hz model: one stream at 0.67 periods or two at 1.33 both lock. With
  // times +-20 % the median interval wanders across the edge; the running mode is kept
  // while it still locks (each switch would restart the streams), so every sample after
  // the first rows stays a frame of one stream.
  const auto c = small_causal();
  const auto model = small_model(c, 13);
  const double period = 1.0 / c.rate_hz;
  constexpr int kRows = 400;
  const auto src = hs::synthetic_hand_input(c, kRows, 53);
  auto f = hs::make_stgae_filter(model, 0.0, 0, false);
  hs::StgaeStream<float> ref(model->net);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(0.8, 1.2);
  hs::Pose out;
  double t = 1.0, worst = 0.0;
  int below_edge = 0;  // intervals that alone would ask for two streams
  for (int n = 0; n < kRows; ++n) {
    const double step = n < 4 ? 0.72 * period : jitter(rng) * period / 1.5;
    if (n > 0) t += step;
    if (n >= 4 && step < period / 1.5) ++below_edge;
    REQUIRE(f->push(t, pose_at(src, n)));
    ref.push(std::span<const float>(src.data() + static_cast<size_t>(n * 78), 78));
    f->estimate(t, out);
    if (n < 4 + 3 * c.window) continue;
    worst = std::max(worst, pose_diff(out, ref.denoised()));
  }
  CHECK(below_edge > kRows / 3);  // the edge is crossed, often
  CHECK(worst < 1e-6);
}

TEST_CASE("PoseFilter adapter: a locked stream's predicted path is read at its own frame spacing") {
  // The network predicts in frames. Locked at 1.3 or 0.8 model periods per sample (23 Hz
  // or 37.5 Hz under a 30 Hz model), predicted frame i lies i sample intervals after the
  // sample, not i model periods: read in model periods, a 50 ms answer at 23 Hz was the
  // path 64 ms ahead.
  const auto c = small_causal();
  REQUIRE(c.horizon >= 2);
  const auto model = small_model(c, 5);
  const double period = 1.0 / c.rate_hz;
  const int kRows = 4 + 3 * c.window + 12;
  const auto src = hs::synthetic_hand_input(c, kRows, 49);
  for (const double speed : {1.3, 0.8}) {
    CAPTURE(speed);
    const double step = speed * period;
    auto f = hs::make_stgae_filter(model, 0.0, 1, false);
    hs::StgaeStream<float> ref(model->net);
    hs::Pose out;
    double worst_mid = 0.0, worst_second = 0.0;
    for (int n = 0; n < kRows; ++n) {
      const double t = 1.0 + n * step;
      REQUIRE(f->push(t, pose_at(src, n)));
      ref.push(std::span<const float>(src.data() + static_cast<size_t>(n * 78), 78));
      if (n < 4 + 3 * c.window) continue;  // locked once the rate is known
      f->estimate(t + 0.5 * step, out);  // halfway to the first predicted frame
      for (size_t i = 0; i < 78; ++i) {
        const double mid = 0.5 * (static_cast<double>(ref.denoised()[i]) + static_cast<double>(ref.predicted(0)[i]));
        worst_mid = std::max(worst_mid, std::abs(out(static_cast<int>(i / 3), static_cast<int>(i % 3)) - mid));
      }
      f->estimate(t + 2.0 * step, out);  // the second predicted frame
      worst_second = std::max(worst_second, pose_diff(out, ref.predicted(1)));
    }
    CHECK(worst_mid < 1e-6);
    CHECK(worst_second < 1e-6);
  }
}

TEST_CASE("PoseFilter adapter: at 45-52 Hz three streams run on intervals split in two") {
  // Two streams at 48 Hz under a 30 Hz model would see frames 1.25 periods apart, near the
  // top of the speeds the model was trained on; three on each interval split in two (a
  // frame halfway, one at the sample) see them 0.94 periods apart. Each answer: the stream
  // framed at the sample, averaged at half weight with the one framed halfway, a third of
  // its frame spacing after its frame (the streams remember a window of frames, so after
  // the first rows, which run on the grid until the rate is known, the adapter's streams
  // hold what reference streams fed that sequence hold).
  const auto c = small_causal();
  const auto model = small_model(c, 15);
  const double dt = 1.0 / 48.0;
  const int kRows = 4 + 6 * c.window + 12;
  const auto src = hs::synthetic_hand_input(c, kRows, 59);
  const auto along = [](const hs::StgaeStream<float>& r, size_t i, double s) {
    const auto d = static_cast<double>(r.denoised()[i]);
    return d + s * (static_cast<double>(r.predicted(0)[i]) - d);
  };
  const auto split_streams = [&](int phases) {
    auto f = hs::make_stgae_filter(model, 0.0, phases, false);
    std::array<std::unique_ptr<hs::StgaeStream<float>>, 3> ref;
    for (auto& r : ref) r = std::make_unique<hs::StgaeStream<float>>(model->net);
    std::vector<float> mid(78);
    hs::Pose out;
    size_t k = 0;  // frames pushed to the references
    double worst = 0.0;
    for (int n = 0; n < kRows; ++n) {
      REQUIRE(f->push(1.0 + n * dt, pose_at(src, n)));
      if (n > 0) {
        for (size_t i = 0; i < 78; ++i)
          mid[i] = 0.5f * (src[static_cast<size_t>((n - 1) * 78) + i] + src[static_cast<size_t>(n * 78) + i]);
        ref[k++ % 3]->push(std::span<const float>(mid));
      }
      ref[k++ % 3]->push(std::span<const float>(src.data() + static_cast<size_t>(n * 78), 78));
      f->estimate(1.0 + n * dt, out);
      if (n < 4 + 6 * c.window) continue;
      const auto& now = *ref[(k - 1) % 3];
      const auto& halfway = *ref[(k - 2) % 3];
      for (size_t i = 0; i < 78; ++i) {
        const double expect = (along(now, i, 0.0) + 0.5 * along(halfway, i, 1.0 / 3.0)) / 1.5;
        worst = std::max(worst, std::abs(out(static_cast<int>(i / 3), static_cast<int>(i % 3)) - expect));
      }
    }
    return worst;
  };
  CHECK(split_streams(0) < 1e-5);
  CHECK(split_streams(2) > 1e-4);  // two streams answer otherwise: the check can fail
}

TEST_CASE("PoseFilter adapter: at 47 Hz the shipped model's three streams on split intervals answer a fast hand closer than two") {
  // What the split is for is the speed the streams see: with two streams (what the adapter
  // ran at 45-52 Hz before) each frame is 1.28 model periods after the last, and a hand
  // writing fast moves in a frame what the model saw it move in 1.28 of its own.
  const auto model = hs::test::shipped_model();
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(0.9, 1.1);
  std::normal_distribution<double> noise(0.0, 0.001);
  auto split = hs::make_stgae_filter(model, 0.0, 0, true), two = hs::make_stgae_filter(model, 0.0, 2, true);
  double err_split = 0.0, err_two = 0.0, err_raw = 0.0;
  int n = 0;
  hs::Pose out;
  for (double t = 0.0; t < 8.0; t += u(rng) / 47.0) {
    const hs::Pose truth = hs::test::writing_hand(t), in = hs::test::jittered(truth, rng, noise);
    split->push(t, in);
    two->push(t, in);
    if (t < 1.0) continue;
    split->estimate(t, out);
    err_split += (out - truth).rowwise().norm().mean();
    two->estimate(t, out);
    err_two += (out - truth).rowwise().norm().mean();
    err_raw += (in - truth).rowwise().norm().mean();
    ++n;
  }
  MESSAGE("47 Hz, 1 mm white noise: mean joint error " << err_split / n * 1e3 << " mm (three streams, split), "
                                                      << err_two / n * 1e3 << " mm (two streams), raw " << err_raw / n * 1e3
                                                      << " mm");
  // 0.945 when written (1.408 against 1.491 mm); since the correction gain's low band counts
  // white noise at the share its removal keeps through the band (docs/STGAE.md "White noise's
  // removal is mostly fast") 0.983 (1.406 against 1.430): the gain now takes back most of the
  // slow error two streams made. The same filter would be 1.
  CHECK(err_split < 0.99 * err_two);
}

TEST_CASE("PoseFilter adapter: a tracker that halves its rate (96 to 48 Hz) keeps the three streams' history") {
  // Leap Motion's service drops from 96 to 48 Hz under load. Three streams on 96 Hz frames
  // and three on 48 Hz intervals split in two run on frames as far apart, so the switch
  // changes the split only: two adapters that saw different hands before it still answer
  // differently after it (a restart would have made them answer alike from then on), until
  // their streams' windows have passed (a long window and wide kernels, so that the
  // frames before the switch are still in them when the split is taken up).
  auto c = small_causal();
  c.window = 32;
  c.temporal_kernel = 9;
  const auto model = small_model(c, 17);
  constexpr int kFast = 60;
  const int kSlow = 40 + 6 * c.window;
  const auto a_src = hs::synthetic_hand_input(c, kFast + kSlow, 61), b_src = hs::synthetic_hand_input(c, kFast + kSlow, 67);
  auto a = hs::make_stgae_filter(model, 0.0, 0, false), b = hs::make_stgae_filter(model, 0.0, 0, false);
  hs::Pose oa, ob;
  double t = 1.0, after_switch = 0.0, at_end = 0.0;
  for (int n = 0; n < kFast + kSlow; ++n) {
    t += n < kFast ? 1.0 / 96.0 : 1.0 / 48.0;
    REQUIRE(a->push(t, pose_at(a_src, n)));
    REQUIRE(b->push(t, n < kFast ? pose_at(b_src, n) : pose_at(a_src, n)));
    a->estimate(t, oa);
    b->estimate(t, ob);
    const double d = (oa - ob).cwiseAbs().maxCoeff();
    // The rate is watched over the last 16 intervals, a new mode taken after 8 rows.
    if (n >= kFast + 26 && n < kFast + 30) after_switch = std::max(after_switch, d);
    if (n == kFast + kSlow - 1) at_end = d;
  }
  MESSAGE("adapters that saw different hands before the switch: " << after_switch << " m apart just after it, " << at_end
                                                                 << " m at the end");
  CHECK(after_switch > 1e-4);
  CHECK(at_end < 1e-6);  // the streams remember a window of frames: the check can fail
}

namespace {
// Mean joint errors of a filter's answers and of its input against the truth, on rows at
// `rate` with each interval 0.9-1.1 periods, after the first second.
struct ErrorsVsRaw {
  double filter = 0.0, raw = 0.0;
};
template <class Truth, class Corrupt>
ErrorsVsRaw errors_vs_raw(hs::PoseFilter& f, double seconds, double rate, std::mt19937_64& rng, Truth truth_at,
                          Corrupt corrupt) {
  std::uniform_real_distribution<double> u(0.9, 1.1);
  ErrorsVsRaw e;
  int n = 0;
  hs::Pose out;
  for (double t = 0.0; t < seconds; t += u(rng) / rate) {
    const hs::Pose truth = truth_at(t), in = corrupt(truth);
    f.push(t, in);
    if (t < 1.0) continue;
    f.estimate(t, out);
    e.filter += (out - truth).rowwise().norm().mean();
    e.raw += (in - truth).rowwise().norm().mean();
    ++n;
  }
  e.filter /= n;
  e.raw /= n;
  return e;
}
}  // namespace

TEST_CASE("PoseFilter adapter: one stream on rows slower than the model bounds its corrections by the rows' measured noise") {
  // At 23.5 Hz (HoloLens 2's rate) one stream's frames are 1.28 model periods apart, and on
  // a hand swiping fast (up to 1.6 m/s) its second difference is mostly motion: a radius
  // opened by it let the network's lag through. The noise measured on the rows bounds it
  // instead.
  const auto model = hs::test::shipped_model();
  std::mt19937_64 rng(23);
  std::normal_distribution<double> noise(0.0, 0.0005);
  auto f = hs::make_stgae_filter(model, 0.0, 0, true);
  auto swiping_hand = [](double t) {
    constexpr double pi = std::numbers::pi;
    const Eigen::RowVector3d shift(0.25 * std::sin(2.0 * pi * t), -0.2 + 0.05 * std::sin(2.0 * pi * 0.7 * t), -0.35);
    return hs::Pose(hs::test::synthetic_hand().rowwise() + shift);
  };
  const auto e = errors_vs_raw(*f, 12.0, 23.5, rng, swiping_hand,
                               [&](const hs::Pose& truth) { return hs::test::jittered(truth, rng, noise); });
  MESSAGE("23.5 Hz, 0.5 mm white noise: mean joint error " << e.filter * 1e3 << " mm, raw " << e.raw * 1e3 << " mm");
  // 1.11 x raw's when written, 1.19 x with the stream's own radius (a temporary edit): the
  // network still lags a hand this fast at this rate, less than it did.
  CHECK(e.filter < 1.15 * e.raw);
}

TEST_CASE("PoseFilter adapter: at 90 Hz shifts of a few joints a row keep a radius that opens to them") {
  // The `paper` preset's way of corrupting (each row, a few joints shifted up to 50 mm per
  // axis): the noise measured on the rows reads the shifts as ~5-10 mm RMS, mostly under
  // the jump bar, and a radius of twice that held a shifted joint up to 20 mm off. Their
  // residuals' shape is no Gaussian's (InputNoise::shape), so such joints keep the stream's
  // own radius, which opens to the row's second difference.
  const auto model = hs::test::shipped_model();
  std::mt19937_64 rng(90);
  std::normal_distribution<double> noise(0.0, 0.0003);
  auto f = hs::make_stgae_filter(model, 0.0, 0, true);
  const auto e = errors_vs_raw(*f, 10.0, 90.0, rng, hs::test::writing_hand, [&](const hs::Pose& truth) {
    return hs::test::shifted(hs::test::jittered(truth, rng, noise), rng, 0.08, 0.05);
  });
  MESSAGE("90 Hz, 8 % of joint-rows shifted up to 50 mm per axis: mean joint error " << e.filter * 1e3 << " mm, raw "
                                                                                    << e.raw * 1e3 << " mm");
  // 0.335 x raw's when written, 0.378 x with the measured radius on every joint (as before
  // 2026-12-05: a temporary edit).
  CHECK(e.filter < 0.36 * e.raw);
}
