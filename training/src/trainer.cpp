// Multi-STGAE training loop: batches, losses, the two-step schedule, validation metrics,
// model selection, checkpoints and .hsm export (the config is train_config.cpp's).
#include "trainer.hpp"

#include "stgae_torch.hpp"

#include "handsteady/corrupt.hpp"
#include "handsteady/error.hpp"
#include "handsteady/hsm_format.hpp"
#include "handsteady/metrics.hpp"
#include "handsteady/skeleton.hpp"
#include "handsteady/source_revision.hpp"
#include "handsteady/synth.hpp"

#include <ATen/Version.h>
#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

namespace hs::train {

namespace {

// The model's meta keeps the config in the order its file gave it.
using json = nlohmann::ordered_json;

// The CPU kernels that fix the order of the training's floating-point sums: libtorch's
// vector capability (ATEN_CPU_CAPABILITY chooses another) and the BLAS, for OpenBLAS its
// core (OPENBLAS_CORETYPE). At one revision, config and thread count they decide the
// weights' bits; a host that picks other ones trains other bits (docs/TRAINING.md
// "Reproducibility").
json cpu_kernels_json() {
  std::string capability = "unknown";
  const std::string config = at::show_config();
  const std::string key = "CPU capability usage: ";
  if (const auto at = config.find(key); at != std::string::npos) {
    const auto from = at + key.size();
    capability = config.substr(from, config.find('\n', from) - from);
  }
  std::string blas = "not OpenBLAS";
  using CoreName = char* (*)();
  if (const auto core = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename")))
    blas = std::string("OpenBLAS ") + core();
  return {{"aten_cpu_capability", capability}, {"blas", blas}};
}

}  // namespace

// ---- batches ---------------------------------------------------------------------------

namespace {

constexpr int N = kJointCount;
constexpr double kCm2 = 1e4;  // m^2 -> cm^2

// Tensors of a batch, float32. Positions are relative to each window's last filled wrist
// (the model is translation invariant, and float32 keeps full precision near zero).
struct Batch {
  torch::Tensor feat;   // [B, T, N, 6]
  torch::Tensor x;      // [B, T, N, 3] filled input
  torch::Tensor truth;  // [B, T + DT, N, 3]
  torch::Tensor distill;  // [B], 1 for windows taught the teacher's answers (loss.distill)
  torch::Tensor newest;   // [B], 1 for windows loss.newest scores; undefined when it scores all
  std::vector<Eigen::RowVector3d> origin;  // per window, added back for metrics
};

class BatchBuilder {
 public:
  // frames: input frames per window (the model window, or a longer training sequence).
  BatchBuilder(const StgaeConfig& c, int frames, int capacity)
      : c_(c), T_(frames), DT_(c.predict ? c.horizon : 0),
        feat_(static_cast<size_t>(T_) * N * 6), filled_(static_cast<size_t>(T_) * N * 3) {
    reserve(capacity);
  }
  void reserve(int capacity) {
    fbuf_.reserve(static_cast<size_t>(capacity) * feat_.size());
    xbuf_.reserve(static_cast<size_t>(capacity) * filled_.size());
    tbuf_.reserve(static_cast<size_t>(capacity) * (T_ + DT_) * N * 3);
  }
  // false when the window is not valid input (nothing tracked in its first frame).
  bool add(const Window& w, bool distill = false, bool newest = true) {
    if (!input_features(w.input, c_.shape_scale_m, c_.velocity_scale_m, feat_.data(), filled_.data())) return false;
    const size_t last = static_cast<size_t>(T_ - 1) * N * 3 + static_cast<size_t>(idx(Joint::Wrist)) * 3;
    const Eigen::RowVector3d o(filled_[last], filled_[last + 1], filled_[last + 2]);
    origin_.push_back(o);
    dbuf_.push_back(distill ? 1.0f : 0.0f);
    nbuf_.push_back(newest ? 1.0f : 0.0f);
    for (double v : feat_) fbuf_.push_back(static_cast<float>(v));
    for (size_t i = 0; i < filled_.size(); ++i) xbuf_.push_back(static_cast<float>(filled_[i] - o[static_cast<long>(i % 3)]));
    for (int t = 0; t < T_ + DT_; ++t)
      for (int j = 0; j < N; ++j)
        for (int k = 0; k < 3; ++k) tbuf_.push_back(static_cast<float>(w.truth[static_cast<size_t>(t)](j, k) - o[k]));
    return true;
  }
  int size() const { return static_cast<int>(origin_.size()); }
  Batch take() {
    const int64_t B = size();
    Batch b;
    b.feat = torch::from_blob(fbuf_.data(), {B, T_, N, 6}, torch::kFloat32).clone();
    b.x = torch::from_blob(xbuf_.data(), {B, T_, N, 3}, torch::kFloat32).clone();
    b.truth = torch::from_blob(tbuf_.data(), {B, T_ + DT_, N, 3}, torch::kFloat32).clone();
    b.distill = torch::from_blob(dbuf_.data(), {B}, torch::kFloat32).clone();
    if (std::find(nbuf_.begin(), nbuf_.end(), 0.0f) != nbuf_.end()) b.newest = torch::from_blob(nbuf_.data(), {B}, torch::kFloat32).clone();
    b.origin = std::move(origin_);
    origin_.clear();
    dbuf_.clear();
    nbuf_.clear();
    fbuf_.clear();
    xbuf_.clear();
    tbuf_.clear();
    return b;
  }

