#include "train_data.hpp"

#include "handsteady/corrupt.hpp"
#include "handsteady/error.hpp"
#include "handsteady/hand_shape.hpp"
#include "handsteady/import.hpp"
#include "handsteady/stgae_features.hpp"
#include "handsteady/track_ops.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace hs::train {

namespace {

double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * std::generate_canonical<double, 53>(rng);
}

// A uniformly distributed rotation: a normalised 4D Gaussian is a uniform unit quaternion.
Eigen::Matrix3d random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  if (q.norm() < 1e-9) return Eigen::Matrix3d::Identity();
  q.normalize();
  return q.toRotationMatrix();
}

bool fully_tracked(const Pose& p) {
  for (int j = 0; j < kJointCount; ++j)
    if (!joint_tracked(p, j)) return false;
  return true;
}

double log_uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::exp(uniform(rng, std::log(lo), std::log(hi)));
}

// Draws nothing when p <= 0, so a config without the option keeps its random sequence.
bool chance(std::mt19937_64& rng, double p) { return p > 0.0 && std::generate_canonical<double, 53>(rng) < p; }

uint64_t mix_seed(uint64_t a, uint64_t b) {
  uint64_t z = a + 0x9E3779B97F4A7C15ULL * (b + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Frames at rate_hz corrupted by each step in turn, step k seeded by mix_seed(seed, k).
std::vector<Pose> corrupt_steps(const std::vector<Pose>& clean, double rate_hz, const std::vector<CorruptionConfig>& steps,
                                uint64_t seed) {
  HandSeries s;
  s.pos = clean;
  s.t.resize(clean.size());
  for (size_t i = 0; i < clean.size(); ++i) s.t[i] = static_cast<double>(i) / rate_hz;
  uint64_t k = 0;
  for (const auto& c : steps) s = corrupt_series(s, c, mix_seed(seed, k++));
  return s.pos;
}

}  // namespace

std::vector<std::string> parse_preset_chain(const std::string& text) {
  std::vector<std::string> out;
  if (text.empty() || text == "clean") return out;
  if (text == "random") return {"random"};
  size_t begin = 0;
  while (begin <= text.size()) {
    const size_t end = std::min(text.find('+', begin), text.size());
    std::string name = text.substr(begin, end - begin);
    if (name == "random") throw std::invalid_argument("\"random\" cannot be chained with presets");
    (void)corruption_preset(name);  // throws std::invalid_argument for an unknown name
    out.push_back(std::move(name));
    begin = end + 1;
  }
  return out;
}

size_t ClipSet::frames() const {
  size_t n = 0;
  for (const auto& c : clips) n += c.size();
  return n;
}

void ClipSet::append(ClipSet&& other, double weight) {
  const int g = static_cast<int>(group_weight.size());
  for (auto& c : other.clips) {
    clips.push_back(std::move(c));
    group.push_back(g);
  }
  group_weight.push_back(weight);
}

ClipSet make_clips(const std::vector<HandSeries>& series, double rate_hz, const std::vector<double>& speed_factors,
                   int min_frames, double split_speed_mps) {
  ClipSet out;
  for (const double speed : speed_factors) {
    if (!(speed > 0.0)) throw std::invalid_argument("speed factors must be positive");
    for (const auto& s : series) {
      if (s.size() < 2) continue;
      // Played back `speed` times faster: the same poses at times t / speed.
      HandSeries scaled = s;
      for (auto& t : scaled.t) t /= speed;
      const HandSeries r = resample_series(scaled, rate_hz);
      std::vector<Pose> piece;
      auto flush = [&] {
        if (static_cast<int>(piece.size()) >= min_frames) {
          out.clips.push_back(std::move(piece));
          out.group.push_back(0);
        }
        piece.clear();
      };
      const double max_step = split_speed_mps > 0.0 ? split_speed_mps / rate_hz : std::numeric_limits<double>::infinity();
      for (const auto& p : r.pos) {
        if (!fully_tracked(p)) {
          flush();
          continue;
        }
        if (!piece.empty() && (p - piece.back()).rowwise().norm().maxCoeff() > max_step) flush();
        piece.push_back(p);
      }
      flush();
    }
  }
  return out;
}

std::vector<std::filesystem::path> source_files(const DataSource& source) {
  namespace fs = std::filesystem;
  const auto keep = [&](const std::string& name) {
    bool in = source.include.empty();
    for (const auto& s : source.include) in = in || name.find(s) != std::string::npos;
    for (const auto& s : source.exclude) in = in && name.find(s) == std::string::npos;
    return in;
  };
  std::vector<fs::path> files;
  if (fs::is_regular_file(source.path)) {
    files.push_back(source.path);
  } else if (fs::is_directory(source.path)) {
    for (const auto& e : fs::directory_iterator(source.path)) {
      const auto ext = e.path().extension();
      if (e.is_regular_file() && (ext == ".csv" || ext == ".bvh") && keep(e.path().filename().string()))
        files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
  } else {
    throw InputError({source.path.string(), 0, ""}, "training data not found (a track CSV, a BVH file or a folder)");
  }
  if (files.empty()) throw InputError({source.path.string(), 0, ""}, "no .csv or .bvh file selected here");
  return files;
}

std::vector<HandSeries> load_source(const DataSource& source) {
  if (source.fpha) return load_fpha_subjects(source.path, source.subjects);
  std::vector<HandSeries> out;
  for (const auto& f : source_files(source)) {
    const Track t = f.extension() == ".bvh" ? import_bvh(f) : read_track_csv(f);
    for (const Hand h : {Hand::Left, Hand::Right}) {
      HandSeries s = hand_series(t, h);
      if (!s.empty()) out.push_back(std::move(s));
    }
  }
  return out;
}

std::vector<HandSeries> load_fpha_subjects(const std::filesystem::path& root, const std::vector<int>& subjects) {
  std::vector<HandSeries> out;
  for (const int s : subjects) {
    const auto dir = root / ("Subject_" + std::to_string(s));
    if (!std::filesystem::is_directory(dir))
      throw InputError({dir.string(), 0, ""}, "FPHA subject directory not found (set data.root in the config)");
    for (const auto& take : import_fpha_takes(dir)) {
      HandSeries h = hand_series(take, Hand::Right);
      if (!h.empty()) out.push_back(std::move(h));
    }
  }
  return out;
}

bool input_features(const std::vector<Pose>& raw, double shape_scale_m, double velocity_scale_m, double* features,
                    double* filled) {
  constexpr int N = kJointCount;
  const StgaeAnchors anchors = stgae_anchors(xr_hand_skeleton());
  StgaeHoleFiller<double> filler(N, anchors);
  Pose x, prev;
  using Features = Eigen::Matrix<double, N, 6, Eigen::RowMajor>;
  for (size_t t = 0; t < raw.size(); ++t) {
    if (!filler.fill(raw[t].data(), x)) return false;
    Eigen::Map<Features> f(features + t * N * 6);
    stgae_frame_features(x, t > 0 ? &prev : nullptr, anchors.wrist, 1.0 / shape_scale_m, 1.0 / velocity_scale_m, f);
    Eigen::Map<Pose>(filled + t * N * 3) = x;
    prev = x;
  }
  return true;
}

std::vector<Pose> corrupt_chain(const std::vector<Pose>& clean, double rate_hz, const std::vector<std::string>& presets,
                                uint64_t seed) {
  if (presets.empty()) return clean;
  if (presets.size() == 1 && presets.front() == "random") {
    std::mt19937_64 rng(seed);
    const RandomCorruption rc = random_corruption(rng, rate_hz);
    return apply_random_corruption(clean, rate_hz, rc, rng());
  }
  std::vector<CorruptionConfig> steps;
  for (const auto& name : presets) steps.push_back(corruption_preset(name));
  return corrupt_steps(clean, rate_hz, steps, seed);
}

RandomCorruption random_corruption(std::mt19937_64& rng, double rate_hz) {
  RandomCorruption rc;
  if (chance(rng, 0.3)) {
    CorruptionConfig c;
    c.kind = CorruptionKind::Tremor;
    const double f = uniform(rng, 3.5, 12.0);
    c.tremor.freq_min_hz = f - 1.0;
    c.tremor.freq_max_hz = f + 1.0;
    c.tremor.hand_amplitude_m = log_uniform(rng, 0.3e-3, 6e-3);
    c.tremor.finger_amplitude_m = uniform(rng, 0.2, 1.0) * c.tremor.hand_amplitude_m;
    rc.steps.push_back(c);
  }
  CorruptionConfig c;
  c.kind = CorruptionKind::Tracker;
  TrackerCorruption& t = c.tracker;
  if (chance(rng, 0.85)) {
    t.jitter_sd_m = log_uniform(rng, 0.2e-3, 6e-3);
    if (chance(rng, 0.5)) t.jitter_ar1 = std::exp(-1.0 / (rate_hz * uniform(rng, 0.02, 0.2)));
  }
  if (chance(rng, 0.2)) t.outlier_prob = log_uniform(rng, 0.002, 0.03);
  if (chance(rng, 0.25)) {
    t.joint_drop_prob = uniform(rng, 0.0, 0.25);
    t.hand_drop_rate_hz = uniform(rng, 0.0, 1.0);
    t.hand_drop_mean_s = 0.3;
  }
  if (chance(rng, 0.1)) t.quantize_m = uniform(rng, 0.5e-3, 4e-3);
  rc.steps.push_back(c);
  for (double& s : rc.joint_scale) s = uniform(rng, 0.5, 1.5);
  return rc;
}

std::vector<Pose> apply_random_corruption(const std::vector<Pose>& clean, double rate_hz, const RandomCorruption& rc,
                                          uint64_t seed) {
  std::vector<Pose> out = corrupt_steps(clean, rate_hz, rc.steps, seed);
  for (size_t i = 0; i < clean.size(); ++i)
    for (int j = 0; j < kJointCount; ++j)
      if (out[i].row(j).allFinite())  // a dropped joint stays dropped
        out[i].row(j) = clean[i].row(j) + rc.joint_scale[static_cast<size_t>(j)] * (out[i].row(j) - clean[i].row(j));
  return out;
}

WindowSampler::WindowSampler(const ClipSet& clips, int window, int horizon, double rate_hz, AugmentConfig augment,
                             std::vector<CorruptionMixEntry> mix)
    : clips_(&clips), T_(window), DT_(horizon), rate_hz_(rate_hz), augment_(std::move(augment)), mix_(std::move(mix)) {
  if (T_ < 1 || DT_ < 0) throw std::invalid_argument("window sampler: bad window/horizon");
  if (mix_.empty()) mix_.push_back({});
  double total = 0.0;
  for (const auto& m : mix_) {
    if (!(m.weight >= 0.0)) throw std::invalid_argument("corruption mix weights must be >= 0");
    total += m.weight;
    mix_cdf_.push_back(total);
  }
  if (!(total > 0.0)) throw std::invalid_argument("corruption mix weights sum to zero");
  const int len = T_ + DT_;
  const size_t groups = std::max<size_t>(1, clips.group_weight.size());
  starts_.resize(groups);
  for (size_t c = 0; c < clips.clips.size(); ++c) {
    const int n = static_cast<int>(clips.clips[c].size());
    const size_t g = c < clips.group.size() ? static_cast<size_t>(clips.group[c]) : 0;
    for (int s = 0; s + len <= n; ++s) starts_.at(g).emplace_back(static_cast<uint32_t>(c), static_cast<uint32_t>(s));
  }
  double weights = 0.0;
  for (size_t g = 0; g < groups; ++g) {
    // A source too short for one window draws nothing.
    if (!starts_[g].empty()) weights += g < clips.group_weight.size() ? clips.group_weight[g] : 1.0;
    group_cdf_.push_back(weights);
  }
  if (!(weights > 0.0)) throw std::invalid_argument("no clip is long enough for one window of T + DT frames");
}

size_t WindowSampler::window_count() const {
  size_t n = 0;
  for (const auto& s : starts_) n += s.size();
  return n;
}

Window WindowSampler::draw(std::mt19937_64& rng) const {
  size_t g = 0;
  if (starts_.size() > 1) {  // one source draws no number, as before sources existed
    const double ug = std::generate_canonical<double, 53>(rng) * group_cdf_.back();
    g = static_cast<size_t>(std::upper_bound(group_cdf_.begin(), group_cdf_.end(), ug) - group_cdf_.begin());
    g = std::min(g, starts_.size() - 1);
    while (starts_[g].empty()) g = (g + 1) % starts_.size();  // ug at the edge of an empty group
  }
  const auto& starts = starts_[g];
  const auto [c, s] = starts[std::uniform_int_distribution<size_t>(0, starts.size() - 1)(rng)];
  const auto& clip = clips_->clips[c];
  const size_t len = static_cast<size_t>(T_ + DT_);
  Window w;
  w.group = static_cast<int>(g);
  w.truth.assign(clip.begin() + s, clip.begin() + s + static_cast<long>(len));
  if (chance(rng, augment_.still_prob)) {
    const size_t held = std::uniform_int_distribution<size_t>(0, len - 1)(rng);
    const Pose p = w.truth[held];
    for (auto& q : w.truth) q = p;
  }
  if (chance(rng, augment_.shape_prob)) {
    apply_shape(w.truth, {"", ShapeKind::BoneJitter, uniform(rng, 0.0, 0.2)}, rng());
    if (chance(rng, 1.0 / 3)) apply_shape(w.truth, {"", ShapeKind::WristProximal, uniform(rng, 0.0, 0.03)}, 0);
    if (chance(rng, 1.0 / 3)) apply_shape(w.truth, {"", ShapeKind::PalmCentroid, 0.0}, 0);
    if (chance(rng, 1.0 / 3)) apply_shape(w.truth, {"", ShapeKind::ThumbBase, uniform(rng, 0.0, 0.4)}, 0);
  }

  // Augmentation: one rigid-plus-scale transform for the whole window.
  const double scale = uniform(rng, augment_.scale_min, augment_.scale_max);
  const bool mirror = std::generate_canonical<double, 53>(rng) < augment_.mirror_prob;
  const Eigen::Matrix3d R = augment_.rotate ? random_rotation(rng) : Eigen::Matrix3d::Identity();
  Eigen::RowVector3d shift;
  for (int k = 0; k < 3; ++k) shift[k] = uniform(rng, -augment_.translate_m, augment_.translate_m);
  const Eigen::RowVector3d origin = w.truth.front().row(idx(Joint::Wrist));
  for (auto& p : w.truth) {
    for (int j = 0; j < kJointCount; ++j) {
      Eigen::RowVector3d v = scale * (p.row(j) - origin);
      if (mirror) v[0] = -v[0];
      p.row(j) = v * R.transpose() + origin + shift;
    }
  }

  const double u = std::generate_canonical<double, 53>(rng) * mix_cdf_.back();
  const size_t m = static_cast<size_t>(std::lower_bound(mix_cdf_.begin(), mix_cdf_.end(), u) - mix_cdf_.begin());
  const auto& chain = mix_[std::min(m, mix_.size() - 1)].presets;
  // Corrupt all T + DT frames (a stateful tracker noise sees a realistic sequence), keep T.
  w.input = corrupt_chain(w.truth, rate_hz_, chain, rng());
  if (chance(rng, augment_.upsample_prob)) {
    const double tracker_hz = std::min(uniform(rng, augment_.upsample_min_hz, augment_.upsample_max_hz), rate_hz_);
    w.input = upsampled_from(w.input, rate_hz_, tracker_hz, uniform(rng, 0.0, rate_hz_ / tracker_hz));
  }
  w.input.resize(static_cast<size_t>(T_));
  return w;
}

std::vector<Pose> upsampled_from(const std::vector<Pose>& frames, double rate_hz, double tracker_hz, double phase) {
  const double step = rate_hz / tracker_hz;  // model frames per tracker sample
  const long n = static_cast<long>(frames.size());
  std::vector<Pose> out(frames.size());
  if (n == 0) return out;
  const auto sample = [&](double tau) -> const Pose& {
    return frames[static_cast<size_t>(std::clamp(std::lround(tau), 0L, n - 1))];
  };
  for (long f = 0; f < n; ++f) {
    // The samples either side of frame f: tau_k = phase + k * step <= f < tau_{k+1}.
    const double k = std::floor((static_cast<double>(f) - phase) / step);
    const double t0 = phase + k * step, t1 = t0 + step;
    const double w = std::clamp((static_cast<double>(f) - t0) / step, 0.0, 1.0);
    const Pose& a = sample(t0);
    const Pose& b = sample(t1);
    Pose& o = out[static_cast<size_t>(f)];
    for (int j = 0; j < kJointCount; ++j) {
      const bool ha = a.row(j).allFinite(), hb = b.row(j).allFinite();
      if (ha && hb) o.row(j) = (1.0 - w) * a.row(j) + w * b.row(j);
      else o.row(j) = ha ? a.row(j) : b.row(j);
    }
  }
  return out;
}

std::vector<Window> fixed_windows(const ClipSet& clips, int window, int horizon, int stride, double rate_hz,
                                  const std::vector<std::string>& presets, uint64_t seed) {
  if (stride < 1) throw std::invalid_argument("validation stride must be >= 1");
  std::vector<Window> out;
  const int len = window + horizon;
  for (const auto& clip : clips.clips) {
    const int n = static_cast<int>(clip.size());
    for (int s = 0; s + len <= n; s += stride) {
      Window w;
      w.truth.assign(clip.begin() + s, clip.begin() + s + len);
      w.input = corrupt_chain(w.truth, rate_hz, presets, mix_seed(seed, out.size()));
      w.input.resize(static_cast<size_t>(window));
      out.push_back(std::move(w));
    }
  }
  return out;
}

}  // namespace hs::train
