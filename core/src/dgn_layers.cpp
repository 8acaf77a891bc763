// The DGN layers (dgn_layers.hpp). Parameters are prepared in double (BN folded) and then
// cast to the engine's scalar, as for the Multi-STGAE layers.
#include "handsteady/dgn_layers.hpp"

#include "handsteady/skeleton.hpp"
#include "layer_weights.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hs::dgn {

using stgae::fold_conv;
using stgae::fold_temporal_conv;
using stgae::row;
using stgae::transposed;

namespace {

// A tensor [r, c] as an r x c matrix.
template <class S>
Mat<S> as_matrix(const Tensor& t) {
  return Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
             t.data.data(), t.shape[0], t.shape[1])
      .template cast<S>();
}

template <class S>
S sigmoid(S x) noexcept {
  return S(1) / (S(1) + std::exp(-x));
}

}  // namespace

DgnGraph dgn_graph(const StgaeConfig& c) {
  const Skeleton& sk = skeleton_by_name(c.skeleton);
  DgnGraph g;
  g.n = sk.joint_count();
  g.e = static_cast<int>(sk.bones.size());
  if (g.e != g.n - 1) throw std::invalid_argument("dgn_graph: the skeleton is not a tree (" + c.skeleton + ")");
  g.bone_of.assign(static_cast<size_t>(g.n), -1);
  Eigen::MatrixXd s0 = Eigen::MatrixXd::Zero(g.n, g.e), t0 = Eigen::MatrixXd::Zero(g.n, g.e);
  for (int e = 0; e < g.e; ++e) {
    const auto [p, j] = sk.bones[static_cast<size_t>(e)];
    g.source.push_back(p);
    g.target.push_back(j);
    g.bone_of[static_cast<size_t>(j)] = e;
    s0(p, e) = 1.0;
    t0(j, e) = 1.0;
  }
  for (int j = 0; j < g.n; ++j)
    if (sk.parent[static_cast<size_t>(j)] < 0) g.root = j;
  // Parents before children: breadth first from the root.
  g.order.push_back(g.root);
  for (size_t i = 0; i < g.order.size(); ++i)
    for (int e = 0; e < g.e; ++e)
      if (g.source[static_cast<size_t>(e)] == g.order[i]) g.order.push_back(g.target[static_cast<size_t>(e)]);
  const Eigen::VectorXd deg = (s0 + t0).rowwise().sum();
  g.S = deg.cwiseInverse().asDiagonal() * s0;
  g.T = deg.cwiseInverse().asDiagonal() * t0;
  return g;
}

template <class S>
void dgn_bone_features(const DgnGraph& g, int L, const Mat<S>& fv, Mat<S>& fe) {
  fe.resize(Eigen::Index(L) * g.e, fv.cols());
  for (int t = 0; t < L; ++t)
    for (int e = 0; e < g.e; ++e)
      fe.row(Eigen::Index(t) * g.e + e) = fv.row(Eigen::Index(t) * g.n + g.target[static_cast<size_t>(e)]) -
                                          fv.row(Eigen::Index(t) * g.n + g.source[static_cast<size_t>(e)]);
}

template <class S>
void dgn_combine(const DgnGraph& g, int L, const Mat<S>& dv, const Mat<S>& de, Mat<S>& d) {
  d.resize(Eigen::Index(L) * g.n, 3);
  for (int t = 0; t < L; ++t) {
    const Eigen::Index v0 = Eigen::Index(t) * g.n, e0 = Eigen::Index(t) * g.e;
    // The bone stream chained from the root (0 there), then the mean with the joint stream.
    d.row(v0 + g.root).setZero();
    for (size_t i = 1; i < g.order.size(); ++i) {
      const int j = g.order[i], b = g.bone_of[static_cast<size_t>(j)];
      d.row(v0 + j) = d.row(v0 + g.source[static_cast<size_t>(b)]) + de.row(e0 + b);
    }
    for (int j = 0; j < g.n; ++j) d.row(v0 + j) = (dv.row(v0 + j) + dv.row(v0 + g.root) + d.row(v0 + j)) / S(2);
  }
}

