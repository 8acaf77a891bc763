// handsteady compare: one markdown table of the main metrics for several outputs
// against one truth (used for the README tables).
#include "commands.hpp"

#include "handsteady/metrics.hpp"

#include <fmt/format.h>

#include <memory>

namespace {

struct CompareOptions {
  std::string truth;
  std::vector<std::string> inputs;  // label=path
  double horizon_ms = 0.0;
  int mpjpe_digits = 2;  // more tell apart rows that round alike (models/MODEL.md)
};

void setup_compare(CLI::App& app) {
  auto opt = std::make_shared<CompareOptions>();
  auto* sub = app.add_subcommand("compare", "Print a markdown table of metrics for several outputs against one truth");
  sub->add_option("--truth", opt->truth, "Clean track CSV")->required()->check(CLI::ExistingFile);
  sub->add_option("--in", opt->inputs, "LABEL=FILE.csv, repeatable")->required();
  sub->add_option("--horizon-ms", opt->horizon_ms, "Prediction horizon: output at t vs truth at t+H")
      ->capture_default_str();
  sub->add_option("--mpjpe-digits", opt->mpjpe_digits, "Decimals of the MPJPE column")
      ->check(CLI::Range(0, 6))
      ->capture_default_str();
  sub->callback([opt] {
    const hs::Track truth = hs::read_track_csv(opt->truth);
    fmt::print("| method | horizon ms | MPJPE mm | E_pos mm² | E_bon mm² | E_sym mm² | accel err mm/f² | jitter mm/f² | lag ms |\n");
    fmt::print("|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const auto& spec : opt->inputs) {
      const auto eq = spec.find('=');
      if (eq == std::string::npos || eq == 0)
        throw std::runtime_error("--in expects LABEL=FILE.csv, got '" + spec + "'");
      const hs::Track est = hs::read_track_csv(spec.substr(eq + 1));
      const hs::Metrics m = hs::evaluate_tracks(truth, est, opt->horizon_ms / 1000.0);
      fmt::print("| {} | {:.0f} | {:.{}f} | {:.2f} | {:.3f} | {:.3f} | {:.3f} | {:.3f} | {:.1f} |\n", spec.substr(0, eq),
                 opt->horizon_ms, m.mpjpe_mm, opt->mpjpe_digits, m.e_pos_mm2, m.e_bon_mm2, m.e_sym_mm2, m.accel_error_mm, m.jitter_mm,
                 m.lag_ms);
    }
  });
}

const hs::cli::CommandRegistration register_compare(&setup_compare);

}  // namespace
