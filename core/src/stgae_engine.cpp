// Multi-STGAE inference: window mode and streaming mode (function: stgae_model.hpp).
//
// Layouts. Window mode keeps a layer's activations as an (L*N) x C column-major matrix,
// row t*N + v = joint v of frame t. Streaming keeps one frame as an N x C matrix. A time
// mean over W(t) is computed from per-frame "items" (one column per frame): the per-frame
// attention products (dot), the block input (gat) or the gate input. Window mode sums the
// items of W(t) directly; streaming keeps the last T items in a ring and a running sum in
// double (add the new column, subtract the one leaving the window), so its cost does not
// grow with T and float rounding does not drift over long streams.
#include "handsteady/stgae_engine.hpp"

#include "handsteady/skeleton.hpp"
#include "handsteady/stgae_features.hpp"
#include "handsteady/stgae_topology.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace hs {

namespace stgae_detail {

constexpr int K = 3;
constexpr double kBnEps = 1e-5;
enum class Pad { Causal, Centred, Valid };
enum class Means { Causal, Whole };  // over the last T frames / over all frames of the window

template <class S>
using Mat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
template <class S>
using RVec = Eigen::Matrix<S, 1, Eigen::Dynamic>;
template <class S>
using CVec = Eigen::Matrix<S, Eigen::Dynamic, 1>;
using DVec = Eigen::Matrix<double, Eigen::Dynamic, 1>;

template <class S>
struct Block {
  int cin = 0, cout = 0, kt = 1, d = 1, n = 0;
  Pad pad = Pad::Causal;
  bool linear = false;  // last block of a decoder: no ReLU after the temporal conv
  bool att = false;     // has the data-dependent C
  bool gat = false;
  Mat<S> wg;            // cin x K*cout (gcn conv, BN folded)
  RVec<S> bg;
  std::array<Mat<S>, K> abt;  // (A_k + B_k)^T
  Mat<S> wq, wk;        // cin x K*d (dot)
  Mat<S> wemb;          // cin x K*d (gat)
  Mat<S> a;             // 2d x K (gat), column k = a_k
  S inv_sqrt_d = 1;
  Mat<S> wt;            // kt*cout x cout, row j*cout + i = input channel i at tap j
  RVec<S> bt;
  Mat<S> wr;            // cin x cout
  RVec<S> br;
  Eigen::Index items() const { return gat ? Eigen::Index(n) * cin : Eigen::Index(K) * n * n; }
};

template <class S>
struct Gate {
  int c = 0, hc = 0;
  Mat<S> ws;  // c x hc (BN folded)
  RVec<S> bs;
  Mat<S> wt;  // hc x c
  RVec<S> bt;
  Mat<S> wj;  // hc x c
  RVec<S> bj;
  RVec<S> scale, shift;  // final BN
};

// ---------------- parameter preparation (in double, then cast) ----------------

struct BnFold {
  Eigen::RowVectorXd scale, shift;
};
BnFold bn_fold(const StgaeWeights& w, const std::string& p) {
  const auto& g = w.at(p + "weight").data;
  const auto& b = w.at(p + "bias").data;
  const auto& m = w.at(p + "running_mean").data;
  const auto& v = w.at(p + "running_var").data;
  BnFold f;
  const auto n = static_cast<Eigen::Index>(g.size());
  f.scale.resize(n);
  f.shift.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto u = static_cast<size_t>(i);
    f.scale(i) = static_cast<double>(g[u]) / std::sqrt(static_cast<double>(v[u]) + kBnEps);
    f.shift(i) = static_cast<double>(b[u]) - static_cast<double>(m[u]) * f.scale(i);
  }
  return f;
}

