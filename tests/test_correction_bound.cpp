// The trust region on the network's output (correction_bound.hpp): exact on a clean still
// hand, free on a noisy one, outliers taken back whole, corrections far beyond the noise
// shrunk, predictions within reach of the input's motion; and the shipped model through the PoseFilter adapter on still hands.
#include "handsteady/correction_bound.hpp"
#include "handsteady/palm_fit.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"
#include "test_support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

namespace {
using hs::CorrectionBound;
using hs::kJointCount;
constexpr size_t kFs = 3 * kJointCount;

std::vector<float> frame_of(const hs::Pose& p) {
  std::vector<float> f(kFs);
  for (int j = 0; j < kJointCount; ++j)
    for (int c = 0; c < 3; ++c) f[static_cast<size_t>(3 * j + c)] = static_cast<float>(p(j, c));
  return f;
}

// A path of `frames` frames: each the input moved by `offset` (m, along x) plus `step` per frame.
std::vector<float> path_near(const std::vector<float>& x, int frames, double offset, double step) {
  std::vector<float> path(kFs * static_cast<size_t>(frames));
  for (int f = 0; f < frames; ++f)
    for (size_t i = 0; i < kFs; ++i)
      path[static_cast<size_t>(f) * kFs + i] = x[i] + static_cast<float>(i % 3 == 0 ? offset + f * step : 0.0);
  return path;
}

double max_diff(const float* a, const float* b, size_t n) {
  double w = 0.0;
  for (size_t i = 0; i < n; ++i) w = std::max(w, std::abs(static_cast<double>(a[i]) - static_cast<double>(b[i])));
  return w;
}

using hs::test::jittered;

// Frame f moved dx (m) along x.
std::vector<float> moved_x(std::vector<float> f, double dx) {
  for (size_t i = 0; i < kFs; i += 3) f[i] += static_cast<float>(dx);
  return f;
}
// Frame f with white jitter on every coordinate.
std::vector<float> jittered_frame(std::vector<float> f, std::mt19937_64& rng, std::normal_distribution<double>& noise) {
  for (auto& v : f) v += static_cast<float>(noise(rng));
  return f;
}

// One phase in [0, 2 pi) per coordinate.
std::vector<double> random_phases(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
  std::vector<double> v(kFs);
  for (auto& x : v) x = phase(rng);
  return v;
}

// A network's slow error of its own (a drag, as on motion it reshapes): 2 mm at 0.7 Hz on
// every coordinate, each with its phase, at time t (s).
void add_drag(std::vector<float>& path, double t, const std::vector<double>& phase) {
  for (size_t i = 0; i < kFs; ++i) path[i] += static_cast<float>(0.002 * std::sin(2 * M_PI * 0.7 * t + phase[i]));
}

// The distance between the points whose xyz start at a and b (m).
double joint_dist(const float* a, const float* b) {
  return (Eigen::Vector3d(a[0], a[1], a[2]) - Eigen::Vector3d(b[0], b[1], b[2])).norm();
}
// The distance of joint i / 3 of path frame f from the joint whose x is coordinate i of `at` (m).
double frame_off(const std::vector<float>& path, size_t f, const std::vector<float>& at, size_t i) {
  return joint_dist(path.data() + f * kFs + i, at.data() + i);
}
// The distance between two frames' joints whose x is coordinate i (m).
double joint_dist(const std::vector<float>& a, const std::vector<float>& b, size_t i) {
  return joint_dist(a.data() + i, b.data() + i);
}

}  // namespace

TEST_CASE("a clean still hand is answered exactly, predictions included, from the first frame") {
  CorrectionBound b(4);
  const auto x = frame_of(hs::test::synthetic_hand());
  for (int n = 0; n < 20; ++n) {
    auto path = path_near(x, 4, 0.005, 0.002);  // the network 5 mm off, drifting 2 mm a period
    b.apply(x, path);
    for (int f = 0; f < 4; ++f) CHECK(max_diff(path.data() + static_cast<size_t>(f) * kFs, x.data(), kFs) < 1e-6);
    CHECK(b.radius(3) == 0.0);
  }
}

TEST_CASE("white jitter: the radius is about three noise RMS and the network's denoising is kept") {
  CorrectionBound b;
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto clean = frame_of(hand);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 0.001);  // 1 mm per axis: RMS |n| = sqrt(3) mm
  double kept = 0.0, raw = 0.0;
  for (int n = 0; n < 300; ++n) {
    const auto x = frame_of(jittered(hand, rng, noise));
    auto path = clean;  // a perfect denoiser: its corrections are the noise, zero-mean
    b.apply(x, path);
    if (n < 30) continue;
    kept += max_diff(path.data(), clean.data(), kFs);
    raw += max_diff(x.data(), clean.data(), kFs);
    if (n < 299) continue;
    double mean = 0.0;
    for (int j = 0; j < kJointCount; ++j) mean += b.radius(j) / kJointCount;
    MESSAGE("mean radius " << mean * 1e3 << " mm, expected about " << 3.0 * std::sqrt(3.0) << " mm");
    CHECK(mean > 0.8 * 3.0 * std::sqrt(3.0) * 1e-3);
    CHECK(mean < 1.2 * 3.0 * std::sqrt(3.0) * 1e-3);
  }
  MESSAGE("largest coordinate error: " << kept / 270 * 1e3 << " mm answered, " << raw / 270 * 1e3 << " mm input");
  CHECK(kept < 0.3 * raw);
}

