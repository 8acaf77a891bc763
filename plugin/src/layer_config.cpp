#include "layer_config.hpp"

#include "handsteady/model_path.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"

#include <nlohmann/json.hpp>

#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string_view>

namespace hs::layer {
namespace {

std::optional<std::string> env(const char* name) {
  const char* v = std::getenv(name);
  if (!v || !*v) return std::nullopt;
  return std::string(v);
}

std::optional<Mode> parse_mode(std::string_view s) {
  if (s == "off") return Mode::Off;
  if (s == "denoise") return Mode::Denoise;
  if (s == "predict") return Mode::Predict;
  return std::nullopt;
}

std::optional<LogLevel> parse_level(std::string_view s) {
  if (s == "off") return LogLevel::Off;
  if (s == "error") return LogLevel::Error;
  if (s == "warn") return LogLevel::Warn;
  if (s == "info") return LogLevel::Info;
  if (s == "debug") return LogLevel::Debug;
  return std::nullopt;
}

// A switch's words: on/true/1 and off/false/0 (nullopt: neither).
std::optional<bool> parse_on_off(std::string_view s) {
  if (s == "on" || s == "true" || s == "1") return true;
  if (s == "off" || s == "false" || s == "0") return false;
  return std::nullopt;
}

std::optional<double> parse_double(const std::string& s) {
  try {
    size_t used = 0;
    const double v = std::stod(s, &used);
    if (used == s.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

struct Applier {
  LayerConfig& c;
  std::vector<std::string>& warnings;

  void mode(const std::string& v, const std::string& where) {
    if (auto m = parse_mode(v)) c.mode = *m;
    else warnings.push_back(where + ": unknown mode '" + v + "' (off, denoise, predict)");
  }
  void method(const std::string& v, const std::string& where) {
    try {
      c.filter.method = parse_filter_method(v);
      c.method_given = true;
    } catch (const std::exception& e) {
      warnings.push_back(where + ": " + e.what());
    }
  }
  void horizon_ms(double v, const std::string& where) {
    if (v >= 0.0 && v <= 500.0) {
      c.horizon_ns = static_cast<int64_t>(std::llround(v * 1e6));
      for (auto& h : c.hands) h.horizon_ns = c.horizon_ns;
    } else {
      warnings.push_back(where + ": horizon must be in [0, 500] ms");
    }
  }
  void max_horizon_ms(double v, const std::string& where) {
    if (v >= 0.0 && v <= 500.0) c.max_horizon_ns = static_cast<int64_t>(std::llround(v * 1e6));
    else warnings.push_back(where + ": max horizon must be in [0, 500] ms");
  }
  void hand_horizon_ms(int hand, double v, const std::string& where) {
    if (v >= 0.0 && v <= 500.0) c.hands[hand].horizon_ns = static_cast<int64_t>(std::llround(v * 1e6));
    else warnings.push_back(where + ": horizon must be in [0, 500] ms");
  }
  void smoothing(int hand, double v, const std::string& where) {  // hand -1: both
    if (!(v >= 0.0 && v <= 1.0)) {
      warnings.push_back(where + ": smoothing must be in [0, 1]");
      return;
    }
    for (int h = 0; h < 2; ++h)
      if (hand < 0 || hand == h) c.hands[h].smoothing = v;
  }
  void worker(const std::string& v, const std::string& where) {
    if (v == "auto") c.worker = WorkerMode::Auto;
    else if (v == "inline") c.worker = WorkerMode::Inline;
    else if (v == "worker") c.worker = WorkerMode::Worker;
    else if (v == "lockstep") c.worker = WorkerMode::Lockstep;
    else warnings.push_back(where + ": unknown worker mode '" + v + "' (auto, inline, worker, lockstep)");
  }
  void stgae_phases(double v, const std::string& where) {
    if (v >= 0 && v <= kStgaeMaxPhases && v == std::floor(v)) c.filter.stgae.phases = static_cast<int>(v);
    else warnings.push_back(where + ": must be an integer in [0, " + std::to_string(kStgaeMaxPhases) + "]");
  }
  void palm_fit(const std::string& v, const std::string& where) {
    if (auto on = parse_on_off(v)) c.filter.palm_fit = *on;
    else if (v == "auto") c.filter.palm_fit.reset();
    else warnings.push_back(where + ": unknown palm fit setting '" + v + "' (auto, on, off)");
  }
  void bone_fit(const std::string& v, const std::string& where) {
    if (auto on = parse_on_off(v)) c.filter.bone_fit = *on;
    else if (v == "auto") c.filter.bone_fit.reset();
    else warnings.push_back(where + ": unknown bone fit setting '" + v + "' (auto, on, off)");
  }
  void tremor_cancel(const std::string& v, const std::string& where) {
    if (auto on = parse_on_off(v)) c.filter.tremor_cancel = *on;
    else warnings.push_back(where + ": unknown tremor canceller setting '" + v + "' (on, off)");
  }
  // The network engine's prediction smoothing: on or off.
  void prediction_smoothing(const std::string& v, const std::string& where) {
    if (auto on = parse_on_off(v)) c.filter.stgae.smooth = *on;
    else warnings.push_back(where + ": unknown prediction smoothing setting '" + v + "' (on, off)");
  }
  // Its correction gain: auto (where the noise is measured at the input rate), on, off.
  void correction_gain(const std::string& v, const std::string& where) {
    if (auto on = parse_on_off(v)) c.filter.stgae.gain = *on;
    else if (v == "auto") c.filter.stgae.gain.reset();
    else warnings.push_back(where + ": unknown correction gain setting '" + v + "' (auto, on, off)");
  }
  // Its oscillation guard: on or off.
  void oscillation_guard(const std::string& v, const std::string& where) {
    if (auto on = parse_on_off(v)) c.filter.stgae.guard = *on;
    else warnings.push_back(where + ": unknown oscillation guard setting '" + v + "' (on, off)");
  }
  void log_level(const std::string& v, const std::string& where) {
    if (auto l = parse_level(v)) c.log_level = *l;
    else warnings.push_back(where + ": unknown log level '" + v + "' (off, error, warn, info, debug)");
  }
};

// Optional positive/non-negative number member of a JSON object.
void read_number(const nlohmann::json& obj, const char* key, double& dst, double min, const std::string& where,
                 std::vector<std::string>& warnings) {
  if (!obj.contains(key)) return;
  const auto& v = obj[key];
  if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < min)
    warnings.push_back(where + ": '" + key + "' must be a number >= " + std::to_string(min));
  else
    dst = v.get<double>();
}

// The JSON text of a configuration file (named `where` in warnings) applied to a.c.
void apply_json(std::string_view text, const std::string& where, Applier& a) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    a.warnings.push_back(where + ": invalid JSON: " + e.what());
    return;
  }
  if (!j.is_object()) {
    a.warnings.push_back(where + ": expected a JSON object");
    return;
  }
  auto str = [&](const char* key) -> std::optional<std::string> {
    if (!j.contains(key)) return std::nullopt;
    if (!j[key].is_string()) {
      a.warnings.push_back(where + ": '" + key + "' must be a string");
      return std::nullopt;
    }
    return j[key].get<std::string>();
  };
  if (auto v = str("mode")) a.mode(*v, where + ": mode");
  if (auto v = str("method")) a.method(*v, where + ": method");
  if (auto v = str("model")) a.c.model_path = *v;
  if (j.contains("rate_models")) {
    const auto& r = j["rate_models"];
    bool ok = r.is_array();
    for (size_t i = 0; ok && i < r.size(); ++i) ok = r[i].is_string() && !r[i].get<std::string>().empty();
    if (ok) a.c.rate_model_paths = r.get<std::vector<std::string>>();
    else a.warnings.push_back(where + ": 'rate_models' must be an array of file names");
  }
  if (auto v = str("log_level")) a.log_level(*v, where + ": log_level");
  if (auto v = str("record_dir")) a.c.record_dir = *v;
  if (j.contains("horizon_ms")) {
    if (j["horizon_ms"].is_number()) a.horizon_ms(j["horizon_ms"].get<double>(), where + ": horizon_ms");
    else a.warnings.push_back(where + ": 'horizon_ms' must be a number");
  }
  if (j.contains("stgae_phases")) {
    if (j["stgae_phases"].is_number()) a.stgae_phases(j["stgae_phases"].get<double>(), where + ": stgae_phases");
    else a.warnings.push_back(where + ": 'stgae_phases' must be a number");
  }
  if (auto v = str("worker")) a.worker(*v, where + ": worker");
  // A switch: true or false (its words "on" and "off"), or one of its words, which its
  // setter checks.
  using Setter = void (Applier::*)(const std::string&, const std::string&);
  auto switch_key = [&](const char* key, Setter set, const char* expected) {
    if (!j.contains(key)) return;
    const auto& v = j[key];
    if (v.is_boolean()) (a.*set)(v.get<bool>() ? "on" : "off", where + ": " + key);
    else if (v.is_string()) (a.*set)(v.get<std::string>(), where + ": " + key);
    else a.warnings.push_back(where + ": '" + key + "' must be " + expected);
  };
  switch_key("palm_fit", &Applier::palm_fit, "true, false or \"auto\"");
  switch_key("bone_fit", &Applier::bone_fit, "true, false or \"auto\"");
  switch_key("tremor_cancel", &Applier::tremor_cancel, "true or false");
  switch_key("prediction_smoothing", &Applier::prediction_smoothing, "true or false");
  switch_key("correction_gain", &Applier::correction_gain, "true, false or \"auto\"");
  switch_key("oscillation_guard", &Applier::oscillation_guard, "true or false");
  auto number = [&](const nlohmann::json& obj, const char* key, const std::string& at, auto&& apply) {
    if (!obj.contains(key)) return;
    if (obj[key].is_number()) apply(obj[key].get<double>(), at + ": " + key);
    else a.warnings.push_back(at + ": '" + key + "' must be a number");
  };
  number(j, "max_horizon_ms", where, [&](double v, const std::string& w) { a.max_horizon_ms(v, w); });
  number(j, "smoothing", where, [&](double v, const std::string& w) { a.smoothing(-1, v, w); });
  if (j.contains("hands")) {
    if (!j["hands"].is_object()) {
      a.warnings.push_back(where + ": 'hands' must be an object with 'left' and/or 'right'");
    } else {
      for (const auto& [key, h] : j["hands"].items()) {
        const int hand = key == "left" ? 0 : key == "right" ? 1 : -1;
        const std::string at = where + ": hands." + key;
        if (hand < 0 || !h.is_object()) {
          a.warnings.push_back(at + ": expected 'left' or 'right' with an object");
          continue;
        }
        number(h, "smoothing", at, [&](double v, const std::string& w) { a.smoothing(hand, v, w); });
        number(h, "horizon_ms", at, [&](double v, const std::string& w) { a.hand_horizon_ms(hand, v, w); });
      }
    }
  }
  FilterConfig& f = a.c.filter;
  double max_gap_ms = f.max_gap_s * 1e3;
  read_number(j, "max_gap_ms", max_gap_ms, 1.0, where, a.warnings);
  f.max_gap_s = max_gap_ms * 1e-3;
  if (j.contains("oneeuro") && j["oneeuro"].is_object()) {
    const auto& o = j["oneeuro"];
    read_number(o, "min_cutoff_hz", f.oneeuro.min_cutoff_hz, 1e-6, where + ": oneeuro", a.warnings);
    read_number(o, "beta", f.oneeuro.beta, 0.0, where + ": oneeuro", a.warnings);
    read_number(o, "d_cutoff_hz", f.oneeuro.d_cutoff_hz, 1e-6, where + ": oneeuro", a.warnings);
  }
  if (j.contains("kalman") && j["kalman"].is_object()) {
    const auto& o = j["kalman"];
    read_number(o, "meas_sd_m", f.kalman.meas_sd_m, 1e-9, where + ": kalman", a.warnings);
    read_number(o, "accel_psd", f.kalman.accel_psd, 1e-9, where + ": kalman", a.warnings);
  }
  if (j.contains("desp") && j["desp"].is_object())
    read_number(j["desp"], "alpha", f.desp.alpha, 1e-6, where + ": desp", a.warnings);
}

void apply_file(const std::string& path, Applier& a) {
  std::ifstream in(path);
  if (!in) {
    a.warnings.push_back(path + ": cannot open configuration file");
    return;
  }
  std::ostringstream text;
  text << in.rdbuf();
  apply_json(text.str(), path, a);
}

// Folder of this shared library (dladdr on one of its functions), empty when unknown.
std::filesystem::path layer_library_dir() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<const void*>(&layer_library_dir), &info) == 0 || !info.dli_fname) return {};
  std::error_code ec;
  const auto p = std::filesystem::weakly_canonical(info.dli_fname, ec);
  return ec ? std::filesystem::path(info.dli_fname).parent_path() : p.parent_path();
}

