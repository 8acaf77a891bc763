// Multi-STGAE inference: window mode and streaming mode (function: stgae_model.hpp).
// The net is the topology's list of nodes (stgae_topology.hpp) made layers
// (stgae_layers.hpp); this file wires them: input features, encoder, gate, the two
// decoders, positional encoding and outputs. Window mode runs each layer's forward() over
// the sequence; streaming runs each layer's step() from its per-stream State.
#include "handsteady/stgae_engine.hpp"

#include "handsteady/dgn_layers.hpp"
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
using dgn::DgnBlockLayer;
using dgn::DgnLiftLayer;
using dgn::DgnTemporalLayer;
template <class S>
using Mat = stgae::Mat<S>;

// The DGN's layers (dgn_layers.hpp), by section.
template <class S>
struct DgnParts {
  dgn::DgnGraph graph;
  std::vector<DgnBlockLayer<S>> enc, den, pre;
  std::vector<DgnTemporalLayer<S>> tv, te;  // joints, bones
  std::optional<DgnLiftLayer<S>> lift;
};

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
  std::optional<DgnParts<S>> dgn;     // family dgn: the network instead of the above
  Mat<S> pe;                          // DT x C
};

// The layer of one topology node, in its section: Multi-STGAE / STGAE ...
template <class S>
void add_node(typename StgaeNet<S>::Impl& m, const StgaeConfig& c, const StgaeNode& node, const StgaeWeights& w) {
  switch (node.section) {
    case StgaeSection::Temporal: break;  // DGN only
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

// ... and DGN.
template <class S>
void add_node(DgnParts<S>& d, const StgaeConfig& c, const StgaeNode& node, const StgaeWeights& w) {
  switch (node.section) {
    case StgaeSection::Encoder: d.enc.emplace_back(c, node, w); break;
    case StgaeSection::Denoise: d.den.emplace_back(c, node, w); break;
    case StgaeSection::PredictDecoder: d.pre.emplace_back(c, node, w); break;
    case StgaeSection::Temporal:
      d.tv.emplace_back(c, node, w, "v.", d.graph.n);
      d.te.emplace_back(c, node, w, "e.", d.graph.e);
      break;
    case StgaeSection::PredictInput: d.lift.emplace(c, node, w); break;
    case StgaeSection::EncoderGate:
    case StgaeSection::PredictGate: break;  // none in a DGN
  }
}

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
  if (c.family == StgaeFamily::Dgn) m.dgn.emplace().graph = dgn::dgn_graph(c);
  for (const StgaeNode& node : stgae_topology(c)) {
    if (m.dgn) add_node<S>(*m.dgn, c, node, w);
    else add_node<S>(m, c, node, w);
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

// PE row i added to the rows of predicted frame i ((DT*rows) x C).
template <class S>
void add_positional_encoding(const Mat<S>& pe, Eigen::Index rows, Mat<S>& z) noexcept {
  for (Eigen::Index i = 0; i < pe.rows(); ++i) z.middleRows(i * rows, rows).rowwise() += pe.row(i);
}

// Prediction decoder on Z ((DT*N) x C): PE added in place, then the pre blocks over the DT
// frames. Allocation-free when outs/ws were sized by an earlier call.
template <class S>
const Mat<S>& predict_decoder(const typename StgaeNet<S>::Impl& m, Mat<S>& z, std::vector<Mat<S>>& outs,
                              std::vector<typename BlockLayer<S>::Workspace>& ws) {
  add_positional_encoding(m.pe, m.n, z);
  const Mat<S>* cur = &z;
  for (size_t i = 0; i < m.pre.size(); ++i) {
    m.pre[i].forward(m.DT, *cur, outs[i], ws[i]);
    cur = &outs[i];
  }
  return *cur;
}

// Multi-STGAE in window mode: features f ((L*N) x 6) -> offsets d, q.
template <class S>
void stgae_window(const typename StgaeNet<S>::Impl& m, int L, const Mat<S>& f, Mat<S>& d, Mat<S>& q) {
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
  d = h;
  for (const auto& blk : m.den) {
    blk.forward(L, d, b, ws);
    std::swap(d, b);
  }
  if (m.DT == 0) return;
  Mat<S> p;
  if (m.pre_gate) m.pre_gate->forward(L, h, p, gws);
  else p = h;
  Mat<S> z;
  if (m.lift) m.lift->forward(L, p, z);
  else m.head->forward(L, p, z, ws);
  std::vector<Mat<S>> outs(m.pre.size());
  std::vector<typename BlockLayer<S>::Workspace> pws(m.pre.size());
  q = predict_decoder<S>(m, z, outs, pws);
}

// DGN blocks over F frames of both streams, in place ((F*N) x C, (F*E) x C).
template <class S>
void dgn_blocks(const std::vector<DgnBlockLayer<S>>& blocks, int F, Mat<S>& v, Mat<S>& e, Mat<S>& v2, Mat<S>& e2,
                typename DgnBlockLayer<S>::Workspace& ws) {
  for (const auto& blk : blocks) {
    blk.forward(F, v, e, v2, e2, ws);
    std::swap(v, v2);
    std::swap(e, e2);
  }
}

}  // namespace

// The DGN prediction decoder on the lifted frames (zv, ze; PE added in place); outputs
// per block, so that a stream's second call allocates nothing. Returns the offsets' streams.
// (Outside the anonymous namespace: a stream's state, which has external linkage, holds one.)
template <class S>
struct DgnDecoderBuffers {
  std::vector<Mat<S>> v, e;
  std::vector<typename DgnBlockLayer<S>::Workspace> ws;  // one per block: widths differ
};

namespace {

template <class S>
std::pair<const Mat<S>*, const Mat<S>*> dgn_predict_decoder(const typename StgaeNet<S>::Impl& m, Mat<S>& zv, Mat<S>& ze,
                                                          DgnDecoderBuffers<S>& buf) {
  const auto& g = *m.dgn;
  add_positional_encoding(m.pe, g.graph.n, zv);
  add_positional_encoding(m.pe, g.graph.e, ze);
  buf.v.resize(g.pre.size());
  buf.e.resize(g.pre.size());
  buf.ws.resize(g.pre.size());
  const Mat<S>* v = &zv;
  const Mat<S>* e = &ze;
  for (size_t i = 0; i < g.pre.size(); ++i) {
    g.pre[i].forward(m.DT, *v, *e, buf.v[i], buf.e[i], buf.ws[i]);
    v = &buf.v[i];
    e = &buf.e[i];
  }
  return {v, e};
}

// DGN in window mode (dgn_layers.hpp step 4): features f ((L*N) x 6) -> offsets d, q.
template <class S>
void dgn_window(const typename StgaeNet<S>::Impl& m, int L, const Mat<S>& f, Mat<S>& d, Mat<S>& q) {
  const auto& g = *m.dgn;
  typename DgnBlockLayer<S>::Workspace ws;
  Mat<S> v = f, e, v2, e2;
  dgn::dgn_bone_features(g.graph, L, f, e);
  dgn_blocks(g.enc, L, v, e, v2, e2, ws);
  for (size_t i = 0; i < g.tv.size(); ++i) {
    g.tv[i].forward(L, v, v2);
    g.te[i].forward(L, e, e2);
    std::swap(v, v2);
    std::swap(e, e2);
  }
  Mat<S> dv = v, de = e;
  dgn_blocks(g.den, L, dv, de, v2, e2, ws);
  dgn::dgn_combine(g.graph, L, dv, de, d);
  if (m.DT == 0) return;
  Mat<S> zv, ze;
  g.lift->forward(L, v, e, zv, ze);
  DgnDecoderBuffers<S> buf;
  const auto [qv, qe] = dgn_predict_decoder<S>(m, zv, ze, buf);
  dgn::dgn_combine(g.graph, m.DT, *qv, *qe, q);
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
  if (m.config.centred_head() && L != m.T)
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
  Mat<S> d, q;  // offsets: denoised (L*N) x 3, predicted (DT*N) x 3
  if (m.dgn) dgn_window<S>(m, L, f, d, q);
  else stgae_window<S>(m, L, f, d, q);
  StgaeOutput<S> out;
  out.denoised.resize(L, 3 * n);
  for (int t = 0; t < L; ++t)
    for (int j = 0; j < n; ++j)
      for (int c = 0; c < 3; ++c)
        out.denoised(t, 3 * j + c) = x(Eigen::Index(t) * n + j, c) + m.shape * d(Eigen::Index(t) * n + j, c);
  out.predicted.resize(m.DT, 3 * n);
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
  // family dgn
  struct Dgn {
    Mat<S> fe, d, q;
    std::vector<typename DgnBlockLayer<S>::State> enc, den;
    std::vector<typename DgnTemporalLayer<S>::State> tv, te;
    std::optional<typename DgnLiftLayer<S>::State> lift;
    DgnDecoderBuffers<S> pre;
  };
  std::optional<Dgn> dgn;
};

namespace {

// One streamed frame's offsets from its input, in units of the shape scale: denoised
// (N x 3) and predicted ((DT*N) x 3; null without prediction).
template <class S>
struct FrameOffsets {
  const Mat<S>* denoised;
  const Mat<S>* predicted;
};

// One frame of a DGN stream: features in s.f -> its offsets.
template <class S>
FrameOffsets<S> push_dgn(const typename StgaeNet<S>::Impl& m, typename StgaeStream<S>::State& s) noexcept {
  const auto& g = *m.dgn;
  auto& d = *s.dgn;
  dgn::dgn_bone_features(g.graph, 1, s.f, d.fe);
  const Mat<S>* v = &s.f;
  const Mat<S>* e = &d.fe;
  for (size_t i = 0; i < g.enc.size(); ++i) {
    g.enc[i].step(d.enc[i], *v, *e);
    v = &d.enc[i].v;
    e = &d.enc[i].e;
  }
  for (size_t i = 0; i < g.tv.size(); ++i) {
    g.tv[i].step(d.tv[i], *v, s.t);
    g.te[i].step(d.te[i], *e, s.t);
    v = &d.tv[i].out;
    e = &d.te[i].out;
  }
  const Mat<S>* hv = v;
  const Mat<S>* he = e;
  for (size_t i = 0; i < g.den.size(); ++i) {
    g.den[i].step(d.den[i], *v, *e);
    v = &d.den[i].v;
    e = &d.den[i].e;
  }
  dgn::dgn_combine(g.graph, 1, *v, *e, d.d);
  if (m.DT == 0) return {&d.d, nullptr};
  g.lift->step(*d.lift, *hv, *he);
  const auto [qv, qe] = dgn_predict_decoder<S>(m, d.lift->zv, d.lift->ze, d.pre);
  dgn::dgn_combine(g.graph, m.DT, *qv, *qe, d.q);
  return {&d.d, &d.q};
}

// One frame of a Multi-STGAE / STGAE stream: features in s.f -> its offsets.
template <class S>
FrameOffsets<S> push_stgae(const typename StgaeNet<S>::Impl& m, typename StgaeStream<S>::State& s) noexcept {
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
  if (m.DT == 0) return {cur, nullptr};
  const Mat<S>* p = h;
  if (m.pre_gate) {
    m.pre_gate->step(*s.pre_gate, *h, s.t);
    p = &s.pre_gate->out;
  }
  m.lift->step(*s.lift, *p, s.t);
  return {cur, &predict_decoder<S>(m, s.lift->out, s.pre_out, s.pre_ws)};
}

}  // namespace

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
  if (m.dgn) {
    const auto& g = *m.dgn;
    auto& d = s.dgn.emplace();
    d.fe.resize(g.graph.e, 6);
    d.d.resize(n, 3);
    d.q.resize(Eigen::Index(m.DT) * n, 3);
    for (const auto& b : g.enc) d.enc.push_back(b.make_state());
    for (const auto& b : g.den) d.den.push_back(b.make_state());
    for (const auto& b : g.tv) d.tv.push_back(b.make_state());
    for (const auto& b : g.te) d.te.push_back(b.make_state());
    if (m.DT > 0) {
      d.lift = g.lift->make_state();
      // One untimed run sizes every buffer of the prediction decoder.
      d.lift->zv.setZero();
      d.lift->ze.setZero();
      (void)dgn_predict_decoder<S>(m, d.lift->zv, d.lift->ze, d.pre);
    }
  }
  for (const auto& b : m.enc) s.enc.push_back(b.make_state());
  for (const auto& b : m.den) s.den.push_back(b.make_state());
  if (m.enc_gate) s.enc_gate = m.enc_gate->make_state();
  s.den_out.assign(static_cast<size_t>(3 * n), S(0));
  if (m.DT > 0) s.pred_out.assign(static_cast<size_t>(m.DT) * 3 * static_cast<size_t>(n), S(0));
  if (m.DT > 0 && !m.dgn) {
    if (m.pre_gate) s.pre_gate = m.pre_gate->make_state();
    s.lift = m.lift->make_state();
    s.pre_out.resize(m.pre.size());
    s.pre_ws.resize(m.pre.size());
    // One untimed run sizes every workspace of the prediction decoder.
    s.lift->out.setZero();
    (void)predict_decoder<S>(m, s.lift->out, s.pre_out, s.pre_ws);
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
  if (s.dgn) {
    for (auto& b : s.dgn->tv) b.reset();
    for (auto& b : s.dgn->te) b.reset();
  }
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
  const FrameOffsets<S> o = m.dgn ? push_dgn<S>(m, s) : push_stgae<S>(m, s);
  const Mat<S>& d = *o.denoised;
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 3; ++c) s.den_out[static_cast<size_t>(3 * j + c)] = s.x(j, c) + m.shape * d(j, c);
  if (o.predicted) {
    const Mat<S>& q = *o.predicted;
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
