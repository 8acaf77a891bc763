#include "shim_config.hpp"

#include <cmath>
#include <cstdlib>
#include <numbers>
#include <stdexcept>
#include <string_view>
#include <vector>

namespace hs::shim {
namespace {

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

double parse_number(const std::string& text, const char* var) {
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) throw std::invalid_argument(std::string(var) + ": not a number: '" + text + "'");
  return v;
}

int64_t parse_ms(const std::string& text, const char* var) {
  const double ms = parse_number(text, var);
  if (!(ms > 0.0 && ms < 10'000.0)) throw std::invalid_argument(std::string(var) + ": out of range: '" + text + "'");
  return static_cast<int64_t>(ms * 1e6 + 0.5);
}

// The comma-separated items of a list variable (an empty item stays: the caller names it).
std::vector<std::string> split_commas(const std::string& s) {
  std::vector<std::string> items;
  size_t start = 0;
  for (;;) {
    const size_t comma = s.find(',', start);
    items.push_back(s.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) return items;
    start = comma + 1;
  }
}

}  // namespace

ShimConfig shim_config_from_env() {
  ShimConfig c;
  c.track_path = env("HANDSTEADY_SHIM_TRACK");

  if (std::string s = env("HANDSTEADY_SHIM_CORRUPT"); !s.empty()) {
    const auto colon = s.rfind(':');
    c.corrupt_preset = s.substr(0, colon);
    if (colon != std::string::npos) {
      const double seed = parse_number(s.substr(colon + 1), "HANDSTEADY_SHIM_CORRUPT");
      // An integer seed: no NaN, infinity or value beyond 64 bits (their conversion is undefined).
      if (!(seed >= 0.0 && seed < 0x1p64))
        throw std::invalid_argument("HANDSTEADY_SHIM_CORRUPT: seed out of [0, 2^64): '" + s.substr(colon + 1) + "'");
      c.corrupt_seed = static_cast<uint64_t>(seed);
    }
  }

  if (std::string s = env("HANDSTEADY_SHIM_CLOCK"); !s.empty()) {
    const auto colon = s.find(':');
    const std::string kind = s.substr(0, colon);
    if (kind == "real") c.real_clock = true;
    else if (kind != "sim") throw std::invalid_argument("HANDSTEADY_SHIM_CLOCK: expected sim:<ms> or real[:<ms>], got '" + s + "'");
    if (colon != std::string::npos) c.period_ns = parse_ms(s.substr(colon + 1), "HANDSTEADY_SHIM_CLOCK");
  }
  if (std::string s = env("HANDSTEADY_SHIM_EPOCH_MS"); !s.empty()) {
    // 0 and small values are what Monado gives (its clock starts at instance creation).
    const double ms = parse_number(s, "HANDSTEADY_SHIM_EPOCH_MS");
    if (!(ms >= 0.0 && ms < 1e12)) throw std::invalid_argument("HANDSTEADY_SHIM_EPOCH_MS: out of range: '" + s + "'");
    c.epoch_ns = static_cast<int64_t>(ms * 1e6 + 0.5);
  }
  if (std::string s = env("HANDSTEADY_SHIM_LATENCY_MS"); !s.empty()) {
    const double ms = parse_number(s, "HANDSTEADY_SHIM_LATENCY_MS");
    if (!(ms >= 0.0 && ms < 10'000.0)) throw std::invalid_argument("HANDSTEADY_SHIM_LATENCY_MS: out of range");
    c.latency_ns = static_cast<int64_t>(ms * 1e6 + 0.5);
  }
  if (c.latency_ns < 0) c.latency_ns = 2 * c.period_ns;

  if (std::string s = env("HANDSTEADY_SHIM_FUTURE"); !s.empty()) {
    if (s == "exact") {
      c.future = FuturePolicy::Exact;
    } else if (s == "hold") {
      c.future = FuturePolicy::Hold;
    } else if (s == "latest") {
      c.future = FuturePolicy::Latest;
    } else if (s.rfind("extrapolate", 0) == 0) {
      c.future = FuturePolicy::Extrapolate;
      // extrapolate[:<capture_hz>:<capture_latency_ms>]
      if (s != "extrapolate") {
        const auto a = s.find(':'), b = s.find(':', a + 1);
        if (a != 11 || b == std::string::npos)
          throw std::invalid_argument("HANDSTEADY_SHIM_FUTURE: expected extrapolate:<capture_hz>:<latency_ms>, got '" + s + "'");
        c.capture_hz = parse_number(s.substr(a + 1, b - a - 1), "HANDSTEADY_SHIM_FUTURE capture_hz");
        const double ms = parse_number(s.substr(b + 1), "HANDSTEADY_SHIM_FUTURE latency_ms");
        if (!(c.capture_hz >= 1.0 && c.capture_hz <= 1000.0) || !(ms >= 0.0 && ms <= 1000.0))
          throw std::invalid_argument("HANDSTEADY_SHIM_FUTURE: capture_hz in [1, 1000], latency_ms in [0, 1000]");
        c.capture_latency_ns = static_cast<int64_t>(ms * 1e6 + 0.5);
      }
    } else {
      throw std::invalid_argument("HANDSTEADY_SHIM_FUTURE: expected exact, hold, latest or extrapolate[:hz:ms], got '" + s + "'");
    }
  }
  if (std::string s = env("HANDSTEADY_SHIM_FRAMES"); !s.empty()) {
    if (s == "normal") c.frames = FrameMode::Normal;
    else if (s == "headless-zero") c.frames = FrameMode::HeadlessZero;
    else throw std::invalid_argument("HANDSTEADY_SHIM_FRAMES: expected normal or headless-zero, got '" + s + "'");
  }
  c.head_motion = env("HANDSTEADY_SHIM_HEAD_MOTION") == "1";
  if (std::string s = env("HANDSTEADY_SHIM_SPACE_VELOCITY"); !s.empty()) {
    if (s != "0" && s != "1")
      throw std::invalid_argument("HANDSTEADY_SHIM_SPACE_VELOCITY: expected 0 or 1, got '" + s + "'");
    c.space_velocity = s == "1";
  }

  if (std::string s = env("HANDSTEADY_SHIM_RECENTER"); !s.empty()) {
    std::vector<double> v;
    for (const std::string& item : split_commas(s)) v.push_back(parse_number(item, "HANDSTEADY_SHIM_RECENTER"));
    // Finite, an offset within 1 km and a yaw within a turn (a larger one overflowed to an
    // infinite angle in the conversion to radians: LOCAL's pose NaN).
    if (v.size() != 5 || !std::isfinite(v[0] + v[1] + v[2] + v[3] + v[4]) ||
        !(Eigen::Vector3d(v[1], v[2], v[3]).norm() <= 1e3) || !(std::abs(v[4]) <= 360.0))
      throw std::invalid_argument("HANDSTEADY_SHIM_RECENTER: expected <track_s>,<dx_m>,<dy_m>,<dz_m>,<yaw_deg> (offset "
                                  "within 1 km, yaw within 360 degrees), got '" + s + "'");
    Recenter rc;
    rc.at_s = v[0];
    rc.offset_m = Eigen::Vector3d(v[1], v[2], v[3]);
    rc.yaw_rad = v[4] * std::numbers::pi / 180.0;
    c.recenter = rc;
  }
  if (std::string s = env("HANDSTEADY_SHIM_CONTROLLER"); !s.empty()) {
    std::vector<double> v;
    for (const std::string& item : split_commas(s)) v.push_back(parse_number(item, "HANDSTEADY_SHIM_CONTROLLER"));
    if (v.size() != 2 || !std::isfinite(v[0] + v[1]) || !(v[0] < v[1]))
      throw std::invalid_argument("HANDSTEADY_SHIM_CONTROLLER: expected <from_track_s>,<to_track_s> with from < to, got '" +
                                  s + "'");
    ControllerSpan span;
    span.from_s = v[0];
    span.to_s = v[1];
    c.controller = span;
  }
  if (std::string s = env("HANDSTEADY_SHIM_FAULTS"); !s.empty()) {
    for (const std::string& item : split_commas(s)) {
      const auto colon = item.find(':');
      if (colon == std::string::npos) throw std::invalid_argument("HANDSTEADY_SHIM_FAULTS: expected kind:prob, got '" + item + "'");
      const std::string kind = item.substr(0, colon);
      const double p = parse_number(item.substr(colon + 1), "HANDSTEADY_SHIM_FAULTS");
      if (!(p >= 0.0 && p <= 1.0)) throw std::invalid_argument("HANDSTEADY_SHIM_FAULTS: probability out of [0,1]");
      if (kind == "nan") c.faults.nan = p;
      else if (kind == "huge") c.faults.huge = p;
      else if (kind == "quat") c.faults.quat = p;
      else if (kind == "origin") c.faults.origin = p;
      else if (kind == "space") c.faults.space = p;
      else if (kind == "velocity") c.faults.velocity = p;
      else if (kind == "radius") c.faults.radius = p;
      else if (kind == "collapse") c.faults.collapse = p;
      else if (kind == "untracked") c.faults.untracked = p;
      else if (kind == "error") c.faults.error = p;
      else if (kind == "space_error") c.faults.space_error = p;
      else throw std::invalid_argument("HANDSTEADY_SHIM_FAULTS: unknown fault '" + kind + "'");
    }
  }
  return c;
}

}  // namespace hs::shim
