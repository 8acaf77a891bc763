#pragma once
// Drawing on a GlContext: frames, panels (viewports), a 3D camera, thick lines, round
// points, polylines, filled quads, hands, and a 2D overlay in pixels with Hershey text.
// Drawing is immediate (each call is drawn before it returns) and in call order, later
// over earlier (no depth test): draw the plane, then the ink, then the hand.
#include "handsteady/track.hpp"
#include "handsteady_render/camera.hpp"
#include "handsteady_render/context.hpp"
#include "handsteady_render/image.hpp"

#include <glm/glm.hpp>

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace hs::render {

class HersheyFont;

// How draw_hand draws: bones as lines, joints as discs (sizes in pixels).
struct HandStyle {
  Color bone = Color::rgb8(40, 180, 165);
  Color joint = Color::rgb8(255, 140, 30);
  float bone_width_px = 4.0f;
  float joint_diameter_px = 9.0f;
  // One joint drawn larger in its own colour (the index fingertip that writes); -1: none.
  int highlight_joint = hs::idx(hs::Joint::IndexTip);
  Color highlight = Color::rgb8(255, 60, 60);
  float highlight_diameter_px = 13.0f;
};

enum class Align { Left, Center, Right };
// Baseline: y is the baseline; Top: the top of the capitals; Middle: half the capital
// height; Bottom: the bottom of descenders (g, p, y).
enum class VAlign { Baseline, Top, Middle, Bottom };

struct TextStyle {
  float size_px = 16.0f;  // height of the capitals in pixels
  Color color{0.0f, 0.0f, 0.0f, 1.0f};
  float stroke_px = 1.5f;  // pen width in pixels
  Align align = Align::Left;
  VAlign valign = VAlign::Baseline;
  float angle_deg = 0.0f;  // counter-clockwise on screen, about the anchor
};

// An axis-aligned rectangle in overlay pixels.
struct Box {
  float x = 0.0f, y = 0.0f, width = 0.0f, height = 0.0f;
  bool contains(float px, float py) const { return px >= x && px <= x + width && py >= y && py <= y + height; }
};

class Renderer {
 public:
  // Compiles the embedded shaders on ctx (made current). font_name: the Hershey font of
  // text(), loaded on first use. Throws RenderError when a shader does not build.
  explicit Renderer(GlContext& ctx, std::string font_name = "rowmans");
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  GlContext& context() { return ctx_; }
  int width() const { return ctx_.width(); }
  int height() const { return ctx_.height(); }

  // Makes the context current, clears the whole frame and selects the whole frame as
  // the viewport.
  void begin_frame(Color clear);
  // Later drawing goes into vp (clipped to it); overlay coordinates start at its
  // top-left. Throws std::invalid_argument for an empty viewport or one outside the frame.
  void set_viewport(const Viewport& vp);
  const Viewport& viewport() const { return viewport_; }
  Viewport full_frame() const { return {0, 0, width(), height()}; }
  // Fills the current viewport.
  void clear_viewport(Color color);
  // The camera of the 3D calls below.
  void set_camera(const Camera& camera) { camera_ = camera; }
  const Camera& camera() const { return camera_; }

  // 3D, world metres through the camera. Widths and diameters are in pixels.
  void line3d(glm::vec3 a, glm::vec3 b, Color color, float width_px);
  // Round joins and caps; fewer than two points draws nothing.
  void polyline3d(std::span<const glm::vec3> points, Color color, float width_px);
  // Several polylines (the ink) in one draw: colors has one colour for all or one per
  // polyline (else std::invalid_argument).
  void polylines3d(std::span<const std::vector<glm::vec3>> lines, std::span<const Color> colors, float width_px);
  void points3d(std::span<const glm::vec3> points, Color color, float diameter_px);
  // The quad a-b-c-d (in order around it), e.g. the writing plane.
  void fill_quad3d(glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d, Color color);
  // Bones of the XR skeleton between tracked joints and discs at tracked joints; NaN
  // (untracked) joints and their bones are skipped. Sorted back to front.
  void draw_hand(const hs::Pose& pose, const HandStyle& style = {});

  // 2D overlay, pixels from the current viewport's top-left, y down.
  void fill_rect(float x, float y, float w, float h, Color color);
  // The outline of a rectangle, a line of width_px centred on its edges.
  void stroke_rect(float x, float y, float w, float h, Color color, float width_px);
  void line2d(glm::vec2 a, glm::vec2 b, Color color, float width_px);
  void polyline2d(std::span<const glm::vec2> points, Color color, float width_px);
  void disc2d(glm::vec2 center, float diameter_px, Color color);
  // Draws text anchored at pos (see TextStyle); returns the box its pixels lie in.
  Box text(std::string_view s, glm::vec2 pos, const TextStyle& style = {});
  // The box text() would draw into, without drawing.
  Box measure_text(std::string_view s, glm::vec2 pos, const TextStyle& style = {}) const;

  // Waits for drawing and reads the whole frame (rows top-down).
  Image read_pixels() { return ctx_.read_pixels(); }

 private:
  struct Stroke;  // one capsule instance
  struct Gl;      // programs, vertex arrays, buffers
  void draw_strokes(const std::vector<Stroke>& strokes, const glm::mat4& mvp);
  void draw_triangles(std::span<const glm::vec3> positions, Color color, const glm::mat4& mvp);
  glm::mat4 overlay_matrix() const;
  const HersheyFont& font() const;
  std::vector<std::vector<glm::vec2>> text_strokes(std::string_view s, glm::vec2 pos, const TextStyle& style,
                                                   Box& box) const;

  GlContext& ctx_;
  std::unique_ptr<Gl> gl_;
  std::string font_name_;
  mutable std::unique_ptr<HersheyFont> font_;
  Viewport viewport_;
  Camera camera_;
};

}  // namespace hs::render
