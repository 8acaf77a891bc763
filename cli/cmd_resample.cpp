// `handsteady resample`: a track linearly resampled to a fixed rate per hand, so that a
// recording can be replayed at a rate it was not made at (hs::resample_track), or on a
// tracker's jittering clock (--jitter: hs::resample_track_jittered, as the benchmark's
// irregular input rates).
#include "commands.hpp"

#include "handsteady/gap_policy.hpp"
#include "handsteady/time_series.hpp"
#include "handsteady/track.hpp"

#include <fmt/format.h>

#include <cstdint>
#include <memory>
#include <string>

namespace hs::cli {
namespace {

struct ResampleOptions {
  std::string in, out;
  double rate_hz = 30.0;
  double max_gap_ms = kInterpolateMaxGapS * 1e3;
  double jitter = 0.0;
  uint64_t seed = 1;
};

void setup_resample(CLI::App& app) {
  auto o = std::make_shared<ResampleOptions>();
  auto* sub = app.add_subcommand("resample", "Resample a track linearly to a fixed rate, per hand (k / rate from each hand's first row)");
  sub->add_option("--in", o->in, "Input track CSV")->required()->check(CLI::ExistingFile);
  sub->add_option("--out", o->out, "Output track CSV")->required();
  sub->add_option("--rate", o->rate_hz, "Output rate (Hz)")->required()->check(CLI::Range(1.0, 1000.0));
  sub->add_option("--max-gap-ms", o->max_gap_ms,
                  "A joint is interpolated only between rows at most this far apart; otherwise untracked (ms)")
      ->check(CLI::Range(0.0, 60000.0))
      ->capture_default_str();
  sub->add_option("--jitter", o->jitter,
                  "Irregular times: each hand at t0 + (k + u) / rate from its first row t0, u uniform in "
                  "[-jitter, jitter] of a period (0 = the regular grid k / rate)")
      ->check(CLI::Range(0.0, 0.49))
      ->capture_default_str();
  sub->add_option("--seed", o->seed, "Seed of the irregular times (--jitter); hand h uses seed + 17 h")->capture_default_str();
  sub->callback([o] {
    const Track in = read_track_csv(o->in);
    const double gap_s = o->max_gap_ms / 1e3;
    const bool jittered = o->jitter > 0.0;
    Track out = jittered ? resample_track_jittered(in, o->rate_hz, o->jitter, o->seed, gap_s)
                         : resample_track(in, o->rate_hz, gap_s);
    const std::string clock = jittered ? fmt::format(" jitter={:g} seed={}", o->jitter, o->seed) : std::string();
    out.header_lines.push_back(
        fmt::format("resampled: rate_hz={:g}{} max_gap_ms={:g} from {}", o->rate_hz, clock, o->max_gap_ms, o->in));
    write_track_csv(out, o->out);
    fmt::print("resample: {} rows -> {} rows at {:g} Hz ({})\n", in.rows.size(), out.rows.size(), o->rate_hz, o->out);
  });
}

const CommandRegistration register_resample(&setup_resample);

}  // namespace
}  // namespace hs::cli