 private:
  const StgaeConfig& c_;
  int T_, DT_;
  std::vector<double> feat_, filled_;
  std::vector<float> fbuf_, xbuf_, tbuf_, dbuf_, nbuf_;
  std::vector<Eigen::RowVector3d> origin_;
};

// ---- losses ----------------------------------------------------------------------------

torch::Tensor edge_index(const std::vector<Edge>& edges, bool first) {
  std::vector<int64_t> v;
  for (const auto& e : edges) v.push_back(first ? e.first : e.second);
  return torch::tensor(v, torch::kInt64);
}

// Second difference (acceleration per frame^2) along dim.
torch::Tensor second_difference(const torch::Tensor& p, int64_t dim) {
  const int64_t n = p.size(dim);
  return p.narrow(dim, 2, n - 2) - 2 * p.narrow(dim, 1, n - 2) + p.narrow(dim, 0, n - 2);
}

// Mean over everything but the first (window) axis: [B, ...] -> [B].
torch::Tensor per_window_mean(const torch::Tensor& t) { return t.reshape({t.size(0), -1}).mean(1); }

// Per window [B]: 1 / (its input's mean squared joint error + eps^2), normalised to mean 1
// over the batch (loss.relative_eps_mm, loss.newest_relative_eps_mm); no gradient.
torch::Tensor relative_weights(const torch::Tensor& x, const torch::Tensor& truth, double eps_mm) {
  torch::NoGradGuard no_grad;
  const double eps_cm = eps_mm * 0.1;
  const auto w = 1.0 / ((x - truth).pow(2).sum(-1).mean({1, 2}) * kCm2 + eps_cm * eps_cm);
  return w / w.mean();
}

// The loss to minimise, and its distillation terms' value for the epoch log.
struct Losses {
  torch::Tensor total;
  double distill = 0;
};

class LossFn {
 public:
  // The model's config (referenced: it outlives the loss) and the weights of this loss.
  LossFn(const StgaeConfig& model, const LossWeights& weights) : model_(model), w_(weights) {
    const auto& s = xr_hand_skeleton();
    bone_a_ = edge_index(s.bones, true);
    bone_b_ = edge_index(s.bones, false);
    sym_a_ = edge_index(s.symmetry, true);
    sym_b_ = edge_index(s.symmetry, false);
  }
  // teacher: the teacher model's output on the same batch (loss.distill), or null.
  Losses operator()(const TorchOutput& out, const Batch& b, bool with_pred, const TorchOutput* teacher = nullptr) const {
    const int T = static_cast<int>(b.x.size(1));
    const auto X = denoised_positions(model_, b.x, out);
    const auto Xt = b.truth.narrow(1, 0, T);
    Losses l;
    // Relative weighting: each window's denoising terms divided by its input's own squared
    // error (+ eps^2), normalised to mean 1 over the batch, so nearly clean windows count
    // as much as heavily corrupted ones (a model must never be worse than clean input).
    torch::Tensor w;
    if (w_.relative_eps_mm > 0) w = relative_weights(b.x, Xt, w_.relative_eps_mm);
    // err's mean, each window weighted by weights when they are given.
    const auto weighted_mean = [](const torch::Tensor& err, const torch::Tensor& weights) {
      if (!weights.defined()) return err.mean();
      return (per_window_mean(err) * weights).mean();
    };
    const auto wmean = [&](const torch::Tensor& err) { return weighted_mean(err, w); };
    auto pose = wmean((X - Xt).pow(2)) * kCm2;
    auto total = w_.pose * pose;
    if (w_.newest > 0) {
      auto err = (X.narrow(1, T - 1, 1) - Xt.narrow(1, T - 1, 1)).pow(2);
      if (w_.newest_by_speed && T >= 2) {
        // A weight from the truth alone: no gradient flows through it.
        const auto speed = (Xt.narrow(1, T - 1, 1) - Xt.narrow(1, T - 2, 1)).norm(2, -1, true).detach();
        err = err * (speed / (speed.mean() + 1e-12));
      }
      // With its own relative weighting, the term goes to the windows whose input is close
      // to the truth, where lag is most of the error, and not to the noisy ones.
      auto nw = w_.newest_relative_eps_mm > 0 ? relative_weights(b.x, Xt, w_.newest_relative_eps_mm) : w;
      // Windows of sources marked "newest": false count as zero, still divided by all
      // windows (as loss.distill), so the weight is per window drawn.
      if (b.newest.defined()) nw = nw.defined() ? nw * b.newest : b.newest;
      const auto term = weighted_mean(err, nw);
      total = total + w_.newest * (term * kCm2);
    }
    if (w_.bone > 0) {
      auto bone = wmean(edge_error(X, Xt, bone_a_, bone_b_)) * kCm2;
      total = total + w_.bone * bone;
    }
    if (w_.symmetry > 0) {
      auto sym = wmean(edge_error(X, Xt, sym_a_, sym_b_)) * kCm2;
      total = total + w_.symmetry * sym;
    }
    if (w_.smooth > 0 && T >= 3) {
      auto smooth = wmean((second_difference(X, 1) - second_difference(Xt, 1)).pow(2)) * kCm2;
      total = total + w_.smooth * smooth;
    }
    if (with_pred && model_.predict) {
      const int DT = model_.horizon;
      const auto Y = predicted_positions(model_, X, out);
      if (Y.dim() == 5) {
        // Predictions made at each of the last P frames: [B, P, DT, N, 3] against the truth
        // 1..DT frames after each.
        const int P = static_cast<int>(Y.size(1));
        const auto Yt = b.truth.narrow(1, T - P + 1, P + DT - 1).unfold(1, DT, 1).permute({0, 1, 4, 2, 3});
        auto pred = (Y - Yt).pow(2).mean() * kCm2;
        total = total + w_.predict * pred;
        if (w_.predict_smooth > 0) {
          // Along each path: denoised t-1, t, then the DT predictions.
          auto path = [&](const torch::Tensor& den, const torch::Tensor& fut) {
            return torch::cat({den.narrow(1, T - P - 1, P).unsqueeze(2), den.narrow(1, T - P, P).unsqueeze(2), fut}, 2);
          };
          const auto pe = path(X, Y), pt = path(Xt, Yt);
          auto ps = (second_difference(pe, 2) - second_difference(pt, 2)).pow(2).mean();
          if (P >= 3)  // each horizon over time
            ps = ps + (second_difference(Y, 1) - second_difference(Yt, 1)).pow(2).mean();
          ps = ps * kCm2;
          total = total + w_.predict_smooth * ps;
        }
      } else {
        auto pred = (Y - b.truth.narrow(1, T, DT)).pow(2).mean() * kCm2;
        total = total + w_.predict * pred;
      }
    }
    if (teacher && w_.distill > 0) {
      // Per window, the mean squared difference from the teacher's answers; summed over the
      // marked windows and divided by all of them, so the weight is per window drawn.
      const auto Xd = denoised_positions(model_, b.x, *teacher).detach();
      auto per = per_window_mean((X - Xd).pow(2));
      if (with_pred && model_.predict) {
        const auto Y = predicted_positions(model_, X, out);
        const auto Yd = predicted_positions(model_, Xd, *teacher).detach();
        per = per + per_window_mean((Y - Yd).pow(2));
      }
      auto distill = (per * b.distill).mean() * kCm2;
      total = total + w_.distill * distill;
      l.distill += distill.item<double>();
    }
    if (teacher && w_.distill_displacement > 0 && with_pred && model_.predict) {
      // predicted_positions = the denoised frame + shape_scale_m * predicted_offset.
      const auto d = (out.predicted_offset - teacher->predicted_offset.detach()) * model_.shape_scale_m;
      auto displacement = (per_window_mean(d.pow(2)) * b.distill).mean() * kCm2;
      total = total + w_.distill_displacement * displacement;
      l.distill += displacement.item<double>();
    }
    l.total = total;
    return l;
  }

