// Multi-STGAE configuration, tensor specs and weights (the file format: hsm_format.cpp).
#include "handsteady/stgae_model.hpp"

#include "handsteady/skeleton.hpp"
#include "handsteady/stgae_topology.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <set>
#include <stdexcept>

namespace hs {

namespace {

using json = nlohmann::json;

[[noreturn]] void config_error(const std::string& source, const std::string& key, const std::string& what) {
  throw InputError(SourceLocation{source, 0, key}, what);
}

std::string_view padding_name(StgaePadding p) { return p == StgaePadding::Causal ? "causal" : "centred"; }
std::string_view attention_name(StgaeAttention a) {
  switch (a) {
    case StgaeAttention::A: return "A";
    case StgaeAttention::AB: return "A+B";
    case StgaeAttention::ABC: return "A+B+C";
  }
  return "A";
}
std::string_view c_variant_name(StgaeCVariant c) { return c == StgaeCVariant::Dot ? "dot" : "gat"; }

const std::set<std::string, std::less<>>& config_keys() {
  static const std::set<std::string, std::less<>> keys = {
      "skeleton", "window", "horizon", "rate_hz", "encoder_channels", "denoise_decoder_channels",
      "predict_decoder_channels", "temporal_kernel", "padding", "attention", "c_variant", "gates",
      "predict", "shape_scale_m", "velocity_scale_m", "meta", "family", "temporal", "temporal_layers"};
  return keys;
}

}  // namespace

int StgaeConfig::joint_count() const { return skeleton_by_name(skeleton).joint_count(); }

StgaeConfig parse_stgae_config(std::string_view text, const std::string& source) {
  json j;
  try {
    j = json::parse(text.begin(), text.end());
  } catch (const json::exception& e) {
    config_error(source, "", std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object()) config_error(source, "", "the model configuration must be a JSON object");
  for (const auto& [key, value] : j.items())
    if (!config_keys().contains(key)) config_error(source, key, "unknown configuration key");

  StgaeConfig c;
  if (j.contains("family")) {
    const auto& v = j.at("family");
    const std::string s = v.is_string() ? v.get<std::string>() : std::string();
    if (s == "multi-stgae") c.family = StgaeFamily::MultiStgae;
    else if (s == "dgn") c.family = StgaeFamily::Dgn;
    else config_error(source, "family", "expected \"multi-stgae\" or \"dgn\"");
  }
  const bool dgn = c.family == StgaeFamily::Dgn;
  for (const char* key : {"attention", "c_variant", "gates"})
    if (dgn && j.contains(key)) config_error(source, key, "does not apply to the dgn family");
  for (const char* key : {"temporal", "temporal_layers"})
    if (!dgn && j.contains(key)) config_error(source, key, "applies to the dgn family only");
  auto get_int = [&](const char* key, int& out) {
    if (!j.contains(key)) return;
    const auto& v = j.at(key);
    if (!v.is_number_integer()) config_error(source, key, "expected an integer");
    const auto x = v.get<long long>();
    if (x < -1000000000LL || x > 1000000000LL) config_error(source, key, "integer out of range");
    out = static_cast<int>(x);
  };
  auto get_double = [&](const char* key, double& out) {
    if (!j.contains(key)) return;
    const auto& v = j.at(key);
    if (!v.is_number()) config_error(source, key, "expected a number");
    out = v.get<double>();
  };
  auto get_bool = [&](const char* key, bool& out) {
    if (!j.contains(key)) return;
    const auto& v = j.at(key);
    if (!v.is_boolean()) config_error(source, key, "expected true or false");
    out = v.get<bool>();
  };
  auto get_string = [&](const char* key) -> std::string {
    const auto& v = j.at(key);
    if (!v.is_string()) config_error(source, key, "expected a string");
    return v.get<std::string>();
  };
  auto get_list = [&](const char* key, std::vector<int>& out) {
    if (!j.contains(key)) return;
    const auto& v = j.at(key);
    if (!v.is_array()) config_error(source, key, "expected a list of integers");
    out.clear();
    for (const auto& e : v) {
      if (!e.is_number_integer()) config_error(source, key, "expected a list of integers");
      const auto x = e.get<long long>();
      if (x < 0 || x > 1000000) config_error(source, key, "channel count out of range");
      out.push_back(static_cast<int>(x));
    }
  };

  if (j.contains("skeleton")) c.skeleton = get_string("skeleton");
  get_int("window", c.window);
  get_int("horizon", c.horizon);
  get_double("rate_hz", c.rate_hz);
  get_list("encoder_channels", c.encoder_channels);
  get_list("denoise_decoder_channels", c.denoise_decoder_channels);
  get_list("predict_decoder_channels", c.predict_decoder_channels);
  get_int("temporal_kernel", c.temporal_kernel);
  if (j.contains("padding")) {
    const auto s = get_string("padding");
    if (s == "causal") c.padding = StgaePadding::Causal;
    else if (s == "centred" || s == "centered") c.padding = StgaePadding::Centred;
    else config_error(source, "padding", "expected \"causal\" or \"centred\", got \"" + s + "\"");
  }
  if (j.contains("attention")) {
    const auto s = get_string("attention");
    if (s == "A") c.attention = StgaeAttention::A;
    else if (s == "A+B") c.attention = StgaeAttention::AB;
    else if (s == "A+B+C") c.attention = StgaeAttention::ABC;
    else config_error(source, "attention", "expected \"A\", \"A+B\" or \"A+B+C\", got \"" + s + "\"");
  }
  if (j.contains("c_variant")) {
    const auto s = get_string("c_variant");
    if (s == "dot") c.c_variant = StgaeCVariant::Dot;
    else if (s == "gat") c.c_variant = StgaeCVariant::Gat;
    else config_error(source, "c_variant", "expected \"dot\" or \"gat\", got \"" + s + "\"");
  }
  get_bool("gates", c.gates);
  if (dgn) c.gates = false;
  get_bool("predict", c.predict);
  if (j.contains("temporal")) {
    const auto s = get_string("temporal");
    if (s == "lstm") c.temporal = DgnTemporal::Lstm;
    else if (s == "tcn") c.temporal = DgnTemporal::Tcn;
    else config_error(source, "temporal", "expected \"lstm\" or \"tcn\", got \"" + s + "\"");
  }
  get_int("temporal_layers", c.temporal_layers);
  get_double("shape_scale_m", c.shape_scale_m);
  get_double("velocity_scale_m", c.velocity_scale_m);
  if (j.contains("meta")) {
    if (!j.at("meta").is_object()) config_error(source, "meta", "expected a JSON object");
    c.meta_json = j.at("meta").dump();
  }
  validate_stgae_config(c, source);
  return c;
}

bool same_network(const StgaeConfig& a, const StgaeConfig& b) {
  StgaeConfig x = a, y = b;
  x.meta_json.clear();
  y.meta_json.clear();
  return to_json(x) == to_json(y);
}

std::string to_json(const StgaeConfig& c) {
  json j;
  const bool dgn = c.family == StgaeFamily::Dgn;
  if (dgn) j["family"] = "dgn";
  j["skeleton"] = c.skeleton;
  j["window"] = c.window;
  j["horizon"] = c.horizon;
  j["rate_hz"] = c.rate_hz;
  j["encoder_channels"] = c.encoder_channels;
  j["denoise_decoder_channels"] = c.denoise_decoder_channels;
  j["predict_decoder_channels"] = c.predict_decoder_channels;
  j["temporal_kernel"] = c.temporal_kernel;
  j["padding"] = padding_name(c.padding);
  if (!dgn) {
    j["attention"] = attention_name(c.attention);
    j["c_variant"] = c_variant_name(c.c_variant);
    j["gates"] = c.gates;
  }
  j["predict"] = c.predict;
  if (dgn) {
    j["temporal"] = c.temporal == DgnTemporal::Lstm ? "lstm" : "tcn";
    j["temporal_layers"] = c.temporal_layers;
  }
  j["shape_scale_m"] = c.shape_scale_m;
  j["velocity_scale_m"] = c.velocity_scale_m;
  j["meta"] = c.meta_json.empty() ? json::object() : json::parse(c.meta_json);
  return j.dump(2);
}

void validate_stgae_config(const StgaeConfig& c, const std::string& source) {
  try {
    (void)skeleton_by_name(c.skeleton);
  } catch (const std::invalid_argument& e) {
    config_error(source, "skeleton", e.what());
  }
  if (c.window < 1 || c.window > 4096) config_error(source, "window", "must be in [1, 4096]");
  if (c.predict && (c.horizon < 1 || c.horizon > 1024)) config_error(source, "horizon", "must be in [1, 1024]");
  if (c.centred_head() && c.horizon > c.window)
    config_error(source, "horizon", "the centred prediction head needs horizon <= window");
  if (!(c.rate_hz > 0.0 && c.rate_hz <= 1000.0)) config_error(source, "rate_hz", "must be in (0, 1000]");
  if (c.temporal_kernel < 1 || c.temporal_kernel % 2 == 0 || c.temporal_kernel > 255)
    config_error(source, "temporal_kernel", "must be odd and in [1, 255]");
  if (!(c.shape_scale_m > 0.0 && std::isfinite(c.shape_scale_m)))
    config_error(source, "shape_scale_m", "must be positive");
  if (!(c.velocity_scale_m > 0.0 && std::isfinite(c.velocity_scale_m)))
    config_error(source, "velocity_scale_m", "must be positive");
  auto check_list = [&](const char* key, const std::vector<int>& v, int first, int last) {
    if (v.size() < 2 || v.size() > 64) config_error(source, key, "needs 2 to 64 entries (input and output widths)");
    for (int x : v)
      if (x < 1 || x > 4096) config_error(source, key, "channel counts must be in [1, 4096]");
    if (first > 0 && v.front() != first)
      config_error(source, key, "first entry must be " + std::to_string(first) + ", got " + std::to_string(v.front()));
    if (last > 0 && v.back() != last)
      config_error(source, key, "last entry must be " + std::to_string(last) + ", got " + std::to_string(v.back()));
  };
  check_list("encoder_channels", c.encoder_channels, 6, 0);
  check_list("denoise_decoder_channels", c.denoise_decoder_channels, c.encoder_channels.back(), 3);
  if (c.predict) check_list("predict_decoder_channels", c.predict_decoder_channels, c.encoder_channels.back(), 3);
  if (c.family == StgaeFamily::Dgn) {
    if (c.gates) config_error(source, "gates", "the dgn family has no gates");
    const Skeleton& sk = skeleton_by_name(c.skeleton);
    if (static_cast<int>(sk.bones.size()) != sk.joint_count() - 1 ||
        std::count(sk.parent.begin(), sk.parent.end(), -1) != 1)
      config_error(source, "skeleton", "the dgn family needs a tree (one root, one bone per other joint)");
    if (c.temporal_layers < 0 || c.temporal_layers > 16) config_error(source, "temporal_layers", "must be in [0, 16]");
    if (c.temporal == DgnTemporal::Lstm && c.padding == StgaePadding::Centred && c.latent_channels() % 2 != 0)
      config_error(source, "encoder_channels", "a bidirectional LSTM needs an even latent width (half per direction)");
  }
  try {
    const auto m = json::parse(c.meta_json.empty() ? std::string("{}") : c.meta_json);
    if (!m.is_object()) config_error(source, "meta", "expected a JSON object");
  } catch (const json::exception& e) {
    config_error(source, "meta", std::string("invalid JSON: ") + e.what());
  }
}

std::size_t TensorSpec::numel() const {
  std::size_t n = 1;
  for (int d : shape) n *= static_cast<std::size_t>(d);
  return n;
}

std::vector<TensorSpec> stgae_tensor_specs(const StgaeConfig& c) {
  std::vector<TensorSpec> out;
  for (auto& node : stgae_topology(c)) std::move(node.tensors.begin(), node.tensors.end(), std::back_inserter(out));
  return out;
}

const Tensor& StgaeWeights::at(std::string_view name) const {
  auto it = tensors.find(name);
  if (it == tensors.end()) throw std::out_of_range("missing tensor '" + std::string(name) + "'");
  return it->second;
}

std::string shape_text(const std::vector<int>& s) {
  std::string t = "[";
  for (size_t i = 0; i < s.size(); ++i) t += (i ? ", " : "") + std::to_string(s[i]);
  return t + "]";
}

void check_stgae_weights(const StgaeConfig& config, const StgaeWeights& w, const std::string& source) {
  std::set<std::string, std::less<>> expected;
  for (const StgaeNode& node : stgae_topology(config)) {
    check_node_tensors(node, w, source);
    for (const TensorSpec& s : node.tensors) {  // present, of their shape: now their values
      expected.insert(s.name);
      const Tensor& t = w.tensors.find(s.name)->second;
      for (float v : t.data)
        if (!std::isfinite(v)) throw InputError(SourceLocation{source, 0, s.name}, "non-finite value");
      if (s.name.ends_with("running_var"))
        for (float v : t.data)
          if (v < 0.0f) throw InputError(SourceLocation{source, 0, s.name}, "negative running variance");
    }
  }
  for (const auto& [name, t] : w.tensors)
    if (!expected.contains(name))
      throw InputError(SourceLocation{source, 0, name}, "unexpected tensor for this configuration");
}

StgaeWeights random_stgae_weights(const StgaeConfig& config, std::uint64_t seed, double scale) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  StgaeWeights w;
  for (const auto& s : stgae_tensor_specs(config)) {
    Tensor t;
    t.shape = s.shape;
    t.data.resize(s.numel());
    const std::string& n = s.name;
    // fan_in of a conv weight [out, in(, k)] is in * k.
    double fan_in = 1.0;
    for (size_t i = 1; i < s.shape.size(); ++i) fan_in *= s.shape[i];
    for (float& v : t.data) {
      double x = u(rng);
      if (n.ends_with("bn.weight")) x = 1.0 + 0.2 * x;
      else if (n.ends_with("bn.bias") || n.ends_with("running_mean")) x = 0.1 * x;
      else if (n.ends_with("running_var")) x = 1.0 + 0.5 * x;
      else if (n.ends_with(".B")) x = 0.1 * x;
      else if (n.ends_with(".bias")) x = 0.1 * x;
      else x = scale * x / std::sqrt(fan_in);
      v = static_cast<float>(x);
    }
    w.tensors.emplace(n, std::move(t));
  }
  return w;
}

std::vector<float> synthetic_hand_input(const StgaeConfig& config, int frames, std::uint64_t seed) {
  // A rest hand (joints spread around the wrist) moving on a smooth path, with jitter.
  const int N = config.joint_count();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> rest(static_cast<size_t>(N) * 3);
  for (auto& v : rest) v = 0.05 * u(rng);
  const double ph = u(rng) * 3.0;
  std::vector<float> out(static_cast<size_t>(frames) * static_cast<size_t>(N) * 3);
  for (int t = 0; t < frames; ++t) {
    const double s = t / config.rate_hz;
    const double cx = 0.1 * std::sin(2.0 * s + ph), cy = 1.2 + 0.05 * std::cos(3.0 * s), cz = -0.4 + 0.03 * s;
    for (int j = 0; j < N; ++j) {
      const size_t o = (static_cast<size_t>(t) * static_cast<size_t>(N) + static_cast<size_t>(j)) * 3;
      const size_t r = static_cast<size_t>(j) * 3;
      out[o + 0] = static_cast<float>(cx + rest[r + 0] + noise(rng));
      out[o + 1] = static_cast<float>(cy + rest[r + 1] + noise(rng));
      out[o + 2] = static_cast<float>(cz + rest[r + 2] + noise(rng));
    }
  }
  return out;
}

}  // namespace hs
