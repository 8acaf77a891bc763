#pragma once
// Viewports (panels of a frame) and 3D cameras (OpenXR convention: metres, +Y up,
// -Z forward).
#include <glm/glm.hpp>

#include <optional>
#include <vector>

namespace hs::render {

// A rectangle of the frame in pixels: origin at the frame's top-left, y down.
struct Viewport {
  int x = 0, y = 0, width = 0, height = 0;
  float aspect() const { return height > 0 ? static_cast<float>(width) / static_cast<float>(height) : 1.0f; }
  bool contains(int px, int py) const { return px >= x && px < x + width && py >= y && py < y + height; }
  friend bool operator==(const Viewport&, const Viewport&) = default;
};

// `count` equal panels side by side filling a frame, `gap` pixels between and around
// them (the last panel takes the rounding remainder). Throws std::invalid_argument when
// they would not fit (or count < 1, gap < 0).
std::vector<Viewport> panel_row(int frame_width, int frame_height, int count, int gap = 0);

// The default distance from the eyes to the writing plane (metres).
inline constexpr float kWritingPlaneDistance = 0.45f;

struct Camera {
  glm::mat4 view{1.0f};        // world -> eye
  glm::mat4 projection{1.0f};  // eye -> clip (OpenGL, depth -1..1)

  // glm::lookAt + glm::perspective (vertical field of view in degrees).
  static Camera look_at(glm::vec3 eye, glm::vec3 target, glm::vec3 up, float fov_y_deg, float aspect,
                        float near_m = 0.01f, float far_m = 10.0f);
  // The user facing a vertical writing plane: eye at (center.x, center.y, 0) looking
  // down -Z at the plane z = -distance, +Y up, the field of view fitting visible_height
  // metres of the plane (0.30 m at 0.45 m: 36.9 degrees).
  static Camera facing_plane(float aspect, float distance_m = kWritingPlaneDistance,
                             glm::vec2 center = {0.0f, 0.0f}, float visible_height_m = 0.30f);

  glm::mat4 view_projection() const { return projection * view; }
  // Where a world point lands in vp, in frame pixels (origin top-left, y down, pixel
  // (i, j) covers [i, i+1) x [j, j+1)); nullopt at or behind the eye.
  std::optional<glm::vec2> project(glm::vec3 world, const Viewport& vp) const;
};

}  // namespace hs::render