// conv weight [out, in] (+ bias) followed by BN -> (in x out, 1 x out).
template <class S>
void fold_conv(const StgaeWeights& w, const std::string& conv, const std::string& bn, Mat<S>& wt, RVec<S>& bias) {
  const Tensor& W = w.at(conv + "weight");
  const Tensor& B = w.at(conv + "bias");
  const int out = W.shape[0], in = W.shape[1];
  const BnFold f = bn_fold(w, bn);
  wt.resize(in, out);
  bias.resize(out);
  for (int o = 0; o < out; ++o) {
    for (int i = 0; i < in; ++i)
      wt(i, o) = static_cast<S>(static_cast<double>(W.data[static_cast<size_t>(o * in + i)]) * f.scale(o));
    bias(o) = static_cast<S>(static_cast<double>(B.data[static_cast<size_t>(o)]) * f.scale(o) + f.shift(o));
  }
}

template <class S>
Mat<S> transposed(const Tensor& t) {  // [out, in] -> in x out
  const int out = t.shape[0], in = t.shape[1];
  Mat<S> m(in, out);
  for (int o = 0; o < out; ++o)
    for (int i = 0; i < in; ++i) m(i, o) = static_cast<S>(t.data[static_cast<size_t>(o * in + i)]);
  return m;
}

template <class S>
Block<S> make_block(const StgaeConfig& c, const StgaeWeights& w, const GraphPartition& gp, const std::string& p,
                    int cin, int cout, int kt, Pad pad, bool linear) {
  Block<S> b;
  const int N = c.joint_count();
  b.cin = cin;
  b.cout = cout;
  b.kt = kt;
  b.n = N;
  b.pad = pad;
  b.linear = linear;
  b.d = std::max(1, cin / 2);
  fold_conv(w, p + "gcn.conv.", p + "gcn.bn.", b.wg, b.bg);
  for (int k = 0; k < K; ++k) {
    Eigen::MatrixXd m = gp.A[static_cast<size_t>(k)];
    if (c.attention != StgaeAttention::A) {
      const auto& B = w.at(p + "B").data;
      for (int v = 0; v < N; ++v)
        for (int u = 0; u < N; ++u) m(v, u) += static_cast<double>(B[static_cast<size_t>((k * N + v) * N + u)]);
    }
    b.abt[static_cast<size_t>(k)] = m.transpose().cast<S>();
  }
  b.att = c.attention == StgaeAttention::ABC;
  b.gat = b.att && c.c_variant == StgaeCVariant::Gat;
  b.inv_sqrt_d = static_cast<S>(1.0 / std::sqrt(static_cast<double>(b.d)));
  if (b.att && !b.gat) {
    b.wq = transposed<S>(w.at(p + "att.q.weight"));
    b.wk = transposed<S>(w.at(p + "att.k.weight"));
  } else if (b.gat) {
    b.wemb = transposed<S>(w.at(p + "att.emb.weight"));
    b.a = transposed<S>(w.at(p + "att.a"));  // [K, 2d] -> 2d x K
  }
  {
    const Tensor& W = w.at(p + "tcn.conv.weight");  // [cout, cout, kt]
    const Tensor& B = w.at(p + "tcn.conv.bias");
    const BnFold f = bn_fold(w, p + "tcn.bn.");
    b.wt.resize(kt * cout, cout);
    b.bt.resize(cout);
    for (int o = 0; o < cout; ++o) {
      for (int i = 0; i < cout; ++i)
        for (int j = 0; j < kt; ++j)
          b.wt(j * cout + i, o) =
              static_cast<S>(static_cast<double>(W.data[static_cast<size_t>((o * cout + i) * kt + j)]) * f.scale(o));
      b.bt(o) = static_cast<S>(static_cast<double>(B.data[static_cast<size_t>(o)]) * f.scale(o) + f.shift(o));
    }
  }
  fold_conv(w, p + "res.conv.", p + "res.bn.", b.wr, b.br);
  return b;
}

