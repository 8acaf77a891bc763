#include "handsteady_render/plot.hpp"

#include "handsteady_render/context.hpp"
#include "handsteady_render/renderer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace hs::render {

namespace {

struct Range {
  double lo = 0.0, hi = 1.0;
};

// A plot drawn alone into an offscreen context of its size (the renderer is gone before
// the context).
template <class Plot, class Draw>
Image render_offscreen(const Plot& plot, Draw draw) {
  auto ctx = create_offscreen_context(plot.width, plot.height);
  Renderer r(*ctx);
  r.begin_frame(plot.background);
  draw(r, r.full_frame(), plot);
  return r.read_pixels();
}

void check_plot(const TrajectoryPlot& plot) {
  for (const PlotSeries& s : plot.series) {
    if (s.t.size() != s.xyz.size()) {
      throw std::invalid_argument("plot series '" + s.label + "': " + std::to_string(s.t.size()) + " times but " +
                                  std::to_string(s.xyz.size()) + " points");
    }
  }
}

// 1, 2 or 5 times a power of ten, near range / target.
double nice_step(double range, int target) {
  const double raw = range / target;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  const double m = raw / p;
  return (m < 1.5 ? 1.0 : m < 3.5 ? 2.0 : m < 7.5 ? 5.0 : 10.0) * p;
}

std::vector<double> ticks(Range r, double step) {
  std::vector<double> out;
  const double eps = step * 1e-6;
  for (double k = std::ceil((r.lo - eps) / step); k * step <= r.hi + eps; k += 1.0) {
    out.push_back(k * step);
  }
  return out;
}

std::string tick_label(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  std::string s = fmt::format("{:.{}f}", v, decimals);
  if (s.find_first_not_of("-0.") == std::string::npos && s.front() == '-') {
    s.erase(0, 1);  // "-0.0" -> "0.0"
  }
  return s;
}

Range padded(double lo, double hi, double fallback_lo, double fallback_hi, double pad_fraction) {
  if (!(lo <= hi)) {
    return {fallback_lo, fallback_hi};
  }
  if (hi - lo < 1e-12) {
    const double half = std::max(std::abs(lo) * 0.05, 1e-3);
    return {lo - half, hi + half};
  }
  const double pad = (hi - lo) * pad_fraction;
  return {lo - pad, hi + pad};
}

struct LegendEntry {
  std::string label;
  Color color;
  float width_px;
  bool marker;  // a dot instead of a line sample
};

// Legend rows centred in width W from y: a line (or dot) sample and the label per entry;
// returns the y below it.
float draw_legend(Renderer& r, const std::vector<LegendEntry>& entries, float y, float W, float u, const TextStyle& style) {
  const float sample = 28.0f * u, space = 8.0f * u, between = 26.0f * u, row_h = 24.0f * u;
  std::vector<float> widths;
  for (const LegendEntry& e : entries) widths.push_back(sample + space + r.measure_text(e.label, {0.0f, 0.0f}, style).width);
  size_t i = 0;
  while (i < entries.size()) {
    size_t j = i;
    float row_w = 0.0f;
    while (j < entries.size() && (j == i || row_w + between + widths[j] <= W - 20.0f * u)) {
      row_w += (j == i ? 0.0f : between) + widths[j];
      ++j;
    }
    float x = 0.5f * (W - row_w);
    const float cy = y + 0.5f * row_h;
    for (size_t k = i; k < j; ++k) {
      const LegendEntry& e = entries[k];
      if (e.marker) r.disc2d({x + 0.5f * sample, cy}, std::max(e.width_px, 6.0f) * u, e.color);
      else r.line2d({x, cy}, {x + sample, cy}, e.color, e.width_px * u);
      r.text(e.label, {x + sample + space, cy}, style);
      x += widths[k] + between;
    }
    y += row_h;
    i = j;
  }
  return y;
}

// What both plot kinds share: the layout unit (u: 1 at 1200 px wide and `height_units`
// high), colours and text styles.
struct PlotLook {
  float W = 0.0f, H = 0.0f, u = 1.0f, tick_len = 5.0f;
  Color ink = Color::rgb8(30, 30, 30), grid = Color::rgb8(225, 225, 225);
  TextStyle title, legend, tick, label;
};
PlotLook plot_look(const Viewport& vp, float height_units) {
  PlotLook k;
  k.W = static_cast<float>(vp.width);
  k.H = static_cast<float>(vp.height);
  k.u = std::clamp(std::min(k.W / 1200.0f, k.H / height_units), 0.35f, 4.0f);
  const float u = k.u;
  k.tick_len = 5.0f * u;
  k.title = {22.0f * u, k.ink, 2.0f * u, Align::Center, VAlign::Top};
  k.legend = {14.0f * u, k.ink, 1.4f * u, Align::Left, VAlign::Middle};
  k.tick = {12.0f * u, k.ink, 1.2f * u, Align::Right, VAlign::Middle};
  k.label = {15.0f * u, k.ink, 1.4f * u, Align::Center, VAlign::Middle, 90.0f};
  return k;
}

// Title and legend from the top; returns the y below them.
float draw_header(Renderer& r, const PlotLook& k, const std::string& title, const std::vector<LegendEntry>& entries) {
  float y = 12.0f * k.u;
  if (!title.empty()) {
    const Box b = r.text(title, {0.5f * k.W, y}, k.title);
    y = b.y + b.height + 10.0f * k.u;
  }
  return draw_legend(r, entries, y, k.W, k.u, k.legend);
}

// An axes box: where it is, its ranges and tick steps.
struct Axes {
  float left = 0.0f, top = 0.0f, w = 1.0f, h = 1.0f;
  Range xr, yr;
  double x_step = 1.0, y_step = 1.0;
  float px(double v) const { return left + static_cast<float>((v - xr.lo) / (xr.hi - xr.lo)) * w; }
  float py(double v) const { return top + (1.0f - static_cast<float>((v - yr.lo) / (yr.hi - yr.lo))) * h; }
};

// Room left of the boxes for the y label and tick numbers `label_w` wide, and below the
// lowest box for the x numbers and label.
float axes_left(const PlotLook& k, float label_w) {
  return std::round(8.0f * k.u + k.label.size_px * 1.6f + 8.0f * k.u + label_w + k.tick_len + 4.0f * k.u);
}
float axes_bottom_margin(const PlotLook& k) { return 12.0f * k.u + k.tick.size_px + 14.0f * k.u + k.label.size_px + 10.0f * k.u; }

void draw_grid(Renderer& r, const PlotLook& k, const Axes& a) {
  for (const double v : ticks(a.xr, a.x_step)) r.line2d({a.px(v), a.top}, {a.px(v), a.top + a.h}, k.grid, 1.0f * k.u);
  for (const double v : ticks(a.yr, a.y_step)) r.line2d({a.left, a.py(v)}, {a.left + a.w, a.py(v)}, k.grid, 1.0f * k.u);
}

// The box's frame, y ticks with numbers, x tick marks and the y label; with an x label
// (the lowest box) also the x numbers and the label under them.
void draw_axes(Renderer& r, const PlotLook& k, const Axes& a, const std::string& y_label, const std::string* x_label) {
  const float u = k.u;
  r.stroke_rect(a.left, a.top, a.w, a.h, k.ink, 1.5f * u);
  for (const double v : ticks(a.yr, a.y_step)) {
    r.line2d({a.left - k.tick_len, a.py(v)}, {a.left, a.py(v)}, k.ink, 1.2f * u);
    r.text(tick_label(v, a.y_step), {a.left - k.tick_len - 4.0f * u, a.py(v)}, k.tick);
  }
  const std::vector<double> x_ticks = ticks(a.xr, a.x_step);
  for (const double v : x_ticks) r.line2d({a.px(v), a.top + a.h}, {a.px(v), a.top + a.h + k.tick_len}, k.ink, 1.2f * u);
  r.text(y_label, {8.0f * u + 0.8f * k.label.size_px, a.top + 0.5f * a.h}, k.label);
  if (!x_label) return;
  TextStyle xt = k.tick;
  xt.align = Align::Center;
  xt.valign = VAlign::Top;
  for (const double v : x_ticks) r.text(tick_label(v, a.x_step), {a.px(v), a.top + a.h + k.tick_len + 6.0f * u}, xt);
  TextStyle xs = k.label;
  xs.angle_deg = 0.0f;
  xs.valign = VAlign::Top;
  r.text(*x_label, {a.left + 0.5f * a.w, a.top + a.h + k.tick_len + 6.0f * u + xt.size_px + 12.0f * u}, xs);
}

}  // namespace

