// Multi-STGAE inference: window mode and streaming mode (function: stgae_model.hpp).
// The net is the topology's list of nodes (stgae_topology.hpp) made layers
// (stgae_layers.hpp); this file wires them: input features, encoder, gate, the two
// decoders, positional encoding and outputs. Window mode runs each layer's forward() over
// the sequence; streaming runs each layer's step() from its per-stream State.
#include "handsteady/stgae_engine.hpp"

#include "handsteady/skeleton.hpp"
#include "handsteady/stgae_features.hpp"
#include "handsteady/stgae_layers.hpp"
#include "handsteady/stgae_topology.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace hs {

using stgae::BlockLayer;
using stgae::GateLayer;
using stgae::LiftLayer;
template <class S>
using Mat = stgae::Mat<S>;

template <class S>
struct StgaeNet<S>::Impl {
  StgaeConfig config;
  int n = 0, T = 1, DT = 0, C = 0;
  StgaeAnchors anchors;
  bool causal = true;
  S inv_shape = 1, inv_vel = 1, shape = 1;
  // The topology's nodes by section (each section runs in list order).
  std::vector<BlockLayer<S>> enc, den, pre;
  std::optional<GateLayer<S>> enc_gate, pre_gate;
  std::optional<BlockLayer<S>> head;  // centred prediction
  std::optional<LiftLayer<S>> lift;   // causal prediction
  Mat<S> pe;                          // DT x C
};

template <class S>
StgaeNet<S>::StgaeNet(const StgaeConfig& c, const StgaeWeights& w) : impl_(std::make_unique<Impl>()) {
  validate_stgae_config(c);
  check_stgae_weights(c, w);
  Impl& m = *impl_;
  m.config = c;
  m.n = c.joint_count();
  m.anchors = stgae_anchors(skeleton_by_name(c.skeleton));
  m.T = c.window;
  m.DT = c.predict ? c.horizon : 0;
  m.C = c.latent_channels();
  m.causal = c.padding == StgaePadding::Causal;
  m.shape = static_cast<S>(c.shape_scale_m);
  m.inv_shape = static_cast<S>(1.0 / c.shape_scale_m);
  m.inv_vel = static_cast<S>(1.0 / c.velocity_scale_m);
  for (const StgaeNode& node : stgae_topology(c)) {
    switch (node.section) {
      case StgaeSection::Encoder: m.enc.emplace_back(c, node, w); break;
      case StgaeSection::Denoise: m.den.emplace_back(c, node, w); break;
      case StgaeSection::PredictDecoder: m.pre.emplace_back(c, node, w); break;
      case StgaeSection::EncoderGate: m.enc_gate.emplace(c, node, w); break;
      case StgaeSection::PredictGate: m.pre_gate.emplace(c, node, w); break;
      case StgaeSection::PredictInput:
        if (node.kind == StgaeNodeKind::Lift) m.lift.emplace(c, node, w);
        else m.head.emplace(c, node, w);
        break;
    }
  }
  m.pe.resize(m.DT, m.C);
  for (int i = 0; i < m.DT; ++i)
    for (int ch = 0; ch < m.C; ++ch) m.pe(i, ch) = static_cast<S>(stgae_positional_encoding(i, ch, m.C));
}

template <class S>
StgaeNet<S>::~StgaeNet() = default;

template <class S>
const StgaeConfig& StgaeNet<S>::config() const noexcept {
  return impl_->config;
}

template <class S>
std::shared_ptr<const StgaeNet<S>> make_stgae_net(const StgaeConfig& config, const StgaeWeights& weights) {
  return std::make_shared<const StgaeNet<S>>(config, weights);
}

namespace {

// Prediction decoder on Z ((DT*N) x C): PE added in place, then the pre blocks over the DT
// frames. Allocation-free when outs/ws were sized by an earlier call.
template <class S>
const Mat<S>& predict_decoder(const typename StgaeNet<S>::Impl& m, Mat<S>& z, std::vector<Mat<S>>& outs,
                              std::vector<typename BlockLayer<S>::Workspace>& ws) {
  for (int i = 0; i < m.DT; ++i) z.middleRows(Eigen::Index(i) * m.n, m.n).rowwise() += m.pe.row(i);
  const Mat<S>* cur = &z;
  for (size_t i = 0; i < m.pre.size(); ++i) {
    m.pre[i].forward(m.DT, *cur, outs[i], ws[i]);
    cur = &outs[i];
  }
  return *cur;
}

}  // namespace

