#include "handsteady/input_noise.hpp"
#include "handsteady/time_series.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>

namespace hs {

namespace {
Eigen::Vector3d at(const float* p) noexcept { return Eigen::Vector3f(p[0], p[1], p[2]).cast<double>(); }
// The largest noise gain of an extrapolation still used: 1 + 3^2 + 3^2 + 1 = 20 on a
// regular grid, 44 when the oldest interval is half the others.
constexpr double kMaxGain2 = 200.0;
}  // namespace

void InputNoise::reset() noexcept {
  have_ = 0;
  smooth2_.fill(0.0);
  bone_mean_.fill(0.0);
  bone_var_.fill(0.0);
  jump_.fill(0.0);
  noise2_.fill(0.0);
  smooth_n_.fill(0);
  bone_n_.fill(0);
}

void InputNoise::push(double t, std::span<const float> x) noexcept {
  if (x.size() < kFs) return;
  // Lagrange weights of the quadratic through the three rows before, at t; white noise
  // of E|n|^2 gives the residual (1 + sum of the weights squared) E|n|^2.
  std::array<double, 3> l{};
  double gain2 = 0.0;
  bool quad = have_ >= 3;
  if (quad) {
    l = quadratic_weights(t, t_[0], t_[1], t_[2]);
    gain2 = 1.0 + l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
    // Rows bunched together (a repeated timestamp nudged apart) make the extrapolation
    // meaningless: no smoothness sample from this row.
    quad = gain2 < kMaxGain2;
  }
  for (int j = 0; j < kJointCount; ++j) {
    const auto ju = static_cast<size_t>(j);
    const size_t o = 3 * ju;
    jump_[ju] = 0.0;
    const float* xj = x.data() + o;
    if (!finite_xyz(xj)) continue;
    const Eigen::Vector3d p = at(xj);
    if (quad && finite_xyz(rows_[0].data() + o) && finite_xyz(rows_[1].data() + o) && finite_xyz(rows_[2].data() + o)) {
      const Eigen::Vector3d r =
          p - l[0] * at(rows_[0].data() + o) - l[1] * at(rows_[1].data() + o) - l[2] * at(rows_[2].data() + o);
      jump_[ju] = r.norm();
      smooth2_[ju] += running_weight(smooth_n_[ju], kInputNoiseRows) * (r.squaredNorm() / gain2 - smooth2_[ju]);
    }
    const int parent = kXrParent[ju];
    if (parent < 0) continue;
    const float* xp = x.data() + 3 * static_cast<size_t>(parent);
    if (!finite_xyz(xp)) continue;
    const double len = (p - at(xp)).norm();
    // The spread about the mean before this row (a mean that follows the sample would
    // hide it); the first row only starts the mean.
    if (bone_n_[ju] > 0) {
      const double d = len - bone_mean_[ju];
      bone_var_[ju] += (1.0 / std::min<double>(bone_n_[ju], kInputNoiseRows)) * (d * d - bone_var_[ju]);
    }
    bone_mean_[ju] += running_weight(bone_n_[ju], kInputNoiseRows) * (len - bone_mean_[ju]);
  }
  // A bone's length varies by the noise of both ends along it: 2 sigma^2 per axis with
  // sigma each; E|n|^2 = 3 sigma^2 = 1.5 times that variance.
  for (size_t j = 0; j < kJointCount; ++j) noise2_[j] = std::max(smooth2_[j], 1.5 * bone_var_[j]);
  rows_[2] = rows_[1];
  rows_[1] = rows_[0];
  std::copy(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(kFs), rows_[0].begin());
  t_[2] = t_[1];
  t_[1] = t_[0];
  t_[0] = t;
  have_ = std::min(have_ + 1, 3);
}


}  // namespace hs
