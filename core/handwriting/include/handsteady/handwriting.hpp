#pragma once
// Synthetic air handwriting (docs/HANDWRITING.md): text laid out with a Hershey vector
// font on a vertical writing plane in front of the user, written by a right hand whose
// index tip is the pen while thumb and index pinch. Produces the clean track, a noisy copy
// (tremor, then tracker noise; seeded) and the font strokes, the reference for the ink.
// Units: metres, seconds; OpenXR convention (right-handed, +Y up, -Z forward).
#include "handsteady/track.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace hs {

// A stroke: the points the pen passes through, in order (one point = a dot).
using Polyline = std::vector<Eigen::Vector3d>;
double polyline_length(const Polyline& line);

// ---------------------------------------------------------------------------------------
// Font strokes file: "stroke,x,y,z" CSV with '#' metadata lines as in the track format.
// stroke = 0-based stroke index; rows of one stroke are consecutive and in pen order;
// indices start at 0 and grow by one. x, y, z in metres.
struct StrokeSet {
  std::vector<std::string> header_lines;  // '#' lines without "# ", in file order
  std::vector<Polyline> strokes;

  std::optional<std::string> meta(std::string_view key) const;  // last "key: value"
  void set_meta(std::string_view key, std::string_view value);   // replaces or appends
};

// Reading throws InputError naming file, line and column: wrong header or column count,
// non-numbers, inf/nan, a stroke index that is negative, skips one or goes back, absurd
// coordinates (> 1000 m).
StrokeSet read_strokes_csv(const std::filesystem::path& path);
StrokeSet parse_strokes_csv(std::istream& in, const std::string& source_name);
// Coordinates with 7 decimals (0.1 um), like the track writer.
void write_strokes_csv(const StrokeSet& set, const std::filesystem::path& path);
void write_strokes_csv(const StrokeSet& set, std::ostream& out);

// ---------------------------------------------------------------------------------------
// Text layout with a Hershey font (libhersheyfont).
struct TextLayout {
  // A name in /usr/share/hershey-fonts ("futural", "scripts", ...; HERSHEY_FONTS_DIR
  // overrides the folder) or a path to a .jhf file.
  std::string font = "futural";
  double letter_height_m = 0.080;  // capital height (the extent of 'H')
  // x: centre of the text's ink bounding box; y: middle of the capital band (baseline at
  // y - h/2); z: the writing plane. LOCAL reference space: the head at the origin, so y = 0
  // is eye height and the text floats 45 cm in front of the eyes.
  Eigen::Vector3d centre{0.0, 0.0, -0.45};
};

// The text's font strokes, left to right, on the plane z = centre.z. Spaces advance the
// pen. Throws InputError (field "text" or "font") for an empty text, a character the font
// has no glyph for (its position is named), an unknown font, a non-positive height.
std::vector<Polyline> layout_text(std::string_view text, const TextLayout& layout);

// ---------------------------------------------------------------------------------------
// The pen's timeline: where the pen (index tip) is and how far the pinch is closed.
struct PenTiming {
  // Pen-down: a stroke is split where it turns more than corner_deg; each piece is one
  // minimum-jerk movement (bell-shaped speed, zero speed and acceleration at both ends)
  // with peak speed peak_speed (duration = 1.875 L / v_peak, at least min_piece_s).
  double peak_speed_m_s = 0.30;
  double min_piece_s = 0.12;
  double corner_deg = 50.0;
  double corner_pause_s = 0.04;
  // Pen-up: a minimum-jerk movement from a stroke's end to the next stroke's start that
  // lifts off the plane towards the user by lift_m (half a sine over the movement).
  double penup_peak_speed_m_s = 0.45;
  double min_penup_s = 0.30;
  double lift_m = 0.015;
  // Pinch: closes (open -> pinched) over pinch_blend_s while the pen rests on a stroke's
  // start, then settle_s before moving; at the end settle_s, then opens over pinch_blend_s.
  double pinch_blend_s = 0.15;
  double settle_s = 0.08;
  // Before the first and after the last stroke: the open hand rests lead_s at approach_m
  // in front of the plane, then moves in (out) in approach_s.
  double lead_s = 0.5;
  double approach_m = 0.03;
  double approach_s = 0.35;
};

struct PenState {
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();
  double pinch = 0.0;  // 0 = open hand, 1 = pinched
  int stroke = -1;     // font stroke the pinched pen is on (pinch closed .. release), else -1
};

// One piece of the timeline: a minimum-jerk movement along `path` by arc length (one
// point = rest), plus a bell-shaped lift towards +Z, while the pinch blends (minimum-jerk)
// from pinch_from to pinch_to over the piece.
struct PenSegment {
  double t0 = 0.0, duration = 0.0;
  Polyline path;
  std::vector<double> arc;  // cumulative length at each path point
  double lift_m = 0.0;
  double pinch_from = 0.0, pinch_to = 0.0;
  int stroke = -1;
};