template <class S>
StgaeOutput<S> stgae_window_forward(const StgaeNet<S>& net, const StgaeFrames<S>& in) {
  const auto& m = net.impl();
  const int n = m.n;
  if (in.cols() != 3 * n)
    throw InputError(SourceLocation{}, "STGAE input has " + std::to_string(in.cols()) + " values per frame, expected " +
                                           std::to_string(3 * n));
  if (in.rows() < 1) throw InputError(SourceLocation{}, "STGAE input has no frames");
  const int L = static_cast<int>(in.rows());
  if (!m.causal && m.DT > 0 && L != m.T)
    throw InputError(SourceLocation{}, "the centred prediction model needs exactly " + std::to_string(m.T) +
                                           " frames, got " + std::to_string(L));
  const Eigen::Index LN = Eigen::Index(L) * n;
  // 1. hole filling and features.
  StgaeHoleFiller<S> fill(n, m.anchors);
  Mat<S> x(LN, 3), xt(n, 3), xprev(n, 3), f(LN, 6);
  for (int t = 0; t < L; ++t) {
    if (!fill.fill(in.row(t).data(), xt))
      throw InputError(SourceLocation{"", 0, "frame " + std::to_string(t)},
                       "no joint is valid in this frame or any earlier one");
    auto ft = f.middleRows(Eigen::Index(t) * n, n);
    stgae_frame_features(xt, t > 0 ? &xprev : nullptr, m.anchors.wrist, m.inv_shape, m.inv_vel, ft);
    x.middleRows(Eigen::Index(t) * n, n) = xt;
    xprev = xt;
  }
  typename BlockLayer<S>::Workspace ws;
  Mat<S> a = f, b;
  for (const auto& blk : m.enc) {
    blk.forward(L, a, b, ws);
    std::swap(a, b);
  }
  typename GateLayer<S>::Workspace gws;
  Mat<S> h;
  if (m.enc_gate) m.enc_gate->forward(L, a, h, gws);
  else h = a;
  // Denoise.
  Mat<S> d = h;
  for (const auto& blk : m.den) {
    blk.forward(L, d, b, ws);
    std::swap(d, b);
  }
  StgaeOutput<S> out;
  out.denoised.resize(L, 3 * n);
  for (int t = 0; t < L; ++t)
    for (int j = 0; j < n; ++j)
      for (int c = 0; c < 3; ++c)
        out.denoised(t, 3 * j + c) = x(Eigen::Index(t) * n + j, c) + m.shape * d(Eigen::Index(t) * n + j, c);
  out.predicted.resize(m.DT, 3 * n);
  if (m.DT == 0) return out;
  // Predict.
  Mat<S> p;
  if (m.pre_gate) m.pre_gate->forward(L, h, p, gws);
  else p = h;
  Mat<S> z;
  if (m.lift) m.lift->forward(L, p, z);
  else m.head->forward(L, p, z, ws);
  std::vector<Mat<S>> outs(m.pre.size());
  std::vector<typename BlockLayer<S>::Workspace> pws(m.pre.size());
  const Mat<S>& q = predict_decoder<S>(m, z, outs, pws);
  for (int i = 0; i < m.DT; ++i)
    for (int j = 0; j < n; ++j)
      for (int c = 0; c < 3; ++c)
        out.predicted(i, 3 * j + c) = out.denoised(L - 1, 3 * j + c) + m.shape * q(Eigen::Index(i) * n + j, c);
  return out;
}

// ---------------- streaming mode ----------------

template <class S>
struct StgaeStream<S>::State {
  StgaeHoleFiller<S> fill;
  Mat<S> x, xprev, f;
  std::vector<typename BlockLayer<S>::State> enc, den;
  std::optional<typename GateLayer<S>::State> enc_gate, pre_gate;
  std::optional<typename LiftLayer<S>::State> lift;
  std::vector<Mat<S>> pre_out;
  std::vector<typename BlockLayer<S>::Workspace> pre_ws;
  std::vector<S> den_out, pred_out;
  long t = 0;
};

template <class S>
StgaeStream<S>::StgaeStream(std::shared_ptr<const StgaeNet<S>> net) : net_(std::move(net)), s_(std::make_unique<State>()) {
  if (!net_) throw std::invalid_argument("StgaeStream: no model");
  const auto& m = net_->impl();
  if (!m.causal) throw std::invalid_argument("StgaeStream: streaming needs a causal model (this one is centred)");
  State& s = *s_;
  const int n = m.n;
  s.fill = StgaeHoleFiller<S>(n, m.anchors);
  s.x.resize(n, 3);
  s.xprev.resize(n, 3);
  s.f.resize(n, 6);
  for (const auto& b : m.enc) s.enc.push_back(b.make_state());
  for (const auto& b : m.den) s.den.push_back(b.make_state());
  if (m.enc_gate) s.enc_gate = m.enc_gate->make_state();
  s.den_out.assign(static_cast<size_t>(3 * n), S(0));
  if (m.DT > 0) {
    if (m.pre_gate) s.pre_gate = m.pre_gate->make_state();
    s.lift = m.lift->make_state();
    s.pre_out.resize(m.pre.size());
    s.pre_ws.resize(m.pre.size());
    // One untimed run sizes every workspace of the prediction decoder.
    s.lift->out.setZero();
    (void)predict_decoder<S>(m, s.lift->out, s.pre_out, s.pre_ws);
    s.pred_out.assign(static_cast<size_t>(m.DT) * 3 * static_cast<size_t>(n), S(0));
  }
  reset();
}