TEST_CASE("corrections far beyond the input's noise are shrunk to the share the noise explains") {
  // Noise measured at the input rate (InputNoise's E|n|^2): 0.5 mm per axis. Two networks
  // on the same input: one removes the noise exactly (its corrections are the noise: kept
  // whole), one removes it but adds an error of its own, zero-mean and 3 times the noise
  // (a network reshaping fast, nearly clean motion): its corrections are shrunk, and the
  // answer is about as close to the hand as the input, not 2 noise radii off as the
  // radius alone allows.
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto clean = frame_of(hand);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 0.0005), own(0.0, 0.0015);
  const std::vector<double> noise2(kJointCount, 3 * 0.0005 * 0.0005), jump(kJointCount, 0.0);
  CorrectionBound exact, erring;
  double e_exact = 0.0, e_erring = 0.0, e_unshrunk = 0.0, e_raw = 0.0;
  for (int n = 0; n < 400; ++n) {
    const auto x = frame_of(jittered(hand, rng, noise));
    auto p_exact = clean, p_erring = clean;
    for (auto& v : p_erring) v += static_cast<float>(own(rng));
    const auto asked = p_erring;
    exact.apply(x, p_exact, {.noise2 = noise2, .jump = jump});
    erring.apply(x, p_erring, {.noise2 = noise2, .jump = jump});
    if (n < 60) continue;
    for (size_t i = 0; i < kFs; i += 3) {
      const Eigen::Vector3d t(clean[i], clean[i + 1], clean[i + 2]), xi(x[i], x[i + 1], x[i + 2]);
      const auto at = [&](const std::vector<float>& q) { return Eigen::Vector3d(q[i], q[i + 1], q[i + 2]); };
      e_raw += (xi - t).norm();
      e_exact += (at(p_exact) - t).norm();
      e_erring += (at(p_erring) - t).norm();
      // What the radius alone would answer: the network's ask pulled into 2 noise RMS of x.
      const Eigen::Vector3d d = at(asked) - xi;
      const double r = hs::kMeasuredNoiseFactor * std::sqrt(noise2[0]);
      e_unshrunk += (xi + (d.norm() > r ? Eigen::Vector3d(d * (r / d.norm())) : d) - t).norm();
    }
  }
  MESSAGE("mean joint error (mm): input " << e_raw / 340 / kJointCount * 1e3 << ", exact denoiser "
          << e_exact / 340 / kJointCount * 1e3 << ", erring network " << e_erring / 340 / kJointCount * 1e3
          << " (the radius alone: " << e_unshrunk / 340 / kJointCount * 1e3 << ")");
  CHECK(e_exact < 0.05 * e_raw);
  CHECK(e_erring < 1.1 * e_raw);
  CHECK(e_erring < 0.8 * e_unshrunk);
}

TEST_CASE("one stream: corrections that change little from frame to frame are shrunk, noise removed is kept") {
  // No noise measured at the input rate (one stream at the model's rate, 30 Hz). Three
  // networks on a still hand with 0.5 mm of white jitter: one removes it exactly; one
  // removes it and adds a slow error of its own (a drag, 0.7 Hz, 2 mm: the kind a
  // network makes on motion it reshapes); one removes a 5 Hz, 1 mm tremor exactly (its
  // correction changes sign every three frames). The first and the last are kept, the slow
  // error shrunk to near the input's own error (the share estimated, not known).
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto clean = frame_of(hand);
  std::mt19937_64 rng(13);
  std::normal_distribution<double> noise(0.0, 0.0005);
  const auto drag_phase = random_phases(rng), tremor_phase = random_phases(rng);
  CorrectionBound exact, erring, tremor;
  double e_raw = 0.0, e_exact = 0.0, e_erring = 0.0, e_unshrunk = 0.0, e_traw = 0.0, e_tremor = 0.0;
  for (int n = 0; n < 600; ++n) {
    const double t = n / 30.0;
    const auto x = frame_of(jittered(hand, rng, noise));
    auto xt = clean;  // the tremor's input
    for (size_t i = 0; i < kFs; ++i) xt[i] += static_cast<float>(0.001 * std::sin(2 * M_PI * 5.0 * t + tremor_phase[i]));
    auto p_exact = clean, p_erring = clean, p_tremor = clean;
    add_drag(p_erring, t, drag_phase);
    const auto asked = p_erring;
    exact.apply(x, p_exact);
    erring.apply(x, p_erring);
    tremor.apply(xt, p_tremor);
    if (n < 90) continue;
    for (size_t i = 0; i < kFs; i += 3) {
      e_raw += joint_dist(x, clean, i);
      e_exact += joint_dist(p_exact, clean, i);
      e_erring += joint_dist(p_erring, clean, i);
      e_unshrunk += joint_dist(asked, clean, i);  // within the radius (3 noise RMS, 2.6 mm) nearly everywhere
      e_traw += joint_dist(xt, clean, i);
      e_tremor += joint_dist(p_tremor, clean, i);
    }
  }
  const double k = 1e3 / 510 / kJointCount;
  MESSAGE("mean joint error (mm): input " << e_raw * k << ", exact denoiser " << e_exact * k << ", erring network "
          << e_erring * k << " (its own answer " << e_unshrunk * k << "); tremor input " << e_traw * k
          << ", its exact remover " << e_tremor * k);
  CHECK(e_exact < 0.3 * e_raw);
  CHECK(e_erring < 1.5 * e_raw);
  CHECK(e_erring < 0.6 * e_unshrunk);
  CHECK(e_tremor < 0.3 * e_traw);
}

