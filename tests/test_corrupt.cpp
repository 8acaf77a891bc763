// Corruption presets: reproducibility, truth untouched, statistics match the configuration.
#include "handsteady/corrupt.hpp"

#include "test_support.hpp"

#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace {

using hs::Joint;
using hs::Pose;
using hs::idx;
using hs::kNaN;
using hs::test::synthetic_hand;


hs::HandSeries static_series(size_t n, double rate_hz, const Pose& pose = synthetic_hand()) {
  hs::HandSeries s;
  for (size_t i = 0; i < n; ++i) {
    s.t.push_back(static_cast<double>(i) / rate_hz);
    s.pos.push_back(pose);
  }
  return s;
}

// Bitwise equality with NaN == NaN (untracked must match untracked).
bool same_pose(const Pose& a, const Pose& b) {
  for (int j = 0; j < hs::kJointCount; ++j)
    for (int k = 0; k < 3; ++k) {
      const double x = a(j, k), y = b(j, k);
      if (std::isnan(x) != std::isnan(y)) return false;
      if (!std::isnan(x) && x != y) return false;
    }
  return true;
}
bool same_series(const hs::HandSeries& a, const hs::HandSeries& b) {
  if (a.t != b.t || a.pos.size() != b.pos.size()) return false;
  for (size_t i = 0; i < a.pos.size(); ++i)
    if (!same_pose(a.pos[i], b.pos[i])) return false;
  return true;
}

const char* const kPresets[] = {"paper", "tracker", "tremor", "tremor-physiological", "hand-jitter"};

hs::CorruptionConfig tracker_only(hs::TrackerCorruption t) {
  hs::CorruptionConfig c;
  c.kind = hs::CorruptionKind::Tracker;
  c.tracker = t;
  return c;
}

double phi_upper(double z) { return 0.5 * std::erfc(z / std::numbers::sqrt2); }

// E[min(|a|, 2 sigma)] for a ~ N(0, sigma^2): the expected Bernoulli mask probability.
double expected_mask_fraction(double sigma) {
  return sigma * (std::sqrt(2.0 / std::numbers::pi) * (1.0 - std::exp(-2.0)) + 4.0 * phi_upper(2.0));
}

}  // namespace

TEST_CASE("presets parse and unknown names are rejected") {
  CHECK(hs::corruption_preset("paper").kind == hs::CorruptionKind::Paper);
  CHECK(hs::corruption_preset("paper").paper.beta_m == doctest::Approx(0.05));
  CHECK(hs::corruption_preset("tracker").kind == hs::CorruptionKind::Tracker);
  const auto pd = hs::corruption_preset("tremor");
  CHECK(pd.kind == hs::CorruptionKind::Tremor);
  CHECK(pd.tremor.freq_min_hz == 4.0);
  CHECK(pd.tremor.freq_max_hz == 6.0);
  const auto ph = hs::corruption_preset("tremor-physiological");
  CHECK(ph.tremor.freq_min_hz == 8.0);
  CHECK(ph.tremor.freq_max_hz == 12.0);
  CHECK_THROWS_AS(hs::corruption_preset("bogus"), std::invalid_argument);
  hs::CorruptionConfig bad = tracker_only({});
  bad.tracker.joint_drop_prob = 1.5;
  CHECK_THROWS_AS(hs::corrupt_series(static_series(3, 30), bad, 1), std::invalid_argument);
}

TEST_CASE("same seed gives the same output, a different seed a different one") {
  const hs::HandSeries clean = static_series(200, 30.0);
  for (const char* name : kPresets) {
    CAPTURE(name);
    const auto cfg = hs::corruption_preset(name);
    const auto a = hs::corrupt_series(clean, cfg, 42);
    const auto b = hs::corrupt_series(clean, cfg, 42);
    const auto c = hs::corrupt_series(clean, cfg, 43);
    CHECK(same_series(a, b));
    CHECK_FALSE(same_series(a, c));
    CHECK_FALSE(same_series(a, clean));
    CHECK(a.t == clean.t);
  }
}

