#include "handsteady/synth.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <random>

namespace hs {

namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Matrix3d rot_x(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix(); }
Eigen::Matrix3d rot_y(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix(); }

}  // namespace

Pose synth_hand_pose(const HandArticulation& art, const HandShapeParams& shape) {
  Pose p = untracked_pose();
  const double s = shape.scale;
  auto set = [&](Joint j, const Eigen::Vector3d& v) { p.row(idx(j)) = (s * v).transpose(); };
  set(Joint::Wrist, Eigen::Vector3d::Zero());
  // Four fingers: metacarpal bases near the wrist, knuckles fanned across the palm.
  // Typical adult lengths (m), wrist -> middle knuckle about 95 mm.
  const double knuckle_x[4] = {-0.030, -0.010, 0.010, 0.028};
  const double knuckle_z[4] = {-0.092, -0.095, -0.090, -0.082};
  const double lengths[4][3] = {{0.040, 0.024, 0.020}, {0.044, 0.028, 0.022}, {0.041, 0.027, 0.021}, {0.032, 0.020, 0.019}};
  const double meta_ratio[4] = {0.25, 0.24, 0.27, 0.33};
  for (int f = 0; f < 4; ++f) {
    const int base = idx(Joint::IndexMetacarpal) + 5 * f;
    const Eigen::Vector3d knuckle(knuckle_x[f], 0.0, knuckle_z[f]);
    p.row(base) = (s * meta_ratio[f] * knuckle).transpose();
    p.row(base + 1) = (s * knuckle).transpose();
    // Each finger splays out about Y, then curls about its own X axis (towards the palm, -Y).
    const double splay = (f - 1.5) * art.spread;
    const double curl = art.curl[static_cast<size_t>(f + 1)];
    Eigen::Matrix3d r = rot_y(-splay);
    Eigen::Vector3d pos = knuckle;
    for (int k = 0; k < 3; ++k) {
      r = r * rot_x(-curl * (k == 0 ? 0.8 : 1.0));  // negative about X: towards -Y, the palm
      pos += r * Eigen::Vector3d(0, 0, -lengths[f][k]);
      p.row(base + 2 + k) = (s * pos).transpose();
    }
  }
  // Thumb: from the carpometacarpal base out towards -X, curling across the palm.
  const Eigen::Vector3d cmc(-0.018, -0.012, -0.020);
  p.row(idx(Joint::ThumbMetacarpal)) = (s * cmc).transpose();
  const double thumb_len[3] = {0.045, 0.032, 0.028};
  Eigen::Matrix3d r = rot_y(0.9) * Eigen::AngleAxisd(-0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Vector3d pos = cmc;
  for (int k = 0; k < 3; ++k) {
    r = r * rot_x(-art.curl[0] * 0.7);
    pos += r * Eigen::Vector3d(0, 0, -thumb_len[k]);
    p.row(idx(Joint::ThumbProximal) + k) = (s * pos).transpose();
  }
  // Palm: midpoint of middle metacarpal and middle proximal, as the importers derive it.
  p.row(idx(Joint::Palm)) = 0.5 * (p.row(idx(Joint::MiddleMetacarpal)) + p.row(idx(Joint::MiddleProximal)));
  return p;
}

Pose transform_pose(const Pose& local, const Eigen::Quaterniond& rotation, const Eigen::Vector3d& position) {
  Pose out = untracked_pose();
  const Eigen::Matrix3d r = rotation.toRotationMatrix();
  for (int j = 0; j < kJointCount; ++j) {
    if (!joint_tracked(local, j)) continue;
    out.row(j) = (r * local.row(j).transpose() + position).transpose();
  }
  return out;
}

HandSeries synth_motion(const SynthMotionParams& prm, Hand hand, uint64_t seed) {
  std::mt19937_64 rng(seed);
  // Phases from raw 64-bit draws so the output is identical across standard libraries.
  auto phase = [&] { return 2.0 * kPi * static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  double ph[16];
  for (double& v : ph) v = phase();
  // Motion is made for a right hand at +X; a left hand is its mirror image (at -X).
  const Eigen::Vector3d centre(0.15, -0.25, -0.40);
  const int n = static_cast<int>(std::floor(prm.duration_s * prm.rate_hz)) + 1;
  HandSeries s;
  s.t.reserve(static_cast<size_t>(n));
  s.pos.reserve(static_cast<size_t>(n));
  const double w = 2.0 * kPi * prm.speed_hz;
  for (int i = 0; i < n; ++i) {
    const double t = i / prm.rate_hz;
    const Eigen::Vector3d pos = centre + prm.reach_m * Eigen::Vector3d(std::sin(w * t + ph[0]) + 0.3 * std::sin(2.3 * w * t + ph[1]),
                                                                       0.6 * std::sin(0.7 * w * t + ph[2]),
                                                                       0.5 * std::sin(1.3 * w * t + ph[3]));
    const double a = prm.rotation_rad;
    const Eigen::Quaterniond rot = Eigen::AngleAxisd(a * std::sin(0.5 * w * t + ph[4]), Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(0.5 * a * std::sin(0.8 * w * t + ph[5]), Eigen::Vector3d::UnitX()) *
                                   Eigen::AngleAxisd(0.4 * a * std::sin(0.6 * w * t + ph[6]), Eigen::Vector3d::UnitZ());
    HandArticulation art;
    for (int f = 0; f < 5; ++f)
      art.curl[static_cast<size_t>(f)] = 0.55 + 0.5 * std::sin(1.7 * w * t + ph[7 + f]);
    art.spread = 0.12 + 0.06 * std::sin(0.9 * w * t + ph[12]);
    Pose p = transform_pose(synth_hand_pose(art), rot, pos);
    if (hand == Hand::Left) p.col(0) *= -1.0;
    s.t.push_back(t);
    s.pos.push_back(p);
  }
  return s;
}

Track synth_track(const SynthMotionParams& prm, uint64_t seed) {
  Track tr;
  tr.set_meta("source", fmt::format("synthetic hand motion (handsteady synth), seed {}", seed));
  tr.set_meta("rate_hz", fmt::format("{}", prm.rate_hz));
  add_hand_series(tr, Hand::Left, synth_motion(prm, Hand::Left, seed * 2 + 1));
  add_hand_series(tr, Hand::Right, synth_motion(prm, Hand::Right, seed * 2 + 2));
  return tr;
}

}  // namespace hs
