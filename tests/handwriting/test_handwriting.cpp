// Text layout, strokes CSV, pen timeline, pinch poses, synth_handwriting and the CLI.
#include "test_support.hpp"

#include "handsteady/error.hpp"
#include "handsteady/handwriting.hpp"
#include "handsteady/import.hpp"
#include "handsteady/ink.hpp"
#include "handsteady/synth.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <sstream>

using namespace hs;

namespace {

std::string track_text(const Track& t) {
  std::ostringstream out;
  write_track_csv(t, out);
  return out.str();
}

Eigen::Vector3d joint(const Pose& p, Joint j) { return p.row(idx(j)).transpose(); }

// Bone lengths of a pose, one per XR bone.
std::vector<double> bone_lengths(const Pose& p) {
  std::vector<double> out;
  for (const auto& [a, b] : xr_hand_skeleton().bones) out.push_back((p.row(a) - p.row(b)).norm());
  return out;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

StrokeSet parse_strokes(const std::string& text) {
  std::istringstream in(text);
  return parse_strokes_csv(in, "s.csv");
}

// The default synthesis, made once (about 0.1 s each).
const Handwriting& ismar(uint64_t seed = 1) {
  static std::map<uint64_t, Handwriting> cache;
  auto it = cache.find(seed);
  if (it == cache.end()) {
    HandwritingParams prm;
    prm.seed = seed;
    it = cache.emplace(seed, synth_handwriting(prm)).first;
  }
  return it->second;
}

}  // namespace

// ---- layout ------------------------------------------------------------------------------

TEST_CASE("layout_text: ISMAR in futural, 80 mm capitals, centred on the writing plane") {
  const TextLayout layout;
  const auto strokes = layout_text("ISMAR", layout);
  CHECK(strokes.size() == 12);  // I 1, S 1, M 4, A 3, R 3
  double xmin = 1e9, xmax = -1e9, ymin = 1e9, ymax = -1e9;
  for (const auto& s : strokes)
    for (const auto& p : s) {
      CHECK(p.z() == doctest::Approx(-0.45));
      xmin = std::min(xmin, p.x());
      xmax = std::max(xmax, p.x());
      ymin = std::min(ymin, p.y());
      ymax = std::max(ymax, p.y());
    }
  CHECK(xmin == doctest::Approx(-xmax));
  CHECK(ymax == doctest::Approx(0.04));
  CHECK(ymin == doctest::Approx(-0.04));
  // 'I' is one vertical stroke, top to bottom, one capital height long.
  REQUIRE(strokes[0].size() == 2);
  CHECK(polyline_length(strokes[0]) == doctest::Approx(0.080));
  CHECK(strokes[0][0].y() > strokes[0][1].y());
  // Left to right; other sizes and places scale and move.
  CHECK(strokes.front().front().x() < strokes.back().front().x());
  TextLayout small;
  small.letter_height_m = 0.05;
  small.centre = {0.1, -0.2, -0.3};
  const auto s2 = layout_text("I", small);
  REQUIRE(s2.size() == 1);
  CHECK(polyline_length(s2[0]) == doctest::Approx(0.05));
  CHECK(s2[0][0].x() == doctest::Approx(0.1));
  CHECK(s2[0][0].y() == doctest::Approx(-0.175));
  CHECK(s2[0][0].z() == doctest::Approx(-0.3));
  // A space advances the pen: "I I" is wider than "II".
  const auto spaced = layout_text("I I", layout), tight = layout_text("II", layout);
  CHECK(spaced[1][0].x() - spaced[0][0].x() > tight[1][0].x() - tight[0][0].x() + 0.03);
}

TEST_CASE("layout_text: clear errors for unknown characters, fonts and bad sizes") {
  const TextLayout layout;
  const std::string umlaut = error_of([&] { layout_text("IS\xc3\x84R", layout); });
  CHECK(umlaut.find("position 3") != std::string::npos);
  CHECK(umlaut.find("no glyph") != std::string::npos);
  CHECK(error_of([&] { layout_text("A\nB", layout); }).find("byte 0x0a at position 2") != std::string::npos);
  CHECK_THROWS_AS(layout_text("", layout), InputError);
  CHECK_THROWS_AS(layout_text("   ", layout), InputError);
  TextLayout bad_font;
  bad_font.font = "no-such-font";
  const std::string font_error = error_of([&] { layout_text("ISMAR", bad_font); });
  CHECK(font_error.find("no-such-font") != std::string::npos);
  CHECK(font_error.find("'font'") != std::string::npos);
  TextLayout zero;
  zero.letter_height_m = 0.0;
  CHECK_THROWS_AS(layout_text("ISMAR", zero), InputError);
  TextLayout script;
  script.font = "scripts";
  CHECK(!layout_text("ISMAR", script).empty());  // another installed Hershey font
}

// ---- strokes CSV ---------------------------------------------------------------------------

TEST_CASE("strokes CSV: round trip with metadata") {
  StrokeSet set;
  set.set_meta("text", "IS");
  set.strokes = layout_text("IS", TextLayout{});
  std::ostringstream out;
  write_strokes_csv(set, out);
  CHECK(out.str().rfind("# text: IS\nstroke,x,y,z\n0,", 0) == 0);
  const StrokeSet back = parse_strokes(out.str());
  CHECK(back.meta("text") == "IS");
  REQUIRE(back.strokes.size() == set.strokes.size());
  for (size_t s = 0; s < set.strokes.size(); ++s) {
    REQUIRE(back.strokes[s].size() == set.strokes[s].size());
    for (size_t i = 0; i < set.strokes[s].size(); ++i) CHECK((back.strokes[s][i] - set.strokes[s][i]).norm() < 1e-7);
  }
  std::ostringstream again;
  write_strokes_csv(back, again);
  CHECK(again.str() == out.str());

  const auto dir = test::temp_dir("strokes_csv");
  write_strokes_csv(set, dir / "s.csv");
  CHECK(read_strokes_csv(dir / "s.csv").strokes.size() == 2);
  CHECK(error_of([&] { read_strokes_csv(dir / "missing.csv"); }).find("cannot open") != std::string::npos);
}

TEST_CASE("strokes CSV: errors name file, line and column") {
  const auto err = [](const std::string& text) { return error_of([&] { parse_strokes(text); }); };
  CHECK(err("# only a comment\n").find("s.csv:1: no header") != std::string::npos);
  CHECK(err("stroke,x,y\n").find("s.csv:1: header has 3 columns") != std::string::npos);
  CHECK(err("stroke,x,z,y\n").find("s.csv:1: column 'z': header column 3 should be 'y'") != std::string::npos);
  CHECK(err("stroke,x,y,z\n0,1,2,3\n0,1,2\n").find("s.csv:3: row has 3 fields") != std::string::npos);
  CHECK(err("stroke,x,y,z\n0,1,abc,3\n").find("s.csv:2: column 'y': 'abc' is not a number") != std::string::npos);
  CHECK(err("stroke,x,y,z\n0,1,2,inf\n").find("s.csv:2: column 'z'") != std::string::npos);
  CHECK(err("stroke,x,y,z\n0,1,2,\n").find("s.csv:2: column 'z'") != std::string::npos);
  CHECK(err("stroke,x,y,z\n0,1e4,2,3\n").find("not a plausible position") != std::string::npos);
  CHECK(err("stroke,x,y,z\n1,1,2,3\n").find("s.csv:2: column 'stroke': stroke 1 follows stroke -1") !=
        std::string::npos);
  CHECK(err("stroke,x,y,z\n0,1,2,3\n2,1,2,3\n").find("s.csv:3: column 'stroke'") != std::string::npos);
  CHECK(err("stroke,x,y,z\n0,1,2,3\n1,1,2,3\n0,1,2,3\n").find("s.csv:4: column 'stroke'") != std::string::npos);
  CHECK(err("stroke,x,y,z\n-1,1,2,3\n").find("not a stroke index") != std::string::npos);
  CHECK(err("stroke,x,y,z\n0.5,1,2,3\n").find("not a stroke index") != std::string::npos);
  const StrokeSet ok = parse_strokes("# a: b\nstroke,x,y,z\n\n0,1,2,3\n0, 4 ,5,6\r\n1,+7,8,9\n");
  REQUIRE(ok.strokes.size() == 2);
  CHECK(ok.strokes[0].size() == 2);
  CHECK(ok.strokes[1][0].x() == 7.0);
}

// ---- pen timeline ------------------------------------------------------------------------

TEST_CASE("minimum-jerk profile") {
  CHECK(minimum_jerk(0.0) == 0.0);
  CHECK(minimum_jerk(0.5) == doctest::Approx(0.5));
  CHECK(minimum_jerk(1.0) == doctest::Approx(1.0));
  CHECK(minimum_jerk(-1.0) == 0.0);
  CHECK(minimum_jerk(2.0) == doctest::Approx(1.0));
}

TEST_CASE("pen path: bell-shaped speed at the set peak, pinch closed while drawing, lifted pen-up") {
  const PenTiming tm;
  const std::vector<Polyline> strokes = {{{0, 0, -0.45}, {0.1, 0, -0.45}}, {{0.2, 0, -0.45}, {0.2, -0.1, -0.45}}};
  const PenPath pen = plan_pen_path(strokes, tm);
  const double dt = 1e-3;
  double peak = 0.0, lift = 0.0, t_start = -1.0, t_end = -1.0;
  for (double t = 0.0; t + dt <= pen.duration_s(); t += dt) {
    const PenState a = pen.at(t), b = pen.at(t + dt);
    if (a.stroke == 0 && b.stroke == 0) {
      peak = std::max(peak, (b.pos - a.pos).norm() / dt);
      CHECK(a.pinch == 1.0);
      CHECK(a.pos.z() == doctest::Approx(-0.45));
      if (t_start < 0.0 && (b.pos - a.pos).norm() > 0.0) t_start = t;
      if ((b.pos - a.pos).norm() > 0.0) t_end = t;
    }
    if (a.stroke < 0 && a.pinch == 0.0 && a.pos.x() > 0.1 && a.pos.x() < 0.2) lift = std::max(lift, a.pos.z() + 0.45);
  }
  CHECK(peak == doctest::Approx(tm.peak_speed_m_s).epsilon(0.01));
  CHECK(t_end - t_start == doctest::Approx(1.875 * 0.1 / tm.peak_speed_m_s).epsilon(0.01));
  CHECK(lift == doctest::Approx(tm.lift_m).epsilon(0.01));
  // Starts and ends with the open hand in front of the plane; pinch is in [0, 1].
  CHECK(pen.at(0.0).pinch == 0.0);
  CHECK(pen.at(0.0).pos.z() == doctest::Approx(-0.45 + tm.approach_m));
  CHECK(pen.at(pen.duration_s()).pos.z() == doctest::Approx(-0.45 + tm.approach_m));
  CHECK(pen.at(1e9).pos.z() == doctest::Approx(-0.45 + tm.approach_m));
  for (const PenSegment& s : pen.segments) CHECK(s.duration > 0.0);
}

TEST_CASE("pen path: the pen stops at sharp corners and flows through gentle turns") {
  PenTiming tm;
  tm.corner_pause_s = 0.0;
  const auto min_speed_inside_stroke = [&](const Polyline& stroke) {
    const PenPath pen = plan_pen_path(std::vector<Polyline>{stroke}, tm);
    double t0 = -1, t1 = -1;
    for (const PenSegment& s : pen.segments)
      if (s.stroke == 0 && s.path.size() > 1) {
        if (t0 < 0) t0 = s.t0;
        t1 = s.t0 + s.duration;
      }
    // The middle 40 % of the stroke's movement (the corner, if any, is in the middle).
    double lowest = 1e9;
    for (double t = t0 + 0.3 * (t1 - t0); t < t1 - 0.3 * (t1 - t0); t += 1e-3)
      lowest = std::min(lowest, (pen.at(t + 1e-3).pos - pen.at(t).pos).norm() / 1e-3);
    return lowest;
  };
  CHECK(min_speed_inside_stroke({{0, 0, -0.45}, {0.05, 0, -0.45}, {0.05, -0.05, -0.45}}) < 0.01);    // 90 deg: stops
  CHECK(min_speed_inside_stroke({{0, 0, -0.45}, {0.05, 0, -0.45}, {0.097, -0.017, -0.45}}) > 0.05);  // 20 deg: flows
  CHECK_THROWS_AS(plan_pen_path(std::vector<Polyline>{}, tm), std::invalid_argument);
  CHECK_THROWS_AS(plan_pen_path(std::vector<Polyline>{Polyline{}}, tm), std::invalid_argument);
  PenTiming bad;
  bad.peak_speed_m_s = 0.0;
  CHECK_THROWS_AS(plan_pen_path(std::vector<Polyline>{{{0, 0, 0}}}, bad), std::invalid_argument);
}

// ---- hand poses --------------------------------------------------------------------------

TEST_CASE("hand frame: independent of where the hand is and how it is turned") {
  HandArticulation art;
  art.curl = {0.3, 0.2, 0.5, 0.6, 0.7};
  const Pose local = synth_hand_pose(art);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  const Pose a = to_hand_frame(local), b = to_hand_frame(transform_pose(local, q, {0.1, -0.2, -0.4}));
  CHECK((a - b).cwiseAbs().maxCoeff() < 1e-12);
  CHECK(a.row(idx(Joint::Wrist)).norm() < 1e-15);
  CHECK(a(idx(Joint::MiddleProximal), 0) == doctest::Approx(0.0).epsilon(1e-12));
  CHECK(a(idx(Joint::MiddleProximal), 2) < -0.05);  // fingers along -Z
  CHECK(a(idx(Joint::LittleProximal), 0) > a(idx(Joint::IndexProximal), 0));
  CHECK_THROWS_AS(to_hand_frame(untracked_pose()), std::invalid_argument);
}

TEST_CASE("parametric pinch poses: a right hand that pinches and opens, bones kept by the blend") {
  const PinchPoses poses = parametric_pinch_poses();
  CHECK(thumb_index_distance(poses.pinched) == doctest::Approx(0.006).epsilon(0.01));
  CHECK(thumb_index_distance(poses.open) == doctest::Approx(0.060).epsilon(0.01));
  CHECK(thumb_index_distance(blend_pinch(poses, 0.0)) == doctest::Approx(0.060).epsilon(0.01));
  CHECK(thumb_index_distance(blend_pinch(poses, 1.0)) == doctest::Approx(0.006).epsilon(0.01));
  // A right hand: fingers curl towards the palm (-Y), thumb on the -X side.
  CHECK(poses.pinched(idx(Joint::IndexTip), 1) < -0.03);
  CHECK(poses.pinched(idx(Joint::ThumbProximal), 0) < 0.0);
  // Thumb bones: the parametric lengths 45, 32, 28 mm, in both poses and in the blend.
  for (double w : {0.0, 0.3, 0.7, 1.0}) {
    const Pose p = blend_pinch(poses, w);
    CHECK((joint(p, Joint::ThumbProximal) - joint(p, Joint::ThumbMetacarpal)).norm() == doctest::Approx(0.045));
    CHECK((joint(p, Joint::ThumbDistal) - joint(p, Joint::ThumbProximal)).norm() == doctest::Approx(0.032));
    CHECK((joint(p, Joint::ThumbTip) - joint(p, Joint::ThumbDistal)).norm() == doctest::Approx(0.028));
  }
  // The distance shrinks monotonically as the pinch closes (no overshoot, no chatter).
  double last = 1.0;
  for (int k = 0; k <= 20; ++k) {
    const double d = thumb_index_distance(blend_pinch(poses, k / 20.0));
    CHECK(d <= last + 1e-12);
    last = d;
  }
}

namespace {

// A recording-like track: the parametric hand moving and turning while it pinches and
// opens (distance from 6 cm to 6 mm and back), optionally as a left hand.
Track pinching_track(bool left) {
  const PinchPoses poses = parametric_pinch_poses();
  HandSeries s;
  for (int k = 0; k <= 60; ++k) {
    const double w = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * k / 60.0);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.02 * k, Eigen::Vector3d::UnitY()));
    Pose p = transform_pose(blend_pinch(poses, w), q, {0.1 + 0.001 * k, -0.2, -0.4});
    if (left) p.col(0) *= -1.0;
    s.t.push_back(k / 30.0);
    s.pos.push_back(p);
  }
  Track tr;
  add_hand_series(tr, left ? Hand::Left : Hand::Right, s);
  return tr;
}

}  // namespace

