// Seeded corruption presets (docs/CORRUPTION.md).
#include "handsteady/corrupt.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace hs {
namespace {

using Vec3 = Eigen::Vector3d;
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// splitmix64 finaliser: turns (seed, stream) into well-separated engine seeds so each
// hand and each noise component has its own independent stream.
uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}
uint64_t sub_seed(uint64_t seed, uint64_t stream) { return mix64(seed + 0x9E3779B97F4A7C15ULL * (stream + 1)); }

// std::mt19937_64's sequence is fixed by the standard; std:: distributions are not,
// so the transforms to uniform/normal/exponential are our own.
class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}
  // [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  bool bernoulli(double p) { return uniform() < p; }
  // Box-Muller; the second value of each pair is kept for the next call.
  double normal() {
    if (have_spare_) {
      have_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]: log is finite
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(kTwoPi * u2);
    have_spare_ = true;
    return r * std::cos(kTwoPi * u2);
  }
  double exponential(double mean) { return -mean * std::log(1.0 - uniform()); }
  Vec3 unit_vector() {
    for (;;) {
      Vec3 v(normal(), normal(), normal());
      const double n = v.norm();
      if (n > 1e-9) return v / n;
    }
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool have_spare_ = false;
};

Vec3 joint(const Pose& p, int j) { return p.row(j).transpose(); }
void set_joint(Pose& p, int j, const Vec3& v) { p.row(j) = v.transpose(); }

// Median over rows of the wrist -> middle_proximal distance (0 when never tracked).
double median_hand_size(const HandSeries& s) {
  std::vector<double> d;
  const int w = idx(Joint::Wrist), m = idx(Joint::MiddleProximal);
  for (const Pose& p : s.pos)
    if (joint_tracked(p, w) && joint_tracked(p, m)) d.push_back((joint(p, m) - joint(p, w)).norm());
  if (d.empty()) return 0.0;
  auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  return *mid;
}

// ---- paper (STGAE Algorithm 1) ------------------------------------------------------

// Joints in parent-first (breadth-first) order with their hop count from the root.
struct TreeOrder {
  std::vector<int> order;
  std::vector<int> depth;
};
const TreeOrder& xr_tree_order() {
  static const TreeOrder tree = [] {
    const Skeleton& sk = xr_hand_skeleton();
    const int n = sk.joint_count();
    TreeOrder t;
    t.depth.assign(static_cast<size_t>(n), -1);
    // Depth by following parents (the tree is tiny; no need for anything smarter).
    for (int j = 0; j < n; ++j) {
      int d = 0;
      for (int p = sk.parent[static_cast<size_t>(j)]; p >= 0 && d <= n; p = sk.parent[static_cast<size_t>(p)]) ++d;
      t.depth[static_cast<size_t>(j)] = d;
    }
    for (int j = 0; j < n; ++j) t.order.push_back(j);
    std::stable_sort(t.order.begin(), t.order.end(),
                     [&](int a, int b) { return t.depth[static_cast<size_t>(a)] < t.depth[static_cast<size_t>(b)]; });
    return t;
  }();
  return tree;
}

// Probability of the Bernoulli masks: min(|alpha|, 2 sigma), alpha ~ N(0, sigma^2).
double frame_mask_probability(Rng& rng, double sigma) {
  return std::min(std::abs(sigma * rng.normal()), 2.0 * sigma);
}