TEST_CASE("with the noise measured too, a slow error of the network's own is shrunk below twice that noise's share") {
  // 0.5 mm of white jitter, measured (E|n|^2 given, as InputNoise would), and a network
  // that removes it and adds a slow drag of 2 mm (0.7 Hz): the measured noise alone allows
  // twice its share, 2 E|n|^2 / E|c|^2 (about 0.22 here); the correction's correlation
  // reads the noise at about its true size, and the smaller of the two is kept.
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto clean = frame_of(hand);
  std::mt19937_64 rng(17);
  std::normal_distribution<double> noise(0.0, 0.0005);
  const auto drag_phase = random_phases(rng);
  const std::vector<double> noise2(kJointCount, 3 * 0.0005 * 0.0005), jump(kJointCount, 0.0);
  // E|c|^2 = E|n|^2 + E|e|^2 = 0.75 + 6 mm^2: twice the measured noise's share is 1.5 / 6.75.
  const double twice = 2.0 * 0.75 / 6.75;
  CorrectionBound b;
  double e_raw = 0.0, e_ans = 0.0, e_twice = 0.0;
  for (int n = 0; n < 600; ++n) {
    const auto x = frame_of(jittered(hand, rng, noise));
    auto p = clean;
    add_drag(p, n / 30.0, drag_phase);
    auto at_twice = x;
    for (size_t i = 0; i < kFs; ++i) at_twice[i] += static_cast<float>(twice * static_cast<double>(p[i] - x[i]));
    b.apply(x, p, {.noise2 = noise2, .jump = jump});
    if (n < 90) continue;
    for (size_t i = 0; i < kFs; i += 3) {
      e_raw += joint_dist(x, clean, i);
      e_ans += joint_dist(p, clean, i);
      e_twice += joint_dist(at_twice, clean, i);
    }
  }
  const double k = 1e3 / 510 / kJointCount;
  MESSAGE("mean joint error (mm): input " << e_raw * k << ", answered " << e_ans * k << ", at twice the measured share "
          << e_twice * k);
  CHECK(e_ans < 0.97 * e_twice);
  CHECK(e_ans < 1.1 * e_raw);
}

TEST_CASE("measured noise over the limit keeps the stream's own radius unless Gaussian in shape: a one-row shift is taken back whole") {
  // One stream on slow rows passes kMeasuredNoiseMaxRms: the `paper` preset's shifts read
  // as ~10 mm RMS of measured noise at the fingertips, where a radius of twice that held a
  // 40 mm shift 20 mm off; the stream's own radius opens to the row's second difference.
  const auto clean = frame_of(hs::test::synthetic_hand());
  const std::vector<double> jump(kJointCount, 0.0);  // a shift InputNoise did not call a jump
  auto answer = [&](double noise_rms, double max_rms, double shape = -1.0) {
    const std::vector<double> noise2(kJointCount, noise_rms * noise_rms);
    const std::vector<double> shapes(shape < 0.0 ? 0 : kJointCount, shape);  // none: no shape given
    CorrectionBound b;
    for (int n = 0; n < 40; ++n) {
      auto path = clean;
      b.apply(clean, path, {.noise2 = noise2, .jump = jump, .measured_max_rms = max_rms, .shape = shapes});
    }
    auto x = clean;
    x[3 * 7 + 1] += 0.04f;  // joint 7 shifted 40 mm for one row
    auto path = clean;      // the network answers the clean hand
    b.apply(x, path, {.noise2 = noise2, .jump = jump, .measured_max_rms = max_rms, .shape = shapes});
    return joint_dist(path, clean, 3 * 7);
  };
  const double limited = answer(0.01, hs::kMeasuredNoiseMaxRms), unlimited = answer(0.01, CorrectionBound::kUnlimitedRms);
  MESSAGE("a 40 mm one-row shift under 10 mm of measured noise: " << limited * 1e3 << " mm off with the limit, "
          << unlimited * 1e3 << " mm without");
  CHECK(limited < 1e-4);
  CHECK(unlimited == doctest::Approx(0.02).epsilon(0.01));  // twice the noise: the measured radius
  // Under the limit the measured noise bounds as before: 1 mm RMS moves the joint 2 mm at most.
  CHECK(answer(0.001, hs::kMeasuredNoiseMaxRms) >= 0.04 - 0.002 - 1e-6);
  // With the residuals' shape (K >= 2 streams, InputNoise::shapes): noise over the limit
  // that is Gaussian in shape is large jitter, which the measured radius serves, and keeps
  // it; a heavy tail (the `paper` shifts) keeps the stream's own.
  const double gaussian = answer(0.01, hs::kMeasuredNoiseMaxRms, 1.0);
  const double heavy = answer(0.01, hs::kMeasuredNoiseMaxRms, hs::kMeasuredNoiseMinShape - 0.05);
  MESSAGE("with the shape: " << gaussian * 1e3 << " mm off when Gaussian, " << heavy * 1e3 << " mm when heavy-tailed");
  CHECK(gaussian == doctest::Approx(0.02).epsilon(0.01));
  CHECK(heavy < 1e-4);
}