TEST_CASE("pinch poses from a track: the pinched and an open frame, in the hand frame") {
  for (bool left : {false, true}) {
    CAPTURE(left);
    Track tr = pinching_track(left);
    // A tracker glitch: the thumb tip snapped onto the index tip (its bone far too long).
    TrackRow glitch = tr.rows[5];
    glitch.t = 10.0;
    glitch.pos.row(idx(Joint::ThumbTip)) = glitch.pos.row(idx(Joint::IndexTip));
    tr.rows.push_back(glitch);
    const PinchPoses p = pinch_poses_from_track(tr, "rec.csv");
    CHECK(thumb_index_distance(p.pinched) == doctest::Approx(0.006).epsilon(0.02));
    CHECK(thumb_index_distance(p.open) >= 0.05);
    CHECK(thumb_index_distance(p.open) <= 0.07);
    CHECK(p.source.find("rec.csv") != std::string::npos);
    CHECK(p.source.find(left ? "left hand mirrored" : "right hand") != std::string::npos);
    // Back in the hand frame: the parametric pinched pose, whatever the recorded placement.
    CHECK((p.pinched - parametric_pinch_poses().pinched).cwiseAbs().maxCoeff() < 1e-3);
  }
  // No pinch, no open hand, nothing tracked: clear errors naming the file.
  Track open_only = pinching_track(false);
  std::erase_if(open_only.rows, [](const TrackRow& r) { return thumb_index_distance(r.pos) < 0.03; });
  const std::string no_pinch = error_of([&] { pinch_poses_from_track(open_only, "open.csv"); });
  CHECK(no_pinch.find("open.csv: no pinch") != std::string::npos);
  Track closed_only = pinching_track(false);
  std::erase_if(closed_only.rows, [](const TrackRow& r) { return thumb_index_distance(r.pos) > 0.03; });
  const std::string no_open = error_of([&] { pinch_poses_from_track(closed_only, "c.csv"); });
  CHECK(no_open.find("c.csv: no open hand frame") != std::string::npos);
  CHECK_THROWS_AS(pinch_poses_from_track(Track{}, "empty.csv"), InputError);
}

