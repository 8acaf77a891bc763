#pragma once
// Preparing a layer's weights from the file's tensors (internal to core/src): BN folded
// into the preceding conv in double, then cast to the engine's scalar. Shared by the
// Multi-STGAE layers (stgae_layers.cpp) and the DGN layers (dgn_layers.cpp).
#include "handsteady/stgae_layers.hpp"

#include <cmath>
#include <string>

namespace hs::stgae {

constexpr double kBnEps = 1e-5;

struct BnFold {
  Eigen::RowVectorXd scale, shift;
};
inline BnFold bn_fold(const StgaeWeights& w, const std::string& p) {
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
RVec<S> row(const Tensor& t) {
  return Eigen::Map<const Eigen::RowVectorXf>(t.data.data(), static_cast<Eigen::Index>(t.data.size())).cast<S>();
}

// Temporal conv weight [cout, cin, kt] (+ bias) followed by BN -> (kt*cin x cout, 1 x
// cout): row j*cin + i holds input channel i at tap j.
template <class S>
void fold_temporal_conv(const StgaeWeights& w, const std::string& conv, const std::string& bn, Mat<S>& wt,
                        RVec<S>& bias) {
  const Tensor& W = w.at(conv + "weight");
  const Tensor& B = w.at(conv + "bias");
  const int cout = W.shape[0], cin = W.shape[1], kt = W.shape[2];
  const BnFold f = bn_fold(w, bn);
  wt.resize(kt * cin, cout);
  bias.resize(cout);
  for (int o = 0; o < cout; ++o) {
    for (int i = 0; i < cin; ++i)
      for (int j = 0; j < kt; ++j)
        wt(j * cin + i, o) =
            static_cast<S>(static_cast<double>(W.data[static_cast<size_t>((o * cin + i) * kt + j)]) * f.scale(o));
    bias(o) = static_cast<S>(static_cast<double>(B.data[static_cast<size_t>(o)]) * f.scale(o) + f.shift(o));
  }
}

}  // namespace hs::stgae
