// libFuzzer target for the replay runtime's environment variables (docs/OPENXR_LAYER.md
// "Replay runtime"), read at each xrCreateInstance: the input is lines NAME=value; each of
// the runtime's variables named gets that value (the others are cleared). The documented
// outcomes: a configuration in range, or std::invalid_argument naming the variable
// (xrCreateInstance then fails); never another exception, a crash, a hang or a leak. The
// track file named is not read here (read_track_csv has its own fuzzer).
#include "fuzz_env.hpp"
#include "shim_config.hpp"

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <string_view>

namespace {
constexpr std::array<const char*, 12> kVariables = {
    "HANDSTEADY_SHIM_TRACK",      "HANDSTEADY_SHIM_CORRUPT",    "HANDSTEADY_SHIM_CLOCK",
    "HANDSTEADY_SHIM_EPOCH_MS",   "HANDSTEADY_SHIM_FRAMES",     "HANDSTEADY_SHIM_LATENCY_MS",
    "HANDSTEADY_SHIM_FUTURE",     "HANDSTEADY_SHIM_HEAD_MOTION", "HANDSTEADY_SHIM_RECENTER",
    "HANDSTEADY_SHIM_CONTROLLER", "HANDSTEADY_SHIM_SPACE_VELOCITY", "HANDSTEADY_SHIM_FAULTS"};

bool in_unit(double p) { return p >= 0.0 && p <= 1.0; }
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hs::fuzz::set_env_from_lines(std::string_view(reinterpret_cast<const char*>(data), size), kVariables);
  hs::shim::ShimConfig c;
  try {
    c = hs::shim::shim_config_from_env();
  } catch (const std::invalid_argument& e) {
    if (std::string_view(e.what()).rfind("HANDSTEADY_SHIM_", 0) != 0) __builtin_trap();  // names the variable
    return 0;
  }
  const auto& f = c.faults;
  bool ok = c.period_ns > 0 && c.latency_ns >= 0 && c.capture_hz >= 1.0 && c.capture_hz <= 1000.0 &&
            c.capture_latency_ns >= 0 && (!c.epoch_ns || *c.epoch_ns >= 0) && in_unit(f.nan) && in_unit(f.huge) &&
            in_unit(f.quat) && in_unit(f.origin) && in_unit(f.space) && in_unit(f.velocity) && in_unit(f.radius) &&
            in_unit(f.collapse) && in_unit(f.untracked) && in_unit(f.error) && in_unit(f.space_error);
  if (c.recenter) ok = ok && std::isfinite(c.recenter->at_s) && c.recenter->offset_m.allFinite() && std::isfinite(c.recenter->yaw_rad);
  if (c.controller) ok = ok && std::isfinite(c.controller->from_s) && std::isfinite(c.controller->to_s) &&
                         c.controller->from_s < c.controller->to_s;
  if (!ok) __builtin_trap();
  return 0;
}