// ---- synth_handwriting ------------------------------------------------------------------

TEST_CASE("synth_handwriting: clean ink lies on the font, one ink stroke per font stroke") {
  const Handwriting& hw = ismar();
  CHECK(hand_series(hw.clean, Hand::Left).empty());
  const HandSeries clean = hand_series(hw.clean, Hand::Right);
  REQUIRE(clean.size() == static_cast<size_t>(std::floor(hw.pen.duration_s() * 60.0)) + 1);
  CHECK(clean.t[1] == doctest::Approx(1.0 / 60.0));
  const auto ink = extract_ink(clean);
  const InkMetrics m = ink_metrics(ink, hw.strokes.strokes, &clean);
  CHECK(m.font_strokes == 12);
  CHECK(m.ink_strokes == 12);
  CHECK(m.p95_distance_mm < 0.01);
  CHECK(m.mean_distance_mm < 0.01);
  CHECK(m.coverage > 0.999);
  CHECK(std::abs(m.latency_ms) < 1.0);
  // Ink stroke k follows font stroke k.
  for (size_t k = 0; k < ink.size(); ++k) {
    CHECK((ink[k].p.front() - hw.strokes.strokes[k].front()).norm() < 1e-6);
    CHECK((ink[k].p.back() - hw.strokes.strokes[k].back()).norm() < 1e-6);
  }
}

