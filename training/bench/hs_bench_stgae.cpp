// Multi-STGAE benchmark (issue 3, §7), one run, one core:
//   fma_peak/...        the core's FMA peak (independent FMA chains, fma_peak.cpp)
//   eigen_stream_frame  StgaeStream<float>::push, one hand, per frame, after warm-up
//   eigen_window/T      stgae_window_forward<float> over one window of T frames
//   torch_window/T      the libtorch forward of the same weights on the same window
// each with a FLOP/s counter (FLOPs from hs::stgae_flops_*). After Google Benchmark, a
// manual loop times every push of 20k frames (p50/p99) and the window forwards, and a
// summary table gives the times, ratios, GFLOP/s, fraction of the FMA peak and whether the
// 0.2 ms per frame per hand target is met. The process is pinned to one CPU
// (sched_setaffinity) before anything runs.
//
// Own options (before Google Benchmark's --benchmark_* flags):
//   --model=PATH          default: hs::default_model_path() (the shipped causal model)
//   --cpu=N               CPU to pin to (default: the allowed CPU idlest over 0.3 s)
//   --stream_frames=N     frames of the manual streaming loop (default 20000)
//   --window_reps=N       repetitions of the manual window loops (default 1000)
#include "fma_peak.hpp"
#include "torch_window.hpp"

#include "handsteady/correction_bound.hpp"
#include "handsteady/corrupt.hpp"
#include "handsteady/model_path.hpp"
#include "handsteady/stgae_engine.hpp"
#include "handsteady/stgae_flops.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/synth.hpp"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <sched.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace hs;
using namespace hs::bench;

// ---------------------------------------------------------------- set-up

struct Setup {
  std::filesystem::path model_path;
  std::shared_ptr<const StgaeModel> model;
  int n = 0, T = 0;
  std::vector<float> stream;   // frames x 3N, raw positions of one hand (tracker noise)
  long stream_frames = 0;
  std::vector<Pose> window;    // T raw poses (a window out of the same track)
  StgaeFrames<float> window_in;
  StgaeFlops flops_frame, flops_window;
};
Setup g;

constexpr long kWarmupFrames = 200;  // > T, fills every ring buffer and the caches

void make_inputs(long frames) {
  const StgaeConfig& c = g.model->config;
  SynthMotionParams p;
  p.rate_hz = c.rate_hz;
  p.duration_s = static_cast<double>(frames + 1) / c.rate_hz;
  const HandSeries clean = synth_motion(p, Hand::Right, 7);
  const HandSeries raw = corrupt_series(clean, corruption_preset("tracker"), 7);
  g.stream_frames = std::min<long>(frames, static_cast<long>(raw.size()));
  g.stream.resize(static_cast<size_t>(g.stream_frames) * static_cast<size_t>(3 * g.n));
  for (long t = 0; t < g.stream_frames; ++t)
    for (int j = 0; j < g.n; ++j)
      for (int k = 0; k < 3; ++k)
        g.stream[static_cast<size_t>((t * g.n + j) * 3 + k)] = static_cast<float>(raw.pos[static_cast<size_t>(t)](j, k));
  // The benchmark window: T frames after the warm-up part, first frame fully tracked.
  long start = kWarmupFrames;
  while (start + g.T < g.stream_frames && tracked_joint_count(raw.pos[static_cast<size_t>(start)]) < g.n) ++start;
  g.window.assign(raw.pos.begin() + start, raw.pos.begin() + start + g.T);
  g.window_in.resize(g.T, 3 * g.n);
  for (int t = 0; t < g.T; ++t)
    for (int j = 0; j < g.n; ++j)
      for (int k = 0; k < 3; ++k) g.window_in(t, 3 * j + k) = static_cast<float>(g.window[static_cast<size_t>(t)](j, k));
}

std::span<const float> frame(long t) {
  const auto fs = static_cast<size_t>(3 * g.n);
  return {g.stream.data() + static_cast<size_t>(t % g.stream_frames) * fs, fs};
}

