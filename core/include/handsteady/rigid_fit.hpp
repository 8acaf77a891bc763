#pragma once
// A similarity (rotation, translation, uniform scale) fitted by least squares to matched
// points (Kabsch, with Umeyama's scale): the palm fit's template onto a row, and the trust
// region's frames onto each other, and the app's base space onto the layer's world
// (plugin/src/joint_rewrite.cpp, when xrLocateSpace fails).
#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

namespace hs {

struct Rigid {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double s = 1.0;
  Eigen::Vector3d apply(const Eigen::Vector3d& p) const { return s * (r * p) + t; }
  Eigen::Vector3d invert(const Eigen::Vector3d& q) const { return r.transpose() * (q - t) / s; }
};

// The rotation, translation and scale taking points a to points b (least squares over the
// points with use[i]; scale 1 unless `scaled`). False when they do not fix a rotation
// (under 3 points, collinear).
template <size_t P>
bool kabsch(const std::array<Eigen::Vector3d, P>& a, const std::array<Eigen::Vector3d, P>& b,
            const std::array<bool, P>& use, Rigid& out, bool scaled = true) {
  using V3 = Eigen::Vector3d;
  V3 ca = V3::Zero(), cb = V3::Zero();
  int n = 0;
  for (size_t i = 0; i < P; ++i)
    if (use[i]) {
      ca += a[i];
      cb += b[i];
      ++n;
    }
  if (n < 3) return false;
  ca /= n;
  cb /= n;
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < P; ++i)
    if (use[i]) h += (a[i] - ca) * (b[i] - cb).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  if (!(sv(1) > 1e-9 * std::max(sv(0), 1e-30))) return false;  // collinear points
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) d(2, 2) = -1.0;
  out.r = svd.matrixV() * d * svd.matrixU().transpose();
  // Uniform scale (Umeyama): trackers that re-estimate the hand's size as they go (Leap
  // Motion does, by up to 10 % between takes and 3 % within one) stay fitted.
  double va = 0.0;
  for (size_t i = 0; i < P; ++i)
    if (use[i]) va += (a[i] - ca).squaredNorm();
  const double tr = sv(0) * d(0, 0) + sv(1) * d(1, 1) + sv(2) * d(2, 2);
  out.s = scaled && va > 0.0 && tr > 0.0 ? tr / va : 1.0;
  out.t = cb - out.s * (out.r * ca);
  return true;
}

// How far each used joint of b disagrees with a (the palm fit's template; the trust
// region's frame before) by its distances to the other used joints, which do not change
// as a rigid body moves (so this needs no fit): a low quantile of |distance - s * distance
// in a| over the others. s is the hand's size: the palm fit's last fit's (it changes slowly;
// a median over pairs would be pulled by the joints that jumped), else (s <= 0) the median
// ratio. A joint that jumped disagrees with most others; a good joint only with the few
// that jumped. Unused joints score 0.
template <size_t P>
void distance_scores(const std::array<Eigen::Vector3d, P>& a, const std::array<Eigen::Vector3d, P>& b,
                     const std::array<bool, P>& use, double s, std::array<double, P>& score) {
  std::array<double, P * P> ratio{};
  size_t n = 0;
  for (size_t i = 0; i < P; ++i)
    for (size_t j = i + 1; j < P; ++j)
      if (use[i] && use[j]) {
        const double d0 = (a[i] - a[j]).norm();
        if (d0 > 0.0) ratio[n++] = (b[i] - b[j]).norm() / d0;
      }
  score.fill(0.0);
  if (n == 0) return;
  if (!(s > 0.0)) {
    std::nth_element(ratio.begin(), ratio.begin() + n / 2, ratio.begin() + n);
    s = ratio[n / 2];
  }
  std::array<double, P> dev{};
  for (size_t i = 0; i < P; ++i) {
    if (!use[i]) continue;
    size_t m = 0;
    for (size_t j = 0; j < P; ++j)
      if (j != i && use[j]) dev[m++] = std::abs((b[i] - b[j]).norm() - s * (a[i] - a[j]).norm());
    if (m == 0) continue;
    const size_t q = (m - 1) / 3;
    std::nth_element(dev.begin(), dev.begin() + q, dev.begin() + m);
    score[i] = dev[q];
  }
}

}  // namespace hs
