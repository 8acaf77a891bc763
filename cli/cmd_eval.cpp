// handsteady eval: quality measures of an estimate track against the truth
// (definitions in docs/METRICS.md).
#include "commands.hpp"

#include "handsteady/error.hpp"
#include "handsteady/metrics.hpp"
#include "handsteady/track.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

namespace hs::cli {
namespace {

struct EvalOptions {
  std::string truth, in;
  double horizon_ms = 0.0;
  bool json = false;
};

// NaN (nothing to compare) prints as "n/a" and is null in JSON.
std::string number(double v, int decimals) { return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : "n/a"; }
nlohmann::json json_number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

void print_table(const EvalOptions& o, const Metrics& m) {
  const auto line = [](const char* name, const std::string& value, const char* unit) {
    std::fputs(fmt::format("{:<16} {:>12}  {}\n", name, value, unit).c_str(), stdout);
  };
  std::fputs(fmt::format("truth     {}\nestimate  {}\n", o.truth, o.in).c_str(), stdout);
  line("horizon", number(m.horizon_ms, 1), "ms");
  line("rows compared", std::to_string(m.frames), "");
  line("rows skipped", std::to_string(m.rows_outside + m.rows_untracked),
       fmt::format("({} outside the truth, {} no joint in common)", m.rows_outside, m.rows_untracked).c_str());
  line("joint samples", std::to_string(m.joint_samples), "");
  line("E_pos", number(m.e_pos_mm2, 3), "mm^2 (MSE per coordinate)");
  line("MPJPE", number(m.mpjpe_mm, 3), "mm");
  line("E_bon", number(m.e_bon_mm2, 3), "mm^2");
  line("E_sym", number(m.e_sym_mm2, 3), "mm^2");
  line("accel error", number(m.accel_error_mm, 3), "mm/frame^2");
  line("jitter", number(m.jitter_mm, 3), "mm/frame^2");
  line("truth jitter", number(m.truth_jitter_mm, 3), "mm/frame^2");
  line("lag", number(m.lag_ms, 1),
       fmt::format("ms ({} frames of {} ms)", number(m.lag_frames, 2), number(m.frame_period_ms, 1)).c_str());
}

void run_eval(const EvalOptions& o) {
  if (!std::isfinite(o.horizon_ms) || o.horizon_ms < 0.0)
    throw InputError({"", 0, "--horizon-ms"}, fmt::format("horizon must be >= 0 ms, got {}", o.horizon_ms));
  const Track truth = read_track_csv(o.truth);
  const Track est = read_track_csv(o.in);
  const Metrics m = evaluate_tracks(truth, est, o.horizon_ms * 1e-3);
  if (!o.json) {
    print_table(o, m);
    return;
  }
  nlohmann::json j = {
      {"truth", o.truth},
      {"estimate", o.in},
      {"horizon_ms", m.horizon_ms},
      {"rows_compared", m.frames},
      {"rows_skipped_outside", m.rows_outside},
      {"rows_skipped_untracked", m.rows_untracked},
      {"joint_samples", m.joint_samples},
      {"e_pos_mm2", json_number(m.e_pos_mm2)},
      {"mpjpe_mm", json_number(m.mpjpe_mm)},
      {"e_bon_mm2", json_number(m.e_bon_mm2)},
      {"e_sym_mm2", json_number(m.e_sym_mm2)},
      {"accel_error_mm", json_number(m.accel_error_mm)},
      {"jitter_mm", json_number(m.jitter_mm)},
      {"truth_jitter_mm", json_number(m.truth_jitter_mm)},
      {"lag_frames", json_number(m.lag_frames)},
      {"frame_period_ms", json_number(m.frame_period_ms)},
      {"lag_ms", json_number(m.lag_ms)},
  };
  std::fputs((j.dump(2) + "\n").c_str(), stdout);
}

void setup_eval(CLI::App& app) {
  auto o = std::make_shared<EvalOptions>();
  CLI::App* sub = app.add_subcommand("eval", "Compare an estimate track with the truth; see docs/METRICS.md");
  sub->add_option("--truth", o->truth, "Ground-truth track CSV")->required();
  sub->add_option("--in", o->in, "Estimate track CSV")->required();
  sub->add_option("--horizon-ms", o->horizon_ms, "Compare the row at t with the truth at t + H (ms)")
      ->capture_default_str();
  sub->add_flag("--json", o->json, "Print JSON instead of a table");
  sub->callback([o] { run_eval(*o); });
}

const CommandRegistration register_eval(&setup_eval);

}  // namespace
}  // namespace hs::cli
