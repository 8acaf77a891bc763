#include "handsteady/track.hpp"

#include "test_support.hpp"

#include <fstream>
#include <random>
#include <sstream>

using namespace hs;

namespace {

std::string header() {
  std::string h;
  for (const auto& c : track_csv_columns()) h += (h.empty() ? "" : ",") + c;
  return h + "\n";
}

// A row with every joint at (base + j mm, ...) so each column is distinguishable.
std::string row(const std::string& t, const std::string& hand, double base = 0.1) {
  std::string r = t + "," + hand;
  for (int j = 0; j < kJointCount; ++j)
    for (int a = 0; a < 3; ++a) r += "," + std::to_string(base + 0.001 * j + 0.0001 * a);
  return r + "\n";
}

Track parse(const std::string& text) {
  std::istringstream in(text);
  return parse_track_csv(in, "mem.csv");
}

// Replaces field number `col` (0-based) of the last data line.
std::string with_field(std::string text, int col, const std::string& value) {
  size_t line_start = text.rfind('\n', text.size() - 2) + 1;
  size_t pos = line_start;
  for (int c = 0; c < col; ++c) pos = text.find(',', pos) + 1;
  size_t end = text.find_first_of(",\n", pos);
  return text.substr(0, pos) + value + text.substr(end);
}

void check_error(const std::string& text, long line, const std::string& field, const std::string& what) {
  CAPTURE(what);
  try {
    parse(text);
    FAIL("expected an InputError");
  } catch (const InputError& e) {
    CHECK(e.where().file == "mem.csv");
    CHECK(e.where().line == line);
    CHECK(e.where().field == field);
    CHECK(std::string(e.what()).find(what) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("columns: t, hand, then x/y/z for the 26 joints") {
  auto cols = track_csv_columns();
  REQUIRE(cols.size() == 80);
  CHECK(cols[0] == "t");
  CHECK(cols[1] == "hand");
  CHECK(cols[2] == "palm_x");
  CHECK(cols[79] == "little_tip_z");
}

TEST_CASE("parse: metadata, rows, missing joints and untracked hands") {
  // Row 3: index_tip (joint 10) missing via empty fields, row 4: whole hand untracked.
  std::string r3 = row("0.0333", "right");
  {
    std::string t = header() + r3;
    t = with_field(t, 32, "");
    t = with_field(t, 33, "nan");
    t = with_field(t, 34, "NaN");
    r3 = t.substr(header().size());
  }
  std::string r4 = "0.0666,right" + std::string(3 * kJointCount, ',') + "\n";
  const std::string text = "# source: unit test\n# rate_hz: 30\n# just a comment\n" + header() + row("0.0", "left") +
         row("0.0", "right") + r3 + r4;
  Track tr = parse(text);
  REQUIRE(tr.rows.size() == 4);
  CHECK(tr.meta("source").value() == "unit test");
  CHECK(tr.meta("rate_hz").value() == "30");
  CHECK_FALSE(tr.meta("derived").has_value());
  CHECK(tr.header_lines.size() == 3);
  CHECK(tr.rows[0].hand == Hand::Left);
  CHECK(tr.rows[1].pos(idx(Joint::IndexTip), 1) == doctest::Approx(0.1 + 0.010 + 0.0001));
  CHECK_FALSE(joint_tracked(tr.rows[2].pos, idx(Joint::IndexTip)));
  CHECK(tracked_joint_count(tr.rows[2].pos) == 25);
  CHECK_FALSE(any_joint_tracked(tr.rows[3].pos));
  HandSeries right = hand_series(tr, Hand::Right);
  CHECK(right.size() == 3);
  CHECK(right.t[2] == doctest::Approx(0.0666));
}

TEST_CASE("write then read round trip is exact to 1e-7 m and stable") {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  Track tr;
  tr.set_meta("source", "random");
  tr.set_meta("rate_hz", "90");
  for (int i = 0; i < 50; ++i)
    for (Hand h : {Hand::Left, Hand::Right}) {
      TrackRow r{i / 90.0, h, untracked_pose()};
      for (int j = 0; j < kJointCount; ++j)
        if ((i + j) % 7 != 0)
          for (int a = 0; a < 3; ++a) r.pos(j, a) = u(rng);
      if (i == 13) r.pos = untracked_pose();
      tr.rows.push_back(r);
    }
  std::ostringstream out1;
  write_track_csv(tr, out1);
  Track back = parse(out1.str());
  REQUIRE(back.rows.size() == tr.rows.size());
  CHECK(back.header_lines == tr.header_lines);
  for (size_t i = 0; i < tr.rows.size(); ++i) {
    CHECK(back.rows[i].hand == tr.rows[i].hand);
    CHECK(std::abs(back.rows[i].t - tr.rows[i].t) < 1e-9);
    for (int j = 0; j < kJointCount; ++j) {
      REQUIRE(joint_tracked(back.rows[i].pos, j) == joint_tracked(tr.rows[i].pos, j));
      if (joint_tracked(tr.rows[i].pos, j))
        CHECK((back.rows[i].pos.row(j) - tr.rows[i].pos.row(j)).cwiseAbs().maxCoeff() <= 1e-7);
    }
  }
  std::ostringstream out2;
  write_track_csv(back, out2);
  CHECK(out1.str() == out2.str());
}

TEST_CASE("file round trip and missing file error") {
  auto dir = test::temp_dir("track");
  Track tr;
  tr.rows.push_back({0.5, Hand::Right, Pose::Constant(0.25)});
  write_track_csv(tr, dir / "a.csv");
  Track back = read_track_csv(dir / "a.csv");
  REQUIRE(back.rows.size() == 1);
  CHECK(back.rows[0].pos(3, 2) == doctest::Approx(0.25));
  CHECK_THROWS_AS(read_track_csv(dir / "missing.csv"), InputError);
  std::filesystem::remove_all(dir);
}

TEST_CASE("bad input names file, line and column") {
  const std::string h = "# c\n" + header();  // header on line 2, data from line 3
  const std::string good = h + row("0.0", "right");
  check_error("t,hand,x\n", 1, "", "header has 3 columns");
  {
    std::string bad_header = header();
    bad_header.replace(bad_header.find("palm_y"), 6, "palm_q");
    check_error(bad_header, 1, "palm_q", "should be 'palm_y'");
  }
  check_error(h + "0.0,right,1,2\n", 3, "", "row has 4 fields, expected 80");
  check_error(with_field(good, 5, "abc"), 3, "wrist_x", "'abc' is not a number");
  check_error(with_field(good, 7, "inf"), 3, "wrist_z", "not a finite number");
  check_error(with_field(good, 0, ""), 3, "t", "time is missing");
  check_error(with_field(good, 0, "nan"), 3, "t", "time is missing");
  check_error(with_field(good, 1, "both"), 3, "hand", "is not a hand");
  check_error(with_field(good, 4, ""), 3, "palm_x", "partly given");
  check_error(with_field(good, 20, "12345"), 3, "index_metacarpal_x", "not a plausible hand position");
  check_error(good + row("0.0", "right"), 4, "t", "not after the previous right hand row");
  check_error(good + row("0.1", "right") + row("0.05", "right"), 5, "t", "not after");
  CHECK_NOTHROW(parse(good + row("0.0", "left")));  // times are per hand
  check_error("# only comments\n", 1, "", "no header line");
}

TEST_CASE("set_meta replaces and add_hand_series merges in time order") {
  Track tr;
  tr.set_meta("rate_hz", "30");
  tr.set_meta("rate_hz", "60");
  CHECK(tr.meta("rate_hz").value() == "60");
  CHECK(tr.header_lines.size() == 1);
  HandSeries l, r;
  l.t = {0.0, 0.2};
  l.pos = {Pose::Zero(), Pose::Zero()};
  r.t = {0.1, 0.2};
  r.pos = {Pose::Ones(), Pose::Ones()};
  add_hand_series(tr, Hand::Left, l);
  add_hand_series(tr, Hand::Right, r);
  REQUIRE(tr.rows.size() == 4);
  CHECK(tr.rows[1].t == doctest::Approx(0.1));
  CHECK(tr.rows[2].hand == Hand::Left);
  CHECK(tr.rows[3].hand == Hand::Right);
}
