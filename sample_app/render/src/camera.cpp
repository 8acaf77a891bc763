#include "handsteady_render/camera.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace hs::render {

std::vector<Viewport> panel_row(int frame_width, int frame_height, int count, int gap) {
  if (count < 1 || gap < 0) {
    throw std::invalid_argument("panel_row: count must be >= 1 and gap >= 0");
  }
  const int inner = frame_width - (count + 1) * gap;
  const int panel_w = inner / count;
  const int panel_h = frame_height - 2 * gap;
  if (panel_w < 1 || panel_h < 1) {
    throw std::invalid_argument("panel_row: " + std::to_string(count) + " panels with gap " + std::to_string(gap) +
                                " do not fit a " + std::to_string(frame_width) + "x" + std::to_string(frame_height) +
                                " frame");
  }
  std::vector<Viewport> out;
  for (int i = 0; i < count; ++i) {
    const int x = gap + i * (panel_w + gap);
    const int w = i + 1 == count ? frame_width - gap - x : panel_w;
    out.push_back({x, gap, w, panel_h});
  }
  return out;
}

Camera Camera::look_at(glm::vec3 eye, glm::vec3 target, glm::vec3 up, float fov_y_deg, float aspect, float near_m,
                       float far_m) {
  if (!(fov_y_deg > 0.0f && fov_y_deg < 180.0f) || !(aspect > 0.0f) || !(near_m > 0.0f) || !(far_m > near_m)) {
    throw std::invalid_argument("Camera::look_at: need 0 < fov < 180 degrees, aspect > 0, 0 < near < far");
  }
  Camera c;
  c.view = glm::lookAt(eye, target, up);
  c.projection = glm::perspective(glm::radians(fov_y_deg), aspect, near_m, far_m);
  return c;
}

Camera Camera::facing_plane(float aspect, float distance_m, glm::vec2 center, float visible_height_m) {
  if (!(distance_m > 0.0f) || !(visible_height_m > 0.0f)) {
    throw std::invalid_argument("Camera::facing_plane: distance and visible height must be > 0");
  }
  const float fov = glm::degrees(2.0f * std::atan(0.5f * visible_height_m / distance_m));
  const glm::vec3 eye(center.x, center.y, 0.0f);
  return look_at(eye, eye + glm::vec3(0.0f, 0.0f, -distance_m), glm::vec3(0.0f, 1.0f, 0.0f), fov, aspect, 0.02f,
                 10.0f);
}

std::optional<glm::vec2> Camera::project(glm::vec3 world, const Viewport& vp) const {
  const glm::vec4 clip = projection * view * glm::vec4(world, 1.0f);
  if (!(clip.w > 0.0f)) {
    return std::nullopt;
  }
  const glm::vec2 ndc(clip.x / clip.w, clip.y / clip.w);
  return glm::vec2(static_cast<float>(vp.x) + (ndc.x * 0.5f + 0.5f) * static_cast<float>(vp.width),
                   static_cast<float>(vp.y) + (0.5f - ndc.y * 0.5f) * static_cast<float>(vp.height));
}

}  // namespace hs::render