PlotSeries joint_series(std::string label, Color color, const std::vector<double>& t,
                        const std::vector<hs::Pose>& poses, int joint, double time_offset_s) {
  if (t.size() != poses.size()) {
    throw std::invalid_argument("joint_series '" + label + "': " + std::to_string(t.size()) + " times but " +
                                std::to_string(poses.size()) + " poses");
  }
  if (joint < 0 || joint >= kJointCount) {
    throw std::invalid_argument("joint_series '" + label + "': joint " + std::to_string(joint) + " out of range");
  }
  PlotSeries s;
  s.label = std::move(label);
  s.color = color;
  s.t.reserve(t.size());
  s.xyz.reserve(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    s.t.push_back(t[i] + time_offset_s);
    const hs::Pose& p = poses[i];
    s.xyz.emplace_back(p(joint, 0), p(joint, 1), p(joint, 2));
  }
  return s;
}

void draw_trajectory_plot(Renderer& r, const Viewport& vp, const TrajectoryPlot& plot) {
  check_plot(plot);
  r.set_viewport(vp);
  r.clear_viewport(plot.background);
  const PlotLook look = plot_look(vp, 900.0f);
  const float u = look.u;
  const double scale = plot.millimetres ? 1000.0 : 1.0;
  const std::string unit = plot.millimetres ? "mm" : "m";

  // Data ranges: time over every series, each axis over its finite values.
  double t_lo = kNaN, t_hi = kNaN;
  double v_lo[3] = {kNaN, kNaN, kNaN}, v_hi[3] = {kNaN, kNaN, kNaN};
  for (const PlotSeries& s : plot.series) {
    for (size_t i = 0; i < s.t.size(); ++i) {
      if (std::isfinite(s.t[i])) {
        t_lo = std::isnan(t_lo) ? s.t[i] : std::min(t_lo, s.t[i]);
        t_hi = std::isnan(t_hi) ? s.t[i] : std::max(t_hi, s.t[i]);
      }
      for (int k = 0; k < 3; ++k) {
        const double v = s.xyz[i][k] * scale;
        if (std::isfinite(v)) {
          v_lo[k] = std::isnan(v_lo[k]) ? v : std::min(v_lo[k], v);
          v_hi[k] = std::isnan(v_hi[k]) ? v : std::max(v_hi[k], v);
        }
      }
    }
  }
  const Range tr = padded(t_lo, t_hi, 0.0, 1.0, 0.0);
  const double t_step = nice_step(tr.hi - tr.lo, 8);
  Range vr[3];
  double v_step[3];
  float label_w = 0.0f;
  for (int k = 0; k < 3; ++k) {
    vr[k] = padded(v_lo[k], v_hi[k], -1.0, 1.0, 0.06);
    v_step[k] = nice_step(vr[k].hi - vr[k].lo, 4);
    for (double v : ticks(vr[k], v_step[k]))
      label_w = std::max(label_w, r.measure_text(tick_label(v, v_step[k]), {0.0f, 0.0f}, look.tick).width);
  }

  // Layout (overlay pixels of vp): three boxes sharing the time axis.
  std::vector<LegendEntry> entries;
  for (const PlotSeries& s : plot.series) entries.push_back({s.label, s.color, std::max(s.width_px, 2.0f), false});
  const float y = draw_header(r, look, plot.title, entries);
  const float left = axes_left(look, label_w);
  const float right = std::round(look.W - 24.0f * u);
  const float top = std::round(y + 8.0f * u);
  const float gap = std::round(16.0f * u);
  const float sub_h = std::max(1.0f, std::floor((look.H - top - axes_bottom_margin(look) - 2.0f * gap) / 3.0f));
  const float plot_w = std::max(1.0f, right - left);

  for (int k = 0; k < 3; ++k) {
    Axes a;
    a.left = left;
    a.top = top + static_cast<float>(k) * (sub_h + gap);
    a.w = plot_w;
    a.h = sub_h;
    a.xr = tr;
    a.x_step = t_step;
    a.yr = vr[k];
    a.y_step = v_step[k];
    draw_grid(r, look, a);
    // Series, clipped to the subplot (its own viewport: coordinates relative to it).
    const Viewport clip{vp.x + static_cast<int>(left), vp.y + static_cast<int>(a.top), static_cast<int>(plot_w),
                        static_cast<int>(sub_h)};
    if (clip.width > 0 && clip.height > 0 && clip.x + clip.width <= vp.x + vp.width &&
        clip.y + clip.height <= vp.y + vp.height) {
      r.set_viewport(clip);
      for (const PlotSeries& s : plot.series) {
        std::vector<glm::vec2> run;
        auto flush = [&] {
          if (run.size() == 1) {
            r.disc2d(run[0], s.width_px * u, s.color);
          } else {
            r.polyline2d(run, s.color, s.width_px * u);
          }
          run.clear();
        };
        for (size_t i = 0; i < s.t.size(); ++i) {
          const double v = s.xyz[i][k] * scale;
          if (!std::isfinite(v) || !std::isfinite(s.t[i])) {
            flush();
            continue;
          }
          run.emplace_back(a.px(s.t[i]) - left, a.py(v) - a.top);
        }
        flush();
      }
      r.set_viewport(vp);
    }
    draw_axes(r, look, a, plot.axis_names[static_cast<size_t>(k)] + " (" + unit + ")", k == 2 ? &plot.time_label : nullptr);
  }
}

