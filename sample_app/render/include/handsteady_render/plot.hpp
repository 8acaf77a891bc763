#pragma once
// Trajectory plots like the Multi-STGAE paper's figure: three stacked subplots (x, y, z
// of one joint over time), labelled coloured series (noisy, denoised, predicted, truth),
// axes with ticks and numbers, a legend and a title. Drawn with the GL renderer.
#include "handsteady/track.hpp"
#include "handsteady_render/camera.hpp"
#include "handsteady_render/image.hpp"

#include <glm/glm.hpp>

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace hs::render {

class Renderer;

struct PlotSeries {
  std::string label;
  Color color;
  std::vector<double> t;        // seconds
  std::vector<glm::dvec3> xyz;  // metres, one per time; a NaN coordinate is a gap
  float width_px = 2.0f;
};

// A series of one joint of poses (untracked joints become gaps). For a prediction made
// at t for t + H, pass time_offset_s = H so it lines up with the truth.
// Throws std::invalid_argument when t and poses differ in size or joint is out of range.
PlotSeries joint_series(std::string label, Color color, const std::vector<double>& t,
                        const std::vector<hs::Pose>& poses, int joint, double time_offset_s = 0.0);

struct TrajectoryPlot {
  std::string title;
  std::vector<PlotSeries> series;  // drawn in order (later on top), listed in the legend
  bool millimetres = true;         // axis values in mm (else m)
  std::string time_label = "time (s)";
  std::array<std::string, 3> axis_names{"x", "y", "z"};
  int width = 1200, height = 900;  // pixels (render/write_trajectory_plot)
  Color background = Color::rgb8(255, 255, 255);
};

// Draws the plot into vp of the renderer's current frame (uses vp, not plot.width/height).
// Throws std::invalid_argument when a series' t and xyz differ in size.
void draw_trajectory_plot(Renderer& renderer, const Viewport& vp, const TrajectoryPlot& plot);
// Renders the plot (plot.width x plot.height) in its own offscreen context. Another
// context current on this thread is unbound: Renderer::begin_frame binds its own again.
// Throws std::invalid_argument for bad sizes or series.
Image render_trajectory_plot(const TrajectoryPlot& plot);
// render_trajectory_plot + write_png.
void write_trajectory_plot(const std::filesystem::path& path, const TrajectoryPlot& plot);

// Points and lines of y against x with axes, ticks, a legend and a title (the benchmark's
// jitter-against-lag plots). Non-finite pairs are left out (and break a line).
struct XySeries {
  std::string label;
  Color color;
  std::vector<double> x, y;
  bool lines = false;      // connect consecutive points
  float line_px = 2.0f;
  float marker_px = 7.0f;  // dot diameter; 0: none
};

struct XyPlot {
  std::string title, x_label, y_label;
  std::vector<XySeries> series;  // drawn in order, listed in the legend
  bool y_from_zero = true;
  int width = 1200, height = 800;
  Color background = Color::rgb8(255, 255, 255);
};

// Throws std::invalid_argument when a series' x and y differ in size.
void draw_xy_plot(Renderer& renderer, const Viewport& vp, const XyPlot& plot);
Image render_xy_plot(const XyPlot& plot);
void write_xy_plot(const std::filesystem::path& path, const XyPlot& plot);

}  // namespace hs::render
