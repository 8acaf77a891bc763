// Multi-STGAE training loop: config parsing, batches, losses, the two-step schedule,
// validation metrics, model selection, checkpoints and .hsm export.
#include "trainer.hpp"

#include "stgae_torch.hpp"

#include "handsteady/corrupt.hpp"
#include "handsteady/error.hpp"
#include "handsteady/hsm_format.hpp"
#include "handsteady/metrics.hpp"
#include "handsteady/skeleton.hpp"
#include "handsteady/synth.hpp"

#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace hs::train {

// ---- config ----------------------------------------------------------------------------

namespace {

// Ordered: keyed source lists and mixes are taken in the order the config gives them, and
// a merge patch keeps a base's keys where they were.
using json = nlohmann::ordered_json;

[[noreturn]] void config_error(const std::string& source, const std::string& key, const std::string& what) {
  throw InputError(SourceLocation{source, 0, key}, what);
}

// Reads a JSON object's members by key with type checks; unknown keys are errors.
class Section {
 public:
  Section(const json& parent, const std::string& name, const std::string& source) : source_(source), path_(name) {
    if (!parent.contains(name)) return;
    obj_ = &parent.at(name);
    if (!obj_->is_object()) config_error(source_, path_, "expected a JSON object");
  }
  template <class T>
  void get(const std::string& key, T& out) {
    seen_.push_back(key);
    if (!obj_ || !obj_->contains(key)) return;
    try {
      out = obj_->at(key).get<T>();
    } catch (const json::exception&) {
      config_error(source_, path_ + "." + key, "wrong type");
    }
  }
  const json* raw(const std::string& key) {
    seen_.push_back(key);
    return obj_ && obj_->contains(key) ? &obj_->at(key) : nullptr;
  }
  void finish() const {
    if (!obj_) return;
    for (const auto& [k, v] : obj_->items())
      if (std::find(seen_.begin(), seen_.end(), k) == seen_.end())
        config_error(source_, path_ + "." + k, "unknown key");
  }
  std::string key(const std::string& k) const { return path_ + "." + k; }

 private:
  std::string source_, path_;
  const json* obj_ = nullptr;
  std::vector<std::string> seen_;
};

void check_presets(const std::vector<std::string>& names, const std::string& source, const std::string& key) {
  for (const auto& n : names) {
    try {
      (void)parse_preset_chain(n);
    } catch (const std::invalid_argument& e) {
      config_error(source, key, e.what());
    }
  }
}

// The entries of a list the config may give as an array or, so that a derived config can
// change or drop one entry by name (merge patch), as an object keyed by name. Either way in
// the order given, each with the key path errors name.
std::vector<std::pair<std::string, const json*>> entries(const json& list, const std::string& source,
                                                         const std::string& key, const char* what) {
  if (!(list.is_array() || list.is_object()) || list.empty())
    config_error(source, key, std::string("expected a non-empty array or object of ") + what);
  std::vector<std::pair<std::string, const json*>> out;
  if (list.is_array())
    for (size_t i = 0; i < list.size(); ++i) out.emplace_back(key + "[" + std::to_string(i) + "]", &list[i]);
  else
    for (const auto& [name, v] : list.items()) out.emplace_back(key + "." + name, &v);
  return out;
}

// [{"fpha": root, "subjects": [1, 2]}, {"path": p, "include": [..], "exclude": [..]}, ...]
// or {"name": {...}, ...}, each with an optional "weight".
std::vector<DataSource> parse_sources(const json& list, const std::string& source, const std::string& key) {
  std::vector<DataSource> out;
  for (const auto& [k, ep] : entries(list, source, key, "sources")) {
    const json& e = *ep;
    if (!e.is_object()) config_error(source, k, "expected {\"fpha\": root, \"subjects\": [...]} or {\"path\": ...}");
    DataSource d;
    try {
      for (const auto& [name, v] : e.items()) {
        if (name == "fpha") {
          d.fpha = true;
          d.path = v.get<std::string>();
        } else if (name == "path") {
          d.path = v.get<std::string>();
        } else if (name == "subjects") {
          d.subjects = v.get<std::vector<int>>();
        } else if (name == "include") {
          d.include = v.get<std::vector<std::string>>();
        } else if (name == "exclude") {
          d.exclude = v.get<std::vector<std::string>>();
        } else if (name == "weight") {
          d.weight = v.get<double>();
        } else {
          config_error(source, k + "." + name, "unknown key");
        }
      }
    } catch (const json::exception&) {
      config_error(source, k, "wrong type");
    }
    if (e.contains("fpha") == e.contains("path")) config_error(source, k, "give exactly one of fpha and path");
    if (d.fpha && d.subjects.empty()) config_error(source, k + ".subjects", "FPHA needs subject numbers");
    if (!d.fpha && e.contains("subjects")) config_error(source, k + ".subjects", "only for fpha sources");
    if (!(d.weight > 0 && std::isfinite(d.weight))) config_error(source, k + ".weight", "must be positive");
    out.push_back(std::move(d));
  }
  return out;
}

// Config text as a JSON object, or an InputError naming the source.
json parse_config_object(std::string_view text, const std::string& source) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(SourceLocation{source, 0, ""}, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object()) config_error(source, "", "expected a JSON object");
  return j;
}

TrainConfig config_from_object(const json& j, const std::string& source, std::string text);

}  // namespace

TrainConfig parse_train_config(std::string_view text, const std::string& source) {
  return config_from_object(parse_config_object(text, source), source, std::string(text));
}