TEST_CASE("truth is untouched and untracked input stays untracked") {
  hs::HandSeries clean = static_series(300, 30.0);
  for (size_t i = 50; i < 60; ++i) clean.pos[i] = hs::untracked_pose();
  for (size_t i = 0; i < clean.size(); i += 7) clean.pos[i].row(idx(Joint::IndexTip)).setConstant(kNaN);
  hs::Track track;
  track.set_meta("source", "test");
  hs::add_hand_series(track, hs::Hand::Right, clean);
  hs::add_hand_series(track, hs::Hand::Left, clean);
  const hs::Track copy = track;
  for (const char* name : kPresets) {
    CAPTURE(name);
    const hs::Track out = hs::corrupt_track(track, hs::corruption_preset(name), 7);
    REQUIRE(track.rows.size() == copy.rows.size());
    for (size_t i = 0; i < track.rows.size(); ++i) CHECK(same_pose(track.rows[i].pos, copy.rows[i].pos));
    REQUIRE(out.rows.size() == track.rows.size());
    CHECK(out.meta("source") == std::optional<std::string>("test"));
    for (size_t i = 0; i < out.rows.size(); ++i) {
      CHECK(out.rows[i].t == track.rows[i].t);
      CHECK(out.rows[i].hand == track.rows[i].hand);
      for (int j = 0; j < hs::kJointCount; ++j)
        if (!hs::joint_tracked(track.rows[i].pos, j)) CHECK_FALSE(hs::joint_tracked(out.rows[i].pos, j));
    }
    // The two hands get distinct sub-seeds: identical input, different noise.
    const auto left = hs::hand_series(out, hs::Hand::Left), right = hs::hand_series(out, hs::Hand::Right);
    CHECK_FALSE(same_series(left, right));
  }
}

TEST_CASE("tracker jitter has the configured SD and row-to-row correlation") {
  const Pose base = synthetic_hand();
  const hs::HandSeries clean = static_series(4000, 30.0, base);
  for (double ar1 : {0.0, 0.6}) {
    CAPTURE(ar1);
    const auto out = hs::corrupt_series(clean, tracker_only({.jitter_sd_m = 0.001, .jitter_ar1 = ar1}), 5);
    double ss = 0, lag1 = 0;
    size_t n = 0;
    for (size_t i = 0; i < out.size(); ++i) {
      const Pose d = out.pos[i] - base;
      ss += d.squaredNorm();
      n += 3 * hs::kJointCount;
      if (i > 0) lag1 += (d.array() * (out.pos[i - 1] - base).array()).sum();
    }
    const double sd = std::sqrt(ss / static_cast<double>(n));
    CHECK(sd == doctest::Approx(0.001).epsilon(0.02));
    CHECK(std::abs(lag1 / ss - ar1) < 0.02);
  }
}

TEST_CASE("whole-hand jitter moves every joint of a row by one displacement of the configured SD") {
  const Pose base = synthetic_hand();
  const hs::HandSeries clean = static_series(4000, 30.0, base);
  for (double ar1 : {0.0, 0.6}) {
    CAPTURE(ar1);
    const auto out = hs::corrupt_series(clean, tracker_only({.jitter_ar1 = ar1, .hand_jitter_sd_m = 0.001}), 5);
    double ss = 0, lag1 = 0, spread = 0;
    for (size_t i = 0; i < out.size(); ++i) {
      const Pose d = out.pos[i] - base;
      const Eigen::Vector3d w = d.row(0).transpose();
      for (int j = 1; j < hs::kJointCount; ++j) spread = std::max(spread, (d.row(j).transpose() - w).norm());
      ss += w.squaredNorm();
      if (i > 0) lag1 += w.dot((out.pos[i - 1] - base).row(0).transpose());
    }
    CHECK(spread < 1e-12);  // rigid: the same displacement for every joint
    CHECK(std::sqrt(ss / (3.0 * static_cast<double>(out.size()))) == doctest::Approx(0.001).epsilon(0.05));
    CHECK(std::abs(lag1 / ss - ar1) < 0.05);
  }
  // Its own stream: adding it leaves the joints' own jitter as it was.
  const auto joints = hs::corrupt_series(clean, tracker_only({.jitter_sd_m = 0.001}), 7);
  const auto both = hs::corrupt_series(clean, tracker_only({.jitter_sd_m = 0.001, .hand_jitter_sd_m = 0.002}), 7);
  const Pose a = joints.pos[10] - both.pos[10];
  for (int j = 1; j < hs::kJointCount; ++j) CHECK((a.row(j) - a.row(0)).norm() < 1e-12);
  CHECK(a.row(0).norm() > 0.0);
  hs::CorruptionConfig bad = tracker_only({.hand_jitter_sd_m = -0.001});
  CHECK_THROWS_AS(hs::validate_corruption(bad), std::invalid_argument);
  const auto preset = hs::corruption_preset("hand-jitter");
  CHECK(preset.kind == hs::CorruptionKind::Tracker);
  CHECK(preset.tracker.hand_jitter_sd_m == doctest::Approx(0.0005));
  CHECK(preset.tracker.jitter_sd_m == 0.0);
}