TEST_CASE("constant offsets of the network, now and predicted, are taken out") {
  // The network answers 3 mm beside a noisy still hand and predicts it moving 2 mm a
  // period: the mean answers, now and ahead, are pulled back to the hand within a second or so.
  CorrectionBound b(3);
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto clean = frame_of(hand);
  std::mt19937_64 rng(8);
  std::normal_distribution<double> noise(0.0, 0.001);
  std::array<Eigen::Vector3d, 3> mean{};
  mean.fill(Eigen::Vector3d::Zero());
  for (int n = 0; n < 150; ++n) {
    auto path = path_near(clean, 3, 0.003, 0.002);
    b.apply(frame_of(jittered(hand, rng, noise)), path);
    if (n < 90) continue;
    for (size_t f = 0; f < 3; ++f) {
      const float* q = path.data() + f * kFs + 30;
      mean[f] += Eigen::Vector3d(q[0] - clean[30], q[1] - clean[31], q[2] - clean[32]).cast<double>() / 60.0;
    }
  }
  for (size_t f = 0; f < 3; ++f) {
    CAPTURE(f);
    MESSAGE("mean offset of joint 10, " << f << " periods ahead, after 3 s: " << mean[f].norm() * 1e3
                                        << " mm (the network's: " << 3 + 2 * f << " mm)");
    // Predicted: less the shrinkage by two standard errors of a noisier mean (the input's
    // displacement over f frames carries two frames of noise).
    CHECK(mean[f].norm() < (f == 0 ? 0.5e-3 : 0.25 * (3 + 2 * static_cast<double>(f)) * 1e-3));
  }
}

TEST_CASE("a one-frame outlier is taken back whole, missing joints are not bound, reset forgets") {
  CorrectionBound b(2);
  const auto clean = frame_of(hs::test::synthetic_hand());
  for (int n = 0; n < 10; ++n) {
    auto path = path_near(clean, 2, 0.0, 0.0);
    b.apply(clean, path);
  }
  auto x = clean;
  x[3 * 7 + 1] += 0.03f;  // joint 7 jumps 30 mm
  x[3 * 4 + 0] = std::numeric_limits<float>::quiet_NaN();  // joint 4 missing
  auto path = path_near(clean, 2, 0.0, 0.0);  // the network answers the clean hand
  path[3 * 4 + 2] += 0.02f;                   // and fills joint 4 where it thinks it is
  const auto before = path;
  b.apply(x, path);
  CHECK(max_diff(path.data(), before.data(), kFs) < 1e-7);
  CHECK(b.radius(7) >= 0.03 - 1e-6);
  CHECK(std::isinf(b.radius(4)));
  CHECK(b.radius(0) == 0.0);

  // After reset the history is gone: a noisy past allows nothing on a still first frame.
  std::mt19937_64 rng(2);
  std::normal_distribution<double> noise(0.0, 0.003);
  for (int n = 0; n < 20; ++n) {
    auto xn = clean;
    for (auto& v : xn) v += static_cast<float>(noise(rng));
    auto p = path_near(xn, 2, 0.002, 0.0);
    b.apply(xn, p);
  }
  CHECK(b.radius(0) > 0.005);
  b.reset();
  auto p = path_near(clean, 2, 0.002, 0.0);
  b.apply(clean, p);
  CHECK(max_diff(p.data(), clean.data(), kFs) < 1e-7);
  CHECK(max_diff(p.data() + kFs, clean.data(), kFs) < 1e-7);
}

namespace {
// The hand turned by `deg` degrees about z through its palm joint; only the joints in
// `which` (all when empty).
hs::Pose turned(const hs::Pose& hand, double deg, const std::vector<int>& which = {}) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d c = hand.row(hs::idx(hs::Joint::Palm)).transpose();
  hs::Pose p = hand;
  for (int j = 0; j < kJointCount; ++j)
    if (which.empty() || std::find(which.begin(), which.end(), j) != which.end())
      p.row(j) = (c + r * (hand.row(j).transpose() - c)).transpose();
  return p;
}
}  // namespace

TEST_CASE("the radius opens to what a joint did against its hand: a hand turning as a whole is followed") {
  // One stream at the model's rate, the palm rigid (as the palm fit in front makes it). The
  // hand turns 1 degree a frame, the network answering the input; then 25 degrees in one
  // frame while the network still answers the frame before (its lag). Measured in the
  // world, that frame's second difference (~40 mm at the fingertips) would open the
  // radius and let the lag through; in the hand's frame it is nothing.
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto tip = static_cast<size_t>(3 * hs::idx(hs::Joint::IndexTip));
  const auto run_up = [&](CorrectionBound& b) {
    for (int n = 0; n < 20; ++n) {
      const auto x = frame_of(turned(hand, n));
      auto path = path_near(x, 2, 0.0, 0.0);
      b.apply(x, path);
    }
  };
  {
    CorrectionBound b(2);
    run_up(b);
    const auto before = frame_of(turned(hand, 19));
    const auto x = frame_of(turned(hand, 44));
    CHECK(joint_dist(x, before, tip) > 0.03);
    auto path = path_near(before, 2, 0.0, 0.0);
    b.apply(x, path);
    CHECK(b.radius(static_cast<int>(tip / 3)) < 0.002);
    CHECK(frame_off(path, 0, x, tip) < 0.002);
  }
  {
    // A joint that jumps against its hand while the hand turns as before is taken back whole.
    CorrectionBound b(2);
    run_up(b);
    const auto clean = frame_of(turned(hand, 20));
    auto x = clean;
    x[tip + 1] += 0.03f;
    auto path = path_near(clean, 2, 0.0, 0.0);
    b.apply(x, path);
    CHECK(b.radius(static_cast<int>(tip / 3)) >= 0.029);
    CHECK(frame_off(path, 0, clean, tip) < 1e-6);
  }
  {
    // A palm that turns while the fingers stay (a fit in front that failed) is no motion of
    // the hand: the radius opens to the palm joints' world second difference, and the
    // network may take them back.
    CorrectionBound b(2);
    run_up(b);
    std::vector<int> palm(hs::kPalmJoints.begin(), hs::kPalmJoints.end());
    const hs::Pose at20 = turned(hand, 20);
    const auto clean = frame_of(at20);
    const auto x = frame_of(turned(at20, 30, palm));
    const auto meta = static_cast<size_t>(3 * hs::idx(hs::Joint::IndexProximal));
    CHECK(joint_dist(x, clean, meta) > 0.02);
    auto path = path_near(clean, 2, 0.0, 0.0);
    b.apply(x, path);
    CHECK(frame_off(path, 0, clean, meta) < 1e-6);
  }
}