namespace {

// `text` is what the model's meta keeps.
TrainConfig config_from_object(const json& j, const std::string& source, std::string text) {
  if (j.contains("base"))
    config_error(source, "base", "a base config is resolved only when reading a config file (read_train_config)");
  for (const auto& [k, v] : j.items())
    if (k != "model" && k != "data" && k != "augment" && k != "corruption" && k != "train" && k != "loss")
      config_error(source, k, "unknown key (expected model, data, augment, corruption, train, loss)");
  TrainConfig c;
  c.json = std::move(text);
  if (!j.contains("model")) config_error(source, "model", "missing (the network configuration)");
  c.model = parse_stgae_config(j.at("model").dump(), source);
  if (c.model.skeleton != "xr26") config_error(source, "model.skeleton", "training data is xr26 only");

  Section data(j, "data", source);
  std::string root = "../shared/data/fpha";
  std::vector<int> train_subjects{1, 2, 3, 4}, val_subjects{5};
  const bool legacy = data.raw("root") || data.raw("train_subjects") || data.raw("val_subjects");
  data.get("root", root);
  data.get("train_subjects", train_subjects);
  data.get("val_subjects", val_subjects);
  const json* train_src = data.raw("train");
  const json* val_src = data.raw("val");
  data.get("split_speed_mps", c.split_speed_mps);
  data.get("synthetic_takes", c.synthetic_takes);
  data.get("synthetic_seconds", c.synthetic_seconds);
  data.finish();
  if (c.synthetic_takes < 0 || c.synthetic_takes > 10000) config_error(source, "data.synthetic_takes", "must be in [0, 10000]");
  if (!(c.synthetic_seconds > 0)) config_error(source, "data.synthetic_seconds", "must be positive");
  if (!(c.split_speed_mps >= 0 && std::isfinite(c.split_speed_mps))) config_error(source, "data.split_speed_mps", "must be finite and >= 0");
  if (legacy && (train_src || val_src))
    config_error(source, "data", "give either root/train_subjects/val_subjects (FPHA) or train/val source lists");
  if (legacy || (!train_src && !val_src)) {
    if (c.synthetic_takes == 0 && (train_subjects.empty() || val_subjects.empty()))
      config_error(source, "data.train_subjects", "train and validation subjects must not be empty");
    for (int a : train_subjects)
      if (std::find(val_subjects.begin(), val_subjects.end(), a) != val_subjects.end())
        config_error(source, "data.val_subjects", "subject " + std::to_string(a) + " is in both train and validation");
    c.train_sources = {fpha_source(root, train_subjects)};
    c.val_sources = {fpha_source(root, val_subjects)};
  } else {
    if (!train_src || !val_src) config_error(source, "data", "train and val source lists go together");
    c.train_sources = parse_sources(*train_src, source, "data.train");
    c.val_sources = parse_sources(*val_src, source, "data.val");
  }

  Section aug(j, "augment", source);
  aug.get("rotate", c.augment.rotate);
  aug.get("translate_m", c.augment.translate_m);
  std::vector<double> scale{c.augment.scale_min, c.augment.scale_max};
  aug.get("scale", scale);
  aug.get("mirror_prob", c.augment.mirror_prob);
  aug.get("speed_factors", c.augment.speed_factors);
  aug.get("shape_prob", c.augment.shape_prob);
  aug.get("still_prob", c.augment.still_prob);
  aug.finish();
  for (const auto& [k, v] : {std::pair{"shape_prob", c.augment.shape_prob}, std::pair{"still_prob", c.augment.still_prob}})
    if (!(v >= 0 && v <= 1)) config_error(source, std::string("augment.") + k, "must be in [0, 1]");
  if (scale.size() != 2 || !(scale[0] > 0) || !(scale[1] >= scale[0]))
    config_error(source, "augment.scale", "expected [min, max] with 0 < min <= max");
  c.augment.scale_min = scale[0];
  c.augment.scale_max = scale[1];
  if (!(c.augment.translate_m >= 0)) config_error(source, "augment.translate_m", "must be >= 0");
  if (!(c.augment.mirror_prob >= 0 && c.augment.mirror_prob <= 1)) config_error(source, "augment.mirror_prob", "must be in [0, 1]");
  if (c.augment.speed_factors.empty()) config_error(source, "augment.speed_factors", "must not be empty");
  for (double s : c.augment.speed_factors)
    if (!(s >= 0.25 && s <= 4)) config_error(source, "augment.speed_factors", "each must be in [0.25, 4]");

  Section cor(j, "corruption", source);
  // [{"presets": "tracker+tremor", "weight": 1}, ...] or {"tracker+tremor": 1, ...}.
  if (const json* mix = cor.raw("mix")) {
    for (const auto& [key, ep] : entries(*mix, source, cor.key("mix"), "corruption presets")) {
      const json& e = *ep;
      CorruptionMixEntry m;
      std::string chain;
      if (mix->is_object()) {
        if (!e.is_number()) config_error(source, key, "expected a weight (the key is the preset chain)");
        chain = key.substr(cor.key("mix").size() + 1);
        m.weight = e.get<double>();
      } else {
        if (!e.is_object() || !e.contains("presets") || !e.at("presets").is_string())
          config_error(source, key, "expected {\"presets\": \"tracker+tremor\", \"weight\": 1}");
        for (const auto& [k, v] : e.items())
          if (k != "presets" && k != "weight") config_error(source, key + "." + k, "unknown key");
        chain = e.at("presets").get<std::string>();
        if (e.contains("weight")) {
          if (!e.at("weight").is_number()) config_error(source, key + ".weight", "wrong type");
          m.weight = e.at("weight").get<double>();
        }
      }
      try {
        m.presets = parse_preset_chain(chain);
      } catch (const std::invalid_argument& ex) {
        config_error(source, mix->is_object() ? key : key + ".presets", ex.what());
      }
      if (!(m.weight >= 0 && std::isfinite(m.weight)))
        config_error(source, mix->is_object() ? key : key + ".weight", "must be finite and >= 0");
      c.mix.push_back(std::move(m));
    }
  }
  cor.get("val_presets", c.val_presets);
  cor.get("val_seed", c.val_seed);
  cor.get("val_stride", c.val_stride);
  cor.finish();
  check_presets(c.val_presets, source, "corruption.val_presets");
  if (c.val_presets.empty()) config_error(source, "corruption.val_presets", "must not be empty");
  if (c.val_stride < 0) config_error(source, "corruption.val_stride", "must be >= 0");
  if (c.mix.empty())
    for (const char* p : {"tracker", "paper", "tremor", "tremor-physiological"}) c.mix.push_back({{p}, 1.0});

  Section tr(j, "train", source);
  tr.get("seed", c.seed);
  tr.get("epochs", c.epochs);
  tr.get("denoise_only_epochs", c.denoise_only_epochs);
  tr.get("batch", c.batch);
  tr.get("windows_per_epoch", c.windows_per_epoch);
  tr.get("sequence", c.sequence);
  tr.get("predict_frames", c.predict_frames);
  if (const json* lr = tr.raw("lr")) {
    c.lr.clear();
    if (!lr->is_array() || lr->empty()) config_error(source, "train.lr", "expected [[first_epoch, rate], ...]");
    for (const auto& e : *lr) {
      if (!e.is_array() || e.size() != 2 || !e[0].is_number_integer() || !e[1].is_number())
        config_error(source, "train.lr", "expected [[first_epoch, rate], ...]");
      c.lr.emplace_back(e[0].get<int>(), e[1].get<double>());
    }
  }
  tr.get("grad_clip", c.grad_clip);
  tr.get("threads", c.threads);
  tr.get("freeze_graph_epochs", c.freeze_graph_epochs);
  tr.finish();
  if (c.freeze_graph_epochs < 0) config_error(source, "train.freeze_graph_epochs", "must be >= 0");
  if (c.freeze_graph_epochs > 0 && c.model.family != StgaeFamily::Dgn)
    config_error(source, "train.freeze_graph_epochs", "applies to the dgn family only");
  if (c.epochs < 1 || c.epochs > 100000) config_error(source, "train.epochs", "must be >= 1");
  if (c.denoise_only_epochs < 0) config_error(source, "train.denoise_only_epochs", "must be >= 0");
  if (c.batch < 2 || c.batch > 65536) config_error(source, "train.batch", "must be in [2, 65536] (BatchNorm needs 2)");
  if (c.windows_per_epoch < c.batch) config_error(source, "train.windows_per_epoch", "must be >= batch");
  if (c.lr.front().first != 0) config_error(source, "train.lr", "the first entry must start at epoch 0");
  for (size_t i = 0; i < c.lr.size(); ++i) {
    if (!(c.lr[i].second > 0 && c.lr[i].second < 10)) config_error(source, "train.lr", "rates must be in (0, 10)");
    if (i && c.lr[i].first <= c.lr[i - 1].first) config_error(source, "train.lr", "epochs must increase");
  }
  if (!(c.grad_clip >= 0)) config_error(source, "train.grad_clip", "must be >= 0");
  if (c.threads < 0 || c.threads > 256) config_error(source, "train.threads", "must be in [0, 256]");
  if (c.sequence != 0 && (c.sequence < c.model.window || c.sequence > 1024))
    config_error(source, "train.sequence", "must be 0 (the window) or in [model.window, 1024]");
  if (c.predict_frames < 1 || (c.predict_frames > 1 && c.predict_frames >= c.sequence_length()))
    config_error(source, "train.predict_frames", "must be 1 or in [2, the sequence length - 1]");
  if (c.predict_frames > 1 && c.model.padding != StgaePadding::Causal)
    config_error(source, "train.predict_frames", "predictions at several frames need a causal model");

  Section lo(j, "loss", source);
  lo.get("pose", c.loss.pose);
  lo.get("bone", c.loss.bone);
  lo.get("symmetry", c.loss.symmetry);
  lo.get("smooth", c.loss.smooth);
  lo.get("predict", c.loss.predict);
  lo.get("predict_smooth", c.loss.predict_smooth);
  lo.get("relative_eps_mm", c.loss.relative_eps_mm);
  if (const json* st = lo.raw("stages")) {
    if (!st->is_array()) config_error(source, "loss.stages", "expected [{\"epoch\": e, \"bone\": w, ...}, ...]");
    for (size_t i = 0; i < st->size(); ++i) {
      const json& e = (*st)[i];
      const std::string key = "loss.stages[" + std::to_string(i) + "]";
      if (!e.is_object() || !e.contains("epoch") || !e.at("epoch").is_number_integer())
        config_error(source, key, "expected {\"epoch\": e, \"bone\": w, ...}");
      LossWeights w = c.loss;
      const std::map<std::string, double*> fields = {{"pose", &w.pose},     {"bone", &w.bone},
                                                     {"symmetry", &w.symmetry}, {"smooth", &w.smooth},
                                                     {"predict", &w.predict}, {"predict_smooth", &w.predict_smooth}};
      for (const auto& [k, v] : e.items()) {
        if (k == "epoch") continue;
        const auto it = fields.find(k);
        if (it == fields.end()) config_error(source, key + "." + k, "unknown key");
        if (!v.is_number() || !(v.get<double>() >= 0) || !std::isfinite(v.get<double>()))
          config_error(source, key + "." + k, "expected a finite weight >= 0");
        *it->second = v.get<double>();
      }
      const int first = e.at("epoch").get<int>();
      if (first < 0 || (!c.loss_stages.empty() && first <= c.loss_stages.back().first))
        config_error(source, key + ".epoch", "epochs must be >= 0 and increase");
      c.loss_stages.emplace_back(first, w);
    }
  }
  lo.finish();
  if (!(c.loss.relative_eps_mm >= 0 && std::isfinite(c.loss.relative_eps_mm)))
    config_error(source, "loss.relative_eps_mm", "must be finite and >= 0");
  for (double w : {c.loss.pose, c.loss.bone, c.loss.symmetry, c.loss.smooth, c.loss.predict, c.loss.predict_smooth})
    if (!(w >= 0 && std::isfinite(w))) config_error(source, "loss", "weights must be finite and >= 0");
  return c;
}

// A config file with its "base" chain resolved: the base (a path relative to the file's
// folder) is read first and the file is applied to it as an RFC 7386 merge patch
// (objects merge key by key, anything else, arrays included, replaces; null removes).
// So an ablation names the config it varies and only the keys it changes.
json resolve_config_file(const std::filesystem::path& path, std::vector<std::filesystem::path>& chain) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    const std::string from = chain.empty() ? "" : " (the base of " + chain.back().string() + ")";
    throw InputError(SourceLocation{path.string(), 0, ""}, "cannot open the training config" + from);
  }
  std::ostringstream s;
  s << f.rdbuf();
  json j = parse_config_object(s.str(), path.string());
  if (!j.contains("base")) return j;
  const json& b = j.at("base");
  if (!b.is_string() || b.get<std::string>().empty())
    config_error(path.string(), "base", "expected the path of another config (relative to this file's folder)");
  const std::filesystem::path base = path.parent_path() / b.get<std::string>();
  chain.push_back(path);
  for (const auto& p : chain)
    if (std::filesystem::weakly_canonical(p) == std::filesystem::weakly_canonical(base))
      config_error(path.string(), "base", "names a config already in its own chain of bases: " + base.string());
  json merged = resolve_config_file(base, chain);
  chain.pop_back();
  j.erase("base");
  merged.merge_patch(j);
  return merged;
}

}  // namespace

