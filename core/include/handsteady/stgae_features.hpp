#pragma once
// The network's input (stgae_model.hpp, step 1: hole filling, the 6 features per joint)
// and its positional encoding (step 4), written once for the Eigen engine (float or
// double) and libtorch training (double). Header-only: the engine's streaming step
// inlines them and allocates nothing.
#include "handsteady/skeleton.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <vector>

namespace hs {

// The joints features are relative to: "wrist" (else the skeleton's root, else joint 0)
// and "palm" (-1 if the skeleton has none).
struct StgaeAnchors {
  int wrist = 0, palm = -1;
};
inline StgaeAnchors stgae_anchors(const Skeleton& sk) {
  StgaeAnchors a;
  a.wrist = -1;
  for (int j = 0; j < sk.joint_count(); ++j) {
    if (sk.joint_names[static_cast<size_t>(j)] == "wrist") a.wrist = j;
    if (sk.joint_names[static_cast<size_t>(j)] == "palm") a.palm = j;
  }
  if (a.wrist < 0)
    for (int j = 0; j < sk.joint_count(); ++j)
      if (sk.parent[static_cast<size_t>(j)] < 0) a.wrist = j;
  if (a.wrist < 0) a.wrist = 0;
  return a;
}

// Hole filling over a sequence: a missing joint holds its last valid position; a joint
// never seen since reset takes the filled wrist, else the palm, else the mean of the seen
// joints. State: the last valid position of each joint.
template <class S>
class StgaeHoleFiller {
 public:
  StgaeHoleFiller() = default;
  StgaeHoleFiller(int joints, StgaeAnchors anchors)
      : last_(Eigen::Matrix<S, Eigen::Dynamic, 3>::Zero(joints, 3)),
        seen_(static_cast<size_t>(joints), 0),
        anchors_(anchors) {}
  void reset() noexcept {
    std::fill(seen_.begin(), seen_.end(), static_cast<unsigned char>(0));
    any_ = false;
  }
  // raw: 3N values (joint-major xyz, NaN = missing); out: N x 3. Returns false (state
  // unchanged) when no joint of this frame or of any earlier one since reset is valid.
  template <class D>
  bool fill(const S* raw, Eigen::MatrixBase<D>& out) noexcept {
    const auto n = static_cast<int>(last_.rows());
    bool now = false;
    for (int j = 0; j < n && !now; ++j) now = valid(raw + 3 * j);
    if (!now && !any_) return false;
    for (int j = 0; j < n; ++j)
      if (valid(raw + 3 * j)) {
        for (int c = 0; c < 3; ++c) last_(j, c) = raw[3 * j + c];
        seen_[static_cast<size_t>(j)] = 1;
      }
    any_ = true;
    int src = -1;
    if (seen_[static_cast<size_t>(anchors_.wrist)]) src = anchors_.wrist;
    else if (anchors_.palm >= 0 && seen_[static_cast<size_t>(anchors_.palm)]) src = anchors_.palm;
    S fill_value[3] = {S(0), S(0), S(0)};
    if (src >= 0) {
      for (int c = 0; c < 3; ++c) fill_value[c] = last_(src, c);
    } else {
      int cnt = 0;
      for (int j = 0; j < n; ++j)
        if (seen_[static_cast<size_t>(j)]) {
          for (int c = 0; c < 3; ++c) fill_value[c] += last_(j, c);
          ++cnt;
        }
      for (int c = 0; c < 3; ++c) fill_value[c] /= static_cast<S>(cnt);
    }
    for (int j = 0; j < n; ++j)
      for (int c = 0; c < 3; ++c) out(j, c) = seen_[static_cast<size_t>(j)] ? last_(j, c) : fill_value[c];
    return true;
  }

 private:
  static bool valid(const S* r) noexcept { return std::isfinite(r[0]) && std::isfinite(r[1]) && std::isfinite(r[2]); }
  Eigen::Matrix<S, Eigen::Dynamic, 3> last_;
  std::vector<unsigned char> seen_;
  StgaeAnchors anchors_;
  bool any_ = false;
};

// Features of one frame from its filled positions x (N x 3) and the previous frame's
// (nullptr: first frame since reset): f (N x 6) = [(x - x[wrist]) * inv_shape,
// (x - prev) * inv_vel or 0]. inv_shape = 1 / shape_scale_m, inv_vel = 1 / velocity_scale_m.
template <class S, class DX, class DP, class DF>
void stgae_frame_features(const Eigen::MatrixBase<DX>& x, const Eigen::MatrixBase<DP>* prev, int wrist, S inv_shape,
                          S inv_vel, Eigen::MatrixBase<DF>& f) noexcept {
  for (Eigen::Index j = 0; j < x.rows(); ++j)
    for (int c = 0; c < 3; ++c) {
      f(j, c) = (x(j, c) - x(wrist, c)) * inv_shape;
      f(j, 3 + c) = prev ? (x(j, c) - (*prev)(j, c)) * inv_vel : S(0);
    }
}

// Sinusoidal positional encoding of predicted frame i, channel c of `channels`:
// sin(i / 10000^(2m/C)) for c = 2m, cos for c = 2m + 1.
inline double stgae_positional_encoding(int i, int c, int channels) {
  const int two_m = c - c % 2;
  const double angle = i / std::pow(10000.0, static_cast<double>(two_m) / channels);
  return c % 2 == 0 ? std::sin(angle) : std::cos(angle);
}

}  // namespace hs