// ---------------- block ----------------

template <class S>
DgnBlockLayer<S>::DgnBlockLayer(const StgaeConfig& c, const StgaeNode& node, const StgaeWeights& w) : node_(node) {
  check_node_tensors(node, w);
  const std::string& p = node.prefix;
  n_ = c.joint_count();
  e_ = n_ - 1;
  s_ = as_matrix<S>(w.at(p + "S"));
  t_ = as_matrix<S>(w.at(p + "T"));
  if (node.linear) {
    wv_ = transposed<S>(w.at(p + "v.weight"));
    bv_ = row<S>(w.at(p + "v.bias"));
    we_ = transposed<S>(w.at(p + "e.weight"));
    be_ = row<S>(w.at(p + "e.bias"));
  } else {
    fold_conv(w, p + "v.", p + "v_bn.", wv_, bv_);
    fold_conv(w, p + "e.", p + "e_bn.", we_, be_);
  }
}

template <class S>
typename DgnBlockLayer<S>::State DgnBlockLayer<S>::make_state() const {
  State st;
  st.ws.av.resize(n_, node_.c_in);
  st.ws.bv.resize(n_, node_.c_in);
  st.ws.ae.resize(e_, node_.c_out);
  st.ws.be.resize(e_, node_.c_out);
  st.v.resize(n_, node_.c_out);
  st.e.resize(e_, node_.c_out);
  return st;
}

template <class S>
template <class DV, class DE, class OV, class OE>
void DgnBlockLayer<S>::frame(const Eigen::MatrixBase<DV>& fv, const Eigen::MatrixBase<DE>& fe, Eigen::MatrixBase<OV>& v,
                             Eigen::MatrixBase<OE>& e, Workspace& ws) const noexcept {
  const int cin = node_.c_in, cout = node_.c_out;
  ws.av.noalias() = s_ * fe;
  ws.bv.noalias() = t_ * fe;
  v.derived().noalias() = fv * wv_.topRows(cin);
  v.derived().noalias() += ws.av * wv_.middleRows(cin, cin);
  v.derived().noalias() += ws.bv * wv_.bottomRows(cin);
  v.derived().rowwise() += bv_;
  if (!node_.linear) v.derived() = v.derived().cwiseMax(S(0));
  ws.ae.noalias() = s_.transpose() * v;
  ws.be.noalias() = t_.transpose() * v;
  e.derived().noalias() = fe * we_.topRows(cin);
  e.derived().noalias() += ws.ae * we_.middleRows(cin, cout);
  e.derived().noalias() += ws.be * we_.bottomRows(cout);
  e.derived().rowwise() += be_;
  if (!node_.linear) e.derived() = e.derived().cwiseMax(S(0));
}

template <class S>
void DgnBlockLayer<S>::forward(int L, const Mat<S>& xv, const Mat<S>& xe, Mat<S>& yv, Mat<S>& ye,
                               Workspace& ws) const {
  const int cin = node_.c_in, cout = node_.c_out;
  ws.av.resize(n_, cin);
  ws.bv.resize(n_, cin);
  ws.ae.resize(e_, cout);
  ws.be.resize(e_, cout);
  yv.resize(Eigen::Index(L) * n_, cout);
  ye.resize(Eigen::Index(L) * e_, cout);
  for (int t = 0; t < L; ++t) {
    auto v = yv.middleRows(Eigen::Index(t) * n_, n_);
    auto e = ye.middleRows(Eigen::Index(t) * e_, e_);
    frame(xv.middleRows(Eigen::Index(t) * n_, n_), xe.middleRows(Eigen::Index(t) * e_, e_), v, e, ws);
  }
}

template <class S>
void DgnBlockLayer<S>::step(State& st, const Mat<S>& xv, const Mat<S>& xe) const noexcept {
  frame(xv, xe, st.v, st.e, st.ws);
}

// ---------------- temporal ----------------

