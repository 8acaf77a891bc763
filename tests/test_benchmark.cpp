// The quality benchmark's parts (noise, shapes, irregular rates, multi-horizon runs, the
// still-hand measure, the report) on synthetic motion, and the CLI's quick run on the
// shared recordings.
#include "handsteady/benchmark.hpp"
#include "handsteady/corrupt.hpp"
#include "handsteady/filters.hpp"
#include "handsteady/synth.hpp"
#include "handsteady/track_ops.hpp"

#include "test_support.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <map>
#include <sstream>

using namespace hs;

namespace {

HandSeries synth_series(double seconds, double rate, uint64_t seed) {
  SynthMotionParams p;
  p.duration_s = seconds;
  p.rate_hz = rate;
  return synth_motion(p, Hand::Right, seed);
}

double bone(const Pose& p, int j) { return (p.row(j) - p.row(kXrParent[static_cast<size_t>(j)])).norm(); }

std::string slurp(const std::filesystem::path& f) {
  std::ifstream in(f);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

TEST_CASE("outliers: single joints jump 10-50 mm for 1-3 rows, the other noise draws the same as without them") {
  const HandSeries clean = synth_series(20.0, 60.0, 3);
  CorruptionConfig base;
  base.kind = CorruptionKind::Tracker;
  base.tracker.jitter_sd_m = 0.001;
  base.tracker.jump_prob = 0.01;
  base.tracker.jump_sd_m = 0.005;
  CorruptionConfig with = base;
  with.tracker.outlier_prob = 0.01;
  const HandSeries a = corrupt_series(clean, base, 7), b = corrupt_series(clean, with, 7);
  int displaced = 0, runs = 0, longest = 0;
  for (int j = 0; j < kJointCount; ++j) {
    int run = 0;
    for (size_t i = 0; i < clean.size(); ++i) {
      const double d = (b.pos[i].row(j) - a.pos[i].row(j)).norm();
      if (d > 0.0) {
        CHECK(d >= 0.010 - 1e-12);
        CHECK(d <= 0.050 + 1e-12);
        ++displaced;
        if (run == 0) ++runs;
        ++run;
        longest = std::max(longest, run);
      } else {
        run = 0;
      }
    }
  }
  const double expected = 0.01 * static_cast<double>(clean.size()) * kJointCount;  // starts
  CHECK(runs > 0.7 * expected);
  CHECK(runs < 1.3 * expected);
  CHECK(longest <= 6);  // 3 rows, or two outliers back to back
  CHECK(displaced > runs);  // some last longer than one row
  with.tracker.outlier_max_rows = 0;
  CHECK_THROWS_AS(validate_corruption(with), std::invalid_argument);
}

TEST_CASE("one pass with several horizons answers as one pass per horizon") {
  const HandSeries in = synth_series(5.0, 45.0, 1);
  FilterConfig c;
  c.method = FilterMethod::Kalman;
  auto f = make_filter(c);
  const std::vector<double> hs = {0.0, 0.02, 0.05};
  const auto all = filter_series(*f, in, std::span<const double>(hs));
  REQUIRE(all.size() == 3);
  for (size_t k = 0; k < hs.size(); ++k) {
    const HandSeries one = filter_series(*f, in, hs[k]);
    REQUIRE(one.size() == all[k].size());
    for (size_t i = 0; i < one.size(); ++i) CHECK((one.pos[i] - all[k].pos[i]).cwiseAbs().maxCoeff() == 0.0);
  }
}

TEST_CASE("hand shapes change what they name and nothing else") {
  HandSeries s;
  s.t = {0.0};
  s.pos = {test::synthetic_hand()};
  s.pos[0].row(idx(Joint::Palm)) = 0.5 * (s.pos[0].row(idx(Joint::MiddleMetacarpal)) + s.pos[0].row(idx(Joint::MiddleProximal)));
  const Pose& in = s.pos[0];
  const Pose big = bench::apply_shape(s, {"x1.2", bench::ShapeKind::Scale, 1.2}, 1).pos[0];
  CHECK((big.row(idx(Joint::Wrist)) - in.row(idx(Joint::Wrist))).norm() == doctest::Approx(0.0));
  for (int j = 0; j < kJointCount; ++j)
    if (kXrParent[static_cast<size_t>(j)] >= 0) CHECK(bone(big, j) == doctest::Approx(1.2 * bone(in, j)));
  const Pose jit = bench::apply_shape(s, {"+-20%", bench::ShapeKind::BoneJitter, 0.2}, 5).pos[0];
  bool changed = false;
  for (int j = 0; j < kJointCount; ++j)
    if (kXrParent[static_cast<size_t>(j)] >= 0) {
      const double r = bone(jit, j) / bone(in, j);
      CHECK(r >= 0.8 - 1e-9);
      CHECK(r <= 1.2 + 1e-9);
      changed = changed || std::abs(r - 1.0) > 0.01;
    }
  CHECK(changed);
  const auto only = [&](const Pose& out, Joint moved) {
    for (int j = 0; j < kJointCount; ++j)
      if (j != idx(moved)) CHECK((out.row(j) - in.row(j)).norm() == 0.0);
    return (out.row(idx(moved)) - in.row(idx(moved))).norm();
  };
  CHECK(only(bench::apply_shape(s, {"w", bench::ShapeKind::WristProximal, 0.02}, 1).pos[0], Joint::Wrist) ==
        doctest::Approx(0.02));
  CHECK(only(bench::apply_shape(s, {"p", bench::ShapeKind::PalmCentroid, 0.0}, 1).pos[0], Joint::Palm) > 0.001);
  CHECK(only(bench::apply_shape(s, {"t", bench::ShapeKind::ThumbBase, 0.3}, 1).pos[0], Joint::ThumbMetacarpal) ==
        doctest::Approx(0.3 * (in.row(idx(Joint::ThumbMetacarpal)) - in.row(idx(Joint::Wrist))).norm()));
}

TEST_CASE("irregular resampling: increasing times within 20 % of the grid, the truth interpolated there") {
  const HandSeries in = synth_series(10.0, 120.0, 2);
  const HandSeries out = hs::resample_series_jittered(in, 30.0, bench::kTimeJitter, 9);
  REQUIRE(out.size() > 280);
  CHECK(out.size() <= 301);
  double max_off = 0.0, mean_dt = (out.t.back() - out.t.front()) / static_cast<double>(out.size() - 1);
  bool irregular = false;
  for (size_t i = 0; i < out.size(); ++i) {
    if (i > 0) CHECK(out.t[i] > out.t[i - 1]);
    const double k = std::round((out.t[i] - in.t.front()) * 30.0);
    max_off = std::max(max_off, std::abs(out.t[i] - in.t.front() - k / 30.0) * 30.0);
    irregular = irregular || std::abs(out.t[i] - in.t.front() - k / 30.0) * 30.0 > 0.05;
    CHECK((out.pos[i] - interpolate_pose(in, out.t[i])).cwiseAbs().maxCoeff() == doctest::Approx(0.0));
  }
  CHECK(max_off <= 0.2 + 1e-9);
  CHECK(irregular);
  CHECK(mean_dt == doctest::Approx(1.0 / 30.0).epsilon(0.01));
}

TEST_CASE("the grid on synthetic motion: noise is what it says, filters are scored, the still measure can fail") {
  std::vector<bench::Dataset> sets(2);
  sets[0].name = "synth-tuning";
  sets[0].split = bench::Split::Tuning;
  add_hand_series(sets[0].clean, Hand::Right, synth_series(10.0, 120.0, 11));
  sets[1].name = "synth-test";
  sets[1].wide = true;
  add_hand_series(sets[1].clean, Hand::Right, synth_series(10.0, 120.0, 12));
  // A recording without truth: noisy motion at 30 Hz, scored against itself.
  bench::Dataset rec;
  rec.name = "synth-recorded";
  rec.has_truth = false;
  CorruptionConfig white;
  white.kind = CorruptionKind::Tracker;
  white.tracker.jitter_sd_m = 0.002;
  add_hand_series(rec.clean, Hand::Right, corrupt_series(synth_series(10.0, 30.0, 13), white, 5));
  sets.push_back(rec);
  bench::Options o;
  o.quick = true;
  bench::Report r;
  bench::tune_oneeuro(sets, o, r);
  CHECK(r.tuned.size() == bench::noise_grid(true).size() + 1);  // and the clean recording
  auto methods = bench::classical_methods(r.tuned);
  // A method that answers 5 mm off: the still-hand measure must see it.
  methods.push_back({"offset", [](const std::string&) {
                       struct Offset final : PoseFilter {
                         Pose last = untracked_pose();
                         double t = std::numeric_limits<double>::quiet_NaN();
                         void reset() noexcept override { t = std::numeric_limits<double>::quiet_NaN(); }
                         bool push(double tt, const Pose& p) noexcept override {
                           t = tt;
                           last = p;
                           return true;
                         }
                         void estimate(double, Pose& out) const noexcept override {
                           out = last;
                           out.col(0).array() += 0.005;
                         }
                         double last_time() const noexcept override { return t; }
                       };
                       return std::unique_ptr<PoseFilter>(std::make_unique<Offset>());
                     }});
  bench::run_grid(sets, methods, o, r);
  REQUIRE(!r.results.empty());
  CHECK(r.results.size() % methods.size() == 0);
  // A cell's result of one method in a report (a noise cell of r unless named).
  const auto find_in = [](const bench::Report& rep, const std::string& family, const std::string& method,
                          const std::string& block = "noise") -> const bench::Result* {
    for (const auto& x : rep.results)
      if (x.cell.block == block && x.cell.family == family && x.method == method) return &x;
    return nullptr;
  };
  const auto find = [&](const std::string& family, const std::string& method) { return find_in(r, family, method); };
  const auto* raw = find("white", "raw");
  const auto* kal = find("white", "kalman");
  const auto* oe = find("white", "oneeuro-tuned");
  REQUIRE(raw);
  REQUIRE(kal);
  REQUIRE(oe);
  // White noise of 1.5 mm per coordinate: mean distance 1.5 * sqrt(8 / pi) = 2.39 mm.
  CHECK(raw->at[0].mpjpe_mm == doctest::Approx(2.39).epsilon(0.08));
  CHECK(std::abs(raw->at[0].lag_ms) < 2.0);
  CHECK(kal->at[0].mpjpe_mm < raw->at[0].mpjpe_mm);
  CHECK(oe->at[0].mpjpe_mm < raw->at[0].mpjpe_mm);
  CHECK(raw->at[2].mpjpe_mm > raw->at[0].mpjpe_mm);  // holding the last sample 50 ms is worse
  bool rate = false, shape = false;
  for (const auto& x : r.results) {
    rate = rate || x.cell.block == "rate";
    shape = shape || x.cell.block == "shape";
  }
  CHECK(rate);
  CHECK(shape);
  // At the recording's own times: its own rows, not resampled; clean, raw is the truth.
  const auto native = [&](const std::string& family, const std::string& method) { return find_in(r, family, method, "native"); };
  const auto* raw_clean = native("clean", "raw");
  const auto* oe_clean = native("clean", "oneeuro");
  const auto* raw_white = native("white", "raw");
  REQUIRE(raw_clean);
  REQUIRE(oe_clean);
  REQUIRE(raw_white);
  REQUIRE(native("preset", "raw"));
  CHECK(raw_clean->cell.dataset == "synth-test");
  CHECK(raw_clean->cell.rate_hz == doctest::Approx(120.0));
  CHECK(raw_clean->at[0].frames == hand_series(sets[1].clean, Hand::Right).size());
  CHECK(raw_clean->at[0].mpjpe_mm == doctest::Approx(0.0));
  CHECK(oe_clean->at[0].mpjpe_mm > 0.01);  // a filter changes a clean input: what it adds is seen
  CHECK(raw_white->at[0].mpjpe_mm == doctest::Approx(2.39).epsilon(0.08));
  CHECK(raw_clean->at[2].mpjpe_mm > 1.0);  // holding the last sample 50 ms is not free
  bool saw_raw = false, saw_offset = false;
  for (const auto& s : r.still) {
    if (s.method == "raw") {
      saw_raw = true;
      CHECK(s.start_mm == doctest::Approx(0.0));
      CHECK(s.drift_mm == doctest::Approx(0.0));
    }
    if (s.method == "offset") {
      saw_offset = true;
      CHECK(s.start_mm == doctest::Approx(5.0));
      CHECK(s.resume_mm == doctest::Approx(5.0));
    }
  }
  CHECK(saw_raw);
  CHECK(saw_offset);
  const std::string md = bench::report_markdown(r, o);
  CHECK(md.find("## synth-test") != std::string::npos);
  CHECK(md.find("## Start and stillness") != std::string::npos);
  CHECK(md.find("## At the recordings' own times") != std::string::npos);
  CHECK(md.find("| synth-test | clean - | 120 |") != std::string::npos);
  // The summary's raw row: the mean of raw's MPJPE over the noise cells.
  double raw_sum = 0.0;
  int raw_n = 0;
  for (const auto& x : r.results)
    if (x.method == "raw" && x.cell.block == "noise") {
      raw_sum += x.at[0].mpjpe_mm;
      ++raw_n;
    }
  REQUIRE(raw_n > 0);
  CHECK_MESSAGE(md.find(fmt::format("| raw | {:.2f} |", raw_sum / raw_n)) != std::string::npos, md.substr(0, 1500));
  const auto j = nlohmann::json::parse(bench::report_json(r, o));
  CHECK(j["results"].size() == r.results.size());
  CHECK(bench::curve_csv(r).find("oneeuro-sweep") != std::string::npos);
  // The recording: One Euro and Kalman swept on it, from light to heavy smoothing.
  const auto* raw_rec = [&]() -> const bench::Result* {
    for (const auto& x : r.results)
      if (x.cell.block == "recorded" && x.method == "raw") return &x;
    return nullptr;
  }();
  REQUIRE(raw_rec);
  for (const std::string method : {"oneeuro", "kalman"}) {
    double least_lag = 1e9, most_lag = -1e9, least_jitter = 1e9;
    for (const auto& p : r.recorded_curves)
      if (p.method == method) {
        CHECK(p.cell == raw_rec->cell.key());
        least_lag = std::min(least_lag, p.lag_ms);
        most_lag = std::max(most_lag, p.lag_ms);
        least_jitter = std::min(least_jitter, p.jitter_mm);
      }
    CHECK_MESSAGE(most_lag > least_lag + 2.0, method, " lag ", least_lag, "..", most_lag);
    CHECK_MESSAGE(least_jitter < 0.8 * raw_rec->at[0].jitter_mm, method, " jitter ", least_jitter, " raw ", raw_rec->at[0].jitter_mm);
  }
  CHECK(md.find("| One Euro at this lag | Kalman at this lag |") != std::string::npos);
  CHECK(md.find("Sweeps (jitter_lag_synth-recorded.png)") != std::string::npos);
  CHECK(j["recorded_curves"].size() == r.recorded_curves.size());
  // Each curve holds the method's default row and raw's, as scored in the grid.
  for (const std::string method : {"oneeuro", "kalman"})
    for (const std::string& row : {method, std::string("raw")}) {
      const bench::Result* x = nullptr;
      for (const auto& y : r.results)
        if (y.cell.block == "recorded" && y.method == row) x = &y;
      REQUIRE(x);
      bool found = false;
      for (const auto& p : r.recorded_curves)
        found = found || (p.method == method && p.lag_ms == x->at[0].lag_ms && p.jitter_mm == x->at[0].jitter_mm);
      CHECK_MESSAGE(found, method, " curve lacks the row ", row);
    }
  // Occluded joints: outliers jump 10-50 mm, so raw's error on them is large, on no other
  // joint of those rows; white noise of 1.5 mm displaces (almost) no joint by 10 mm.
  const auto* raw_out = find("outliers", "raw");
  const auto* offset_out = find("outliers", "offset");
  REQUIRE(raw_out);
  REQUIRE(offset_out);
  REQUIRE(raw_out->occluded.joint_samples > 0);
  CHECK(raw_out->occluded.mpjpe_mm > 10.0);
  CHECK(raw_out->occluded.mpjpe_mm > 3.0 * raw_out->at[0].mpjpe_mm);
  CHECK(offset_out->occluded.joint_samples == raw_out->occluded.joint_samples);
  CHECK(raw->occluded.joint_samples < raw->at[0].joint_samples / 1000 + 1);
  CHECK(md.find("## Occluded joints") != std::string::npos);
  // The tuning split scored instead (for choosing a method's constants): its set only.
  bench::Options ot = o;
  ot.tuning_split = true;
  bench::Report rt;
  rt.tuned = r.tuned;
  bench::run_grid(sets, bench::classical_methods(rt.tuned), ot, rt);
  REQUIRE(!rt.results.empty());
  for (const auto& x : rt.results) CHECK(x.cell.dataset == "synth-tuning");
  CHECK(rt.tuning_split);
  const std::string mdt = bench::report_markdown(rt, ot);
  CHECK(mdt.find("Scored on the tuning split") != std::string::npos);
  CHECK(mdt.find("noise cells of the tuning sets") != std::string::npos);
  CHECK(md.find("Scored on the tuning split") == std::string::npos);
  // At another input rate (--rate): the sets with truth resampled to it, the recording not.
  auto sets30 = sets;
  bench::use_rate(sets30, 30.0);
  bench::Report r30;
  r30.tuned = r.tuned;
  bench::run_grid(sets30, bench::classical_methods(r30.tuned), o, r30);
  size_t noise30 = 0;
  for (const auto& x : r30.results) {
    if (x.cell.block == "noise") {
      CHECK(x.cell.rate_hz == 30.0);
      ++noise30;
    }
    if (x.cell.block == "recorded") CHECK(x.cell.rate_hz == 0.0);
  }
  CHECK(noise30 > 0);
  const auto* raw30 = find_in(r30, "white", "raw");
  REQUIRE(raw30);
  CHECK(raw30->cell.dataset == raw->cell.dataset);
  CHECK(raw->cell.rate_hz != 30.0);
  CHECK(raw30->at[0].frames * 2 < raw->at[0].frames);  // a third of the rows of the 90 Hz grid
}

TEST_CASE("jitter at equal lag: the lower envelope of a sweep, interpolated, held at its ends") {
  const std::vector<std::pair<double, double>> pts = {{0.0, 5.0}, {8.0, 3.5}, {2.0, 4.8}, {20.0, 2.0}, {10.0, 4.0}, {30.0, 2.5}};
  CHECK(bench::jitter_at_lag(pts, 4.0) == doctest::Approx(4.8 + (3.5 - 4.8) * 2.0 / 6.0));
  CHECK(bench::jitter_at_lag(pts, 8.0) == doctest::Approx(3.5));
  CHECK(bench::jitter_at_lag(pts, 14.0) == doctest::Approx(3.5 + (2.0 - 3.5) * 6.0 / 12.0));  // (10, 4) is above the envelope
  CHECK(bench::jitter_at_lag(pts, 50.0) == doctest::Approx(2.0));  // (30, 2.5) reaches nothing new
  CHECK(bench::jitter_at_lag(pts, -1.0) == doctest::Approx(5.0));
  CHECK(std::isnan(bench::jitter_at_lag({}, 4.0)));
  CHECK(bench::jitter_at_lag({{std::nan(""), 1.0}, {1.0, 3.0}}, 4.0) == doctest::Approx(3.0));
}

TEST_CASE("the recordings-without-truth criterion compares a model with One Euro and Kalman at its own lag") {
  // A recording where the model has 4 ms of lag: One Euro's defaults reach less jitter but
  // at 20 ms; its sweep reaches 4.37 mm at 4 ms, Kalman 4.5 mm.
  bench::Report r;
  r.methods = {"raw", "oneeuro", "kalman", "model"};
  r.models = {"model"};
  const bench::Cell cell{"recorded", "rec", "recorded", "-", "-", 0.0, 0.0};
  const auto add = [&](const std::string& method, double lag_ms, double jitter_mm) {
    bench::Result x;
    x.cell = cell;
    x.method = method;
    for (auto& m : x.at) {
      m.lag_ms = lag_ms;
      m.jitter_mm = jitter_mm;
      m.truth_jitter_mm = 5.0;
    }
    r.results.push_back(x);
  };
  add("raw", 0.0, 5.0);
  add("oneeuro", 20.0, 2.0);
  add("kalman", 4.0, 4.5);
  // Each curve: its sweep, its default row and raw's (as run_grid records them).
  for (const auto& [lag, jit] : {std::pair{2.0, 4.8}, std::pair{8.0, 3.5}, std::pair{20.0, 2.0}, std::pair{0.0, 5.0}})
    r.recorded_curves.push_back({cell.key(), "oneeuro", "swept", jit, lag});
  for (const auto& [lag, jit] : {std::pair{1.0, 4.9}, std::pair{4.0, 4.5}, std::pair{0.0, 5.0}})
    r.recorded_curves.push_back({cell.key(), "kalman", "swept", jit, lag});
  const auto criterion = [&](double model_jitter) {
    bench::Report rm = r;
    bench::Result x = rm.results.back();
    x.method = "model";
    for (auto& m : x.at) m.jitter_mm = model_jitter;
    for (auto& m : x.at) m.lag_ms = 4.0;
    rm.results.push_back(x);
    const std::string md = bench::report_markdown(rm, bench::Options{});
    const auto at = md.find("| recordings without truth");
    REQUIRE(at != std::string::npos);
    return md.substr(at, md.find('\n', at) - at);
  };
  const std::string pass = criterion(4.2), fail = criterion(4.4);
  CHECK_MESSAGE(pass.find("**pass** 2/2") != std::string::npos, pass);
  CHECK_MESSAGE(fail.find("**fail** 1/2") != std::string::npos, fail);
  CHECK_MESSAGE(fail.find("rec vs oneeuro at 4.0 ms") != std::string::npos, fail);
}

TEST_CASE("recordings added to benchmark/ are read by their kind, anything else is named in a note") {
  namespace fs = std::filesystem;
  const fs::path data = test::temp_dir("benchmark_extra");
  const fs::path extra = data / "benchmark";
  fs::create_directories(extra / "takes");
  fs::create_directories(extra / "fpha_subject" / "act" / "1");
  Track one;
  add_hand_series(one, Hand::Right, synth_series(2.0, 60.0, 21));
  write_track_csv(one, extra / "a_track.csv");
  write_track_csv(one, extra / "takes" / "t1.csv");
  write_track_csv(one, extra / "takes" / "t2.csv");
  write_track_csv(one, extra / "takes.csv");  // the folder's set name again
  fs::copy_file(test::fixture("mrtk_small.csv"), extra / "hl.csv");
  {
    std::ofstream fpha(extra / "fpha_subject" / "act" / "1" / "skeleton.txt");
    for (int f = 0; f < 3; ++f) {
      fpha << f;
      for (int j = 0; j < 21; ++j) fpha << fmt::format(" {:.1f} {:.1f} {:.1f}", 10.0 * j + f, 100.0 + j, 300.0 + 2.0 * j);
      fpha << '\n';
    }
    std::ofstream(extra / "notes.txt") << "not a recording\n";
    fs::create_directories(data / "newsensor");  // beside the known sets, not in benchmark/
    std::ofstream(data / "README.md") << "the data's own description\n";
    std::ofstream(extra / "bad.bvh") << "HIERARCHY\nnonsense\n";
  }
  std::vector<std::string> notes;
  const std::vector<bench::Dataset> sets = bench::load_datasets(data, false, notes);
  std::map<std::string, const bench::Dataset*> by;
  for (const auto& d : sets) by[d.name] = &d;
  std::string all_notes;
  for (const auto& n : notes) all_notes += n + "\n";
  INFO(all_notes);
  REQUIRE(by.size() == 4);
  for (const char* name : {"extra-a_track", "extra-takes", "extra-fpha_subject", "extra-hl"}) {
    REQUIRE_MESSAGE(by.count(name) == 1, name);
    CHECK(by[name]->split == bench::Split::Test);
    CHECK(!by[name]->clean.rows.empty());
  }
  CHECK(by["extra-a_track"]->has_truth);
  CHECK(by["extra-takes"]->has_truth);
  CHECK(by["extra-takes"]->clean.rows.size() > 2 * one.rows.size());  // both takes, a lost row between
  CHECK(by["extra-fpha_subject"]->has_truth);
  CHECK_FALSE(by["extra-hl"]->has_truth);  // a HoloLens 2 export: scored against itself
  CHECK(all_notes.find("benchmark/notes.txt skipped: not a recording the benchmark reads") != std::string::npos);
  CHECK(all_notes.find("extra-bad skipped") != std::string::npos);
  CHECK(all_notes.find("benchmark/takes.csv skipped: a set named extra-takes was read already") != std::string::npos);
  CHECK(all_notes.find("newsensor not read: ") != std::string::npos);
  CHECK(all_notes.find("README") == std::string::npos);
  fs::remove_all(data);
}

TEST_CASE("handsteady benchmark refuses two models under one label before reading any data") {
  const auto dir = test::temp_dir("benchmark_labels");
  const std::string err = (dir / "err.txt").string();
  const auto refused = [&](const std::string& models) {
    // --data names no folder: the labels are checked first, so the message is theirs.
    const int rc = test::run_cli("benchmark --data /nonexistent --out \"" + dir.string() + "\" " + models + " 2> \"" + err + "\"");
    return rc != 0 ? slurp(err) : std::string("exit status 0");
  };
  CHECK_MESSAGE(refused("--no-default-model --model a=x.hsm --model a=y.hsm").find("'a' is given twice") != std::string::npos,
                slurp(err));
  CHECK_MESSAGE(refused("--model multistgae=x.hsm").find("'multistgae' is a shipped model's") != std::string::npos, slurp(err));
  CHECK_MESSAGE(refused("--no-default-model --model kalman=x.hsm").find("'kalman' is a baseline's") != std::string::npos,
                slurp(err));
  // The case each differs from: distinct labels pass the check and meet the missing folder.
  CHECK_MESSAGE(refused("--no-default-model --model a=x.hsm --model b=y.hsm").find("/nonexistent") != std::string::npos,
                slurp(err));
  CHECK_MESSAGE(refused("--no-default-model --model multistgae=x.hsm").find("/nonexistent") != std::string::npos, slurp(err));
  std::filesystem::remove_all(dir);
}

TEST_CASE("handsteady benchmark --quick on the shared recordings writes the report") {
  HS_SKIP_WITHOUT_SHARED_DATA();
  if (HS_SANITIZED) {
    MESSAGE("skipped in sanitizer builds (the grid runs the model over every cell)");
    return;
  }
  const auto dir = test::temp_dir("benchmark");
  REQUIRE(test::run_cli("benchmark --quick --data \"" + test::shared_data().string() + "\" --out \"" + dir.string() +
                        "\" > /dev/null") == 0);
  const std::string md = slurp(dir / "benchmark.md");
  for (const char* set : {"fpha-s5", "manipnet-mug3", "leap-gestures-s04", "leap-handwriting"})
    CHECK_MESSAGE(md.find(std::string("## ") + set) != std::string::npos, set);
  CHECK(md.find("**hololens2**") != std::string::npos);
  CHECK(md.find("| One Euro at this lag | Kalman at this lag |") != std::string::npos);
  CHECK(md.find("## Criteria") != std::string::npos);
  const auto j = nlohmann::json::parse(slurp(dir / "benchmark.json"));
  CHECK(j["results"].size() > 100);
  CHECK(!j["oneeuro_curve"].empty());
  CHECK(!j["recorded_curves"].empty());
  // The report names the code it was made with, as `handsteady --version` does.
  const std::string revision = j["revision"].get<std::string>();
  CHECK(!revision.empty());
  CHECK(md.find("at revision `" + revision + "`") != std::string::npos);
  REQUIRE(test::run_cli("--version > \"" + (dir / "version.txt").string() + "\"") == 0);
  CHECK(slurp(dir / "version.txt").find("(revision " + revision + ")") != std::string::npos);
  CHECK(test::run_cli("benchmark --quick --data /nonexistent --out \"" + dir.string() + "\" 2> /dev/null") != 0);
  std::filesystem::remove_all(dir);
}