TEST_CASE("synth_handwriting: thumb pinches while writing, opens between strokes, the hand is rigid and turns") {
  const Handwriting& hw = ismar();
  const HandSeries s = hand_series(hw.clean, Hand::Right);
  const std::vector<double> bones0 = bone_lengths(s.pos.front());
  double max_angle = 0.0;
  for (size_t i = 0; i < s.size(); ++i) {
    const PenState pen = hw.pen.at(s.t[i]);
    const double d = thumb_index_distance(s.pos[i]);
    if (pen.stroke >= 0) CHECK(d <= 0.010);
    if (pen.pinch == 0.0) CHECK(d >= 0.040);
    CHECK((joint(s.pos[i], Joint::IndexTip) - pen.pos).norm() < 1e-9);  // the pen is the index tip
    // Finger bones keep their length (the blend only turns them).
    const std::vector<double> bones = bone_lengths(s.pos[i]);
    for (size_t b = 0; b < bones.size(); ++b)
      if (xr_hand_skeleton().bones[b].first != idx(Joint::Wrist)) CHECK(bones[b] == doctest::Approx(bones0[b]));
    // Wrist rotation: the wrist -> middle knuckle direction turns along the path.
    const Eigen::Vector3d a = joint(s.pos[0], Joint::MiddleProximal) - joint(s.pos[0], Joint::Wrist);
    const Eigen::Vector3d b = joint(s.pos[i], Joint::MiddleProximal) - joint(s.pos[i], Joint::Wrist);
    max_angle = std::max(max_angle, std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)));
  }
  CHECK(max_angle > 0.05);  // about 3 deg or more ...
  CHECK(max_angle < 0.5);   // ... but slight
}