// ---------------------------------------------------------------- pinning, machine

std::vector<int> allowed_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  std::vector<int> cpus;
  if (sched_getaffinity(0, sizeof set, &set) != 0) return cpus;
  for (int i = 0; i < CPU_SETSIZE; ++i)
    if (CPU_ISSET(i, &set)) cpus.push_back(i);
  return cpus;
}

// Idle jiffies per CPU from /proc/stat.
std::map<int, long long> idle_jiffies() {
  std::map<int, long long> idle;
  std::ifstream f("/proc/stat");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("cpu", 0) != 0 || line.size() < 4 || !std::isdigit(static_cast<unsigned char>(line[3]))) continue;
    std::istringstream s(line.substr(3));
    int cpu = 0;
    long long user = 0, nice = 0, sys = 0, idl = 0, iowait = 0;
    s >> cpu >> user >> nice >> sys >> idl >> iowait;
    idle[cpu] = idl + iowait;
  }
  return idle;
}

int idlest_cpu(const std::vector<int>& cpus) {
  const auto a = idle_jiffies();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto b = idle_jiffies();
  int best = cpus.empty() ? 0 : cpus.back();
  long long best_idle = -1;
  for (int c : cpus) {
    const auto ia = a.find(c), ib = b.find(c);
    if (ia == a.end() || ib == b.end()) continue;
    if (ib->second - ia->second > best_idle) {
      best_idle = ib->second - ia->second;
      best = c;
    }
  }
  return best;
}

bool pin_to(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return sched_setaffinity(0, sizeof set, &set) == 0;
}

std::string cpuinfo_field(const std::string& key) {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind(key, 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(std::min(line.size(), colon + 2));
    }
  return "?";
}

std::string loadavg() {
  std::ifstream f("/proc/loadavg");
  std::string a, b, c;
  f >> a >> b >> c;
  return a + " " + b + " " + c;
}

std::string compiled_isa() {
  std::string s;
#ifdef __AVX512F__
  s += "avx512f ";
#endif
#ifdef __AVX2__
  s += "avx2 ";
#endif
#ifdef __FMA__
  s += "fma ";
#endif
#ifdef __SSE2__
  s += "sse2";
#endif
  return s.empty() ? "generic" : s;
}

std::string join(const std::vector<int>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? "," : "") + std::to_string(v[i]);
  return s;
}

std::string describe(const StgaeConfig& c) {
  const char* att = c.attention == StgaeAttention::A ? "A" : c.attention == StgaeAttention::AB ? "A+B" : "A+B+C";
  std::string s = fmt::format("{}, T={}, DT={}, kt={}, enc [{}], den [{}], pre [{}], {}", c.skeleton, c.window,
                              c.predict ? c.horizon : 0, c.temporal_kernel, fmt::join(c.encoder_channels, ","),
                              fmt::join(c.denoise_decoder_channels, ","), fmt::join(c.predict_decoder_channels, ","),
                              att);
  if (c.attention == StgaeAttention::ABC) s += c.c_variant == StgaeCVariant::Dot ? " dot" : " gat";
  s += c.gates ? ", gates" : ", no gates";
  s += c.padding == StgaePadding::Causal ? ", causal" : ", centred";
  return s;
}

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// ---------------------------------------------------------------- benchmarks

constexpr std::int64_t kFmaRounds = 1 << 16;

void bm_fma(benchmark::State& state, FmaIsa isa, FmaType type) {
  for (auto _ : state) benchmark::DoNotOptimize(fma_kernel(isa, type, kFmaRounds));
  state.counters["FLOP/s"] = benchmark::Counter(static_cast<double>(fma_flops_per_round(isa, type) * kFmaRounds),
                                                benchmark::Counter::kIsIterationInvariantRate);
}

