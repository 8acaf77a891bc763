// The benchmark's grid: recordings, noise cells, hand shapes, irregular resampling, and
// the runner (docs/BENCHMARK.md).
#include "handsteady/benchmark.hpp"

#include "handsteady/gap_policy.hpp"
#include "handsteady/import.hpp"
#include "handsteady/track_ops.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <span>
#include <string_view>
#include <thread>

namespace hs::bench {
namespace {

namespace fs = std::filesystem;

// FNV-1a: a seed per cell that does not depend on the standard library's hashes.
uint64_t seed_of(uint64_t seed, const std::string& text) {
  uint64_t h = 0xcbf29ce484222325ull ^ seed;
  for (const unsigned char c : text) h = (h ^ c) * 0x100000001b3ull;
  return h;
}

// Rows of each hand within the first seconds of that hand.
Track first_seconds(const Track& track, double seconds) {
  Track out;
  out.header_lines = track.header_lines;
  for (const Hand h : {Hand::Left, Hand::Right}) {
    HandSeries s = hand_series(track, h);
    if (s.empty()) continue;
    const double end = s.t.front() + seconds;
    size_t n = 0;
    while (n < s.size() && s.t[n] < end) ++n;
    s.t.resize(n);
    s.pos.resize(n);
    add_hand_series(out, h, s);
  }
  return out;
}

// Both hands of two one-hand tracks in one track.
Track merge_hands(const Track& a, const Track& b) {
  Track out = a;
  out.rows.clear();
  for (const Track* t : {&a, &b})
    for (const Hand h : {Hand::Left, Hand::Right}) {
      const HandSeries s = hand_series(*t, h);
      if (!s.empty()) add_hand_series(out, h, s);
    }
  return out;
}

// The .csv files of a folder whose names pass keep(), sorted.
std::vector<fs::path> csv_files(const fs::path& dir, const std::function<bool(const std::string&)>& keep) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".csv" && keep(e.path().filename().string()))
      files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

// Those files, each read by read(), concatenated as takes.
Track folder_takes(const fs::path& dir, const std::function<bool(const std::string&)>& keep,
                   const std::function<Track(const fs::path&)>& read) {
  const std::vector<fs::path> files = csv_files(dir, keep);
  if (files.empty()) throw InputError({dir.string(), 0, ""}, "no track CSV selected in this folder");
  std::vector<Track> takes;
  std::vector<std::string> names;
  for (const auto& f : files) {
    takes.push_back(read(f));
    names.push_back(f.filename().string());
  }
  return concatenate_takes(takes, names);
}
Track csv_takes(const fs::path& dir, const std::function<bool(const std::string&)>& keep) {
  return folder_takes(dir, keep, [](const fs::path& f) { return read_track_csv(f); });
}

// A HoloLens 2 (MRTK) export rather than a track CSV: its header starts "Label,Time,".
bool is_mrtk_csv(const fs::path& f) {
  std::ifstream in(f);
  std::string first;
  std::getline(in, first);
  return first.starts_with("Label,Time,");
}

// What benchmark/ may hold, one test set each (docs/BENCHMARK.md "Data and the split").
// The data folder's entries the benchmark reads (the sets below, then benchmark/).
inline constexpr std::array<std::string_view, 5> kDataFolders = {"fpha", "manipnet", "leap", "hololens2", "benchmark"};
inline constexpr const char* kExtraKinds =
    "a track CSV, a HoloLens 2 (MRTK) CSV, a ManipNet BVH, or a folder of track CSVs or of FPHA takes";

CorruptionConfig tracker(const TrackerCorruption& t) {
  CorruptionConfig c;
  c.kind = CorruptionKind::Tracker;
  c.tracker = t;
  return c;
}
CorruptionConfig jitter(double sd_m, double ar1 = 0.0) {
  TrackerCorruption t;
  t.jitter_sd_m = sd_m;
  t.jitter_ar1 = ar1;
  return tracker(t);
}
CorruptionConfig tremor(double fmin, double fmax, double amplitude_m) {
  CorruptionConfig c;
  c.kind = CorruptionKind::Tremor;
  c.tremor.freq_min_hz = fmin;
  c.tremor.freq_max_hz = fmax;
  c.tremor.hand_amplitude_m = amplitude_m;
  c.tremor.finger_amplitude_m = 0.5 * amplitude_m;
  return c;
}
// Correlated jitter: AR(1) with a 80 ms time constant whatever the rate.
double ar1_at(double rate_hz) { return std::exp(-1.0 / (rate_hz * 0.080)); }


}  // namespace

std::string Cell::key() const {
  return fmt::format("{} | {} | {} {} | {} | {:g} Hz", block, dataset, family, strength, shape, rate_hz);
}

