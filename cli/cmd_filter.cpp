// handsteady filter: runs a streaming filter causally over a track, per hand.
// Output row at time t uses only input rows of that hand with time <= t and is the
// filter's estimate at t + horizon. See docs/FILTERS.md.
#include "commands.hpp"

#include "handsteady/error.hpp"
#include "handsteady/filters.hpp"
#include "handsteady/track.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <array>
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
// parameters in the output metadata. Another PoseFilter (e.g. a learned model) plugs in
// by adding an entry here and its options in setup_filter(); reading, causal filtering
// and writing are shared.
struct MethodEntry {
  std::string_view name;
  std::unique_ptr<PoseFilter> (*make)(const FilterOptions&);
  std::string (*describe)(const FilterOptions&);
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

const std::array<MethodEntry, 4> kMethods = {
    classical_entry<FilterMethod::Raw>("raw"),
    classical_entry<FilterMethod::OneEuro>("oneeuro"),
    classical_entry<FilterMethod::Desp>("desp"),
    classical_entry<FilterMethod::Kalman>("kalman"),
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

// Filters each hand of the track in place; rows keep their order and timestamps.
void filter_track(Track& track, const MethodEntry& method, const FilterOptions& o) {
  const double horizon_s = o.horizon_ms * 1e-3;
  for (Hand hand : {Hand::Left, Hand::Right}) {
    const HandSeries series = hand_series(track, hand);
    if (series.empty()) continue;
    std::unique_ptr<PoseFilter> filter = method.make(o);
    const HandSeries filtered = filter_series(*filter, series, horizon_s);
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
  const MethodEntry& method = find_method(o.method);
  if (!(o.horizon_ms >= 0.0)) {
    throw InputError({"", 0, "--horizon-ms"}, fmt::format("horizon must be >= 0 ms, got {}", o.horizon_ms));
  }
  // Validate the parameters before reading a possibly large file.
  try {
    (void)method.make(o);
  } catch (const std::invalid_argument& e) {
    throw InputError({"", 0, fmt::format("--method {}", method.name)}, e.what());
  }
  Track track = read_track_csv(o.in);
  filter_track(track, method, o);
  // Appended (not replaced) so that a chain of filters stays visible; meta() reads the last.
  track.header_lines.push_back(
      fmt::format("filter: {} horizon_ms={} {}", method.name, o.horizon_ms, method.describe(o)));
  write_track_csv(track, o.out);
}

void setup_filter(CLI::App& app) {
  auto o = std::make_shared<FilterOptions>();
  CLI::App* sub = app.add_subcommand(
      "filter", "Filter a track causally per hand (raw, One Euro, DESP, Kalman); see docs/FILTERS.md");
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
  sub->callback([o] { run_filter(*o); });
}

const CommandRegistration reg(&setup_filter);

}  // namespace
}  // namespace hs::cli