TEST_CASE("tracker joint drops, whole-hand dropouts, jumps and quantisation") {
  const Pose base = synthetic_hand();
  SUBCASE("joint drop fraction") {
    const auto out = hs::corrupt_series(static_series(5000, 30.0, base), tracker_only({.joint_drop_prob = 0.1}), 9);
    size_t dropped = 0, total = 0;
    for (const Pose& p : out.pos) {
      dropped += static_cast<size_t>(hs::kJointCount - hs::tracked_joint_count(p));
      total += hs::kJointCount;
    }
    CHECK(static_cast<double>(dropped) / static_cast<double>(total) == doctest::Approx(0.1).epsilon(0.03));
  }
  SUBCASE("whole-hand dropouts follow the Poisson/exponential model") {
    // Rate 0.5/s, mean 0.4 s over 1000 s: the covered fraction of a Poisson process of
    // intervals is 1 - exp(-rate * mean).
    const double rate = 0.5, mean = 0.4;
    const auto out = hs::corrupt_series(static_series(20000, 20.0, base),
                                        tracker_only({.hand_drop_rate_hz = rate, .hand_drop_mean_s = mean}), 11);
    size_t untracked = 0, partial = 0;
    for (const Pose& p : out.pos) {
      const int k = hs::tracked_joint_count(p);
      if (k == 0) ++untracked;
      else if (k != hs::kJointCount) ++partial;
    }
    CHECK(partial == 0);
    const double fraction = static_cast<double>(untracked) / static_cast<double>(out.size());
    CHECK(fraction == doctest::Approx(1.0 - std::exp(-rate * mean)).epsilon(0.2));
  }
  SUBCASE("jumps move single joints for single rows") {
    const auto out = hs::corrupt_series(static_series(5000, 30.0, base),
                                        tracker_only({.jump_prob = 0.01, .jump_sd_m = 0.01}), 13);
    size_t moved = 0, total = 0;
    for (const Pose& p : out.pos)
      for (int j = 0; j < hs::kJointCount; ++j, ++total)
        if ((p.row(j) - base.row(j)).norm() > 0.0) ++moved;
    CHECK(static_cast<double>(moved) / static_cast<double>(total) == doctest::Approx(0.01).epsilon(0.1));
  }
  SUBCASE("quantisation rounds to the step") {
    const auto out = hs::corrupt_series(static_series(50, 30.0, base),
                                        tracker_only({.jitter_sd_m = 0.002, .quantize_m = 0.001}), 17);
    for (const Pose& p : out.pos)
      for (int j = 0; j < hs::kJointCount; ++j)
        for (int k = 0; k < 3; ++k) {
          const double mm = p(j, k) * 1000.0;
          CHECK(std::abs(mm - std::round(mm)) < 1e-6);
        }
  }
}

namespace {
// Power of a real signal at frequency f (Hz) by a direct DFT term.
double power_at(const std::vector<double>& x, double rate, double f) {
  std::complex<double> acc = 0;
  for (size_t i = 0; i < x.size(); ++i)
    acc += x[i] * std::polar(1.0, -2.0 * std::numbers::pi * f * static_cast<double>(i) / rate);
  return std::norm(acc);
}
}  // namespace