TEST_CASE("synth_handwriting: tremor and tracker noise make the ink measurably worse") {
  const Handwriting& hw = ismar();
  const HandSeries truth = hand_series(hw.clean, Hand::Right);
  const InkMetrics clean = ink_metrics(extract_ink(truth), hw.strokes.strokes, &truth);
  const InkMetrics noisy = ink_metrics(extract_ink(hand_series(hw.noisy, Hand::Right)), hw.strokes.strokes, &truth);
  CHECK(noisy.mean_distance_mm > clean.mean_distance_mm + 1.0);
  CHECK(noisy.p95_distance_mm > 2.0);
  CHECK(noisy.jerk_rms_m_s3 > 5.0 * clean.jerk_rms_m_s3);
  CHECK(noisy.coverage < clean.coverage);
  CHECK(std::abs(noisy.latency_ms) < 5.0);  // noise, no delay

  HandwritingParams physio;
  physio.tremor = TremorKind::Physiological;
  physio.noise = TrackerNoise::None;
  const Handwriting ph = synth_handwriting(physio);
  const InkMetrics pm = ink_metrics(extract_ink(hand_series(ph.noisy, Hand::Right)), ph.strokes.strokes, &truth);
  CHECK(pm.mean_distance_mm > clean.mean_distance_mm);
  CHECK(pm.mean_distance_mm < noisy.mean_distance_mm);
  CHECK(pm.ink_strokes == 12);

  HandwritingParams quiet;
  quiet.tremor = TremorKind::None;
  quiet.noise = TrackerNoise::None;
  const Handwriting q = synth_handwriting(quiet);
  REQUIRE(q.noisy.rows.size() == q.clean.rows.size());
  for (size_t i = 0; i < q.clean.rows.size(); ++i) CHECK(q.noisy.rows[i].pos == q.clean.rows[i].pos);
}

