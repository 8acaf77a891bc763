// handsteady benchmark: the project's quality benchmark (docs/BENCHMARK.md). Scores the
// classical filters and any number of models on a fixed, seeded grid and writes
// benchmark.md, benchmark.json and curve.csv to --out.
#include "commands.hpp"

#include "handsteady/benchmark.hpp"
#include "handsteady/error.hpp"
#include "handsteady/model_path.hpp"
#include "handsteady/source_revision.hpp"
#include "handsteady/stgae_model.hpp"
#ifdef HS_HAVE_HANDWRITING
#include "handsteady/handwriting.hpp"
#endif

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace hs::cli {
namespace {

namespace fs = std::filesystem;

struct BenchmarkOptions {
  std::string data = "../shared/data";
  std::string out;
  std::vector<std::string> models;  // LABEL=FILE.hsm
  bool no_default_model = false;
  bool quiet = false;  // no progress lines on stderr
  bool unbounded = false;  // also each model without its trust region
  bool gain = false;       // also each model with its correction gain at every rate
  bool no_gain = false;    // also each model without it
  bool no_guard = false;   // also each model without its oscillation guard
  bool smoothed = false;   // also each model with its prediction smoothing
  bool palm_fit = false;   // also raw and tuned One Euro behind the palm fit, and each model without it
  bool tremor = false;     // also raw and tuned One Euro behind the palm fit and tremor canceller, each model with it
  bool bone_fit = false;   // also raw and tuned One Euro with the bone fit behind them, and each model without it
  bench::Options run;
};

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) throw InputError({path.string(), 0, "--out"}, "cannot write");
}

// The shipped models of every family, under the labels their rows take.
constexpr std::array<std::pair<std::string_view, std::string_view>, 3> kShippedModels{
    {{"multistgae", kDefaultModelFile}, {"stgae", kStgaeModelFile}, {"dgn", kDgnModelFile}}};

// The --model specs as (label, files), before any data is read. A label names one row of
// every table: two models under one label would be two rows no reader could tell apart.
std::vector<std::pair<std::string, fs::path>> model_specs(const BenchmarkOptions& o) {
  std::vector<std::pair<std::string, fs::path>> model_files;
  const auto baselines = bench::classical_methods({});
  for (const auto& spec : o.models) {
    const auto eq = spec.find('=');
    if (eq == std::string::npos || eq == 0) throw InputError({"", 0, "--model"}, "expects LABEL=FILE.hsm, got '" + spec + "'");
    std::string label = spec.substr(0, eq);
    for (const auto& [seen, file] : model_files)
      if (seen == label) throw InputError({"", 0, "--model"}, "the label '" + label + "' is given twice; each model needs its own");
    if (!o.no_default_model && std::any_of(kShippedModels.begin(), kShippedModels.end(), [&](const auto& m) { return m.first == label; }))
      throw InputError({"", 0, "--model"}, "the label '" + label +
                                               "' is a shipped model's; name this model otherwise, or pass --no-default-model");
    for (const auto& m : baselines)
      if (m.name == label) throw InputError({"", 0, "--model"}, "the label '" + label + "' is a baseline's; name this model otherwise");
    model_files.emplace_back(std::move(label), spec.substr(eq + 1));
  }
  return model_files;
}

void run_benchmark(const BenchmarkOptions& o, const std::string& command) {
  auto model_files = model_specs(o);
  if (!fs::is_directory(o.data)) throw InputError({o.data, 0, "--data"}, "not a folder (the shared recordings)");
  const auto t_start = std::chrono::steady_clock::now();
  bench::Report report;
  report.command = command;
  report.revision = hs::source_revision();
  bench::Options run = o.run;
  std::mutex progress_mu;
  if (!o.quiet)
    run.progress = [&progress_mu, t_start](const std::string& line) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
      std::lock_guard lock(progress_mu);
      fmt::print(stderr, "benchmark [{:5.0f} s] {}\n", s, line);
    };
  if (run.progress) run.progress("loading the recordings");
  auto sets = bench::load_datasets(o.data, o.run.quick, report.notes);
#ifdef HS_HAVE_HANDWRITING
  try {  // synthetic handwriting: truth by construction, writing motion at 60 Hz
    HandwritingParams p;
    p.text = o.run.quick ? "Steady" : "Steady hands write";
    p.noise = TrackerNoise::None;
    p.tremor = TremorKind::None;
    bench::Dataset d;
    d.name = "synth-handwriting";
    d.clean = synth_handwriting(p).clean;
    d.rate_hz = 90.0;
    d.source = fmt::format("synth-handwriting \"{}\" (60 Hz, clean)", p.text);
    sets.push_back(std::move(d));
  } catch (const std::exception& e) {
    report.notes.push_back(std::string("synth-handwriting skipped: ") + e.what());
  }
