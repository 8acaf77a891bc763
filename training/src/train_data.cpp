#include "train_data.hpp"

#include "handsteady/corrupt.hpp"
#include "handsteady/error.hpp"
#include "handsteady/import.hpp"
#include "handsteady/track_ops.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
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

uint64_t mix_seed(uint64_t a, uint64_t b) {
  uint64_t z = a + 0x9E3779B97F4A7C15ULL * (b + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace

std::vector<std::string> parse_preset_chain(const std::string& text) {
  std::vector<std::string> out;
  if (text.empty() || text == "clean") return out;
  size_t begin = 0;
  while (begin <= text.size()) {
    const size_t end = std::min(text.find('+', begin), text.size());
    std::string name = text.substr(begin, end - begin);
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

ClipSet make_clips(const std::vector<HandSeries>& series, double rate_hz, const std::vector<double>& speed_factors,
                   int min_frames) {
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
        if (static_cast<int>(piece.size()) >= min_frames) out.clips.push_back(std::move(piece));
        piece.clear();
      };
      for (const auto& p : r.pos) {
        if (fully_tracked(p)) {
          piece.push_back(p);
        } else {
          flush();
        }
      }
      flush();
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
  const int wrist = idx(Joint::Wrist), palm = idx(Joint::Palm);
  Pose last = Pose::Zero(), prev = Pose::Zero();
  std::array<bool, N> seen{};
  for (size_t t = 0; t < raw.size(); ++t) {
    const Pose& p = raw[t];
    Pose x = Pose::Zero();
    int n_seen = 0;
    Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
    for (int j = 0; j < N; ++j) {
      if (p.row(j).allFinite()) {  // as the engine: a joint is valid when x, y, z are finite
        last.row(j) = p.row(j);
        seen[static_cast<size_t>(j)] = true;
      }
      if (seen[static_cast<size_t>(j)]) {
        x.row(j) = last.row(j);
        sum += x.row(j);
        ++n_seen;
      }
    }
    if (n_seen == 0) return false;
    if (n_seen < N) {
      const Eigen::RowVector3d fill = seen[static_cast<size_t>(wrist)] ? Eigen::RowVector3d(x.row(wrist))
                                      : seen[static_cast<size_t>(palm)] ? Eigen::RowVector3d(x.row(palm))
                                                                        : Eigen::RowVector3d(sum / n_seen);
      for (int j = 0; j < N; ++j)
        if (!seen[static_cast<size_t>(j)]) x.row(j) = fill;
    }
    const Eigen::RowVector3d w = x.row(wrist);
    for (int j = 0; j < N; ++j) {
      double* f = features + (t * N + static_cast<size_t>(j)) * 6;
      double* o = filled + (t * N + static_cast<size_t>(j)) * 3;
      for (int c = 0; c < 3; ++c) {
        f[c] = (x(j, c) - w[c]) / shape_scale_m;
        f[3 + c] = t == 0 ? 0.0 : (x(j, c) - prev(j, c)) / velocity_scale_m;
        o[c] = x(j, c);
      }
    }
    prev = x;
  }
  return true;
}

std::vector<Pose> corrupt_chain(const std::vector<Pose>& clean, double rate_hz, const std::vector<std::string>& presets,
                                uint64_t seed) {
  if (presets.empty()) return clean;
  HandSeries s;
  s.pos = clean;
  s.t.resize(clean.size());
  for (size_t i = 0; i < clean.size(); ++i) s.t[i] = static_cast<double>(i) / rate_hz;
  uint64_t k = 0;
  for (const auto& name : presets) s = corrupt_series(s, corruption_preset(name), mix_seed(seed, k++));
  return s.pos;
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
  for (size_t c = 0; c < clips.clips.size(); ++c) {
    const int n = static_cast<int>(clips.clips[c].size());
    for (int s = 0; s + len <= n; ++s) starts_.emplace_back(static_cast<uint32_t>(c), static_cast<uint32_t>(s));
  }
  if (starts_.empty()) throw std::invalid_argument("no clip is long enough for one window of T + DT frames");
}

Window WindowSampler::draw(std::mt19937_64& rng) const {
  const auto [c, s] = starts_[std::uniform_int_distribution<size_t>(0, starts_.size() - 1)(rng)];
  const auto& clip = clips_->clips[c];
  const size_t len = static_cast<size_t>(T_ + DT_);
  Window w;
  w.truth.assign(clip.begin() + s, clip.begin() + s + static_cast<long>(len));

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
  w.input.resize(static_cast<size_t>(T_));
  return w;
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