TEST_CASE("synth_handwriting: same seed same output, another seed other noise on the same clean track") {
  HandwritingParams prm;
  const Handwriting again = synth_handwriting(prm);
  CHECK(track_text(again.noisy) == track_text(ismar(1).noisy));
  CHECK(track_text(again.clean) == track_text(ismar(1).clean));
  const Handwriting& other = ismar(2);
  REQUIRE(other.clean.rows.size() == ismar(1).clean.rows.size());
  for (size_t i = 0; i < other.clean.rows.size(); ++i) CHECK(other.clean.rows[i].pos == ismar(1).clean.rows[i].pos);
  REQUIRE(other.noisy.rows.size() == ismar(1).noisy.rows.size());
  size_t differ = 0;
  for (size_t i = 0; i < other.noisy.rows.size(); ++i) {
    const Pose& a = other.noisy.rows[i].pos;
    const Pose& b = ismar(1).noisy.rows[i].pos;
    differ += (a.array() != b.array()).any() ? 1 : 0;  // NaN != NaN also counts: dropouts differ too
  }
  CHECK(differ > other.noisy.rows.size() / 2);
}

TEST_CASE("synth_handwriting: metadata and the strokes file") {
  const Handwriting& hw = ismar();
  CHECK(hw.clean.meta("source")->rfind("synth-handwriting text=\"ISMAR\"", 0) == 0);
  CHECK(hw.clean.meta("text") == "ISMAR");
  CHECK(hw.clean.meta("font") == "futural");
  CHECK(hw.clean.meta("tremor") == "parkinson");
  CHECK(hw.clean.meta("noise") == "tracker");
  CHECK(hw.clean.meta("seed") == "1");
  CHECK(hw.clean.meta("rate_hz") == "60");
  CHECK(hw.clean.meta("pose_source")->find("parametric") != std::string::npos);
  CHECK(hw.clean.meta("content") == std::optional<std::string>("clean (no noise)"));
  CHECK(hw.noisy.meta("corruption")->rfind("tracker seed=", 0) == 0);
  int corruption_lines = 0;
  for (const auto& l : hw.noisy.header_lines) corruption_lines += l.rfind("corruption:", 0) == 0 ? 1 : 0;
  CHECK(corruption_lines == 2);  // tremor, then tracker
  CHECK(hw.strokes.meta("text") == "ISMAR");
  CHECK(hw.strokes.meta("strokes") == "12");
  CHECK(hw.strokes.strokes.size() == 12);
}

