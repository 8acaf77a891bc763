// handsteady_benchmark_plot: reads benchmark.json (handsteady benchmark) and writes
//  - oneeuro_curve.png: One Euro's jitter against lag over its tuning sweep on the curve
//    cell (its lower envelope as a curve, every swept pair as a dot), every method as a point;
//  - jitter_lag_<set>.png per set: jitter (÷ the truth's) against lag at H = 0, one dot
//    per noise cell of the noise block, one colour per method; on a recording without
//    truth, One Euro's and Kalman's sweeps as curves (least jitter at a given lag).
#include "handsteady/error.hpp"
#include "handsteady_render/plot.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace {

namespace fs = std::filesystem;
using hs::render::Color;
using hs::render::XyPlot;
using hs::render::XySeries;
using nlohmann::json;

double num(const json& v) { return v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN(); }

Color method_color(size_t i) {
  static const std::vector<Color> palette = {Color::rgb8(120, 120, 120), Color::rgb8(230, 159, 0), Color::rgb8(213, 94, 0),
                                             Color::rgb8(0, 114, 178),   Color::rgb8(0, 158, 115), Color::rgb8(204, 121, 167),
                                             Color::rgb8(86, 180, 233),  Color::rgb8(20, 20, 20)};
  return palette[i % palette.size()];
}

XySeries series(std::string label, Color color) {
  XySeries s;
  s.label = std::move(label);
  s.color = color;
  return s;
}

// Lower envelope of (lag, jitter) points: the least jitter reachable at no more lag.
XySeries envelope(std::vector<std::pair<double, double>> pts, std::string label, Color color) {
  std::sort(pts.begin(), pts.end());
  XySeries env = series(std::move(label), color);
  env.lines = true;
  env.marker_px = 0.0f;
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [x, y] : pts)
    if (std::isfinite(x) && std::isfinite(y) && y < best) {
      best = y;
      env.x.push_back(x);
      env.y.push_back(y);
    }
  return env;
}

std::string file_safe(std::string s) {
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  return s;
}

int run(const fs::path& in, const fs::path& out_dir) {
  std::ifstream f(in);
  if (!f) throw hs::InputError({in.string(), 0, ""}, "cannot open");
  json j;
  try {
    j = json::parse(f);
  } catch (const json::exception& e) {
    throw hs::InputError({in.string(), 0, ""}, std::string("not JSON: ") + e.what());
  }
  if (!j.contains("methods") || !j.contains("results"))
    throw hs::InputError({in.string(), 0, "methods"}, "not a benchmark report (no methods or results)");
  const auto methods = j["methods"].get<std::vector<std::string>>();
  fs::create_directories(out_dir);
  int written = 0;

  // One Euro's curve.
  if (j.contains("oneeuro_curve")) {
    XyPlot p;
    p.title = "One Euro sweep, jitter against lag: " + j.value("curve_label", std::string("?"));
    p.x_label = "lag behind the truth (ms)";
    p.y_label = "jitter (mm per row, second difference)";
    XySeries dots = series("One Euro, every (min cutoff, beta)", Color::rgb8(190, 190, 190));
    dots.marker_px = 5.0f;
    std::vector<std::pair<double, double>> pts;
    for (const auto& c : j["oneeuro_curve"]) {
      dots.x.push_back(num(c["lag_ms"]));
      dots.y.push_back(num(c["jitter_mm"]));
      pts.emplace_back(dots.x.back(), dots.y.back());
    }
    p.series = {dots, envelope(pts, "One Euro, least jitter at a given lag", Color::rgb8(230, 159, 0))};
    for (size_t m = 0; m < methods.size(); ++m)
      for (const auto& r : j["results"])
        if (r["method"] == methods[m] && !j.value("curve_cell", std::string()).empty() &&
            r.value("cell", std::string()) == j.value("curve_cell", std::string())) {
          XySeries s = series(methods[m], method_color(m));
          s.marker_px = 12.0f;
          s.x = {num(r["h0ms"]["lag_ms"])};
          s.y = {num(r["h0ms"]["jitter_mm"])};
          p.series.push_back(s);
        }
    hs::render::write_xy_plot(out_dir / "oneeuro_curve.png", p);
    ++written;
  }

  // Jitter against lag per set.
  std::vector<std::string> sets;
  for (const auto& r : j["results"]) {
    const std::string s = r["set"];
    if ((r["block"] == "noise" || r["block"] == "recorded") && std::find(sets.begin(), sets.end(), s) == sets.end())
      sets.push_back(s);
  }
  for (const auto& set : sets) {
    XyPlot p;
    bool recorded = false;
    for (size_t m = 0; m < methods.size(); ++m) {
      XySeries s = series(methods[m], method_color(m));
      for (const auto& r : j["results"]) {
        if (r["set"] != set || r["method"] != methods[m] || (r["block"] != "noise" && r["block"] != "recorded")) continue;
        recorded = r["block"] == "recorded";
        const auto& h = r["h0ms"];
        s.x.push_back(num(h["lag_ms"]));
        s.y.push_back(recorded ? num(h["jitter_mm"]) : num(h["jitter_mm"]) / num(h["truth_jitter_mm"]));
      }
      p.series.push_back(s);
    }
    // A recording without truth: One Euro's and Kalman's curves (sweep, defaults, raw), what
    // the criterion compares at equal lag.
    if (recorded && j.contains("recorded_curves"))
      for (const auto& [method, label, color] :
           {std::tuple{"oneeuro", "One Euro swept, least jitter at a given lag", Color::rgb8(230, 159, 0)},
            std::tuple{"kalman", "Kalman swept, least jitter at a given lag", Color::rgb8(0, 158, 115)}}) {
        std::vector<std::pair<double, double>> pts;
        for (const auto& c : j["recorded_curves"])
          if (c.value("method", std::string()) == method && c.value("cell", std::string()).find("| " + set + " |") != std::string::npos)
            pts.emplace_back(num(c["lag_ms"]), num(c["jitter_mm"]));
        if (!pts.empty()) p.series.push_back(envelope(std::move(pts), label, color));
      }
    p.title = recorded ? set + ": jitter against lag behind the raw recording"
                       : set + ": jitter against lag, one dot per noise cell (H = 0)";
    p.x_label = recorded ? "lag behind raw (ms)" : "lag behind the truth (ms)";
    p.y_label = recorded ? "jitter (mm per row)" : "jitter / the truth's jitter";
    hs::render::write_xy_plot(out_dir / ("jitter_lag_" + file_safe(set) + ".png"), p);
    ++written;
  }
  fmt::print("{} plots in {}\n", written, out_dir.string());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"PNG plots of a handsteady benchmark report"};
  std::string in, out;
  app.add_option("--in", in, "benchmark.json")->required();
  app.add_option("--out", out, "Folder for the PNGs (default: beside --in)");
  CLI11_PARSE(app, argc, argv);
  try {
    return run(in, out.empty() ? fs::path(in).parent_path() : fs::path(out));
  } catch (const std::exception& e) {
    fmt::print(stderr, "handsteady_benchmark_plot: {}\n", e.what());
    return 1;
  }
}