TrainConfig read_train_config(const std::filesystem::path& path) {
  std::vector<std::filesystem::path> chain;
  const json resolved = resolve_config_file(path, chain);
  // The resolved config is what the model's meta keeps: the full recipe, not the patch.
  return config_from_object(resolved, path.string(), resolved.dump(2));
}

LossWeights TrainConfig::loss_at(int epoch) const {
  LossWeights w = loss;
  for (const auto& [first, stage] : loss_stages)
    if (epoch >= first) w = stage;
  return w;
}

double learning_rate(const TrainConfig& config, int epoch) {
  double lr = config.lr.front().second;
  for (const auto& [first, rate] : config.lr)
    if (epoch >= first) lr = rate;
  return lr;
}

// ---- batches ---------------------------------------------------------------------------

namespace {

constexpr int N = kJointCount;
constexpr double kCm2 = 1e4;  // m^2 -> cm^2

// Tensors of a batch, float32. Positions are relative to each window's last filled wrist
// (the model is translation invariant, and float32 keeps full precision near zero).
struct Batch {
  torch::Tensor feat;   // [B, T, N, 6]
  torch::Tensor x;      // [B, T, N, 3] filled input
  torch::Tensor truth;  // [B, T + DT, N, 3]
  std::vector<Eigen::RowVector3d> origin;  // per window, added back for metrics
};

class BatchBuilder {
 public:
  // frames: input frames per window (the model window, or a longer training sequence).
  BatchBuilder(const StgaeConfig& c, int frames, int capacity)
      : c_(c), T_(frames), DT_(c.predict ? c.horizon : 0),
        feat_(static_cast<size_t>(T_) * N * 6), filled_(static_cast<size_t>(T_) * N * 3) {
    reserve(capacity);
  }
  void reserve(int capacity) {
    fbuf_.reserve(static_cast<size_t>(capacity) * feat_.size());
    xbuf_.reserve(static_cast<size_t>(capacity) * filled_.size());
    tbuf_.reserve(static_cast<size_t>(capacity) * (T_ + DT_) * N * 3);
  }
  // false when the window is not valid input (nothing tracked in its first frame).
  bool add(const Window& w) {
    if (!input_features(w.input, c_.shape_scale_m, c_.velocity_scale_m, feat_.data(), filled_.data())) return false;
    const size_t last = static_cast<size_t>(T_ - 1) * N * 3 + static_cast<size_t>(idx(Joint::Wrist)) * 3;
    const Eigen::RowVector3d o(filled_[last], filled_[last + 1], filled_[last + 2]);
    origin_.push_back(o);
    for (double v : feat_) fbuf_.push_back(static_cast<float>(v));
    for (size_t i = 0; i < filled_.size(); ++i) xbuf_.push_back(static_cast<float>(filled_[i] - o[static_cast<long>(i % 3)]));
    for (int t = 0; t < T_ + DT_; ++t)
      for (int j = 0; j < N; ++j)
        for (int k = 0; k < 3; ++k) tbuf_.push_back(static_cast<float>(w.truth[static_cast<size_t>(t)](j, k) - o[k]));
    return true;
  }
  int size() const { return static_cast<int>(origin_.size()); }
  Batch take() {
    const int64_t B = size();
    Batch b;
    b.feat = torch::from_blob(fbuf_.data(), {B, T_, N, 6}, torch::kFloat32).clone();
    b.x = torch::from_blob(xbuf_.data(), {B, T_, N, 3}, torch::kFloat32).clone();
    b.truth = torch::from_blob(tbuf_.data(), {B, T_ + DT_, N, 3}, torch::kFloat32).clone();
    b.origin = std::move(origin_);
    origin_.clear();
    fbuf_.clear();
    xbuf_.clear();
    tbuf_.clear();
    return b;
  }