TEST_CASE("synth_handwriting: bad inputs throw clear errors") {
  HandwritingParams prm;
  prm.rate_hz = 0.0;
  CHECK_THROWS_AS(synth_handwriting(prm), std::invalid_argument);
  prm.rate_hz = 60.0;
  prm.text = "ISM\xe2\x82\xac";  // euro sign
  CHECK(error_of([&] { synth_handwriting(prm); }).find("position 4") != std::string::npos);
  prm.text = "ISMAR";
  prm.layout.font = "nope";
  CHECK_THROWS_AS(synth_handwriting(prm), InputError);
  CHECK(parse_tremor("parkinson") == TremorKind::Parkinson);
  CHECK(parse_tremor("physiological") == TremorKind::Physiological);
  CHECK(parse_tremor("none") == TremorKind::None);
  CHECK_FALSE(parse_tremor("essential"));
  CHECK(parse_tracker_noise("tracker") == TrackerNoise::Tracker);
  CHECK_FALSE(parse_tracker_noise("paper"));
  CHECK(tremor_name(TremorKind::Physiological) == "physiological");
}

TEST_CASE("synth_handwriting: other rates and real poses") {
  HandwritingParams prm;
  prm.rate_hz = 23.3;  // HoloLens 2 rate: still one ink stroke per font stroke
  prm.poses = pinch_poses_from_track(pinching_track(true), "rec.csv");
  const Handwriting hw = synth_handwriting(prm);
  const HandSeries clean = hand_series(hw.clean, Hand::Right);
  const InkMetrics m = ink_metrics(extract_ink(clean), hw.strokes.strokes, &clean);
  CHECK(m.ink_strokes == 12);
  CHECK(m.p95_distance_mm < 0.01);
  CHECK(m.coverage > 0.999);  // the ink polyline covers the font at any rate
  CHECK(hw.clean.meta("pose_source")->find("rec.csv") != std::string::npos);
}