template <class S>
Gate<S> make_gate(const StgaeWeights& w, const std::string& g, int ch) {
  Gate<S> r;
  r.c = ch;
  r.hc = std::max(1, ch / 2);
  fold_conv(w, g + "shared.conv.", g + "shared.bn.", r.ws, r.bs);
  r.wt = transposed<S>(w.at(g + "time.conv.weight"));
  r.bt = Eigen::Map<const Eigen::RowVectorXf>(w.at(g + "time.conv.bias").data.data(), ch).cast<S>();
  r.wj = transposed<S>(w.at(g + "joint.conv.weight"));
  r.bj = Eigen::Map<const Eigen::RowVectorXf>(w.at(g + "joint.conv.bias").data.data(), ch).cast<S>();
  const BnFold f = bn_fold(w, g + "bn.");
  r.scale = f.scale.cast<S>();
  r.shift = f.shift.cast<S>();
  return r;
}

// ---------------- per-frame math shared by both modes ----------------

template <class S>
struct AttWs {  // scratch for one block's attention
  Mat<S> q, k, e;
  CVec<S> u1, u2;
  std::array<Mat<S>, K> mt;  // M_k^T for the current frame
  void size_for(const Block<S>& b) {
    const int n = b.n;
    if (b.att && !b.gat) {
      q.resize(n, K * b.d);
      k.resize(n, K * b.d);
    }
    if (b.gat) {
      e.resize(n, K * b.d);
      u1.resize(n);
      u2.resize(n);
    }
    for (auto& m : mt) m.resize(n, n);
  }
};

// The per-frame item whose mean over W(t) the attention needs, written to out (b.items()).
template <class S, class D>
void attention_items(const Block<S>& b, const Eigen::MatrixBase<D>& x, AttWs<S>& ws, S* out) noexcept {
  const int n = b.n;
  if (b.gat) {
    Eigen::Map<Mat<S>>(out, n, b.cin) = x;
    return;
  }
  ws.q.noalias() = x * b.wq;
  ws.k.noalias() = x * b.wk;
  for (int k = 0; k < K; ++k)  // transposed score: (k_w . q_v) at (w, v)
    Eigen::Map<Mat<S>>(out + Eigen::Index(k) * n * n, n, n).noalias() =
        ws.k.middleCols(k * b.d, b.d) * ws.q.middleCols(k * b.d, b.d).transpose();
}

// Softmax of each column (column v of a transposed score = row v of the score).
template <class S>
void softmax_columns(Mat<S>& m) noexcept {
  for (Eigen::Index v = 0; v < m.cols(); ++v) {
    auto col = m.col(v);
    const S mx = col.maxCoeff();
    col = (col.array() - mx).exp().matrix();
    col /= col.sum();
  }
}

// ws.mt[k] = (A_k + B_k + C_k)^T from the window mean of the items.
template <class S>
void attention_matrices(const Block<S>& b, const S* mean, AttWs<S>& ws) noexcept {
  const int n = b.n;
  if (!b.att) {
    for (int k = 0; k < K; ++k) ws.mt[static_cast<size_t>(k)] = b.abt[static_cast<size_t>(k)];
    return;
  }
  if (b.gat) ws.e.noalias() = Eigen::Map<const Mat<S>>(mean, n, b.cin) * b.wemb;
  for (int k = 0; k < K; ++k) {
    Mat<S>& m = ws.mt[static_cast<size_t>(k)];
    if (b.gat) {
      ws.u1.noalias() = ws.e.middleCols(k * b.d, b.d) * b.a.col(k).head(b.d);  // a[0:d] . e_v
      ws.u2.noalias() = ws.e.middleCols(k * b.d, b.d) * b.a.col(k).tail(b.d);  // a[d:2d] . e_w
      for (int v = 0; v < n; ++v)
        for (int u = 0; u < n; ++u) {
          const S s = ws.u2(u) + ws.u1(v);
          m(u, v) = s > S(0) ? s : S(0.2) * s;
        }
    } else {
      m = Eigen::Map<const Mat<S>>(mean + Eigen::Index(k) * n * n, n, n) * b.inv_sqrt_d;
    }
    softmax_columns(m);
    m += b.abt[static_cast<size_t>(k)];
  }
}

template <class S>
struct GateWs {
  Mat<S> zt, gt;
  RVec<S> pj, zj, gj;
  void size_for(const Gate<S>& g, int n) {
    zt.resize(n, g.hc);
    gt.resize(n, g.c);
    pj.resize(g.c);
    zj.resize(g.hc);
    gj.resize(g.c);
  }
};

