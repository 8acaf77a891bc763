#pragma once
// The panels' camera. The scene's default view (panel.hpp) shows the text with room for
// the writing hand; a runtime whose hands are elsewhere (another LOCAL origin, Monado's
// simulated hands, a hand far from the text) would be drawn off screen. So the camera
// keeps that view while every joint seen so far lies inside it, and otherwise backs off
// and re-centres, same direction and field of view, until the default view and every
// joint seen fit with a margin. The joints' box only grows: the view settles, no jumps.
#include "handsteady/track.hpp"
#include "handsteady_render/camera.hpp"
#include "panel.hpp"

#include <Eigen/Geometry>

namespace hs::demo {

class ViewFraming {
 public:
  // Keeps a reference: the scene outlives the framing.
  explicit ViewFraming(const SceneGeometry& scene) : scene_(scene) {}
  // Takes in the pose's tracked joints (a joint over 10 m from the head is a runtime
  // fault, not a hand to frame, and is left out).
  void add(const Pose& pose);
  // The camera for a panel of this aspect (width / height).
  render::Camera camera(float aspect) const;
  // Whether joints outside the default view move the camera of such a panel.
  bool reframed(float aspect) const;

 private:
  const SceneGeometry& scene_;
  Eigen::AlignedBox3d joints_;  // empty until a joint is tracked
  // Over the joints, in the default view: the largest |x - centre| / depth and
  // |y - centre| / depth (infinite for a joint at or behind the eye).
  double reach_x_ = 0.0, reach_y_ = 0.0;
};

}  // namespace hs::demo