 private:
  const StgaeConfig& c_;
  int T_, DT_;
  std::vector<double> feat_, filled_;
  std::vector<float> fbuf_, xbuf_, tbuf_;
  std::vector<Eigen::RowVector3d> origin_;
};

// ---- losses ----------------------------------------------------------------------------

torch::Tensor edge_index(const std::vector<Edge>& edges, bool first) {
  std::vector<int64_t> v;
  for (const auto& e : edges) v.push_back(first ? e.first : e.second);
  return torch::tensor(v, torch::kInt64);
}

// Second difference (acceleration per frame^2) along dim.
torch::Tensor second_difference(const torch::Tensor& p, int64_t dim) {
  const int64_t n = p.size(dim);
  return p.narrow(dim, 2, n - 2) - 2 * p.narrow(dim, 1, n - 2) + p.narrow(dim, 0, n - 2);
}

struct Losses {
  torch::Tensor total;
  double pose = 0, bone = 0, sym = 0, smooth = 0, pred = 0, pred_smooth = 0;
};

class LossFn {
 public:
  // The model's config (referenced: it outlives the loss) and the weights of this loss.
  LossFn(const StgaeConfig& model, const LossWeights& weights) : model_(model), w_(weights) {
    const auto& s = xr_hand_skeleton();
    bone_a_ = edge_index(s.bones, true);
    bone_b_ = edge_index(s.bones, false);
    sym_a_ = edge_index(s.symmetry, true);
    sym_b_ = edge_index(s.symmetry, false);
  }
  Losses operator()(const TorchOutput& out, const Batch& b, bool with_pred) const {
    const int T = static_cast<int>(b.x.size(1));
    const auto X = denoised_positions(model_, b.x, out);
    const auto Xt = b.truth.narrow(1, 0, T);
    Losses l;
    // Relative weighting: each window's denoising terms divided by its input's own squared
    // error (+ eps^2), normalised to mean 1 over the batch, so nearly clean windows count
    // as much as heavily corrupted ones (a model must never be worse than clean input).
    torch::Tensor w;
    if (w_.relative_eps_mm > 0) {
      torch::NoGradGuard no_grad;
      const double eps_cm = w_.relative_eps_mm * 0.1;
      w = 1.0 / ((b.x - Xt).pow(2).sum(-1).mean({1, 2}) * kCm2 + eps_cm * eps_cm);
      w = w / w.mean();
    }
    const auto wmean = [&w](const torch::Tensor& err) {
      if (!w.defined()) return err.mean();
      return (err.reshape({err.size(0), -1}).mean(1) * w).mean();
    };
    auto pose = wmean((X - Xt).pow(2)) * kCm2;
    auto total = w_.pose * pose;
    l.pose = pose.item<double>();
    if (w_.bone > 0) {
      auto bone = wmean(edge_error(X, Xt, bone_a_, bone_b_)) * kCm2;
      total = total + w_.bone * bone;
      l.bone = bone.item<double>();
    }
    if (w_.symmetry > 0) {
      auto sym = wmean(edge_error(X, Xt, sym_a_, sym_b_)) * kCm2;
      total = total + w_.symmetry * sym;
      l.sym = sym.item<double>();
    }
    if (w_.smooth > 0 && T >= 3) {
      auto smooth = wmean((second_difference(X, 1) - second_difference(Xt, 1)).pow(2)) * kCm2;
      total = total + w_.smooth * smooth;
      l.smooth = smooth.item<double>();
    }
    if (with_pred && model_.predict) {
      const int DT = model_.horizon;
      const auto Y = predicted_positions(model_, X, out);
      if (Y.dim() == 5) {
        // Predictions made at each of the last P frames: [B, P, DT, N, 3] against the truth
        // 1..DT frames after each.
        const int P = static_cast<int>(Y.size(1));
        const auto Yt = b.truth.narrow(1, T - P + 1, P + DT - 1).unfold(1, DT, 1).permute({0, 1, 4, 2, 3});
        auto pred = (Y - Yt).pow(2).mean() * kCm2;
        total = total + w_.predict * pred;
        l.pred = pred.item<double>();
        if (w_.predict_smooth > 0) {
          // Along each path: denoised t-1, t, then the DT predictions.
          auto path = [&](const torch::Tensor& den, const torch::Tensor& fut) {
            return torch::cat({den.narrow(1, T - P - 1, P).unsqueeze(2), den.narrow(1, T - P, P).unsqueeze(2), fut}, 2);
          };
          const auto pe = path(X, Y), pt = path(Xt, Yt);
          auto ps = (second_difference(pe, 2) - second_difference(pt, 2)).pow(2).mean();
          if (P >= 3)  // each horizon over time
            ps = ps + (second_difference(Y, 1) - second_difference(Yt, 1)).pow(2).mean();
          ps = ps * kCm2;
          total = total + w_.predict_smooth * ps;
          l.pred_smooth = ps.item<double>();
        }
      } else {
        auto pred = (Y - b.truth.narrow(1, T, DT)).pow(2).mean() * kCm2;
        total = total + w_.predict * pred;
        l.pred = pred.item<double>();
      }
    }
    l.total = total;
    return l;
  }