// The installed models folder relative to the installed layer (set by plugin/CMakeLists.txt).
#ifndef HS_LAYER_MODELS_RELDIR
#define HS_LAYER_MODELS_RELDIR "../../share/handsteady/models"
#endif

FilterMethod classical_default(Mode m) { return m == Mode::Predict ? FilterMethod::Kalman : FilterMethod::OneEuro; }

}  // namespace

void resolve_engine(LayerConfig& c, std::vector<LogMessage>& messages) {
  const bool requested = c.method_given && is_network(c.filter.method);
  // The network to load: the one asked for, else (no method given) Multi-STGAE.
  const FilterMethod network = requested ? c.filter.method : FilterMethod::Stgae;
  const std::string net_name(filter_method_name(network));
  c.filter.stgae.model.reset();
  c.filter.stgae.rate_models.clear();
  if (c.method_given && !requested) return;  // a classical method was asked for
  c.filter.method = classical_default(c.mode);  // the fallback, if needed
  const std::string fallback(filter_method_name(c.filter.method));

  std::filesystem::path file = c.model_path;
  if (file.empty()) {
    const auto dir = layer_library_dir();
    const ModelLookup found =
        lookup_default_model({dir.empty() ? dir : dir / HS_LAYER_MODELS_RELDIR}, default_model_file(network));
    if (found.found.empty()) {
      messages.push_back({requested ? LogLevel::Error : LogLevel::Info,
                          "engine " + fallback + ": no " + net_name + " model found (tried " + found.describe_tried() + ")"});
      return;
    }
    file = found.found;
  }
  try {
    FilterConfig stgae = c.filter;
    stgae.method = network;
    stgae.stgae.model = load_hsm(file);
    stgae.stgae.source = file.string();
    // Checks the model can stream (causal, 26 joints, the method's family) before any tracker exists.
    (void)make_filter(stgae);
    // Models at other rates: each must stream beside it, else it is left out (logged).
    for (const std::string& r : c.rate_model_paths) {
      const size_t kept = stgae.stgae.rate_models.size();
      try {
        stgae.stgae.rate_models.push_back(load_hsm(r));
        (void)make_filter(stgae);
        messages.push_back({LogLevel::Info, "engine " + net_name + ": rate model " + r + " (" +
                                                std::to_string(std::lround(stgae.stgae.rate_models.back()->config.rate_hz)) +
                                                " Hz) for input at its rate"});
      } catch (const std::exception& e) {
        stgae.stgae.rate_models.resize(kept);
        messages.push_back({LogLevel::Error, "engine " + net_name + ": rate model " + r + " cannot be used: " + e.what()});
      }
    }
    const bool palm = palm_fit_on(stgae), bones = bone_fit_on(stgae);
    c.filter = std::move(stgae);
    c.model_path = file.string();
    messages.push_back({LogLevel::Info, "engine " + net_name + ": model " + file.string() +
                                            (requested ? " (method " + net_name + ")" : " (default: a model was found)") +
                                            (palm ? ", palm fit on" : ", palm fit off") +
                                            (bones ? ", bone fit on" : ", bone fit off") +
                                            (c.filter.tremor_cancel ? ", tremor canceller on" : "") +
                                            (c.filter.stgae.smooth ? ", predictions smoothed" : "") +
                                            (!c.filter.stgae.gain ? "" : *c.filter.stgae.gain ? ", correction gain on at every rate"
                                                                                 : ", correction gain off") +
                                            (c.filter.stgae.guard ? "" : ", oscillation guard off")});
  } catch (const std::exception& e) {
    messages.push_back({LogLevel::Error, "engine " + fallback + ": the " + net_name + " model " + file.string() +
                                             " cannot be used: " + e.what()});
  }
}