#else
  report.notes.push_back("synth-handwriting skipped: built without libhersheyfont-dev");
#endif
  bench::use_rate(sets, o.run.rate_hz);
  if (!o.no_default_model) {
    // The shipped models of every family, so that one run compares them all.
    for (const auto& [label, file] : kShippedModels) {
      const auto lookup = lookup_default_model({installed_models_dir_for_executable()}, file);
      if (!lookup.found.empty()) model_files.emplace_back(std::string(label), lookup.found);
      else report.notes.push_back("no shipped " + std::string(label) + " model found (" + lookup.describe_tried() + ")");
    }
  }
  bench::tune_oneeuro(sets, run, report);
  auto methods = bench::classical_methods(report.tuned);
  const auto classical = static_cast<std::ptrdiff_t>(methods.size());
  for (const auto& [label, spec] : model_files) {
    // FILE.hsm, or FILE.hsm+FILE2.hsm...: models for different input rates (rate_choice.hpp).
    std::vector<std::shared_ptr<const StgaeModel>> models;
    const std::string files = spec.string();
    for (size_t from = 0; from <= files.size();) {
      const size_t plus = std::min(files.find('+', from), files.size());
      const std::string file = files.substr(from, plus - from);
      if (file.empty()) throw InputError({"", 0, "--model"}, "expects LABEL=FILE.hsm[+FILE.hsm...], got '" + files + "'");
      models.push_back(load_hsm(file));  // InputError naming the file
      if (models.back()->config.padding != StgaePadding::Causal)
        throw InputError({file, 0, "--model"}, "a centred model cannot stream; the benchmark runs causally");
      from = plus + 1;
    }
    FilterConfig c;
    c.method = network_method(*models.front());
    c.stgae.model = models.front();
    c.stgae.rate_models.assign(models.begin() + 1, models.end());
    c.stgae.source = files;
    try {
      (void)make_filter(c);  // the models fit together (family, distinct rates)
    } catch (const std::invalid_argument& e) {
      throw InputError({files, 0, "--model"}, e.what());
    }
    // The model's row, then each asked-for variant of it (LABEL-suffix): c changed by `vary`.
    const auto add = [&](const std::string& suffix, auto vary) {
      FilterConfig v = c;
      vary(v);
      methods.push_back({label + suffix, [v](const std::string&) { return make_filter(v); }, true});
    };
    add("", [](FilterConfig&) {});
    if (o.palm_fit) add("-nopalmfit", [](FilterConfig& v) { v.palm_fit = false; });
    if (o.bone_fit) add("-nobonefit", [](FilterConfig& v) { v.bone_fit = false; });
    if (o.gain) add("-gain", [](FilterConfig& v) { v.stgae.gain = true; });
    if (o.no_gain) add("-nogain", [](FilterConfig& v) { v.stgae.gain = false; });
    if (o.smoothed) add("-smoothed", [](FilterConfig& v) { v.stgae.smooth = true; });
    if (o.no_guard) add("-noguard", [](FilterConfig& v) { v.stgae.guard = false; });
    if (o.unbounded) add("-unbounded", [](FilterConfig& v) { v.stgae.bounded = false; });
    if (o.tremor) add("-tremor", [](FilterConfig& v) { v.tremor_cancel = true; });
    report.notes.push_back(fmt::format("model {} = {}", label, files));
  }
  if (o.palm_fit) {  // the fit alone, in front of the plain baselines
    std::vector<bench::Method> fitted;
    for (const auto& m : methods)
      if (m.name == "raw" || m.name == "oneeuro-tuned")
        fitted.push_back({m.name + "-palmfit", [make = m.make](const std::string& key) { return with_palm_fit(make(key)); }});
    methods.insert(methods.begin() + classical, fitted.begin(), fitted.end());
  }
  if (o.bone_fit) {  // the bone fit alone, behind the plain baselines
    std::vector<bench::Method> fitted;
    for (const auto& m : methods)
      if (m.name == "raw" || m.name == "oneeuro-tuned")
        fitted.push_back({m.name + "-bonefit", [make = m.make](const std::string& key) { return with_bone_fit(make(key)); }});
    methods.insert(methods.begin() + classical, fitted.begin(), fitted.end());
  }
  if (o.tremor) {  // the canceller alone (behind the palm fit), in front of the plain baselines
    std::vector<bench::Method> cancelled;
    for (const auto& m : methods)
      if (m.name == "raw" || m.name == "oneeuro-tuned")
        cancelled.push_back({m.name + "-tremor", [make = m.make](const std::string& key) {
                               return with_palm_fit(with_tremor_cancel(make(key)));
                             }});
    methods.insert(methods.begin() + classical, cancelled.begin(), cancelled.end());
  }
  for (auto m = methods.begin(); m != methods.end(); ++m)  // a label like "raw", or "A-nobonefit" beside --bone-fit
    if (std::any_of(methods.begin(), m, [&](const bench::Method& e) { return e.name == m->name; }))
      throw InputError({"", 0, "--model"}, "two rows would be named '" + m->name + "'; give the model another label");
  bench::run_grid(sets, methods, run, report);
  report.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  fs::create_directories(o.out);
  write_text(fs::path(o.out) / "benchmark.md", bench::report_markdown(report, o.run));
  write_text(fs::path(o.out) / "benchmark.json", bench::report_json(report, o.run));
  write_text(fs::path(o.out) / "curve.csv", bench::curve_csv(report));
  fmt::print("{} results in {:.0f} s ({:.0f} s the grid): {}/benchmark.md, benchmark.json, curve.csv\n",
             report.results.size(), report.total_seconds, report.seconds, o.out);
}