 private:
  static torch::Tensor lengths(const torch::Tensor& p, const torch::Tensor& a, const torch::Tensor& b) {
    // The epsilon keeps the gradient finite for (never expected) zero-length edges.
    return (p.index_select(2, a) - p.index_select(2, b)).pow(2).sum(-1).add(1e-12).sqrt();
  }
  static torch::Tensor edge_error(const torch::Tensor& X, const torch::Tensor& Xt, const torch::Tensor& a,
                                  const torch::Tensor& b) {
    return (lengths(X, a, b) - lengths(Xt, a, b)).pow(2);  // [B, T, edges], m^2
  }
  const StgaeConfig& model_;
  LossWeights w_;
  torch::Tensor bone_a_, bone_b_, sym_a_, sym_b_;
};

// ---- progress --------------------------------------------------------------------------

std::string clock_text(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long s = std::lround(seconds);
  char buf[32];
  if (s >= 3600)
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  else
    std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  return buf;
}

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// One line on stderr, redrawn in place on a terminal (every 10% otherwise).
class ProgressBar {
 public:
  ProgressBar(bool enabled, std::string label, int total, double run_eta_after)
      : enabled_(enabled), tty_(::isatty(2) != 0), label_(std::move(label)), total_(total),
        run_after_(run_eta_after), t0_(Clock::now()) {}
  void update(int done, double loss) {
    if (!enabled_) return;
    const double el = since(t0_);
    const bool last = done == total_;
    if (tty_) {
      if (!last && el - shown_ < 0.25) return;
    } else {
      const int decile = done * 10 / std::max(total_, 1);
      if (!last && decile == decile_) return;
      decile_ = decile;
    }
    shown_ = el;
    const double eta = done > 0 ? el / done * (total_ - done) : std::numeric_limits<double>::quiet_NaN();
    constexpr int kWidth = 24;
    const int fill = total_ ? done * kWidth / total_ : kWidth;
    std::string bar(static_cast<size_t>(fill), '=');
    bar.resize(kWidth, ' ');
    std::fprintf(stderr, "%s%s [%s] %d/%d loss %.4f  %s elapsed, ETA %s (run %s)%s", tty_ ? "\r" : "",
                 label_.c_str(), bar.c_str(), done, total_, loss, clock_text(el).c_str(), clock_text(eta).c_str(),
                 clock_text(eta + run_after_).c_str(), tty_ ? "\x1b[K" : "\n");
    if (tty_ && last) std::fputc('\n', stderr);
    std::fflush(stderr);
  }

