#include "stgae_torch.hpp"

#include "dgn_torch.hpp"

#include "handsteady/skeleton.hpp"
#include "handsteady/stgae_features.hpp"
#include "handsteady/stgae_topology.hpp"

#include <torch/torch.h>

#include <cmath>
#include <set>
#include <stdexcept>

namespace hs::train {

torch::Tensor default_uniform(std::vector<int64_t> shape, int64_t fan_in) {
  const double a = 1.0 / std::sqrt(static_cast<double>(std::max<int64_t>(fan_in, 1)));
  return torch::empty(shape).uniform_(-a, a);
}

namespace {

torch::nn::Module& holder(torch::nn::Module& parent, const std::string& name) {
  return *parent.register_module(name, std::make_shared<torch::nn::Module>());
}

}  // namespace

torch::Tensor time_mean(const torch::Tensor& x, TimeMean mean, int T) {
  const int64_t L = x.size(1);
  if (mean == TimeMean::Whole) return x.mean(1, /*keepdim=*/true);
  torch::Tensor cs = x.cumsum(1);
  if (L > T) {
    // Sum over the last T frames = cumsum(t) - cumsum(t - T).
    cs = cs - torch::cat({torch::zeros_like(cs.narrow(1, 0, T)), cs.narrow(1, 0, L - T)}, 1);
  }
  std::vector<int64_t> shape(static_cast<size_t>(x.dim()), 1);
  shape[1] = L;
  const torch::Tensor count =
      torch::arange(1, L + 1, torch::TensorOptions().dtype(x.dtype())).clamp_max(T).view(shape);
  return cs / count;
}

torch::Tensor positional_encoding(int frames, int channels, torch::Dtype dtype) {
  auto pe = torch::zeros({frames, channels}, torch::kFloat64);
  auto acc = pe.accessor<double, 2>();
  for (int i = 0; i < frames; ++i)
    for (int c = 0; c < channels; ++c) acc[i][c] = stgae_positional_encoding(i, c, channels);
  return pe.to(dtype);
}

// ---- layers ----------------------------------------------------------------------------

Conv1x1Impl::Conv1x1Impl(int in, int out, bool has_bias) {
  weight = register_parameter("weight", default_uniform({out, in}, in));
  if (has_bias) bias = register_parameter("bias", default_uniform({out}, in));
}

torch::Tensor Conv1x1Impl::forward(const torch::Tensor& x) { return torch::linear(x, weight, bias); }

ChannelNormImpl::ChannelNormImpl(int channels) {
  weight = register_parameter("weight", torch::ones({channels}));
  bias = register_parameter("bias", torch::zeros({channels}));
  running_mean = register_buffer("running_mean", torch::zeros({channels}));
  running_var = register_buffer("running_var", torch::ones({channels}));
}

torch::Tensor ChannelNormImpl::forward(const torch::Tensor& x) {
  const int64_t C = x.size(-1);
  const auto flat = x.reshape({-1, C});
  const auto y = torch::batch_norm(flat, weight, bias, running_mean, running_var, is_training(),
                                   /*momentum=*/0.1, /*eps=*/1e-5, /*cudnn_enabled=*/false);
  return y.view(x.sizes());
}

TemporalConvImpl::TemporalConvImpl(int in, int out, int kernel) {
  weight = register_parameter("weight", default_uniform({out, in, kernel}, static_cast<int64_t>(in) * kernel));
  bias = register_parameter("bias", default_uniform({out}, static_cast<int64_t>(in) * kernel));
}

// ---- block -----------------------------------------------------------------------------

BlockImpl::BlockImpl(const StgaeConfig& config, const BlockOptions& options)
    : opt(options), attention(config.attention), c_variant(config.c_variant) {
  const auto& partition = hand_partition(skeleton_by_name(config.skeleton));
  N = static_cast<int>(partition.A[0].rows());
  d = std::max(1, opt.c_in / 2);
  A = torch::empty({K, N, N}, torch::kFloat64);
  for (int k = 0; k < K; ++k)
    for (int v = 0; v < N; ++v)
      for (int w = 0; w < N; ++w) A[k][v][w] = partition.A[static_cast<size_t>(k)](v, w);

  auto& g = holder(*this, "gcn");
  gcn_conv = g.register_module("conv", std::make_shared<Conv1x1Impl>(opt.c_in, K * opt.c_out, true));
  gcn_bn = g.register_module("bn", std::make_shared<ChannelNormImpl>(K * opt.c_out));
  // B starts at zero (ISMAR paper), so training starts from the physical graph.
  if (attention != StgaeAttention::A) B = register_parameter("B", torch::zeros({K, N, N}));
  if (attention == StgaeAttention::ABC) {
    auto& a = holder(*this, "att");
    if (c_variant == StgaeCVariant::Dot) {
      att_q = a.register_module("q", std::make_shared<Conv1x1Impl>(opt.c_in, K * d, false));
      att_k = a.register_module("k", std::make_shared<Conv1x1Impl>(opt.c_in, K * d, false));
    } else {
      att_emb = a.register_module("emb", std::make_shared<Conv1x1Impl>(opt.c_in, K * d, false));
      att_a = a.register_parameter("a", default_uniform({K, 2 * d}, 2 * d));
    }
  }
  auto& t = holder(*this, "tcn");
  tcn_conv = t.register_module("conv", std::make_shared<TemporalConvImpl>(opt.c_out, opt.c_out, opt.kernel));
  tcn_bn = t.register_module("bn", std::make_shared<ChannelNormImpl>(opt.c_out));
  auto& r = holder(*this, "res");
  res_conv = r.register_module("conv", std::make_shared<Conv1x1Impl>(opt.c_in, opt.c_out, true));
  res_bn = r.register_module("bn", std::make_shared<ChannelNormImpl>(opt.c_out));
  if (!opt.relu_out) {
    // A decoder's linear output starts small: the initial model is close to identity
    // (denoised = input, prediction = hold the last frame).
    torch::NoGradGuard no_grad;
    tcn_bn->weight.fill_(0.1);
    res_bn->weight.fill_(0.1);
  }
}

torch::Tensor BlockImpl::forward(const torch::Tensor& f) {
  const int64_t Bn = f.size(0), L = f.size(1), C = opt.c_out;
  // a. 1x1 conv to K*Cout channels (index k*Cout + c), BN, ReLU.
  const auto h = torch::relu(gcn_bn->forward(gcn_conv->forward(f)));
  // [B, L, N, K, C] -> [B, L, C, K*N] so that the aggregation is one matmul with the
  // stacked [K*N, N] graph (row k*N + v).
  const auto hp = h.view({Bn, L, N, K, C}).permute({0, 1, 4, 3, 2}).reshape({Bn, L, C, K * N});
  // b. M_k = A_k (+ B_k) (+ C_k(t)).
  torch::Tensor M = A.to(f.dtype());
  if (attention != StgaeAttention::A) M = M + B;
  torch::Tensor g;
  if (attention == StgaeAttention::ABC) {
    torch::Tensor S;
    if (c_variant == StgaeCVariant::Dot) {
      const auto inv_sqrt_d = 1.0 / std::sqrt(static_cast<double>(d));
      if (opt.mean == TimeMean::Whole) {
        // Mean over all frames of q_s[v] . k_s[w] = one product over the (frame, dim) axis.
        const auto q = att_q->forward(f).view({Bn, L, N, K, d}).permute({0, 3, 2, 1, 4}).reshape({Bn, K, N, L * d});
        const auto k = att_k->forward(f).view({Bn, L, N, K, d}).permute({0, 3, 2, 1, 4}).reshape({Bn, K, N, L * d});
        S = (torch::matmul(q, k.transpose(-1, -2)) * (inv_sqrt_d / static_cast<double>(L))).unsqueeze(1);
      } else {
        const auto q = att_q->forward(f).view({Bn, L, N, K, d}).permute({0, 1, 3, 2, 4});
        const auto k = att_k->forward(f).view({Bn, L, N, K, d}).permute({0, 1, 3, 2, 4});
        // Per-frame products q_s[v] . k_s[w], averaged over W(t), / sqrt(d).
        S = time_mean(torch::matmul(q, k.transpose(-1, -2)), opt.mean, opt.T) * inv_sqrt_d;
      }
    } else {
      const auto fm = time_mean(f, opt.mean, opt.T);  // [B, L|1, N, Cin]
      const int64_t Lm = fm.size(1);
      const auto e = att_emb->forward(fm).view({Bn, Lm, N, K, d}).permute({0, 1, 3, 2, 4});  // [B,Lm,K,N,d]
      const auto a1 = att_a.narrow(1, 0, d).view({1, 1, K, 1, d});
      const auto a2 = att_a.narrow(1, d, d).view({1, 1, K, 1, d});
      const auto s1 = (e * a1).sum(-1), s2 = (e * a2).sum(-1);  // [B, Lm, K, N]
      S = torch::leaky_relu(s1.unsqueeze(-1) + s2.unsqueeze(-2), 0.2);
    }
    const auto Cm = torch::softmax(S, -1);  // [B, L|1, K, N, N], rows sum to 1
    const auto Mfull = (Cm + M).reshape({Bn, Cm.size(1), K * N, N});
    if (Cm.size(1) == 1) {
      // One matrix per window: a single product per window over all (frame, channel) rows.
      g = torch::matmul(hp.reshape({Bn, L * C, K * N}), Mfull.squeeze(1)).view({Bn, L, C, N});
    } else {
      g = torch::matmul(hp, Mfull);  // one matrix per frame
    }
  } else {
    g = torch::matmul(hp, M.reshape({K * N, N}));
  }
  // d. temporal conv over frames.
  const auto u = temporal_conv(g.transpose(2, 3), *tcn_conv, opt.pad);  // [B, L', N, C]
  const int64_t Lo = u.size(1);
  auto z = tcn_bn->forward(u);
  if (opt.relu_out) z = torch::relu(z);
  auto r = res_bn->forward(res_conv->forward(f));
  // Valid padding: output frame t covers input frames t..t+kt-1; its residual is the newest one.
  if (Lo != L) r = r.narrow(1, L - Lo, Lo);
  return z + r;
}

torch::Tensor temporal_conv(const torch::Tensor& x, const TemporalConvImpl& conv, StgaeTemporalPad pad) {
  // One GEMM: unfold gives the kt (zero-padded) frames under the kernel as
  // [B, L', R, C, kt] (index c*kt + j after reshape = W's [Cout, Cin*kt] layout).
  const int64_t kt = conv.weight.size(2), C = x.size(3), Cout = conv.weight.size(0);
  auto gl = x;
  if (pad == StgaeTemporalPad::Causal && kt > 1) {
    gl = torch::constant_pad_nd(gl, {0, 0, 0, 0, kt - 1, 0});
  } else if (pad == StgaeTemporalPad::Centred && kt > 1) {
    gl = torch::constant_pad_nd(gl, {0, 0, 0, 0, (kt - 1) / 2, (kt - 1) / 2});
  }
  const int64_t Lo = gl.size(1) - kt + 1;
  const auto stacked = gl.unfold(1, kt, 1).reshape({x.size(0), Lo, x.size(2), C * kt});
  return torch::linear(stacked, conv.weight.reshape({Cout, C * kt}), conv.bias);
}

// ---- gate ------------------------------------------------------------------------------

GateImpl::GateImpl(int channels, TimeMean mean_, int T_) : mean(mean_), T(T_) {
  const int hc = std::max(1, channels / 2);
  auto& s = holder(*this, "shared");
  shared_conv = s.register_module("conv", std::make_shared<Conv1x1Impl>(channels, hc, true));
  shared_bn = s.register_module("bn", std::make_shared<ChannelNormImpl>(hc));
  time_conv = holder(*this, "time").register_module("conv", std::make_shared<Conv1x1Impl>(hc, channels, true));
  joint_conv = holder(*this, "joint").register_module("conv", std::make_shared<Conv1x1Impl>(hc, channels, true));
  bn = register_module("bn", std::make_shared<ChannelNormImpl>(channels));
}

torch::Tensor GateImpl::forward(const torch::Tensor& x) {
  const auto pt = time_mean(x, mean, T);  // [B, L|1, N, C]: per joint, pooled over time
  const auto pj = x.mean(2);              // [B, L, C]: per frame, pooled over joints
  const auto zt = torch::relu(shared_bn->forward(shared_conv->forward(pt)));
  const auto zj = torch::relu(shared_bn->forward(shared_conv->forward(pj)));
  const auto gt = torch::sigmoid(time_conv->forward(zt));
  const auto gj = torch::sigmoid(joint_conv->forward(zj)).unsqueeze(2);
  return torch::relu(bn->forward(x + x * gt * gj));
}

// ---- network ---------------------------------------------------------------------------

StgaeNetImpl::StgaeNetImpl(const StgaeConfig& cfg) : config(cfg) {
  const auto nodes = stgae_topology(config);
  const dgn::DgnGraph graph = config.family == StgaeFamily::Dgn ? dgn::dgn_graph(config) : dgn::DgnGraph{};
  // Holders "enc", "den", "pre" and the leaves under them follow the tensor name prefixes.
  auto parent_of = [&](const std::string& prefix, std::string& leaf) -> torch::nn::Module& {
    const std::string path = prefix.substr(0, prefix.size() - 1);  // without the final '.'
    const auto dot = path.find('.');
    if (dot == std::string::npos) {
      leaf = path;
      return *this;
    }
    leaf = path.substr(dot + 1);
    const std::string group = path.substr(0, dot);
    auto& slot = group == "enc" ? enc : group == "den" ? den : group == "tmp" ? tmp : pre;
    if (!slot) slot = register_module(group, std::make_shared<torch::nn::Module>());
    return *slot;
  };
  auto add = [&](const StgaeNode& node) {
    std::string leaf;
    torch::nn::Module& parent = parent_of(node.prefix, leaf);
    switch (node.kind) {
      case StgaeNodeKind::Block: {
        const BlockOptions o{node.c_in, node.c_out, node.kernel, node.pad, node.mean, config.window, !node.linear};
        auto b = parent.register_module(leaf, std::make_shared<BlockImpl>(config, o));
        if (node.section == StgaeSection::Encoder) enc_blocks.push_back(b);
        else if (node.section == StgaeSection::Denoise) den_blocks.push_back(b);
        else if (node.section == StgaeSection::PredictInput) pre_head = b;
        else pre_blocks.push_back(b);
        break;
      }
      case StgaeNodeKind::Gate: {
        auto g = parent.register_module(leaf, std::make_shared<GateImpl>(node.c_in, node.mean, config.window));
        (node.section == StgaeSection::EncoderGate ? enc_gate : pre_gate) = g;
        break;
      }
      case StgaeNodeKind::Lift:
        pre_lift = parent.register_module(leaf, std::make_shared<Conv1x1Impl>(node.c_in, node.c_out, true));
        break;
      case StgaeNodeKind::DgnBlock: {
        auto b = parent.register_module(leaf, std::make_shared<DgnBlockImpl>(graph, node.c_in, node.c_out, node.linear));
        (node.section == StgaeSection::Encoder ? dgn_enc : node.section == StgaeSection::Denoise ? dgn_den : dgn_pre)
            .push_back(b);
        break;
      }
      case StgaeNodeKind::DgnTemporal:
        dgn_tmp.push_back(parent.register_module(leaf, std::make_shared<DgnTemporalImpl>(config, node)));
        break;
      case StgaeNodeKind::DgnLift:
        dgn_lift = parent.register_module(leaf, std::make_shared<DgnLiftImpl>(node.c_in, config.horizon));
        break;
    }
  };
  if (config.family == StgaeFamily::Dgn) {
    root = graph.root;
    bone_source = torch::tensor(std::vector<int64_t>(graph.source.begin(), graph.source.end()), torch::kLong);
    bone_target = torch::tensor(std::vector<int64_t>(graph.target.begin(), graph.target.end()), torch::kLong);
    bone_path = torch::zeros({graph.n, graph.e}, torch::kFloat64);
    for (int j = 0; j < graph.n; ++j)
      for (int v = j; graph.bone_of[static_cast<size_t>(v)] >= 0;) {
        const int b = graph.bone_of[static_cast<size_t>(v)];
        bone_path[j][b] = 1.0;
        v = graph.source[static_cast<size_t>(b)];
      }
  }
  // The prediction gate is made last, as it always was: the same seed gives the same
  // initial weights (and parameter order) as before.
  for (const auto& node : nodes)
    if (node.section != StgaeSection::PredictGate) add(node);
  for (const auto& node : nodes)
    if (node.section == StgaeSection::PredictGate) add(node);
}

torch::Tensor StgaeNetImpl::dgn_combine(const torch::Tensor& dv, const torch::Tensor& de) const {
  return 0.5 * (dv + dv.narrow(-2, root, 1) + torch::matmul(bone_path.to(de.scalar_type()), de));
}

TorchOutput StgaeNetImpl::dgn_forward(const torch::Tensor& fv, int pred_frames) {
  auto v = fv;
  auto e = fv.index_select(2, bone_target) - fv.index_select(2, bone_source);
  for (auto& b : dgn_enc) std::tie(v, e) = b->forward(v, e);
  for (auto& t : dgn_tmp) {
    v = t->v->forward(v);
    e = t->e->forward(e);
  }
  TorchOutput out;
  auto dv = v, de = e;
  for (auto& b : dgn_den) std::tie(dv, de) = b->forward(dv, de);
  out.denoised_offset = dgn_combine(dv, de);
  if (!config.predict) return out;
  const int64_t Bn = v.size(0), L = v.size(1), N = v.size(2), E = e.size(2);
  const int64_t P = std::max(pred_frames, 1);
  if (P > L) throw std::invalid_argument("dgn: predictions at several frames need L >= P");
  const int DT = config.horizon, C = config.latent_channels();
  const auto pe = positional_encoding(DT, C, v.scalar_type()).view({1, DT, 1, C});
  auto lift = [&](Conv1x1Impl& conv, const torch::Tensor& h, int64_t rows) {
    return conv.forward(h.narrow(1, L - P, P).reshape({Bn * P, rows, C})).view({Bn * P, rows, DT, C}).permute({0, 2, 1, 3}) + pe;
  };
  auto qv = lift(*dgn_lift->v, v, N), qe = lift(*dgn_lift->e, e, E);
  for (auto& b : dgn_pre) std::tie(qv, qe) = b->forward(qv, qe);
  const auto q = dgn_combine(qv, qe);  // [B*P, DT, N, 3]
  out.predicted_offset = P > 1 ? q.view({Bn, P, DT, N, 3}) : q.view({Bn, DT, N, 3});
  return out;
}

TorchOutput StgaeNetImpl::forward(const torch::Tensor& features, int pred_frames) {
  if (features.dim() != 4 || features.size(3) != 6)
    throw std::invalid_argument("stgae: features must be [B, L, N, 6]");
  if (config.family == StgaeFamily::Dgn) return dgn_forward(features, pred_frames);
  torch::Tensor H = features;
  for (auto& b : enc_blocks) H = b->forward(H);
  if (enc_gate) H = enc_gate->forward(H);
  TorchOutput out;
  torch::Tensor D = H;
  for (auto& b : den_blocks) D = b->forward(D);
  out.denoised_offset = D;
  if (config.predict) {
    const int64_t Bn = H.size(0), L = H.size(1), N = H.size(2);
    const int DT = config.horizon, C = config.latent_channels();
    torch::Tensor P = pre_gate ? pre_gate->forward(H) : H;
    torch::Tensor Z;
    if (pred_frames > 1) {
      if (!pre_lift || pred_frames > L) throw std::invalid_argument("stgae: predictions at several frames need a causal model and L >= P");
      // Each of the last P frames predicts as the stream would there: fold them into the batch.
      const int64_t Pn = pred_frames;
      Z = pre_lift->forward(P.narrow(1, L - Pn, Pn).reshape({Bn * Pn, N, C}))
              .view({Bn * Pn, N, DT, C})
              .permute({0, 2, 1, 3});
      Z = Z + positional_encoding(DT, C, H.scalar_type()).view({1, DT, 1, C});
      for (auto& b : pre_blocks) Z = b->forward(Z);
      out.predicted_offset = Z.view({Bn, Pn, DT, N, Z.size(-1)});
      return out;
    }
    if (pre_lift) {
      Z = pre_lift->forward(P.select(1, L - 1)).view({Bn, N, DT, C}).permute({0, 2, 1, 3});
    } else {
      if (L != config.window) throw std::invalid_argument("stgae: the centred prediction head needs L = T frames");
      Z = pre_head->forward(P);
    }
    Z = Z + positional_encoding(DT, C, H.scalar_type()).view({1, DT, 1, C});
    for (auto& b : pre_blocks) Z = b->forward(Z);
    out.predicted_offset = Z;
  }
  return out;
}

torch::Tensor denoised_positions(const StgaeConfig& config, const torch::Tensor& x, const TorchOutput& out) {
  return x + config.shape_scale_m * out.denoised_offset;
}

torch::Tensor predicted_positions(const StgaeConfig& config, const torch::Tensor& denoised, const TorchOutput& out) {
  const int64_t L = denoised.size(1);
  if (out.predicted_offset.dim() == 5) {
    const int64_t P = out.predicted_offset.size(1);
    return denoised.narrow(1, L - P, P).unsqueeze(2) + config.shape_scale_m * out.predicted_offset;
  }
  return denoised.narrow(1, L - 1, 1) + config.shape_scale_m * out.predicted_offset;
}

// ---- weights ---------------------------------------------------------------------------

namespace {

std::map<std::string, torch::Tensor> named_tensors(StgaeNetImpl& net) {
  std::map<std::string, torch::Tensor> all;
  for (const auto& p : net.named_parameters(true)) all.emplace(p.key(), p.value());
  for (const auto& b : net.named_buffers(true)) all.emplace(b.key(), b.value());
  return all;
}

std::string shape_text(c10::IntArrayRef s) {
  std::string t = "[";
  for (size_t i = 0; i < s.size(); ++i) t += (i ? ", " : "") + std::to_string(s[i]);
  return t + "]";
}

torch::Tensor spec_tensor(const std::map<std::string, torch::Tensor>& all, const TensorSpec& spec) {
  const auto it = all.find(spec.name);
  if (it == all.end()) throw std::logic_error("stgae torch model lacks tensor " + spec.name);
  std::vector<int64_t> want(spec.shape.begin(), spec.shape.end());
  if (it->second.sizes() != c10::IntArrayRef(want))
    throw std::logic_error("stgae torch tensor " + spec.name + " has shape " + shape_text(it->second.sizes()) +
                           ", the spec says " + shape_text(want));
  return it->second;
}

}  // namespace

StgaeWeights export_weights(StgaeNetImpl& net) {
  const auto all = named_tensors(net);
  const auto specs = stgae_tensor_specs(net.config);
  std::set<std::string> used;
  StgaeWeights w;
  for (const auto& spec : specs) {
    const auto t = spec_tensor(all, spec).detach().to(torch::kCPU, torch::kFloat32).contiguous();
    Tensor out;
    out.shape = spec.shape;
    out.data.assign(t.data_ptr<float>(), t.data_ptr<float>() + t.numel());
    w.tensors.emplace(spec.name, std::move(out));
    used.insert(spec.name);
  }
  for (const auto& [name, t] : all)
    if (!used.count(name)) throw std::logic_error("stgae torch tensor " + name + " is not in the model file spec");
  return w;
}

void import_weights(StgaeNetImpl& net, const StgaeWeights& weights) {
  check_stgae_weights(net.config, weights);
  const auto all = named_tensors(net);
  torch::NoGradGuard no_grad;
  for (const auto& spec : stgae_tensor_specs(net.config)) {
    auto dst = spec_tensor(all, spec);
    const auto& src = weights.at(spec.name);
    auto cpu = torch::from_blob(const_cast<float*>(src.data.data()),  // NOLINT: read only
                                std::vector<int64_t>(spec.shape.begin(), spec.shape.end()), torch::kFloat32);
    dst.copy_(cpu.to(dst.scalar_type()));
  }
}

std::vector<std::string> import_matching_weights(StgaeNetImpl& net, const StgaeWeights& weights) {
  const auto all = named_tensors(net);
  torch::NoGradGuard no_grad;
  std::vector<std::string> left;
  for (const auto& spec : stgae_tensor_specs(net.config)) {
    const auto it = weights.tensors.find(spec.name);
    if (it == weights.tensors.end() || it->second.shape != spec.shape || it->second.data.size() != spec.numel()) {
      left.push_back(spec.name);
      continue;
    }
    auto dst = spec_tensor(all, spec);
    auto cpu = torch::from_blob(const_cast<float*>(it->second.data.data()),  // NOLINT: read only
                                std::vector<int64_t>(spec.shape.begin(), spec.shape.end()), torch::kFloat32);
    dst.copy_(cpu.to(dst.scalar_type()));
  }
  return left;
}

}  // namespace hs::train