std::string_view engine_name(const LayerConfig& c) {
  return filter_method_name(c.filter.method);
}

std::string_view mode_name(Mode m) {
  switch (m) {
    case Mode::Off: return "off";
    case Mode::Denoise: return "denoise";
    case Mode::Predict: return "predict";
  }
  return "unknown";
}

namespace {
// HANDSTEADY_SMOOTHING (both hands), HANDSTEADY_{LEFT,RIGHT}_SMOOTHING, HANDSTEADY_{LEFT,RIGHT}_HORIZON_MS.
void apply_hand_env(Applier& a) {
  if (auto v = env("HANDSTEADY_SMOOTHING")) {
    if (auto d = parse_double(*v)) a.smoothing(-1, *d, "HANDSTEADY_SMOOTHING");
    else a.warnings.push_back("HANDSTEADY_SMOOTHING: not a number: '" + *v + "'");
  }
  for (int h = 0; h < 2; ++h) {
    const std::string prefix = h == 0 ? "HANDSTEADY_LEFT_" : "HANDSTEADY_RIGHT_";
    if (auto v = env((prefix + "SMOOTHING").c_str())) {
      if (auto d = parse_double(*v)) a.smoothing(h, *d, prefix + "SMOOTHING");
      else a.warnings.push_back(prefix + "SMOOTHING: not a number: '" + *v + "'");
    }
    if (auto v = env((prefix + "HORIZON_MS").c_str())) {
      if (auto d = parse_double(*v)) a.hand_horizon_ms(h, *d, prefix + "HORIZON_MS");
      else a.warnings.push_back(prefix + "HORIZON_MS: not a number: '" + *v + "'");
    }
  }
}
}  // namespace

