#pragma once
// One panel of the demo: the writing plane with the font's guide strokes, the ink, the
// right hand as the app received it, and a label. Same camera for every panel
// (framing.hpp).
#include "handsteady/ink.hpp"
#include "handsteady_render/renderer.hpp"

#include <string>
#include <vector>

namespace hs::demo {

struct PanelContent {
  std::string label;     // "raw", "HandSteady (denoise)", ...
  std::string subtitle;  // e.g. live metrics
  render::Color ink_color;
  const std::vector<InkStroke>* ink = nullptr;
  const Pose* hand = nullptr;  // nullptr or all-NaN: not drawn
  bool pen_down = false;
};

struct SceneGeometry {
  std::vector<std::vector<glm::vec3>> guides;  // font strokes (faint), converted once; may be empty
  float plane_z = -0.45f;
  glm::vec2 centre{0.0f, 0.0f};
  float visible_height_m = 0.30f;  // of the plane, for a 4:3 panel
  float text_width_m = 0.0f;       // the text's extent: every panel shows all of it
};

// Camera and plane placement from the font strokes (their bounding box), else defaults.
SceneGeometry scene_from_strokes(const std::vector<Polyline>& strokes);

void draw_panel(render::Renderer& r, const render::Viewport& vp, const render::Camera& camera,
                const SceneGeometry& scene, const PanelContent& content);

}  // namespace hs::demo