std::vector<Dataset> load_datasets(const fs::path& data_dir, bool quick, std::vector<std::string>& notes) {
  std::vector<Dataset> out;
  const auto add = [&](const std::string& name, Split split, bool truth, double rate, const std::string& source,
                       const std::function<Track()>& load, bool wide = false) {
    try {
      Dataset d;
      d.name = name;
      d.split = split;
      d.has_truth = truth;
      d.rate_hz = rate;
      d.source = source;
      d.wide = wide;
      d.clean = load();
      if (quick) d.clean = first_seconds(d.clean, 20.0);
      out.push_back(std::move(d));
    } catch (const std::exception& e) {
      notes.push_back(fmt::format("{} skipped: {}", name, e.what()));
    }
  };
  const fs::path leap = data_dir / "leap";
  const fs::path manip = data_dir / "manipnet";
  // Tuning split (One Euro's parameters; model selection).
  add("manipnet-cup1", Split::Tuning, true, 90.0, "manipnet/cup1_{left,right}Hand.bvh", [&] {
    return merge_hands(import_bvh(manip / "cup1_leftHand.bvh"), import_bvh(manip / "cup1_rightHand.bvh"));
  });
  add("leap-guinevere-s03", Split::Tuning, true, 90.0, "leap/guinevere/s03_*",
      [&] { return csv_takes(leap / "guinevere", [](const std::string& f) { return f.starts_with("s03_"); }); });
  // Test split.
  add("fpha-s5", Split::Test, true, 30.0, "fpha/Subject_5", [&] { return import_fpha(data_dir / "fpha" / "Subject_5"); },
      true);
  add("manipnet-mug3", Split::Test, true, 90.0, "manipnet/mug3_{left,right}Hand.bvh", [&] {
    return merge_hands(import_bvh(manip / "mug3_leftHand.bvh"), import_bvh(manip / "mug3_rightHand.bvh"));
  });
  add("leap-gestures-s04", Split::Test, true, 90.0, "leap/guinevere/s04_*",
      [&] { return csv_takes(leap / "guinevere", [](const std::string& f) { return f.starts_with("s04_"); }); }, true);
  add("leap-handwriting", Split::Test, true, 90.0, "leap/fmkit_handwriting/*_10, fmcode, fmhash", [&] {
    return csv_takes(leap / "fmkit_handwriting", [](const std::string& f) {
      return f.ends_with("_10.csv") || f.starts_with("fmcode") || f.starts_with("fmhash");
    });
  });
  add("hololens2", Split::Test, false, 0.0, "hololens2/*.csv", [&] {
    return folder_takes(data_dir / "hololens2", [](const std::string&) { return true; },
                        [](const fs::path& f) { return import_mrtk(f); });
  });
  // Data added later, in benchmark/: each recording there is a test set, read by its kind;
  // anything else is named in a note, never passed over in silence.
  const fs::path extra = data_dir / "benchmark";
  if (fs::is_directory(extra)) {
    std::vector<fs::path> entries;
    for (const auto& e : fs::directory_iterator(extra)) entries.push_back(e.path());
    std::sort(entries.begin(), entries.end());
    for (const fs::path& f : entries) {
      const std::string name = "extra-" + (fs::is_directory(f) ? f.filename() : f.stem()).string();
      const std::string source = "benchmark/" + f.filename().string();
      if (std::any_of(out.begin(), out.end(), [&](const Dataset& d) { return d.name == name; })) {
        notes.push_back(fmt::format("{} skipped: a set named {} was read already", source, name));
      } else if (fs::is_directory(f)) {
        add(name, Split::Test, true, 90.0, source + "/", [f] {
          return csv_files(f, [](const std::string&) { return true; }).empty()
                     ? import_fpha(f)
                     : csv_takes(f, [](const std::string&) { return true; });
        });
      } else if (f.extension() == ".csv" && is_mrtk_csv(f)) {
        add(name, Split::Test, false, 0.0, source, [f] { return import_mrtk(f); });
      } else if (f.extension() == ".csv") {
        add(name, Split::Test, true, 90.0, source, [f] { return read_track_csv(f); });
      } else if (f.extension() == ".bvh") {
        add(name, Split::Test, true, 90.0, source, [f] { return import_bvh(f); });
      } else {
        notes.push_back(fmt::format("{} skipped: not a recording the benchmark reads ({})", source, kExtraKinds));
      }
    }
  }
  // Whatever else the data folder holds is not read: say so, so that recordings put beside
  // the known sets are not taken for scored.
  if (fs::is_directory(data_dir)) {
    std::vector<std::string> others;
    for (const auto& e : fs::directory_iterator(data_dir)) {
      const std::string n = e.path().filename().string();
      if (std::find(kDataFolders.begin(), kDataFolders.end(), n) == kDataFolders.end() && !n.starts_with("README"))
        others.push_back(n);
    }
    std::sort(others.begin(), others.end());
    for (const std::string& n : others)
      notes.push_back(fmt::format("{} not read: the benchmark reads its own sets and benchmark/ (recordings to score go "
                                  "in benchmark/: {})",
                                  n, kExtraKinds));
  }
  return out;
}