void bm_eigen_stream(benchmark::State& state) {
  StgaeStream<float> s(g.model->net);
  long t = 0;
  for (; t < kWarmupFrames; ++t) s.push(frame(t));
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.push(frame(t++)));
    benchmark::DoNotOptimize(s.denoised().data());
    benchmark::ClobberMemory();
  }
  state.counters["FLOP/s"] = benchmark::Counter(static_cast<double>(g.flops_frame.total()),
                                                benchmark::Counter::kIsIterationInvariantRate);
}

// The trust region the streaming adapter puts on each stream step (correction_bound.hpp):
// inputs and network paths recorded from the stream, replayed; the copy of the path
// (312 floats) that apply() rewrites is inside the timing.
void bm_trust_region(benchmark::State& state) {
  const auto& c = g.model->config;
  const int F = 1 + (c.predict ? c.horizon : 0);
  const size_t fs = static_cast<size_t>(3 * g.n);
  constexpr long kRecorded = 256;
  StgaeStream<float> s(g.model->net);
  for (long t = 0; t < kWarmupFrames; ++t) s.push(frame(t));
  std::vector<float> paths(static_cast<size_t>(kRecorded) * static_cast<size_t>(F) * fs);
  for (long t = 0; t < kRecorded; ++t) {
    s.push(frame(kWarmupFrames + t));
    float* p = paths.data() + static_cast<size_t>(t) * static_cast<size_t>(F) * fs;
    std::copy(s.denoised().begin(), s.denoised().end(), p);
    for (int i = 0; i + 1 < F; ++i) std::copy(s.predicted(i).begin(), s.predicted(i).end(), p + static_cast<size_t>(i + 1) * fs);
  }
  CorrectionBound b(F);
  std::vector<float> path(static_cast<size_t>(F) * fs);
  long t = 0;
  for (auto _ : state) {
    const long k = t++ % kRecorded;
    const float* src = paths.data() + static_cast<size_t>(k) * static_cast<size_t>(F) * fs;
    std::copy(src, src + path.size(), path.begin());
    b.apply(frame(kWarmupFrames + k), path);
    benchmark::DoNotOptimize(path.data());
    benchmark::ClobberMemory();
  }
}

void bm_eigen_window(benchmark::State& state) {
  for (auto _ : state) {
    auto out = stgae_window_forward(*g.model->net, g.window_in);
    benchmark::DoNotOptimize(out.denoised.data());
    benchmark::DoNotOptimize(out.predicted.data());
    benchmark::ClobberMemory();
  }
  state.counters["FLOP/s"] = benchmark::Counter(static_cast<double>(g.flops_window.total()),
                                                benchmark::Counter::kIsIterationInvariantRate);
}

std::unique_ptr<TorchWindow> g_torch;

void bm_torch_window(benchmark::State& state) {
  for (int i = 0; i < 10; ++i) g_torch->forward();  // warm-up (allocator, dispatch caches)
  for (auto _ : state) {
    g_torch->forward();
    benchmark::ClobberMemory();
  }
  state.counters["FLOP/s"] = benchmark::Counter(static_cast<double>(g.flops_window.total()),
                                                benchmark::Counter::kIsIterationInvariantRate);
}

// ---------------------------------------------------------------- result collection

struct Measured {
  double real_s = 0, cpu_s = 0;  // per iteration
  bool aggregate = false;
};