TEST_CASE("tremor: spectral peak inside the band, amplitude, fingers, rate independence") {
  const Pose base = synthetic_hand();
  struct Case {
    const char* preset;
    double lo, hi;
  };
  for (Case c : {Case{"tremor", 4.0, 6.0}, Case{"tremor-physiological", 8.0, 12.0}}) {
    CAPTURE(c.preset);
    const auto cfg = hs::corruption_preset(c.preset);
    const double rate = 60.0;
    const auto out = hs::corrupt_series(static_series(1800, rate, base), cfg, 21);
    std::vector<double> wx[3];
    double ss = 0;
    for (const Pose& p : out.pos)
      for (int k = 0; k < 3; ++k) {
        const double d = p(idx(Joint::Wrist), k) - base(idx(Joint::Wrist), k);
        wx[k].push_back(d);
        ss += d * d;
      }
    double in_band = 0, total = 0, peak_f = 0, peak_p = -1;
    for (double f = 0.5; f <= 25.0; f += 0.1) {
      double p = 0;
      for (auto& x : wx) p += power_at(x, rate, f);
      total += p;
      if (f >= c.lo - 0.3 && f <= c.hi + 0.3) in_band += p;
      if (p > peak_p) {
        peak_p = p;
        peak_f = f;
      }
    }
    CHECK(peak_f >= c.lo);
    CHECK(peak_f <= c.hi);
    CHECK(in_band / total > 0.9);
    // RMS of A (1 + 0.3 sin) sin(...) is about A / sqrt(2) * sqrt(1.045).
    const double rms = std::sqrt(ss / static_cast<double>(out.size()));
    CHECK(rms > 0.55 * cfg.tremor.hand_amplitude_m);
    CHECK(rms < 0.85 * cfg.tremor.hand_amplitude_m);

    // Finger oscillation grows towards the tip and is zero at the pivot.
    double tip = 0, mid = 0, pivot = 0;
    const int w = idx(Joint::Wrist);
    for (const Pose& p : out.pos) {
      const auto hand = (p.row(w) - base.row(w)).eval();
      pivot += (p.row(idx(Joint::IndexProximal)) - base.row(idx(Joint::IndexProximal)) - hand).squaredNorm();
      mid += (p.row(idx(Joint::IndexIntermediate)) - base.row(idx(Joint::IndexIntermediate)) - hand).squaredNorm();
      tip += (p.row(idx(Joint::IndexTip)) - base.row(idx(Joint::IndexTip)) - hand).squaredNorm();
    }
    CHECK(pivot < 1e-20);
    CHECK(mid > 0.0);
    CHECK(tip == doctest::Approx(9.0 * mid).epsilon(1e-6));  // weights 1/3 and 1

    // Displacement depends on time only: a 30 Hz copy matches every other 60 Hz row.
    const auto slow = hs::corrupt_series(static_series(900, 30.0, base), cfg, 21);
    for (size_t i = 0; i < slow.size(); i += 37) CHECK((slow.pos[i] - out.pos[2 * i]).norm() < 1e-12);
  }
}

TEST_CASE("paper Optimize keeps the bone lengths of inherited children") {
  const hs::Skeleton& sk = hs::xr_hand_skeleton();
  const Pose clean = synthetic_hand();
  SUBCASE("a bone stretched along a straight finger is pulled back exactly") {
    Pose shifted = clean;
    const Eigen::RowVector3d dir = (clean.row(idx(Joint::IndexIntermediate)) - clean.row(idx(Joint::IndexProximal))).normalized();
    shifted.row(idx(Joint::IndexIntermediate)) += 0.01 * dir;
    const Pose out = hs::paper_optimize(clean, shifted);
    CHECK((out - clean).norm() < 1e-12);
  }
  SUBCASE("random shifts: lengths restored two hops out, first hop left alone") {
    hs::CorruptionConfig cfg = hs::corruption_preset("paper");
    cfg.paper.sigma_o = 0.0;  // no occlusion: every joint is visible
    cfg.paper.sigma_s = 0.5;  // many shifts
    const auto out = hs::corrupt_series(static_series(200, 30.0, clean), cfg, 3);
    cfg.paper.optimize = false;
    const auto raw = hs::corrupt_series(static_series(200, 30.0, clean), cfg, 3);
    size_t changed = 0;
    for (size_t i = 0; i < out.size(); ++i) {
      for (auto [p, c] : sk.bones) {
        const bool first_hop = sk.parent[static_cast<size_t>(p)] < 0;
        if (first_hop) {
          CHECK((out.pos[i].row(c) - raw.pos[i].row(c)).norm() == 0.0);
          continue;
        }
        const double lc = (clean.row(c) - clean.row(p)).norm();
        const double lo = (out.pos[i].row(c) - out.pos[i].row(p)).norm();
        CHECK(lo == doctest::Approx(lc).epsilon(1e-9));
        if ((out.pos[i].row(c) - clean.row(c)).norm() > 1e-9) ++changed;
      }
    }
    CHECK(changed > 0);
  }
}

