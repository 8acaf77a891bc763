// handsteady synth-handwriting: a right hand writing text in the air (index tip = pen while
// thumb and index pinch), clean and with tremor + tracker noise, plus the font strokes
// (docs/HANDWRITING.md).
#include "commands.hpp"

#include "handsteady/error.hpp"
#include "handsteady/handwriting.hpp"
#include "handsteady/ink.hpp"
#include "handsteady/track.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <string>

namespace hs::cli {
namespace {

namespace fs = std::filesystem;

struct SynthHandwritingOptions {
  std::string text, tremor, out, clean_out, strokes_out, pose_from;
  std::string noise = "tracker", font = "futural";
  double rate_hz = 60.0, letter_height_mm = 80.0;
  uint64_t seed = 1;
};

// "<dir>/<stem of out><suffix>.csv", the default names of the companion files.
fs::path beside(const fs::path& out, const std::string& suffix) {
  return out.parent_path() / (out.stem().string() + suffix + ".csv");
}

HandwritingParams build_params(const SynthHandwritingOptions& o) {
  HandwritingParams prm;
  prm.text = o.text;
  const auto tremor = parse_tremor(o.tremor);
  if (!tremor)
    throw InputError({"", 0, "--tremor"}, fmt::format("'{}' is not parkinson, physiological or none", o.tremor));
  prm.tremor = *tremor;
  const auto noise = parse_tracker_noise(o.noise);
  if (!noise) throw InputError({"", 0, "--noise"}, fmt::format("'{}' is not tracker or none", o.noise));
  prm.noise = *noise;
  prm.layout.font = o.font;
  prm.layout.letter_height_m = o.letter_height_mm * 1e-3;
  prm.rate_hz = o.rate_hz;
  prm.seed = o.seed;
  if (!o.pose_from.empty()) prm.poses = pinch_poses_from_track(read_track_csv(o.pose_from), o.pose_from);
  return prm;
}

void write_file_set(const Handwriting& hw, const fs::path& out, const fs::path& clean, const fs::path& strokes) {
  for (const fs::path& p : {out, clean, strokes})
    if (p.has_parent_path()) fs::create_directories(p.parent_path());
  write_track_csv(hw.noisy, out);
  write_track_csv(hw.clean, clean);
  write_strokes_csv(hw.strokes, strokes);
}

void print_ink_summary(const char* label, const Track& track, const Handwriting& hw) {
  const HandSeries hand = hand_series(track, Hand::Right);
  const HandSeries truth = hand_series(hw.clean, Hand::Right);
  const auto ink = extract_ink(hand);
  const InkMetrics m = ink_metrics(ink, hw.strokes.strokes, &truth);
  fmt::print("  {:<5} ink: {} strokes ({} font strokes), {} points, distance mean {:.2f} mm p95 {:.2f} mm, "
             "coverage {:.3f}, jerk {:.1f} m/s^3, latency {:.1f} ms\n",
             label, m.ink_strokes, m.font_strokes, m.ink_points, m.mean_distance_mm, m.p95_distance_mm, m.coverage,
             m.jerk_rms_m_s3, m.latency_ms);
}

void run_synth_handwriting(const SynthHandwritingOptions& o) {
  const HandwritingParams prm = build_params(o);
  const Handwriting hw = synth_handwriting(prm);
  const fs::path out(o.out);
  const fs::path clean = o.clean_out.empty() ? beside(out, "_clean") : fs::path(o.clean_out);
  const fs::path strokes = o.strokes_out.empty() ? beside(out, "_strokes") : fs::path(o.strokes_out);
  write_file_set(hw, out, clean, strokes);
  fmt::print("synth-handwriting: \"{}\" ({} font strokes, {:.1f} s, {} rows at {} Hz), pose: {}\n", prm.text,
             hw.strokes.strokes.size(), hw.pen.duration_s(), hw.clean.rows.size(), prm.rate_hz,
             *hw.clean.meta("pose_source"));
  fmt::print("  wrote {} (tremor {}, noise {}, seed {}), {}, {}\n", out.string(), tremor_name(prm.tremor),
             tracker_noise_name(prm.noise), prm.seed, clean.string(), strokes.string());
  print_ink_summary("clean", hw.clean, hw);
  print_ink_summary("noisy", hw.noisy, hw);
}

void setup_synth_handwriting(CLI::App& app) {
  auto o = std::make_shared<SynthHandwritingOptions>();
  CLI::App* sub = app.add_subcommand(
      "synth-handwriting", "Write a right hand writing text in the air (pinch = pen down), clean and noisy, "
                           "plus the font strokes; see docs/HANDWRITING.md");
  sub->add_option("--text", o->text, "Text to write (characters of the font; spaces allowed)")->required();
  sub->add_option("--tremor", o->tremor, "Tremor: parkinson (4-6 Hz), physiological (8-12 Hz) or none")
      ->required()
      ->check(CLI::IsMember({"parkinson", "physiological", "none"}));
  sub->add_option("--out", o->out, "Noisy output track CSV (tremor, then tracker noise)")->required();
  sub->add_option("--clean-out", o->clean_out, "Clean track CSV (default: <out stem>_clean.csv)");
  sub->add_option("--strokes-out", o->strokes_out, "Font strokes CSV (default: <out stem>_strokes.csv)");
  sub->add_option("--pose-from", o->pose_from,
                  "Track CSV to take a real pinched and open hand pose from (default: parametric hand)");
  sub->add_option("--rate", o->rate_hz, "Frame rate in Hz")->check(CLI::Range(1.0, 1000.0))->capture_default_str();
  sub->add_option("--seed", o->seed, "Noise seed (same seed, same output)")->capture_default_str();
  sub->add_option("--noise", o->noise, "Tracker noise after the tremor: tracker (HoloLens 2 preset) or none")
      ->check(CLI::IsMember({"tracker", "none"}))
      ->capture_default_str();
  sub->add_option("--font", o->font, "Hershey font name (/usr/share/hershey-fonts) or .jhf path")
      ->capture_default_str();
  sub->add_option("--letter-height-mm", o->letter_height_mm, "Capital letter height (mm)")
      ->check(CLI::Range(5.0, 1000.0))
      ->capture_default_str();
  sub->callback([o] { run_synth_handwriting(*o); });
}

const CommandRegistration register_synth_handwriting(&setup_synth_handwriting);

}  // namespace
}  // namespace hs::cli
