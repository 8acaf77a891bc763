#pragma once
// The directed-graph refinement network (DGN, third seed paper; docs/DGN.md): its layers,
// one class per DGN node kind of the topology (stgae_topology.hpp), with the same contract
// as the Multi-STGAE layers (stgae_layers.hpp): immutable prepared weights shared by any
// number of streams, a per-stream State, forward() over a window, step() for the newest
// frame of a causal stream (noexcept, allocation-free), State::reset().
//
// ============================== FORWARD PASS (exact) ==============================
// N joints, E = N - 1 bones: bone e = skeleton.bones[e] = (parent p, child j), directed
// from its source p to its target j. Incidence (N x E): S0[v][e] = 1 if v is the source
// of e, T0[v][e] = 1 if v is its target; d_v = sum_e S0[v][e] + T0[v][e]; the file stores
// each block's learnable S, T, initialised to D^-1 S0, D^-1 T0.
// Activations: joints [L][N][C], bones [L][E][C]. BN, conv layouts and LeakyReLU-free
// ReLU as in stgae_model.hpp. root = the skeleton's root joint.
// 1. Features: joints f_v = the 6 Multi-STGAE features (stgae_model.hpp step 1: hole
//    filling, wrist-relative position / shape_scale_m, displacement / velocity_scale_m);
//    bones f_e[e] = f_v[j] - f_v[p] (bone vector and its change, same units).
// 2. DGN block P (C_in -> C_out), per frame:
//    a_v = S f_e, b_v = T f_e                               (N x C_in)
//    v'  = act_v(W_{P.v} [f_v, a_v, b_v] + b)              (channels concatenated in this order)
//    a_e = S^T v', b_e = T^T v'                             (E x C_out)
//    e'  = act_e(W_{P.e} [f_e, a_e, b_e] + b)
//    act = ReLU(BN_{P.v_bn|P.e_bn}(.)), except the last block of each decoder: identity
//    (and no BN tensors).
// 3. Temporal layer P (C -> C), on joints and bones separately (P.v., P.e.), per row:
//    tcn:  y[t] = x[t] + ReLU(BN_{P.s.bn}(sum_{j<k} W_{P.s.conv}[:, :, j] x[t + j - o] + b)),
//          x = 0 outside [0, L), o = k-1 (causal) or (k-1)/2 (centred).
//    lstm: causal: one forward LSTM (hidden H = C): y[t] = x[t] + h[t];
//          centred: forward and backward LSTM (H = C/2 each): y[t] = x[t] + [h_fwd[t], h_bwd[t]].
//          LSTM (PyTorch gate order i, f, g, o): z = W_ih x[t] + W_hh h[t-1] + bias (4H),
//          c[t] = sigma(z_f) c[t-1] + sigma(z_i) tanh(z_g), h[t] = sigma(z_o) tanh(c[t]),
//          h = c = 0 before the first frame (the backward LSTM runs from the last frame).
// 4. Network: encoder blocks on (f_v, f_e); temporal layers; H = their output.
//    Denoise: den blocks on H -> (D_v [L][N][3], D_e [L][E][3]) offsets; combined
//      D[j] = (D_v[j] + D_v[root] + sum_{bones e on the path root -> j} D_e[e]) / 2,
//      Xhat = x + shape_scale_m * D (the mean of the joint stream and the bone stream
//      chained from the joint stream's root).
//    Predict: from the newest frame of H: z_s = W_{pre.lift.s} H_s[L-1] + b (DT*C per row,
//      index i*C + c = future frame i), + the positional encoding PE[i][c] of
//      stgae_model.hpp; pre blocks on each of the DT frames -> (Q_v, Q_e), combined as D;
//      Yhat[i] = Xhat[L-1] + shape_scale_m * Q[i].
// ==================================================================================
#include "handsteady/stgae_layers.hpp"

