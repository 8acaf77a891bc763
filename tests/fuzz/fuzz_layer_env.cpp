// libFuzzer target for the OpenXR layer's environment variables (docs/OPENXR_LAYER.md
// "Configuration"): the input is lines NAME=value; each of the layer's variables named
// gets that value (the others are cleared), then the layer reads its configuration as at
// xrCreateInstance (read_layer_config) and its live per-hand settings
// (load_hand_settings). Any values must give a configuration in the documented ranges,
// with warnings for what is ignored; never a throw, crash, hang or leak. HANDSTEADY_CONFIG
// (a file: fuzz_layer_config covers its text) is never set, and no engine is chosen, so
// no model is loaded.
#include "fuzz_env.hpp"
#include "layer_config.hpp"

#include "handsteady/stgae_filter.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

namespace {
constexpr std::array<const char*, 21> kVariables = {
    "HANDSTEADY_MODE",          "HANDSTEADY_METHOD",           "HANDSTEADY_MODEL",
    "HANDSTEADY_RATE_MODELS",   "HANDSTEADY_HORIZON_MS",       "HANDSTEADY_STGAE_PHASES",
    "HANDSTEADY_PALM_FIT",      "HANDSTEADY_BONE_FIT",         "HANDSTEADY_TREMOR_CANCEL",
    "HANDSTEADY_PREDICTION_SMOOTHING", "HANDSTEADY_CORRECTION_GAIN", "HANDSTEADY_OSCILLATION_GUARD",
    "HANDSTEADY_LOG",           "HANDSTEADY_RECORD",           "HANDSTEADY_WORKER",
    "HANDSTEADY_MAX_HORIZON_MS", "HANDSTEADY_SMOOTHING",       "HANDSTEADY_LEFT_SMOOTHING",
    "HANDSTEADY_RIGHT_SMOOTHING", "HANDSTEADY_LEFT_HORIZON_MS", "HANDSTEADY_RIGHT_HORIZON_MS"};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  unsetenv("HANDSTEADY_CONFIG");
  hs::fuzz::set_env_from_lines(std::string_view(reinterpret_cast<const char*>(data), size), kVariables);
  const hs::layer::LoadedConfig loaded = hs::layer::read_layer_config();
  const hs::layer::LayerConfig& c = loaded.config;
  std::vector<std::string> warnings;
  const auto hands = hs::layer::load_hand_settings(warnings);
  // The documented ranges hold whatever the variables say (bad values keep the defaults).
  auto horizon_ok = [](std::int64_t ns) { return ns >= 0 && ns <= 500'000'000; };
  bool ok = horizon_ok(c.horizon_ns) && horizon_ok(c.max_horizon_ns) && c.filter.stgae.phases >= 0 &&
            c.filter.stgae.phases <= hs::kStgaeMaxPhases && !c.filter.stgae.model;
  for (const auto& h : c.hands)
    ok = ok && horizon_ok(h.horizon_ns) && h.horizon_ns <= c.max_horizon_ns && h.smoothing >= 0.0 && h.smoothing <= 1.0;
  for (const auto& h : hands) ok = ok && horizon_ok(h.horizon_ns) && h.smoothing >= 0.0 && h.smoothing <= 1.0;
  if (!ok) __builtin_trap();
  return 0;
}