HandSeries corrupt_paper(const HandSeries& clean, const PaperCorruption& c, uint64_t seed) {
  HandSeries out = clean;
  double beta = c.beta_m;
  if (c.reference_hand_m > 0.0) {
    const double size = median_hand_size(clean);
    if (size > 0.0) beta *= size / c.reference_hand_m;
  }
  Rng shift_rng(sub_seed(seed, 0));
  Rng occl_rng(sub_seed(seed, 1));
  for (size_t i = 0; i < clean.size(); ++i) {
    const Pose& x = clean.pos[i];
    Pose& y = out.pos[i];
    // Every draw is made whether or not the joint is tracked, so the noise of a row
    // does not depend on which joints happen to be missing.
    const double ps = frame_mask_probability(shift_rng, c.sigma_s);
    for (int j = 0; j < kJointCount; ++j) {
      const bool shift = shift_rng.bernoulli(ps);
      const Vec3 s(shift_rng.uniform(-beta, beta), shift_rng.uniform(-beta, beta), shift_rng.uniform(-beta, beta));
      if (shift && joint_tracked(x, j)) set_joint(y, j, joint(x, j) + s);
    }
    if (c.optimize) y = paper_optimize(x, y);
    const double po = frame_mask_probability(occl_rng, c.sigma_o);
    for (int j = 0; j < kJointCount; ++j)
      if (occl_rng.bernoulli(po)) y.row(j).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

// ---- tracker -------------------------------------------------------------------------

HandSeries corrupt_tracker(const HandSeries& clean, const TrackerCorruption& c, uint64_t seed) {
  HandSeries out = clean;
  const size_t n = clean.size();
  Rng jitter_rng(sub_seed(seed, 0)), drop_rng(sub_seed(seed, 1)), hand_rng(sub_seed(seed, 2)),
      jump_rng(sub_seed(seed, 3)), outlier_rng(sub_seed(seed, 4)), hand_jitter_rng(sub_seed(seed, 5));
  std::array<int, kJointCount> outlier_rows{};  // rows the joint's outlier still holds
  std::array<Vec3, kJointCount> outlier_step;

  // Whole-hand dropouts: Poisson starts over the series' time span, exponential lengths.
  std::vector<bool> hand_dropped(n, false);
  if (c.hand_drop_rate_hz > 0.0 && c.hand_drop_mean_s > 0.0 && n > 0) {
    const double t0 = clean.t.front(), t1 = clean.t.back();
    double start = t0 + hand_rng.exponential(1.0 / c.hand_drop_rate_hz);
    size_t i = 0;
    while (start <= t1) {
      const double end = start + hand_rng.exponential(c.hand_drop_mean_s);
      while (i < n && clean.t[i] < start) ++i;
      for (size_t k = i; k < n && clean.t[k] < end; ++k) hand_dropped[k] = true;
      start += hand_rng.exponential(1.0 / c.hand_drop_rate_hz);
    }
  }

  // AR(1) jitter with stationary SD jitter_sd_m: n_t = a n_{t-1} + sqrt(1 - a^2) sd z.
  const double a = c.jitter_ar1;
  const double innov = std::sqrt(1.0 - a * a);
  Pose noise;
  for (int j = 0; j < kJointCount; ++j)
    for (int k = 0; k < 3; ++k) noise(j, k) = c.jitter_sd_m * jitter_rng.normal();

  // The whole hand's jitter, the same process shared by every joint of a row.
  Vec3 hand_noise = Vec3::Zero();
  if (c.hand_jitter_sd_m > 0.0)
    for (int k = 0; k < 3; ++k) hand_noise(k) = c.hand_jitter_sd_m * hand_jitter_rng.normal();

  for (size_t i = 0; i < n; ++i) {
    if (i > 0)
      for (int j = 0; j < kJointCount; ++j)
        for (int k = 0; k < 3; ++k) noise(j, k) = a * noise(j, k) + innov * c.jitter_sd_m * jitter_rng.normal();
    if (i > 0 && c.hand_jitter_sd_m > 0.0)
      for (int k = 0; k < 3; ++k) hand_noise(k) = a * hand_noise(k) + innov * c.hand_jitter_sd_m * hand_jitter_rng.normal();
    Pose& y = out.pos[i];
    for (int j = 0; j < kJointCount; ++j) {
      const bool drop = drop_rng.bernoulli(c.joint_drop_prob);
      const bool jump = jump_rng.bernoulli(c.jump_prob);
      const Vec3 jv(jump_rng.normal(), jump_rng.normal(), jump_rng.normal());
      const auto ju = static_cast<size_t>(j);
      if (c.outlier_prob > 0.0 && outlier_rows[ju] == 0 && outlier_rng.bernoulli(c.outlier_prob)) {
        outlier_step[ju] = outlier_rng.uniform(c.outlier_min_m, c.outlier_max_m) * outlier_rng.unit_vector();
        outlier_rows[ju] = 1 + std::min(static_cast<int>(outlier_rng.uniform() * c.outlier_max_rows), c.outlier_max_rows - 1);
      }
      const bool outlier = outlier_rows[ju] > 0;
      if (outlier) --outlier_rows[ju];
      if (!joint_tracked(y, j)) continue;
      if (hand_dropped[i] || drop) {
        y.row(j).setConstant(std::numeric_limits<double>::quiet_NaN());
        continue;
      }
      Vec3 p = joint(y, j) + noise.row(j).transpose() + hand_noise;
      if (jump) p += c.jump_sd_m * jv;
      if (outlier) p += outlier_step[ju];
      if (c.quantize_m > 0.0)
        for (int k = 0; k < 3; ++k) p(k) = std::round(p(k) / c.quantize_m) * c.quantize_m;
      set_joint(y, j, p);
    }
  }
  return out;
}

// ---- tremor --------------------------------------------------------------------------

// A sinusoid along a fixed direction whose frequency wanders slowly inside
// [fc - fw, fc + fw] and whose amplitude is modulated by +-30 %. Closed form in t, so
// the displacement at a row depends only on its time (rate-independent).
struct Oscillator {
  Vec3 dir = Vec3::UnitX();
  double amplitude = 0.0;
  double fc = 0.0, fw = 0.0;           // centre frequency and wander half-width, Hz
  double wander_w = 1.0, wander_phi = 0.0;  // rad/s, rad
  double am_w = 1.0, am_phi = 0.0;
  double phase0 = 0.0;

  Vec3 at(double t) const {
    // phase = 2 pi * integral of fc + fw sin(w s + phi) ds from 0 to t.
    const double phase = phase0 + kTwoPi * (fc * t + fw / wander_w * (std::cos(wander_phi) - std::cos(wander_w * t + wander_phi)));
    const double amp = amplitude * (1.0 + 0.3 * std::sin(am_w * t + am_phi));
    return amp * std::sin(phase) * dir;
  }
};

Oscillator make_oscillator(Rng& rng, double fmin, double fmax, double amplitude) {
  Oscillator o;
  const double mid = 0.5 * (fmin + fmax), half = 0.5 * (fmax - fmin);
  o.dir = rng.unit_vector();
  o.amplitude = amplitude;
  o.fc = mid + rng.uniform(-0.5, 0.5) * half;
  o.fw = 0.5 * (half - std::abs(o.fc - mid));  // fc +- fw stays inside [fmin, fmax]
  o.wander_w = kTwoPi / rng.uniform(4.0, 10.0);
  o.wander_phi = rng.uniform(0.0, kTwoPi);
  o.am_w = kTwoPi / rng.uniform(3.0, 8.0);
  o.am_phi = rng.uniform(0.0, kTwoPi);
  o.phase0 = rng.uniform(0.0, kTwoPi);
  return o;
}

// Finger chains from the joint the finger pivots about (weight 0) to the tip (weight 1).
struct FingerChain {
  std::array<int, 4> joints;
};
constexpr std::array<FingerChain, 5> kFingers = {{
    {{idx(Joint::ThumbMetacarpal), idx(Joint::ThumbProximal), idx(Joint::ThumbDistal), idx(Joint::ThumbTip)}},
    {{idx(Joint::IndexProximal), idx(Joint::IndexIntermediate), idx(Joint::IndexDistal), idx(Joint::IndexTip)}},
    {{idx(Joint::MiddleProximal), idx(Joint::MiddleIntermediate), idx(Joint::MiddleDistal), idx(Joint::MiddleTip)}},
    {{idx(Joint::RingProximal), idx(Joint::RingIntermediate), idx(Joint::RingDistal), idx(Joint::RingTip)}},
    {{idx(Joint::LittleProximal), idx(Joint::LittleIntermediate), idx(Joint::LittleDistal), idx(Joint::LittleTip)}},
}};

HandSeries corrupt_tremor(const HandSeries& clean, const TremorCorruption& c, uint64_t seed) {
  HandSeries out = clean;
  Rng rng(sub_seed(seed, 0));
  const Oscillator hand = make_oscillator(rng, c.freq_min_hz, c.freq_max_hz, c.hand_amplitude_m);
  std::array<Oscillator, 5> fingers;
  for (auto& f : fingers) f = make_oscillator(rng, c.freq_min_hz, c.freq_max_hz, c.finger_amplitude_m);
  for (size_t i = 0; i < clean.size(); ++i) {
    const double t = clean.t[i];
    Pose d = Pose::Zero();
    const Vec3 h = hand.at(t);
    for (int j = 0; j < kJointCount; ++j) set_joint(d, j, h);
    for (size_t f = 0; f < fingers.size(); ++f) {
      const Vec3 v = fingers[f].at(t);
      for (size_t k = 1; k < 4; ++k) {
        const int j = kFingers[f].joints[k];
        set_joint(d, j, joint(d, j) + (static_cast<double>(k) / 3.0) * v);
      }
    }
    out.pos[i] += d;  // NaN rows stay NaN
  }
  return out;
}

void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("corruption parameter out of range: ") + what);
}

}  // namespace

