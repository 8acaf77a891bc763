// handsteady filter: runs a streaming filter causally over a track, per hand.
// Output row at time t uses only input rows of that hand with time <= t and is the
// filter's estimate at t + horizon. --method stgae runs the Multi-STGAE streaming engine
// the same way; --offline runs a centred model in window mode over the whole recording
// (non-causal; with a horizon, the window ending at each row predicts). See docs/FILTERS.md.
#include "commands.hpp"

#include "handsteady/error.hpp"
#include "handsteady/filters.hpp"
#include "handsteady/model_path.hpp"
#include "handsteady/stgae_engine.hpp"
#include "handsteady/stgae_filter.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/track.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace hs::cli {
namespace {

struct FilterOptions {
  std::string in;
  std::string out;
  std::string method = "oneeuro";
  double horizon_ms = 0.0;
  // Classical filter parameters, in the units of the command line.
  OneEuroParams oneeuro;
  bool per_axis = false;
  double desp_alpha = DespParams{}.alpha;
  double period_ms = 0.0;
  double meas_sd_mm = KalmanParams{}.meas_sd_m * 1e3;
  double accel_psd = KalmanParams{}.accel_psd;
  double max_gap_ms = FilterConfig{}.max_gap_s * 1e3;
  // Multi-STGAE.
  std::string model_file;  // empty: hs::default_model_path()
  bool offline = false;
  int phases = 0;  // interleaved streams; 0 = input rate / model rate
  bool unbounded = false;  // the network's own answer, without the trust region
  std::shared_ptr<const StgaeModel> model;  // loaded once by run_filter (prepare_stgae)
  std::string model_source;                 // the file it came from
};

FilterConfig classical_config(const FilterOptions& o, FilterMethod m) {
  FilterConfig c;
  c.method = m;
  c.oneeuro = o.oneeuro;
  c.oneeuro.vec3 = !o.per_axis;
  c.desp.alpha = o.desp_alpha;
  c.desp.period_s = o.period_ms * 1e-3;
  c.kalman.meas_sd_m = o.meas_sd_mm * 1e-3;
  c.kalman.accel_psd = o.accel_psd;
  c.max_gap_s = o.max_gap_ms * 1e-3;
  return c;
}

// One entry per --method: how to build a filter for one hand and how to describe its
// parameters in the output metadata, and (optionally) what to load once before that.
// Another PoseFilter plugs in by adding an entry here and its options in setup_filter();
// reading, causal filtering and writing are shared.
struct MethodEntry {
  std::string_view name;
  std::unique_ptr<PoseFilter> (*make)(const FilterOptions&);
  std::string (*describe)(const FilterOptions&);
  void (*prepare)(FilterOptions&) = nullptr;  // throws InputError for bad resources
};

template <FilterMethod M>
std::unique_ptr<PoseFilter> make_classical(const FilterOptions& o) {
  return make_filter(classical_config(o, M));
}
template <FilterMethod M>
std::string describe_classical(const FilterOptions& o) {
  return filter_params_summary(classical_config(o, M));
}
template <FilterMethod M>
constexpr MethodEntry classical_entry(std::string_view name) {
  return {name, &make_classical<M>, &describe_classical<M>};
}

// ---------------------------------------------------------------- Multi-STGAE

// Loads the model once (per run, shared by both hands): --model, else the shipped one.
void prepare_stgae(FilterOptions& o) {
  const std::filesystem::path file = o.model_file.empty() ? default_model_path() : std::filesystem::path(o.model_file);
  o.model = load_hsm(file);  // InputError naming the file for any defect
  o.model_source = file.string();
  const bool causal = o.model->config.padding == StgaePadding::Causal;
  if (o.offline && causal) {
    throw InputError({o.model_source, 0, "--offline"},
                     "--offline runs a centred model in window mode; this model is causal (stream it without --offline)");
  }
  if (!o.offline && !causal) {
    throw InputError({o.model_source, 0, "--model"},
                     "this model is centred (non-causal): it cannot stream; use --offline for window mode");
  }
  if (o.offline && o.horizon_ms > 0.0 && !o.model->config.predict) {
    throw InputError({o.model_source, 0, "--horizon-ms"},
                     "this model has no prediction branch: --offline with a horizon needs one (or use --horizon-ms 0)");
  }
}

std::unique_ptr<PoseFilter> make_stgae(const FilterOptions& o) { return make_stgae_filter(o.model, o.horizon_ms * 1e-3, o.phases, !o.unbounded); }

std::string describe_stgae(const FilterOptions& o) {
  const StgaeConfig& c = o.model->config;
  return fmt::format("model={} rate_hz={} window={} horizon_frames={} padding={} mode={} phases={}{}", o.model_source,
                     c.rate_hz, c.window, c.predict ? c.horizon : 0,
                     c.padding == StgaePadding::Causal ? "causal" : "centred", o.offline ? "offline" : "streaming",
                     o.phases == 0 ? std::string("auto") : std::to_string(o.phases), o.unbounded ? " unbounded" : "");
}

const std::array<MethodEntry, 5> kMethods = {
    classical_entry<FilterMethod::Raw>("raw"),
    classical_entry<FilterMethod::OneEuro>("oneeuro"),
    classical_entry<FilterMethod::Desp>("desp"),
    classical_entry<FilterMethod::Kalman>("kalman"),
    MethodEntry{"stgae", &make_stgae, &describe_stgae, &prepare_stgae},
};

std::vector<std::string> method_names() {
  std::vector<std::string> names;
  for (const MethodEntry& e : kMethods) names.emplace_back(e.name);
  return names;
}

const MethodEntry& find_method(std::string_view name) {
  for (const MethodEntry& e : kMethods) {
    if (e.name == name) return e;
  }
  throw InputError({"", 0, "--method"}, fmt::format("unknown method '{}' (one of: {})", name,
                                                       fmt::join(method_names(), ", ")));
}

// Window-mode prediction over one resampled segment (offline_series with a horizon):
// for each row, the window of T grid frames ending at the row's grid frame (at or before
// the row), its path [denoised last frame, predicted DT frames] read at row time + horizon
// (piecewise linear; beyond the last predicted frame its last segment continues).
void predict_rows(const StgaeNet<float>& net, const StgaeFrames<float>& grid, const std::vector<double>& gt,
                  double t0, double horizon_s, const std::vector<size_t>& tracked, size_t a, size_t b,
                  const std::array<bool, kJointCount>& seen, HandSeries& out) {
  const StgaeConfig& c = net.config();
  const int T = c.window, DT = c.horizon, frames = static_cast<int>(grid.rows());
  const double period = 1.0 / c.rate_hz;
  StgaeFrames<float> window(T, grid.cols());
  int cached = -1;
  StgaeOutput<float> y;
  for (size_t q = a; q <= b; ++q) {
    const size_t row = tracked[q];
    const double tr = out.t[row];
    // A grid frame up to 1 us after the row counts as at it (CSV times are rounded to ns);
    // never a later one.
    constexpr double kTolS = 1e-6;
    int k = std::clamp(static_cast<int>(std::floor((tr + kTolS - t0) / period)), 0, frames - 1);
    while (k > 0 && gt[static_cast<size_t>(k)] > tr + kTolS) --k;
    if (k != cached) {
      for (int i = 0; i < T; ++i) window.row(i) = grid.row(std::max(0, k - (T - 1) + i));
      y = stgae_window_forward(net, window);
      cached = k;
    }
    const double s = (tr + horizon_s - gt[static_cast<size_t>(k)]) / period;  // periods after frame k
    const int seg = std::clamp(static_cast<int>(std::floor(s)), 0, DT - 1);
    const double f = s - seg;
    const auto point = [&](int i, Eigen::Index col) {
      return static_cast<double>(i == 0 ? y.denoised(T - 1, col) : y.predicted(i - 1, col));
    };
    Pose& p = out.pos[row];
    for (int j = 0; j < kJointCount; ++j)
      for (int d = 0; d < 3; ++d) {
        const Eigen::Index col = 3 * j + d;
        const double v0 = point(seg, col), v1 = point(seg + 1, col);
        p(j, d) = seen[static_cast<size_t>(j)] ? v0 + f * (v1 - v0) : std::numeric_limits<double>::quiet_NaN();
      }
  }
}

// Offline (window-mode) denoising of one hand with a centred model. The tracked rows are
// cut into segments wherever the hand is lost for more than kModelResetGapS (as the
// streaming adapter resets there). Each segment is resampled onto the model grid
// t0 + k / rate_hz by per-joint linear interpolation between the bracketing rows (a joint
// missing in one of them takes the other's value; missing in both: NaN, hole-filled by
// the model). Every grid frame k is denoised by the window of T frames centred on it
// (start k - (T-1)/2, stride 1); at the segment's ends the window is clamped inside the
// segment, so frame k comes off-centre from the first/last full window. A segment shorter
// than T frames is padded by repeating its first and last frames. The denoised grid is
// interpolated back to the segment's rows; joints never observed in a segment stay NaN.
// horizon_s > 0 (the paper's prediction protocol instead): grid frame k is answered by the
// window that ends at it (frames k-T+1..k, the first frame repeated before the segment's
// start): the path [denoised k, predicted k+1..k+DT] at horizon_s after the row, taken
// from the row's own grid frame or the one before, so only rows up to the row are used.
HandSeries offline_series(const StgaeModel& model, const HandSeries& in, double horizon_s) {
  const StgaeConfig& c = model.config;
  const int n = c.joint_count();
  if (n != kJointCount) throw InputError({"", 0, "--model"}, "offline filtering needs a 26-joint (xr26) model");
  const int T = c.window;
  const int centre = (T - 1) / 2;
  const double period = 1.0 / c.rate_hz;
  const auto width = static_cast<Eigen::Index>(3 * n);
  const StgaeNet<float>& net = *model.net;

  HandSeries out = in;
  std::vector<size_t> tracked;
  for (size_t i = 0; i < in.size(); ++i)
    if (any_joint_tracked(in.pos[i])) tracked.push_back(i);

  size_t a = 0;
  while (a < tracked.size()) {
    size_t b = a;  // segment = tracked[a..b]
    while (b + 1 < tracked.size() && in.t[tracked[b + 1]] - in.t[tracked[b]] <= kModelResetGapS) ++b;
    const double t0 = in.t[tracked[a]], t1 = in.t[tracked[b]];
    const int frames = 1 + static_cast<int>(std::ceil((t1 - t0) / period - 1e-9));

    // Resample onto the grid (the last tick may lie after t1: it takes the last row).
    StgaeFrames<float> grid(frames, width);
    std::vector<double> gt(static_cast<size_t>(frames));  // sample time of each grid frame
    std::array<bool, kJointCount> seen{};
    for (size_t r = a; r <= b; ++r)
      for (int j = 0; j < n; ++j) seen[static_cast<size_t>(j)] = seen[static_cast<size_t>(j)] || joint_tracked(in.pos[tracked[r]], j);
    size_t r = a;
    for (int k = 0; k < frames; ++k) {
      const double g = std::min(t0 + k * period, t1);
      gt[static_cast<size_t>(k)] = g;
      while (r < b && in.t[tracked[r + 1]] <= g) ++r;
      const Pose& p0 = in.pos[tracked[r]];
      const Pose& p1 = in.pos[tracked[std::min(r + 1, b)]];
      const double ta = in.t[tracked[r]], tb = in.t[tracked[std::min(r + 1, b)]];
      const double w = tb > ta ? std::clamp((g - ta) / (tb - ta), 0.0, 1.0) : 0.0;
      for (int j = 0; j < n; ++j) {
        const bool h0 = joint_tracked(p0, j), h1 = joint_tracked(p1, j);
        for (int d = 0; d < 3; ++d) {
          double v = std::numeric_limits<double>::quiet_NaN();
          if (h0 && h1) v = p0(j, d) + w * (p1(j, d) - p0(j, d));
          else if (h0 || h1) v = (h0 && (w < 0.5 || !h1)) ? p0(j, d) : p1(j, d);
          grid(k, 3 * j + d) = static_cast<float>(v);
        }
      }
    }

    if (horizon_s > 0.0) {
      predict_rows(net, grid, gt, t0, horizon_s, tracked, a, b, seen, out);
      a = b + 1;
      continue;
    }
    // Window mode, one window per start position; each grid frame taken from its window.
    StgaeFrames<float> den(frames, width);
    StgaeFrames<float> window(T, width);
    if (frames < T) {
      const int pad = (T - frames) / 2;
      for (int i = 0; i < T; ++i) window.row(i) = grid.row(std::clamp(i - pad, 0, frames - 1));
      const StgaeOutput<float> y = stgae_window_forward(net, window);
      for (int k = 0; k < frames; ++k) den.row(k) = y.denoised.row(k + pad);
    } else {
      for (int ws = 0; ws + T <= frames; ++ws) {
        window = grid.middleRows(ws, T);
        const StgaeOutput<float> y = stgae_window_forward(net, window);
        const int first = ws == 0 ? 0 : ws + centre;
        const int last = ws + T == frames ? frames - 1 : ws + centre;
        for (int k = first; k <= last; ++k) den.row(k) = y.denoised.row(k - ws);
      }
    }

    // Back to the rows, linearly between the grid frames' sample times.
    for (size_t q = a; q <= b; ++q) {
      const size_t row = tracked[q];
      const int k0 = std::clamp(static_cast<int>(std::floor((in.t[row] - t0) / period)), 0, frames - 1);
      const int k1 = std::min(k0 + 1, frames - 1);
      const double g0 = gt[static_cast<size_t>(k0)], g1 = gt[static_cast<size_t>(k1)];
      const double f = g1 > g0 ? std::clamp((in.t[row] - g0) / (g1 - g0), 0.0, 1.0) : 0.0;
      Pose& p = out.pos[row];
      for (int j = 0; j < n; ++j)
        for (int d = 0; d < 3; ++d) {
          const auto v0 = static_cast<double>(den(k0, 3 * j + d)), v1 = static_cast<double>(den(k1, 3 * j + d));
          p(j, d) = seen[static_cast<size_t>(j)] ? v0 + f * (v1 - v0) : std::numeric_limits<double>::quiet_NaN();
        }
    }
    a = b + 1;
  }
  return out;
}

// Replaces each hand's rows of the track by `series_fn(series)`; rows keep order and times.
template <class SeriesFn>
void map_hands(Track& track, SeriesFn&& series_fn) {
  for (Hand hand : {Hand::Left, Hand::Right}) {
    const HandSeries series = hand_series(track, hand);
    if (series.empty()) continue;
    const HandSeries filtered = series_fn(series);
    // Times are strictly increasing per hand, so the series is this hand's rows in file order.
    size_t k = 0;
    for (TrackRow& row : track.rows) {
      if (row.hand != hand) continue;
      if (k >= filtered.size() || filtered.t[k] != row.t) {
        throw std::runtime_error(fmt::format("internal: {} hand series does not match the track rows",
                                             hand_name(hand)));
      }
      row.pos = filtered.pos[k++];
    }
  }
}

void run_filter(const FilterOptions& options) {
  FilterOptions o = options;
  const MethodEntry& method = find_method(o.method);
  if (!(o.horizon_ms >= 0.0)) {
    throw InputError({"", 0, "--horizon-ms"}, fmt::format("horizon must be >= 0 ms, got {}", o.horizon_ms));
  }
  if (o.offline && method.name != "stgae") throw InputError({"", 0, "--offline"}, "--offline needs --method stgae");

  if (o.phases != 0 && method.name != "stgae") {
    throw InputError({"", 0, "--phases"}, fmt::format("--phases is for --method stgae, not {}", method.name));
  }
  if (o.unbounded && (method.name != "stgae" || o.offline)) {
    throw InputError({"", 0, "--unbounded"}, "--unbounded is for --method stgae streaming");
  }
  if (!o.model_file.empty() && method.name != "stgae") {
    throw InputError({"", 0, "--model"}, fmt::format("--model is for --method stgae, not {}", method.name));
  }
  // Load resources and validate the parameters before reading a possibly large file.
  if (method.prepare) method.prepare(o);
  if (!o.offline) {
    try {
      (void)method.make(o);
    } catch (const std::invalid_argument& e) {
      throw InputError({o.model_source, 0, fmt::format("--method {}", method.name)}, e.what());
    }
  }
  Track track = read_track_csv(o.in);
  if (o.offline) {
    map_hands(track, [&](const HandSeries& s) { return offline_series(*o.model, s, o.horizon_ms * 1e-3); });
  } else {
    const double horizon_s = o.horizon_ms * 1e-3;
    map_hands(track, [&](const HandSeries& s) {
      std::unique_ptr<PoseFilter> filter = method.make(o);  // one per hand
      return filter_series(*filter, s, horizon_s);
    });
  }
  // Appended (not replaced) so that a chain of filters stays visible; meta() reads the last.
  track.header_lines.push_back(
      fmt::format("filter: {} horizon_ms={} {}", method.name, o.horizon_ms, method.describe(o)));
  write_track_csv(track, o.out);
}

void setup_filter(CLI::App& app) {
  auto o = std::make_shared<FilterOptions>();
  CLI::App* sub = app.add_subcommand(
      "filter", "Filter a track causally per hand (raw, One Euro, DESP, Kalman, Multi-STGAE); see docs/FILTERS.md");
  sub->add_option("--in", o->in, "Input track CSV")->required();
  sub->add_option("--out", o->out, "Output track CSV")->required();
  sub->add_option("--method", o->method, "Filter method")
      ->check(CLI::IsMember(method_names()))
      ->capture_default_str();
  sub->add_option("--horizon-ms", o->horizon_ms, "Prediction horizon: output at t + H (ms)")->capture_default_str();
  sub->add_option("--max-gap-ms", o->max_gap_ms, "A joint unseen this long restarts its filter (ms)")
      ->capture_default_str();
  sub->add_option("--mincutoff", o->oneeuro.min_cutoff_hz, "One Euro minimum cutoff (Hz)")->capture_default_str();
  sub->add_option("--beta", o->oneeuro.beta, "One Euro speed coefficient (s/m; speed in m/s)")
      ->capture_default_str();
  sub->add_option("--dcutoff", o->oneeuro.d_cutoff_hz, "One Euro derivative cutoff (Hz)")->capture_default_str();
  sub->add_flag("--per-axis", o->per_axis, "One Euro: one cutoff per coordinate instead of per joint");
  sub->add_flag("--extrapolate", o->oneeuro.extrapolate,
                "One Euro: extrapolate with the filtered velocity instead of holding");
  sub->add_option("--alpha", o->desp_alpha, "DESP smoothing per sample period, in (0, 1)")->capture_default_str();
  sub->add_option("--period-ms", o->period_ms, "DESP nominal sample period (ms); 0 = observed mean")
      ->capture_default_str();
  sub->add_option("--meas-sd-mm", o->meas_sd_mm, "Kalman measurement noise sd (mm)")->capture_default_str();
  sub->add_option("--accel-psd", o->accel_psd, "Kalman white-acceleration PSD (m^2/s^3)")->capture_default_str();
  sub->add_option("--model", o->model_file,
                  fmt::format("Multi-STGAE model (.hsm); default: ${}, else the shipped {}", kModelEnvVar,
                              kDefaultModelFile));
  sub->add_option("--phases", o->phases,
                  "Multi-STGAE: interleaved streams for input faster than the model (0 = input rate / model rate)")
      ->capture_default_str();
  sub->add_flag("--unbounded", o->unbounded,
                "Multi-STGAE: the network's own answer, without the trust region that holds it near its input "
                "(docs/STGAE.md \"Trust region\"; for comparison)");
  sub->add_flag("--offline", o->offline,
                "Multi-STGAE: run a centred model in window mode over the whole recording (not causal); with "
                "--horizon-ms, the window ending at each row predicts (the paper's protocol)");
  sub->callback([o] { run_filter(*o); });
}

const CommandRegistration reg(&setup_filter);

}  // namespace
}  // namespace hs::cli