namespace {
// The hand at frame n of a 40 mm sweep to and fro at 2 Hz, 30 frames a second.
std::vector<float> swept(const hs::Pose& hand, int n) {
  return frame_of(hand.rowwise() + Eigen::RowVector3d(0.04 * std::sin(2 * M_PI * 2.0 * n / 30.0), 0, 0));
}
}  // namespace

TEST_CASE("a hand that sweeps as a whole: each joint's own correction is held to the hand's frame, the whole hand's is not") {
  // One stream at 30 Hz; a clean hand sweeping 40 mm to and fro at 2 Hz (7 mm of second
  // difference a frame at every joint, all of it the hand's motion). The world's roughness
  // would give the network a radius of ~6 mm for errors of its own at each joint; in the
  // hand's frame the input is still, and a joint may move only with the hand.
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto at = [&](int n) { return swept(hand, n); };
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.002 / std::sqrt(3.0));
  {
    // The network answers each joint 2 mm RMS off, a new error each frame (what the shrink
    // reads as noise removed): held to within a fraction of that.
    CorrectionBound b(2);
    double off = 0.0;
    int count = 0;
    for (int n = 0; n < 90; ++n) {
      const auto x = at(n);
      auto path = path_near(x, 2, 0.0, 0.0);
      for (size_t i = 0; i < kFs; ++i) path[i] += static_cast<float>(noise(rng));
      b.apply(x, path);
      if (n < 30) continue;
      for (size_t i = 0; i < kFs; i += 3) off += frame_off(path, 0, x, i), ++count;
    }
    CHECK(off / count < 0.0007);
  }
  {
    // The input shaken as a whole, 2 mm RMS a frame, which the network takes out: kept.
    CorrectionBound b(2);
    double off = 0.0, raw = 0.0;
    int count = 0;
    for (int n = 0; n < 90; ++n) {
      const auto clean = at(n);
      auto x = clean;
      const Eigen::Vector3d shake(noise(rng), noise(rng), noise(rng));
      for (size_t i = 0; i < kFs; ++i) x[i] += static_cast<float>(shake[static_cast<int>(i % 3)]);
      auto path = path_near(clean, 2, 0.0, 0.0);
      b.apply(x, path);
      if (n < 30) continue;
      for (size_t i = 0; i < kFs; i += 3) off += frame_off(path, 0, clean, i), raw += joint_dist(x, clean, i), ++count;
    }
    CHECK(off < 0.1 * raw);
  }
}

TEST_CASE("an outlier that lasts three rows is taken back on its third, where its bones say it is still off") {
  // One stream at 30 Hz, the hand sweeping as above; the index tip shifted 15 mm for three
  // rows, the network answering the clean hand. On the third row the tip's second
  // difference is nothing (shifted now and the row before alike): only the row before's
  // jump, and its bones still off their length (InputNoise::stretched), say it is an
  // outlier. A re-fit that stays looks the same to the second differences but keeps its
  // bones: there the radius stays at the noise.
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto at = [&](int n) { return swept(hand, n); };
  const auto tip = static_cast<size_t>(3 * hs::idx(hs::Joint::IndexTip));
  const auto tip_j = static_cast<size_t>(hs::idx(hs::Joint::IndexTip));
  const auto parent = static_cast<size_t>(hs::kXrParent[tip_j]);
  // Returns the tip's offset from the clean hand on the outlier's third row, and its radius there.
  const auto third_row = [&](bool off_bones) {
    CorrectionBound b(2);
    for (int n = 0; n < 63; ++n) {
      const auto clean = at(n);
      auto x = clean;
      std::array<bool, kJointCount> stretched{};
      if (n >= 60) {
        x[tip + 1] += 0.015f;
        stretched[tip_j] = stretched[parent] = off_bones;
      }
      auto path = path_near(clean, 2, 0.0, 0.0);
      b.apply(x, path, {.stretched = stretched});
      if (n == 62) return std::pair(frame_off(path, 0, clean, tip), b.radius(static_cast<int>(tip_j)));
    }
    return std::pair(1.0, 0.0);
  };
  const auto [outlier_off, outlier_r] = third_row(true);
  CHECK(outlier_r >= 0.0149);
  CHECK(outlier_off < 0.001);
  const auto [refit_off, refit_r] = third_row(false);
  MESSAGE("third row: " << outlier_off * 1e3 << " mm off, radius " << outlier_r * 1e3 << " mm; bones kept: "
                        << refit_off * 1e3 << " mm, radius " << refit_r * 1e3 << " mm");
  CHECK(refit_r < 0.012);
  CHECK(refit_off > 0.003);
}