CorruptionConfig corruption_preset(std::string_view name) {
  CorruptionConfig c;
  if (name == "paper") {
    c.kind = CorruptionKind::Paper;  // published sigma_o = sigma_s = 0.1, beta = 50 mm
  } else if (name == "tracker") {
    // Measured on the HoloLens 2 recordings by tools/measure_hl2_noise.py
    // (docs/CORRUPTION.md has the numbers and the method).
    c.kind = CorruptionKind::Tracker;
    c.tracker.jitter_sd_m = 0.0005;
    c.tracker.jitter_ar1 = 0.0;
    c.tracker.joint_drop_prob = 0.0;
    c.tracker.hand_drop_rate_hz = 0.014;
    c.tracker.hand_drop_mean_s = 1.45;
    c.tracker.jump_prob = 0.004;
    c.tracker.jump_sd_m = 0.009;
    c.tracker.quantize_m = 0.001;
  } else if (name == "tremor") {
    c.kind = CorruptionKind::Tremor;
    c.tremor = {4.0, 6.0, 0.004, 0.002};
  } else if (name == "tremor-physiological") {
    c.kind = CorruptionKind::Tremor;
    c.tremor = {8.0, 12.0, 0.0005, 0.0005};
  } else if (name == "hand-jitter") {
    // The common-mode part of the HoloLens 2 recordings' still-hand jitter: the median
    // over joints of the residual x_t - (x_{t-1} + x_{t+1}) / 2, as robust SD, is 0.3-0.6
    // mm per coordinate (the joints' own part 0.6 mm; docs/CORRUPTION.md "Whole-hand jitter").
    c.kind = CorruptionKind::Tracker;
    c.tracker.hand_jitter_sd_m = 0.0005;
  } else {
    throw std::invalid_argument("unknown corruption preset '" + std::string(name) +
                                "' (expected paper, tracker, tremor, tremor-physiological, hand-jitter)");
  }
  return c;
}

