#pragma once
// The Multi-STGAE engine's layers, one class per node kind of the topology
// (stgae_topology.hpp): STGCB block, gate, prediction lift. Each holds immutable prepared
// weights (BN folded; shared by any number of streams) and declares a State, one per
// stream, so that
//   - the constructor loads its node's tensors and checks their names and shapes
//     (check_node_tensors, stgae_topology.hpp),
//   - node() gives its tensors and macs() its cost,
//   - forward() computes the layer over a window (activations (L*N) x C, row t*N + v),
//   - step() computes the newest frame of a causal stream (N x C) from the State;
//     noexcept and allocation-free once the State is made,
//   - State::reset() forgets the stream's history.
// The function of each layer: stgae_model.hpp, steps 2 (block), 3 (gate), 4 (lift).
#include "handsteady/stgae_model.hpp"
#include "handsteady/stgae_topology.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>

namespace hs::stgae {

inline constexpr int kSubsets = 3;  // K

template <class S>
using Mat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
template <class S>
using RVec = Eigen::Matrix<S, 1, Eigen::Dynamic>;
template <class S>
using CVec = Eigen::Matrix<S, Eigen::Dynamic, 1>;

// The time mean over W(t) of a per-frame item (one column per frame) in a stream: the
// last T items in a ring and their running sum in double (add the new column, subtract
// the one leaving), so the cost does not grow with T and float rounding does not drift.
template <class S>
struct MeanRing {
  Mat<S> items;  // m x T
  Eigen::Matrix<double, Eigen::Dynamic, 1> sum;
  CVec<S> mean;
  void init(Eigen::Index m, int T);
  void reset() noexcept;
  S* slot(long t) noexcept;       // where frame t's item goes; then push_done(t)
  void push_done(long t) noexcept;
};

template <class S>
class BlockLayer {
 public:
  BlockLayer(const StgaeConfig& config, const StgaeNode& node, const StgaeWeights& weights);
  const StgaeNode& node() const noexcept { return node_; }
  std::int64_t macs(const StgaeConfig& config, std::int64_t frames) const { return node_.macs(config, frames); }

  // Attention workspace for one frame's matrices: mt = [M_0^T | ... | M_{K-1}^T] (N x K*N).
  struct Attention {
    Mat<S> e;
    CVec<S> u1, u2;
    RVec<S> colmax, colsum;
    Mat<S> mt;
  };
  struct State {
    Attention att;
    MeanRing<S> ring;
    Mat<S> xw, g, hist, out;  // xw: x times the fused weights; hist: N x (2*kt*cout), each frame written twice
    void reset() noexcept;
  };
  struct Workspace {  // window-mode scratch, reused across calls
    Mat<S> xw, g, items;
    CVec<S> mean;
    Attention att;
  };
  State make_state() const;
  // x: (L*N) x cin -> y: (L'*N) x cout (L' = L - kt + 1 for valid padding, else L).
  void forward(int L, const Mat<S>& x, Mat<S>& y, Workspace& ws) const;
  // Frame t (since reset) of a causal stream; the output is st.out (N x cout).
  void step(State& st, const Mat<S>& x, long t) const noexcept;

 private:
  Eigen::Index items() const { return gat_ ? Eigen::Index(n_) * node_.c_in : Eigen::Index(kSubsets) * n_ * n_; }
  void size_attention(Attention& a) const;
  template <class DX, class DW>
  void attention_items(const Eigen::MatrixBase<DX>& x, const Eigen::MatrixBase<DW>& xw, S* out) const noexcept;
  void attention_matrices(const S* mean, Attention& a) const noexcept;
  template <class DW>
  void gcn(Eigen::MatrixBase<DW>& xw) const noexcept;
  template <class DR>
  void finish(const Eigen::MatrixBase<DR>& xw, Mat<S>& y) const noexcept;