TEST_CASE("on a whole hand's own row followed, the row before stays in the roughness") {
  // One stream; a clean still hand steps 5 mm in one row, then 30 mm in the next, and
  // stays; every joint followed on the 30 mm row and the two after (InputNoise::followed).
  // A followed row takes the row before's second difference back out of the roughness (on
  // the row after a re-fit that is the re-fit's). On a whole hand's own row
  // (InputNoise::hand_refit) the row before is no re-fit's but the hand's motion setting
  // off, and stays: the noise radius after it is what that step says.
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto radius_after = [&](bool hand_moved) {
    CorrectionBound b(2);
    std::array<bool, kJointCount> all{};
    all.fill(true);
    for (int n = 0; n < 24; ++n) {
      const double dx = n >= 20 ? 0.035 : n == 19 ? 0.005 : 0.0;
      const auto x = frame_of(hand.rowwise() + Eigen::RowVector3d(dx, 0, 0));
      auto path = path_near(x, 2, 0.0, 0.0);
      const bool followed = n >= 20 && n <= 22;
      b.apply(x, path, {.followed = followed ? std::span<const bool>(all) : std::span<const bool>(),
                        .followed_hand = hand_moved && n == 20});
    }
    return b.radius(hs::idx(hs::Joint::IndexTip));
  };
  const double hand_r = radius_after(true), refit_r = radius_after(false);
  MESSAGE("the radius after the whole hand's 30 mm row: " << hand_r * 1e3 << " mm; after a re-fit's: " << refit_r * 1e3 << " mm");
  CHECK(hand_r > 0.001);
  CHECK(refit_r < 0.0001);
}

TEST_CASE("predicted displacements the input's future does not confirm are taken back, a hand setting off keeps its") {
  // 30 Hz, 1 mm of white jitter. For 3 s the hand is still and the network answers it
  // exactly but predicts it moving 2 mm a period back and forth at 10 Hz (a tremor it
  // extrapolates); then the hand sets off at 6 mm a period and the network predicts that.
  CorrectionBound b(4);
  const hs::Pose hand = hs::test::synthetic_hand();
  const auto clean = frame_of(hand);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 0.001);
  const auto phase = random_phases(rng);
  constexpr double kRate = 30.0, kStep = 0.006;
  constexpr int kStill = 90;
  std::array<double, 4> err{}, made{};  // still, last second: per path frame, answer and network error (m)
  double moving_err = 0.0;              // moving, frames 3-10: frame 2's error
  for (int n = 0; n < kStill + 11; ++n) {
    const double t = n / kRate;
    const int moved = std::max(n - kStill, 0);
    auto truth_at = [&](int ahead) { return moved_x(clean, (n + ahead > kStill ? n + ahead - kStill : 0) * kStep); };
    const auto x = jittered_frame(truth_at(0), rng, noise);
    std::vector<float> path(4 * kFs);
    for (size_t f = 0; f < 4; ++f) {
      const auto ahead = truth_at(static_cast<int>(f));
      for (size_t i = 0; i < kFs; ++i) {
        const double shake = n < kStill ? 0.002 * static_cast<double>(f) * std::sin(2 * M_PI * 10.0 * t + phase[i]) : 0.0;
        path[f * kFs + i] = ahead[i] + static_cast<float>(shake);
      }
    }
    const auto network = path;
    b.apply(x, path);
    for (size_t f = 1; f < 4; ++f) {
      const auto ahead = truth_at(static_cast<int>(f));
      for (size_t i = 0; i < kFs; i += 3) {
        if (n >= kStill - 30 && n < kStill) {
          err[f] += frame_off(path, f, ahead, i) / (30.0 * kJointCount);
          made[f] += frame_off(network, f, ahead, i) / (30.0 * kJointCount);
        }
        if (f == 2 && moved >= 3) moving_err += frame_off(path, f, ahead, i) / (8.0 * kJointCount);
      }
    }
  }
  for (size_t f = 1; f < 4; ++f) {
    CAPTURE(f);
    MESSAGE("still hand, " << f << " periods ahead: " << err[f] * 1e3 << " mm from the hand (the network's "
                           << made[f] * 1e3 << " mm)");
    // Frame 1 has no gain; the blend with the denoised velocity (the next test) takes it back here.
    if (f >= static_cast<size_t>(hs::kPredictionGainFirstFrame)) CHECK(err[f] < 0.5 * made[f]);
  }
  MESSAGE("setting off at 18 cm/s, 2 periods ahead (12 mm): " << moving_err * 1e3 << " mm from the hand");
  CHECK(moving_err < 0.003);
}

TEST_CASE("with the noise measured at the input rate, a still hand's shake is taken back one period ahead too") {
  // 1 mm of white jitter, the noise measured (K >= 2 streams) or not (one stream). The
  // network takes out half of the jitter and predicts a 10 Hz shake of 2 mm a period ahead.
  // Its denoised frames' velocity is noise too, so the blend alone has no good forecast to
  // weigh the shake against; where the noise is measured, the gain from frame 1 takes it
  // back (one period ahead is then also the older stream's share of an answer now). One
  // stream does not gain frame 1 (kPredictionGainFirstFrame): only the blend with the
  // denoised velocity takes part of the shake back there. Both runs see the same input.
  const auto clean = frame_of(hs::test::synthetic_hand());
  const std::vector<double> noise2(kJointCount, 3 * 0.001 * 0.001), jump(kJointCount, 0.0);
  std::array<double, 2> stray{}, made{};  // frame 1, last second, one stream / measured: from the denoised frame (m)
  for (int measured = 0; measured < 2; ++measured) {
    CorrectionBound b(4);
    std::mt19937_64 rng(17);
    std::normal_distribution<double> noise(0.0, 0.001);
    const auto phase = random_phases(rng);
    constexpr int kRows = 120;
    for (int n = 0; n < kRows; ++n) {
      const double t = n / 30.0;
      const auto x = jittered_frame(clean, rng, noise);
      std::vector<float> path(4 * kFs);
      for (size_t f = 0; f < 4; ++f)
        for (size_t i = 0; i < kFs; ++i) {
          const double shake = 0.002 * static_cast<double>(f) * std::sin(2 * M_PI * 10.0 * t + phase[i]);
          path[f * kFs + i] = clean[i] + 0.5f * (x[i] - clean[i]) + static_cast<float>(shake);
        }
      const auto network = path;
      if (measured) b.apply(x, path, {.noise2 = noise2, .jump = jump});
      else b.apply(x, path);
      if (n < kRows - 30) continue;
      const auto m = static_cast<size_t>(measured);
      for (size_t i = 0; i < kFs; i += 3) {
        stray[m] += frame_off(path, 1, path, i) / (30.0 * kJointCount);
        made[m] += frame_off(network, 1, network, i) / (30.0 * kJointCount);
      }
    }
  }
  MESSAGE("one period ahead, from the denoised frame: one stream " << stray[0] * 1e3 << " mm (the network's "
                                                                   << made[0] * 1e3 << " mm), the noise measured "
                                                                   << stray[1] * 1e3 << " mm (the network's "
                                                                   << made[1] * 1e3 << " mm)");
  CHECK(made[0] == doctest::Approx(made[1]));
  CHECK(stray[0] < made[0]);
  CHECK(stray[1] < 0.15 * made[1]);
  CHECK(stray[1] < 0.6 * stray[0]);
}

