// `handsteady resample`: each hand on its own grid k / rate from its first row, linear
// between rows, untracked across gaps and outside the hand's span, metadata kept, bad
// options refused.
#include "handsteady/track.hpp"

#include "test_support.hpp"

#include <cmath>
#include <filesystem>
#include <string>

namespace {

using Vec3 = Eigen::Vector3d;
namespace fs = std::filesystem;

hs::Pose pose_at(const Vec3& x) {
  hs::Pose p;
  for (int j = 0; j < hs::kJointCount; ++j) p.row(j) = (x + 1e-2 * j * Vec3(1, 1, 1)).transpose();
  return p;
}

std::string quoted(const fs::path& p) { return "\"" + p.string() + "\""; }

}  // namespace

TEST_CASE("resample: a ramp at 30 Hz to 42 Hz, per hand, with a gap") {
  const fs::path dir = hs::test::temp_dir("cli_resample");
  hs::Track track;
  track.header_lines.push_back("source: test_cli_resample");
  track.set_meta("rate_hz", "30");
  const Vec3 v(0.2, -0.1, 0.05);
  for (int i = 0; i < 60; ++i) {
    const double t = i / 30.0;
    hs::TrackRow left{t, hs::Hand::Left, pose_at(v * t)};
    if (i >= 20 && i <= 31) left.pos = hs::untracked_pose();  // 0.43 s lost: more than the 250 ms gap
    track.rows.push_back(left);
    track.rows.push_back(hs::TrackRow{0.5 + t, hs::Hand::Right, pose_at(-v * t)});
  }
  hs::write_track_csv(track, dir / "in.csv");
  REQUIRE(hs::test::run_cli("resample --in " + quoted(dir / "in.csv") + " --out " + quoted(dir / "out.csv") +
                            " --rate 42 >/dev/null") == 0);
  const hs::Track out = hs::read_track_csv(dir / "out.csv");
  CHECK(out.meta("source") == "test_cli_resample");
  CHECK(out.meta("rate_hz") == "42");
  int left = 0, right = 0, left_untracked = 0;
  for (const hs::TrackRow& r : out.rows) {
    const bool is_left = r.hand == hs::Hand::Left;
    const double t0 = is_left ? 0.0 : 0.5;
    const double k = (r.t - t0) * 42.0;
    CHECK(std::abs(k - std::round(k)) < 1e-6);  // on the hand's own grid
    CHECK(r.t <= t0 + 59.0 / 30.0 + 1e-9);       // within the hand's span
    (is_left ? left : right)++;
    if (!hs::any_joint_tracked(r.pos)) {
      CHECK(is_left);
      CHECK(r.t > 19.0 / 30.0);  // only inside the gap
      CHECK(r.t < 32.0 / 30.0);
      ++left_untracked;
      continue;
    }
    const Vec3 x = (is_left ? v : Vec3(-v)) * (r.t - t0);  // the ramp, exact under linear interpolation
    for (int j = 0; j < hs::kJointCount; ++j)
      CHECK((r.pos.row(j).transpose() - (x + 1e-2 * j * Vec3(1, 1, 1))).cwiseAbs().maxCoeff() < 1e-6);
  }
  CHECK(left == 83);  // floor(59 / 30 * 42) + 1
  CHECK(right == 83);
  CHECK(left_untracked >= 16);  // (32 - 19) / 30 s at 42 Hz, less the ends
  // Bad options: a rate out of range, a missing file.
  CHECK(hs::test::run_cli("resample --in " + quoted(dir / "in.csv") + " --out " + quoted(dir / "o.csv") +
                          " --rate 0 2>/dev/null") != 0);
  CHECK(hs::test::run_cli("resample --in " + quoted(dir / "missing.csv") + " --out " + quoted(dir / "o.csv") +
                          " --rate 42 2>/dev/null") != 0);
  CHECK_FALSE(fs::exists(dir / "o.csv"));
  fs::remove_all(dir);
}
