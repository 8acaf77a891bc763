#include "handsteady/import.hpp"
#include "handsteady/track_ops.hpp"

#include "test_support.hpp"

#include <Eigen/Geometry>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

using namespace hs;

namespace {

constexpr double kEps = 1e-9;

Eigen::Vector3d at(const Pose& p, Joint j) { return p.row(idx(j)).transpose(); }

// What an InputError says, or "" when none is thrown.
template <class F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// The FPHA fixture: joint j of frame f is at (10 j + f, 100 + j, 300 + 2 j) mm.
Eigen::Vector3d fpha_fixture_joint(int j, int f) {
  return {0.001 * (10 * j + f), -0.001 * (100 + j), -0.001 * (300 + 2 * j)};
}

// Writes the FPHA fixture tree once per run: Subject_1/act_a/1 (3 frames), act_a/2 (empty,
// as three real FPHA takes are), act_b/1 (4 frames). Generated rather than committed so no
// file named like a recording is tracked.
std::filesystem::path fpha_fixture_dir() {
  static const std::filesystem::path root = [] {
    const auto dir = test::temp_dir("fpha_fixture") / "fpha";
    const std::pair<const char*, int> takes[] = {{"Subject_1/act_a/1", 3}, {"Subject_1/act_a/2", 0}, {"Subject_1/act_b/1", 4}};
    for (auto [take, frames] : takes) {
      std::filesystem::create_directories(dir / take);
      std::ofstream out(dir / take / "skeleton.txt");
      for (int f = 0; f < frames; ++f) {
        out << fmt::format("{:04d}", f);
        for (int j = 0; j < 21; ++j) out << fmt::format(" {:.4f} {:.4f} {:.4f}", 10.0 * j + f, 100.0 + j, 300.0 + 2.0 * j);
        out << '\n';
      }
    }
    return dir;
  }();
  return root;
}

double median_bone_mm(const HandSeries& s, Joint a, Joint b) {
  std::vector<double> d;
  for (const auto& p : s.pos)
    if (joint_tracked(p, idx(a)) && joint_tracked(p, idx(b))) d.push_back(1000.0 * (at(p, a) - at(p, b)).norm());
  if (d.empty()) return std::nan("");
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

}  // namespace

// ---------------------------------------------------------------- FPHA

TEST_CASE("fpha: joints map to the XR columns with mm -> m and (x, -y, -z)") {
  const Track t = import_fpha_file(fpha_fixture_dir() / "Subject_1/act_a/1/skeleton.txt");
  REQUIRE(t.rows.size() == 3);
  // FPHA index: wrist 0, thumb MCP 1, index MCP 2, middle MCP 3, ..., index tip 11, little tip 20.
  const std::pair<int, Joint> expect[] = {{0, Joint::Wrist},          {1, Joint::ThumbMetacarpal},
                                          {2, Joint::IndexProximal},  {3, Joint::MiddleProximal},
                                          {5, Joint::LittleProximal}, {6, Joint::ThumbProximal},
                                          {8, Joint::ThumbTip},       {9, Joint::IndexIntermediate},
                                          {11, Joint::IndexTip},      {14, Joint::MiddleTip},
                                          {17, Joint::RingTip},       {18, Joint::LittleIntermediate},
                                          {20, Joint::LittleTip}};
  for (int f = 0; f < 3; ++f) {
    const TrackRow& r = t.rows[static_cast<size_t>(f)];
    CHECK(r.hand == Hand::Right);
    CHECK(r.t == doctest::Approx(f / 30.0));
    for (auto [fpha, xr] : expect) CHECK((at(r.pos, xr) - fpha_fixture_joint(fpha, f)).norm() < kEps);
    CHECK(tracked_joint_count(r.pos) == kJointCount);
  }
  CHECK(t.meta("rate_hz") == "30");
  CHECK(t.meta("derived") == "palm,index_metacarpal,middle_metacarpal,ring_metacarpal,little_metacarpal");
}

TEST_CASE("fpha: derived metacarpals and palm follow the documented formulas") {
  const Track t = import_fpha_file(fpha_fixture_dir() / "Subject_1/act_a/1/skeleton.txt");
  const Pose& p = t.rows[1].pos;
  const Eigen::Vector3d w = fpha_fixture_joint(0, 1);
  const double a[4] = {0.25, 0.24, 0.27, 0.33};
  const Joint meta[4] = {Joint::IndexMetacarpal, Joint::MiddleMetacarpal, Joint::RingMetacarpal, Joint::LittleMetacarpal};
  for (int f = 0; f < 4; ++f) {
    const Eigen::Vector3d mcp = fpha_fixture_joint(2 + f, 1);
    CHECK((at(p, meta[f]) - (w + a[f] * (mcp - w))).norm() < kEps);
  }
  const Eigen::Vector3d middle_meta = w + 0.24 * (fpha_fixture_joint(3, 1) - w);
  CHECK((at(p, Joint::Palm) - 0.5 * (middle_meta + fpha_fixture_joint(3, 1))).norm() < kEps);
}

TEST_CASE("fpha: empty file gives an empty track") {
  const Track t = import_fpha_file(fpha_fixture_dir() / "Subject_1/act_a/2/skeleton.txt");
  CHECK(t.rows.empty());
  CHECK(t.meta("source").has_value());
}

TEST_CASE("fpha: bad lines name file, line and field") {
  std::string good, second;
  for (int k = 0; k < 64; ++k) good += (k ? " " : "") + std::to_string(k);
  for (int k = 0; k < 64; ++k) second += (k ? " " : "") + std::to_string(k ? k : 1);
  auto parse = [](const std::string& text) {
    std::istringstream in(text);
    return parse_fpha(in, "mem.txt");
  };
  CHECK(parse(good + "\n").rows.size() == 1);
  std::string e = input_error([&] { parse(good + "\n1 2 3\n"); });
  CHECK(contains(e, "mem.txt:2"));
  CHECK(contains(e, "3 fields"));
  // Field 11 of the line is y3 (frame_index, then x0 y0 z0 ... ).
  std::string bad = second;
  bad.replace(bad.find(" 11 "), 4, " abc ");
  e = input_error([&] { parse(good + "\n" + bad + "\n"); });
  CHECK(contains(e, "mem.txt:2"));
  CHECK(contains(e, "'y3'"));
  CHECK(contains(e, "'abc' is not a number"));
  // Frame indices must increase.
  e = input_error([&] { parse(good + "\n" + good + "\n"); });
  CHECK(contains(e, "mem.txt:2: column 'frame_index'"));
}

TEST_CASE("fpha: directory import, one track per take and concatenation") {
  const auto dir = fpha_fixture_dir();
  const auto takes = import_fpha_takes(dir);
  REQUIRE(takes.size() == 3);  // sorted: act_a/1 (3 rows), act_a/2 (empty), act_b/1 (4 rows)
  CHECK(takes[0].rows.size() == 3);
  CHECK(takes[1].rows.empty());
  CHECK(takes[2].rows.size() == 4);
  CHECK(takes[2].meta("take") == "Subject_1/act_b/1/skeleton.txt");

  const Track all = import_fpha(dir);
  // 3 rows, one untracked separator, 4 rows.
  REQUIRE(all.rows.size() == 8);
  const double end_a = 2.0 / 30.0;
  CHECK(!any_joint_tracked(all.rows[3].pos));
  CHECK(all.rows[3].t == doctest::Approx(end_a + 0.5));
  CHECK(all.rows[4].t == doctest::Approx(end_a + 1.0));
  CHECK(all.rows[7].t == doctest::Approx(end_a + 1.0 + 3.0 / 30.0));
  CHECK((at(all.rows[4].pos, Joint::IndexTip) - fpha_fixture_joint(11, 0)).norm() < kEps);
  std::vector<std::string> take_lines;
  for (const auto& l : all.header_lines)
    if (l.rfind("take:", 0) == 0) take_lines.push_back(l);
  REQUIRE(take_lines.size() == 2);
  CHECK(take_lines[0] == "take: 0.000000 Subject_1/act_a/1/skeleton.txt");
  CHECK(contains(take_lines[1], "Subject_1/act_b/1/skeleton.txt"));
  CHECK(all.meta("empty_take") == "Subject_1/act_a/2/skeleton.txt");
  CHECK(all.meta("derived").has_value());
  // Times strictly increase, so the track round-trips through the CSV format.
  std::stringstream csv;
  write_track_csv(all, csv);
  CHECK(parse_track_csv(csv, "rt.csv").rows.size() == all.rows.size());
}

TEST_CASE("fpha: a single file import is that take") {
  const Track t = import_fpha(fpha_fixture_dir() / "Subject_1/act_b/1/skeleton.txt");
  CHECK(t.rows.size() == 4);
}

// ---------------------------------------------------------------- MRTK

TEST_CASE("mrtk: wall clock parsing") {
  CHECK(parse_wall_clock("1970-01-01 00:00:00.000") == doctest::Approx(0.0));
  CHECK(parse_wall_clock("1970-01-02 00:00:01.5") == doctest::Approx(86401.5));
  // 2024 is a leap year: Feb 29 exists, so Mar 1 - Feb 28 = 2 days.
  CHECK(*parse_wall_clock("2024-03-01 00:00:00") - *parse_wall_clock("2024-02-28 00:00:00") == doctest::Approx(172800.0));
  CHECK(!parse_wall_clock("2024-02-19 20:28"));
  CHECK(!parse_wall_clock("2024-13-19 20:28:00.000"));
  CHECK(!parse_wall_clock("2024-02-19 20:28:00.1x"));
}

TEST_CASE("mrtk: both hands, untracked cells, dropped rows, axes") {
  const auto path = test::fixture("mrtk_small.csv");
  const Track t = import_mrtk(path);
  // 5 data rows, 2 dropped (repeated and earlier Time) -> 3 rows x 2 hands.
  REQUIRE(t.rows.size() == 6);
  CHECK(t.meta("dropped_rows") == "2");
  const HandSeries right = hand_series(t, Hand::Right), left = hand_series(t, Hand::Left);
  REQUIRE(right.size() == 3);
  REQUIRE(left.size() == 3);
  // Times from the first row, across midnight: 23:59:59.990 -> 00:00:00.030 -> .075.
  CHECK(right.t[0] == doctest::Approx(0.0));
  CHECK(right.t[1] == doctest::Approx(0.040));
  CHECK(right.t[2] == doctest::Approx(0.085));
  CHECK(!any_joint_tracked(right.pos[0]));
  CHECK(!any_joint_tracked(left.pos[0]));
  CHECK(!any_joint_tracked(left.pos[1]));  // a hand of '0' cells is untracked
  CHECK(tracked_joint_count(right.pos[1]) == kJointCount);
  CHECK(tracked_joint_count(right.pos[2]) == kJointCount - 1);  // ThumbTip was '0'
  CHECK(!joint_tracked(right.pos[2], idx(Joint::ThumbTip)));

  // The fixture puts header column k (0-based among the 26) of the first hand at
  // (k/100, 0.2, 0.4 + k/1000) and of the second at (-k/100, 0.25, 0.5 + k/1000).
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  std::vector<std::string> names;
  std::stringstream hs(header);
  for (std::string c; std::getline(hs, c, ',');) names.push_back(c);
  auto column = [&](const std::string& n) {
    return static_cast<int>(std::find(names.begin(), names.end(), n) - names.begin()) - 3;
  };
  const std::pair<const char*, Joint> mapping[] = {
      {"Wrist", Joint::Wrist},
      {"Palm", Joint::Palm},
      {"ThumbMetacarpalJoint", Joint::ThumbMetacarpal},
      {"ThumbDistalJoint", Joint::ThumbDistal},
      {"IndexKnuckle", Joint::IndexProximal},
      {"IndexMiddleJoint", Joint::IndexIntermediate},
      {"IndexDistalJoint", Joint::IndexDistal},
      {"IndexTip", Joint::IndexTip},
      {"MiddleMetacarpal", Joint::MiddleMetacarpal},
      {"RingKnuckle", Joint::RingProximal},
      {"PinkyMetacarpal", Joint::LittleMetacarpal},
      {"PinkyMiddleJoint", Joint::LittleIntermediate},
      {"PinkyTip", Joint::LittleTip},
  };
  for (auto [name, joint] : mapping) {
    const int k = column(name);
    REQUIRE(k >= 0);
    // Unity (left-handed, +Z forward) -> OpenXR: z negated.
    const Eigen::Vector3d r(k / 100.0, 0.2, -(0.4 + k / 1000.0));
    const Eigen::Vector3d l(-k / 100.0, 0.25, -(0.5 + k / 1000.0));
    CHECK((at(right.pos[1], joint) - r).norm() < 1e-12);
    CHECK((at(left.pos[2], joint) - l).norm() < 1e-12);
  }
}

TEST_CASE("mrtk: bad input names line and column") {
  std::ifstream in(test::fixture("mrtk_small.csv"));
  std::string header, row;
  std::getline(in, header);
  std::getline(in, row);
  std::getline(in, row);  // the first tracked row
  auto parse = [](const std::string& text) {
    std::istringstream s(text);
    return parse_mrtk(s, "hl.csv");
  };
  CHECK(parse(header + "\n" + row + "\n").rows.size() == 2);
  // A malformed cell: the 5th joint column of the first hand is IndexTip.
  std::string bad = row;
  const size_t p = bad.find("(0.040/ 0.200/ 0.404)");
  REQUIRE(p != std::string::npos);
  bad.replace(p, 21, "(0.040; 0.200; 0.404)");
  std::string e = input_error([&] { parse(header + "\n" + row + "\n" + bad + "\n"); });
  CHECK(contains(e, "hl.csv:3: column 'IndexTip'"));
  bad = row;
  bad.replace(bad.find("2024"), 4, "20x4");
  e = input_error([&] { parse(header + "\n" + bad + "\n"); });
  CHECK(contains(e, "hl.csv:2: column 'Time'"));
  e = input_error([&] { parse(header + "\n" + row.substr(0, row.rfind(',')) + "\n"); });
  CHECK(contains(e, "hl.csv:2"));
  CHECK(contains(e, "fields"));
  std::string bad_header = header;
  bad_header.replace(bad_header.find("IndexTip"), 8, "IndexTop");
  e = input_error([&] { parse(bad_header + "\n"); });
  CHECK(contains(e, "hl.csv:1: column 'IndexTop'"));
}

// ---------------------------------------------------------------- BVH

TEST_CASE("bvh: parser and forward kinematics on a two-joint chain") {
  const BvhData b = read_bvh(test::fixture("tiny.bvh"));
  REQUIRE(b.joints.size() == 2);
  CHECK(b.channel_count == 9);
  CHECK(b.frame_time == 0.5);
  REQUIRE(b.frames.size() == 3);
  CHECK(b.joints[1].parent == 0);
  CHECK(b.joints[1].first_channel == 6);
  CHECK(b.joints[1].has_end_site);
  auto end_site = [&](const BvhFrame& f) -> Eigen::Vector3d {
    return f.position[1] + f.rotation[1] * b.joints[1].end_offset;
  };
  // Rest: A at its offset, end site 2 up from it.
  BvhFrame f = bvh_forward_kinematics(b, 0);
  CHECK((f.position[1] - Eigen::Vector3d(1, 0, 0)).norm() < kEps);
  CHECK((end_site(f) - Eigen::Vector3d(1, 2, 0)).norm() < kEps);
  // Root at (1,2,3), Zrotation 90 then Xrotation 90 (R = Rz Rx): Rx leaves +X alone,
  // Rz turns it to +Y; (the other order would give +Z). (0,2,0) -> Rx -> (0,0,2) -> Rz -> (0,0,2).
  f = bvh_forward_kinematics(b, 1);
  CHECK((f.position[0] - Eigen::Vector3d(1, 2, 3)).norm() < kEps);
  CHECK((f.position[1] - Eigen::Vector3d(1, 3, 3)).norm() < kEps);
  CHECK((end_site(f) - Eigen::Vector3d(1, 3, 5)).norm() < kEps);
  // A's own Zrotation 90 turns its end site from +Y to -X.
  f = bvh_forward_kinematics(b, 2);
  CHECK((end_site(f) - Eigen::Vector3d(-1, 0, 0)).norm() < kEps);
}

TEST_CASE("bvh: errors name file, line and token") {
  std::ifstream in(test::fixture("tiny.bvh"));
  std::stringstream buf;
  buf << in.rdbuf();
  const std::string good = buf.str();
  auto parse = [](const std::string& text) {
    std::istringstream s(text);
    return parse_bvh(s, "t.bvh");
  };
  CHECK(parse(good).frames.size() == 3);
  auto with = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  std::string e = input_error([&] { parse(with("Zrotation Yrotation Xrotation", "Zrotation Yrotation Wrotation")); });
  CHECK(contains(e, "t.bvh:9: column 'Wrotation'"));
  e = input_error([&] { parse(with("OFFSET 1.0 0.0 0.0", "OFFSET 1.0 zero 0.0")); });
  CHECK(contains(e, "t.bvh:8: column 'zero'"));
  e = input_error([&] { parse(with("1 2 3 90 90 0 0 0 0", "1 2 3 90 90 0 0 0")); });
  CHECK(contains(e, "t.bvh:20"));
  CHECK(contains(e, "8 values, expected 9"));
  e = input_error([&] { parse(with("1 2 3 90 90 0 0 0 0", "1 2 3 90 x 0 0 0 0")); });
  CHECK(contains(e, "t.bvh:20: column 'channel 5'"));
  e = input_error([&] { parse(with("Frames: 3", "Frames: 4")); });
  CHECK(contains(e, "3 of 4 frames"));
  e = input_error([&] { parse(with("Frames: 3", "Frames: 2")); });
  CHECK(contains(e, "t.bvh:21"));
  e = input_error([&] { parse(with("MOTION", "MOTON")); });
  CHECK(contains(e, "no MOTION"));
  e = input_error([&] { parse(with("\t\t}\n\t}\n}", "\t\t}\n\t}\n")); });
  CHECK(contains(e, "file ends"));
}

// Inputs that crashed fuzz_bvh (tests/fuzz): a frame count was reserved before any frame was read
// (2.4 GB for "Frames: 99999999"), and deep JOINT nesting overflowed the stack.
TEST_CASE("bvh: a huge frame count or hierarchy is an error, not an allocation or a stack overflow") {
  auto parse = [](const std::string& text) {
    std::istringstream s(text);
    return parse_bvh(s, "t.bvh");
  };
  const std::string huge_count = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 99999999\nFrame Time: 1\n";
  std::string e = input_error([&] { parse(huge_count); });
  CHECK(contains(e, "file ends after 0 of 99999999 frames"));

  auto nested = [](int depth) {
    std::string s = "HIERARCHY\nROOT j0 {OFFSET 0 0 0\n";
    for (int d = 1; d < depth; ++d) s += fmt::format("JOINT j{} {{OFFSET 0 0 0\n", d);
    return s + std::string(static_cast<size_t>(depth), '}') + "\nMOTION\nFrames: 0\nFrame Time: 1\n";
  };
  CHECK(parse(nested(256)).joints.size() == 256);
  e = input_error([&] { parse(nested(257)); });
  CHECK(contains(e, "t.bvh:258: column 'j256': joints nested more than 256 deep"));
  CHECK(contains(input_error([&] { parse(nested(100'000)); }), "nested more than 256 deep"));

  auto siblings = [](int joints) {
    std::string s = "HIERARCHY\nROOT j0 {OFFSET 0 0 0\n";
    for (int j = 1; j < joints; ++j) s += fmt::format("JOINT j{} {{OFFSET 0 0 0}}\n", j);
    return s + "}\nMOTION\nFrames: 0\nFrame Time: 1\n";
  };
  CHECK(parse(siblings(1024)).joints.size() == 1024);
  e = input_error([&] { parse(siblings(1025)); });
  CHECK(contains(e, "t.bvh:1026: column 'j1024': more than 1024 joints"));
}

namespace {

// A ManipNet-named hand: every chain along +X, spread in Y; all channels zero except
// the second frame's. Decimetres.
std::string manipnet_like(const std::string& second_frame) {
  std::string s = "HIERARCHY\nROOT WRIST\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n";
  struct F {
    const char* names[3];
    double y;
  };
  const F fingers[] = {{{"THUMB_CMC_AA", "THUMB_MCP_FE", "THUMB_IP_FE"}, 2.0},
                       {{"INDEX_MCP", "INDEX_PIP_FE", "INDEX_DIP_FE"}, 1.0},
                       {{"MIDDLE_MCP", "MIDDLE_PIP_FE", "MIDDLE_DIP_FE"}, 0.0},
                       {{"RING_MCP", "RING_PIP_FE", "RING_DIP_FE"}, -1.0},
                       {{"PINKY_MCP", "PINKY_PIP_FE", "PINKY_DIP_FE"}, -2.0}};
  for (const auto& f : fingers) {
    s += " JOINT " + std::string(f.names[0]) + "\n {\n  OFFSET 10 " + std::to_string(f.y) +
         " 0\n  CHANNELS 3 Zrotation Yrotation Xrotation\n";
    s += "  JOINT " + std::string(f.names[1]) + "\n  {\n   OFFSET 4 0 0\n   CHANNELS 3 Zrotation Yrotation Xrotation\n";
    s += "   JOINT " + std::string(f.names[2]) + "\n   {\n    OFFSET 2 0 0\n    CHANNELS 3 Zrotation Yrotation Xrotation\n";
    s += "    End Site\n    {\n     OFFSET 0 0 0\n    }\n   }\n  }\n }\n";
  }
  s += "}\nMOTION\nFrames: 2\nFrame Time: 0.0083333333\n";
  for (int c = 0; c < 6 + 15 * 3; ++c) s += "0 ";
  return s + "\n" + second_frame + "\n";
}

}  // namespace

TEST_CASE("bvh: ManipNet mapping, axes, units, extrapolated tips, wrist shift") {
  // Second frame: root at (1, 2, 3) dm, INDEX_DIP_FE (joint 6) Zrotation 90.
  std::string f2 = "1 2 3 0 0 0";
  for (int j = 1; j < 16; ++j) f2 += (j == 6 ? " 90 0 0" : " 0 0 0");
  std::istringstream in(manipnet_like(f2));
  const BvhData b = parse_bvh(in, "mem_rightHand.bvh");
  REQUIRE(b.find("INDEX_DIP_FE") == 6);

  BvhImportOptions no_shift;
  no_shift.relocate_wrist = false;
  Track t = bvh_to_track(b, "mem_rightHand.bvh", no_shift);
  REQUIRE(t.rows.size() == 2);
  CHECK(t.rows[0].hand == Hand::Right);
  CHECK(t.rows[1].t == doctest::Approx(0.0083333333));
  CHECK(t.meta("rate_hz") == "120");
  const std::string derived = *t.meta("derived");
  for (const char* j : {"palm", "thumb_tip", "index_metacarpal", "index_tip", "little_tip", "little_metacarpal"})
    CHECK(contains(derived, j));
  CHECK(!contains(derived, "index_proximal"));
  // dm -> m and (x, y, -z): frame 0, everything on the XY plane.
  const Pose& p0 = t.rows[0].pos;
  CHECK(tracked_joint_count(p0) == kJointCount);
  CHECK((at(p0, Joint::Wrist) - Eigen::Vector3d(0, 0, 0)).norm() < kEps);
  CHECK((at(p0, Joint::IndexProximal) - Eigen::Vector3d(1.0, 0.1, 0)).norm() < kEps);
  CHECK((at(p0, Joint::IndexDistal) - Eigen::Vector3d(1.6, 0.1, 0)).norm() < kEps);
  CHECK((at(p0, Joint::ThumbMetacarpal) - Eigen::Vector3d(1.0, 0.2, 0)).norm() < kEps);
  // Tip = distal + ratio * (last bone, 0.2 m): index 0.65, little 0.79, thumb 0.55.
  CHECK((at(p0, Joint::IndexTip) - Eigen::Vector3d(1.6 + 0.65 * 0.2, 0.1, 0)).norm() < kEps);
  CHECK((at(p0, Joint::LittleTip) - Eigen::Vector3d(1.6 + 0.79 * 0.2, -0.2, 0)).norm() < kEps);
  CHECK((at(p0, Joint::ThumbTip) - Eigen::Vector3d(1.6 + 0.55 * 0.2, 0.2, 0)).norm() < kEps);
  CHECK((at(p0, Joint::IndexMetacarpal) - 0.25 * at(p0, Joint::IndexProximal)).norm() < kEps);
  // Frame 1: translated by (1, 2, 3) dm -> (0.1, 0.2, -0.3) m; the DIP's 90 degree
  // Zrotation bends the extrapolated index tip from +X to +Y.
  const Pose& p1 = t.rows[1].pos;
  const Eigen::Vector3d shift(0.1, 0.2, -0.3);
  CHECK((at(p1, Joint::MiddleDistal) - at(p0, Joint::MiddleDistal) - shift).norm() < kEps);
  CHECK((at(p1, Joint::IndexTip) - (at(p1, Joint::IndexDistal) + Eigen::Vector3d(0, 0.65 * 0.2, 0))).norm() < kEps);

  // Default: the wrist moves towards the middle MCP so that wrist->MCP = 1.733 x MCP->PIP.
  t = bvh_to_track(b, "mem_rightHand.bvh", {});
  const double expect_shift = 1.0 - 1.733 * 0.4;  // m along +X
  CHECK((at(t.rows[0].pos, Joint::Wrist) - Eigen::Vector3d(expect_shift, 0, 0)).norm() < kEps);
  CHECK(t.meta("wrist_shift_mm") == "306.8");
  CHECK(hand_size(hand_series(t, Hand::Right)) == doctest::Approx(1.733 * 0.4));

  // Hand from the file name, or given; a name without either is an error.
  CHECK(bvh_to_track(b, "x_leftHand.bvh", {}).rows[0].hand == Hand::Left);
  BvhImportOptions left;
  left.hand = Hand::Left;
  CHECK(bvh_to_track(b, "x_rightHand.bvh", left).rows[0].hand == Hand::Left);
  CHECK(contains(input_error([&] { bvh_to_track(b, "x.bvh", {}); }), "cannot tell the hand"));
  // A missing joint is named.
  std::string text = manipnet_like(f2);
  text.replace(text.find("RING_PIP_FE"), 11, "RING_PIP_XX");
  std::istringstream in2(text);
  const BvhData b2 = parse_bvh(in2, "y_rightHand.bvh");
  CHECK(contains(input_error([&] { bvh_to_track(b2, "y_rightHand.bvh", {}); }), "'RING_PIP_FE'"));
}

// ---------------------------------------------------------------- real data (optional)

TEST_CASE("real data: an FPHA take has plausible bone lengths") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  const auto file = test::shared_data() / "fpha/Subject_1/charge_cell_phone/1/skeleton.txt";
  if (!std::filesystem::exists(file)) {
    MESSAGE("skipped: " << file << " is absent");
    return;
  }
  const Track t = import_fpha_file(file);
  REQUIRE(t.rows.size() > 10);
  const HandSeries s = hand_series(t, Hand::Right);
  // Bone lengths in mm (measured on subjects 1-5: index proximal ~44, intermediate ~27,
  // distal ~20; wrist -> middle MCP ~69; thumb base ~14 mm from the wrist).
  CHECK(median_bone_mm(s, Joint::IndexProximal, Joint::IndexIntermediate) == doctest::Approx(44).epsilon(0.35));
  CHECK(median_bone_mm(s, Joint::IndexIntermediate, Joint::IndexDistal) == doctest::Approx(27).epsilon(0.35));
  CHECK(median_bone_mm(s, Joint::IndexDistal, Joint::IndexTip) == doctest::Approx(20).epsilon(0.35));
  CHECK(median_bone_mm(s, Joint::Wrist, Joint::ThumbMetacarpal) < 30.0);
  CHECK(hand_size(s) == doctest::Approx(0.069).epsilon(0.3));
  // OpenXR axes: in a head-mounted view the fingers point away from the wearer (-Z)
  // and mostly up from the wrist.
  Eigen::Vector3d dir = Eigen::Vector3d::Zero();
  for (const auto& p : s.pos) dir += (at(p, Joint::MiddleProximal) - at(p, Joint::Wrist)).normalized();
  CHECK(dir.z() < 0.0);
}

TEST_CASE("real data: a HoloLens 2 recording imports both hands") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  const auto file = test::shared_data() / "hololens2/20240216_202836897.csv";
  if (!std::filesystem::exists(file)) {
    MESSAGE("skipped: " << file << " is absent");
    return;
  }
  const Track t = import_mrtk(file);
  const HandSeries right = hand_series(t, Hand::Right), left = hand_series(t, Hand::Left);
  size_t tracked[2] = {0, 0};
  for (const auto& p : left.pos) tracked[0] += any_joint_tracked(p) ? 1 : 0;
  for (const auto& p : right.pos) tracked[1] += any_joint_tracked(p) ? 1 : 0;
  CHECK(tracked[0] > 1000);  // the recording is mostly the second ('.1', left) hand
  CHECK(tracked[1] > 5);
  const double rate = std::stod(*t.meta("rate_hz"));
  CHECK(rate > 15.0);
  CHECK(rate < 35.0);
  CHECK(hand_size(left) == doctest::Approx(0.075).epsilon(0.25));
  CHECK(median_bone_mm(left, Joint::IndexProximal, Joint::IndexIntermediate) == doctest::Approx(39).epsilon(0.3));
  // The hand assignment agrees with the finger-curl chirality.
  const std::string check = *t.meta("chirality_check_left");
  CHECK(std::stod(check) > 0.8);
}

TEST_CASE("real data: a ManipNet BVH gives plausible finger bones and hand size") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  const auto file = test::shared_data() / "manipnet/cup1_rightHand.bvh";
  if (!std::filesystem::exists(file)) {
    MESSAGE("skipped: " << file << " is absent");
    return;
  }
  const Track t = import_bvh(file);
  CHECK(t.rows.size() > 3000);
  CHECK(t.meta("rate_hz") == "120");
  const HandSeries s = hand_series(t, Hand::Right);
  for (auto [a, b] : {std::pair{Joint::IndexProximal, Joint::IndexIntermediate},
                      std::pair{Joint::IndexIntermediate, Joint::IndexDistal},
                      std::pair{Joint::IndexDistal, Joint::IndexTip},
                      std::pair{Joint::MiddleProximal, Joint::MiddleIntermediate},
                      std::pair{Joint::LittleIntermediate, Joint::LittleDistal},
                      std::pair{Joint::ThumbProximal, Joint::ThumbDistal}}) {
    const double mm = median_bone_mm(s, a, b);
    CHECK(mm > 10.0);
    CHECK(mm < 60.0);
  }
  CHECK(hand_size(s) == doctest::Approx(0.083).epsilon(0.15));
  // Right-hand chirality in OpenXR axes: fingers curl to the side (index - wrist) x
  // (little - wrist) points to.
  int right_handed = 0, n = 0;
  for (size_t i = 0; i < s.size(); i += 50, ++n) {
    const Pose& p = s.pos[i];
    const Eigen::Vector3d w = at(p, Joint::Wrist);
    const Eigen::Vector3d normal = (at(p, Joint::IndexProximal) - w).cross(at(p, Joint::LittleProximal) - w);
    double curl = 0;
    for (Joint f : {Joint::IndexProximal, Joint::MiddleProximal, Joint::RingProximal, Joint::LittleProximal})
      curl += normal.dot(at(p, static_cast<Joint>(idx(f) + 2)) - at(p, f));
    right_handed += curl > 0 ? 1 : 0;
  }
  CHECK(right_handed > 0.8 * n);
}

// ---------------------------------------------------------------- CLI

TEST_CASE("cli: import writes a readable track, bad input fails with a location") {
  const auto dir = test::temp_dir("import");
  const auto out = dir / "fpha.csv";
  CHECK(test::run_cli("import --format fpha --in \"" + fpha_fixture_dir().string() + "\" --out \"" + out.string() +
                      "\" > /dev/null") == 0);
  const Track t = read_track_csv(out);
  CHECK(t.rows.size() == 8);
  CHECK(t.meta("derived").has_value());
  const auto out2 = dir / "mrtk.csv";
  CHECK(test::run_cli("import -f mrtk -i \"" + test::fixture("mrtk_small.csv").string() + "\" -o \"" + out2.string() +
                      "\" > /dev/null") == 0);
  CHECK(read_track_csv(out2).rows.size() == 6);
  // An FPHA file that is not one: exit status 2 (InputError).
  CHECK(test::run_cli("import --format fpha --in \"" + test::fixture("tiny.bvh").string() + "\" --out \"" +
                      (dir / "bad.csv").string() + "\" 2> /dev/null") == 2);
  CHECK(test::run_cli("import --format bvh --hand up --in \"" + test::fixture("tiny.bvh").string() + "\" --out \"" +
                      (dir / "bad.csv").string() + "\" 2> /dev/null") != 0);
  std::filesystem::remove_all(dir);
}