void use_rate(std::vector<Dataset>& datasets, double rate_hz) {
  if (!(rate_hz > 0.0)) return;
  for (Dataset& d : datasets)
    if (d.has_truth) d.rate_hz = rate_hz;
}

std::vector<NoiseCell> noise_grid(bool quick) {
  std::vector<NoiseCell> g;
  const auto mm = [](double v) { return fmt::format("{:g}mm", v); };
  const std::vector<double> levels = quick ? std::vector<double>{1.5} : std::vector<double>{0.5, 1.5, 3.0, 5.0};
  for (const double a : levels)
    g.push_back({"white", mm(a), a, [a](double) { return std::vector{jitter(a * 1e-3)}; }});
  for (const double a : levels)
    g.push_back({"correlated", mm(a), a, [a](double r) { return std::vector{jitter(a * 1e-3, ar1_at(r))}; }});
  for (const double a : levels)
    g.push_back({"tremor-4-6hz", mm(a), a, [a](double) { return std::vector{tremor(4.0, 6.0, a * 1e-3)}; }});
  for (const double a : quick ? std::vector<double>{1.5} : std::vector<double>{0.5, 1.5, 3.0})
    g.push_back({"tremor-8-12hz", mm(a), a, [a](double) { return std::vector{tremor(8.0, 12.0, a * 1e-3)}; }});
  for (const double p : quick ? std::vector<double>{0.02} : std::vector<double>{0.005, 0.02}) {
    g.push_back({"outliers", fmt::format("p={:g}", p), 0.5, [p](double) {
                   TrackerCorruption t;
                   t.jitter_sd_m = 0.0005;
                   t.outlier_prob = p;
                   return std::vector{tracker(t)};
                 }});
  }
  for (const double d : quick ? std::vector<double>{0.1} : std::vector<double>{0.05, 0.2}) {
    g.push_back({"missing", fmt::format("joints={:g}", d), 0.5, [d](double) {
                   TrackerCorruption t;
                   t.jitter_sd_m = 0.0005;
                   t.joint_drop_prob = d;
                   t.hand_drop_rate_hz = 4.0 * d;  // 0.2 or 0.8 dropouts per second
                   t.hand_drop_mean_s = 0.3;
                   return std::vector{tracker(t)};
                 }});
  }
  for (const double q : quick ? std::vector<double>{2.0} : std::vector<double>{1.0, 4.0}) {
    g.push_back({"quantised", mm(q), 0.0, [q](double) {
                   TrackerCorruption t;
                   t.quantize_m = q * 1e-3;
                   return std::vector{tracker(t)};
                 }});
  }
  const std::vector<std::string> presets =
      quick ? std::vector<std::string>{"tracker"} : std::vector<std::string>{"tracker", "paper", "tremor", "tremor-physiological"};
  for (const auto& p : presets) g.push_back({"preset", p, 0.0, [p](double) { return std::vector{corruption_preset(p)}; }});
  return g;
}

NoiseCell clean_cell() {
  return {"clean", "-", 0.0, [](double) { return std::vector<CorruptionConfig>{}; }};
}

double recorded_rate_hz(const Track& track) {
  std::vector<double> dt;
  for (const Hand h : {Hand::Left, Hand::Right}) {
    const HandSeries s = hand_series(track, h);
    for (size_t i = 1; i < s.size(); ++i)
      if (const double d = s.t[i] - s.t[i - 1]; d > 0.0 && d <= kInterpolateMaxGapS) dt.push_back(d);  // not a gap (between takes)
  }
  if (dt.empty()) return 0.0;
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return std::round(10.0 / dt[dt.size() / 2]) / 10.0;
}

std::vector<ShapeVariant> shape_variants(bool quick) {
  if (quick) return {{"standard"}, {"bones x0.8", ShapeKind::Scale, 0.8}, {"wrist +2cm", ShapeKind::WristProximal, 0.02}};
  return {{"standard"},
          {"bones x0.8", ShapeKind::Scale, 0.8},
          {"bones x1.2", ShapeKind::Scale, 1.2},
          {"bones +-20%", ShapeKind::BoneJitter, 0.2},
          {"wrist +2cm", ShapeKind::WristProximal, 0.02},
          {"palm centroid", ShapeKind::PalmCentroid, 0.0},
          {"thumb base", ShapeKind::ThumbBase, 0.3}};
}