 private:
  static torch::Tensor lengths(const torch::Tensor& p, const torch::Tensor& a, const torch::Tensor& b) {
    // The epsilon keeps the gradient finite for (never expected) zero-length edges.
    return (p.index_select(2, a) - p.index_select(2, b)).pow(2).sum(-1).add(1e-12).sqrt();
  }
  static torch::Tensor edge_error(const torch::Tensor& X, const torch::Tensor& Xt, const torch::Tensor& a,
                                  const torch::Tensor& b) {
    return (lengths(X, a, b) - lengths(Xt, a, b)).pow(2);  // [B, T, edges], m^2
  }
  const StgaeConfig& model_;
  LossWeights w_;
  torch::Tensor bone_a_, bone_b_, sym_a_, sym_b_;
};

// ---- progress --------------------------------------------------------------------------

std::string clock_text(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long s = std::lround(seconds);
  char buf[32];
  if (s >= 3600)
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  else
    std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  return buf;
}

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// One line on stderr, redrawn in place on a terminal (every 10% otherwise).
class ProgressBar {
 public:
  ProgressBar(bool enabled, std::string label, int total, double run_eta_after)
      : enabled_(enabled), tty_(::isatty(2) != 0), label_(std::move(label)), total_(total),
        run_after_(run_eta_after), t0_(Clock::now()) {}
  void update(int done, double loss) {
    if (!enabled_) return;
    const double el = since(t0_);
    const bool last = done == total_;
    if (tty_) {
      if (!last && el - shown_ < 0.25) return;
    } else {
      const int decile = done * 10 / std::max(total_, 1);
      if (!last && decile == decile_) return;
      decile_ = decile;
    }
    shown_ = el;
    const double eta = done > 0 ? el / done * (total_ - done) : std::numeric_limits<double>::quiet_NaN();
    constexpr int kWidth = 24;
    const int fill = total_ ? done * kWidth / total_ : kWidth;
    std::string bar(static_cast<size_t>(fill), '=');
    bar.resize(kWidth, ' ');
    std::fprintf(stderr, "%s%s [%s] %d/%d loss %.4f  %s elapsed, ETA %s (run %s)%s", tty_ ? "\r" : "",
                 label_.c_str(), bar.c_str(), done, total_, loss, clock_text(el).c_str(), clock_text(eta).c_str(),
                 clock_text(eta + run_after_).c_str(), tty_ ? "\x1b[K" : "\n");
    if (tty_ && last) std::fputc('\n', stderr);
    std::fflush(stderr);
  }