// y = ReLU(BN(x + x * gt * gj)) for one frame, pt = time-pooled input (N x C).
template <class S, class DX, class DY>
void gate_frame(const Gate<S>& g, const S* pt, const Eigen::MatrixBase<DX>& x, Eigen::MatrixBase<DY>& y,
                GateWs<S>& ws) noexcept {
  const Eigen::Index n = x.rows();
  ws.zt.noalias() = Eigen::Map<const Mat<S>>(pt, n, g.c) * g.ws;
  ws.zt.rowwise() += g.bs;
  ws.zt = ws.zt.cwiseMax(S(0));
  ws.gt.noalias() = ws.zt * g.wt;
  ws.gt.rowwise() += g.bt;
  ws.gt = (S(1) + (-ws.gt.array()).exp()).inverse().matrix();
  ws.pj = x.colwise().sum();
  ws.pj /= static_cast<S>(n);
  ws.zj.noalias() = ws.pj * g.ws;
  ws.zj += g.bs;
  ws.zj = ws.zj.cwiseMax(S(0));
  ws.gj.noalias() = ws.zj * g.wj;
  ws.gj += g.bj;
  ws.gj = (S(1) + (-ws.gj.array()).exp()).inverse().matrix();
  for (Eigen::Index c = 0; c < g.c; ++c)
    for (Eigen::Index v = 0; v < n; ++v) {
      const S z = x(v, c) * (S(1) + ws.gt(v, c) * ws.gj(c)) * g.scale(c) + g.shift(c);
      y(v, c) = z > S(0) ? z : S(0);
    }
}

// ---------------- window mode ----------------

template <class S>
struct WindowWs {
  Mat<S> h, g, items;
  CVec<S> mean;
  AttWs<S> att;
};

// One STGCB over a window. x: (L*N) x cin; y: (Lout*N) x cout (pre-sized by the caller
// for streaming use; then nothing here allocates).
template <class S>
void block_window(const Block<S>& b, Means means, int T, int L, const Mat<S>& x, Mat<S>& y, WindowWs<S>& ws) {
  const int n = b.n;
  const Eigen::Index LN = Eigen::Index(L) * n;
  ws.att.size_for(b);
  // a. gcn conv + BN + ReLU for every frame at once.
  ws.h.resize(LN, K * b.cout);
  ws.h.noalias() = x * b.wg;
  ws.h.rowwise() += b.bg;
  ws.h = ws.h.cwiseMax(S(0));
  // b, c. graph aggregation with the attention of each frame's window.
  ws.g.resize(LN, b.cout);
  if (b.att) {
    ws.items.resize(b.items(), L);
    ws.mean.resize(b.items());
    for (int s = 0; s < L; ++s) attention_items(b, x.middleRows(Eigen::Index(s) * n, n), ws.att, ws.items.col(s).data());
  }
  bool have = false;
  for (int t = 0; t < L; ++t) {
    if (b.att && (means == Means::Causal || !have)) {
      const int s0 = means == Means::Causal ? std::max(0, t - T + 1) : 0;
      const int cnt = means == Means::Causal ? t - s0 + 1 : L;
      ws.mean.noalias() = ws.items.middleCols(s0, cnt).rowwise().sum();
      ws.mean /= static_cast<S>(cnt);
      attention_matrices(b, ws.mean.data(), ws.att);
    } else if (!have) {
      attention_matrices(b, static_cast<const S*>(nullptr), ws.att);
    }
    have = true;
    auto gt = ws.g.middleRows(Eigen::Index(t) * n, n);
    gt.noalias() = ws.att.mt[0] * ws.h.block(Eigen::Index(t) * n, 0, n, b.cout);
    for (int k = 1; k < K; ++k)
      gt.noalias() += ws.att.mt[static_cast<size_t>(k)] * ws.h.block(Eigen::Index(t) * n, k * b.cout, n, b.cout);
  }
  // d. temporal conv, tap by tap over all frames.
  const int off = b.pad == Pad::Causal ? b.kt - 1 : b.pad == Pad::Centred ? (b.kt - 1) / 2 : 0;
  const int lout = b.pad == Pad::Valid ? L - b.kt + 1 : L;
  y.resize(Eigen::Index(lout) * n, b.cout);
  y.rowwise() = b.bt;
  for (int j = 0; j < b.kt; ++j) {
    const int t0 = std::max(0, off - j), t1 = std::min(lout, L + off - j);  // output frames [t0, t1)
    if (t1 <= t0) continue;
    y.middleRows(Eigen::Index(t0) * n, Eigen::Index(t1 - t0) * n).noalias() +=
        ws.g.middleRows(Eigen::Index(t0 + j - off) * n, Eigen::Index(t1 - t0) * n) * b.wt.middleRows(j * b.cout, b.cout);
  }
  // e. (BN folded) ReLU; f. residual (valid: from the newest frame under the kernel).
  if (!b.linear) y = y.cwiseMax(S(0));
  const int r0 = b.pad == Pad::Valid ? b.kt - 1 : 0;
  y.noalias() += x.middleRows(Eigen::Index(r0) * n, Eigen::Index(lout) * n) * b.wr;
  y.rowwise() += b.br;
}