namespace {
// The hand of the two tests below, row n at 30 Hz: still for kStill rows, then swaying 4 cm
// along x at 0.5 Hz (up to 2 mm a period); its input with 0.5 mm of white jitter, and a
// network that takes out half of the jitter and predicts only 60 % of each displacement.
struct SwayingHand {
  static constexpr double kRate = 30.0;
  static constexpr int kStill = 90, kMoving = 180;
  std::vector<float> clean = frame_of(hs::test::synthetic_hand());
  std::mt19937_64 rng{5};
  std::normal_distribution<double> noise{0.0, 0.0005};
  std::vector<float> truth(int n) const {
    return moved_x(clean, 0.04 * std::sin(M_PI * (std::max(n - kStill, 0) / kRate)));
  }
  // Row n's input and the network's path for it (4 frames).
  std::pair<std::vector<float>, std::vector<float>> row(int n) {
    const auto now = truth(n);
    auto x = jittered_frame(now, rng, noise);
    std::vector<float> path(4 * kFs);
    for (size_t f = 0; f < 4; ++f) {
      const auto ahead = truth(n + static_cast<int>(f));
      for (size_t i = 0; i < kFs; ++i) path[f * kFs + i] = now[i] + 0.5f * (x[i] - now[i]) + 0.6f * (ahead[i] - now[i]);
    }
    return {std::move(x), std::move(path)};
  }
};
}  // namespace

TEST_CASE("predictions that fall behind a moving hand take the denoised velocity's share, a still hand's gets none") {
  // SwayingHand: for 3 s the hand is still (the denoised velocity is what is left of the
  // noise), then it sways.
  CorrectionBound b(4);
  SwayingHand hand;
  constexpr int kStill = SwayingHand::kStill, kMoving = SwayingHand::kMoving;
  std::array<double, 4> still_err{}, err{}, made{};  // per path frame (m)
  for (int n = 0; n < kStill + kMoving; ++n) {
    auto [x, path] = hand.row(n);
    const auto network = path;
    b.apply(x, path);
    for (size_t f = 1; f < 4; ++f) {
      const auto ahead = hand.truth(n + static_cast<int>(f));
      for (size_t i = 0; i < kFs; i += 3) {
        // Still: how far the prediction strays from the denoised frame (the velocity forecast alone: ~0.5 mm a period).
        if (n >= kStill - 30 - 3 && n < kStill - 3) still_err[f] += frame_off(path, f, path, i) / (30.0 * kJointCount);
        if (n >= kStill + 60) {
          err[f] += frame_off(path, f, ahead, i) / ((kMoving - 60.0) * kJointCount);
          made[f] += frame_off(network, f, ahead, i) / ((kMoving - 60.0) * kJointCount);
        }
      }
    }
  }
  for (size_t f = 1; f < 4; ++f) {
    CAPTURE(f);
    MESSAGE(f << " periods ahead: still hand " << still_err[f] * 1e3 << " mm from its denoised frame; swaying "
              << err[f] * 1e3 << " mm from the hand (the network's " << made[f] * 1e3 << " mm)");
    CHECK(still_err[f] < 0.1e-3 * static_cast<double>(f));  // the still hand's noisy velocity was not taken up
    CHECK(err[f] < 0.8 * made[f]);
  }
}

