#include "panel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hs::demo {
namespace {

glm::vec3 v3(const Eigen::Vector3d& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

}  // namespace

SceneGeometry scene_from_strokes(const std::vector<Polyline>& strokes) {
  SceneGeometry s;
  for (const auto& line : strokes) {
    std::vector<glm::vec3> g;
    g.reserve(line.size());
    for (const auto& p : line) g.push_back(v3(p));
    s.guides.push_back(std::move(g));
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& line : strokes)
    for (const auto& p : line) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  if (!lo.allFinite() || !hi.allFinite()) return s;
  s.centre = {static_cast<float>(0.5 * (lo.x() + hi.x())), static_cast<float>(0.5 * (lo.y() + hi.y()))};
  s.plane_z = static_cast<float>(0.5 * (lo.z() + hi.z()));
  // Room for the hand below and around the text: the text takes about 40 % of the height.
  s.visible_height_m = std::max(0.20f, static_cast<float>(2.5 * (hi.y() - lo.y())));
  s.text_width_m = static_cast<float>(hi.x() - lo.x());
  return s;
}

void draw_panel(render::Renderer& r, const render::Viewport& vp, const render::Camera& camera,
                const SceneGeometry& scene, const PanelContent& content) {
  using render::Color;
  r.set_viewport(vp);
  r.clear_viewport(Color::rgb8(246, 246, 242));
  r.set_camera(camera);
  // Guide strokes of the font: what the user means to write.
  if (!scene.guides.empty()) {
    const Color guide = Color::rgb8(200, 200, 215);
    r.polylines3d(scene.guides, std::span<const Color>(&guide, 1), 9.0f);
  }
  // Ink.
  if (content.ink && !content.ink->empty()) {
    std::vector<std::vector<glm::vec3>> lines;
    for (const auto& s : *content.ink) {
      std::vector<glm::vec3> l;
      l.reserve(s.p.size());
      for (const auto& p : s.p) l.push_back(v3(p));
      lines.push_back(std::move(l));
    }
    r.polylines3d(lines, std::span<const Color>(&content.ink_color, 1), 3.0f);
  }
  // The hand.
  if (content.hand && any_joint_tracked(*content.hand)) {
    render::HandStyle style;
    style.highlight = content.pen_down ? content.ink_color : Color::rgb8(150, 150, 150);
    r.draw_hand(*content.hand, style);
  }
  render::TextStyle title;
  title.size_px = 22.0f;
  title.stroke_px = 2.0f;
  r.text(content.label, {14.0f, 14.0f}, [&] {
    render::TextStyle t = title;
    t.valign = render::VAlign::Top;
    return t;
  }());
  if (!content.subtitle.empty()) {
    render::TextStyle sub;
    sub.size_px = 13.0f;
    sub.stroke_px = 1.3f;
    sub.valign = render::VAlign::Bottom;
    sub.color = Color::rgb8(60, 60, 60);
    r.text(content.subtitle, {14.0f, static_cast<float>(vp.height) - 12.0f}, sub);
  }
  r.stroke_rect(0.0f, 0.0f, static_cast<float>(vp.width), static_cast<float>(vp.height), Color::rgb8(120, 120, 120),
                2.0f);
}

}  // namespace hs::demo