void validate_corruption(const CorruptionConfig& config) {
  const auto finite_nonneg = [](double v) { return std::isfinite(v) && v >= 0.0; };
  const auto prob = [](double v) { return std::isfinite(v) && v >= 0.0 && v <= 1.0; };
  switch (config.kind) {
    case CorruptionKind::Paper: {
      const PaperCorruption& p = config.paper;
      require(finite_nonneg(p.sigma_s), "sigma_s must be >= 0");
      require(finite_nonneg(p.sigma_o), "sigma_o must be >= 0");
      require(finite_nonneg(p.beta_m), "beta must be >= 0");
      require(finite_nonneg(p.reference_hand_m), "reference hand size must be >= 0");
      break;
    }
    case CorruptionKind::Tracker: {
      const TrackerCorruption& t = config.tracker;
      require(finite_nonneg(t.jitter_sd_m), "jitter SD must be >= 0");
      require(finite_nonneg(t.hand_jitter_sd_m), "whole-hand jitter SD must be >= 0");
      require(std::isfinite(t.jitter_ar1) && t.jitter_ar1 >= 0.0 && t.jitter_ar1 < 1.0, "jitter AR(1) must be in [0, 1)");
      require(prob(t.joint_drop_prob), "joint drop probability must be in [0, 1]");
      require(finite_nonneg(t.hand_drop_rate_hz), "hand dropout rate must be >= 0");
      require(finite_nonneg(t.hand_drop_mean_s), "hand dropout duration must be >= 0");
      require(prob(t.jump_prob), "jump probability must be in [0, 1]");
      require(finite_nonneg(t.jump_sd_m), "jump SD must be >= 0");
      require(finite_nonneg(t.quantize_m), "quantisation step must be >= 0");
      require(prob(t.outlier_prob), "outlier probability must be in [0, 1]");
      require(finite_nonneg(t.outlier_min_m) && t.outlier_max_m >= t.outlier_min_m && std::isfinite(t.outlier_max_m),
              "outlier sizes must be 0 <= min <= max");
      require(t.outlier_max_rows >= 1 && t.outlier_max_rows <= 1000, "outlier rows must be 1..1000");
      break;
    }
    case CorruptionKind::Tremor: {
      const TremorCorruption& t = config.tremor;
      require(finite_nonneg(t.freq_min_hz) && std::isfinite(t.freq_max_hz) && t.freq_min_hz <= t.freq_max_hz,
              "tremor band must satisfy 0 <= freq_min <= freq_max");
      require(finite_nonneg(t.hand_amplitude_m), "hand tremor amplitude must be >= 0");
      require(finite_nonneg(t.finger_amplitude_m), "finger tremor amplitude must be >= 0");
      break;
    }
  }
}

