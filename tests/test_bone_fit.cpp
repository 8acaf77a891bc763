// The bone fit (bone_fit.hpp): noise along a rigid finger's bones is taken out in the same
// answer, a clean hand and a hand whose bones really change length pass (almost)
// unchanged, chains with a missing joint and every joint outside the fingers' chains are
// untouched, nothing moves before the lengths are taught; through make_filter it is on
// for the network methods and off for the classical ones unless asked, and a tracking gap
// starts a take that learns the lengths anew.
#include "handsteady/bone_fit.hpp"
#include "handsteady/filters.hpp"
#include "handsteady/synth.hpp"
#include "test_support.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace {
using hs::BoneFit;
using hs::kFingerChains;
using hs::Pose;
using hs::test::jittered;

hs::HandSeries moving_hand(double seconds, double rate_hz = 90.0) { return hs::test::moving_hand(seconds, rate_hz, 5); }

// The joints the fit may move: each chain's three outer joints.
bool is_moved(int j) {
  for (const auto& chain : kFingerChains)
    if (std::find(chain.begin() + 1, chain.end(), j) != chain.end()) return true;
  return false;
}

double finger_error_mm(const Pose& a, const Pose& b) {
  double s = 0.0;
  int n = 0;
  for (int j = 0; j < hs::kJointCount; ++j)
    if (is_moved(j)) {
      s += (a.row(j) - b.row(j)).norm();
      ++n;
    }
  return 1e3 * s / n;
}

// A hand whose finger bones each change length by up to `mm` over a few seconds (what
// FPHA's mocap does): every outer chain joint moved along its bone, the change carried to
// the joints beyond it.
Pose stretched(const Pose& p, double t, double mm) {
  Pose out = p;
  for (size_t c = 0; c < kFingerChains.size(); ++c) {
    const auto& chain = kFingerChains[c];
    Eigen::RowVector3d carried = Eigen::RowVector3d::Zero();
    for (size_t i = 1; i < 4; ++i) {
      const Eigen::RowVector3d bone = p.row(chain[i]) - p.row(chain[i - 1]);
      const double change = 1e-3 * mm * std::sin(2.0 * 3.141592653589793 * (0.2 + 0.05 * double(c + i)) * t + double(i));
      carried += change * bone.normalized();
      out.row(chain[i]) += carried;
    }
  }
  return out;
}

// The tip's signed distance from the plane of its chain's first three joints (m), as
// BoneFit measures it (normal along bone 0 x bone 1); NaN where the chain is too straight.
double tip_offset(const Pose& p, size_t c) {
  const auto& ch = kFingerChains[c];
  const Eigen::Vector3d a = (p.row(ch[1]) - p.row(ch[0])).transpose(), b = (p.row(ch[2]) - p.row(ch[1])).transpose();
  const Eigen::Vector3d d = (p.row(ch[3]) - p.row(ch[2])).transpose();
  const Eigen::Vector3d m = a.cross(b);
  if (m.norm() < hs::kPlaneMinSin * a.norm() * b.norm()) return hs::kNaN;
  return m.normalized().dot(d);
}

// Each fingertip moved off its finger's plane by a fixed distance (a tracker or a mocap
// whose joints are not on one hinge plane: ManipNet's, FPHA's), along the normal.
Pose tips_off_plane(const Pose& p, const std::array<double, 5>& mm) {
  Pose out = p;
  for (size_t c = 0; c < kFingerChains.size(); ++c) {
    const auto& ch = kFingerChains[c];
    const Eigen::Vector3d a = (p.row(ch[1]) - p.row(ch[0])).transpose(), b = (p.row(ch[2]) - p.row(ch[1])).transpose();
    out.row(ch[3]) += 1e-3 * mm[c] * a.cross(b).normalized().transpose();
  }
  return out;
}

}  // namespace

TEST_CASE("Bone fit: white noise along rigid finger bones is taken out in the same answer, other joints untouched") {
  const hs::HandSeries truth = moving_hand(8.0);
  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0.0, 0.0015);
  BoneFit fit;
  double in_err = 0.0, out_err = 0.0;
  int n = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const Pose noisy = jittered(truth.pos[i], rng, noise);
    fit.learn(truth.t[i], noisy);
    Pose row = noisy;
    fit.apply(row);
    for (int j = 0; j < hs::kJointCount; ++j)
      if (!is_moved(j)) CHECK(row.row(j) == noisy.row(j));
    if (i < static_cast<size_t>(hs::kBoneMinRows) - 1) CHECK(row == noisy);  // nothing before the lengths are taught
    if (i < 180) continue;
    in_err += finger_error_mm(noisy, truth.pos[i]);
    out_err += finger_error_mm(row, truth.pos[i]);
    ++n;
  }
  in_err /= n;
  out_err /= n;
  MESSAGE("finger joints, 1.5 mm white noise: input " << in_err << " mm, bone fit " << out_err << " mm");
  // Three lengths fix three of a chain's nine coordinates, but the root's noise stays in them.
  CHECK(out_err < 0.96 * in_err);
  for (size_t c = 0; c < kFingerChains.size(); ++c)
    for (size_t b = 0; b < 3; ++b) {
      const double truth_len = (truth.pos[0].row(kFingerChains[c][b + 1]) - truth.pos[0].row(kFingerChains[c][b])).norm();
      CHECK(std::abs(fit.length(c, b) - truth_len) < 0.001);  // learnt within a millimetre of the hand's
      CHECK(fit.weight(c, b) > 0.5);                            // noise is fast: most of it moves
    }
  for (size_t c = 0; c < kFingerChains.size(); ++c) {
    CHECK(std::abs(fit.plane_offset(c)) < 0.001);  // the synthetic fingers bend in one plane
    CHECK(fit.plane_weight(c) > 0.5);
  }
}