template <class S>
void gate_window(const Gate<S>& g, Means means, int T, int L, int n, const Mat<S>& x, Mat<S>& y, Mat<S>& items,
                 CVec<S>& mean, GateWs<S>& ws) {
  ws.size_for(g, n);
  y.resize(Eigen::Index(L) * n, g.c);
  items.resize(Eigen::Index(n) * g.c, L);
  mean.resize(Eigen::Index(n) * g.c);
  for (int s = 0; s < L; ++s) Eigen::Map<Mat<S>>(items.col(s).data(), n, g.c) = x.middleRows(Eigen::Index(s) * n, n);
  for (int t = 0; t < L; ++t) {
    if (means == Means::Causal || t == 0) {
      const int s0 = means == Means::Causal ? std::max(0, t - T + 1) : 0;
      const int cnt = means == Means::Causal ? t - s0 + 1 : L;
      mean.noalias() = items.middleCols(s0, cnt).rowwise().sum();
      mean /= static_cast<S>(cnt);
    }
    auto yt = y.middleRows(Eigen::Index(t) * n, n);
    gate_frame(g, mean.data(), x.middleRows(Eigen::Index(t) * n, n), yt, ws);
  }
}

}  // namespace stgae_detail

using namespace stgae_detail;

template <class S>
struct StgaeNet<S>::Impl {
  StgaeConfig config;
  int n = 0, wrist = 0, T = 1, DT = 0, C = 0;
  StgaeAnchors anchors;
  bool causal = true;
  S inv_shape = 1, inv_vel = 1, shape = 1;
  std::vector<Block<S>> enc, den, pre;
  std::optional<Block<S>> head;
  bool gates = false;
  Gate<S> enc_gate, pre_gate;
  Mat<S> lift;  // C x DT*C
  RVec<S> lift_b;
  Mat<S> pe;  // DT x C
};