 private:
  bool enabled_, tty_;
  std::string label_;
  int total_;
  double run_after_;
  Clock::time_point t0_;
  double shown_ = -1.0;
  int decile_ = -1;
};

// ---- validation ------------------------------------------------------------------------

struct ValSet {
  std::string preset;
  std::vector<Window> windows;  // valid input only
};

Pose to_pose(const float* p, const Eigen::RowVector3d& origin) {
  Pose out;
  for (int j = 0; j < N; ++j)
    for (int k = 0; k < 3; ++k) out(j, k) = static_cast<double>(p[j * 3 + k]) + origin[k];
  return out;
}

PresetMetrics validate(StgaeNetImpl& net, const TrainConfig& c, const ValSet& set, const LossFn& loss, bool with_pred,
                       double& loss_sum, double& loss_count) {
  const int T = c.sequence_length(), DT = c.model.predict ? c.model.horizon : 0;
  PresetMetrics m;
  m.preset = set.preset;
  m.windows = set.windows.size();
  std::vector<Pose> truth_all, in_all, den_all, truth_last, den_last, hold_in, hold_truth;
  std::vector<std::vector<Pose>> pred_est(static_cast<size_t>(DT)), pred_truth(static_cast<size_t>(DT));
  constexpr int kChunk = 256;
  BatchBuilder builder(c.model, T, kChunk);
  torch::NoGradGuard no_grad;
  for (size_t first = 0; first < set.windows.size(); first += kChunk) {
    const size_t end = std::min(set.windows.size(), first + kChunk);
    for (size_t i = first; i < end; ++i) builder.add(set.windows[i]);
    const Batch b = builder.take();
    const auto out = net.forward(b.feat, c.predict_frames);
    const auto l = loss(out, b, with_pred);
    const double n = static_cast<double>(b.origin.size());
    loss_sum += l.total.item<double>() * n;
    loss_count += n;
    const auto X = denoised_positions(c.model, b.x, out).contiguous();
    const auto x = b.x.contiguous();
    const auto tr = b.truth.contiguous();
    torch::Tensor Y;
    if (DT > 0) {
      Y = predicted_positions(c.model, X, out);
      if (Y.dim() == 5) Y = Y.select(1, Y.size(1) - 1);  // the newest frame's prediction
      Y = Y.contiguous();
    }
    const size_t frame = N * 3;
    for (size_t w = 0; w < b.origin.size(); ++w) {
      const auto& o = b.origin[w];
      const float* Xp = X.data_ptr<float>() + w * T * frame;
      const float* xp = x.data_ptr<float>() + w * T * frame;
      const float* tp = tr.data_ptr<float>() + w * (T + DT) * frame;
      for (int t = 0; t < T; ++t) {
        truth_all.push_back(to_pose(tp + t * frame, o));
        in_all.push_back(to_pose(xp + t * frame, o));
        den_all.push_back(to_pose(Xp + t * frame, o));
      }
      truth_last.push_back(truth_all.back());
      den_last.push_back(den_all.back());
      if (DT > 0) {
        const float* yp = Y.data_ptr<float>() + w * DT * frame;
        for (int i = 0; i < DT; ++i) {
          pred_est[static_cast<size_t>(i)].push_back(to_pose(yp + i * frame, o));
          pred_truth[static_cast<size_t>(i)].push_back(to_pose(tp + (T + i) * frame, o));
        }
        hold_in.push_back(in_all.back());
        hold_truth.push_back(pred_truth[static_cast<size_t>(DT - 1)].back());
      }
    }
  }
  if (truth_all.empty()) return m;
  m.input_mpjpe_mm = mpjpe_mm(truth_all, in_all);
  m.denoised_mpjpe_mm = mpjpe_mm(truth_all, den_all);
  m.denoised_last_mpjpe_mm = mpjpe_mm(truth_last, den_last);
  m.input_ebon_mm2 = e_bon_mm2(truth_all, in_all);
  m.denoised_ebon_mm2 = e_bon_mm2(truth_all, den_all);
  for (int i = 0; i < DT; ++i)
    m.predicted_mpjpe_mm.push_back(mpjpe_mm(pred_truth[static_cast<size_t>(i)], pred_est[static_cast<size_t>(i)]));
  if (DT > 0) m.hold_mpjpe_mm = mpjpe_mm(hold_truth, hold_in);
  return m;
}

std::string metrics_text(const PresetMetrics& m) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(2);
  s << m.preset << ": MPJPE " << m.input_mpjpe_mm << " -> " << m.denoised_mpjpe_mm << " mm (newest "
    << m.denoised_last_mpjpe_mm << "), E_bon " << m.input_ebon_mm2 << " -> " << m.denoised_ebon_mm2 << " mm^2";
  if (!m.predicted_mpjpe_mm.empty()) {
    s << ", pred";
    for (double v : m.predicted_mpjpe_mm) s << ' ' << v;
    s << " mm (hold " << m.hold_mpjpe_mm << ")";
  }
  return s.str();
}

json metrics_json(const std::vector<PresetMetrics>& ms) {
  json j = json::object();
  for (const auto& m : ms)
    j[m.preset] = {{"windows", m.windows},
                   {"input_mpjpe_mm", m.input_mpjpe_mm},
                   {"denoised_mpjpe_mm", m.denoised_mpjpe_mm},
                   {"denoised_newest_mpjpe_mm", m.denoised_last_mpjpe_mm},
                   {"input_ebon_mm2", m.input_ebon_mm2},
                   {"denoised_ebon_mm2", m.denoised_ebon_mm2},
                   {"predicted_mpjpe_mm", m.predicted_mpjpe_mm},
                   {"hold_mpjpe_mm", m.hold_mpjpe_mm}};
  return j;
}

// ---- data ------------------------------------------------------------------------------