TEST_CASE("Bone fit: noise across a finger's plane is taken out, and tips that sit off it by a fixed distance keep it") {
  const hs::HandSeries truth = moving_hand(8.0);
  const std::array<double, 5> off_mm = {2.0, -3.0, 1.5, 4.0, -2.5};
  std::mt19937_64 rng(12);
  std::normal_distribution<double> noise(0.0, 0.001);
  BoneFit fit, clean_fit;
  double in_err = 0.0, out_err = 0.0, clean_worst = 0.0;
  int n = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const Pose clean = tips_off_plane(truth.pos[i], off_mm);
    const Pose noisy = jittered(clean, rng, noise);
    fit.learn(truth.t[i], noisy);
    clean_fit.learn(truth.t[i], clean);
    Pose row = noisy, clean_row = clean;
    fit.apply(row);
    clean_fit.apply(clean_row);
    if (i < 180) continue;
    clean_worst = std::max(clean_worst, finger_error_mm(clean_row, clean));
    for (size_t c = 0; c < kFingerChains.size(); ++c) {
      const double want = tip_offset(clean, c), before = tip_offset(noisy, c), after = tip_offset(row, c);
      if (std::isnan(want) || std::isnan(before) || std::isnan(after)) continue;
      in_err += std::abs(before - want);
      out_err += std::abs(after - want);
      ++n;
    }
  }
  REQUIRE(n > 1000);
  in_err *= 1e3 / n;
  out_err *= 1e3 / n;
  MESSAGE("tips 1.5-4 mm off their plane, 1 mm noise: the tip's offset off by " << in_err << " mm in the input, " << out_err
                                                                               << " mm after the fit");
  CHECK(out_err < 0.7 * in_err);
  CHECK(clean_worst < 0.01);  // a clean hand with tips off the plane passes
  for (size_t c = 0; c < kFingerChains.size(); ++c) {
    CHECK(std::abs(1e3 * fit.plane_offset(c) - off_mm[c]) < 0.5);  // learnt within half a millimetre
    CHECK(fit.plane_weight(c) > 0.5);
  }
}

TEST_CASE("Bone fit: a clean moving hand comes out as it went in") {
  const hs::HandSeries truth = moving_hand(4.0);
  BoneFit fit;
  double worst = 0.0;
  for (size_t i = 0; i < truth.size(); ++i) {
    fit.learn(truth.t[i], truth.pos[i]);
    Pose row = truth.pos[i];
    fit.apply(row);
    worst = std::max(worst, finger_error_mm(row, truth.pos[i]));
  }
  CHECK(worst < 0.01);
}

TEST_CASE("Bone fit: bones that really change length slowly are moved little (their weight is low)") {
  const hs::HandSeries truth = moving_hand(10.0);
  std::mt19937_64 rng(6);
  std::normal_distribution<double> noise(0.0, 0.0003);  // a little noise, as any tracker has
  BoneFit fit;
  double in_err = 0.0, out_err = 0.0;
  int n = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const Pose clean = stretched(truth.pos[i], truth.t[i], 3.0);
    const Pose noisy = jittered(clean, rng, noise);
    fit.learn(truth.t[i], noisy);
    Pose row = noisy;
    fit.apply(row);
    if (i < 180) continue;
    in_err += finger_error_mm(noisy, clean);
    out_err += finger_error_mm(row, clean);
    ++n;
  }
  in_err /= n;
  out_err /= n;
  MESSAGE("bones changing length by up to 3 mm, 0.3 mm noise: input " << in_err << " mm, bone fit " << out_err << " mm");
  CHECK(out_err < 1.05 * in_err);
}

