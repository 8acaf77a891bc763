#pragma once
// Small pose helpers shared by the layer, the replay runtime and the tests:
// XrPosef <-> Eigen rigid transforms (the bone each joint's orientation follows is
// hs::kXrFrameBone, handsteady/skeleton.hpp).
#include <openxr/openxr.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <utility>

namespace hs::xr {

using Rigid = Eigen::Transform<double, 3, Eigen::Isometry>;

inline Eigen::Vector3d to_eigen(const XrVector3f& v) { return {v.x, v.y, v.z}; }
inline XrVector3f to_xr(const Eigen::Vector3d& v) {
  return {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
}
inline Eigen::Quaterniond to_eigen(const XrQuaternionf& q) { return {q.w, q.x, q.y, q.z}; }
inline XrQuaternionf to_xr(const Eigen::Quaterniond& q) {
  return {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()),
          static_cast<float>(q.w())};
}
inline bool finite(const XrVector3f& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
// A usable orientation: finite and close to unit length.
inline bool usable(const XrQuaternionf& q) {
  if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w)) return false;
  const float n = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  return n > 0.8f && n < 1.2f;
}

inline Rigid to_rigid(const XrPosef& p) {
  Rigid r = Rigid::Identity();
  r.linear() = to_eigen(p.orientation).normalized().toRotationMatrix();
  r.translation() = to_eigen(p.position);
  return r;
}
inline XrPosef to_xr(const Rigid& r) {
  XrPosef p{};
  p.orientation = to_xr(Eigen::Quaterniond(r.rotation()).normalized());
  p.position = to_xr(Eigen::Vector3d(r.translation()));
  return p;
}

}  // namespace hs::xr
