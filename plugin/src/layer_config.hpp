#pragma once
// Layer configuration: defaults, then an optional JSON file (HANDSTEADY_CONFIG), then
// environment variables (each overrides the file). Documented in docs/OPENXR_LAYER.md.
#include "handsteady/filters.hpp"

#include <cstdint>
#include <string>
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

struct LayerConfig {
  Mode mode = Mode::Denoise;
  FilterConfig filter = layer_default_filter();  // method and parameters of the engine behind PoseFilter
  bool method_given = false;    // false: the mode's default method
  std::string model_path;       // model for a learned engine (not used by classical filters)
  int64_t horizon_ns = 20'000'000;  // predict mode: sample the runtime this long before the asked time
  LogLevel log_level = LogLevel::Warn;
  std::string record_dir;       // non-empty: write raw and filtered track CSVs per tracker
};

struct LoadedConfig {
  LayerConfig config;
  std::vector<std::string> warnings;  // bad values that were ignored (defaults kept)
};

// Never throws for bad user input: a bad value is reported in warnings and ignored.
LoadedConfig load_layer_config();

std::string_view mode_name(Mode m);

}  // namespace hs::layer
