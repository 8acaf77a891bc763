// synth_handwriting: text -> font strokes -> pen timeline -> a right hand carrying the pen
// on its index tip -> clean track -> tremor and tracker noise (docs/HANDWRITING.md).
#include "handsteady/corrupt.hpp"
#include "handsteady/handwriting.hpp"
#include "handsteady/synth.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace hs {

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// splitmix64 finaliser: one well-separated seed per noise stage from the user's seed.
uint64_t stage_seed(uint64_t seed, uint64_t stage) {
  uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (stage + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Hand orientation (hand frame -> world) at time t with the pen at `pen`: the base writing
// posture, turned towards where the pen is (the forearm pivots at the elbow, so writing to
// the right turns the fingers right and writing higher raises them), plus a slow sway.
// The sway frequencies are fixed and incommensurate: the clean track is seed-independent.
Eigen::Quaterniond hand_orientation(const HandwritingParams& prm, const Eigen::Vector3d& pen, double t) {
  const Eigen::Vector3d offset = pen - prm.layout.centre;
  const double yaw = prm.yaw_rad - prm.follow_rad_per_m * offset.x() + prm.sway_rad * std::sin(kTwoPi * 0.23 * t);
  const double pitch =
      prm.pitch_rad + prm.follow_rad_per_m * offset.y() + prm.sway_rad * std::sin(kTwoPi * 0.31 * t + 1.0);
  const double roll = prm.roll_rad + 0.5 * prm.sway_rad * std::sin(kTwoPi * 0.17 * t + 2.0);
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ());
}

// The hand pose that puts the (blended) index tip exactly on the pen.
Pose hand_at(const HandwritingParams& prm, const PinchPoses& poses, const PenState& pen, double t) {
  const Pose local = blend_pinch(poses, pen.pinch);
  const Eigen::Quaterniond q = hand_orientation(prm, pen.pos, t);
  const Eigen::Vector3d tip = local.row(idx(Joint::IndexTip)).transpose();
  return transform_pose(local, q, pen.pos - q * tip);
}

HandSeries write_with_hand(const HandwritingParams& prm, const PinchPoses& poses, const PenPath& pen) {
  const auto frames = static_cast<size_t>(std::floor(pen.duration_s() * prm.rate_hz + 1e-9)) + 1;
  HandSeries s;
  s.t.reserve(frames);
  s.pos.reserve(frames);
  for (size_t k = 0; k < frames; ++k) {
    const double t = static_cast<double>(k) / prm.rate_hz;
    s.t.push_back(t);
    s.pos.push_back(hand_at(prm, poses, pen.at(t), t));
  }
  return s;
}

std::string describe_plane(const TextLayout& l) {
  return fmt::format("z={:.3f} m, text centre x={:.3f} y={:.3f} m (LOCAL space: head at the origin, y=0 eye height)",
                     l.centre.z(), l.centre.x(), l.centre.y());
}

void add_common_metadata(Track& tr, const HandwritingParams& prm, const std::string& pose_source) {
  tr.set_meta("source", fmt::format("synth-handwriting text=\"{}\" font={} tremor={} noise={} seed={} rate_hz={}",
                                    prm.text, prm.layout.font, tremor_name(prm.tremor),
                                    tracker_noise_name(prm.noise), prm.seed, prm.rate_hz));
  tr.set_meta("rate_hz", fmt::format("{}", prm.rate_hz));
  tr.set_meta("text", prm.text);
  tr.set_meta("font", prm.layout.font);
  tr.set_meta("letter_height_mm", fmt::format("{}", prm.layout.letter_height_m * 1e3));
  tr.set_meta("writing_plane", describe_plane(prm.layout));
  tr.set_meta("tremor", tremor_name(prm.tremor));
  tr.set_meta("noise", tracker_noise_name(prm.noise));
  tr.set_meta("pose_source", pose_source);
  tr.set_meta("seed", fmt::format("{}", prm.seed));
  tr.set_meta("hands", "right hand writes; no left hand rows");
}

// Tremor first (the hand shakes), then the tracker measures the shaking hand.
Track add_noise(const Track& clean, const HandwritingParams& prm) {
  Track noisy = clean;
  noisy.set_meta("content", "noisy (tremor, then tracker noise; truth in the clean track)");
  if (prm.tremor != TremorKind::None) {
    const char* preset = prm.tremor == TremorKind::Parkinson ? "tremor" : "tremor-physiological";
    const uint64_t s = stage_seed(prm.seed, 1);
    noisy = corrupt_track(noisy, corruption_preset(preset), s);
    noisy.header_lines.push_back(fmt::format("corruption: {} seed={}", preset, s));
  }
  if (prm.noise == TrackerNoise::Tracker) {
    const uint64_t s = stage_seed(prm.seed, 2);
    noisy = corrupt_track(noisy, corruption_preset("tracker"), s);
    noisy.header_lines.push_back(fmt::format("corruption: tracker seed={}", s));
  }
  return noisy;
}

StrokeSet make_stroke_set(const HandwritingParams& prm, std::vector<Polyline> strokes) {
  StrokeSet set;
  set.set_meta("source", fmt::format("synth-handwriting text=\"{}\" font={}", prm.text, prm.layout.font));
  set.set_meta("text", prm.text);
  set.set_meta("font", prm.layout.font);
  set.set_meta("letter_height_mm", fmt::format("{}", prm.layout.letter_height_m * 1e3));
  set.set_meta("writing_plane", describe_plane(prm.layout));
  set.set_meta("units", "metres, OpenXR convention (right-handed, +Y up, -Z forward)");
  set.set_meta("strokes", fmt::format("{}", strokes.size()));
  set.strokes = std::move(strokes);
  return set;
}

}  // namespace

std::optional<TremorKind> parse_tremor(std::string_view s) {
  if (s == "none") return TremorKind::None;
  if (s == "physiological") return TremorKind::Physiological;
  if (s == "parkinson") return TremorKind::Parkinson;
  return std::nullopt;
}

std::string_view tremor_name(TremorKind k) {
  switch (k) {
    case TremorKind::None: return "none";
    case TremorKind::Physiological: return "physiological";
    case TremorKind::Parkinson: return "parkinson";
  }
  return "?";
}

std::optional<TrackerNoise> parse_tracker_noise(std::string_view s) {
  if (s == "none") return TrackerNoise::None;
  if (s == "tracker") return TrackerNoise::Tracker;
  return std::nullopt;
}

std::string_view tracker_noise_name(TrackerNoise k) { return k == TrackerNoise::Tracker ? "tracker" : "none"; }

Handwriting synth_handwriting(const HandwritingParams& prm) {
  if (!(prm.rate_hz > 0.0 && prm.rate_hz <= 1000.0))
    throw std::invalid_argument(fmt::format("synth_handwriting: rate must be in (0, 1000] Hz, got {}", prm.rate_hz));
  Handwriting out;
  std::vector<Polyline> strokes = layout_text(prm.text, prm.layout);
  out.pen = plan_pen_path(strokes, prm.timing);
  const PinchPoses poses = prm.poses ? *prm.poses : parametric_pinch_poses();
  add_common_metadata(out.clean, prm, poses.source);
  out.clean.set_meta("content", "clean (no noise)");
  add_hand_series(out.clean, Hand::Right, write_with_hand(prm, poses, out.pen));
  out.noisy = add_noise(out.clean, prm);
  out.strokes = make_stroke_set(prm, std::move(strokes));
  return out;
}

}  // namespace hs