struct PenPath {
  std::vector<PenSegment> segments;  // contiguous in time, starting at t = 0
  double duration_s() const;
  PenState at(double t) const;  // clamped to [0, duration]
};

// Throws std::invalid_argument for no strokes or non-positive speeds/durations.
PenPath plan_pen_path(std::span<const Polyline> strokes, const PenTiming& timing = {});

// Minimum-jerk position profile s(u) = 10u^3 - 15u^4 + 6u^5 on u in [0, 1] (clamped).
double minimum_jerk(double u);

// ---------------------------------------------------------------------------------------
// Hand poses. The hand frame: wrist at the origin, fingers along -Z (wrist -> middle
// proximal), palm facing -Y, thumb towards -X (+X towards the little finger): the frame
// of synth_hand_pose's right hand.
struct PinchPoses {
  Pose pinched;        // thumb tip at the index tip, in the hand frame
  Pose open;           // thumb tip 5-7 cm from the index tip, in the hand frame
  std::string source;  // for the track metadata
};

// World -> hand-frame rotation/origin of a right-hand pose (needs wrist, index_proximal,
// middle_proximal, little_proximal); throws std::invalid_argument when they are missing.
Pose to_hand_frame(const Pose& world);
double thumb_index_distance(const Pose& p);  // thumb_tip - index_tip, m (NaN if untracked)

// The parametric hand (synth_hand_pose, mirrored in Y: as generated, its fingers curl
// towards +Y, the geometry of a left hand palm up) with the index flexed as in a pinch and
// the other three fingers curled. Its thumb cannot reach the index tip by curling alone:
// the thumb chain is curled to the needed reach (but no less than 0.2 rad), turned rigidly
// about the thumb metacarpal joint towards the target and, if still short, slid along that
// line (thumb bone lengths kept; only wrist -> thumb_metacarpal stretches). pinched = tip
// 6 mm from the index tip (the pads touch), open = 6 cm away.
PinchPoses parametric_pinch_poses();
// A real pinched frame (the smallest thumb-index distance) and a real open frame (distance
// in 5-7 cm, the one whose four fingers are closest to the pinched frame's) from the hand
// of `track` with more fully tracked frames (a left hand is mirrored into a right hand).
// Frames whose bones differ by more than 20 % from the hand's median are skipped (tracker
// glitches). Throws InputError naming source_name when no frame qualifies.
PinchPoses pinch_poses_from_track(const Track& track, const std::string& source_name);
// Bone-wise blend in the hand frame from open (w = 0) to pinched (w = 1): the wrist stays,
// each bone's direction is slerped and its length interpolated, so bones keep their length.
Pose blend_pinch(const PinchPoses& poses, double w);

// ---------------------------------------------------------------------------------------
enum class TremorKind { None, Physiological, Parkinson };
enum class TrackerNoise { None, Tracker };
std::optional<TremorKind> parse_tremor(std::string_view s);  // none|physiological|parkinson
std::string_view tremor_name(TremorKind k);
std::optional<TrackerNoise> parse_tracker_noise(std::string_view s);  // none|tracker
std::string_view tracker_noise_name(TrackerNoise k);

struct HandwritingParams {
  std::string text = "ISMAR";
  TextLayout layout;
  PenTiming timing;
  double rate_hz = 60.0;
  uint64_t seed = 1;  // drives the noise only: the clean track is the same for every seed
  TremorKind tremor = TremorKind::Parkinson;
  TrackerNoise noise = TrackerNoise::Tracker;
  std::optional<PinchPoses> poses;  // empty = parametric_pinch_poses()
  // Hand orientation while writing (radians, applied to the hand frame in this order: roll
  // about the finger axis, pitch up, yaw left): palm turned 45 deg towards the left (thumb
  // up-left), fingers raised 20 deg and pointing 10 deg to the left.
  double roll_rad = -0.785, pitch_rad = 0.35, yaw_rad = 0.17;
  // Natural wrist rotation along the path: the hand turns towards where it writes
  // (yaw/pitch per metre of pen offset from the text centre) and sways slowly (amplitude).
  double follow_rad_per_m = 0.6;
  double sway_rad = 0.04;
};

struct Handwriting {
  Track clean;  // right hand only (no left rows)
  Track noisy;  // clean + tremor + tracker noise (as chosen), same rows and times
  StrokeSet strokes;
  PenPath pen;
};

// Throws InputError for bad text/font (see layout_text) and std::invalid_argument for a
// rate outside (0, 1000] Hz or bad timing.
Handwriting synth_handwriting(const HandwritingParams& params);

}  // namespace hs
