#pragma once
// The project's quality benchmark (docs/BENCHMARK.md): a fixed, seeded grid of
// recordings x noise families x input rates x hand shapes. Every method runs causally
// over every cell (one pass, answers at t, t + 20 ms and t + 50 ms) and is scored with
// metrics.hpp against the clean recording. Recordings without truth (HoloLens 2) are
// scored against themselves: jitter, lag behind the raw input, prediction of the
// observed future. One Euro is tuned per noise cell on the declared tuning split only.
#include "handsteady/corrupt.hpp"
#include "handsteady/filters.hpp"
#include "handsteady/hand_shape.hpp"
#include "handsteady/metrics.hpp"
#include "handsteady/track.hpp"

#include <array>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace hs::bench {

inline constexpr std::array<double, 3> kHorizonsS = {0.0, 0.020, 0.050};

enum class Split { Tuning, Test };

struct Dataset {
  std::string name;        // "fpha-s5", "manipnet", "leap-gestures", ...
  Split split = Split::Test;
  Track clean;             // the truth; for a set without truth, the recording itself
  bool has_truth = true;
  double rate_hz = 90.0;   // input rate of the main grid (resampled, irregular times)
  bool wide = false;       // also run the rate, hand-shape and still-hand blocks on it
  std::string source;      // where it came from (for the report)
};

// The benchmark's recordings under data_dir (../shared/data): FPHA subject 5, ManipNet,
// held-out Leap gestures and handwriting, the HoloLens 2 recordings, plus every track CSV
// under data_dir/benchmark/ (added later: test split, truth assumed). The tuning split is
// ManipNet cup1 and Leap guinevere subject 03. A set whose files are missing is skipped
// with a note. quick: the first ~20 s of each set.
std::vector<Dataset> load_datasets(const std::filesystem::path& data_dir, bool quick, std::vector<std::string>& notes);
// Every set with truth scored at `rate_hz` instead of its own grid rate (Options::rate_hz;
// 0: unchanged). Recordings without truth stay as recorded.
void use_rate(std::vector<Dataset>& datasets, double rate_hz);

// One noise condition: corruption steps applied in order to the resampled truth.
struct NoiseCell {
  std::string family;    // "white", "correlated", "tremor-4-6hz", ...
  std::string strength;  // "1.5mm", "p=0.02", ...
  double level_mm = 0;   // jitter/tremor amplitude (0 where the family has none)
  std::function<std::vector<CorruptionConfig>(double rate_hz)> steps;
  std::string key() const { return family + " " + strength; }
};
std::vector<NoiseCell> noise_grid(bool quick);
// No noise added: the recording itself is the input (block "native"; raw's answer is the
// truth, so what a method changes is all it adds). One Euro is tuned for it too.
NoiseCell clean_cell();
// The recording's own rate: 1 / the median interval between its rows (Hz, to 0.1), over
// the intervals that are no gap (at most kInterpolateMaxGapS: not the time between takes).
double recorded_rate_hz(const Track& track);

// The hands the benchmark scores on (handsteady/hand_shape.hpp), applied to the truth.
using hs::ShapeKind;
using hs::ShapeVariant;
using hs::apply_shape;
std::vector<ShapeVariant> shape_variants(bool quick);

// The rows a tracker at rate_hz gives: times k / rate +- 20 % of a period (seeded,
// hs::resample_series_jittered), the truth interpolated there.
inline constexpr double kTimeJitter = 0.2;

// A method under test: a fresh filter per hand and cell. tuned_key is the NoiseCell key
// of the cell (a method tuned per noise cell looks its parameters up by it).
struct Method {
  std::string name;
  std::function<std::unique_ptr<PoseFilter>(const std::string& tuned_key)> make;
  bool is_model = false;
};

struct Options {
  bool quick = false;
  int threads = 2;
  uint64_t seed = 1;
  // Score the tuning sets instead of the test sets: for choosing a method's own constants
  // without looking at the test sets (One Euro is then tuned on the sets it is scored on).
  bool tuning_split = false;
  // > 0: every set with truth resampled to this grid rate instead of its own (Hz), One
  // Euro's tuning included: to score or choose constants for another input rate (a model
  // runs one stream per frame at its own rate, several at faster input).
  double rate_hz = 0.0;
  // Where a run reports its stages and the scoring's progress, a line at a time (called
  // from worker threads, so it must be thread-safe); empty: silent. A full run takes tens
  // of minutes, and a user should see it move.
  std::function<void(const std::string&)> progress;
};