TEST_CASE("paper occlusion and shift fractions match E[min(|alpha|, 2 sigma)]") {
  const Pose clean = synthetic_hand();
  const hs::HandSeries series = static_series(20000, 30.0, clean);
  const double expected = expected_mask_fraction(0.1);  // ~0.078
  hs::CorruptionConfig cfg = hs::corruption_preset("paper");
  cfg.paper.sigma_s = 0.0;
  const auto occl = hs::corrupt_series(series, cfg, 5);
  size_t hidden = 0;
  for (const Pose& p : occl.pos) hidden += static_cast<size_t>(hs::kJointCount - hs::tracked_joint_count(p));
  CHECK(static_cast<double>(hidden) / (20000.0 * hs::kJointCount) == doctest::Approx(expected).epsilon(0.04));

  cfg = hs::corruption_preset("paper");
  cfg.paper.sigma_o = 0.0;
  cfg.paper.optimize = false;
  cfg.paper.reference_hand_m = 0.0;
  const auto shift = hs::corrupt_series(series, cfg, 5);
  size_t moved = 0;
  double max_coord = 0;
  for (const Pose& p : shift.pos)
    for (int j = 0; j < hs::kJointCount; ++j)
      if ((p.row(j) - clean.row(j)).norm() > 0) {
        ++moved;
        max_coord = std::max(max_coord, (p.row(j) - clean.row(j)).cwiseAbs().maxCoeff());
      }
  CHECK(static_cast<double>(moved) / (20000.0 * hs::kJointCount) == doctest::Approx(expected).epsilon(0.04));
  CHECK(max_coord <= 0.05);
  CHECK(max_coord > 0.049);

  // Hand-size normalisation: a reference twice the hand's size halves beta.
  const double size = (clean.row(idx(Joint::MiddleProximal)) - clean.row(idx(Joint::Wrist))).norm();
  cfg.paper.reference_hand_m = 2.0 * size;
  const auto half = hs::corrupt_series(series, cfg, 5);
  double half_max = 0;
  for (const Pose& p : half.pos) half_max = std::max(half_max, (p - clean).cwiseAbs().maxCoeff());
  CHECK(half_max <= 0.025 + 1e-12);
  CHECK(half_max > 0.024);
}

TEST_CASE("CLI: corrupt is reproducible and records the preset, eval reads the result") {
  const auto dir = hs::test::temp_dir("corrupt_cli");
  hs::Track clean;
  hs::add_hand_series(clean, hs::Hand::Right, static_series(120, 30.0));
  hs::write_track_csv(clean, dir / "clean.csv");
  const std::string in = "--in \"" + (dir / "clean.csv").string() + "\"";
  const auto out = [&](const char* name) { return "\"" + (dir / name).string() + "\""; };
  REQUIRE(hs::test::run_cli("corrupt " + in + " --out " + out("a.csv") + " --preset tracker --seed 4") == 0);
  REQUIRE(hs::test::run_cli("corrupt " + in + " --out " + out("b.csv") + " --preset tracker --seed 4") == 0);
  const hs::Track a = hs::read_track_csv(dir / "a.csv"), b = hs::read_track_csv(dir / "b.csv");
  CHECK(a.meta("corruption") == std::optional<std::string>("tracker seed=4"));
  REQUIRE(a.rows.size() == b.rows.size());
  for (size_t i = 0; i < a.rows.size(); ++i) CHECK(same_pose(a.rows[i].pos, b.rows[i].pos));
  CHECK(hs::test::run_cli("eval --truth " + out("clean.csv") + " --in " + out("a.csv") + " --json > " +
                          out("eval.json")) == 0);
  CHECK(hs::test::run_cli("eval --truth " + out("clean.csv") + " --in " + out("a.csv") + " > " + out("eval.txt")) == 0);
  CHECK(hs::test::run_cli("noise-stats --in " + out("a.csv") + " > " + out("stats.txt")) == 0);
  // Wrong-family override and out-of-range values are input errors (exit 2).
  CHECK(hs::test::run_cli("corrupt " + in + " --out " + out("c.csv") + " --preset paper --jitter-mm 1 2>/dev/null") == 2);
  CHECK(hs::test::run_cli("corrupt " + in + " --out " + out("c.csv") + " --preset tracker --joint-drop 3 2>/dev/null") == 2);
  std::filesystem::remove_all(dir);
}
