// handsteady filter: runs a streaming filter causally over a track, per hand.
// Output row at time t uses only input rows of that hand with time <= t and is the
// filter's estimate at t + horizon. --method stgae runs the Multi-STGAE streaming engine
// the same way; --offline runs a centred model in window mode over the whole recording
// (non-causal; with a horizon, the window ending at each row predicts). See docs/FILTERS.md.
#include "commands.hpp"

#include "handsteady/error.hpp"
#include "handsteady/filters.hpp"
#include "handsteady/model_path.hpp"
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
  std::vector<std::string> rate_models;  // models at other rates (rate_choice.hpp)
  bool offline = false;
  int phases = 0;  // interleaved streams; 0 = input rate / model rate
  bool unbounded = false;  // the network's own answer, without the trust region
  bool gain = false;       // the correction gain at every rate (correction_gain.hpp)
  bool no_gain = false;    // ... at none (the default: where the noise is measured at the input rate)
  bool no_guard = false;   // without the oscillation guard (oscillation_guard.hpp)
  bool smooth_predictions = false; // predicted displacements smoothed over time
  bool palm_fit = false;     // fit the hand's rigid palm to each input row first (any method)
  bool no_palm_fit = false;  // ... not even for a network method (where it is the default)
  bool tremor_cancel = false;  // cancel quasi-periodic tremor in each input row first (any method)
  bool skip_repeats = false;   // a row repeating one that moved is a stale answer: not fed (filters.hpp)
  bool bone_fit = false;     // move each answer's finger joints towards the learnt bone lengths and planes (any method)
  bool no_bone_fit = false;  // ... not even for a network method (where it is the default)
};

// The method and its parameters, from the command line.
FilterConfig filter_config(const FilterOptions& o) {
  FilterConfig c;
  c.method = parse_filter_method(o.method);  // the option checks the name
  c.oneeuro = o.oneeuro;
  c.oneeuro.vec3 = !o.per_axis;
  c.desp.alpha = o.desp_alpha;
  c.desp.period_s = o.period_ms * 1e-3;
  c.kalman.meas_sd_m = o.meas_sd_mm * 1e-3;
  c.kalman.accel_psd = o.accel_psd;
  c.max_gap_s = o.max_gap_ms * 1e-3;
  c.stgae.phases = o.phases;
  c.stgae.bounded = !o.unbounded;
  if (o.gain) c.stgae.gain = true;
  if (o.no_gain) c.stgae.gain = false;
  c.stgae.smooth = o.smooth_predictions;
  c.stgae.guard = !o.no_guard;
  c.stgae.offline = o.offline;
  if (o.palm_fit) c.palm_fit = true;
  if (o.no_palm_fit) c.palm_fit = false;
  c.tremor_cancel = o.tremor_cancel;
  if (o.bone_fit) c.bone_fit = true;
  if (o.no_bone_fit) c.bone_fit = false;
  return c;
}

std::vector<std::string> method_names() {
  std::vector<std::string> names;
  for (FilterMethod m : kFilterMethods) names.emplace_back(filter_method_name(m));
  return names;
}