struct Cell {
  // "noise", "rate", "shape", "recorded", or "native": a set with truth at its own row
  // times (rate_hz is then recorded_rate_hz, not resampled), clean, the tracker preset and
  // 1.5 mm white jitter. Leap Motion's service changes its rate within a take (96 / 48 Hz)
  // and re-fits fingers between rows: the grid's resampling smooths both away.
  std::string block;
  std::string dataset, family, strength, shape;
  double rate_hz = 0;
  double level_mm = 0;
  std::string key() const;  // one line naming every coordinate
};

// A joint of an input row counts as occluded when it is missing or more than this far
// from the truth (outliers, heavy noise): the DGN paper's claim is about those joints.
inline constexpr double kOccludedMm = 10.0;

struct Result {
  Cell cell;
  std::string method;
  std::array<Metrics, kHorizonsS.size()> at;  // per horizon
  // H = 0 on the occluded joints of each row only (joint_samples = 0: none in this cell).
  Metrics occluded;
};

// One Euro parameters tried by the tuning sweep, and their score.
struct SweepPoint {
  std::string cell;  // NoiseCell key, on the tuning split (mean over its sets) or a test cell
  OneEuroParams params;
  double mpjpe_mm = 0, jitter_mm = 0, lag_ms = 0;
};

// A still hand (one pose of a test set held for 3 s, tracking starting at its first row,
// lost for 0.5 s after 2 s and back): the largest joint distance from the pose over the
// first 0.3 s after each start, and after 1 s.
struct StillResult {
  std::string dataset, shape, method;
  double start_mm = 0, resume_mm = 0, drift_mm = 0;
  double noisy_offset_mm = 0;  // with 0.5 mm jitter: the mean answer (1 s to 2 s) from the pose
};

// A classical method swept over its smoothing on a recording without truth: the jitter it
// reaches at each lag. The criterion compares a model with it at the model's own lag. Each
// method's curve also holds its default row and raw's (no smoothing, the sweep's limit).
struct LagPoint {
  std::string cell;    // Cell::key() of the recording
  std::string method;  // "oneeuro" or "kalman"
  std::string params;  // what was set, e.g. "min cutoff 1 Hz, beta 5 s/m", "defaults", "raw (no smoothing)"
  double jitter_mm = 0, lag_ms = 0;
};

// The least jitter a swept method reaches at lag_ms: the lower envelope of its (lag,
// jitter) points (each point's jitter below that of every point with less lag), linearly
// interpolated between the envelope's neighbours of lag_ms and held at its ends (below the
// least lag swept, the envelope's first point, which needed more lag: conservative for
// whoever is compared with it). NaN without finite points.
double jitter_at_lag(std::vector<std::pair<double, double>> lag_jitter, double lag_ms);

struct SetInfo {
  std::string name, split, source;
  size_t rows = 0;
  double rate_hz = 0;
  bool truth = true;
};

struct Report {
  std::vector<SetInfo> sets;
  std::vector<Result> results;
  std::vector<SweepPoint> tuning;      // every sweep point on the tuning split
  std::vector<SweepPoint> curve;       // the sweep on the test curve cell (jitter-lag curve)
  std::string curve_cell;              // its Cell::key()
  std::string curve_label;             // "<set>, <noise>"
  std::vector<std::pair<std::string, OneEuroParams>> tuned;  // per noise cell key
  std::vector<StillResult> still;
  std::vector<LagPoint> recorded_curves;  // One Euro's and Kalman's curves on each recording without truth
  std::vector<std::string> notes;
  std::vector<std::string> methods;  // in the order given
  std::vector<std::string> models;   // those that are learnt models (the criteria are checked for them)
  std::string command;               // how the report was made (for its header)
  std::string revision;              // the code it was made with (hs::source_revision(), set by the caller)
  bool tuning_split = false;         // the scored sets are the tuning split (Options::tuning_split)
  double seconds = 0;
  double total_seconds = 0;  // the whole run: loading the sets, tuning, the grid (set by the caller)
};

// The standard methods: raw, oneeuro (defaults), oneeuro-tuned (looked up in tuned),
// desp, kalman (constant velocity). tuned must outlive the methods.
std::vector<Method> classical_methods(const std::vector<std::pair<std::string, OneEuroParams>>& tuned);

// Tunes One Euro per noise cell on the tuning sets (minimum mean MPJPE at H = 0).
void tune_oneeuro(const std::vector<Dataset>& datasets, const Options& options, Report& report);

// Runs every method over the grid (report.tuned must be set: tune_oneeuro first).
void run_grid(const std::vector<Dataset>& datasets, const std::vector<Method>& methods, const Options& options,
              Report& report);

// The whole report as markdown (tables per block, the criteria checked) and JSON.
std::string report_markdown(const Report& report, const Options& options);
std::string report_json(const Report& report, const Options& options);
// One Euro's jitter-lag curve and every method as a point, as CSV (method,mpjpe,jitter,lag).
std::string curve_csv(const Report& report);

}  // namespace hs::bench
