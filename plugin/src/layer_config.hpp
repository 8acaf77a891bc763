#pragma once
// Layer configuration: defaults, then an optional JSON file (HANDSTEADY_CONFIG), then
// environment variables (each overrides the file). Documented in docs/OPENXR_LAYER.md.
#include "handsteady/filters.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace hs::layer {

enum class Mode { Off, Denoise, Predict };
enum class LogLevel { Off = 0, Error, Warn, Info, Debug };

// The engine parameters the layer starts from: hs::FilterConfig's defaults, except One
// Euro's beta, raised for 90 Hz runtimes (cutoff 1 Hz at rest, ~14 Hz at 0.25 m/s).
inline FilterConfig layer_default_filter() {
  FilterConfig f;
  f.oneeuro.min_cutoff_hz = 1.0;
  f.oneeuro.beta = 50.0;
  f.oneeuro.d_cutoff_hz = 1.0;
  return f;
}

// Where the engine runs (tracker_filter.hpp): auto = a worker thread for Multi-STGAE, the
// app's thread for the classical filters; lockstep = as auto, with the network's worker in
// lockstep (its real-time answers, deterministic: simulated clocks); inline, worker: for
// every engine.
enum class WorkerMode { Auto, Inline, Worker, Lockstep };

// What a user may tune per hand while the app runs (the configuration file is re-read
// when it changes): how much of the engine's estimate replaces the runtime's joints
// (0 = the runtime's, 1 = the engine's) and the prediction horizon.
struct HandSettings {
  double smoothing = 1.0;
  int64_t horizon_ns = 20'000'000;
};

struct LayerConfig {
  Mode mode = Mode::Denoise;
  // The engine: any method behind hs::PoseFilter (filter.method). Multi-STGAE runs over
  // filter.stgae.model, loaded once per instance by resolve_engine and shared (read-only)
  // by every tracker; filter.stgae.phases: its streams per tracker, 0 = the app's call
  // rate / the model rate (one model step per call), 1 = one stream (a step every model
  // period, answers moved along its predicted path in between: a third of the compute at
  // 90 Hz, rougher answers).
  FilterConfig filter = layer_default_filter();
  bool method_given = false;    // false: stgae when a model is found, else the mode's classical default
  std::string model_path;       // model file for stgae (empty: hs::lookup_default_model)
  // Models of the same family at other frame rates: each tracker runs the one whose rate
  // suits the runtime's (hs::make_rate_chosen_filter). "rate_models" in the file (an array),
  // HANDSTEADY_RATE_MODELS (':'-separated). One that cannot be used is left out, logged.
  std::vector<std::string> rate_model_paths;
  int64_t horizon_ns = 20'000'000;  // predict mode: predict this far past the runtime's data (default of both hands)
  // Largest horizon a hand may be given at run time (the engine publishes its path this far).
  int64_t max_horizon_ns = 100'000'000;
  std::array<HandSettings, 2> hands;  // [left, right]; "hands" in the file, HANDSTEADY_{LEFT,RIGHT}_*
  WorkerMode worker = WorkerMode::Auto;
  LogLevel log_level = LogLevel::Warn;
  std::string record_dir;       // non-empty: write raw and filtered track CSVs per tracker
};

struct LogMessage {
  LogLevel level;
  std::string text;
};

struct LoadedConfig {
  LayerConfig config;
  std::vector<std::string> warnings;  // bad values that were ignored (defaults kept)
  // The engine chosen and why (model found / loaded / failed and the fallback); log each once.
  std::vector<LogMessage> engine_messages;
};

// Never throws for bad user input: a bad value is reported in warnings and ignored; a
// model that cannot be used is reported in engine_messages and the classical default of
// the mode (One Euro for denoise, Kalman for predict) is used instead.
LoadedConfig load_layer_config();
// The same without choosing the engine (no model is loaded): defaults, the file, the
// environment. What an app running the layer reads to know its mode (the demo's labels).
LoadedConfig read_layer_config();

// The per-hand settings from the configuration file and environment as they are now
// (smoothing, horizon_ms: global and per hand), for re-reading while the app runs; bad
// values are reported in warnings and the defaults kept.
std::array<HandSettings, 2> load_hand_settings(std::vector<std::string>& warnings);

// Defaults with the JSON configuration text applied (what load_layer_config does with
// the HANDSTEADY_CONFIG file, before the environment and the engine choice): never
// throws for bad text; each problem is a warning prefixed with `where`. Loads no model.
LayerConfig parse_layer_config_json(std::string_view text, const std::string& where,
                                    std::vector<std::string>& warnings);

// Picks the engine: method "stgae", or no method given and a model found -> load the model
// (config.model_path, else hs::lookup_default_model next to the installed layer, else the
// source tree); on any failure -> the mode's classical default. Called by load_layer_config.
void resolve_engine(LayerConfig& c, std::vector<LogMessage>& messages);

std::string_view mode_name(Mode m);
// "stgae" or the classical method's name.
std::string_view engine_name(const LayerConfig& c);

}  // namespace hs::layer