std::vector<Method> classical_methods(const std::vector<std::pair<std::string, OneEuroParams>>& tuned) {
  const auto plain = [](FilterMethod m) {
    return [m](const std::string&) {
      FilterConfig c;
      c.method = m;
      return make_filter(c);
    };
  };
  std::vector<Method> out;
  out.push_back({"raw", plain(FilterMethod::Raw)});
  out.push_back({"oneeuro", plain(FilterMethod::OneEuro)});
  out.push_back({"oneeuro-tuned", [&tuned](const std::string& key) {
                   FilterConfig c;
                   c.method = FilterMethod::OneEuro;
                   for (const auto& [k, p] : tuned)
                     if (k == key) c.oneeuro = p;
                   return make_filter(c);
                 }});
  out.push_back({"desp", plain(FilterMethod::Desp)});
  out.push_back({"kalman", plain(FilterMethod::Kalman)});
  return out;
}

namespace {

// A prepared input: what the method sees per hand, and the truth it is scored against.
struct Prepared {
  Cell cell;
  std::string tuned_key;
  std::array<HandSeries, 2> input;
  std::array<HandSeries, 2> clean;  // the truth at the input's rows (sets with truth)
  std::shared_ptr<const Track> truth;
};

Track to_track(const std::array<HandSeries, 2>& hands) {
  Track t;
  for (const Hand h : {Hand::Left, Hand::Right})
    if (!hands[static_cast<size_t>(h)].empty()) add_hand_series(t, h, hands[static_cast<size_t>(h)]);
  return t;
}

// Shape -> irregular rate (block "native": the recording's own rows) -> corruption, per
// hand, seeded by the cell.
Prepared prepare(const Dataset& d, const Cell& cell, const NoiseCell* noise, const ShapeVariant& shape, uint64_t seed,
                 std::shared_ptr<const Track>& shaped_cache) {
  Prepared p;
  p.cell = cell;
  p.tuned_key = noise ? noise->key() : std::string();
  const uint64_t s = seed_of(seed, cell.key());
  if (!d.has_truth) {  // recorded as is; scored against itself
    for (const Hand h : {Hand::Left, Hand::Right}) p.input[static_cast<size_t>(h)] = hand_series(d.clean, h);
    p.truth = std::make_shared<const Track>(d.clean);
    return p;
  }
  std::array<HandSeries, 2> shaped;
  for (const Hand h : {Hand::Left, Hand::Right})
    shaped[static_cast<size_t>(h)] = apply_shape(hand_series(d.clean, h), shape, seed_of(seed, d.name + shape.name));
  if (!shaped_cache) shaped_cache = std::make_shared<const Track>(to_track(shaped));
  p.truth = shaped_cache;
  for (const Hand h : {Hand::Left, Hand::Right}) {
    const auto hi = static_cast<size_t>(h);
    HandSeries in = cell.block == "native"
                        ? shaped[hi]
                        : resample_series_jittered(shaped[hi], cell.rate_hz, kTimeJitter, s + 17 * static_cast<uint64_t>(h));
    p.clean[hi] = in;
    if (noise) {
      uint64_t k = 0;
      for (const CorruptionConfig& c : noise->steps(cell.rate_hz)) in = corrupt_series(in, c, s + 1000 * ++k + static_cast<uint64_t>(h));
    }
    p.input[hi] = std::move(in);
  }
  return p;
}

// The method's answers to each hand's input at each horizon: [horizon][hand].
std::vector<std::array<HandSeries, 2>> estimates(const Prepared& p, const Method& m, std::span<const double> horizons_s) {
  std::vector<std::array<HandSeries, 2>> est(horizons_s.size());
  for (const Hand h : {Hand::Left, Hand::Right}) {
    const auto hi = static_cast<size_t>(h);
    if (p.input[hi].empty()) continue;
    auto f = m.make(p.tuned_key);
    auto outs = filter_series(*f, p.input[hi], horizons_s);
    for (size_t k = 0; k < horizons_s.size(); ++k) est[k][hi] = std::move(outs[k]);
  }
  return est;
}

// H = 0 only: what the sweeps read (a third of score()'s work; the same values).
Metrics score_now(const Prepared& p, const Method& m) {
  constexpr double now = 0.0;
  return evaluate_tracks(*p.truth, to_track(estimates(p, m, std::span<const double>(&now, 1)).front()), now);
}

Result score(const Prepared& p, const Method& m) {
  Result r;
  r.cell = p.cell;
  r.method = m.name;
  const auto est = estimates(p, m, kHorizonsS);
  for (size_t k = 0; k < kHorizonsS.size(); ++k) r.at[k] = evaluate_tracks(*p.truth, to_track(est[k]), kHorizonsS[k]);
  // The occluded joints only: every other joint of the answer is blanked.
  std::array<HandSeries, 2> occ = est[0];
  bool any = false;
  for (size_t hi = 0; hi < 2; ++hi) {
    if (p.clean[hi].size() != occ[hi].size()) continue;
    for (size_t i = 0; i < occ[hi].size(); ++i)
      for (int j = 0; j < kJointCount; ++j) {
        const auto in = p.input[hi].pos[i].row(j), clean = p.clean[hi].pos[i].row(j);
        const bool occluded = !in.allFinite() || (in - clean).norm() > kOccludedMm * 1e-3;
        if (occluded && occ[hi].pos[i].row(j).allFinite()) any = true;
        else occ[hi].pos[i].row(j).setConstant(std::numeric_limits<double>::quiet_NaN());
      }
  }
  if (any) r.occluded = evaluate_tracks(*p.truth, to_track(occ), 0.0);
  return r;
}

void say(const Options& options, const std::string& line) {
  if (options.progress) options.progress(line);
}

// Runs jobs 0..n-1 on `threads` threads (job i by whichever thread takes it first).
void parallel_for(size_t n, int threads, const std::function<void(size_t)>& job) {
  std::atomic<size_t> next{0};
  std::exception_ptr error;
  std::mutex mu;
  const auto worker = [&] {
    for (size_t i; (i = next++) < n;) {
      try {
        job(i);
      } catch (...) {
        std::lock_guard lock(mu);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int k = 1; k < std::max(1, threads); ++k) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

// The One Euro parameters the sweep tries: cutoff (Hz) x beta (s/m).
std::vector<OneEuroParams> sweep_points(bool quick) {
  const std::vector<double> cutoffs =
      quick ? std::vector<double>{0.5, 2.0, 8.0} : std::vector<double>{0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0};
  const std::vector<double> betas =
      quick ? std::vector<double>{1.0, 10.0, 100.0} : std::vector<double>{0.0, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0};
  std::vector<OneEuroParams> out;
  for (const double c : cutoffs)
    for (const double b : betas) {
      OneEuroParams p;
      p.min_cutoff_hz = c;
      p.beta = b;
      out.push_back(p);
    }
  return out;
}

Method oneeuro_with(const OneEuroParams& p) {
  return {"oneeuro", [p](const std::string&) {
            FilterConfig c;
            c.method = FilterMethod::OneEuro;
            c.oneeuro = p;
            return make_filter(c);
          }};
}

// The Kalman filter's smoothing swept: the white-acceleration noise q (m²/s³) against its
// default 5 mm measurement noise (only their ratio sets the lag).
std::vector<KalmanParams> kalman_sweep(bool quick) {
  const std::vector<double> qs = quick ? std::vector<double>{0.1, 10.0, 1000.0}
                                       : std::vector<double>{0.01, 0.1, 1.0, 10.0, 100.0, 1000.0, 10000.0};
  std::vector<KalmanParams> out;
  for (const double q : qs) {
    KalmanParams p;
    p.accel_psd = q;
    out.push_back(p);
  }
  return out;
}

Method kalman_with(const KalmanParams& p) {
  return {"kalman", [p](const std::string&) {
            FilterConfig c;
            c.method = FilterMethod::Kalman;
            c.kalman = p;
            return make_filter(c);
          }};
}

}  // namespace

double jitter_at_lag(std::vector<std::pair<double, double>> lag_jitter, double lag_ms) {
  std::erase_if(lag_jitter, [](const auto& p) { return !std::isfinite(p.first) || !std::isfinite(p.second); });
  if (lag_jitter.empty() || !std::isfinite(lag_ms)) return std::numeric_limits<double>::quiet_NaN();
  std::sort(lag_jitter.begin(), lag_jitter.end());
  std::vector<std::pair<double, double>> env;  // lag increasing, jitter decreasing
  for (const auto& p : lag_jitter)
    if (env.empty() || p.second < env.back().second) env.push_back(p);
  if (lag_ms <= env.front().first) return env.front().second;
  for (size_t i = 1; i < env.size(); ++i)
    if (lag_ms <= env[i].first) {
      const auto& [x0, y0] = env[i - 1];
      const auto& [x1, y1] = env[i];
      return x1 > x0 ? y0 + (y1 - y0) * (lag_ms - x0) / (x1 - x0) : y1;
    }
  return env.back().second;
}

void tune_oneeuro(const std::vector<Dataset>& datasets, const Options& options, Report& report) {
  auto noise = noise_grid(options.quick);
  noise.push_back(clean_cell());
  const auto points = sweep_points(options.quick);
  const ShapeVariant standard{"standard"};
  std::vector<const Dataset*> tuning;
  for (const Dataset& d : datasets)
    if (d.split == Split::Tuning && d.has_truth) tuning.push_back(&d);
  if (tuning.empty()) {
    report.notes.push_back("no tuning set: oneeuro-tuned uses One Euro's defaults");
    return;
  }
  say(options, fmt::format("tuning One Euro on the tuning split: {} noise cells x {} parameter pairs", noise.size(),
                           points.size()));
  std::vector<Prepared> inputs(noise.size() * tuning.size());
  parallel_for(inputs.size(), options.threads, [&](size_t i) {
    const NoiseCell& n = noise[i / tuning.size()];
    const Dataset& d = *tuning[i % tuning.size()];
    Cell c{"tuning", d.name, n.family, n.strength, standard.name, d.rate_hz, n.level_mm};
    std::shared_ptr<const Track> cache;
    inputs[i] = prepare(d, c, &n, standard, options.seed, cache);
  });
  std::vector<SweepPoint> sweep(noise.size() * points.size());
  parallel_for(sweep.size(), options.threads, [&](size_t i) {
    const NoiseCell& n = noise[i / points.size()];
    const OneEuroParams& p = points[i % points.size()];
    SweepPoint s{n.key(), p};
    for (size_t k = 0; k < tuning.size(); ++k) {
      const Metrics m = score_now(inputs[(i / points.size()) * tuning.size() + k], oneeuro_with(p));
      s.mpjpe_mm += m.mpjpe_mm / static_cast<double>(tuning.size());
      s.jitter_mm += m.jitter_mm / static_cast<double>(tuning.size());
      s.lag_ms += m.lag_ms / static_cast<double>(tuning.size());
    }
    sweep[i] = s;
  });
  for (size_t n = 0; n < noise.size(); ++n) {
    const auto first = sweep.begin() + static_cast<std::ptrdiff_t>(n * points.size());
    const auto best = std::min_element(first, first + static_cast<std::ptrdiff_t>(points.size()),
                                       [](const SweepPoint& a, const SweepPoint& b) { return a.mpjpe_mm < b.mpjpe_mm; });
    report.tuned.emplace_back(noise[n].key(), best->params);
  }
  report.tuning = std::move(sweep);
}

void run_grid(const std::vector<Dataset>& datasets, const std::vector<Method>& methods, const Options& options,
              Report& report) {
  const auto t_start = std::chrono::steady_clock::now();
  const Split scored = options.tuning_split ? Split::Tuning : Split::Test;
  report.tuning_split = options.tuning_split;
  const auto noise = noise_grid(options.quick);
  const auto shapes = shape_variants(options.quick);
  const auto find_noise = [&](const std::string& family, const std::string& strength) -> const NoiseCell* {
    for (const auto& n : noise)
      if (n.family == family && n.strength == strength) return &n;
    return nullptr;
  };
  for (const Method& m : methods) {
    report.methods.push_back(m.name);
    if (m.is_model) report.models.push_back(m.name);
  }
  for (const Dataset& d : datasets)
    report.sets.push_back({d.name, d.split == Split::Tuning ? "tuning" : "test", d.source, d.clean.rows.size(), d.rate_hz,
                           d.has_truth});

  // The cells: every test set with truth x every noise cell at its rate (block "noise"),
  // and at its own times (block "native"); rates and shapes on the sets that have many
  // hands and motions; recordings as they are.
  struct Spec {
    const Dataset* d;
    Cell cell;
    const NoiseCell* noise;
    ShapeVariant shape;
  };
  std::vector<Spec> specs;
  const std::vector<double> rates = options.quick ? std::vector<double>{20.0, 90.0} : std::vector<double>{20.0, 30.0, 60.0, 90.0};
  const NoiseCell* tracker_preset = find_noise("preset", "tracker");
  const NoiseCell* white = find_noise("white", "1.5mm");
  const NoiseCell clean = clean_cell();
  for (const Dataset& d : datasets) {
    if (d.split != scored) continue;
    if (!d.has_truth) {
      specs.push_back({&d, Cell{"recorded", d.name, "recorded", "-", "-", 0.0, 0.0}, nullptr, shapes.front()});
      continue;
    }
    for (const NoiseCell& n : noise)
      specs.push_back({&d, Cell{"noise", d.name, n.family, n.strength, "standard", d.rate_hz, n.level_mm}, &n, shapes.front()});
    if (const double own = recorded_rate_hz(d.clean); own > 0.0)
      for (const NoiseCell* n : {&clean, tracker_preset, white})
        if (n)
          specs.push_back({&d, Cell{"native", d.name, n->family, n->strength, "standard", own, n->level_mm}, n, shapes.front()});
    if (!d.wide) continue;
    for (const NoiseCell* n : {tracker_preset, white}) {
      if (!n) continue;
      for (const double r : rates)
        if (r != d.rate_hz)
          specs.push_back({&d, Cell{"rate", d.name, n->family, n->strength, "standard", r, n->level_mm}, n, shapes.front()});
    }
    for (const ShapeVariant& s : shapes)
      if (s.kind != ShapeKind::Standard && tracker_preset)
        specs.push_back({&d, Cell{"shape", d.name, tracker_preset->family, tracker_preset->strength, s.name, d.rate_hz, 0.0},
                         tracker_preset, s});
  }
  // Prepare inputs (the shaped truth is shared by the cells of one set and shape).
  say(options, fmt::format("preparing {} cells", specs.size()));
  std::vector<Prepared> inputs(specs.size());
  {
    std::map<std::string, std::shared_ptr<const Track>> truth_cache;
    std::mutex mu;
    parallel_for(specs.size(), options.threads, [&](size_t i) {
      const Spec& s = specs[i];
      const std::string k = s.d->name + "/" + s.shape.name;
      std::shared_ptr<const Track> cache;
      {
        std::lock_guard lock(mu);
        if (auto it = truth_cache.find(k); it != truth_cache.end()) cache = it->second;
      }
      inputs[i] = prepare(*s.d, s.cell, s.noise, s.shape, options.seed, cache);
      std::lock_guard lock(mu);
      truth_cache.emplace(k, inputs[i].truth);
    });
  }
  // Score: (cell, method) jobs, models first (they take longest).
  std::vector<std::pair<size_t, size_t>> jobs;
  for (int pass = 0; pass < 2; ++pass)
    for (size_t m = 0; m < methods.size(); ++m)
      if (methods[m].is_model == (pass == 0))
        for (size_t c = 0; c < inputs.size(); ++c) jobs.emplace_back(c, m);
  std::vector<Result> results(jobs.size());
  say(options, fmt::format("scoring {} cells x {} methods", inputs.size(), methods.size()));
  std::atomic<size_t> done{0};
  parallel_for(jobs.size(), options.threads, [&](size_t i) {
    results[i] = score(inputs[jobs[i].first], methods[jobs[i].second]);
    const size_t d = ++done, n = jobs.size();
    if (d * 10 / n != (d - 1) * 10 / n) say(options, fmt::format("scoring: {} % ({} of {} jobs)", d * 100 / n, d, n));
  });
  // Report order: cell by cell, methods in the order given.
  const auto method_pos = [&](const std::string& name) {
    return std::find(report.methods.begin(), report.methods.end(), name) - report.methods.begin();
  };
  std::sort(results.begin(), results.end(), [&](const Result& a, const Result& b) {
    const std::string ka = a.cell.key(), kb = b.cell.key();
    return ka != kb ? ka < kb : method_pos(a.method) < method_pos(b.method);
  });
  for (auto& r : results) report.results.push_back(std::move(r));

  say(options, "sweeps (One Euro's curve, the recordings without truth) and still hands");
  // One Euro's whole sweep on one test cell: its jitter-lag curve.
  for (const Prepared& p : inputs)
    if (p.cell.block == "noise" && p.tuned_key == (tracker_preset ? tracker_preset->key() : "")) {
      report.curve_cell = p.cell.key();
      report.curve_label = p.cell.dataset + ", " + p.cell.family + " " + p.cell.strength;
      const auto points = sweep_points(options.quick);
      std::vector<SweepPoint> curve(points.size());
      parallel_for(points.size(), options.threads, [&](size_t i) {
        const Metrics m = score_now(p, oneeuro_with(points[i]));
        curve[i] = SweepPoint{p.cell.key(), points[i], m.mpjpe_mm, m.jitter_mm, m.lag_ms};
      });
      report.curve = std::move(curve);
      break;
    }

  // One Euro and Kalman swept on each recording without truth: what each reaches at a lag.
  for (const Prepared& p : inputs) {
    if (p.cell.block != "recorded") continue;
    std::vector<std::pair<Method, std::string>> sweep;
    for (const OneEuroParams& e : sweep_points(options.quick))
      sweep.emplace_back(oneeuro_with(e), fmt::format("min cutoff {:g} Hz, beta {:g} s/m", e.min_cutoff_hz, e.beta));
    for (const KalmanParams& k : kalman_sweep(options.quick))
      sweep.emplace_back(kalman_with(k), fmt::format("q {:g} m²/s³, measurement {:g} mm", k.accel_psd, k.meas_sd_m * 1e3));
    std::vector<LagPoint> pts(sweep.size());
    parallel_for(sweep.size(), options.threads, [&](size_t i) {
      const Metrics m = score_now(p, sweep[i].first);
      pts[i] = LagPoint{p.cell.key(), sweep[i].first.name, sweep[i].second, m.jitter_mm, m.lag_ms};
    });
    // Each curve's other points, already scored: the method's own row (its defaults) and
    // raw (no smoothing, the sweeps' limit).
    for (const std::string method : {"oneeuro", "kalman"})
      for (const Result& x : report.results)
        if (x.cell.key() == p.cell.key() && (x.method == method || x.method == "raw"))
          pts.push_back(LagPoint{p.cell.key(), method, x.method == "raw" ? "raw (no smoothing)" : "defaults",
                                 x.at[0].jitter_mm, x.at[0].lag_ms});
    for (auto& x : pts) report.recorded_curves.push_back(std::move(x));
  }

  // Still hands: start, resume, drift.
  for (const Dataset& d : datasets) {
    if (d.split != scored || !d.has_truth || !d.wide) continue;
    const Hand hand = hand_series(d.clean, Hand::Right).empty() ? Hand::Left : Hand::Right;
    const HandSeries src = hand_series(d.clean, hand);
    std::vector<Pose> poses;  // complete poses at 1/4, 1/2, 3/4 of the recording
    for (const double q : {0.25, 0.5, 0.75})
      for (size_t i = static_cast<size_t>(q * static_cast<double>(src.size())); i < src.size(); ++i)
        if (tracked_joint_count(src.pos[i]) == kJointCount) {
          poses.push_back(src.pos[i]);
          break;
        }
    for (const ShapeVariant& shape : shapes) {
      std::vector<StillResult> rows(methods.size());
      parallel_for(methods.size(), options.threads, [&](size_t mi) {
        StillResult r{d.name, shape.name, methods[mi].name};
        for (const Pose& pose0 : poses) {
          HandSeries one;
          one.t = {0.0};
          one.pos = {pose0};
          const Pose pose = apply_shape(one, shape, seed_of(options.seed, d.name + shape.name)).pos[0];
          HandSeries still;  // 2 s still, 0.5 s lost, 1 s still again
          for (double t = 0.0; t < 3.5; t += 1.0 / d.rate_hz) {
            still.t.push_back(t);
            still.pos.push_back(t >= 2.0 && t < 2.5 ? untracked_pose() : pose);
          }
          auto f = methods[mi].make("");
          const HandSeries out = filter_series(*f, still, 0.0);
          // The same with 0.5 mm white jitter per axis (a good tracker's): the mean answer
          // from 1 s to 2 s should still be the pose, not a learnt offset.
          std::mt19937_64 rng(seed_of(options.seed, d.name + shape.name + "jitter"));
          std::normal_distribution<double> jitter(0.0, 0.0005);
          HandSeries noisy = still;
          for (Pose& p : noisy.pos)
            if (any_joint_tracked(p))
              for (int j = 0; j < kJointCount; ++j)
                for (int c = 0; c < 3; ++c) p(j, c) += jitter(rng);
          const HandSeries nout = filter_series(*methods[mi].make(""), noisy, 0.0);
          Pose mean = Pose::Zero();
          int n = 0;
          for (size_t i = 0; i < nout.size(); ++i)
            if (nout.t[i] >= 1.0 && nout.t[i] < 2.0 && any_joint_tracked(nout.pos[i])) {
              mean += nout.pos[i];
              ++n;
            }
          if (n > 0) {
            const double off = ((mean / n) - pose).rowwise().norm().maxCoeff() * 1e3;
            r.noisy_offset_mm = std::max(r.noisy_offset_mm, std::isfinite(off) ? off : std::numeric_limits<double>::infinity());
          }
          for (size_t i = 0; i < out.size(); ++i) {
            const double t = out.t[i];
            if (!any_joint_tracked(out.pos[i])) continue;
            double worst = 0.0;
            for (int j = 0; j < kJointCount; ++j) {
              const double e = (out.pos[i].row(j) - pose.row(j)).norm() * 1e3;
              worst = std::max(worst, std::isfinite(e) ? e : std::numeric_limits<double>::infinity());
            }
            if (t < 0.3) r.start_mm = std::max(r.start_mm, worst);
            else if (t >= 1.0 && t < 2.0) r.drift_mm = std::max(r.drift_mm, worst);
            else if (t >= 2.5 && t < 2.8) r.resume_mm = std::max(r.resume_mm, worst);
          }
        }
        rows[mi] = r;
      });
      for (auto& r : rows) report.still.push_back(std::move(r));
    }
  }
  report.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
}

}  // namespace hs::bench
