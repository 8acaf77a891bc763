// libFuzzer target for the OpenXR layer's JSON configuration (docs/OPENXR_LAYER.md): any
// byte string must parse to a configuration, with warnings for what is ignored; it must
// never throw, crash, hang or leak. Only the text is parsed: no environment, no engine
// choice, so no model is ever loaded.
#include "layer_config.hpp"

#include "handsteady/stgae_filter.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::string> warnings;
  const hs::layer::LayerConfig c = hs::layer::parse_layer_config_json(
      std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.json", warnings);
  // The documented ranges hold whatever the text says (bad values keep the defaults).
  auto horizon_ok = [](std::int64_t ns) { return ns >= 0 && ns <= 500'000'000; };
  bool ok = horizon_ok(c.horizon_ns) && horizon_ok(c.max_horizon_ns) && c.filter.stgae.phases >= 0 &&
            c.filter.stgae.phases <= hs::kStgaeMaxPhases && !c.filter.stgae.model;
  for (const auto& h : c.hands) ok = ok && horizon_ok(h.horizon_ns) && h.smoothing >= 0.0 && h.smoothing <= 1.0;
  if (!ok) __builtin_trap();
  return 0;
}