template <class S>
DgnTemporalLayer<S>::DgnTemporalLayer(const StgaeConfig& c, const StgaeNode& node, const StgaeWeights& w,
                                      const char* stream, int rows)
    : node_(node), rows_(rows), c_(node.c_in), k_(node.kernel) {
  check_node_tensors(node, w);
  const std::string q = node.prefix + stream;
  tcn_ = c.temporal == DgnTemporal::Tcn;
  causal_ = node.pad == StgaeTemporalPad::Causal;
  if (tcn_) {
    fold_temporal_conv(w, q + "conv.", q + "bn.", wt_, bt_);
    return;
  }
  h_ = causal_ ? c_ : c_ / 2;
  auto load = [&](const std::string& d, Lstm& l) {
    l.wih = transposed<S>(w.at(q + d + "w_ih"));
    l.whh = transposed<S>(w.at(q + d + "w_hh"));
    l.b = row<S>(w.at(q + d + "bias"));
  };
  load("fwd.", fwd_);
  if (!causal_) load("bwd.", bwd_);
}

template <class S>
void DgnTemporalLayer<S>::State::reset() noexcept {
  hist.setZero();
  h.setZero();
  c.setZero();
}

template <class S>
typename DgnTemporalLayer<S>::State DgnTemporalLayer<S>::make_state() const {
  State st;
  if (tcn_) st.hist = Mat<S>::Zero(rows_, Eigen::Index(k_) * c_);
  else {
    st.h = Mat<S>::Zero(rows_, h_);
    st.c = Mat<S>::Zero(rows_, h_);
    st.z.resize(rows_, 4 * h_);
  }
  st.out.resize(rows_, c_);
  return st;
}

template <class S>
void DgnTemporalLayer<S>::lstm_frame(const Lstm& p, const Eigen::Ref<const Mat<S>>& x, Mat<S>& z, Mat<S>& h,
                                     Mat<S>& c) noexcept {
  const auto H = static_cast<int>(h.cols());
  z.noalias() = x * p.wih;
  z.noalias() += h * p.whh;
  z.rowwise() += p.b;
  for (Eigen::Index r = 0; r < h.rows(); ++r)
    for (int k = 0; k < H; ++k) {
      const S ig = sigmoid(z(r, k)), fg = sigmoid(z(r, H + k)), gg = std::tanh(z(r, 2 * H + k)),
              og = sigmoid(z(r, 3 * H + k));
      c(r, k) = fg * c(r, k) + ig * gg;
      h(r, k) = og * std::tanh(c(r, k));
    }
}

template <class S>
void DgnTemporalLayer<S>::lstm_run(const Lstm& p, int L, const Mat<S>& x, Mat<S>& y, int col0, bool backward) const {
  const auto H = static_cast<int>(p.whh.rows());
  Mat<S> h = Mat<S>::Zero(rows_, H), c = Mat<S>::Zero(rows_, H), z(rows_, 4 * H);
  for (int i = 0; i < L; ++i) {
    const int t = backward ? L - 1 - i : i;
    lstm_frame(p, x.middleRows(Eigen::Index(t) * rows_, rows_), z, h, c);
    y.block(Eigen::Index(t) * rows_, col0, rows_, H) += h;
  }
}

template <class S>
void DgnTemporalLayer<S>::forward(int L, const Mat<S>& x, Mat<S>& y) const {
  y = x;
  if (!tcn_) {
    lstm_run(fwd_, L, x, y, 0, false);
    if (!causal_) lstm_run(bwd_, L, x, y, h_, true);
    return;
  }
  const int off = causal_ ? k_ - 1 : (k_ - 1) / 2;
  Mat<S> u(Eigen::Index(L) * rows_, c_);
  u.rowwise() = bt_;
  for (int j = 0; j < k_; ++j) {
    const int t0 = std::max(0, off - j), t1 = std::min(L, L + off - j);
    if (t1 <= t0) continue;
    u.middleRows(Eigen::Index(t0) * rows_, Eigen::Index(t1 - t0) * rows_).noalias() +=
        x.middleRows(Eigen::Index(t0 + j - off) * rows_, Eigen::Index(t1 - t0) * rows_) * wt_.middleRows(j * c_, c_);
  }
  y += u.cwiseMax(S(0));
}

