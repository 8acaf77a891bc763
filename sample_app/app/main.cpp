// handsteady_demo: the AR handwriting demo. A real OpenXR app: it creates both hand
// trackers, runs the frame loop, and draws two labelled panels side by side, the raw
// joints (the HandSteady layer's raw side channel, XR_NOVENDOR_handsteady_raw_joints)
// and HandSteady's, each with its ink: the index fingertip's trail while thumb tip and
// index tip pinch. In a GLFW window when a display exists, else headless through OSMesa,
// writing PNG frames, the final composite, the trajectory plot and a metrics summary.
// On a headless session without frame timing (Monado's) it times its own frames.
#include "handsteady/filters.hpp"
#include "layer_config.hpp"
#include "handsteady/ink.hpp"
#include "handsteady/model_path.hpp"
#include "handsteady/stgae_model.hpp"
#include "handsteady/track_ops.hpp"
#include "handsteady_render/context.hpp"
#include "handsteady_render/renderer.hpp"
#include "framing.hpp"
#include "panel.hpp"
#include "report.hpp"
#include "xr_hands.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdlib>
#include <exception>
#include <filesystem>
#include <optional>
#include <string>

namespace {

struct Options {
  std::string out = "out/demo_app";
  std::string strokes, truth;
  int64_t truth_epoch_ns = 1'000'000'000;  // the replay runtime's XrTime of the track's first row
  double max_seconds = 600.0;
  int frames_every = 0;
  int panel_width = 640, panel_height = 480;
  double predict_ms = 50.0;  // the plot's Multi-STGAE prediction from the raw joints; 0 = none
  double fps = 90.0;         // frame rate when the runtime times no frames (headless session)
  bool window = false, headless = false;
};

// The layer's mode as the layer itself reads it (its configuration file and environment).
std::string layer_mode() { return std::string(hs::layer::mode_name(hs::layer::read_layer_config().config.mode)); }

// The shipped (or HANDSTEADY_MODEL) Multi-STGAE model run causally over the raw joints,
// each row answered for row time + horizon; none (with a note) when no model is usable.
std::optional<hs::demo::Prediction> predict_from_raw(const hs::HandSeries& raw, double horizon_ms) {
  try {
    hs::demo::Prediction p;
    p.horizon_ms = horizon_ms;
    const std::filesystem::path file = hs::default_model_path();
    p.model = file.filename().string();
    hs::FilterConfig config;
    config.method = hs::FilterMethod::Stgae;
    config.stgae.model = hs::load_hsm(file);
    config.stgae.source = file.string();
    p.at_row = hs::filter_series_with(config, raw, horizon_ms * 1e-3);
    return p;
  } catch (const std::exception& e) {
    fmt::print("demo: no prediction in the plot: {}\n", e.what());
    return std::nullopt;
  }
}

int run(const Options& opt) {
  namespace fs = std::filesystem;
  using hs::render::Color;
  const fs::path out(opt.out);
  fs::create_directories(out / "frames");

  std::optional<hs::StrokeSet> strokes;
  if (!opt.strokes.empty()) strokes = hs::read_strokes_csv(opt.strokes);
  std::optional<hs::HandSeries> truth;
  double truth_t0 = 0.0;
  if (!opt.truth.empty()) {
    const hs::Track t = hs::read_track_csv(opt.truth);
    truth = hs::hand_series(t, hs::Hand::Right);
    // The replay runtime maps the track's first row (either hand) to truth_epoch_ns.
    truth_t0 = std::numeric_limits<double>::infinity();
    for (const auto& row : t.rows) truth_t0 = std::min(truth_t0, row.t);
  }
  // Track seconds of an XrTime (XrTime seconds when there is no truth to align with).
  auto track_time = [&](XrTime T) {
    return truth ? truth_t0 + static_cast<double>(T - opt.truth_epoch_ns) * 1e-9 : static_cast<double>(T) * 1e-9;
  };

  hs::demo::XrHandsOptions xr_options;
  xr_options.fps = opt.fps;
  hs::demo::XrHands xr(xr_options);
  fmt::print("demo: runtime '{}', raw side channel {}\n", xr.runtime_name(),
             xr.has_raw() ? "on (HandSteady layer active)" : "unavailable (layer not active): one panel");

  const int panels = xr.has_raw() ? 2 : 1;
  const int gap = 8;
  const int W = panels * opt.panel_width + (panels + 1) * gap, H = opt.panel_height + 2 * gap;
  std::unique_ptr<hs::render::GlContext> ctx;
  if (opt.window || (!opt.headless && hs::render::display_available())) {
    std::string why;
    ctx = hs::render::create_window_context(W, H, "HandSteady handwriting demo", &why);
    if (!ctx) fmt::print("demo: no window ({}); rendering headless\n", why);
  }
  if (!ctx) ctx = hs::render::create_offscreen_context(W, H);
  fmt::print("demo: OpenGL {}\n", ctx->description());
  hs::render::Renderer renderer(*ctx);
  const auto viewports = hs::render::panel_row(ctx->width(), ctx->height(), panels, gap);
  const hs::demo::SceneGeometry scene =
      hs::demo::scene_from_strokes(strokes ? strokes->strokes : std::vector<hs::Polyline>{});

  const std::string mode = layer_mode();
  std::vector<hs::demo::PanelRecord> rec(static_cast<size_t>(panels));
  std::vector<hs::InkRecorder> ink(static_cast<size_t>(panels));
  const Color ink_colors[] = {Color::rgb8(220, 60, 50), Color::rgb8(30, 110, 220)};
  if (panels == 2) {
    rec[0] = {"raw", "raw (runtime)", {}, {}};
    rec[1] = {"handsteady", "HandSteady (" + mode + ")", {}, {}};
  } else {
    rec[0] = {"app", "as received", {}, {}};
  }

  // One frame: a panel per view, labelled, with its ink and hand, the camera framing
  // every joint seen so far.
  hs::demo::ViewFraming framing(scene);
  bool reframed = false;
  XrTime first_T = 0, last_seen_T = 0, last_T = 0;
  auto draw = [&](XrTime T, const std::vector<hs::Pose>& poses) {
    last_T = T;
    if (!reframed && framing.reframed(viewports.front().aspect())) {
      reframed = true;
      fmt::print("demo: joints outside the default view: the camera backs off to show them\n");
    }
    renderer.begin_frame(Color::rgb8(210, 210, 205));
    for (int p = 0; p < panels; ++p) {
      const auto& ir = ink[static_cast<size_t>(p)];
      hs::demo::PanelContent c;
      c.label = rec[static_cast<size_t>(p)].label;
      c.subtitle = fmt::format("t = {:.2f} s   ink strokes: {}{}", static_cast<double>(T - first_T) * 1e-9,
                               ir.strokes().size(), ir.pen_down() ? "   (pinch: writing)" : "");
      c.ink_color = ink_colors[p % 2];
      c.ink = &ir.strokes();
      c.hand = &poses[static_cast<size_t>(p)];
      c.pen_down = ir.pen_down();
      const auto& vp = viewports[static_cast<size_t>(p)];
      hs::demo::draw_panel(renderer, vp, framing.camera(vp.aspect()), scene, c);
    }
  };
  std::vector<hs::Pose> last_poses(static_cast<size_t>(panels), hs::untracked_pose());
  int frame = 0;
  bool seen_hand = false;
  while (xr.running() && !ctx->should_close()) {
    const XrTime T = xr.begin_frame();
    if (frame == 0) first_T = T;
    const double t = track_time(T);
    bool any = false;
    std::vector<hs::Pose> poses(static_cast<size_t>(panels));
    for (int p = 0; p < panels; ++p) {
      const bool raw = panels == 2 && p == 0;
      poses[static_cast<size_t>(p)] = xr.locate(hs::Hand::Right, T, raw);
      const hs::Pose& pose = poses[static_cast<size_t>(p)];
      framing.add(pose);
      if (hs::any_joint_tracked(pose)) {
        any = true;
        if (rec[static_cast<size_t>(p)].seen.t.empty() || t > rec[static_cast<size_t>(p)].seen.t.back()) {
          rec[static_cast<size_t>(p)].seen.t.push_back(t);
          rec[static_cast<size_t>(p)].seen.pos.push_back(pose);
        }
      }
      ink[static_cast<size_t>(p)].push(t, pose);
    }
    if (any) {
      seen_hand = true;
      last_seen_T = T;
    }

    // Each panel keeps its own hand as last seen: at the end of a recording one panel
    // (the layer's, a frame behind on a loaded machine) may still show a hand the other lost.
    for (size_t p = 0; p < poses.size(); ++p)
      if (hs::any_joint_tracked(poses[p])) last_poses[p] = poses[p];
    draw(T, poses);
    if (opt.frames_every > 0 && frame % opt.frames_every == 0)
      hs::render::write_png(out / "frames" / fmt::format("frame_{:05d}.png", frame), renderer.read_pixels());
    ctx->present();
    ctx->poll_events();
    xr.end_frame(T);
    ++frame;
    const double elapsed = static_cast<double>(T - first_T) * 1e-9;
    // The recording is over past the truth's end, or when the hand has been gone for 2 s
    // (tracker dropouts are shorter).
    if (truth && !truth->t.empty() && t > truth->t.back() + 0.1) break;
    if (seen_hand && static_cast<double>(T - last_seen_T) * 1e-9 > 2.0) break;
    if (!seen_hand && elapsed > 5.0) throw std::runtime_error("no hand was tracked in the first 5 s");
    if (elapsed > opt.max_seconds) break;
  }
  xr.shutdown();
  // The composite: every panel with all its ink, the hands as last seen.
  if (frame > 0) {
    draw(last_T, last_poses);
    hs::render::write_png(out / "composite.png", renderer.read_pixels());
  }

  hs::demo::ReportInputs report;
  for (int p = 0; p < panels; ++p) {
    rec[static_cast<size_t>(p)].ink = ink[static_cast<size_t>(p)].strokes();
    report.panels.push_back(std::move(rec[static_cast<size_t>(p)]));
  }
  if (panels == 2 && opt.predict_ms > 0.0) report.prediction = predict_from_raw(report.panels.front().seen, opt.predict_ms);
  report.strokes = strokes;
  report.truth = truth;
  report.layer_mode = mode;
  const std::string md = hs::demo::write_report(out, report);
  fmt::print("demo: {} frames\n{}", frame, md);
  fmt::print("demo: wrote {}/composite.png, summary.md, summary.json{}\n", out.string(),
             truth ? ", index_tip_plot.png" : "");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"HandSteady AR handwriting demo: an OpenXR app drawing raw and HandSteady hands and ink"};
  app.add_option("--out", opt.out, "Output folder (composite.png, frames/, summary, plot)")->capture_default_str();
  app.add_option("--strokes", opt.strokes, "Font strokes CSV (handsteady synth-handwriting): guides and ink metrics")
      ->check(CLI::ExistingFile);
  app.add_option("--truth", opt.truth, "Clean track replayed by the runtime (for latency, errors and the plot)")
      ->check(CLI::ExistingFile);
  app.add_option("--truth-epoch-ns", opt.truth_epoch_ns, "XrTime of the track's first row (replay runtime: 1 s)")
      ->capture_default_str();
  app.add_option("--max-seconds", opt.max_seconds, "Stop after this long")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--frames-every", opt.frames_every, "Write every Nth frame as PNG (0: none)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--panel-width", opt.panel_width, "Panel width (pixels)")->check(CLI::Range(64, 4096))->capture_default_str();
  app.add_option("--panel-height", opt.panel_height, "Panel height (pixels)")->check(CLI::Range(64, 4096))->capture_default_str();
  app.add_option("--predict-ms", opt.predict_ms,
                 "Plot and score a Multi-STGAE prediction this far ahead from the raw joints (0: none)")
      ->check(CLI::Range(0.0, 500.0))->capture_default_str();
  app.add_option("--fps", opt.fps, "Frame rate when the runtime gives no display times (e.g. Monado's headless session)")
      ->check(CLI::Range(1.0, 1000.0))->capture_default_str();
  auto* w = app.add_flag("--window", opt.window, "Open a GLFW window (default when a display exists)");
  app.add_flag("--headless", opt.headless, "Render offscreen through OSMesa even with a display")->excludes(w);
  CLI11_PARSE(app, argc, argv);
  try {
    return run(opt);
  } catch (const std::exception& e) {
    fmt::print(stderr, "handsteady_demo: {}\n", e.what());
    return 1;
  }
}
