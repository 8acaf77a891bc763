// Pinched and open hand poses (parametric or picked from a real recording), the hand
// frame they live in, and the bone-wise blend between them (docs/HANDWRITING.md).
#include "handsteady/error.hpp"
#include "handsteady/handwriting.hpp"
#include "handsteady/synth.hpp"
#include "handsteady/track_ops.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace hs {

namespace {

Eigen::Vector3d joint(const Pose& p, Joint j) { return p.row(idx(j)).transpose(); }
void set_joint(Pose& p, int j, const Eigen::Vector3d& v) { p.row(j) = v.transpose(); }

bool fully_tracked(const Pose& p) { return tracked_joint_count(p) == kJointCount; }

// ---- parametric hand -------------------------------------------------------------------

// synth_hand_pose: a right hand, palm down (-Y), fingers along -Z, thumb towards -X: the
// hand frame used here.
Pose parametric_right_hand(const HandArticulation& art) { return synth_hand_pose(art); }

// Finger curls of the writing hand: index flexed as in a pinch (about 130 deg summed over
// its three joints), middle, ring and little curled into the palm.
HandArticulation writing_articulation(double thumb_curl) {
  HandArticulation art;
  art.curl = {thumb_curl, 0.8, 1.35, 1.45, 1.5};
  art.spread = 0.08;
  return art;
}

constexpr int kThumbFirst = idx(Joint::ThumbProximal), kThumbLast = idx(Joint::ThumbTip);
constexpr double kMinThumbCurl = 0.2;  // a relaxed thumb is never fully straight

Pose moved_thumb(const Pose& p, const Eigen::Quaterniond& q, const Eigen::Vector3d& shift) {
  Pose out = p;
  const Eigen::Vector3d pivot = joint(p, Joint::ThumbMetacarpal);
  set_joint(out, idx(Joint::ThumbMetacarpal), pivot + shift);
  for (int j = kThumbFirst; j <= kThumbLast; ++j) set_joint(out, j, pivot + shift + q * (p.row(j).transpose() - pivot));
  return out;
}

double thumb_reach(double curl) {
  const Pose p = parametric_right_hand(writing_articulation(curl));
  return (joint(p, Joint::ThumbTip) - joint(p, Joint::ThumbMetacarpal)).norm();
}

// The parametric thumb curls in one plane only and, with its base close to the wrist, is
// too short to reach a pinching index tip. So: curl sets the metacarpal -> tip distance
// (bisection; it shrinks as the thumb curls), the chain is turned rigidly about the
// thumb metacarpal joint to point at the target and, when even the least curled thumb
// falls short, the whole thumb (metacarpal joint included) slides along that line by the
// shortfall. Thumb bone lengths are kept; only wrist -> thumb_metacarpal changes, as if
// the thumb's base sat further forward (as it does on real hands).
Pose parametric_hand_with_thumb_tip_at(const Eigen::Vector3d& target) {
  const Eigen::Vector3d pivot = joint(parametric_right_hand(writing_articulation(0.0)), Joint::ThumbMetacarpal);
  const double need = (target - pivot).norm();
  double lo = kMinThumbCurl, hi = 2.0;  // reach(lo) >= need >= reach(hi) after the bisection
  if (need >= thumb_reach(lo)) hi = lo;
  for (int it = 0; it < 60 && hi > lo; ++it) {
    const double mid = 0.5 * (lo + hi);
    (thumb_reach(mid) > need ? lo : hi) = mid;
  }
  const Pose curled = parametric_right_hand(writing_articulation(0.5 * (lo + hi)));
  const Eigen::Vector3d tip = joint(curled, Joint::ThumbTip) - pivot, to_target = target - pivot;
  const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(tip, to_target);
  const Eigen::Vector3d shift = std::max(0.0, need - tip.norm()) * to_target.normalized();
  return moved_thumb(curled, q, shift);
}

// ---- picking real frames ---------------------------------------------------------------

double median_of(std::vector<double> v) {
  if (v.empty()) return kNaN;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Tracker glitches (a thumb snapped onto the index) show as bones of the wrong length:
// keep frames whose every bone is within 20 % of that bone's median length.
std::vector<size_t> plausible_frames(const HandSeries& s) {
  const auto& bones = xr_hand_skeleton().bones;
  std::vector<size_t> full;
  for (size_t i = 0; i < s.size(); ++i)
    if (fully_tracked(s.pos[i])) full.push_back(i);
  std::vector<double> median_len(bones.size());
  for (size_t b = 0; b < bones.size(); ++b) {
    std::vector<double> len;
    for (size_t i : full) len.push_back((s.pos[i].row(bones[b].first) - s.pos[i].row(bones[b].second)).norm());
    median_len[b] = median_of(std::move(len));
  }
  std::vector<size_t> out;
  for (size_t i : full) {
    bool ok = true;
    for (size_t b = 0; b < bones.size() && ok; ++b) {
      const double len = (s.pos[i].row(bones[b].first) - s.pos[i].row(bones[b].second)).norm();
      ok = std::abs(len - median_len[b]) <= 0.2 * median_len[b];
    }
    if (ok) out.push_back(i);
  }
  return out;
}

// How different the index, middle, ring and little fingers are (mean joint distance, hand
// frame): the open frame should differ from the pinched one in the thumb. The index tip
// carries the pen, so an index that changed shape between the two frames would move the
// whole hand at every pen lift (48 mm in 0.15 s on a HoloLens 2 recording) while the tip
// stays put: not how people open a pinch, and a motion no tracker data trains for.
double fingers_difference(const Pose& a, const Pose& b) {
  double sum = 0.0;
  for (int j = idx(Joint::IndexMetacarpal); j <= idx(Joint::LittleTip); ++j) sum += (a.row(j) - b.row(j)).norm();
  return sum / (idx(Joint::LittleTip) - idx(Joint::IndexMetacarpal) + 1);
}

// The hand with more fully tracked frames; a left hand becomes a right hand by mirroring.
struct RecordedRightHand {
  HandSeries series;
  bool mirrored = false;
};

RecordedRightHand recorded_right_hand(const Track& track) {
  HandSeries right = hand_series(track, Hand::Right), left = hand_series(track, Hand::Left);
  const auto full_count = [](const HandSeries& s) { return std::count_if(s.pos.begin(), s.pos.end(), fully_tracked); };
  if (full_count(left) <= full_count(right)) return {std::move(right), false};
  for (Pose& p : left.pos) p = mirror_pose(p);
  return {std::move(left), true};
}

constexpr double kMaxRecordedPinch_m = 0.015;  // closer than this, thumb and index touch

size_t most_pinched_frame(const HandSeries& s, const std::vector<size_t>& frames) {
  size_t best = frames.front();
  for (size_t i : frames)
    if (thumb_index_distance(s.pos[i]) < thumb_index_distance(s.pos[best])) best = i;
  return best;
}

// Among frames with the thumb tip 5-7 cm from the index tip, the one whose four fingers
// are most like the pinched frame's.
std::optional<size_t> open_frame_like(const HandSeries& s, const std::vector<size_t>& frames,
                                      const Pose& pinched_local) {
  std::optional<size_t> open;
  double best = std::numeric_limits<double>::infinity();
  for (size_t i : frames) {
    const double d = thumb_index_distance(s.pos[i]);
    if (d < 0.05 || d > 0.07) continue;
    const double diff = fingers_difference(to_hand_frame(s.pos[i]), pinched_local);
    if (diff < best) {
      best = diff;
      open = i;
    }
  }
  return open;
}

// Joints in parent-first order (the XR order has palm, whose parent is the wrist, first).
const std::vector<int>& parent_first_order() {
  static const std::vector<int> order = [] {
    const auto& parent = xr_hand_skeleton().parent;
    std::vector<int> o;
    std::vector<bool> done(parent.size(), false);
    while (o.size() < parent.size())
      for (size_t j = 0; j < parent.size(); ++j)
        if (!done[j] && (parent[j] < 0 || done[static_cast<size_t>(parent[j])])) {
          done[j] = true;
          o.push_back(static_cast<int>(j));
        }
    return o;
  }();
  return order;
}

Eigen::Vector3d slerp_direction(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double w) {
  const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(a, b);
  return Eigen::Quaterniond::Identity().slerp(w, q) * a;
}

}  // namespace

double thumb_index_distance(const Pose& p) {
  if (!joint_tracked(p, idx(Joint::ThumbTip)) || !joint_tracked(p, idx(Joint::IndexTip))) return kNaN;
  return (joint(p, Joint::ThumbTip) - joint(p, Joint::IndexTip)).norm();
}

Pose to_hand_frame(const Pose& world) {
  for (Joint j : {Joint::Wrist, Joint::IndexProximal, Joint::MiddleProximal, Joint::LittleProximal})
    if (!joint_tracked(world, idx(j)))
      throw std::invalid_argument(
          fmt::format("to_hand_frame: joint '{}' is not tracked", xr_joint_names()[static_cast<size_t>(idx(j))]));
  const Eigen::Vector3d wrist = joint(world, Joint::Wrist);
  const Eigen::Vector3d z = (wrist - joint(world, Joint::MiddleProximal)).normalized();  // fingers along -Z
  const Eigen::Vector3d across = joint(world, Joint::LittleProximal) - joint(world, Joint::IndexProximal);
  const Eigen::Vector3d x = (across - across.dot(z) * z).normalized();  // towards the little finger
  Eigen::Matrix3d r;  // columns: hand axes in world coordinates
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  Pose local = untracked_pose();
  for (int j = 0; j < kJointCount; ++j)
    if (joint_tracked(world, j)) local.row(j) = (r.transpose() * (world.row(j).transpose() - wrist)).transpose();
  return local;
}

PinchPoses parametric_pinch_poses() {
  // Direction from the index tip towards where the relaxed thumb's tip is: the
  // thumb opens and closes along it, so the blend is a straight approach.
  const Pose relaxed = parametric_right_hand(writing_articulation(kMinThumbCurl));
  const Eigen::Vector3d index_tip = joint(relaxed, Joint::IndexTip);
  const Eigen::Vector3d u = (joint(relaxed, Joint::ThumbTip) - index_tip).normalized();
  PinchPoses out;
  out.pinched = to_hand_frame(parametric_hand_with_thumb_tip_at(index_tip + 0.006 * u));
  out.open = to_hand_frame(parametric_hand_with_thumb_tip_at(index_tip + 0.060 * u));
  out.source = "parametric (synth_hand_pose; thumb turned and slid to pinch)";
  return out;
}

PinchPoses pinch_poses_from_track(const Track& track, const std::string& source_name) {
  const RecordedRightHand hand = recorded_right_hand(track);
  const HandSeries& s = hand.series;
  const std::vector<size_t> frames = plausible_frames(s);
  if (frames.empty())
    throw InputError({source_name, 0, ""},
                     "no fully tracked hand frame with plausible bone lengths to take a pose from");
  const size_t pinched = most_pinched_frame(s, frames);
  const double d_pinch = thumb_index_distance(s.pos[pinched]);
  if (d_pinch > kMaxRecordedPinch_m)
    throw InputError({source_name, 0, ""},
                     fmt::format("no pinch in the recording: the smallest thumb tip - index tip distance is {:.1f} mm "
                                 "(need <= {:.0f} mm; use a recording in which thumb and index touch)",
                                 d_pinch * 1e3, kMaxRecordedPinch_m * 1e3));
  const Pose pinched_local = to_hand_frame(s.pos[pinched]);
  const std::optional<size_t> open = open_frame_like(s, frames, pinched_local);
  if (!open)
    throw InputError({source_name, 0, ""},
                     "no open hand frame (thumb tip - index tip distance 5-7 cm) in the recording");

  PinchPoses out;
  out.pinched = pinched_local;
  out.open = to_hand_frame(s.pos[*open]);
  const double index_shift = (out.open.row(idx(Joint::IndexTip)) - out.pinched.row(idx(Joint::IndexTip))).norm();
  out.source = fmt::format(
      "{} ({} hand{}; pinched t={:.3f} s {:.1f} mm, open t={:.3f} s {:.1f} mm, index tip {:.1f} mm apart)", source_name,
      hand.mirrored ? "left" : "right", hand.mirrored ? " mirrored" : "", s.t[pinched], d_pinch * 1e3, s.t[*open],
      thumb_index_distance(s.pos[*open]) * 1e3, index_shift * 1e3);
  return out;
}

Pose blend_pinch(const PinchPoses& poses, double w) {
  w = std::clamp(w, 0.0, 1.0);
  const auto& parent = xr_hand_skeleton().parent;
  Pose out = untracked_pose();
  for (int j : parent_first_order()) {
    const int p = parent[static_cast<size_t>(j)];
    if (p < 0) {
      out.row(j) = (1.0 - w) * poses.open.row(j) + w * poses.pinched.row(j);
      continue;
    }
    const Eigen::Vector3d a = (poses.open.row(j) - poses.open.row(p)).transpose();
    const Eigen::Vector3d b = (poses.pinched.row(j) - poses.pinched.row(p)).transpose();
    const double len = (1.0 - w) * a.norm() + w * b.norm();
    set_joint(out, j, out.row(p).transpose() + len * slerp_direction(a.normalized(), b.normalized(), w));
  }
  return out;
}

}  // namespace hs