// Clean clips of every source at the model rate (training: with the speed variants), one
// group per training source.
void load_clips(const TrainConfig& c, int min_frames, ClipSet& train, ClipSet& val) {
  const double rate = c.model.rate_hz;
  if (c.synthetic_takes > 0) {
    SynthMotionParams p;
    p.duration_s = c.synthetic_seconds;
    const int n_val = std::max(1, c.synthetic_takes / 4);
    std::vector<HandSeries> ts, vs;
    for (int i = 0; i < c.synthetic_takes; ++i) ts.push_back(synth_motion(p, Hand::Right, c.seed * 7919 + static_cast<uint64_t>(i)));
    for (int i = 0; i < n_val; ++i) vs.push_back(synth_motion(p, Hand::Right, 1000003 + c.val_seed * 7919 + static_cast<uint64_t>(i)));
    train.append(make_clips(ts, rate, c.augment.speed_factors, min_frames), 1.0);
    val.append(make_clips(vs, rate, {1.0}, min_frames), 1.0);
    return;
  }
  const double split = c.split_speed_mps;
  for (const auto& s : c.train_sources)
    train.append(make_clips(load_source(s), rate, c.augment.speed_factors, min_frames, split), s.weight);
  for (const auto& s : c.val_sources) val.append(make_clips(load_source(s), rate, {1.0}, min_frames, split), 1.0);
}

// Writes to a temporary name and renames, so an interrupted run never leaves a torn file.
template <class Write>
void write_atomically(const std::filesystem::path& path, Write&& write) {
  auto tmp = path;
  tmp += ".tmp";
  write(tmp);
  std::filesystem::rename(tmp, path);
}

void save_model(StgaeNetImpl& net, const TrainConfig& c, const std::filesystem::path& out, const Window& ref_window,
                const json& meta) {
  StgaeConfig mc = c.model;
  mc.meta_json = meta.dump();
  const StgaeWeights w = export_weights(net);
  std::vector<float> input;
  // The model's own window: the first T frames of a (possibly longer) validation sequence.
  for (size_t t = 0; t < static_cast<size_t>(c.model.window); ++t)
    for (int j = 0; j < N; ++j)
      for (int k = 0; k < 3; ++k) input.push_back(static_cast<float>(ref_window.input[t](j, k)));
  // The reference output comes from the Eigen engine, so the loader's check is exact.
  const StgaeReference ref = make_stgae_reference(mc, w, std::move(input));
  write_atomically(out, [&](const std::filesystem::path& p) { save_hsm(p, mc, w, ref); });
  (void)load_hsm(out, true);  // the file we ship must load and verify
}

}  // namespace

// ---- training --------------------------------------------------------------------------

