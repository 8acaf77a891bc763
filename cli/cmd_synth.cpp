// handsteady synth: writes a synthetic two-hand track (smooth, seeded), the small
// example the project makes itself for demos and tests.
#include "commands.hpp"

#include "handsteady/synth.hpp"

#include <fmt/format.h>

#include <memory>

namespace {

struct SynthOptions {
  std::string out;
  double seconds = 20.0;
  double rate_hz = 30.0;
  uint64_t seed = 1;
};

void setup_synth(CLI::App& app) {
  auto opt = std::make_shared<SynthOptions>();
  auto* sub = app.add_subcommand("synth", "Write a synthetic two-hand track (smooth motion of a parametric hand)");
  sub->add_option("--out", opt->out, "Output track CSV")->required();
  sub->add_option("--seconds", opt->seconds, "Duration in seconds")->check(CLI::Range(0.1, 3600.0))->capture_default_str();
  sub->add_option("--rate", opt->rate_hz, "Frame rate in Hz")->check(CLI::Range(1.0, 1000.0))->capture_default_str();
  sub->add_option("--seed", opt->seed, "Random seed")->capture_default_str();
  sub->callback([opt] {
    hs::SynthMotionParams prm;
    prm.duration_s = opt->seconds;
    prm.rate_hz = opt->rate_hz;
    hs::Track tr = hs::synth_track(prm, opt->seed);
    hs::write_track_csv(tr, opt->out);
    fmt::print("synth: wrote {} rows to {}\n", tr.rows.size(), opt->out);
  });
}

const hs::cli::CommandRegistration register_synth(&setup_synth);

}  // namespace