TEST_CASE("rows InputNoise calls jumps on a moving hand still teach the predictions where the hand went") {
  // The test above with the noise measured, as on input faster or slower than the model:
  // InputNoise measures 0.5 mm of jitter, and on rows slower than the model a swaying
  // hand's rows leave their quadratic by more than that, so it calls each of them a jump
  // (2 mm). The stream's own frames see no outlier (their second difference is the sway's
  // and the jitter's), so the rows still say where the predictions went, and the blend takes
  // the denoised velocity's share. Read as jumps they said nothing, and the predictions
  // stayed as far behind as the network's.
  const std::vector<double> noise2(kJointCount, 3 * 0.0005 * 0.0005), calm(kJointCount, 0.0), jumps(kJointCount, 0.002);
  CorrectionBound b(4);
  SwayingHand hand;
  constexpr int kStill = SwayingHand::kStill, kMoving = SwayingHand::kMoving;
  std::array<double, 4> err{}, made{};  // per path frame, the last 4 s (m)
  for (int n = 0; n < kStill + kMoving; ++n) {
    auto [x, path] = hand.row(n);
    const auto network = path;
    b.apply(x, path, {.noise2 = noise2, .jump = n < kStill ? calm : jumps});
    if (n < kStill + 60) continue;
    for (size_t f = 1; f < 4; ++f) {
      const auto ahead = hand.truth(n + static_cast<int>(f));
      for (size_t i = 0; i < kFs; i += 3) {
        err[f] += frame_off(path, f, ahead, i) / ((kMoving - 60.0) * kJointCount);
        made[f] += frame_off(network, f, ahead, i) / ((kMoving - 60.0) * kJointCount);
      }
    }
  }
  for (size_t f = 1; f < 4; ++f) {
    CAPTURE(f);
    MESSAGE(f << " periods ahead, every moving row a jump to InputNoise: " << err[f] * 1e3
              << " mm from the hand (the network's " << made[f] * 1e3 << " mm)");
    CHECK(err[f] < 0.8 * made[f]);
  }
}

TEST_CASE("clean motion at constant velocity: predictions are pulled onto the input's own line") {
  CorrectionBound b(5);
  const auto hand = frame_of(hs::test::synthetic_hand());
  constexpr double kStep = 0.004;  // 4 mm a period along x (12 cm/s at 30 Hz)
  for (int n = 0; n < 12; ++n) {
    auto x = hand;
    for (size_t i = 0; i < kFs; i += 3) x[i] += static_cast<float>(n * kStep);
    // The network: 1 mm behind now, predicting half the speed. Clean input has no
    // roughness, so both are pulled onto the input's line.
    auto path = path_near(x, 5, -0.001, 0.5 * kStep);
    b.apply(x, path);
    if (n < 1) continue;  // the velocity is known from the second frame
    for (int f = 0; f < 5; ++f) {
      auto expect = x;
      for (size_t i = 0; i < kFs; i += 3) expect[i] += static_cast<float>(f * kStep);
      CAPTURE(n);
      CAPTURE(f);
      CHECK(max_diff(path.data() + static_cast<size_t>(f) * kFs, expect.data(), kFs) < 2e-6);
    }
  }
}

TEST_CASE("the shipped model holds a still hand of any proportion still, from start and after a gap") {
  const auto model = hs::test::shipped_model();
  for (const double scale : {0.8, 1.0, 1.25})
    for (const double rate : {20.0, 30.0, 90.0})
      for (const double horizon : {0.0, 0.05}) {
        CAPTURE(scale);
        CAPTURE(rate);
        CAPTURE(horizon);
        hs::Pose pose = hs::test::synthetic_hand() * scale;
        pose.rowwise() += Eigen::RowVector3d(0.1, -0.2, -0.35);  // in front of the head
        const auto run = [&](bool bounded) {
          auto f = hs::make_stgae_filter(model, horizon, 0, bounded);
          double worst = 0.0;
          hs::Pose out;
          for (double t = 0.0; t < 3.0; t += 1.0 / rate) {
            const bool lost = t >= 1.5 && t < 2.0;  // a gap longer than the model's reset
            f->push(t, lost ? hs::untracked_pose() : pose);
            if (lost) continue;
            f->estimate(t, out);
            worst = std::max(worst, (out - pose).rowwise().norm().maxCoeff());
          }
          return worst;
        };
        const double bounded = run(true), unbounded = run(false);
        MESSAGE("largest joint error on a still hand: " << bounded * 1e3 << " mm bounded, " << unbounded * 1e3
                                                         << " mm unbounded");
        CHECK(bounded < 1e-5);
        CHECK(unbounded > 1e-3);  // the network alone does move it: the test can fail
      }
}


TEST_CASE("the shipped model's mean answer on a still hand with tracker jitter is the hand") {
  // Noise lets the network correct; its learnt offset for an unfamiliar hand must not stay.
  const auto model = hs::test::shipped_model();
  for (const double scale : {0.8, 1.0, 1.25})
    for (const double rate : {30.0, 90.0}) {
      CAPTURE(scale);
      CAPTURE(rate);
      hs::Pose pose = hs::test::synthetic_hand() * scale;
      pose.rowwise() += Eigen::RowVector3d(0.1, -0.2, -0.35);
      const auto run = [&](bool bounded) {
        auto f = hs::make_stgae_filter(model, 0.0, 0, bounded);
        std::mt19937_64 rng(1);
        std::normal_distribution<double> noise(0.0, 0.0005);
        hs::Pose sum = hs::Pose::Zero(), out;
        int n = 0;
        for (double t = 0.0; t < 4.0; t += 1.0 / rate) {
          f->push(t, jittered(pose, rng, noise));
          f->estimate(t, out);
          if (t < 2.0) continue;
          sum += out;
          ++n;
        }
        return (sum / n - pose).rowwise().norm().maxCoeff();
      };
      const double bounded = run(true), unbounded = run(false);
      MESSAGE("largest joint offset of the mean answer: " << bounded * 1e3 << " mm bounded, " << unbounded * 1e3
                                                           << " mm unbounded");
      CHECK(bounded < 0.6e-3);
      CHECK(bounded < unbounded);
      // Where the network alone is off by more than that (the base model: 1.0-2.1 mm), the
      // trust region takes at least half of it out; the shipped blend alone is within
      // 0.36-0.53 mm, which the check above holds it to.
      if (unbounded > 0.6e-3) CHECK(bounded < 0.5 * unbounded);
    }
}