  StgaeNode node_;
  int n_ = 0, d_ = 1, T_ = 1;
  bool att_ = false, gat_ = false;  // data-dependent C; its gat variant
  // Every product of the block's input in one: x wx_ = [h | residual | q | k] (N x cols).
  // h's column c*K + k is subset k's channel c, so that one frame's h read as (K*N) x cout
  // is [h_0; h_1; ...] and the aggregation is one product.
  Mat<S> wx_;                        // cin x (K*cout + cout [+ 2*K*d for dot attention])
  Eigen::Index off_r_ = 0, off_q_ = 0, off_k_ = 0;
  RVec<S> bg_;                       // 1 x K*cout, the gcn bias (BN folded), interleaved as h
  Mat<S> abt_;                       // [(A_0 + B_0)^T | ...], N x K*N
  Mat<S> wemb_;                      // cin x K*d (gat)
  Mat<S> a_;                         // 2d x K (gat), column k = a_k
  Mat<S> wt_;                        // kt*cout x cout, row j*cout + i = input channel i at tap j
  RVec<S> bt_;
  RVec<S> br_;                       // the residual's bias (BN folded)
};

template <class S>
class GateLayer {
 public:
  GateLayer(const StgaeConfig& config, const StgaeNode& node, const StgaeWeights& weights);
  const StgaeNode& node() const noexcept { return node_; }
  std::int64_t macs(const StgaeConfig& config, std::int64_t frames) const { return node_.macs(config, frames); }

  struct Scratch {
    Mat<S> zt, gt;
    RVec<S> pj, zj, gj;
  };
  struct State {
    MeanRing<S> ring;
    Scratch ws;
    Mat<S> out;
    void reset() noexcept;
  };
  struct Workspace {
    Mat<S> items;
    CVec<S> mean;
    Scratch ws;
  };
  State make_state() const;
  void forward(int L, const Mat<S>& x, Mat<S>& y, Workspace& ws) const;  // (L*N) x C, both
  void step(State& st, const Mat<S>& x, long t) const noexcept;          // output st.out

 private:
  void size_scratch(Scratch& s) const;
  template <class DX, class DY>
  void frame(const S* pt, const Eigen::MatrixBase<DX>& x, Eigen::MatrixBase<DY>& y, Scratch& ws) const noexcept;

  StgaeNode node_;
  int n_ = 0, c_ = 0, hc_ = 0, T_ = 1;
  Mat<S> ws_;  // c x hc (shared conv, BN folded)
  RVec<S> bs_;
  Mat<S> wt_, wj_;  // hc x c
  RVec<S> bt_, bj_;
  RVec<S> scale_, shift_;  // final BN
};

// pre.lift: the newest latent frame (N x C) -> DT latent frames Z ((DT*N) x C, frame-major).
template <class S>
class LiftLayer {
 public:
  LiftLayer(const StgaeConfig& config, const StgaeNode& node, const StgaeWeights& weights);
  const StgaeNode& node() const noexcept { return node_; }
  std::int64_t macs(const StgaeConfig& config, std::int64_t frames) const { return node_.macs(config, frames); }

  struct State {
    Mat<S> lifted;  // N x DT*C
    Mat<S> out;     // (DT*N) x C
    void reset() noexcept {}
  };
  State make_state() const;
  // From the last frame of x ((L*N) x C).
  void forward(int L, const Mat<S>& x, Mat<S>& z) const;
  void step(State& st, const Mat<S>& x, long t) const noexcept;  // output st.out

 private:
  StgaeNode node_;
  int n_ = 0, c_ = 0, dt_ = 0;
  Mat<S> w_;  // C x DT*C
  RVec<S> b_;
};

extern template struct MeanRing<float>;
extern template struct MeanRing<double>;
extern template class BlockLayer<float>;
extern template class BlockLayer<double>;
extern template class GateLayer<float>;
extern template class GateLayer<double>;
extern template class LiftLayer<float>;
extern template class LiftLayer<double>;

}  // namespace hs::stgae