Pose paper_optimize(const Pose& clean, const Pose& shifted) {
  const Skeleton& sk = xr_hand_skeleton();
  const TreeOrder& tree = xr_tree_order();
  Pose out = shifted;
  Pose correction = Pose::Zero();  // displacement Optimize applied to each joint
  for (int j : tree.order) {
    if (tree.depth[static_cast<size_t>(j)] < 2) continue;  // root and its children stay
    const int p = sk.parent[static_cast<size_t>(j)];
    if (!joint_tracked(clean, j) || !joint_tracked(clean, p) || !joint_tracked(shifted, j) ||
        !joint_tracked(out, p))
      continue;
    const Vec3 parent = joint(out, p);
    const double length = (joint(clean, j) - joint(clean, p)).norm();
    Vec3 dir = joint(shifted, j) + correction.row(p).transpose() - parent;
    if (dir.norm() < 1e-12) dir = joint(clean, j) - joint(clean, p);  // degenerate: clean direction
    const double n = dir.norm();
    const Vec3 placed = n > 0.0 ? Vec3(parent + (length / n) * dir) : parent;
    set_joint(out, j, placed);
    correction.row(j) = (placed - joint(shifted, j)).transpose();
  }
  return out;
}

HandSeries corrupt_series(const HandSeries& clean, const CorruptionConfig& config, uint64_t seed) {
  validate_corruption(config);
  if (clean.t.size() != clean.pos.size()) throw std::invalid_argument("corrupt_series: t and pos differ in length");
  switch (config.kind) {
    case CorruptionKind::Paper: return corrupt_paper(clean, config.paper, seed);
    case CorruptionKind::Tracker: return corrupt_tracker(clean, config.tracker, seed);
    case CorruptionKind::Tremor: return corrupt_tremor(clean, config.tremor, seed);
  }
  throw std::invalid_argument("corrupt_series: unknown corruption kind");
}

Track corrupt_track(const Track& clean, const CorruptionConfig& config, uint64_t seed) {
  Track out;
  out.header_lines = clean.header_lines;
  for (Hand h : {Hand::Left, Hand::Right}) {
    const HandSeries s = hand_series(clean, h);
    if (s.empty()) continue;
    add_hand_series(out, h, corrupt_series(s, config, sub_seed(seed, 100 + static_cast<uint64_t>(h))));
  }
  return out;
}

}  // namespace hs