 private:
  bool enabled_, tty_;
  std::string label_;
  int total_;
  double run_after_;
  Clock::time_point t0_;
  double shown_ = -1.0;
  int decile_ = -1;
};

// ---- validation ------------------------------------------------------------------------

struct ValSet {
  std::string preset;
  std::vector<Window> windows;  // valid input only
};

Pose to_pose(const float* p, const Eigen::RowVector3d& origin) {
  Pose out;
  for (int j = 0; j < N; ++j)
    for (int k = 0; k < 3; ++k) out(j, k) = static_cast<double>(p[j * 3 + k]) + origin[k];
  return out;
}

PresetMetrics validate(StgaeNetImpl& net, const TrainConfig& c, const ValSet& set, const LossFn& loss, bool with_pred,
                       double& loss_sum, double& loss_count) {
  const int T = c.sequence_length(), DT = c.model.predict ? c.model.horizon : 0;
  PresetMetrics m;
  m.preset = set.preset;
  m.windows = set.windows.size();
  std::vector<Pose> truth_all, in_all, den_all, truth_last, den_last, hold_in, hold_truth;
  std::vector<std::vector<Pose>> pred_est(static_cast<size_t>(DT)), pred_truth(static_cast<size_t>(DT));
  constexpr int kChunk = 256;
  BatchBuilder builder(c.model, T, kChunk);
  torch::NoGradGuard no_grad;
  for (size_t first = 0; first < set.windows.size(); first += kChunk) {
    const size_t end = std::min(set.windows.size(), first + kChunk);
    for (size_t i = first; i < end; ++i) builder.add(set.windows[i]);
    const Batch b = builder.take();
    const auto out = net.forward(b.feat, c.predict_frames);
    const auto l = loss(out, b, with_pred);
    const double n = static_cast<double>(b.origin.size());
    loss_sum += l.total.item<double>() * n;
    loss_count += n;
    const auto X = denoised_positions(c.model, b.x, out).contiguous();
    const auto x = b.x.contiguous();
    const auto tr = b.truth.contiguous();
    torch::Tensor Y;
    if (DT > 0) {
      Y = predicted_positions(c.model, X, out);
      if (Y.dim() == 5) Y = Y.select(1, Y.size(1) - 1);  // the newest frame's prediction
      Y = Y.contiguous();
    }
    const size_t frame = N * 3;
    for (size_t w = 0; w < b.origin.size(); ++w) {
      const auto& o = b.origin[w];
      const float* Xp = X.data_ptr<float>() + w * T * frame;
      const float* xp = x.data_ptr<float>() + w * T * frame;
      const float* tp = tr.data_ptr<float>() + w * (T + DT) * frame;
      for (int t = 0; t < T; ++t) {
        truth_all.push_back(to_pose(tp + t * frame, o));
        in_all.push_back(to_pose(xp + t * frame, o));
        den_all.push_back(to_pose(Xp + t * frame, o));
      }
      truth_last.push_back(truth_all.back());
      den_last.push_back(den_all.back());
      if (DT > 0) {
        const float* yp = Y.data_ptr<float>() + w * DT * frame;
        for (int i = 0; i < DT; ++i) {
          pred_est[static_cast<size_t>(i)].push_back(to_pose(yp + i * frame, o));
          pred_truth[static_cast<size_t>(i)].push_back(to_pose(tp + (T + i) * frame, o));
        }
        hold_in.push_back(in_all.back());
        hold_truth.push_back(pred_truth[static_cast<size_t>(DT - 1)].back());
      }
    }
  }
  if (truth_all.empty()) return m;
  m.input_mpjpe_mm = mpjpe_mm(truth_all, in_all);
  m.denoised_mpjpe_mm = mpjpe_mm(truth_all, den_all);
  m.denoised_last_mpjpe_mm = mpjpe_mm(truth_last, den_last);
  m.input_ebon_mm2 = e_bon_mm2(truth_all, in_all);
  m.denoised_ebon_mm2 = e_bon_mm2(truth_all, den_all);
  for (int i = 0; i < DT; ++i)
    m.predicted_mpjpe_mm.push_back(mpjpe_mm(pred_truth[static_cast<size_t>(i)], pred_est[static_cast<size_t>(i)]));
  if (DT > 0) m.hold_mpjpe_mm = mpjpe_mm(hold_truth, hold_in);
  return m;
}

std::string metrics_text(const PresetMetrics& m) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(2);
  s << m.preset << ": MPJPE " << m.input_mpjpe_mm << " -> " << m.denoised_mpjpe_mm << " mm (newest "
    << m.denoised_last_mpjpe_mm << "), E_bon " << m.input_ebon_mm2 << " -> " << m.denoised_ebon_mm2 << " mm^2";
  if (!m.predicted_mpjpe_mm.empty()) {
    s << ", pred";
    for (double v : m.predicted_mpjpe_mm) s << ' ' << v;
    s << " mm (hold " << m.hold_mpjpe_mm << ")";
  }
  return s.str();
}

json metrics_json(const std::vector<PresetMetrics>& ms) {
  json j = json::object();
  for (const auto& m : ms)
    j[m.preset] = {{"windows", m.windows},
                   {"input_mpjpe_mm", m.input_mpjpe_mm},
                   {"denoised_mpjpe_mm", m.denoised_mpjpe_mm},
                   {"denoised_newest_mpjpe_mm", m.denoised_last_mpjpe_mm},
                   {"input_ebon_mm2", m.input_ebon_mm2},
                   {"denoised_ebon_mm2", m.denoised_ebon_mm2},
                   {"predicted_mpjpe_mm", m.predicted_mpjpe_mm},
                   {"hold_mpjpe_mm", m.hold_mpjpe_mm}};
  return j;
}

// ---- data ------------------------------------------------------------------------------

// Clean clips of every source at the model rate (training: with the speed variants), one
// group per training source.
void load_clips(const TrainConfig& c, int min_frames, ClipSet& train, ClipSet& val) {
  const double rate = c.model.rate_hz;
  if (c.synthetic_takes > 0) {
    SynthMotionParams p;
    p.duration_s = c.synthetic_seconds;
    const int n_val = std::max(1, c.synthetic_takes / 4);
    std::vector<HandSeries> ts, vs;
    for (int i = 0; i < c.synthetic_takes; ++i) ts.push_back(synth_motion(p, Hand::Right, c.seed * 7919 + static_cast<uint64_t>(i)));
    for (int i = 0; i < n_val; ++i) vs.push_back(synth_motion(p, Hand::Right, 1000003 + c.val_seed * 7919 + static_cast<uint64_t>(i)));
    train.append(make_clips(ts, rate, c.augment.speed_factors, min_frames), 1.0);
    val.append(make_clips(vs, rate, {1.0}, min_frames), 1.0);
    return;
  }
  const double split = c.split_speed_mps;
  for (const auto& s : c.train_sources)
    train.append(make_clips(load_source(s), rate, c.augment.speed_factors, min_frames, split), s.weight);
  for (const auto& s : c.val_sources) val.append(make_clips(load_source(s), rate, {1.0}, min_frames, split), 1.0);
}

// Writes to a temporary name and renames, so an interrupted run never leaves a torn file.
template <class Write>
void write_atomically(const std::filesystem::path& path, Write&& write) {
  auto tmp = path;
  tmp += ".tmp";
  write(tmp);
  std::filesystem::rename(tmp, path);
}

void save_model(StgaeNetImpl& net, const TrainConfig& c, const std::filesystem::path& out, const Window& ref_window,
                const json& meta) {
  StgaeConfig mc = c.model;
  mc.meta_json = meta.dump();
  const StgaeWeights w = export_weights(net);
  std::vector<float> input;
  // The model's own window: the first T frames of a (possibly longer) validation sequence.
  for (size_t t = 0; t < static_cast<size_t>(c.model.window); ++t)
    for (int j = 0; j < N; ++j)
      for (int k = 0; k < 3; ++k) input.push_back(static_cast<float>(ref_window.input[t](j, k)));
  // The reference output comes from the Eigen engine, so the loader's check is exact.
  const StgaeReference ref = make_stgae_reference(mc, w, std::move(input));
  save_hsm_verified(out, mc, w, ref);  // the file we ship must load and verify
}

// The weights of a model file (path, named by the config key `key`) into net; its network
// configuration must equal `model`.
void import_same_network(StgaeNetImpl& net, const StgaeConfig& model, const std::string& path, const std::string& key) {
  const auto m = load_hsm(path, true);
  if (!same_network(m->config, model))
    throw InputError(SourceLocation{path, 0, "config"},
                     key + ": the model's network configuration differs from the config's \"model\"");
  import_weights(net, m->weights);
}

}  // namespace

// ---- training --------------------------------------------------------------------------

TrainResult train_stgae(const TrainConfig& cfg, const TrainOptions& opt, std::ostream& log) {
  TrainConfig c = cfg;
  if (opt.epochs) c.epochs = *opt.epochs;
  if (opt.threads) c.threads = *opt.threads;
  if (c.threads > 0) torch::set_num_threads(c.threads);
  if (opt.out.empty()) throw std::invalid_argument("train: no output path");
  const int T = c.model.window, DT = c.model.predict ? c.model.horizon : 0;
  const auto run_t0 = Clock::now();
  torch::manual_seed(c.seed);
  std::mt19937_64 rng(c.seed);

  const int L = c.sequence_length();
  ClipSet train_clips, val_clips;
  load_clips(c, L + DT, train_clips, val_clips);
  const WindowSampler sampler(train_clips, L, DT, c.model.rate_hz, c.augment, c.mix);
  std::vector<ValSet> val;
  for (size_t i = 0; i < c.val_presets.size(); ++i) {
    ValSet v;
    v.preset = c.val_presets[i];
    auto all = fixed_windows(val_clips, L, DT, c.val_stride > 0 ? c.val_stride : L, c.model.rate_hz,
                             parse_preset_chain(c.val_presets[i]), c.val_seed + 1000 * i);
    std::vector<double> f(static_cast<size_t>(L) * N * 6), x(static_cast<size_t>(L) * N * 3);
    for (auto& w : all)
      if (input_features(w.input, c.model.shape_scale_m, c.model.velocity_scale_m, f.data(), x.data()))
        v.windows.push_back(std::move(w));
    if (v.windows.empty()) throw std::runtime_error("train: no validation window for preset " + v.preset);
    val.push_back(std::move(v));
  }
  log << "data: " << train_clips.clips.size() << " training clips (" << train_clips.frames() << " frames at "
      << c.model.rate_hz << " Hz incl. speed variants, " << sampler.window_count() << " windows), validation "
      << val_clips.frames() << " frames, " << val.front().windows.size() << " windows per preset\n";

  auto net = std::make_shared<StgaeNetImpl>(c.model);
  size_t n_params = 0;
  for (const auto& p : net->parameters()) n_params += static_cast<size_t>(p.numel());
  const json cpu_kernels = cpu_kernels_json();  // once: it does not change within a run
  log << "model: " << n_params << " parameters, " << (c.model.padding == StgaePadding::Causal ? "causal" : "centred")
      << ", T " << T << ", DT " << DT << ", training sequences of " << L << " frames, threads " << torch::get_num_threads()
      << ", CPU kernels " << cpu_kernels.dump() << "\n";
  // Frozen parameters (train.freeze) get no gradient, and their modules stay in eval mode
  // below so that their BatchNorm statistics stay as they were.
  const auto frozen = [&](const std::string& name) {
    return std::any_of(c.freeze.begin(), c.freeze.end(), [&](const std::string& f) { return name.starts_with(f); });
  };
  for (const auto& f : c.freeze) {
    size_t hits = 0;
    for (const auto& p : net->named_parameters(true))
      if (p.key().starts_with(f)) ++hits;
    if (hits == 0) throw InputError(SourceLocation{"", 0, "train.freeze"}, "no parameter starts with \"" + f + "\"");
  }
  size_t n_frozen = 0;
  for (auto& p : net->named_parameters(true))
    if (frozen(p.key())) {
      p.value().set_requires_grad(false);
      n_frozen += static_cast<size_t>(p.value().numel());
    }
  if (n_frozen > 0) log << "frozen: " << n_frozen << " of " << n_params << " parameters\n";
  torch::optim::Adam adam(net->parameters(), torch::optim::AdamOptions(learning_rate(c, 0)));
  const LossFn loss(c.model, c.loss);  // validation: the base weights, whatever the stage
  // DGN: the incidence matrices S, T, whose gradients the first stage zeroes.
  std::vector<torch::Tensor> graph_params;
  for (const auto& p : net->named_parameters(true))
    if (p.key().ends_with(".S") || p.key().ends_with(".T")) graph_params.push_back(p.value());

  int start_epoch = 0;
  double best = std::numeric_limits<double>::infinity();
  int best_epoch = -1;
  bool best_joint = false;  // the phase `best` was measured in
  const auto ckpt = std::filesystem::path(opt.out.string() + ".ckpt");
  if (!c.init.empty() && !opt.resume) {
    // Fine-tuning: the same network, its weights (BatchNorm statistics included) from a
    // model file; Adam starts afresh.
    if (c.init_matching) {
      const auto m = load_hsm(c.init, true);
      if (m->config.family != c.model.family || m->config.skeleton != c.model.skeleton)
        throw InputError(SourceLocation{c.init, 0, "config"},
                         "train.init: the model's family or skeleton differs from the config's \"model\"");
      const auto left = import_matching_weights(*net, m->weights);
      log << "initialised from " << c.init << " where names and shapes match; "
          << (left.empty() ? std::string("every tensor") : std::to_string(left.size()) + " tensors")
          << (left.empty() ? " matched\n" : " left as initialised:");
      for (const auto& name : left) log << " " << name;
      if (!left.empty()) log << "\n";
    } else {
      import_same_network(*net, c.model, c.init, "train.init");
      log << "initialised from " << c.init << "\n";
    }
  }
  // Distillation (train.teacher): the teacher runs without gradients on the same batches,
  // its BatchNorm as the student's (train.fixed_norm: the running statistics; else the
  // batch's, or the two would differ before any step and the student learn the difference).
  std::shared_ptr<StgaeNetImpl> teacher;
  if (!c.teacher.empty()) {
    teacher = std::make_shared<StgaeNetImpl>(c.model);
    import_same_network(*teacher, c.model, c.teacher, "train.teacher");
    for (auto& p : teacher->parameters()) p.set_requires_grad(false);
    teacher->train(!c.fixed_norm);
    log << "teacher " << c.teacher << " for the windows of the sources marked \"distill\"\n";
  }
  if (const auto skipped = std::count_if(c.train_sources.begin(), c.train_sources.end(),
                                         [](const DataSource& d) { return !d.newest; }))
    log << "loss.newest leaves out the windows of " << skipped << " source(s) marked \"newest\": false\n";
  if (opt.resume) {
    torch::serialize::InputArchive ar;
    try {
      ar.load_from(opt.resume->string());
    } catch (const c10::Error&) {
      throw InputError(SourceLocation{opt.resume->string(), 0, ""}, "not a training checkpoint");
    }
    c10::IValue model_json, state;
    ar.read("model_config", model_json);
    if (model_json.toStringRef() != to_json(c.model))
      throw InputError(SourceLocation{opt.resume->string(), 0, "model_config"},
                       "checkpoint was trained with another model configuration");
    net->load(ar);
    torch::serialize::InputArchive oa;
    ar.read("optimizer", oa);
    adam.load(oa);
    c10::IValue v;
    ar.read("next_epoch", v);
    start_epoch = static_cast<int>(v.toInt());
    ar.read("best", v);
    best = v.toDouble();
    ar.read("best_epoch", v);
    best_epoch = static_cast<int>(v.toInt());
    ar.read("best_joint", v);
    best_joint = v.toBool();
    ar.read("rng", state);
    std::istringstream(state.toStringRef()) >> rng;
    log << "resumed from " << opt.resume->string() << " at epoch " << start_epoch << "\n";
  }

  TrainResult result;
  result.best_epoch = best_epoch;
  result.best_val_loss = best;
  const int steps = c.windows_per_epoch / c.batch;
  BatchBuilder builder(c.model, L, c.batch);
  double mean_epoch_s = std::numeric_limits<double>::quiet_NaN();
  for (int epoch = start_epoch; epoch < c.epochs; ++epoch) {
    const auto t0 = Clock::now();
    const bool joint = c.model.predict && epoch >= c.denoise_only_epochs;
    const double lr = learning_rate(c, epoch);
    for (auto& g : adam.param_groups()) static_cast<torch::optim::AdamOptions&>(g.options()).lr(lr);
    net->train();
    if (n_frozen > 0)
      for (const auto& m : net->named_modules("", false))
        if (frozen(m.key())) m.value()->eval();
    if (c.fixed_norm)
      for (const auto& m : net->modules(false))
        if (dynamic_cast<ChannelNormImpl*>(m.get())) m->eval();
    ProgressBar bar(opt.progress,
                    "epoch " + std::to_string(epoch + 1) + "/" + std::to_string(c.epochs) + (joint ? " [joint]" : " [denoise]"),
                    steps, std::isfinite(mean_epoch_s) ? mean_epoch_s * (c.epochs - epoch - 1) : std::numeric_limits<double>::quiet_NaN());
    double loss_sum = 0, data_s = 0, distill_sum = 0;
    const LossFn train_loss(c.model, c.loss_at(epoch));
    const bool freeze_graph = epoch < c.freeze_graph_epochs;
    for (int s = 0; s < steps; ++s) {
      const auto td = Clock::now();
      while (builder.size() < c.batch) {
        const Window w = sampler.draw(rng);
        // Groups are the training sources in order (one group for synthetic motion).
        const auto g = static_cast<size_t>(w.group);
        const bool real = g < c.train_sources.size();
        builder.add(w, teacher && real && c.train_sources[g].distill, !real || c.train_sources[g].newest);
      }
      const Batch b = builder.take();
      data_s += since(td);
      adam.zero_grad();
      const auto out = net->forward(b.feat, c.predict_frames);
      std::optional<TorchOutput> tout;
      if (teacher && c.loss_at(epoch).distills()) {
        torch::NoGradGuard no_grad;
        tout = teacher->forward(b.feat, c.predict_frames);
      }
      const auto l = train_loss(out, b, joint, tout ? &*tout : nullptr);
      l.total.backward();
      if (freeze_graph)
        for (auto& p : graph_params)
          if (p.grad().defined()) p.mutable_grad().zero_();
      if (c.grad_clip > 0) torch::nn::utils::clip_grad_norm_(net->parameters(), c.grad_clip);
      adam.step();
      const double lv = l.total.item<double>();
      if (!std::isfinite(lv)) throw std::runtime_error("train: the loss became non-finite at epoch " + std::to_string(epoch + 1));
      loss_sum += lv;
      distill_sum += l.distill;
      bar.update(s + 1, loss_sum / (s + 1));
    }

    const double train_s = since(t0);
    net->eval();
    EpochReport rep;
    rep.epoch = epoch;
    rep.joint_phase = joint;
    rep.lr = lr;
    rep.train_loss = loss_sum / std::max(steps, 1);
    double vsum = 0, vcount = 0;
    for (const auto& v : val) rep.val.push_back(validate(*net, c, v, loss, joint, vsum, vcount));
    rep.val_loss = vsum / std::max(vcount, 1.0);
    const double val_s = since(t0) - train_s;
    // Model selection on validation only, within the current phase (the objective changes).
    if (joint != best_joint) {
      best = std::numeric_limits<double>::infinity();
      best_joint = joint;
    }
    rep.best = rep.val_loss < best;
    rep.seconds = since(t0);
    if (rep.best) {
      best = rep.val_loss;
      best_epoch = epoch;
      json meta = {{"training", json::parse(c.json.empty() ? "{}" : c.json)},
                   {"epoch", epoch + 1},
                   {"phase", joint ? "joint" : "denoise"},
                   {"val_loss", rep.val_loss},
                   {"validation", metrics_json(rep.val)},
                   {"wall_s", since(run_t0)},
                   {"threads", torch::get_num_threads()},
                   // The code matters as much as the config: the same config and seed give the same
                   // weights at one revision, not across revisions (docs/TRAINING.md "Reproducibility").
                   {"source", {{"revision", source_revision()}}},
                   {"cpu_kernels", cpu_kernels}};
      save_model(*net, c, opt.out, val.front().windows.front(), meta);
    }
    {
      torch::serialize::OutputArchive ar;
      net->save(ar);
      torch::serialize::OutputArchive oa;
      adam.save(oa);
      ar.write("optimizer", oa);
      ar.write("model_config", c10::IValue(to_json(c.model)));
      ar.write("next_epoch", c10::IValue(static_cast<int64_t>(epoch + 1)));
      ar.write("best", c10::IValue(best));
      ar.write("best_epoch", c10::IValue(static_cast<int64_t>(best_epoch)));
      ar.write("best_joint", c10::IValue(best_joint));
      std::ostringstream rs;
      rs << rng;
      ar.write("rng", c10::IValue(rs.str()));
      write_atomically(ckpt, [&](const std::filesystem::path& p) { ar.save_to(p.string()); });
    }
    rep.seconds = since(t0);
    mean_epoch_s = std::isfinite(mean_epoch_s) ? 0.5 * (mean_epoch_s + rep.seconds) : rep.seconds;
    {
      std::ostringstream s;
      s.setf(std::ios::fixed);
      s.precision(4);
      s << "epoch " << epoch + 1 << "/" << c.epochs << (joint ? " joint" : " denoise") << " lr " << lr << " train "
        << rep.train_loss;
      if (teacher) s << " (distill " << distill_sum / std::max(steps, 1) << ")";
      s << " val " << rep.val_loss << (rep.best ? " (best, saved)" : "");
      s.precision(1);
      s << " " << rep.seconds << " s (batches " << data_s << " s, optimisation " << train_s - data_s
        << " s, validation " << val_s << " s)\n";
      for (const auto& m : rep.val) s << "  " << metrics_text(m) << "\n";
      log << s.str() << std::flush;
    }
    result.epochs.push_back(std::move(rep));
  }
  result.best_epoch = best_epoch;
  result.best_val_loss = best;
  log << "best epoch " << best_epoch + 1 << " (val " << best << "), model " << opt.out.string() << ", "
      << clock_text(since(run_t0)) << " wall\n";
  return result;
}

}  // namespace hs::train