Image render_trajectory_plot(const TrajectoryPlot& plot) {
  check_plot(plot);
  return render_offscreen(plot, draw_trajectory_plot);
}

void write_trajectory_plot(const std::filesystem::path& path, const TrajectoryPlot& plot) {
  write_png(path, render_trajectory_plot(plot));
}

void draw_xy_plot(Renderer& r, const Viewport& vp, const XyPlot& plot) {
  for (const XySeries& s : plot.series)
    if (s.x.size() != s.y.size())
      throw std::invalid_argument("xy plot series '" + s.label + "': " + std::to_string(s.x.size()) + " x but " +
                                  std::to_string(s.y.size()) + " y");
  r.set_viewport(vp);
  r.clear_viewport(plot.background);
  const PlotLook look = plot_look(vp, 800.0f);
  const float u = look.u;

  double x_lo = kNaN, x_hi = kNaN, y_lo = kNaN, y_hi = kNaN;
  for (const XySeries& s : plot.series)
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x_lo = std::isnan(x_lo) ? s.x[i] : std::min(x_lo, s.x[i]);
      x_hi = std::isnan(x_hi) ? s.x[i] : std::max(x_hi, s.x[i]);
      y_lo = std::isnan(y_lo) ? s.y[i] : std::min(y_lo, s.y[i]);
      y_hi = std::isnan(y_hi) ? s.y[i] : std::max(y_hi, s.y[i]);
    }
  if (plot.y_from_zero && y_lo > 0.0) y_lo = 0.0;
  Axes a;
  a.xr = padded(x_lo, x_hi, 0.0, 1.0, 0.05);
  a.yr = padded(y_lo, y_hi, 0.0, 1.0, 0.05);
  a.x_step = nice_step(a.xr.hi - a.xr.lo, 8);
  a.y_step = nice_step(a.yr.hi - a.yr.lo, 6);
  float label_w = 0.0f;
  for (const double v : ticks(a.yr, a.y_step))
    label_w = std::max(label_w, r.measure_text(tick_label(v, a.y_step), {0.0f, 0.0f}, look.tick).width);

  std::vector<LegendEntry> entries;
  for (const XySeries& s : plot.series) entries.push_back({s.label, s.color, s.lines ? s.line_px : s.marker_px, !s.lines});
  const float y = draw_header(r, look, plot.title, entries);
  a.left = axes_left(look, label_w);
  a.top = std::round(y + 8.0f * u);
  a.w = std::max(1.0f, std::round(look.W - 24.0f * u) - a.left);
  a.h = std::max(1.0f, std::round(look.H - axes_bottom_margin(look)) - a.top);
  draw_grid(r, look, a);
  const Viewport clip{vp.x + static_cast<int>(a.left), vp.y + static_cast<int>(a.top), static_cast<int>(a.w), static_cast<int>(a.h)};
  if (clip.width > 0 && clip.height > 0) {
    r.set_viewport(clip);
    for (const XySeries& s : plot.series) {
      std::vector<glm::vec2> run;
      const auto flush = [&] {
        if (s.lines && run.size() > 1) r.polyline2d(run, s.color, s.line_px * u);
        run.clear();
      };
      for (size_t i = 0; i < s.x.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
          flush();
          continue;
        }
        const glm::vec2 p{a.px(s.x[i]) - a.left, a.py(s.y[i]) - a.top};
        run.push_back(p);
        if (s.marker_px > 0.0f) r.disc2d(p, s.marker_px * u, s.color);
      }
      flush();
    }
    r.set_viewport(vp);
  }
  draw_axes(r, look, a, plot.y_label, &plot.x_label);
}

Image render_xy_plot(const XyPlot& plot) {
  if (plot.width <= 0 || plot.height <= 0) throw std::invalid_argument("xy plot: width and height must be positive");
  return render_offscreen(plot, draw_xy_plot);
}

void write_xy_plot(const std::filesystem::path& path, const XyPlot& plot) { write_png(path, render_xy_plot(plot)); }

}  // namespace hs::render