void setup_benchmark(CLI::App& app) {
  auto o = std::make_shared<BenchmarkOptions>();
  auto* sub = app.add_subcommand("benchmark", "Score filters and models on the project's fixed, seeded grid (docs/BENCHMARK.md)");
  sub->add_option("--data", o->data, "The shared recordings folder")->capture_default_str();
  sub->add_option("--out", o->out, "Folder for benchmark.md, benchmark.json, curve.csv")->required();
  sub->add_option("--model", o->models, "LABEL=FILE.hsm, a causal model to score (repeatable; each its own label, none a shipped model's or a baseline's); LABEL=A.hsm+B.hsm: models at different frame rates, "
                "each input run by the one whose rate suits it (docs/STGAE.md \"Models by input rate\")");
  sub->add_flag("--quiet", o->quiet, "No progress lines on stderr (stages, and the scoring every 10 %)");
  sub->add_flag("--no-default-model", o->no_default_model, "Do not add the shipped models (labels multistgae, stgae, dgn)");
  sub->add_flag("--palm-fit", o->palm_fit,
                "Also score raw and tuned One Euro behind the palm fit (raw-palmfit, oneeuro-tuned-palmfit) and each "
                "model without it (LABEL-nopalmfit; docs/FILTERS.md \"Palm fit\")");
  sub->add_flag("--bone-fit", o->bone_fit,
                "Also score raw and tuned One Euro with the bone fit behind them (raw-bonefit, oneeuro-tuned-bonefit) "
                "and each model without it (LABEL-nobonefit; docs/FILTERS.md \"Bone fit\")");
  sub->add_flag("--tremor-cancel", o->tremor,
                "Also score raw and tuned One Euro behind the palm fit and the tremor canceller (raw-tremor, "
                "oneeuro-tuned-tremor) and each model with the canceller (LABEL-tremor; docs/FILTERS.md \"Tremor canceller\")");
  sub->add_flag("--gain", o->gain,
                "Also score each model with its correction gain at every input rate (label LABEL-gain; the default "
                "applies it to input faster than the model or 10-25 % slower; docs/STGAE.md \"Correction gain\")");
  sub->add_flag("--no-gain", o->no_gain,
                "Also score each model without its correction gain (label LABEL-nogain)");
  sub->add_flag("--no-guard", o->no_guard,
                "Also score each model without its oscillation guard (label LABEL-noguard; docs/STGAE.md "
                "\"Oscillation guard\")");
  sub->add_flag("--unbounded", o->unbounded,
                "Also score each model without its trust region (label LABEL-unbounded; docs/STGAE.md)");
  sub->add_flag("--smoothed", o->smoothed,
                "Also score each model with its prediction smoothing (label LABEL-smoothed; docs/STGAE.md "
                "\"Prediction smoothing\")");
  sub->add_flag("--tuning-split", o->run.tuning_split,
                "Score the tuning sets instead of the test sets (for choosing a method's constants; docs/BENCHMARK.md)");
  sub->add_option("--rate", o->run.rate_hz,
                  "Score every set with truth at this input rate (Hz) instead of its own (30 for FPHA, 90 for the "
                  "others); recordings without truth stay as recorded")
      ->check(CLI::Range(5.0, 500.0));
  sub->add_flag("--quick", o->run.quick, "The CI subset: ~20 s of each set, one strength per family");
  sub->add_option("--threads", o->run.threads, "Worker threads")->capture_default_str()->check(CLI::Range(1, 64));
  sub->add_option("--seed", o->run.seed, "Seed of every corruption and timing jitter")->capture_default_str();
  sub->callback([o, sub] {
    std::string command = "handsteady benchmark";
    for (const auto& a : sub->get_options())
      if (a->count() > 0 && a->get_name() != "--help") {
        command += " " + a->get_name();
        if (a->get_expected_min() > 0)
          for (const auto& v : a->results()) command += " " + v;
      }
    run_benchmark(*o, command);
  });
}

const CommandRegistration register_benchmark(&setup_benchmark);

}  // namespace
}  // namespace hs::cli
