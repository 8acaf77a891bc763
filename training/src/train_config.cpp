// Training config: JSON text or files (with "base" chains) to TrainConfig, every key
// checked (docs/TRAINING.md "Config file"). Torch-free, so it is fuzzed on its own.
#include "train_config.hpp"

#include "handsteady/error.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <type_traits>
#include <utility>

namespace hs::train {

namespace {

// Ordered: keyed source lists and mixes are taken in the order the config gives them, and
// a merge patch keeps a base's keys where they were.
using json = nlohmann::ordered_json;

[[noreturn]] void config_error(const std::string& source, const std::string& key, const std::string& what) {
  throw InputError(SourceLocation{source, 0, key}, what);
}

template <class T>
struct IsVector : std::false_type {};
template <class U, class A>
struct IsVector<std::vector<U, A>> : std::true_type {};

// A JSON value as T, or an InputError naming the key. nlohmann's get<int>() casts any
// number it finds (5.6e113 into an int is undefined behaviour, 2^32 + 5 silently becomes 5),
// so every number is checked against the range of the type it is read into.
template <class T>
T checked(const json& v, const std::string& source, const std::string& key) {
  if constexpr (std::is_same_v<T, bool>) {
    if (!v.is_boolean()) config_error(source, key, "expected true or false");
    return v.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    const auto range = "expected an integer in [" + std::to_string(std::numeric_limits<T>::min()) + ", " +
                       std::to_string(std::numeric_limits<T>::max()) + "]";
    if (v.is_number_unsigned()) {
      const auto x = v.get<std::uint64_t>();
      if (!std::in_range<T>(x)) config_error(source, key, range);
      return static_cast<T>(x);
    }
    if (!v.is_number_integer()) config_error(source, key, range);
    const auto x = v.get<std::int64_t>();
    if (!std::in_range<T>(x)) config_error(source, key, range);
    return static_cast<T>(x);
  } else if constexpr (std::is_floating_point_v<T>) {
    if (!v.is_number()) config_error(source, key, "expected a number");
    const double x = v.get<double>();
    if (!std::isfinite(x) || std::fabs(x) > static_cast<double>(std::numeric_limits<T>::max()))
      config_error(source, key, "expected a finite number");
    return static_cast<T>(x);
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!v.is_string()) config_error(source, key, "expected a string");
    return v.get<std::string>();
  } else if constexpr (IsVector<T>::value) {
    if (!v.is_array()) config_error(source, key, "expected an array");
    T out;
    for (size_t i = 0; i < v.size(); ++i)
      out.push_back(checked<typename T::value_type>(v[i], source, key + "[" + std::to_string(i) + "]"));
    return out;
  } else {
    static_assert(IsVector<T>::value, "checked<T>: add this type");
  }
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
    out = checked<T>(obj_->at(key), source_, path_ + "." + key);
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
    for (const auto& [name, v] : e.items()) {
      const std::string at = k + "." + name;
      if (name == "fpha") {
        d.fpha = true;
        d.path = checked<std::string>(v, source, at);
      } else if (name == "path") {
        d.path = checked<std::string>(v, source, at);
      } else if (name == "subjects") {
        d.subjects = checked<std::vector<int>>(v, source, at);
      } else if (name == "include") {
        d.include = checked<std::vector<std::string>>(v, source, at);
      } else if (name == "exclude") {
        d.exclude = checked<std::vector<std::string>>(v, source, at);
      } else if (name == "weight") {
        d.weight = checked<double>(v, source, at);
      } else if (name == "distill") {
        d.distill = checked<bool>(v, source, at);
      } else if (name == "newest") {
        d.newest = checked<bool>(v, source, at);
      } else {
        config_error(source, at, "unknown key");
      }
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
  } catch (const json::exception& e) {  // parse_error, and out_of_range for a number like 1e999
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
    for (const auto& [k, e] : entries(*val_src, source, "data.val", "sources"))
      for (const char* flag : {"distill", "newest"})
        if (e->contains(flag)) config_error(source, k + "." + flag, "only for training sources");
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
  aug.get("upsample_prob", c.augment.upsample_prob);
  std::vector<double> upsample_hz{c.augment.upsample_min_hz, c.augment.upsample_max_hz};
  aug.get("upsample_hz", upsample_hz);
  aug.finish();
  for (const auto& [k, v] : {std::pair{"shape_prob", c.augment.shape_prob}, std::pair{"still_prob", c.augment.still_prob},
                             std::pair{"upsample_prob", c.augment.upsample_prob}})
    if (!(v >= 0 && v <= 1)) config_error(source, std::string("augment.") + k, "must be in [0, 1]");
  if (upsample_hz.size() != 2 || !(upsample_hz[0] > 0) || !(upsample_hz[1] >= upsample_hz[0]) ||
      !std::isfinite(upsample_hz[1]))
    config_error(source, "augment.upsample_hz", "expected [min, max] tracker rates with 0 < min <= max");
  c.augment.upsample_min_hz = upsample_hz[0];
  c.augment.upsample_max_hz = upsample_hz[1];
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
      c.lr.emplace_back(checked<int>(e[0], source, "train.lr"), checked<double>(e[1], source, "train.lr"));
    }
  }
  tr.get("grad_clip", c.grad_clip);
  tr.get("threads", c.threads);
  tr.get("freeze_graph_epochs", c.freeze_graph_epochs);
  tr.get("init", c.init);
  tr.get("init_matching", c.init_matching);
  tr.get("freeze", c.freeze);
  tr.get("teacher", c.teacher);
  tr.get("fixed_norm", c.fixed_norm);
  tr.finish();
  for (const auto& f : c.freeze)
    if (f.empty()) config_error(source, "train.freeze", "a prefix must not be empty");
  if (c.init_matching && c.init.empty()) config_error(source, "train.init_matching", "needs train.init");
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
  lo.get("newest", c.loss.newest);
  lo.get("newest_by_speed", c.loss.newest_by_speed);
  lo.get("newest_relative_eps_mm", c.loss.newest_relative_eps_mm);
  lo.get("bone", c.loss.bone);
  lo.get("symmetry", c.loss.symmetry);
  lo.get("smooth", c.loss.smooth);
  lo.get("predict", c.loss.predict);
  lo.get("predict_smooth", c.loss.predict_smooth);
  lo.get("relative_eps_mm", c.loss.relative_eps_mm);
  lo.get("distill", c.loss.distill);
  lo.get("distill_displacement", c.loss.distill_displacement);
  if (const json* st = lo.raw("stages")) {
    if (!st->is_array()) config_error(source, "loss.stages", "expected [{\"epoch\": e, \"bone\": w, ...}, ...]");
    for (size_t i = 0; i < st->size(); ++i) {
      const json& e = (*st)[i];
      const std::string key = "loss.stages[" + std::to_string(i) + "]";
      if (!e.is_object() || !e.contains("epoch") || !e.at("epoch").is_number_integer())
        config_error(source, key, "expected {\"epoch\": e, \"bone\": w, ...}");
      LossWeights w = c.loss;
      const std::map<std::string, double*> fields = {{"pose", &w.pose},
                                                     {"newest", &w.newest},
                                                     {"bone", &w.bone},
                                                     {"symmetry", &w.symmetry},
                                                     {"smooth", &w.smooth},
                                                     {"predict", &w.predict},
                                                     {"predict_smooth", &w.predict_smooth},
                                                     {"distill", &w.distill},
                                                     {"distill_displacement", &w.distill_displacement}};
      for (const auto& [k, v] : e.items()) {
        if (k == "epoch") continue;
        const auto it = fields.find(k);
        if (it == fields.end()) config_error(source, key + "." + k, "unknown key");
        if (!v.is_number() || !(v.get<double>() >= 0) || !std::isfinite(v.get<double>()))
          config_error(source, key + "." + k, "expected a finite weight >= 0");
        *it->second = v.get<double>();
      }
      const int first = checked<int>(e.at("epoch"), source, key + ".epoch");
      if (first < 0 || (!c.loss_stages.empty() && first <= c.loss_stages.back().first))
        config_error(source, key + ".epoch", "epochs must be >= 0 and increase");
      c.loss_stages.emplace_back(first, w);
    }
  }
  lo.finish();
  if (!(c.loss.relative_eps_mm >= 0 && std::isfinite(c.loss.relative_eps_mm)))
    config_error(source, "loss.relative_eps_mm", "must be finite and >= 0");
  if (!(c.loss.newest_relative_eps_mm >= 0 && std::isfinite(c.loss.newest_relative_eps_mm)))
    config_error(source, "loss.newest_relative_eps_mm", "must be finite and >= 0");
  for (double w : {c.loss.pose, c.loss.newest, c.loss.bone, c.loss.symmetry, c.loss.smooth, c.loss.predict,
                   c.loss.predict_smooth, c.loss.distill, c.loss.distill_displacement})
    if (!(w >= 0 && std::isfinite(w))) config_error(source, "loss", "weights must be finite and >= 0");
  bool distills = c.loss.distills();
  for (const auto& [e, w] : c.loss_stages) distills = distills || w.distills();
  const bool marked = std::any_of(c.train_sources.begin(), c.train_sources.end(), [](const DataSource& d) { return d.distill; });
  if (distills && c.teacher.empty()) config_error(source, "loss.distill", "a distillation weight needs train.teacher");
  if (!c.teacher.empty() && !distills)
    config_error(source, "train.teacher", "needs a loss.distill or loss.distill_displacement weight > 0");
  if (!c.teacher.empty() && !marked)
    config_error(source, "train.teacher", "needs a data.train source with \"distill\": true");
  if (marked && c.teacher.empty()) config_error(source, "data.train", "\"distill\" needs train.teacher");
  bool newest = c.loss.newest > 0;
  for (const auto& [e, w] : c.loss_stages) newest = newest || w.newest > 0;
  const bool skipped = std::any_of(c.train_sources.begin(), c.train_sources.end(), [](const DataSource& d) { return !d.newest; });
  if (skipped && !newest) config_error(source, "data.train", "\"newest\": false needs a loss.newest weight > 0");
  if (skipped && c.synthetic_takes == 0 &&
      std::none_of(c.train_sources.begin(), c.train_sources.end(), [](const DataSource& d) { return d.newest; }))
    config_error(source, "data.train", "\"newest\": false on every source leaves loss.newest nothing to score");
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

}  // namespace hs::train