TEST_CASE("synth_handwriting: with poses from the HoloLens 2 recordings") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  const auto dir = test::shared_data() / "hololens2";
  if (!std::filesystem::is_directory(dir)) {
    MESSAGE("skipped: no hololens2 recordings");
    return;
  }
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".csv") continue;
    CAPTURE(entry.path().string());
    HandwritingParams prm;
    prm.poses = pinch_poses_from_track(import_mrtk(entry.path()), entry.path().string());
    CHECK(thumb_index_distance(prm.poses->pinched) < 0.010);
    CHECK(thumb_index_distance(prm.poses->open) >= 0.05);
    const Handwriting hw = synth_handwriting(prm);
    const HandSeries clean = hand_series(hw.clean, Hand::Right);
    const InkMetrics m = ink_metrics(extract_ink(clean), hw.strokes.strokes, &clean);
    CHECK(m.ink_strokes == 12);
    CHECK(m.p95_distance_mm < 1.0);
    for (size_t i = 0; i < clean.size(); ++i)
      if (hw.pen.at(clean.t[i]).stroke >= 0) CHECK(thumb_index_distance(clean.pos[i]) < 0.010);
  }
}

// ---- CLI ---------------------------------------------------------------------------------

TEST_CASE("CLI: synth-handwriting writes the noisy track, the clean track and the strokes") {
  const auto dir = test::temp_dir("cli_synth_handwriting");
  const auto out = dir / "hw" / "track.csv";
  REQUIRE(test::run_cli("synth-handwriting --text ISMAR --tremor parkinson --seed 3 --rate 30 --out " + out.string() +
                        " > /dev/null") == 0);
  const Track noisy = read_track_csv(out);
  const Track clean = read_track_csv(dir / "hw" / "track_clean.csv");
  const StrokeSet strokes = read_strokes_csv(dir / "hw" / "track_strokes.csv");
  CHECK(strokes.strokes.size() == 12);
  CHECK(clean.meta("rate_hz") == "30");
  CHECK(noisy.meta("seed") == "3");
  CHECK(noisy.rows.size() == clean.rows.size());
  const HandSeries c = hand_series(clean, Hand::Right);
  CHECK(extract_ink(c).size() == 12);

  // Explicit companion paths, physiological tremor, no tracker noise, another font.
  REQUIRE(test::run_cli("synth-handwriting --text Hi --tremor physiological --noise none --font rowmans "
                        "--letter-height-mm 60 --out " + (dir / "a.csv").string() + " --clean-out " +
                        (dir / "b.csv").string() + " --strokes-out " + (dir / "c.csv").string() + " > /dev/null") == 0);
  CHECK(read_strokes_csv(dir / "c.csv").meta("font") == "rowmans");
  CHECK(read_track_csv(dir / "b.csv").meta("tremor") == "physiological");

  // Bad inputs: exit status 2 for input errors, non-zero for bad options.
  CHECK(test::run_cli("synth-handwriting --text 'I\xc3\x84' --tremor none --out " + (dir / "x.csv").string() +
                      " 2> /dev/null") == 2);
  CHECK(test::run_cli("synth-handwriting --text I --tremor none --font nope --out " + (dir / "x.csv").string() +
                      " 2> /dev/null") == 2);
  CHECK(test::run_cli("synth-handwriting --text I --tremor none --pose-from " + (dir / "missing.csv").string() +
                      " --out " + (dir / "x.csv").string() + " 2> /dev/null") == 2);
  CHECK(test::run_cli("synth-handwriting --text I --tremor essential --out " + (dir / "x.csv").string() +
                      " > /dev/null 2>&1") != 0);
  CHECK(test::run_cli("synth-handwriting --text I --tremor none > /dev/null 2>&1") != 0);  // --out missing
  CHECK_FALSE(std::filesystem::exists(dir / "x.csv"));

  // --pose-from a track with a pinching hand.
  write_track_csv(pinching_track(false), dir / "rec.csv");
  REQUIRE(test::run_cli("synth-handwriting --text A --tremor none --pose-from " + (dir / "rec.csv").string() +
                        " --out " + (dir / "p.csv").string() + " > /dev/null") == 0);
  CHECK(read_track_csv(dir / "p.csv").meta("pose_source")->find("rec.csv") != std::string::npos);
  std::filesystem::remove_all(dir);
}
