// handsteady corrupt: seeded corruption of a clean track (docs/CORRUPTION.md).
#include "commands.hpp"

#include "handsteady/corrupt.hpp"
#include "handsteady/error.hpp"
#include "handsteady/track.hpp"

#include <fmt/format.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hs::cli {
namespace {

const std::vector<std::string> kPresetNames = {"paper", "tracker", "tremor", "tremor-physiological",
                                                "hand-jitter"};

// Overrides in command-line units (mm, ms); unset = the preset's value.
struct CorruptOptions {
  std::string in, out, preset = "tracker";
  uint64_t seed = 1;
  std::optional<double> sigma_s, sigma_o, beta_mm, reference_hand_mm;
  bool no_optimize = false;
  std::optional<double> jitter_mm, jitter_ar1, joint_drop, hand_drop_rate, hand_drop_mean_ms, jump_prob, jump_mm,
      quantize_mm, hand_jitter_mm;
  std::optional<double> tremor_min_hz, tremor_max_hz, tremor_hand_mm, tremor_finger_mm;
};

template <class T>
void apply(const std::optional<double>& v, T& target, double scale, bool& used) {
  if (!v) return;
  target = *v * scale;
  used = true;
}

// Applies overrides; an override for another preset family is an error, not ignored.
CorruptionConfig build_config(const CorruptOptions& o) {
  CorruptionConfig c = corruption_preset(o.preset);
  bool paper = o.no_optimize, tracker = false, tremor = false;
  apply(o.sigma_s, c.paper.sigma_s, 1.0, paper);
  apply(o.sigma_o, c.paper.sigma_o, 1.0, paper);
  apply(o.beta_mm, c.paper.beta_m, 1e-3, paper);
  apply(o.reference_hand_mm, c.paper.reference_hand_m, 1e-3, paper);
  if (o.no_optimize) c.paper.optimize = false;
  apply(o.jitter_mm, c.tracker.jitter_sd_m, 1e-3, tracker);
  apply(o.jitter_ar1, c.tracker.jitter_ar1, 1.0, tracker);
  apply(o.joint_drop, c.tracker.joint_drop_prob, 1.0, tracker);
  apply(o.hand_drop_rate, c.tracker.hand_drop_rate_hz, 1.0, tracker);
  apply(o.hand_drop_mean_ms, c.tracker.hand_drop_mean_s, 1e-3, tracker);
  apply(o.jump_prob, c.tracker.jump_prob, 1.0, tracker);
  apply(o.jump_mm, c.tracker.jump_sd_m, 1e-3, tracker);
  apply(o.quantize_mm, c.tracker.quantize_m, 1e-3, tracker);
  apply(o.hand_jitter_mm, c.tracker.hand_jitter_sd_m, 1e-3, tracker);
  apply(o.tremor_min_hz, c.tremor.freq_min_hz, 1.0, tremor);
  apply(o.tremor_max_hz, c.tremor.freq_max_hz, 1.0, tremor);
  apply(o.tremor_hand_mm, c.tremor.hand_amplitude_m, 1e-3, tremor);
  apply(o.tremor_finger_mm, c.tremor.finger_amplitude_m, 1e-3, tremor);
  const auto mismatch = [&](bool used, CorruptionKind kind, const char* family) {
    if (used && c.kind != kind)
      throw InputError({"", 0, "--preset"}, fmt::format("{} options were given but the preset is '{}'", family, o.preset));
  };
  mismatch(paper, CorruptionKind::Paper, "paper");
  mismatch(tracker, CorruptionKind::Tracker, "tracker");
  mismatch(tremor, CorruptionKind::Tremor, "tremor");
  try {
    validate_corruption(c);
  } catch (const std::invalid_argument& e) {
    throw InputError({"", 0, "--preset " + o.preset}, e.what());
  }
  return c;
}

std::string describe(const CorruptionConfig& c) {
  switch (c.kind) {
    case CorruptionKind::Paper:
      return fmt::format("sigma_s={} sigma_o={} beta_mm={} reference_hand_mm={} optimize={}", c.paper.sigma_s,
                         c.paper.sigma_o, c.paper.beta_m * 1e3, c.paper.reference_hand_m * 1e3,
                         c.paper.optimize ? "yes" : "no");
    case CorruptionKind::Tracker: {
      const TrackerCorruption& t = c.tracker;
      return fmt::format(
          "jitter_mm={} jitter_ar1={} joint_drop={} hand_drop_rate_hz={} hand_drop_mean_ms={} jump_prob={} "
          "jump_mm={} quantize_mm={} hand_jitter_mm={}",
          t.jitter_sd_m * 1e3, t.jitter_ar1, t.joint_drop_prob, t.hand_drop_rate_hz, t.hand_drop_mean_s * 1e3,
          t.jump_prob, t.jump_sd_m * 1e3, t.quantize_m * 1e3, t.hand_jitter_sd_m * 1e3);
    }
    case CorruptionKind::Tremor:
      return fmt::format("band_hz={}-{} hand_mm={} finger_mm={}", c.tremor.freq_min_hz, c.tremor.freq_max_hz,
                         c.tremor.hand_amplitude_m * 1e3, c.tremor.finger_amplitude_m * 1e3);
  }
  return {};
}

void run_corrupt(const CorruptOptions& o) {
  const CorruptionConfig config = build_config(o);  // validate before reading the input
  const Track clean = read_track_csv(o.in);
  Track noisy = corrupt_track(clean, config, o.seed);
  // Appended so that a chain of corruptions stays visible; meta() reads the last.
  noisy.header_lines.push_back(fmt::format("corruption: {} seed={}", o.preset, o.seed));
  noisy.header_lines.push_back(fmt::format("corruption_params: {}", describe(config)));
  write_track_csv(noisy, o.out);
}

void setup_corrupt(CLI::App& app) {
  auto o = std::make_shared<CorruptOptions>();
  CLI::App* sub = app.add_subcommand("corrupt", "Corrupt a clean track with seeded noise; see docs/CORRUPTION.md");
  sub->add_option("--in", o->in, "Clean input track CSV")->required();
  sub->add_option("--out", o->out, "Corrupted output track CSV")->required();
  sub->add_option("--preset", o->preset, "Corruption preset")->check(CLI::IsMember(kPresetNames))->capture_default_str();
  sub->add_option("--seed", o->seed, "Random seed (same seed, same output)")->capture_default_str();
  auto* p = sub->add_option_group("paper", "Overrides for --preset paper");
  p->add_option("--sigma-s", o->sigma_s, "Shift probability scale sigma_s");
  p->add_option("--sigma-o", o->sigma_o, "Occlusion probability scale sigma_o");
  p->add_option("--beta-mm", o->beta_mm, "Shift amplitude beta for the reference hand (mm)");
  p->add_option("--reference-hand-mm", o->reference_hand_mm, "Reference hand size for beta (mm); 0 = no scaling");
  p->add_flag("--no-optimize", o->no_optimize, "Skip the Optimize bone-length step");
  auto* t = sub->add_option_group("tracker", "Overrides for --preset tracker / hand-jitter");
  t->add_option("--jitter-mm", o->jitter_mm, "Jitter SD per coordinate (mm)");
  t->add_option("--jitter-ar1", o->jitter_ar1, "Row-to-row jitter correlation in [0, 1)");
  t->add_option("--joint-drop", o->joint_drop, "Probability a joint is dropped in a row");
  t->add_option("--hand-drop-rate", o->hand_drop_rate, "Whole-hand dropout starts per second");
  t->add_option("--hand-drop-mean-ms", o->hand_drop_mean_ms, "Mean whole-hand dropout duration (ms)");
  t->add_option("--jump-prob", o->jump_prob, "Probability of a one-row jump per joint and row");
  t->add_option("--jump-mm", o->jump_mm, "Jump SD per coordinate (mm)");
  t->add_option("--quantize-mm", o->quantize_mm, "Output rounding step (mm); 0 = none");
  t->add_option("--hand-jitter-mm", o->hand_jitter_mm, "Whole-hand jitter SD per coordinate (mm), one displacement of all joints per row");
  auto* r = sub->add_option_group("tremor", "Overrides for --preset tremor / tremor-physiological");
  r->add_option("--tremor-min-hz", o->tremor_min_hz, "Lowest tremor frequency (Hz)");
  r->add_option("--tremor-max-hz", o->tremor_max_hz, "Highest tremor frequency (Hz)");
  r->add_option("--tremor-hand-mm", o->tremor_hand_mm, "Whole-hand oscillation amplitude (mm)");
  r->add_option("--tremor-finger-mm", o->tremor_finger_mm, "Extra fingertip oscillation amplitude (mm)");
  sub->callback([o] { run_corrupt(*o); });
}

const CommandRegistration register_corrupt(&setup_corrupt);

}  // namespace
}  // namespace hs::cli
