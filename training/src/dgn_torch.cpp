#include "dgn_torch.hpp"

#include <torch/torch.h>

namespace hs::train {

namespace {

torch::Tensor to_tensor(const Eigen::MatrixXd& m) {
  auto t = torch::empty({m.rows(), m.cols()}, torch::kFloat64);
  auto a = t.accessor<double, 2>();
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) a[r][c] = m(r, c);
  return t.to(torch::kFloat32);
}

}  // namespace

DgnBlockImpl::DgnBlockImpl(const dgn::DgnGraph& g, int cin, int cout, bool linear_) : linear(linear_) {
  S = register_parameter("S", to_tensor(g.S));
  T = register_parameter("T", to_tensor(g.T));
  v_conv = register_module("v", std::make_shared<Conv1x1Impl>(3 * cin, cout, true));
  if (!linear) v_bn = register_module("v_bn", std::make_shared<ChannelNormImpl>(cout));
  e_conv = register_module("e", std::make_shared<Conv1x1Impl>(cin + 2 * cout, cout, true));
  if (!linear) e_bn = register_module("e_bn", std::make_shared<ChannelNormImpl>(cout));
}

std::pair<torch::Tensor, torch::Tensor> DgnBlockImpl::forward(const torch::Tensor& fv, const torch::Tensor& fe) {
  const auto s = S.to(fv.scalar_type()), t = T.to(fv.scalar_type());
  auto v = v_conv->forward(torch::cat({fv, torch::matmul(s, fe), torch::matmul(t, fe)}, -1));
  if (!linear) v = torch::relu(v_bn->forward(v));
  auto e = e_conv->forward(torch::cat({fe, torch::matmul(s.t(), v), torch::matmul(t.t(), v)}, -1));
  if (!linear) e = torch::relu(e_bn->forward(e));
  return {v, e};
}

DgnLstmImpl::DgnLstmImpl(int cin, int hidden) {
  w_ih = register_parameter("w_ih", default_uniform({4 * hidden, cin}, hidden));
  w_hh = register_parameter("w_hh", default_uniform({4 * hidden, hidden}, hidden));
  bias = register_parameter("bias", default_uniform({4 * hidden}, hidden));
}

torch::Tensor DgnLstmImpl::forward(const torch::Tensor& x, bool backward) {
  // The fused kernel over [B*R, L, C] (batch first); the second bias is zero.
  const int64_t B = x.size(0), L = x.size(1), R = x.size(2), C = x.size(3), H = w_hh.size(1);
  auto seq = x.permute({0, 2, 1, 3}).reshape({B * R, L, C});
  if (backward) seq = seq.flip(1);
  const auto h0 = torch::zeros({1, B * R, H}, x.options());
  const auto zero_bias = torch::zeros_like(bias);
  auto out = std::get<0>(torch::lstm(seq, {h0, h0}, {w_ih, w_hh, bias, zero_bias}, /*has_biases=*/true,
                                     /*num_layers=*/1, /*dropout=*/0.0, is_training(), /*bidirectional=*/false,
                                     /*batch_first=*/true));
  if (backward) out = out.flip(1);
  return out.reshape({B, R, L, H}).permute({0, 2, 1, 3});
}

DgnStreamTemporalImpl::DgnStreamTemporalImpl(const StgaeConfig& c, const StgaeNode& node) : pad(node.pad) {
  const int C = node.c_in;
  if (c.temporal == DgnTemporal::Tcn) {
    conv = register_module("conv", std::make_shared<TemporalConvImpl>(C, C, node.kernel));
    bn = register_module("bn", std::make_shared<ChannelNormImpl>(C));
    return;
  }
  const bool causal = pad == StgaeTemporalPad::Causal;
  fwd = register_module("fwd", std::make_shared<DgnLstmImpl>(C, causal ? C : C / 2));
  if (!causal) bwd = register_module("bwd", std::make_shared<DgnLstmImpl>(C, C / 2));
}

torch::Tensor DgnStreamTemporalImpl::forward(const torch::Tensor& x) {
  if (conv) return x + torch::relu(bn->forward(temporal_conv(x, *conv, pad)));
  if (!bwd) return x + fwd->forward(x, false);
  return x + torch::cat({fwd->forward(x, false), bwd->forward(x, true)}, -1);
}

DgnTemporalImpl::DgnTemporalImpl(const StgaeConfig& c, const StgaeNode& node) {
  v = register_module("v", std::make_shared<DgnStreamTemporalImpl>(c, node));
  e = register_module("e", std::make_shared<DgnStreamTemporalImpl>(c, node));
}

DgnLiftImpl::DgnLiftImpl(int C, int DT) {
  v = register_module("v", std::make_shared<Conv1x1Impl>(C, DT * C, true));
  e = register_module("e", std::make_shared<Conv1x1Impl>(C, DT * C, true));
}

}  // namespace hs::train