TEST_CASE("Bone fit: a chain with a missing joint or a bone of zero length is untouched, and learn ignores repeated and non-finite times") {
  const hs::HandSeries truth = moving_hand(2.0);
  std::mt19937_64 rng(8);
  std::normal_distribution<double> noise(0.0, 0.002);
  BoneFit fit;
  for (size_t i = 0; i < 60; ++i) fit.learn(truth.t[i], jittered(truth.pos[i], rng, noise));
  const int rows = fit.rows();
  fit.learn(truth.t[59], truth.pos[59]);  // the same time again
  fit.learn(hs::kNaN, truth.pos[59]);
  CHECK(fit.rows() == rows);
  Pose row = jittered(truth.pos[60], rng, noise);
  const Pose before = row;
  const auto& index = kFingerChains[1];
  row.row(index[2]).setConstant(hs::kNaN);
  fit.apply(row);
  for (int j : index)
    if (j != index[2]) CHECK(row.row(j) == before.row(j));
  CHECK(row.row(kFingerChains[2][3]) != before.row(kFingerChains[2][3]));  // the other chains are fitted
  // A bone of zero length (a runtime that puts two joints at one place) leaves its chain
  // alone, with no NaN.
  Pose flat = jittered(truth.pos[61], rng, noise);
  const auto& middle = kFingerChains[2];
  flat.row(middle[2]) = flat.row(middle[1]);
  const Pose flat_before = flat;
  fit.apply(flat);
  CHECK(flat.allFinite());
  for (int j : middle) CHECK(flat.row(j) == flat_before.row(j));
}

TEST_CASE("Bone fit: a joint the method filled in gives way before the joints it was given") {
  const hs::HandSeries truth = moving_hand(4.0);
  std::mt19937_64 rng(10);
  std::normal_distribution<double> noise(0.0, 0.001);
  BoneFit fit;
  for (size_t i = 0; i < truth.size(); ++i) fit.learn(truth.t[i], jittered(truth.pos[i], rng, noise));
  const auto& index = kFingerChains[1];
  const Pose& clean = truth.pos.back();
  // The tip filled in 4 mm too far along its bone.
  Pose filled = clean;
  const Eigen::RowVector3d along = (clean.row(index[3]) - clean.row(index[2])).normalized();
  filled.row(index[3]) += 0.004 * along;
  hs::JointMask observed;
  observed.fill(true);
  observed[size_t(index[3])] = false;
  Pose plain = filled, masked = filled;
  fit.apply(plain);
  fit.apply(masked, &observed);
  const auto moved_mm = [&](const Pose& p, int j) { return 1e3 * (p.row(j) - clean.row(j)).norm(); };
  MESSAGE("distal joint moved " << moved_mm(plain, index[2]) << " mm without the mask, " << moved_mm(masked, index[2])
                                << " with it; the tip left " << moved_mm(plain, index[3]) << " / " << moved_mm(masked, index[3]) << " mm off");
  CHECK(moved_mm(masked, index[2]) < 0.5 * moved_mm(plain, index[2]));
  CHECK(moved_mm(masked, index[3]) < moved_mm(plain, index[3]));
  CHECK(moved_mm(masked, index[3]) < 1.0);
}

TEST_CASE("Bone fit through make_filter: on for the networks by default, off for the classical methods unless asked, and a gap starts a take") {
  hs::FilterConfig c;
  c.method = hs::FilterMethod::Raw;
  CHECK_FALSE(hs::bone_fit_on(c));
  c.method = hs::FilterMethod::Stgae;
  CHECK(hs::bone_fit_on(c));
  c.bone_fit = false;
  CHECK_FALSE(hs::bone_fit_on(c));
  c.bone_fit.reset();
  c.stgae.offline = true;  // window mode has none
  CHECK_FALSE(hs::bone_fit_on(c));
  c = {};
  c.method = hs::FilterMethod::Raw;
  c.bone_fit = true;
  CHECK(hs::filter_params_summary(c) == "max_gap_ms=500 bone_fit=1");

  // Raw with the fit behind it answers what BoneFit makes of each row; a gap (time, or
  // untracked rows between) starts a take (BoneFit::resume).
  const hs::HandSeries truth = moving_hand(3.0, 30.0);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> noise(0.0, 0.002);
  auto f = hs::make_filter(c);
  BoneFit direct;
  double t_off = 0.0;
  for (int take = 0; take < 2; ++take) {
    for (size_t i = 0; i < truth.size(); ++i) {
      const double t = truth.t[i] + t_off;
      const Pose noisy = jittered(truth.pos[i], rng, noise);
      REQUIRE(f->push(t, noisy));
      if (i == 0 && take == 1) direct.resume();
      direct.learn(t, noisy);
      Pose got, want = noisy;
      f->estimate(t, got);
      direct.apply(want);
      CHECK_MESSAGE(got.isApprox(want, 1e-12), "take " << take << " row " << i << " " << (got - want).norm() << " " << (got - noisy).norm());
      // A take learns its lengths anew (a tracker may re-measure the hand): its first
      // answers pass unchanged, then the weights learnt before apply at once.
      if (take == 1 && i + 1 < size_t(hs::kBoneMinRows)) CHECK(got == noisy);
      if (take == 1 && i + 1 == size_t(hs::kBoneMinRows)) CHECK(got != noisy);
    }
    if (take == 0) {  // untracked rows for 1 s, then the same hand again
      const double end = truth.t.back();
      for (int k = 1; k <= 30; ++k) REQUIRE(f->push(end + k / 30.0, hs::untracked_pose()));
      t_off = end + 31.0 / 30.0 - truth.t.front();
    }
  }
}
