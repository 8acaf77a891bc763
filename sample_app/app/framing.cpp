#include "framing.hpp"

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace hs::demo {
namespace {

constexpr double kMaxReach_m = 10.0;
constexpr double kMargin = 0.9;       // joints within 90 % of the half-extents: discs not cut at the border
constexpr double kMinDepth_m = 0.05;  // nearest joint's distance in front of the eye

// A camera looking down -Z with +Y up: the eye, the tangents of the half angles and the
// height of the plane it shows.
struct View {
  Eigen::Vector3d eye;
  double tan_x, tan_y;
  float height;
};

// The default view: the eye at the LOCAL origin's depth (the user's head), facing the
// writing plane, the text's width fitting the panel.
View default_view(const SceneGeometry& scene, float aspect) {
  const float height = std::max(scene.visible_height_m, 1.15f * scene.text_width_m / aspect);
  const double tan_y = 0.5 * static_cast<double>(height) / -static_cast<double>(scene.plane_z);
  return {{scene.centre.x, scene.centre.y, 0.0}, tan_y * static_cast<double>(aspect), tan_y, height};
}

template <class F>
void for_corners(const Eigen::AlignedBox3d& box, F f) {
  for (int i = 0; i < 8; ++i) f(box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(i)));
}

}  // namespace

void ViewFraming::add(const Pose& pose) {
  const View v = default_view(scene_, 1.0f);  // the eye does not depend on the aspect
  for (int j = 0; j < kJointCount; ++j) {
    if (!joint_tracked(pose, j)) continue;
    const Eigen::Vector3d p = pose.row(j).transpose();
    if (p.norm() > kMaxReach_m) continue;
    joints_.extend(p);
    const double d = v.eye.z() - p.z();
    const double inf = std::numeric_limits<double>::infinity();
    reach_x_ = std::max(reach_x_, d >= kMinDepth_m ? std::abs(p.x() - v.eye.x()) / d : inf);
    reach_y_ = std::max(reach_y_, d >= kMinDepth_m ? std::abs(p.y() - v.eye.y()) / d : inf);
  }
}

bool ViewFraming::reframed(float aspect) const {
  const View v = default_view(scene_, aspect);
  return reach_x_ > kMargin * v.tan_x || reach_y_ > kMargin * v.tan_y;
}

render::Camera ViewFraming::camera(float aspect) const {
  View v = default_view(scene_, aspect);
  if (!reframed(aspect)) return render::Camera::facing_plane(aspect, -scene_.plane_z, scene_.centre, v.height);
  // The default view's rectangle on the plane and the joints, centred; the eye backs off
  // until the box's every corner fits.
  Eigen::AlignedBox3d box = joints_;
  const double distance = -static_cast<double>(scene_.plane_z);
  const Eigen::Vector3d half(distance * v.tan_x, distance * v.tan_y, 0.0);
  const Eigen::Vector3d plane_centre(scene_.centre.x, scene_.centre.y, scene_.plane_z);
  box.extend(plane_centre - half);
  box.extend(plane_centre + half);
  v.eye.head<2>() = box.center().head<2>();
  v.eye.z() = -std::numeric_limits<double>::infinity();
  for_corners(box, [&](const Eigen::Vector3d& c) {
    const double d = std::max({std::abs(c.x() - v.eye.x()) / (kMargin * v.tan_x),
                               std::abs(c.y() - v.eye.y()) / (kMargin * v.tan_y), kMinDepth_m});
    v.eye.z() = std::max(v.eye.z(), c.z() + d);
  });
  const glm::vec3 eye(static_cast<float>(v.eye.x()), static_cast<float>(v.eye.y()), static_cast<float>(v.eye.z()));
  const float fov_deg = static_cast<float>(2.0 * std::atan(v.tan_y) * 180.0 / std::numbers::pi);
  const float far_m = static_cast<float>(v.eye.z() - box.min().z() + 1.0);
  return render::Camera::look_at(eye, eye + glm::vec3(0.0f, 0.0f, -1.0f), glm::vec3(0.0f, 1.0f, 0.0f), fov_deg, aspect,
                                 0.02f, far_m);
}

}  // namespace hs::demo