std::array<HandSettings, 2> load_hand_settings(std::vector<std::string>& warnings) {
  LayerConfig c;
  Applier a{c, warnings};
  if (auto path = env("HANDSTEADY_CONFIG")) apply_file(*path, a);
  if (auto v = env("HANDSTEADY_HORIZON_MS"))
    if (auto d = parse_double(*v)) a.horizon_ms(*d, "HANDSTEADY_HORIZON_MS");
  apply_hand_env(a);
  return c.hands;
}

LayerConfig parse_layer_config_json(std::string_view text, const std::string& where,
                                    std::vector<std::string>& warnings) {
  LayerConfig c;
  Applier a{c, warnings};
  apply_json(text, where, a);
  return c;
}

LoadedConfig read_layer_config() {
  LoadedConfig out;
  LayerConfig& c = out.config;
  Applier a{c, out.warnings};
  if (auto path = env("HANDSTEADY_CONFIG")) apply_file(*path, a);
  if (auto v = env("HANDSTEADY_MODE")) a.mode(*v, "HANDSTEADY_MODE");
  if (auto v = env("HANDSTEADY_METHOD")) a.method(*v, "HANDSTEADY_METHOD");
  if (auto v = env("HANDSTEADY_MODEL")) c.model_path = *v;
  if (auto v = env("HANDSTEADY_RATE_MODELS")) {
    c.rate_model_paths.clear();
    for (size_t from = 0; from <= v->size();) {
      const size_t colon = std::min(v->find(':', from), v->size());
      if (colon > from) c.rate_model_paths.push_back(v->substr(from, colon - from));
      from = colon + 1;
    }
  }
  if (auto v = env("HANDSTEADY_HORIZON_MS")) {
    if (auto d = parse_double(*v)) a.horizon_ms(*d, "HANDSTEADY_HORIZON_MS");
    else out.warnings.push_back("HANDSTEADY_HORIZON_MS: not a number: '" + *v + "'");
  }
  if (auto v = env("HANDSTEADY_STGAE_PHASES")) {
    if (auto d = parse_double(*v)) a.stgae_phases(*d, "HANDSTEADY_STGAE_PHASES");
    else out.warnings.push_back("HANDSTEADY_STGAE_PHASES: not a number: '" + *v + "'");
  }
  if (auto v = env("HANDSTEADY_PALM_FIT")) a.palm_fit(*v, "HANDSTEADY_PALM_FIT");
  if (auto v = env("HANDSTEADY_BONE_FIT")) a.bone_fit(*v, "HANDSTEADY_BONE_FIT");
  if (auto v = env("HANDSTEADY_TREMOR_CANCEL")) a.tremor_cancel(*v, "HANDSTEADY_TREMOR_CANCEL");
  if (auto v = env("HANDSTEADY_PREDICTION_SMOOTHING")) a.prediction_smoothing(*v, "HANDSTEADY_PREDICTION_SMOOTHING");
  if (auto v = env("HANDSTEADY_CORRECTION_GAIN")) a.correction_gain(*v, "HANDSTEADY_CORRECTION_GAIN");
  if (auto v = env("HANDSTEADY_OSCILLATION_GUARD")) a.oscillation_guard(*v, "HANDSTEADY_OSCILLATION_GUARD");
  if (auto v = env("HANDSTEADY_LOG")) a.log_level(*v, "HANDSTEADY_LOG");
  if (auto v = env("HANDSTEADY_RECORD")) c.record_dir = *v;
  if (auto v = env("HANDSTEADY_WORKER")) a.worker(*v, "HANDSTEADY_WORKER");
  if (auto v = env("HANDSTEADY_MAX_HORIZON_MS")) {
    if (auto d = parse_double(*v)) a.max_horizon_ms(*d, "HANDSTEADY_MAX_HORIZON_MS");
    else out.warnings.push_back("HANDSTEADY_MAX_HORIZON_MS: not a number: '" + *v + "'");
  }
  apply_hand_env(a);
  c.max_horizon_ns = std::max({c.max_horizon_ns, c.horizon_ns, c.hands[0].horizon_ns, c.hands[1].horizon_ns});
  return out;
}

LoadedConfig load_layer_config() {
  LoadedConfig out = read_layer_config();
  LayerConfig& c = out.config;
  // Each mode's classical default: smoothing without lag-compensation for denoise, a
  // constant-velocity Kalman (which extrapolates) for predict; Multi-STGAE (which does
  // both) when a model is found and no method is given. Never in mode off (nothing runs).
  if (c.mode == Mode::Off) {
    if (!c.method_given || is_network(c.filter.method)) c.filter.method = classical_default(c.mode);
    return out;
  }
  resolve_engine(c, out.engine_messages);
  return out;
}

}  // namespace hs::layer