template <class S>
void DgnTemporalLayer<S>::step(State& st, const Mat<S>& x, long t) const noexcept {
  if (!tcn_) {
    lstm_frame(fwd_, x, st.z, st.h, st.c);
    st.out = x + st.h;
    return;
  }
  // Ring of the last k inputs; tap j reads frame t - k + 1 + j.
  st.hist.middleCols(Eigen::Index(t % k_) * c_, c_) = x;
  st.out.rowwise() = bt_;
  for (int j = 0; j < k_; ++j) {
    const long f = t - k_ + 1 + j;
    if (f < 0) continue;
    st.out.noalias() += st.hist.middleCols(Eigen::Index(f % k_) * c_, c_) * wt_.middleRows(j * c_, c_);
  }
  st.out = x + st.out.cwiseMax(S(0));
}

// ---------------- lift ----------------

template <class S>
DgnLiftLayer<S>::DgnLiftLayer(const StgaeConfig& c, const StgaeNode& node, const StgaeWeights& w) : node_(node) {
  check_node_tensors(node, w);
  n_ = c.joint_count();
  e_ = n_ - 1;
  c_ = node.c_in;
  dt_ = c.horizon;
  wv_ = transposed<S>(w.at(node.prefix + "v.weight"));
  bv_ = row<S>(w.at(node.prefix + "v.bias"));
  we_ = transposed<S>(w.at(node.prefix + "e.weight"));
  be_ = row<S>(w.at(node.prefix + "e.bias"));
}

template <class S>
typename DgnLiftLayer<S>::State DgnLiftLayer<S>::make_state() const {
  State st;
  st.lv.resize(n_, Eigen::Index(dt_) * c_);
  st.le.resize(e_, Eigen::Index(dt_) * c_);
  st.zv.resize(Eigen::Index(dt_) * n_, c_);
  st.ze.resize(Eigen::Index(dt_) * e_, c_);
  return st;
}

template <class S>
void DgnLiftLayer<S>::lift(const Mat<S>& w, const RVec<S>& b, const Eigen::Ref<const Mat<S>>& h, Mat<S>& l,
                           Mat<S>& z) const noexcept {
  const Eigen::Index rows = h.rows();
  l.noalias() = h * w;
  l.rowwise() += b;
  for (int i = 0; i < dt_; ++i) z.middleRows(Eigen::Index(i) * rows, rows) = l.middleCols(Eigen::Index(i) * c_, c_);
}

template <class S>
void DgnLiftLayer<S>::forward(int L, const Mat<S>& hv, const Mat<S>& he, Mat<S>& zv, Mat<S>& ze) const {
  State st = make_state();
  lift(wv_, bv_, hv.middleRows(Eigen::Index(L - 1) * n_, n_), st.lv, st.zv);
  lift(we_, be_, he.middleRows(Eigen::Index(L - 1) * e_, e_), st.le, st.ze);
  zv = std::move(st.zv);
  ze = std::move(st.ze);
}

template <class S>
void DgnLiftLayer<S>::step(State& st, const Mat<S>& hv, const Mat<S>& he) const noexcept {
  lift(wv_, bv_, hv, st.lv, st.zv);
  lift(we_, be_, he, st.le, st.ze);
}

template class DgnBlockLayer<float>;
template class DgnBlockLayer<double>;
template class DgnTemporalLayer<float>;
template class DgnTemporalLayer<double>;
template class DgnLiftLayer<float>;
template class DgnLiftLayer<double>;
template void dgn_bone_features<float>(const DgnGraph&, int, const Mat<float>&, Mat<float>&);
template void dgn_bone_features<double>(const DgnGraph&, int, const Mat<double>&, Mat<double>&);
template void dgn_combine<float>(const DgnGraph&, int, const Mat<float>&, const Mat<float>&, Mat<float>&);
template void dgn_combine<double>(const DgnGraph&, int, const Mat<double>&, const Mat<double>&, Mat<double>&);

}  // namespace hs::dgn