// Loads the model once (per run, shared by both hands): --model, else the shipped one.
void load_stgae(FilterConfig& c, const std::string& model_file, const std::vector<std::string>& rate_models,
                 double horizon_ms) {
  const std::filesystem::path file =
      model_file.empty() ? default_model_path(default_model_file(c.method)) : std::filesystem::path(model_file);
  c.stgae.model = load_hsm(file);  // InputError naming the file for any defect
  c.stgae.source = file.string();
  if (network_method(*c.stgae.model) != c.method)
    throw InputError({c.stgae.source, 0, "--model"},
                     fmt::format("this is a {0} model: run it with --method {0}", filter_method_name(network_method(*c.stgae.model))));
  const bool causal = c.stgae.model->config.padding == StgaePadding::Causal;
  if (c.stgae.offline && causal) {
    throw InputError({c.stgae.source, 0, "--offline"},
                     "--offline runs a centred model in window mode; this model is causal (stream it without --offline)");
  }
  if (!c.stgae.offline && !causal) {
    throw InputError({c.stgae.source, 0, "--model"},
                     "this model is centred (non-causal): it cannot stream; use --offline for window mode");
  }
  if (c.stgae.offline && horizon_ms > 0.0 && !c.stgae.model->config.predict) {
    throw InputError({c.stgae.source, 0, "--horizon-ms"},
                     "this model has no prediction branch: --offline with a horizon needs one (or use --horizon-ms 0)");
  }
  if (c.stgae.offline && c.stgae.model->config.joint_count() != kJointCount)
    throw InputError({c.stgae.source, 0, "--model"}, "offline filtering needs a 26-joint (xr26) model");
  for (const std::string& f : rate_models) {
    auto m = load_hsm(f);
    if (m->config.padding != StgaePadding::Causal)
      throw InputError({f, 0, "--rate-model"}, "this model is centred (non-causal): it cannot stream");
    c.stgae.rate_models.push_back(std::move(m));
  }
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

void run_filter(const FilterOptions& o) {
  FilterConfig config = filter_config(o);
  const bool stgae = is_network(config.method);  // stgae or dgn
  if (!(o.horizon_ms >= 0.0)) {
    throw InputError({"", 0, "--horizon-ms"}, fmt::format("horizon must be >= 0 ms, got {}", o.horizon_ms));
  }
  if (o.offline && !stgae) throw InputError({"", 0, "--offline"}, "--offline needs --method stgae or dgn");
  if (o.phases != 0 && !stgae) {
    throw InputError({"", 0, "--phases"}, fmt::format("--phases is for --method stgae or dgn, not {}", o.method));
  }
  if (o.unbounded && (!stgae || o.offline)) {
    throw InputError({"", 0, "--unbounded"}, "--unbounded is for --method stgae or dgn streaming");
  }
  // Options of the trust region's stages: a network streaming, with the trust region.
  for (const auto& [set, flag] : {std::pair{o.gain, "--gain"}, std::pair{o.no_gain, "--no-gain"},
                                  std::pair{o.smooth_predictions, "--smooth-predictions"},
                                  std::pair{o.no_guard, "--no-guard"}})
    if (set && (!stgae || o.offline || o.unbounded))
      throw InputError({"", 0, flag}, fmt::format("{} is for --method stgae or dgn streaming, with the trust region", flag));
  if (o.gain && o.no_gain) throw InputError({"", 0, "--gain"}, "--gain and --no-gain contradict");
  if (o.palm_fit && o.no_palm_fit) throw InputError({"", 0, "--palm-fit"}, "--palm-fit and --no-palm-fit contradict");
  if (o.palm_fit && o.offline) throw InputError({"", 0, "--palm-fit"}, "--palm-fit streams; --offline has none");
  if (o.bone_fit && o.no_bone_fit) throw InputError({"", 0, "--bone-fit"}, "--bone-fit and --no-bone-fit contradict");
  if (o.bone_fit && o.offline) throw InputError({"", 0, "--bone-fit"}, "--bone-fit streams; --offline has none");
  if (o.tremor_cancel && o.offline)
    throw InputError({"", 0, "--tremor-cancel"}, "--tremor-cancel streams; --offline has none");
  if (o.skip_repeats && o.offline)
    throw InputError({"", 0, "--skip-repeats"}, "--skip-repeats streams; --offline has none");
  if (!o.rate_models.empty() && (!stgae || o.offline))
    throw InputError({"", 0, "--rate-model"}, "--rate-model is for --method stgae or dgn streaming");
  if (!o.model_file.empty() && !stgae) {
    throw InputError({"", 0, "--model"}, fmt::format("--model is for --method stgae or dgn, not {}", o.method));
  }
  // Load resources and validate the parameters before reading a possibly large file.
  if (stgae) load_stgae(config, o.model_file, o.rate_models, o.horizon_ms);
  if (!o.offline) {
    try {
      (void)make_filter(config);
    } catch (const std::invalid_argument& e) {
      throw InputError({config.stgae.source, 0, fmt::format("--method {}", o.method)}, e.what());
    }
  }
  Track track = read_track_csv(o.in);
  const double horizon_s = o.horizon_ms * 1e-3;
  map_hands(track, [&](const HandSeries& s) {  // a filter per hand
    return filter_series_with(config, s, horizon_s, o.skip_repeats);
  });
  // Appended (not replaced) so that a chain of filters stays visible; meta() reads the last.
  track.header_lines.push_back(fmt::format("filter: {} horizon_ms={} {}{}", o.method, o.horizon_ms,
                                           filter_params_summary(config), o.skip_repeats ? " skip_repeats" : ""));
  write_track_csv(track, o.out);
}

void setup_filter(CLI::App& app) {
  auto o = std::make_shared<FilterOptions>();
  CLI::App* sub = app.add_subcommand(
      "filter", "Filter a track causally per hand (raw, One Euro, DESP, Kalman, STGAE or Multi-STGAE, DGN); see docs/FILTERS.md");
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
                  fmt::format("network model (.hsm) of the method's family; default: ${}, else the shipped {} "
                              "(stgae) or {} (dgn)",
                              kModelEnvVar, kDefaultModelFile, kDgnModelFile));
  sub->add_option("--rate-model", o->rate_models,
                  "another causal model of the family at another frame rate (repeatable): each hand runs the "
                  "model whose rate suits its input (with a 30 and a 90 Hz model, the 90 Hz one from 72 Hz up; docs/STGAE.md \"Models by "
                  "input rate\")");
  sub->add_option("--phases", o->phases,
                  "stgae, dgn: interleaved streams for input faster than the model (0 = input rate / model rate)")
      ->capture_default_str();
  sub->add_flag("--unbounded", o->unbounded,
                "stgae, dgn: the network's own answer, without the trust region that holds it near its input "
                "(docs/STGAE.md \"Trust region\"; for comparison)");
  sub->add_flag("--gain", o->gain,
                "stgae, dgn: keep only the share of the network's correction that the input's next rows confirm at "
                "every input rate (docs/STGAE.md \"Correction gain\"; the default does so only where the input's "
                "noise is measured at its own rate, input faster than the model or 10-25 % slower; at its rate it gives "
                "back the removal of 4-6 Hz tremor)");
  sub->add_flag("--no-gain", o->no_gain,
                "stgae, dgn: no correction gain at any rate (the default applies it to input faster than the model "
                "or 10-25 % slower)");
  sub->add_flag("--no-guard", o->no_guard,
                "stgae, dgn: without the oscillation guard, which scales the whole hand's correction back where "
                "the answer's whole-hand motion accelerates more than the input's (docs/STGAE.md \"Oscillation guard\"; "
                "for comparison)");
  sub->add_flag("--smooth-predictions", o->smooth_predictions,
                "stgae, dgn: smooth each predicted frame's displacement over time (docs/STGAE.md \"Prediction "
                "smoothing\"; ~40 % less jitter at --horizon-ms 50 for a few % more error)");
  sub->add_flag("--palm-fit", o->palm_fit,
                "Any method: fit the hand's rigid palm (learnt from the input) to each row's palm joints before "
                "filtering (docs/FILTERS.md \"Palm fit\"; the default for stgae and dgn streaming)");
  sub->add_flag("--no-palm-fit", o->no_palm_fit, "stgae, dgn: without the palm fit (for comparison)");
  sub->add_flag("--bone-fit", o->bone_fit,
                "Any method: move each answer's finger joints towards the bone lengths and finger planes learnt from "
                "the method's answers (docs/FILTERS.md \"Bone fit\"; the default for stgae and dgn streaming)");
  sub->add_flag("--no-bone-fit", o->no_bone_fit, "stgae, dgn: without the bone fit (for comparison)");
  sub->add_flag("--tremor-cancel", o->tremor_cancel,
                "Cancel quasi-periodic tremor (3.5-12.5 Hz) in each input row before the method, behind the palm fit "
                "(any method; docs/FILTERS.md \"Tremor canceller\")");
  sub->add_flag("--skip-repeats", o->skip_repeats,
                "Any streaming method: a row that repeats a row that moved (within 10 um) is taken for the runtime's "
                "stale answer, as the OpenXR layer takes it: answered from the filter's estimate, not fed (one per "
                "run; docs/FILTERS.md \"CLI\", repeated rows)");
  sub->add_flag("--offline", o->offline,
                "stgae, dgn: run a centred model in window mode over the whole recording (not causal); with "
                "--horizon-ms, the window ending at each row predicts (the paper's protocol)");
  sub->callback([o] { run_filter(*o); });
}

const CommandRegistration register_filter(&setup_filter);

}  // namespace
}  // namespace hs::cli