class CollectingReporter : public benchmark::ConsoleReporter {
 public:
  CollectingReporter() : ConsoleReporter(isatty(STDOUT_FILENO) ? OO_ColorTabular : OO_Tabular) {}
  std::map<std::string, std::vector<Measured>> runs;  // per iteration run
  std::map<std::string, Measured> medians;            // median aggregates (with repetitions)
  void ReportRuns(const std::vector<Run>& reports) override {
    ConsoleReporter::ReportRuns(reports);
    for (const Run& r : reports) {
      if (r.error_occurred) continue;
      const double unit = r.time_unit == benchmark::kNanosecond    ? 1e-9
                          : r.time_unit == benchmark::kMicrosecond ? 1e-6
                          : r.time_unit == benchmark::kMillisecond ? 1e-3
                                                                   : 1.0;
      Measured m{r.GetAdjustedRealTime() * unit, r.GetAdjustedCPUTime() * unit, r.run_type == Run::RT_Aggregate};
      if (r.run_type == Run::RT_Iteration) runs[r.run_name.str()].push_back(m);
      else if (r.aggregate_name == "median") medians[r.run_name.str()] = m;
    }
  }
  // Median aggregate if repetitions ran, else the mean of the iteration runs.
  std::optional<Measured> get(const std::string& name) const {
    if (auto it = medians.find(name); it != medians.end()) return it->second;
    const auto it = runs.find(name);
    if (it == runs.end() || it->second.empty()) return std::nullopt;
    Measured m;
    for (const auto& r : it->second) {
      m.real_s += r.real_s / static_cast<double>(it->second.size());
      m.cpu_s += r.cpu_s / static_cast<double>(it->second.size());
    }
    return m;
  }
};

// ---------------------------------------------------------------- manual timing loops

struct Dist {
  double mean = 0, p50 = 0, p99 = 0, max = 0, cpu_mean = 0;  // seconds
  long count = 0;
  long preempted = 0;  // involuntary context switches of this thread during the loop
};

long involuntary_switches() {
  rusage u{};
  getrusage(RUSAGE_THREAD, &u);
  return u.ru_nivcsw;
}

Dist distribution(std::vector<double> v, double cpu_total) {
  Dist d;
  d.count = static_cast<long>(v.size());
  if (v.empty()) return d;
  double sum = 0;
  for (double x : v) sum += x;
  d.mean = sum / static_cast<double>(v.size());
  d.cpu_mean = cpu_total / static_cast<double>(v.size());
  std::sort(v.begin(), v.end());
  auto q = [&](double p) { return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))]; };
  d.p50 = q(0.5);
  d.p99 = q(0.99);
  d.max = v.back();
  return d;
}

template <class F>
Dist time_loop(long reps, F&& step) {
  std::vector<double> v(static_cast<size_t>(reps));
  const double c0 = thread_cpu_s();
  const long s0 = involuntary_switches();
  for (long i = 0; i < reps; ++i) {
    const auto a = std::chrono::steady_clock::now();
    step(i);
    const auto b = std::chrono::steady_clock::now();
    v[static_cast<size_t>(i)] = std::chrono::duration<double>(b - a).count();
  }
  Dist d = distribution(std::move(v), thread_cpu_s() - c0);
  d.preempted = involuntary_switches() - s0;
  return d;
}

Dist stream_loop(long frames) {
  StgaeStream<float> s(g.model->net);
  for (long t = 0; t < kWarmupFrames; ++t) s.push(frame(t));
  return time_loop(frames, [&](long i) {
    benchmark::DoNotOptimize(s.push(frame(kWarmupFrames + i)));
    benchmark::ClobberMemory();
  });
}

// Largest |a - b| over two equally long float arrays.
double max_abs_diff(const float* a, const float* b, size_t n) {
  double m = 0;
  for (size_t i = 0; i < n; ++i) m = std::max(m, std::abs(static_cast<double>(a[i]) - static_cast<double>(b[i])));
  return m;
}

// ---------------------------------------------------------------- main

std::optional<std::string> take_option(std::vector<char*>& args, const std::string& name) {
  const std::string prefix = "--" + name + "=";
  for (auto it = args.begin(); it != args.end(); ++it)
    if (std::string(*it).rfind(prefix, 0) == 0) {
      std::string v = std::string(*it).substr(prefix.size());
      args.erase(it);
      return v;
    }
  return std::nullopt;
}