TrainResult train_stgae(const TrainConfig& cfg, const TrainOptions& opt, std::ostream& log) {
  TrainConfig c = cfg;
  if (opt.epochs) c.epochs = *opt.epochs;
  if (opt.threads) c.threads = *opt.threads;
  if (c.threads > 0) torch::set_num_threads(c.threads);
  if (opt.out.empty()) throw std::invalid_argument("train: no output path");
  const int T = c.model.window, DT = c.model.predict ? c.model.horizon : 0;
  const auto run_t0 = Clock::now();
  torch::manual_seed(c.seed);
  std::mt19937_64 rng(c.seed);

  const int L = c.sequence_length();
  ClipSet train_clips, val_clips;
  load_clips(c, L + DT, train_clips, val_clips);
  const WindowSampler sampler(train_clips, L, DT, c.model.rate_hz, c.augment, c.mix);
  std::vector<ValSet> val;
  for (size_t i = 0; i < c.val_presets.size(); ++i) {
    ValSet v;
    v.preset = c.val_presets[i];
    auto all = fixed_windows(val_clips, L, DT, c.val_stride > 0 ? c.val_stride : L, c.model.rate_hz,
                             parse_preset_chain(c.val_presets[i]), c.val_seed + 1000 * i);
    std::vector<double> f(static_cast<size_t>(L) * N * 6), x(static_cast<size_t>(L) * N * 3);
    for (auto& w : all)
      if (input_features(w.input, c.model.shape_scale_m, c.model.velocity_scale_m, f.data(), x.data()))
        v.windows.push_back(std::move(w));
    if (v.windows.empty()) throw std::runtime_error("train: no validation window for preset " + v.preset);
    val.push_back(std::move(v));
  }
  log << "data: " << train_clips.clips.size() << " training clips (" << train_clips.frames() << " frames at "
      << c.model.rate_hz << " Hz incl. speed variants, " << sampler.window_count() << " windows), validation "
      << val_clips.frames() << " frames, " << val.front().windows.size() << " windows per preset\n";

  auto net = std::make_shared<StgaeNetImpl>(c.model);
  size_t n_params = 0;
  for (const auto& p : net->parameters()) n_params += static_cast<size_t>(p.numel());
  log << "model: " << n_params << " parameters, " << (c.model.padding == StgaePadding::Causal ? "causal" : "centred")
      << ", T " << T << ", DT " << DT << ", training sequences of " << L << " frames, threads " << torch::get_num_threads() << "\n";
  torch::optim::Adam adam(net->parameters(), torch::optim::AdamOptions(learning_rate(c, 0)));
  const LossFn loss(c.model, c.loss);  // validation: the base weights, whatever the stage
  // DGN: the incidence matrices S, T, whose gradients the first stage zeroes.
  std::vector<torch::Tensor> graph_params;
  for (const auto& p : net->named_parameters(true))
    if (p.key().ends_with(".S") || p.key().ends_with(".T")) graph_params.push_back(p.value());

  int start_epoch = 0;
  double best = std::numeric_limits<double>::infinity();
  int best_epoch = -1;
  bool best_joint = false;  // the phase `best` was measured in
  const auto ckpt = std::filesystem::path(opt.out.string() + ".ckpt");
  if (opt.resume) {
    torch::serialize::InputArchive ar;
    try {
      ar.load_from(opt.resume->string());
    } catch (const c10::Error&) {
      throw InputError(SourceLocation{opt.resume->string(), 0, ""}, "not a training checkpoint");
    }
    c10::IValue model_json, state;
    ar.read("model_config", model_json);
    if (model_json.toStringRef() != to_json(c.model))
      throw InputError(SourceLocation{opt.resume->string(), 0, "model_config"},
                       "checkpoint was trained with another model configuration");
    net->load(ar);
    torch::serialize::InputArchive oa;
    ar.read("optimizer", oa);
    adam.load(oa);
    c10::IValue v;
    ar.read("next_epoch", v);
    start_epoch = static_cast<int>(v.toInt());
    ar.read("best", v);
    best = v.toDouble();
    ar.read("best_epoch", v);
    best_epoch = static_cast<int>(v.toInt());
    ar.read("best_joint", v);
    best_joint = v.toBool();
    ar.read("rng", state);
    std::istringstream(state.toStringRef()) >> rng;
    log << "resumed from " << opt.resume->string() << " at epoch " << start_epoch << "\n";
  }

  TrainResult result;
  result.best_epoch = best_epoch;
  result.best_val_loss = best;
  const int steps = c.windows_per_epoch / c.batch;
  BatchBuilder builder(c.model, L, c.batch);
  double mean_epoch_s = std::numeric_limits<double>::quiet_NaN();
  for (int epoch = start_epoch; epoch < c.epochs; ++epoch) {
    const auto t0 = Clock::now();
    const bool joint = c.model.predict && epoch >= c.denoise_only_epochs;
    const double lr = learning_rate(c, epoch);
    for (auto& g : adam.param_groups()) static_cast<torch::optim::AdamOptions&>(g.options()).lr(lr);
    net->train();
    ProgressBar bar(opt.progress,
                    "epoch " + std::to_string(epoch + 1) + "/" + std::to_string(c.epochs) + (joint ? " [joint]" : " [denoise]"),
                    steps, std::isfinite(mean_epoch_s) ? mean_epoch_s * (c.epochs - epoch - 1) : std::numeric_limits<double>::quiet_NaN());
    double loss_sum = 0, data_s = 0;
    const LossFn train_loss(c.model, c.loss_at(epoch));
    const bool freeze_graph = epoch < c.freeze_graph_epochs;
    for (int s = 0; s < steps; ++s) {
      const auto td = Clock::now();
      while (builder.size() < c.batch) builder.add(sampler.draw(rng));
      const Batch b = builder.take();
      data_s += since(td);
      adam.zero_grad();
      const auto out = net->forward(b.feat, c.predict_frames);
      const auto l = train_loss(out, b, joint);
      l.total.backward();
      if (freeze_graph)
        for (auto& p : graph_params)
          if (p.grad().defined()) p.mutable_grad().zero_();
      if (c.grad_clip > 0) torch::nn::utils::clip_grad_norm_(net->parameters(), c.grad_clip);
      adam.step();
      const double lv = l.total.item<double>();
      if (!std::isfinite(lv)) throw std::runtime_error("train: the loss became non-finite at epoch " + std::to_string(epoch + 1));
      loss_sum += lv;
      bar.update(s + 1, loss_sum / (s + 1));
    }

    const double train_s = since(t0);
    net->eval();
    EpochReport rep;
    rep.epoch = epoch;
    rep.joint_phase = joint;
    rep.lr = lr;
    rep.train_loss = loss_sum / std::max(steps, 1);
    double vsum = 0, vcount = 0;
    for (const auto& v : val) rep.val.push_back(validate(*net, c, v, loss, joint, vsum, vcount));
    rep.val_loss = vsum / std::max(vcount, 1.0);
    const double val_s = since(t0) - train_s;
    // Model selection on validation only, within the current phase (the objective changes).
    if (joint != best_joint) {
      best = std::numeric_limits<double>::infinity();
      best_joint = joint;
    }
    rep.best = rep.val_loss < best;
    rep.seconds = since(t0);
    if (rep.best) {
      best = rep.val_loss;
      best_epoch = epoch;
      json meta = {{"training", json::parse(c.json.empty() ? "{}" : c.json)},
                   {"epoch", epoch + 1},
                   {"phase", joint ? "joint" : "denoise"},
                   {"val_loss", rep.val_loss},
                   {"validation", metrics_json(rep.val)},
                   {"wall_s", since(run_t0)},
                   {"threads", torch::get_num_threads()}};
      save_model(*net, c, opt.out, val.front().windows.front(), meta);
    }
    {
      torch::serialize::OutputArchive ar;
      net->save(ar);
      torch::serialize::OutputArchive oa;
      adam.save(oa);
      ar.write("optimizer", oa);
      ar.write("model_config", c10::IValue(to_json(c.model)));
      ar.write("next_epoch", c10::IValue(static_cast<int64_t>(epoch + 1)));
      ar.write("best", c10::IValue(best));
      ar.write("best_epoch", c10::IValue(static_cast<int64_t>(best_epoch)));
      ar.write("best_joint", c10::IValue(best_joint));
      std::ostringstream rs;
      rs << rng;
      ar.write("rng", c10::IValue(rs.str()));
      write_atomically(ckpt, [&](const std::filesystem::path& p) { ar.save_to(p.string()); });
    }
    rep.seconds = since(t0);
    mean_epoch_s = std::isfinite(mean_epoch_s) ? 0.5 * (mean_epoch_s + rep.seconds) : rep.seconds;
    {
      std::ostringstream s;
      s.setf(std::ios::fixed);
      s.precision(4);
      s << "epoch " << epoch + 1 << "/" << c.epochs << (joint ? " joint" : " denoise") << " lr " << lr << " train "
        << rep.train_loss << " val " << rep.val_loss << (rep.best ? " (best, saved)" : "");
      s.precision(1);
      s << " " << rep.seconds << " s (batches " << data_s << " s, optimisation " << train_s - data_s
        << " s, validation " << val_s << " s)\n";
      for (const auto& m : rep.val) s << "  " << metrics_text(m) << "\n";
      log << s.str() << std::flush;
    }
    result.epochs.push_back(std::move(rep));
  }
  result.best_epoch = best_epoch;
  result.best_val_loss = best;
  log << "best epoch " << best_epoch + 1 << " (val " << best << "), model " << opt.out.string() << ", "
      << clock_text(since(run_t0)) << " wall\n";
  return result;
}

}  // namespace hs::train
