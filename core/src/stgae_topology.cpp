// The Multi-STGAE topology (stgae_topology.hpp): nodes, their tensors and their cost.
#include "handsteady/stgae_topology.hpp"

#include <algorithm>

namespace hs {

namespace {

constexpr int K = 3;  // graph subsets

void add_bn(std::vector<TensorSpec>& out, const std::string& p, int ch) {
  for (const char* s : {"weight", "bias", "running_mean", "running_var"}) out.push_back({p + "bn." + s, {ch}});
}

std::vector<TensorSpec> block_tensors(const StgaeConfig& c, const std::string& p, int cin, int cout, int kt) {
  const int N = c.joint_count();
  std::vector<TensorSpec> out;
  out.push_back({p + "gcn.conv.weight", {K * cout, cin}});
  out.push_back({p + "gcn.conv.bias", {K * cout}});
  add_bn(out, p + "gcn.", K * cout);
  if (c.attention != StgaeAttention::A) out.push_back({p + "B", {K, N, N}});
  if (c.attention == StgaeAttention::ABC) {
    const int d = std::max(1, cin / 2);
    if (c.c_variant == StgaeCVariant::Dot) {
      out.push_back({p + "att.q.weight", {K * d, cin}});
      out.push_back({p + "att.k.weight", {K * d, cin}});
    } else {
      out.push_back({p + "att.emb.weight", {K * d, cin}});
      out.push_back({p + "att.a", {K, 2 * d}});
    }
  }
  out.push_back({p + "tcn.conv.weight", {cout, cout, kt}});
  out.push_back({p + "tcn.conv.bias", {cout}});
  add_bn(out, p + "tcn.", cout);
  out.push_back({p + "res.conv.weight", {cout, cin}});
  out.push_back({p + "res.conv.bias", {cout}});
  add_bn(out, p + "res.", cout);
  return out;
}

std::vector<TensorSpec> gate_tensors(const std::string& g, int ch) {
  const int hc = std::max(1, ch / 2);
  std::vector<TensorSpec> out;
  out.push_back({g + "shared.conv.weight", {hc, ch}});
  out.push_back({g + "shared.conv.bias", {hc}});
  add_bn(out, g + "shared.", hc);
  out.push_back({g + "time.conv.weight", {ch, hc}});
  out.push_back({g + "time.conv.bias", {ch}});
  out.push_back({g + "joint.conv.weight", {ch, hc}});
  out.push_back({g + "joint.conv.bias", {ch}});
  add_bn(out, g, ch);
  return out;
}

std::vector<TensorSpec> dgn_block_tensors(const StgaeConfig& c, const std::string& p, int cin, int cout, bool linear) {
  const int N = c.joint_count(), E = N - 1;
  std::vector<TensorSpec> out;
  out.push_back({p + "S", {N, E}});
  out.push_back({p + "T", {N, E}});
  out.push_back({p + "v.weight", {cout, 3 * cin}});
  out.push_back({p + "v.bias", {cout}});
  if (!linear) add_bn(out, p + "v_", cout);
  out.push_back({p + "e.weight", {cout, cin + 2 * cout}});
  out.push_back({p + "e.bias", {cout}});
  if (!linear) add_bn(out, p + "e_", cout);
  return out;
}

// The causal prediction's lift (either family): the newest latent frame to `horizon` frames.
StgaeNode lift_node(StgaeNodeKind kind, int C, int horizon) {
  StgaeNode n;
  n.kind = kind;
  n.section = StgaeSection::PredictInput;
  n.prefix = "pre.lift.";
  n.c_in = C;
  n.c_out = horizon * C;
  n.span = StgaeFrameSpan::Newest;
  return n;
}

// DGN topology (dgn_layers.hpp): enc blocks, temporal layers, den blocks, and (predict)
// the lift and the pre blocks on the DT frames.
std::vector<StgaeNode> dgn_topology(const StgaeConfig& c) {
  const bool causal = c.padding == StgaePadding::Causal;
  const int C = c.latent_channels();
  std::vector<StgaeNode> nodes;
  auto blocks = [&](StgaeSection section, const std::string& name, const std::vector<int>& ch, StgaeFrameSpan span) {
    for (size_t i = 0; i + 1 < ch.size(); ++i) {
      StgaeNode n;
      n.kind = StgaeNodeKind::DgnBlock;
      n.section = section;
      n.prefix = name + "." + std::to_string(i) + ".";
      n.c_in = ch[i];
      n.c_out = ch[i + 1];
      n.span = span;
      n.linear = section != StgaeSection::Encoder && i + 2 == ch.size();
      n.tensors = dgn_block_tensors(c, n.prefix, n.c_in, n.c_out, n.linear);
      nodes.push_back(std::move(n));
    }
  };
  blocks(StgaeSection::Encoder, "enc", c.encoder_channels, StgaeFrameSpan::Input);
  for (int i = 0; i < c.temporal_layers; ++i) {
    StgaeNode n;
    n.kind = StgaeNodeKind::DgnTemporal;
    n.section = StgaeSection::Temporal;
    n.prefix = "tmp." + std::to_string(i) + ".";
    n.c_in = n.c_out = C;
    n.pad = causal ? StgaeTemporalPad::Causal : StgaeTemporalPad::Centred;
    n.kernel = c.temporal == DgnTemporal::Tcn ? c.temporal_kernel : 1;
    for (const char* s : {"v.", "e."}) {
      const std::string q = n.prefix + s;
      if (c.temporal == DgnTemporal::Tcn) {
        n.tensors.push_back({q + "conv.weight", {C, C, n.kernel}});
        n.tensors.push_back({q + "conv.bias", {C}});
        add_bn(n.tensors, q, C);
      } else {
        const int H = causal ? C : C / 2;
        for (const char* d : causal ? std::vector<const char*>{"fwd."} : std::vector<const char*>{"fwd.", "bwd."}) {
          n.tensors.push_back({q + d + "w_ih", {4 * H, C}});
          n.tensors.push_back({q + d + "w_hh", {4 * H, H}});
          n.tensors.push_back({q + d + "bias", {4 * H}});
        }
      }
    }
    nodes.push_back(std::move(n));
  }
  blocks(StgaeSection::Denoise, "den", c.denoise_decoder_channels, StgaeFrameSpan::Input);
  if (!c.predict) return nodes;
  StgaeNode n = lift_node(StgaeNodeKind::DgnLift, C, c.horizon);
  for (const char* s : {"v.", "e."}) {
    n.tensors.push_back({n.prefix + s + "weight", {n.c_out, C}});
    n.tensors.push_back({n.prefix + s + "bias", {n.c_out}});
  }
  nodes.push_back(std::move(n));
  blocks(StgaeSection::PredictDecoder, "pre", c.predict_decoder_channels, StgaeFrameSpan::Horizon);
  return nodes;
}

}  // namespace

std::vector<StgaeNode> stgae_topology(const StgaeConfig& c) {
  validate_stgae_config(c);
  if (c.family == StgaeFamily::Dgn) return dgn_topology(c);
  const bool causal = c.padding == StgaePadding::Causal;
  const StgaeTemporalPad pad = causal ? StgaeTemporalPad::Causal : StgaeTemporalPad::Centred;
  const StgaeTimeMean mean = causal ? StgaeTimeMean::Causal : StgaeTimeMean::Whole;
  std::vector<StgaeNode> nodes;
  auto block = [&](StgaeSection section, std::string prefix, int cin, int cout, int kt, StgaeTemporalPad p,
                   StgaeTimeMean m, StgaeFrameSpan span, bool linear) {
    StgaeNode n;
    n.kind = StgaeNodeKind::Block;
    n.section = section;
    n.prefix = std::move(prefix);
    n.c_in = cin;
    n.c_out = cout;
    n.kernel = kt;
    n.pad = p;
    n.mean = m;
    n.span = span;
    n.linear = linear;
    n.tensors = block_tensors(c, n.prefix, cin, cout, kt);
    nodes.push_back(std::move(n));
  };
  auto blocks = [&](StgaeSection section, const std::string& name, const std::vector<int>& ch, int kt,
                    StgaeTemporalPad p, StgaeTimeMean m, StgaeFrameSpan span, bool linear_last) {
    for (size_t i = 0; i + 1 < ch.size(); ++i)
      block(section, name + "." + std::to_string(i) + ".", ch[i], ch[i + 1], kt, p, m, span,
            linear_last && i + 2 == ch.size());
  };
  auto gate = [&](StgaeSection section, const std::string& prefix, StgaeFrameSpan span) {
    StgaeNode n;
    n.kind = StgaeNodeKind::Gate;
    n.section = section;
    n.prefix = prefix;
    n.c_in = n.c_out = c.latent_channels();
    n.mean = mean;
    n.span = span;
    n.tensors = gate_tensors(prefix, n.c_in);
    nodes.push_back(std::move(n));
  };
  const int kt = c.temporal_kernel, C = c.latent_channels();
  blocks(StgaeSection::Encoder, "enc", c.encoder_channels, kt, pad, mean, StgaeFrameSpan::Input, false);
  blocks(StgaeSection::Denoise, "den", c.denoise_decoder_channels, kt, pad, mean, StgaeFrameSpan::Input, true);
  if (c.gates) gate(StgaeSection::EncoderGate, "enc_gate.", StgaeFrameSpan::Input);
  if (!c.predict) return nodes;
  // The causal prediction reads the newest frame only.
  if (c.gates) gate(StgaeSection::PredictGate, "pre_gate.", causal ? StgaeFrameSpan::Newest : StgaeFrameSpan::Input);
  if (causal) {
    StgaeNode n = lift_node(StgaeNodeKind::Lift, C, c.horizon);
    n.tensors = {{"pre.lift.weight", {n.c_out, C}}, {"pre.lift.bias", {n.c_out}}};
    nodes.push_back(std::move(n));
  } else {
    // The published head: T latent frames -> DT (valid padding, needs L = T).
    block(StgaeSection::PredictInput, "pre.head.", C, C, c.window - c.horizon + 1, StgaeTemporalPad::Valid,
          StgaeTimeMean::Whole, StgaeFrameSpan::Input, false);
  }
  // The DT future frames are computed together (means over the DT frames); causal: kernel 1.
  blocks(StgaeSection::PredictDecoder, "pre", c.predict_decoder_channels, causal ? 1 : kt, StgaeTemporalPad::Centred,
         StgaeTimeMean::Whole, StgaeFrameSpan::Horizon, true);
  return nodes;
}

void check_node_tensors(const StgaeNode& node, const StgaeWeights& weights, const std::string& source) {
  for (const TensorSpec& s : node.tensors) {
    const auto it = weights.tensors.find(s.name);
    if (it == weights.tensors.end())
      throw InputError(SourceLocation{source, 0, s.name}, "missing tensor (expected shape " + shape_text(s.shape) + ")");
    const Tensor& t = it->second;
    if (t.shape != s.shape)
      throw InputError(SourceLocation{source, 0, s.name},
                       "wrong shape: expected " + shape_text(s.shape) + ", got " + shape_text(t.shape));
    if (t.data.size() != s.numel())
      throw InputError(SourceLocation{source, 0, s.name}, "data size does not match its shape");
  }
}

std::int64_t StgaeNode::macs(const StgaeConfig& c, std::int64_t L) const {
  const std::int64_t n = c.joint_count();
  const std::int64_t f_in = span == StgaeFrameSpan::Input ? L : span == StgaeFrameSpan::Newest ? 1 : c.horizon;
  const std::int64_t f_out = pad == StgaeTemporalPad::Valid ? f_in - kernel + 1 : f_in;
  const std::int64_t means = mean == StgaeTimeMean::Causal ? f_in : 1;  // distinct time means
  const std::int64_t cin = c_in, cout = c_out;
  switch (kind) {
    case StgaeNodeKind::Block: {
      // gcn conv, aggregation and attention items per input frame, the gat embedding per
      // distinct mean, temporal and residual convs per output frame.
      const std::int64_t d = std::max<std::int64_t>(1, cin / 2);
      std::int64_t per_in = n * cin * K * cout + K * n * n * cout;
      std::int64_t per_mean = 0;
      if (c.attention == StgaeAttention::ABC) {
        if (c.c_variant == StgaeCVariant::Dot) per_in += 2 * n * cin * K * d + K * n * n * d;  // q, k; q.k
        else per_mean = n * cin * K * d + 2 * K * n * d;                                      // emb; a . e
      }
      const std::int64_t per_out = n * kernel * cout * cout + n * cin * cout;
      return f_in * per_in + means * per_mean + f_out * per_out;
    }
    case StgaeNodeKind::Gate: {
      const std::int64_t hc = std::max<std::int64_t>(1, cin / 2);
      return means * n * 2 * cin * hc + f_in * 2 * cin * hc;  // time pools per joint, joint pool per frame
    }
    case StgaeNodeKind::Lift: return f_in * n * cin * cout;
    case StgaeNodeKind::DgnBlock: {
      // vertex and edge updates, and the four incidence products (dense N x E).
      const std::int64_t e = n - 1;
      return f_in * (n * 3 * cin * cout + e * (cin + 2 * cout) * cout + 2 * n * e * (cin + cout));
    }
    case StgaeNodeKind::DgnTemporal: {
      const std::int64_t rows = 2 * n - 1;  // joints and bones
      if (c.temporal == DgnTemporal::Tcn) return f_in * rows * kernel * cin * cout;
      const bool bi = pad == StgaeTemporalPad::Centred;
      const std::int64_t h = bi ? cin / 2 : cin;
      return f_in * rows * (bi ? 2 : 1) * 4 * h * (cin + h);
    }
    case StgaeNodeKind::DgnLift: return f_in * (2 * n - 1) * cin * cout;
  }
  return 0;
}

}  // namespace hs
