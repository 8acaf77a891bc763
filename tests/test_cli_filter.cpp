// `handsteady filter`: rows, timestamps and untracked rows preserved, causal output,
// prediction horizon, metadata, and bad options rejected; `handsteady compare`'s MPJPE decimals.
#include "handsteady/filters.hpp"
#include "handsteady/metrics.hpp"
#include "handsteady/track.hpp"

#include "test_support.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace {

using hs::Hand;
using hs::Pose;
using Vec3 = Eigen::Vector3d;
namespace fs = std::filesystem;

Pose pose_at(const Vec3& x) {
  Pose p;
  for (int j = 0; j < hs::kJointCount; ++j) p.row(j) = (x + 1e-2 * j * Vec3(1, 1, 1)).transpose();
  return p;
}

// Left hand on a ramp at 30 Hz, right hand still at 30 Hz offset by 10 ms; the left hand
// is lost for rows 10..12 and its joint 4 is missing in row 20.
hs::Track test_track(int n_per_hand) {
  hs::Track track;
  track.header_lines.push_back("source: test_cli_filter");
  const Vec3 v(0.2, -0.1, 0.05);
  for (int i = 0; i < n_per_hand; ++i) {
    const double t = i / 30.0;
    hs::TrackRow left{t, Hand::Left, pose_at(v * t)};
    if (i >= 10 && i <= 12) left.pos = hs::untracked_pose();
    if (i == 20) left.pos.row(4).setConstant(std::nan(""));
    track.rows.push_back(left);
    track.rows.push_back(hs::TrackRow{t + 0.01, Hand::Right, pose_at(Vec3(0.3, 0.0, -0.2))});
  }
  return track;
}

std::string quoted(const fs::path& p) { return "\"" + p.string() + "\""; }

hs::Track run_filter(const fs::path& in, const fs::path& out, const std::string& options) {
  REQUIRE(hs::test::run_cli("filter --in " + quoted(in) + " --out " + quoted(out) + " " + options) == 0);
  return hs::read_track_csv(out);
}

}  // namespace

TEST_CASE("filter keeps rows, timestamps and untracked rows, raw at horizon 0 reproduces the input") {
  const fs::path dir = hs::test::temp_dir("cli_filter_raw");
  hs::write_track_csv(test_track(40), dir / "in.csv");
  const hs::Track input = hs::read_track_csv(dir / "in.csv");  // what the CLI sees (CSV precision)
  const hs::Track out = run_filter(dir / "in.csv", dir / "out.csv", "--method raw");
  REQUIRE(out.rows.size() == input.rows.size());
  for (size_t i = 0; i < input.rows.size(); ++i) {
    const hs::TrackRow& a = input.rows[i];
    const hs::TrackRow& b = out.rows[i];
    CHECK(a.t == b.t);
    CHECK(a.hand == b.hand);
    CHECK(hs::any_joint_tracked(a.pos) == hs::any_joint_tracked(b.pos));
    for (int j = 0; j < hs::kJointCount; ++j) {
      if (hs::joint_tracked(a.pos, j)) CHECK(a.pos.row(j) == b.pos.row(j));
    }
  }
  // The joint missing in left row 20 (file row 40) is held from left row 19 (file row 38).
  CHECK(out.rows[40].pos.row(4) == input.rows[38].pos.row(4));
  CHECK(out.meta("source") == "test_cli_filter");
  CHECK(out.meta("filter") == "raw horizon_ms=0 max_gap_ms=500");
  fs::remove_all(dir);
}

TEST_CASE("filter predicts at t + horizon: Kalman on a ramp, per hand") {
  const fs::path dir = hs::test::temp_dir("cli_filter_kalman");
  hs::write_track_csv(test_track(90), dir / "in.csv");
  const hs::Track out = run_filter(dir / "in.csv", dir / "out.csv", "--method kalman --horizon-ms 50 --meas-sd-mm 1");
  const Vec3 v(0.2, -0.1, 0.05);
  const hs::TrackRow& last_left = out.rows[out.rows.size() - 2];
  const hs::TrackRow& last_right = out.rows.back();
  REQUIRE(last_left.hand == Hand::Left);
  CHECK((last_left.pos - pose_at(v * (last_left.t + 0.05))).cwiseAbs().maxCoeff() < 1e-5);
  CHECK((last_right.pos - pose_at(Vec3(0.3, 0.0, -0.2))).cwiseAbs().maxCoeff() < 1e-9);
  const auto meta = out.meta("filter");
  REQUIRE(meta.has_value());
  CHECK(meta->rfind("kalman horizon_ms=50 meas_sd_mm=1 ", 0) == 0);
  fs::remove_all(dir);
}

TEST_CASE("filter is causal: the output of a truncated input is a prefix of the full output") {
  const fs::path dir = hs::test::temp_dir("cli_filter_causal");
  const hs::Track full_in = test_track(40);
  hs::Track short_in = full_in;
  short_in.rows.resize(50);
  hs::write_track_csv(full_in, dir / "full.csv");
  hs::write_track_csv(short_in, dir / "short.csv");
  for (const char* method : {"oneeuro", "desp", "kalman"}) {
    const std::string options = std::string("--horizon-ms 30 --method ") + method;
    const hs::Track a = run_filter(dir / "full.csv", dir / "full_out.csv", options);
    const hs::Track b = run_filter(dir / "short.csv", dir / "short_out.csv", options);
    REQUIRE(b.rows.size() == 50);
    for (size_t i = 0; i < b.rows.size(); ++i) {
      const bool a_nan = a.rows[i].pos.array().isNaN().all(), b_nan = b.rows[i].pos.array().isNaN().all();
      CHECK(a_nan == b_nan);
      if (!a_nan) CHECK((a.rows[i].pos - b.rows[i].pos).cwiseAbs().maxCoeff() < 1e-12);
    }
  }
  fs::remove_all(dir);
}

