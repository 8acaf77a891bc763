#include "handsteady/hand_shape.hpp"

#include "handsteady/skeleton.hpp"

#include <Eigen/Core>

#include <array>
#include <random>

namespace hs {

namespace {
Eigen::Vector3d row3(const Pose& p, int j) { return p.row(j).transpose(); }
}  // namespace

void apply_shape(std::vector<Pose>& poses, const ShapeVariant& shape, uint64_t seed) {
  if (shape.kind == ShapeKind::Standard) return;
  std::array<double, kJointCount> factor;
  factor.fill(shape.kind == ShapeKind::Scale ? shape.amount : 1.0);
  if (shape.kind == ShapeKind::BoneJitter) {
    std::mt19937_64 rng(seed);
    for (double& f : factor) f = 1.0 + shape.amount * (2.0 * static_cast<double>(rng() >> 11) * 0x1.0p-53 - 1.0);
  }
  const int wrist = idx(Joint::Wrist);
  for (Pose& p : poses) {
    const Pose in = p;
    switch (shape.kind) {
      case ShapeKind::Scale:
      case ShapeKind::BoneJitter: {
        // Rebuild from the wrist outwards with each bone (parent -> joint) scaled; a joint
        // whose parent is missing moves with its nearest tracked ancestor.
        std::array<Eigen::Vector3d, kJointCount> moved;
        moved.fill(Eigen::Vector3d::Zero());
        for (const int j : kXrParentFirst) {
          const int par = kXrParent[static_cast<size_t>(j)];
          if (par < 0 || !joint_tracked(in, j)) continue;
          if (!joint_tracked(in, par)) {
            moved[static_cast<size_t>(j)] = moved[static_cast<size_t>(par)];
            continue;
          }
          const Eigen::Vector3d bone = row3(in, j) - row3(in, par);
          const Eigen::Vector3d np = row3(in, par) + moved[static_cast<size_t>(par)] + factor[static_cast<size_t>(j)] * bone;
          moved[static_cast<size_t>(j)] = np - row3(in, j);
        }
        for (int j = 0; j < kJointCount; ++j)
          if (joint_tracked(in, j)) p.row(j) += moved[static_cast<size_t>(j)].transpose();
        break;
      }
      case ShapeKind::WristProximal: {
        const int mm = idx(Joint::MiddleMetacarpal);
        if (!joint_tracked(in, wrist) || !joint_tracked(in, mm)) break;
        const Eigen::Vector3d away = row3(in, wrist) - row3(in, mm);
        if (away.norm() > 1e-6) p.row(wrist) += (shape.amount * away.normalized()).transpose();
        break;
      }
      case ShapeKind::PalmCentroid: {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int n = 0;
        for (const Joint j : {Joint::IndexMetacarpal, Joint::MiddleMetacarpal, Joint::RingMetacarpal, Joint::LittleMetacarpal,
                              Joint::IndexProximal, Joint::MiddleProximal, Joint::RingProximal, Joint::LittleProximal})
          if (joint_tracked(in, idx(j))) {
            sum += row3(in, idx(j));
            ++n;
          }
        if (n == 8 && joint_tracked(in, idx(Joint::Palm))) p.row(idx(Joint::Palm)) = (sum / n).transpose();
        break;
      }
      case ShapeKind::ThumbBase: {
        const int tm = idx(Joint::ThumbMetacarpal);
        if (joint_tracked(in, tm) && joint_tracked(in, wrist))
          p.row(tm) = in.row(tm) + shape.amount * (in.row(wrist) - in.row(tm));
        break;
      }
      case ShapeKind::Standard: break;
    }
  }
}

HandSeries apply_shape(const HandSeries& series, const ShapeVariant& shape, uint64_t seed) {
  HandSeries out = series;
  apply_shape(out.pos, shape, seed);
  return out;
}

}  // namespace hs