namespace hs::dgn {

using stgae::CVec;
using stgae::Mat;
using stgae::RVec;

// The hand's directed graph for a skeleton: initial normalised incidence and bones.
struct DgnGraph {
  int n = 0, e = 0, root = 0;
  std::vector<int> source, target;    // per bone
  std::vector<int> bone_of;           // per joint: the bone ending there (-1 for the root)
  std::vector<int> order;             // joints, parents before children
  Eigen::MatrixXd S, T;               // D^-1 S0, D^-1 T0 (N x E)
};
DgnGraph dgn_graph(const StgaeConfig& config);

// Bone features from joint features (rows: frame-major, L*N -> L*E).
template <class S>
void dgn_bone_features(const DgnGraph& g, int L, const Mat<S>& fv, Mat<S>& fe);
// The combined offset D of step 4 from (D_v, D_e) for L frames ((L*N) x 3, (L*E) x 3).
template <class S>
void dgn_combine(const DgnGraph& g, int L, const Mat<S>& dv, const Mat<S>& de, Mat<S>& d);

template <class S>
class DgnBlockLayer {
 public:
  DgnBlockLayer(const StgaeConfig& config, const StgaeNode& node, const StgaeWeights& weights);
  const StgaeNode& node() const noexcept { return node_; }
  struct Workspace {
    Mat<S> av, bv, ae, be;
  };
  struct State {
    Workspace ws;
    Mat<S> v, e;  // outputs of the newest frame (N x cout, E x cout)
    void reset() noexcept {}
  };
  State make_state() const;
  // (L*N) x cin, (L*E) x cin -> (L*N) x cout, (L*E) x cout.
  void forward(int L, const Mat<S>& xv, const Mat<S>& xe, Mat<S>& yv, Mat<S>& ye, Workspace& ws) const;
  void step(State& st, const Mat<S>& xv, const Mat<S>& xe) const noexcept;

 private:
  template <class DV, class DE, class OV, class OE>
  void frame(const Eigen::MatrixBase<DV>& fv, const Eigen::MatrixBase<DE>& fe, Eigen::MatrixBase<OV>& v,
             Eigen::MatrixBase<OE>& e, Workspace& ws) const noexcept;

  StgaeNode node_;
  int n_ = 0, e_ = 0;
  Mat<S> s_, t_;          // N x E
  Mat<S> wv_;             // 3cin x cout (BN folded unless linear)
  RVec<S> bv_;
  Mat<S> we_;             // (cin + 2cout) x cout
  RVec<S> be_;
};

// One temporal layer on one stream (rows = N joints or E bones).
template <class S>
class DgnTemporalLayer {
 public:
  // stream: "v." or "e."
  DgnTemporalLayer(const StgaeConfig& config, const StgaeNode& node, const StgaeWeights& weights, const char* stream,
                   int rows);
  const StgaeNode& node() const noexcept { return node_; }
  struct State {
    Mat<S> hist;          // tcn: rows x (k*C) ring of inputs
    Mat<S> h, c, z;       // lstm (forward): rows x H, rows x H, rows x 4H
    Mat<S> out;           // rows x C
    void reset() noexcept;
  };
  State make_state() const;
  void forward(int L, const Mat<S>& x, Mat<S>& y) const;  // (L*rows) x C
  void step(State& st, const Mat<S>& x, long t) const noexcept;

 private:
  struct Lstm {
    Mat<S> wih, whh;  // C x 4H, H x 4H (transposed)
    RVec<S> b;
  };
  void lstm_run(const Lstm& p, int L, const Mat<S>& x, Mat<S>& y, int col0, bool backward) const;
  // One LSTM frame for every row: gates z (rows x 4H: i, f, g, o) from x and h, then h, c in place.
  static void lstm_frame(const Lstm& p, const Eigen::Ref<const Mat<S>>& x, Mat<S>& z, Mat<S>& h, Mat<S>& c) noexcept;

  StgaeNode node_;
  int rows_ = 0, c_ = 0, k_ = 1, h_ = 0;
  bool tcn_ = true, causal_ = true;
  Mat<S> wt_;    // k*C x C (tap j rows j*C..), BN folded
  RVec<S> bt_;
  Lstm fwd_, bwd_;
};

template <class S>
class DgnLiftLayer {
 public:
  DgnLiftLayer(const StgaeConfig& config, const StgaeNode& node, const StgaeWeights& weights);
  const StgaeNode& node() const noexcept { return node_; }
  // From the last frame of (L*N) x C and (L*E) x C to (DT*N) x C, (DT*E) x C.
  void forward(int L, const Mat<S>& hv, const Mat<S>& he, Mat<S>& zv, Mat<S>& ze) const;
  // For preallocated outputs (streaming): zv, ze must already have their sizes.
  struct State {
    Mat<S> lv, le, zv, ze;
    void reset() noexcept {}
  };
  State make_state() const;
  void step(State& st, const Mat<S>& hv, const Mat<S>& he) const noexcept;

 private:
  void lift(const Mat<S>& w, const RVec<S>& b, const Eigen::Ref<const Mat<S>>& h, Mat<S>& l, Mat<S>& z) const noexcept;
  StgaeNode node_;
  int n_ = 0, e_ = 0, c_ = 0, dt_ = 0;
  Mat<S> wv_, we_;  // C x DT*C
  RVec<S> bv_, be_;
};

extern template class DgnBlockLayer<float>;
extern template class DgnBlockLayer<double>;
extern template class DgnTemporalLayer<float>;
extern template class DgnTemporalLayer<double>;
extern template class DgnLiftLayer<float>;
extern template class DgnLiftLayer<double>;

}  // namespace hs::dgn
