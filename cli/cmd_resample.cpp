// `handsteady resample`: a track linearly resampled to a fixed rate per hand, so that a
// recording can be replayed at a rate it was not made at (hs::resample_track).
#include "commands.hpp"

#include "handsteady/gap_policy.hpp"
#include "handsteady/time_series.hpp"
#include "handsteady/track.hpp"

#include <fmt/format.h>

#include <memory>
#include <string>

namespace hs::cli {
namespace {

struct ResampleOptions {
  std::string in, out;
  double rate_hz = 30.0;
  double max_gap_ms = kInterpolateMaxGapS * 1e3;
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
  sub->callback([o] {
    const Track in = read_track_csv(o->in);
    Track out = resample_track(in, o->rate_hz, o->max_gap_ms / 1e3);
    out.header_lines.push_back(fmt::format("resampled: rate_hz={:g} max_gap_ms={:g} from {}", o->rate_hz, o->max_gap_ms, o->in));
    write_track_csv(out, o->out);
    fmt::print("resample: {} rows -> {} rows at {:g} Hz ({})\n", in.rows.size(), out.rows.size(), o->rate_hz, o->out);
  });
}

CommandRegistration reg(&setup_resample);

}  // namespace
}  // namespace hs::cli
