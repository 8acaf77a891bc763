// The engine's layers (stgae_layers.hpp). Parameters are prepared in double (BN folded
// into the preceding conv) and then cast to the engine's scalar.
#include "handsteady/stgae_layers.hpp"

#include "handsteady/skeleton.hpp"
#include "layer_weights.hpp"

#include <algorithm>
#include <cmath>

namespace hs::stgae {

namespace {

constexpr int K = kSubsets;
// Window-mode time mean of frame t's window from per-frame items (one column per frame).
// Returns false when the mean of frame t is the one already computed (whole-window means).
template <class S>
bool window_mean(StgaeTimeMean mean, int T, int L, int t, const Mat<S>& items, CVec<S>& out) {
  if (mean == StgaeTimeMean::Whole && t > 0) return false;
  const int s0 = mean == StgaeTimeMean::Causal ? std::max(0, t - T + 1) : 0;
  const int cnt = mean == StgaeTimeMean::Causal ? t - s0 + 1 : L;
  out.noalias() = items.middleCols(s0, cnt).rowwise().sum();
  out /= static_cast<S>(cnt);
  return true;
}

}  // namespace

// ---------------- MeanRing ----------------

template <class S>
void MeanRing<S>::init(Eigen::Index m, int T) {
  items = Mat<S>::Zero(m, T);
  sum = Eigen::Matrix<double, Eigen::Dynamic, 1>::Zero(m);
  mean = CVec<S>::Zero(m);
}
template <class S>
void MeanRing<S>::reset() noexcept {
  items.setZero();
  sum.setZero();
}
template <class S>
S* MeanRing<S>::slot(long t) noexcept {
  const auto s = static_cast<Eigen::Index>(t % items.cols());
  sum -= items.col(s).template cast<double>();
  return items.col(s).data();
}
template <class S>
void MeanRing<S>::push_done(long t) noexcept {
  const auto s = static_cast<Eigen::Index>(t % items.cols());
  sum += items.col(s).template cast<double>();
  const long cnt = std::min<long>(t + 1, items.cols());
  mean = (sum / static_cast<double>(cnt)).template cast<S>();
}

// ---------------- block ----------------

template <class S>
BlockLayer<S>::BlockLayer(const StgaeConfig& c, const StgaeNode& node, const StgaeWeights& w) : node_(node) {
  check_node_tensors(node, w);
  const std::string& p = node.prefix;
  const int N = c.joint_count(), cin = node.c_in, cout = node.c_out;
  n_ = N;
  T_ = c.window;
  d_ = std::max(1, cin / 2);
  att_ = c.attention == StgaeAttention::ABC;
  gat_ = att_ && c.c_variant == StgaeCVariant::Gat;
  const bool dot = att_ && !gat_;
  Mat<S> wg, wr;
  RVec<S> bg;
  fold_conv(w, p + "gcn.conv.", p + "gcn.bn.", wg, bg);
  fold_conv(w, p + "res.conv.", p + "res.bn.", wr, br_);
  off_r_ = Eigen::Index(K) * cout;
  off_q_ = off_r_ + cout;
  off_k_ = off_q_ + Eigen::Index(K) * d_;
  wx_.resize(cin, dot ? off_k_ + Eigen::Index(K) * d_ : off_q_);
  bg_.resize(off_r_);
  for (int k = 0; k < K; ++k)
    for (int ch = 0; ch < cout; ++ch) {  // the file's column k*cout + ch -> ch*K + k
      wx_.col(Eigen::Index(ch) * K + k) = wg.col(Eigen::Index(k) * cout + ch);
      bg_(Eigen::Index(ch) * K + k) = bg(Eigen::Index(k) * cout + ch);
    }
  wx_.middleCols(off_r_, cout) = wr;
  if (dot) {  // 1/sqrt(d) of the score folded into the query
    wx_.middleCols(off_q_, Eigen::Index(K) * d_) =
        (transposed<double>(w.at(p + "att.q.weight")) / std::sqrt(static_cast<double>(d_))).cast<S>();
    wx_.middleCols(off_k_, Eigen::Index(K) * d_) = transposed<S>(w.at(p + "att.k.weight"));
  }
  const GraphPartition gp = hand_partition(skeleton_by_name(c.skeleton));
  abt_.resize(N, Eigen::Index(K) * N);
  for (int k = 0; k < K; ++k) {
    Eigen::MatrixXd m = gp.A[static_cast<size_t>(k)];
    if (c.attention != StgaeAttention::A) {
      const auto& B = w.at(p + "B").data;
      for (int v = 0; v < N; ++v)
        for (int u = 0; u < N; ++u) m(v, u) += static_cast<double>(B[static_cast<size_t>((k * N + v) * N + u)]);
    }
    abt_.middleCols(Eigen::Index(k) * N, N) = m.transpose().cast<S>();
  }
  if (gat_) {
    wemb_ = transposed<S>(w.at(p + "att.emb.weight"));
    a_ = transposed<S>(w.at(p + "att.a"));  // [K, 2d] -> 2d x K
  }
  fold_temporal_conv(w, p + "tcn.conv.", p + "tcn.bn.", wt_, bt_);
}

template <class S>
void BlockLayer<S>::size_attention(Attention& a) const {
  if (gat_) {
    a.e.resize(n_, K * d_);
    a.u1.resize(n_);
    a.u2.resize(n_);
  }
  a.colmax.resize(Eigen::Index(K) * n_);
  a.colsum.resize(Eigen::Index(K) * n_);
  a.mt.resize(n_, Eigen::Index(K) * n_);
}

// The per-frame item whose mean over W(t) the attention needs, written to out (items()),
// from one frame's input x and its product xw.
template <class S>
template <class DX, class DW>
void BlockLayer<S>::attention_items(const Eigen::MatrixBase<DX>& x, const Eigen::MatrixBase<DW>& xw,
                                    S* out) const noexcept {
  const int n = n_;
  if (gat_) {
    Eigen::Map<Mat<S>>(out, n, node_.c_in) = x;
    return;
  }
  for (int k = 0; k < K; ++k)  // transposed score: (k_w . q_v) / sqrt(d) at (w, v)
    Eigen::Map<Mat<S>>(out + Eigen::Index(k) * n * n, n, n).noalias() =
        xw.middleCols(off_k_ + k * d_, d_) * xw.middleCols(off_q_ + k * d_, d_).transpose();
}

// a.mt = [(A_k + B_k + C_k)^T]_k from the window mean of the items (nullptr without C).
template <class S>
void BlockLayer<S>::attention_matrices(const S* mean, Attention& a) const noexcept {
  const int n = n_;
  if (!att_) {
    a.mt = abt_;
    return;
  }
  if (gat_) {
    a.e.noalias() = Eigen::Map<const Mat<S>>(mean, n, node_.c_in) * wemb_;
    for (int k = 0; k < K; ++k) {
      a.u1.noalias() = a.e.middleCols(k * d_, d_) * a_.col(k).head(d_);  // a[0:d] . e_v
      a.u2.noalias() = a.e.middleCols(k * d_, d_) * a_.col(k).tail(d_);  // a[d:2d] . e_w
      for (int v = 0; v < n; ++v)
        for (int u = 0; u < n; ++u) {
          const S s = a.u2(u) + a.u1(v);
          a.mt(u, Eigen::Index(k) * n + v) = s > S(0) ? s : S(0.2) * s;
        }
    }
  } else {
    a.mt = Eigen::Map<const Mat<S>>(mean, n, Eigen::Index(K) * n);
  }
  // Softmax of each column (column v of a transposed score = row v of the score), over
  // the whole matrix at once so that exp() runs on full vectors.
  a.colmax = a.mt.colwise().maxCoeff();
  a.mt.array().rowwise() -= a.colmax.array();
  a.mt.array() = a.mt.array().exp();
  a.colsum = a.mt.colwise().sum();
  a.mt.array().rowwise() /= a.colsum.array();
  a.mt += abt_;
}

template <class S>
typename BlockLayer<S>::State BlockLayer<S>::make_state() const {
  State st;
  size_attention(st.att);
  if (att_) st.ring.init(items(), T_);
  st.xw.resize(n_, wx_.cols());
  st.g.resize(n_, node_.c_out);
  st.hist = Mat<S>::Zero(n_, 2 * node_.kernel * node_.c_out);
  st.out.resize(n_, node_.c_out);
  return st;
}

template <class S>
void BlockLayer<S>::State::reset() noexcept {
  if (ring.items.size()) ring.reset();
  hist.setZero();  // zeros before the sequence start = causal padding
}

// The per-frame steps shared by forward() and step(); only the time means (window sums /
// ring) and the temporal conv (taps over the window / history ring) differ between them.
// a. h = ReLU(x Wg + bg) (BN folded) in the first K*cout columns of xw = x wx_.
template <class S>
template <class DW>
void BlockLayer<S>::gcn(Eigen::MatrixBase<DW>& xw) const noexcept {
  auto h = xw.leftCols(off_r_);
  h.rowwise() += bg_;
  h = h.cwiseMax(S(0));
}

// e, f. y (the temporal conv + bias) -> ReLU unless linear, + the residual (xw's columns
// after h; its bias here).
template <class S>
template <class DR>
void BlockLayer<S>::finish(const Eigen::MatrixBase<DR>& xw, Mat<S>& y) const noexcept {
  if (!node_.linear) y = y.cwiseMax(S(0));
  y += xw.middleCols(off_r_, node_.c_out);
  y.rowwise() += br_;
}

template <class S>
void BlockLayer<S>::forward(int L, const Mat<S>& x, Mat<S>& y, Workspace& ws) const {
  const int n = n_, cout = node_.c_out, kt = node_.kernel;
  const Eigen::Index LN = Eigen::Index(L) * n;
  size_attention(ws.att);
  // a. every product of x for every frame at once; gcn BN + ReLU.
  ws.xw.resize(LN, wx_.cols());
  ws.xw.noalias() = x * wx_;
  gcn(ws.xw);
  // b, c. graph aggregation with the attention of each frame's window: g_t = sum_k M_k^T h_k,
  // subset k's h of frame t being xw's columns k, K+k, ... at the frame's rows.
  ws.g.resize(LN, cout);
  if (att_) {
    ws.items.resize(items(), L);
    ws.mean.resize(items());
    for (int s = 0; s < L; ++s)
      attention_items(x.middleRows(Eigen::Index(s) * n, n), ws.xw.middleRows(Eigen::Index(s) * n, n),
                      ws.items.col(s).data());
  }
  using Strided = Eigen::Map<const Mat<S>, 0, Eigen::OuterStride<>>;
  for (int t = 0; t < L; ++t) {
    if (att_) {
      if (window_mean(node_.mean, T_, L, t, ws.items, ws.mean)) attention_matrices(ws.mean.data(), ws.att);
    } else if (t == 0) {
      attention_matrices(nullptr, ws.att);
    }
    auto gt = ws.g.middleRows(Eigen::Index(t) * n, n);
    for (int k = 0; k < K; ++k) {
      const Strided hk(ws.xw.data() + Eigen::Index(k) * LN + Eigen::Index(t) * n, n, cout, Eigen::OuterStride<>(K * LN));
      if (k == 0) gt.noalias() = ws.att.mt.leftCols(n) * hk;
      else gt.noalias() += ws.att.mt.middleCols(Eigen::Index(k) * n, n) * hk;
    }
  }
  // d. temporal conv, tap by tap over all frames.
  const StgaeTemporalPad pad = node_.pad;
  const int off = pad == StgaeTemporalPad::Causal ? kt - 1 : pad == StgaeTemporalPad::Centred ? (kt - 1) / 2 : 0;
  const int lout = pad == StgaeTemporalPad::Valid ? L - kt + 1 : L;
  y.resize(Eigen::Index(lout) * n, cout);
  y.rowwise() = bt_;
  for (int j = 0; j < kt; ++j) {
    const int t0 = std::max(0, off - j), t1 = std::min(lout, L + off - j);  // output frames [t0, t1)
    if (t1 <= t0) continue;
    y.middleRows(Eigen::Index(t0) * n, Eigen::Index(t1 - t0) * n).noalias() +=
        ws.g.middleRows(Eigen::Index(t0 + j - off) * n, Eigen::Index(t1 - t0) * n) * wt_.middleRows(j * cout, cout);
  }
  // e. (BN folded) ReLU; f. residual (valid: from the newest frame under the kernel).
  const int r0 = pad == StgaeTemporalPad::Valid ? kt - 1 : 0;
  finish(ws.xw.middleRows(Eigen::Index(r0) * n, Eigen::Index(lout) * n), y);
}

template <class S>
void BlockLayer<S>::step(State& st, const Mat<S>& x, long t) const noexcept {
  const int n = n_, cout = node_.c_out, kt = node_.kernel;
  st.xw.noalias() = x * wx_;
  if (att_) {
    attention_items(x, st.xw, st.ring.slot(t));
    st.ring.push_done(t);
    attention_matrices(st.ring.mean.data(), st.att);
  } else if (t == 0) {
    attention_matrices(nullptr, st.att);
  }
  gcn(st.xw);
  // One frame's h as (K*N) x cout is [h_0; h_1; ...]: the aggregation in one product.
  st.g.noalias() = st.att.mt * Eigen::Map<const Mat<S>>(st.xw.data(), Eigen::Index(K) * n, cout);
  // The last kt aggregated frames, each stored twice so that the newest kt are contiguous.
  const auto p = static_cast<Eigen::Index>(t % kt);
  st.hist.middleCols(p * cout, cout) = st.g;
  st.hist.middleCols((p + kt) * cout, cout) = st.g;
  st.out.noalias() = st.hist.middleCols((p + 1) * cout, Eigen::Index(kt) * cout) * wt_;
  st.out.rowwise() += bt_;
  finish(st.xw, st.out);
}

// ---------------- gate ----------------

template <class S>
GateLayer<S>::GateLayer(const StgaeConfig& c, const StgaeNode& node, const StgaeWeights& w) : node_(node) {
  check_node_tensors(node, w);
  const std::string& g = node.prefix;
  n_ = c.joint_count();
  T_ = c.window;
  c_ = node.c_in;
  hc_ = std::max(1, c_ / 2);
  fold_conv(w, g + "shared.conv.", g + "shared.bn.", ws_, bs_);
  wt_ = transposed<S>(w.at(g + "time.conv.weight"));
  bt_ = row<S>(w.at(g + "time.conv.bias"));
  wj_ = transposed<S>(w.at(g + "joint.conv.weight"));
  bj_ = row<S>(w.at(g + "joint.conv.bias"));
  const BnFold f = bn_fold(w, g + "bn.");
  scale_ = f.scale.cast<S>();
  shift_ = f.shift.cast<S>();
}

template <class S>
void GateLayer<S>::size_scratch(Scratch& s) const {
  s.zt.resize(n_, hc_);
  s.gt.resize(n_, c_);
  s.pj.resize(c_);
  s.zj.resize(hc_);
  s.gj.resize(c_);
}

// y = ReLU(BN(x + x * gt * gj)) for one frame, pt = time-pooled input (N x C).
template <class S>
template <class DX, class DY>
void GateLayer<S>::frame(const S* pt, const Eigen::MatrixBase<DX>& x, Eigen::MatrixBase<DY>& y,
                         Scratch& ws) const noexcept {
  const Eigen::Index n = x.rows();
  ws.zt.noalias() = Eigen::Map<const Mat<S>>(pt, n, c_) * ws_;
  ws.zt.rowwise() += bs_;
  ws.zt = ws.zt.cwiseMax(S(0));
  ws.gt.noalias() = ws.zt * wt_;
  ws.gt.rowwise() += bt_;
  ws.gt = (S(1) + (-ws.gt.array()).exp()).inverse().matrix();
  ws.pj = x.colwise().sum();
  ws.pj /= static_cast<S>(n);
  ws.zj.noalias() = ws.pj * ws_;
  ws.zj += bs_;
  ws.zj = ws.zj.cwiseMax(S(0));
  ws.gj.noalias() = ws.zj * wj_;
  ws.gj += bj_;
  ws.gj = (S(1) + (-ws.gj.array()).exp()).inverse().matrix();
  for (Eigen::Index c = 0; c < c_; ++c)
    for (Eigen::Index v = 0; v < n; ++v) {
      const S z = x(v, c) * (S(1) + ws.gt(v, c) * ws.gj(c)) * scale_(c) + shift_(c);
      y(v, c) = z > S(0) ? z : S(0);
    }
}

template <class S>
typename GateLayer<S>::State GateLayer<S>::make_state() const {
  State st;
  st.ring.init(Eigen::Index(n_) * c_, T_);
  size_scratch(st.ws);
  st.out.resize(n_, c_);
  return st;
}

template <class S>
void GateLayer<S>::State::reset() noexcept {
  if (ring.items.size()) ring.reset();
}

template <class S>
void GateLayer<S>::forward(int L, const Mat<S>& x, Mat<S>& y, Workspace& w) const {
  const int n = n_;
  size_scratch(w.ws);
  y.resize(Eigen::Index(L) * n, c_);
  w.items.resize(Eigen::Index(n) * c_, L);
  w.mean.resize(Eigen::Index(n) * c_);
  for (int s = 0; s < L; ++s) Eigen::Map<Mat<S>>(w.items.col(s).data(), n, c_) = x.middleRows(Eigen::Index(s) * n, n);
  for (int t = 0; t < L; ++t) {
    (void)window_mean(node_.mean, T_, L, t, w.items, w.mean);
    auto yt = y.middleRows(Eigen::Index(t) * n, n);
    frame(w.mean.data(), x.middleRows(Eigen::Index(t) * n, n), yt, w.ws);
  }
}

template <class S>
void GateLayer<S>::step(State& st, const Mat<S>& x, long t) const noexcept {
  Eigen::Map<Mat<S>>(st.ring.slot(t), x.rows(), c_) = x;
  st.ring.push_done(t);
  frame(st.ring.mean.data(), x, st.out, st.ws);
}

// ---------------- lift ----------------

template <class S>
LiftLayer<S>::LiftLayer(const StgaeConfig& c, const StgaeNode& node, const StgaeWeights& w) : node_(node) {
  check_node_tensors(node, w);
  n_ = c.joint_count();
  c_ = node.c_in;
  dt_ = node.c_out / node.c_in;
  w_ = transposed<S>(w.at(node.prefix + "weight"));
  b_ = row<S>(w.at(node.prefix + "bias"));
}

template <class S>
typename LiftLayer<S>::State LiftLayer<S>::make_state() const {
  State st;
  st.lifted.resize(n_, Eigen::Index(dt_) * c_);
  st.out.resize(Eigen::Index(dt_) * n_, c_);
  return st;
}

template <class S>
void LiftLayer<S>::forward(int L, const Mat<S>& x, Mat<S>& z) const {
  State st = make_state();
  step(st, x.middleRows(Eigen::Index(L - 1) * n_, n_), 0);
  z = st.out;
}

template <class S>
void LiftLayer<S>::step(State& st, const Mat<S>& x, long /*t*/) const noexcept {
  st.lifted.noalias() = x * w_;
  st.lifted.rowwise() += b_;
  for (int i = 0; i < dt_; ++i) st.out.middleRows(Eigen::Index(i) * n_, n_) = st.lifted.middleCols(Eigen::Index(i) * c_, c_);
}

template struct MeanRing<float>;
template struct MeanRing<double>;
template class BlockLayer<float>;
template class BlockLayer<double>;
template class GateLayer<float>;
template class GateLayer<double>;
template class LiftLayer<float>;
template class LiftLayer<double>;

}  // namespace hs::stgae