int run(int argc, char** argv) {
  std::vector<char*> args(argv, argv + argc);
  const auto model_opt = take_option(args, "model");
  const auto cpu_opt = take_option(args, "cpu");
  const long stream_frames = std::stol(take_option(args, "stream_frames").value_or("20000"));
  const long window_reps = std::stol(take_option(args, "window_reps").value_or("1000"));
  int bargc = static_cast<int>(args.size());
  benchmark::Initialize(&bargc, args.data());
  if (benchmark::ReportUnrecognizedArguments(bargc, args.data())) return 2;

  // Pin first: every allocation and first touch below happens on the measured core.
  const std::vector<int> allowed = allowed_cpus();
  const int cpu = cpu_opt ? std::stoi(*cpu_opt) : idlest_cpu(allowed);
  const bool pinned = pin_to(cpu);
  const std::string load_start = loadavg();

  g.model_path = model_opt ? std::filesystem::path(*model_opt) : default_model_path();
  g.model = load_hsm(g.model_path);
  const StgaeConfig& c = g.model->config;
  if (c.padding != StgaePadding::Causal) {
    std::fprintf(stderr, "hs_bench_stgae: %s is a centred model; streaming needs a causal one\n",
                 g.model_path.c_str());
    return 2;
  }
  g.n = c.joint_count();
  g.T = c.window;
  make_inputs(kWarmupFrames + std::max(stream_frames, 4L * g.T));
  g.flops_frame = stgae_flops_per_frame(c);
  g.flops_window = stgae_flops_per_window(c, g.T);
  g_torch = std::make_unique<TorchWindow>(*g.model, g.window);

  std::printf("hs_bench_stgae: model %s (%s)\n", g.model_path.c_str(), describe(c).c_str());
  std::printf("CPU: %s (family %s, model %s); %s to CPU %d of {%s} (sched_setaffinity); load average %s\n",
              cpuinfo_field("model name").c_str(), cpuinfo_field("cpu family").c_str(),
              cpuinfo_field("model\t").c_str(), pinned ? "pinned" : "FAILED to pin", cpu, join(allowed).c_str(),
              load_start.c_str());
  std::printf("Compiled for: %s; Eigen SIMD: %s; %s\n\n", compiled_isa().c_str(), Eigen::SimdInstructionSetsInUse(),
              TorchWindow::describe().c_str());
  std::fflush(stdout);

  // Benchmarks, registered here (the FMA ISAs depend on the CPU).
  std::vector<std::string> fma_names;
  bool vector_fma = false;
  for (FmaIsa isa : {FmaIsa::Avx2, FmaIsa::Avx512}) {
    if (!fma_supported(isa)) continue;
    vector_fma = true;
    for (FmaType type : {FmaType::F32, FmaType::F64}) {
      const std::string name = fmt::format("fma_peak/{}/{}", type == FmaType::F32 ? "f32" : "f64", isa_name(isa));
      benchmark::RegisterBenchmark(name.c_str(), bm_fma, isa, type)->Unit(benchmark::kMicrosecond);
      fma_names.push_back(name);
    }
  }
  if (!vector_fma)
    for (FmaType type : {FmaType::F32, FmaType::F64}) {
      const std::string name = fmt::format("fma_peak/{}/scalar", type == FmaType::F32 ? "f32" : "f64");
      benchmark::RegisterBenchmark(name.c_str(), bm_fma, FmaIsa::Scalar, type)->Unit(benchmark::kMicrosecond);
      fma_names.push_back(name);
    }
  const std::string win_name = fmt::format("eigen_window/{}", g.T), torch_name = fmt::format("torch_window/{}", g.T);
  benchmark::RegisterBenchmark("eigen_stream_frame", bm_eigen_stream)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("trust_region_step", bm_trust_region)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark(win_name.c_str(), bm_eigen_window)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark(torch_name.c_str(), bm_torch_window)->Unit(benchmark::kMicrosecond);

  CollectingReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();

  // Manual loops: per-push distribution (wall, steady_clock) and thread CPU time.
  const Dist ds = stream_loop(stream_frames);
  const Dist dw = time_loop(window_reps, [&](long) {
    auto out = stgae_window_forward(*g.model->net, g.window_in);
    benchmark::DoNotOptimize(out.denoised.data());
  });
  const Dist dt = time_loop(window_reps, [&](long) { g_torch->forward(); });

  // Same model, same function: torch vs Eigen window, and streaming vs window.
  const auto ew = stgae_window_forward(*g.model->net, g.window_in);
  g_torch->forward();
  const auto td = g_torch->denoised(), tp = g_torch->predicted();
  const double d_torch = std::max(max_abs_diff(td.data(), ew.denoised.data(), td.size()),
                                  max_abs_diff(tp.data(), ew.predicted.data(), tp.size()));
  StgaeStream<float> check(g.model->net);
  for (int t = 0; t < g.T; ++t) check.push(std::span<const float>(g.window_in.row(t).data(), static_cast<size_t>(3 * g.n)));
  double d_stream = max_abs_diff(check.denoised().data(), ew.denoised.row(g.T - 1).data(), static_cast<size_t>(3 * g.n));
  for (int i = 0; i < (c.predict ? c.horizon : 0); ++i)
    d_stream = std::max(d_stream, max_abs_diff(check.predicted(i).data(), ew.predicted.row(i).data(),
                                               static_cast<size_t>(3 * g.n)));

  // ------------------------------------------------------------ summary
  double peak32 = 0, peak64 = 0;
  std::string peak32_isa;
  for (const auto& name : fma_names) {
    const auto m = reporter.get(name);
    if (!m) continue;
    const bool f32 = name.find("/f32/") != std::string::npos;
    const FmaIsa isa = name.ends_with("avx512") ? FmaIsa::Avx512 : name.ends_with("avx2") ? FmaIsa::Avx2 : FmaIsa::Scalar;
    const double rate = static_cast<double>(fma_flops_per_round(isa, f32 ? FmaType::F32 : FmaType::F64) * kFmaRounds) /
                        m->cpu_s;
    if (f32 && rate > peak32) {
      peak32 = rate;
      peak32_isa = isa_name(isa);
    }
    if (!f32) peak64 = std::max(peak64, rate);
  }
  const auto ms = reporter.get("eigen_stream_frame"), mw = reporter.get(win_name), mt = reporter.get(torch_name);
  const double ff = static_cast<double>(g.flops_frame.total()), fw = static_cast<double>(g.flops_window.total());
  auto gflops = [](double flops, double sec) { return sec > 0 ? flops / sec * 1e-9 : 0.0; };
  auto frac = [&](double flops, double sec) { return peak32 > 0 && sec > 0 ? 100.0 * flops / sec / peak32 : 0.0; };
  auto row = [&](const char* what, double real_s, double cpu_s, double unit, const char* u, double flops) {
    const int digits = unit < 1e-4 ? 1 : 3;  // µs with one decimal, ms with three
    const std::string of_peak = peak32 > 0 ? fmt::format("{:.1f} %", frac(flops, cpu_s)) : "n/a (fma_peak not run)";
    std::printf("| %s | %.*f %s | %.*f %s | %.2f | %s |\n", what, digits, real_s / unit, u, digits, cpu_s / unit, u,
                gflops(flops, cpu_s), of_peak.c_str());
  };

  std::printf("\n== Summary (one hand, one core: CPU %d, float32) ==\n", cpu);
  std::printf("model: %s\n", describe(c).c_str());
  std::printf("FLOPs (2 per multiply-add, hs::stgae_flops_*): streaming %.3f MFLOP/frame "
              "(encoder %.3f, gates %.3f, denoise %.3f, predict %.3f); window of %d frames %.3f MFLOP\n",
              ff * 1e-6, static_cast<double>(g.flops_frame.encoder) * 1e-6,
              static_cast<double>(g.flops_frame.gates) * 1e-6, static_cast<double>(g.flops_frame.denoise) * 1e-6,
              static_cast<double>(g.flops_frame.predict) * 1e-6, g.T, fw * 1e-6);
  std::printf("FMA peak of this core (f32, %s): %.1f GFLOP/s; f64: %.1f GFLOP/s\n", peak32_isa.c_str(), peak32 * 1e-9,
              peak64 * 1e-9);
  std::printf("same function: |torch - Eigen window| max %.2e m; |streaming - window| max %.2e m\n\n", d_torch,
              d_stream);
  std::printf("| measurement | wall | thread CPU | GFLOP/s (CPU) | of f32 FMA peak |\n|---|---:|---:|---:|---:|\n");
  if (ms) row("Eigen streaming, per frame (Google Benchmark)", ms->real_s, ms->cpu_s, 1e-6, "µs", ff);
  row("Eigen streaming, per frame (manual loop, mean)", ds.mean, ds.cpu_mean, 1e-6, "µs", ff);
  if (const auto mb = reporter.get("trust_region_step"))
    std::printf("| trust region on a stream step (CorrectionBound::apply, Google Benchmark) | %.1f µs | %.1f µs | – | – |\n",
                mb->real_s * 1e6, mb->cpu_s * 1e6);
  if (mw) row(fmt::format("Eigen window, {} frames (Google Benchmark)", g.T).c_str(), mw->real_s, mw->cpu_s, 1e-3, "ms", fw);
  row(fmt::format("Eigen window, {} frames (manual loop, mean)", g.T).c_str(), dw.mean, dw.cpu_mean, 1e-3, "ms", fw);
  if (mt)
    row(fmt::format("libtorch window, {} frames (Google Benchmark)", g.T).c_str(), mt->real_s, mt->cpu_s, 1e-3, "ms", fw);
  row(fmt::format("libtorch window, {} frames (manual loop, mean)", g.T).c_str(), dt.mean, dt.cpu_mean, 1e-3, "ms", fw);
  std::printf("\nwall-clock distribution (manual loops):\n");
  std::printf("| loop | count | p50 | p99 | max | preempted |\n|---|---:|---:|---:|---:|---:|\n");
  std::printf("| Eigen streaming push | %ld | %.1f µs | %.1f µs | %.1f µs | %ld |\n", ds.count, ds.p50 * 1e6,
              ds.p99 * 1e6, ds.max * 1e6, ds.preempted);
  std::printf("| Eigen window | %ld | %.3f ms | %.3f ms | %.3f ms | %ld |\n", dw.count, dw.p50 * 1e3, dw.p99 * 1e3,
              dw.max * 1e3, dw.preempted);
  std::printf("| libtorch window | %ld | %.3f ms | %.3f ms | %.3f ms | %ld |\n", dt.count, dt.p50 * 1e3,
              dt.p99 * 1e3, dt.max * 1e3, dt.preempted);
  std::printf("(preempted: involuntary context switches of the benchmark thread during the loop; on a loaded\n"
              " machine they, not the model, make the p99 and max)\n");

  const double stream_cpu = ms ? ms->cpu_s : ds.cpu_mean, win_cpu = mw ? mw->cpu_s : dw.cpu_mean,
               torch_cpu = mt ? mt->cpu_s : dt.cpu_mean;
  std::printf("\nratios (thread CPU time): window / streaming frame = %.1f (FLOP ratio %.1f); "
              "libtorch window / Eigen window = %.1f; libtorch window / streaming frame = %.1f\n",
              win_cpu / stream_cpu, fw / ff, torch_cpu / win_cpu, torch_cpu / stream_cpu);
  const double target = 200e-6;
  std::printf("target <= 0.2 ms per frame per hand, streaming: %s (mean %.1f µs CPU, p50 %.1f µs, p99 %.1f µs wall; "
              "p99 %s)\n",
              stream_cpu <= target ? "MET" : "NOT MET", stream_cpu * 1e6, ds.p50 * 1e6, ds.p99 * 1e6,
              ds.p99 <= target ? "within" : "over");
  std::printf("load average at start %s, at end %s\n", load_start.c_str(), loadavg().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hs_bench_stgae: %s\n", e.what());
    return 1;
  }
}
