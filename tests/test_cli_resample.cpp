// `handsteady resample`: each hand on its own grid k / rate from its first row, linear
// between rows, untracked across gaps and outside the hand's span, metadata kept, bad
// options refused; with --jitter, on a seeded jittering clock around that grid.
#include "handsteady/track.hpp"

#include "test_support.hpp"

#include <algorithm>
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

TEST_CASE("resample --jitter: seeded irregular times within the jitter of each hand's grid, the ramp exact") {
  const fs::path dir = hs::test::temp_dir("cli_resample_jitter");
  hs::Track track;
  const Vec3 v(0.2, -0.1, 0.05);
  for (int i = 0; i < 90; ++i) {
    const double t = i / 30.0;
    track.rows.push_back(hs::TrackRow{t, hs::Hand::Left, pose_at(v * t)});
    track.rows.push_back(hs::TrackRow{0.25 + t, hs::Hand::Right, pose_at(-v * t)});
  }
  hs::write_track_csv(track, dir / "in.csv");
  const auto run = [&](const std::string& args, const std::string& out) {
    return hs::test::run_cli("resample --in " + quoted(dir / "in.csv") + " --out " + quoted(dir / out) +
                             " --rate 75 " + args + " >/dev/null 2>&1");
  };
  REQUIRE(run("--jitter 0.3 --seed 5", "a.csv") == 0);
  REQUIRE(run("--jitter 0.3 --seed 5", "b.csv") == 0);
  REQUIRE(run("--jitter 0.3 --seed 6", "c.csv") == 0);
  const hs::Track a = hs::read_track_csv(dir / "a.csv"), b = hs::read_track_csv(dir / "b.csv"),
                  c = hs::read_track_csv(dir / "c.csv");
  CHECK(a.meta("rate_hz") == "75");
  REQUIRE(a.rows.size() == b.rows.size());
  bool same = true, other_seed_differs = false, off_grid = false;
  for (size_t i = 0; i < a.rows.size(); ++i) same = same && a.rows[i].t == b.rows[i].t;
  for (size_t i = 0; i < std::min(a.rows.size(), c.rows.size()); ++i)
    other_seed_differs = other_seed_differs || a.rows[i].t != c.rows[i].t;
  CHECK(same);                // one seed, one clock
  CHECK(other_seed_differs);  // another seed, another clock
  double last[2] = {-1.0, -1.0};
  int count[2] = {0, 0};
  for (const hs::TrackRow& r : a.rows) {
    const int h = static_cast<int>(r.hand);
    const double t0 = h == 0 ? 0.0 : 0.25;
    const double k = (r.t - t0) * 75.0, off = std::abs(k - std::round(k));
    CHECK(off <= 0.3 + 1e-6);  // within the jitter of the hand's grid
    off_grid = off_grid || off > 0.05;
    CHECK(r.t > last[h]);  // increasing per hand
    CHECK(r.t >= t0);
    CHECK(r.t <= t0 + 89.0 / 30.0 + 1e-9);
    last[h] = r.t;
    ++count[h];
    const Vec3 x = (h == 0 ? v : Vec3(-v)) * (r.t - t0);
    CHECK((r.pos.row(0).transpose() - x).cwiseAbs().maxCoeff() < 1e-6);
  }
  CHECK(off_grid);
  CHECK(count[0] >= 220);  // 89 / 30 s at 75 Hz: 223 grid points, less the first if it fell early
  CHECK(count[0] <= 223);
  CHECK(count[1] >= 220);
  // A jitter of half a period or more could reorder times: refused.
  CHECK(run("--jitter 0.5", "d.csv") != 0);
  CHECK(run("--jitter -0.1", "d.csv") != 0);
  CHECK_FALSE(fs::exists(dir / "d.csv"));
  fs::remove_all(dir);
}