template <class S>
StgaeNet<S>::StgaeNet(const StgaeConfig& c, const StgaeWeights& w) : impl_(std::make_unique<Impl>()) {
  validate_stgae_config(c);
  check_stgae_weights(c, w);
  Impl& m = *impl_;
  m.config = c;
  const Skeleton& sk = skeleton_by_name(c.skeleton);
  const GraphPartition gp = hand_partition(sk);
  m.n = sk.joint_count();
  m.anchors = stgae_anchors(sk);
  m.wrist = m.anchors.wrist;
  m.T = c.window;
  m.DT = c.predict ? c.horizon : 0;
  m.C = c.latent_channels();
  m.causal = c.padding == StgaePadding::Causal;
  m.shape = static_cast<S>(c.shape_scale_m);
  m.inv_shape = static_cast<S>(1.0 / c.shape_scale_m);
  m.inv_vel = static_cast<S>(1.0 / c.velocity_scale_m);
  m.gates = c.gates;
  for (const StgaeNode& node : stgae_topology(c)) {
    switch (node.kind) {
      case StgaeNodeKind::Block: {
        const Pad pad = node.pad == StgaeTemporalPad::Causal    ? Pad::Causal
                        : node.pad == StgaeTemporalPad::Centred ? Pad::Centred
                                                                : Pad::Valid;
        Block<S> b = make_block<S>(c, w, gp, node.prefix, node.c_in, node.c_out, node.kernel, pad, node.linear);
        if (node.section == StgaeSection::Encoder) m.enc.push_back(std::move(b));
        else if (node.section == StgaeSection::Denoise) m.den.push_back(std::move(b));
        else if (node.section == StgaeSection::PredictInput) m.head = std::move(b);
        else m.pre.push_back(std::move(b));
        break;
      }
      case StgaeNodeKind::Gate:
        (node.section == StgaeSection::EncoderGate ? m.enc_gate : m.pre_gate) = make_gate<S>(w, node.prefix, node.c_in);
        break;
      case StgaeNodeKind::Lift:
        m.lift = transposed<S>(w.at(node.prefix + "weight"));
        m.lift_b = Eigen::Map<const Eigen::RowVectorXf>(w.at(node.prefix + "bias").data.data(), node.c_out).cast<S>();
        break;
    }
  }
  if (c.predict) {
    m.pe.resize(m.DT, m.C);
    for (int i = 0; i < m.DT; ++i)
      for (int ch = 0; ch < m.C; ++ch) m.pe(i, ch) = static_cast<S>(stgae_positional_encoding(i, ch, m.C));
  }
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

namespace stgae_detail {

// Prediction decoder on Z ((DT*N) x C, PE added): pre blocks with means over the DT frames.
template <class S>
const Mat<S>& predict_decoder(const typename StgaeNet<S>::Impl& m, const Mat<S>& z, std::vector<Mat<S>>& outs,
                              std::vector<WindowWs<S>>& ws) {
  const Mat<S>* cur = &z;
  for (size_t i = 0; i < m.pre.size(); ++i) {
    block_window(m.pre[i], Means::Whole, m.T, m.DT, *cur, outs[i], ws[i]);
    cur = &outs[i];
  }
  return *cur;
}

template <class S>
void add_pe(const typename StgaeNet<S>::Impl& m, Mat<S>& z) noexcept {
  for (int i = 0; i < m.DT; ++i) z.middleRows(Eigen::Index(i) * m.n, m.n).rowwise() += m.pe.row(i);
}

}  // namespace stgae_detail

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
    stgae_frame_features(xt, t > 0 ? &xprev : nullptr, m.wrist, m.inv_shape, m.inv_vel, ft);
    x.middleRows(Eigen::Index(t) * n, n) = xt;
    xprev = xt;
  }
  const Means means = m.causal ? Means::Causal : Means::Whole;
  WindowWs<S> ws;
  Mat<S> a = f, b;
  for (const auto& blk : m.enc) {
    block_window(blk, means, m.T, L, a, b, ws);
    std::swap(a, b);
  }
  Mat<S> items;
  CVec<S> mean;
  GateWs<S> gws;
  Mat<S> h;
  if (m.gates) gate_window(m.enc_gate, means, m.T, L, n, a, h, items, mean, gws);
  else h = a;
  // Denoise.
  Mat<S> d = h;
  for (const auto& blk : m.den) {
    block_window(blk, means, m.T, L, d, b, ws);
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
  if (m.gates) gate_window(m.pre_gate, means, m.T, L, n, h, p, items, mean, gws);
  else p = h;
  Mat<S> z(Eigen::Index(m.DT) * n, m.C);
  if (m.causal) {
    Mat<S> lifted(n, Eigen::Index(m.DT) * m.C);
    lifted.noalias() = p.middleRows(Eigen::Index(L - 1) * n, n) * m.lift;
    lifted.rowwise() += m.lift_b;
    for (int i = 0; i < m.DT; ++i) z.middleRows(Eigen::Index(i) * n, n) = lifted.middleCols(Eigen::Index(i) * m.C, m.C);
  } else {
    block_window(*m.head, Means::Whole, m.T, L, p, z, ws);
  }
  add_pe<S>(m, z);
  std::vector<Mat<S>> outs(m.pre.size());
  std::vector<WindowWs<S>> pws(m.pre.size());
  const Mat<S>& q = predict_decoder<S>(m, z, outs, pws);
  for (int i = 0; i < m.DT; ++i)
    for (int j = 0; j < n; ++j)
      for (int c = 0; c < 3; ++c)
        out.predicted(i, 3 * j + c) = out.denoised(L - 1, 3 * j + c) + m.shape * q(Eigen::Index(i) * n + j, c);
  return out;
}