TEST_CASE("filter --skip-repeats answers a stale row from the estimate, and says so in the metadata") {
  const fs::path dir = hs::test::temp_dir("cli_filter_repeats");
  hs::Track in = test_track(40);
  // The left hand's row 25 (on its ramp) answered again at row 26: a runtime's stale answer.
  const size_t row25 = 2 * 25, row26 = 2 * 26;
  REQUIRE(in.rows[row26].hand == Hand::Left);
  in.rows[row26].pos = in.rows[row25].pos;
  hs::write_track_csv(in, dir / "in.csv");
  const hs::Track plain = run_filter(dir / "in.csv", dir / "plain.csv", "--method kalman --meas-sd-mm 1");
  const hs::Track skip = run_filter(dir / "in.csv", dir / "skip.csv", "--method kalman --meas-sd-mm 1 --skip-repeats");
  REQUIRE(skip.rows.size() == plain.rows.size());
  // Before the stale row nothing differs; on it the answer goes on with the ramp.
  for (size_t i = 0; i < row26; ++i)
    if (!plain.rows[i].pos.array().isNaN().all()) CHECK((plain.rows[i].pos - skip.rows[i].pos).cwiseAbs().maxCoeff() < 1e-12);
  const Vec3 v(0.2, -0.1, 0.05);
  const Pose on_ramp = pose_at(v * skip.rows[row26].t);
  CHECK((skip.rows[row26].pos - on_ramp).cwiseAbs().maxCoeff() < 1e-3);
  CHECK((plain.rows[row26].pos - on_ramp).cwiseAbs().maxCoeff() > 2e-3);
  REQUIRE(skip.meta("filter").has_value());
  CHECK(skip.meta("filter")->ends_with(" skip_repeats"));
  CHECK_FALSE(plain.meta("filter")->ends_with(" skip_repeats"));
  // Window mode has no stream to skip rows of.
  const std::string io = "--in " + quoted(dir / "in.csv") + " --out " + quoted(dir / "o.csv");
  CHECK(hs::test::run_cli("filter " + io + " --method stgae --offline --skip-repeats 2>/dev/null") == 2);
  fs::remove_all(dir);
}

TEST_CASE("filter rejects bad options with a non-zero exit") {
  const fs::path dir = hs::test::temp_dir("cli_filter_bad");
  hs::write_track_csv(test_track(5), dir / "in.csv");
  const std::string io = "--in " + quoted(dir / "in.csv") + " --out " + quoted(dir / "out.csv");
  CHECK(hs::test::run_cli("filter " + io + " --method median 2>/dev/null") != 0);
  CHECK(hs::test::run_cli("filter " + io + " --method desp --alpha 1.5 2>/dev/null") == 2);
  CHECK(hs::test::run_cli("filter " + io + " --method oneeuro --mincutoff 0 2>/dev/null") == 2);
  CHECK(hs::test::run_cli("filter " + io + " --horizon-ms -5 2>" + quoted(dir / "err.txt")) == 2);
  {  // the message names the option, not a file
    std::ifstream in(dir / "err.txt");
    const std::string err((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK(err.find("option --horizon-ms: horizon must be >= 0 ms, got -5") != std::string::npos);
  }
  CHECK(hs::test::run_cli("filter --in " + quoted(dir / "missing.csv") + " --out " + quoted(dir / "o.csv") +
                          " 2>/dev/null") != 0);
  CHECK_FALSE(fs::exists(dir / "out.csv"));
  fs::remove_all(dir);
}

TEST_CASE("compare prints the MPJPE column to the decimals asked for, two by default") {
  const fs::path dir = hs::test::temp_dir("cli_compare_digits");
  hs::write_track_csv(test_track(40), dir / "in.csv");
  run_filter(dir / "in.csv", dir / "out.csv", "--method kalman");
  const auto mpjpe = hs::evaluate_tracks(hs::read_track_csv(dir / "in.csv"), hs::read_track_csv(dir / "out.csv"), 0.0).mpjpe_mm;
  const std::string cmd = "compare --truth " + quoted(dir / "in.csv") + " --in k=" + quoted(dir / "out.csv");
  auto row = [&](const std::string& options) {
    REQUIRE(hs::test::run_cli(cmd + options + " > " + quoted(dir / "table.md")) == 0);
    return hs::test::slurp(dir / "table.md");
  };
  auto cell = [&](int digits) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "| k | 0 | %.*f |", digits, mpjpe);
    return std::string(buf);
  };
  CHECK(row("").find(cell(2)) != std::string::npos);
  CHECK(row(" --mpjpe-digits 4").find(cell(4)) != std::string::npos);
  CHECK(hs::test::run_cli(cmd + " --mpjpe-digits 7 2>/dev/null") != 0);
  fs::remove_all(dir);
}