template <class S>
StgaeStream<S>::~StgaeStream() = default;

template <class S>
void StgaeStream<S>::reset() noexcept {
  State& s = *s_;
  s.fill.reset();
  for (auto& b : s.enc) b.reset();
  for (auto& b : s.den) b.reset();
  if (s.enc_gate) s.enc_gate->reset();
  if (s.pre_gate) s.pre_gate->reset();
  if (s.lift) s.lift->reset();
  std::fill(s.den_out.begin(), s.den_out.end(), std::numeric_limits<S>::quiet_NaN());
  std::fill(s.pred_out.begin(), s.pred_out.end(), std::numeric_limits<S>::quiet_NaN());
  s.t = 0;
}

template <class S>
bool StgaeStream<S>::push(std::span<const S> frame) noexcept {
  const auto& m = net_->impl();
  State& s = *s_;
  const int n = m.n;
  if (frame.size() != static_cast<size_t>(3 * n)) return false;
  if (!s.fill.fill(frame.data(), s.x)) return false;
  stgae_frame_features(s.x, s.t > 0 ? &s.xprev : nullptr, m.anchors.wrist, m.inv_shape, m.inv_vel, s.f);
  s.xprev = s.x;
  const Mat<S>* cur = &s.f;
  for (size_t i = 0; i < m.enc.size(); ++i) {
    m.enc[i].step(s.enc[i], *cur, s.t);
    cur = &s.enc[i].out;
  }
  if (m.enc_gate) {
    m.enc_gate->step(*s.enc_gate, *cur, s.t);
    cur = &s.enc_gate->out;
  }
  const Mat<S>* h = cur;
  for (size_t i = 0; i < m.den.size(); ++i) {
    m.den[i].step(s.den[i], *cur, s.t);
    cur = &s.den[i].out;
  }
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 3; ++c) s.den_out[static_cast<size_t>(3 * j + c)] = s.x(j, c) + m.shape * (*cur)(j, c);
  if (m.DT > 0) {
    const Mat<S>* p = h;
    if (m.pre_gate) {
      m.pre_gate->step(*s.pre_gate, *h, s.t);
      p = &s.pre_gate->out;
    }
    m.lift->step(*s.lift, *p, s.t);
    const Mat<S>& q = predict_decoder<S>(m, s.lift->out, s.pre_out, s.pre_ws);
    for (int i = 0; i < m.DT; ++i)
      for (int j = 0; j < n; ++j)
        for (int c = 0; c < 3; ++c)
          s.pred_out[static_cast<size_t>((i * n + j) * 3 + c)] =
              s.den_out[static_cast<size_t>(3 * j + c)] + m.shape * q(Eigen::Index(i) * n + j, c);
  }
  ++s.t;
  return true;
}

template <class S>
std::span<const S> StgaeStream<S>::denoised() const noexcept {
  return {s_->den_out.data(), s_->den_out.size()};
}

template <class S>
std::span<const S> StgaeStream<S>::predicted(int i) const noexcept {
  const size_t fs = s_->den_out.size();
  if (i < 0 || static_cast<size_t>(i) * fs >= s_->pred_out.size()) return {};
  return {s_->pred_out.data() + static_cast<size_t>(i) * fs, fs};
}

template <class S>
long StgaeStream<S>::frames_pushed() const noexcept {
  return s_->t;
}

template <class S>
const StgaeConfig& StgaeStream<S>::config() const noexcept {
  return net_->config();
}

template class StgaeNet<float>;
template class StgaeNet<double>;
template class StgaeStream<float>;
template class StgaeStream<double>;
template std::shared_ptr<const StgaeNet<float>> make_stgae_net<float>(const StgaeConfig&, const StgaeWeights&);
template std::shared_ptr<const StgaeNet<double>> make_stgae_net<double>(const StgaeConfig&, const StgaeWeights&);
template StgaeOutput<float> stgae_window_forward<float>(const StgaeNet<float>&, const StgaeFrames<float>&);
template StgaeOutput<double> stgae_window_forward<double>(const StgaeNet<double>&, const StgaeFrames<double>&);

}  // namespace hs