// ---------------- streaming mode ----------------

namespace stgae_detail {

// Ring of the last T per-frame items plus their running sum (double).
template <class S>
struct MeanRing {
  Mat<S> items;  // m x T
  DVec sum;
  CVec<S> mean;
  void init(Eigen::Index m, int T) {
    items = Mat<S>::Zero(m, T);
    sum = DVec::Zero(m);
    mean = CVec<S>::Zero(m);
  }
  void reset() noexcept {
    items.setZero();
    sum.setZero();
  }
  // The slot of frame t; call push_done after writing it.
  S* slot(long t) noexcept {
    const auto s = static_cast<Eigen::Index>(t % items.cols());
    sum -= items.col(s).template cast<double>();
    return items.col(s).data();
  }
  void push_done(long t) noexcept {
    const auto s = static_cast<Eigen::Index>(t % items.cols());
    sum += items.col(s).template cast<double>();
    const long cnt = std::min<long>(t + 1, items.cols());
    mean = (sum / static_cast<double>(cnt)).template cast<S>();
  }
};

template <class S>
struct BlockState {
  AttWs<S> att;
  MeanRing<S> ring;
  Mat<S> h, g, hist, u, out;  // hist: N x (2*kt*cout), each frame written twice
  void init(const Block<S>& b, int T) {
    att.size_for(b);
    if (b.att) ring.init(b.items(), T);
    h.resize(b.n, K * b.cout);
    g.resize(b.n, b.cout);
    hist = Mat<S>::Zero(b.n, 2 * b.kt * b.cout);
    u.resize(b.n, b.cout);
    out.resize(b.n, b.cout);
  }
  void reset() noexcept {
    if (ring.items.size()) ring.reset();
    hist.setZero();  // zeros before the sequence start = causal padding
  }
};

// Frame t of a causal block from its ring buffers.
template <class S>
void block_step(const Block<S>& b, BlockState<S>& st, const Mat<S>& x, long t) noexcept {
  if (b.att) {
    attention_items(b, x, st.att, st.ring.slot(t));
    st.ring.push_done(t);
    attention_matrices(b, st.ring.mean.data(), st.att);
  } else if (t == 0) {
    attention_matrices(b, static_cast<const S*>(nullptr), st.att);
  }
  st.h.noalias() = x * b.wg;
  st.h.rowwise() += b.bg;
  st.h = st.h.cwiseMax(S(0));
  st.g.noalias() = st.att.mt[0] * st.h.leftCols(b.cout);
  for (int k = 1; k < K; ++k) st.g.noalias() += st.att.mt[static_cast<size_t>(k)] * st.h.middleCols(k * b.cout, b.cout);
  const auto p = static_cast<Eigen::Index>(t % b.kt);
  st.hist.middleCols(p * b.cout, b.cout) = st.g;
  st.hist.middleCols((p + b.kt) * b.cout, b.cout) = st.g;
  st.u.noalias() = st.hist.middleCols((p + 1) * b.cout, Eigen::Index(b.kt) * b.cout) * b.wt;
  st.u.rowwise() += b.bt;
  if (!b.linear) st.u = st.u.cwiseMax(S(0));
  st.out = st.u;
  st.out.noalias() += x * b.wr;
  st.out.rowwise() += b.br;
}

template <class S>
struct GateState {
  MeanRing<S> ring;
  GateWs<S> ws;
  Mat<S> out;
  void init(const Gate<S>& g, int n, int T) {
    ring.init(Eigen::Index(n) * g.c, T);
    ws.size_for(g, n);
    out.resize(n, g.c);
  }
};

template <class S>
void gate_step(const Gate<S>& g, GateState<S>& st, const Mat<S>& x, long t) noexcept {
  Eigen::Map<Mat<S>>(st.ring.slot(t), x.rows(), g.c) = x;
  st.ring.push_done(t);
  gate_frame(g, st.ring.mean.data(), x, st.out, st.ws);
}

}  // namespace stgae_detail

template <class S>
struct StgaeStream<S>::State {
  StgaeHoleFiller<S> fill;
  Mat<S> x, xprev, f;
  std::vector<BlockState<S>> enc, den;
  GateState<S> enc_gate, pre_gate;
  Mat<S> lifted, z;
  std::vector<Mat<S>> pre_out;
  std::vector<WindowWs<S>> pre_ws;
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
  s.enc.resize(m.enc.size());
  for (size_t i = 0; i < m.enc.size(); ++i) s.enc[i].init(m.enc[i], m.T);
  s.den.resize(m.den.size());
  for (size_t i = 0; i < m.den.size(); ++i) s.den[i].init(m.den[i], m.T);
  if (m.gates) s.enc_gate.init(m.enc_gate, n, m.T);
  s.den_out.assign(static_cast<size_t>(3 * n), S(0));
  if (m.DT > 0) {
    if (m.gates) s.pre_gate.init(m.pre_gate, n, m.T);
    s.lifted.resize(n, Eigen::Index(m.DT) * m.C);
    s.z.resize(Eigen::Index(m.DT) * n, m.C);
    s.pre_out.resize(m.pre.size());
    s.pre_ws.resize(m.pre.size());
    // One untimed run sizes every workspace of the prediction decoder.
    s.z.setZero();
    (void)predict_decoder<S>(m, s.z, s.pre_out, s.pre_ws);
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
  if (s.enc_gate.ring.items.size()) s.enc_gate.ring.reset();
  if (s.pre_gate.ring.items.size()) s.pre_gate.ring.reset();
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
  stgae_frame_features(s.x, s.t > 0 ? &s.xprev : nullptr, m.wrist, m.inv_shape, m.inv_vel, s.f);
  s.xprev = s.x;
  const Mat<S>* cur = &s.f;
  for (size_t i = 0; i < m.enc.size(); ++i) {
    block_step(m.enc[i], s.enc[i], *cur, s.t);
    cur = &s.enc[i].out;
  }
  if (m.gates) {
    gate_step(m.enc_gate, s.enc_gate, *cur, s.t);
    cur = &s.enc_gate.out;
  }
  const Mat<S>* h = cur;
  for (size_t i = 0; i < m.den.size(); ++i) {
    block_step(m.den[i], s.den[i], *cur, s.t);
    cur = &s.den[i].out;
  }
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 3; ++c) s.den_out[static_cast<size_t>(3 * j + c)] = s.x(j, c) + m.shape * (*cur)(j, c);
  if (m.DT > 0) {
    const Mat<S>* p = h;
    if (m.gates) {
      gate_step(m.pre_gate, s.pre_gate, *h, s.t);
      p = &s.pre_gate.out;
    }
    s.lifted.noalias() = *p * m.lift;
    s.lifted.rowwise() += m.lift_b;
    for (int i = 0; i < m.DT; ++i) s.z.middleRows(Eigen::Index(i) * n, n) = s.lifted.middleCols(Eigen::Index(i) * m.C, m.C);
    add_pe<S>(m, s.z);
    const Mat<S>& q = predict_decoder<S>(m, s.z, s.pre_out, s.pre_ws);
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
