#pragma once
// Hand skeletons (joint names, parent tree, symmetry edges) and the Multi-STGAE
// hand-partition graph A1 (self), A2 (bones), A3 (symmetry).
#include <Eigen/Core>

#include <array>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hs {

// A missing coordinate (a joint a row, pose or frame lacks) is NaN everywhere.
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

// The canonical skeleton: the 26-joint OpenXR hand in XrHandJointEXT order.
inline constexpr int kJointCount = 26;

enum class Joint : int {
  Palm = 0, Wrist,
  ThumbMetacarpal, ThumbProximal, ThumbDistal, ThumbTip,
  IndexMetacarpal, IndexProximal, IndexIntermediate, IndexDistal, IndexTip,
  MiddleMetacarpal, MiddleProximal, MiddleIntermediate, MiddleDistal, MiddleTip,
  RingMetacarpal, RingProximal, RingIntermediate, RingDistal, RingTip,
  LittleMetacarpal, LittleProximal, LittleIntermediate, LittleDistal, LittleTip,
};
constexpr int idx(Joint j) { return static_cast<int>(j); }

using Edge = std::pair<int, int>;  // (a, b); for bones (parent, child)

// The OpenXR hand's topology, written once: each joint's parent (-1: the wrist, the root;
// the palm, the thumb's and the fingers' metacarpals hang off it). Everything else about
// the hand's shape (bones, tips, orientation bones, the graph) is derived from it.
inline constexpr std::array<int, kJointCount> kXrParent = {
    1,  -1,                // palm, wrist
    1,  2,  3,  4,         // thumb: metacarpal, proximal, distal, tip
    1,  6,  7,  8,  9,     // index: metacarpal, proximal, intermediate, distal, tip
    1,  11, 12, 13, 14,    // middle
    1,  16, 17, 18, 19,    // ring
    1,  21, 22, 23, 24,    // little
};

// The joints with every parent before its children: the wrist, then the rest in index
// order (every other parent's index is below its children's; the palm's is the wrist).
inline constexpr std::array<int, kJointCount> kXrParentFirst = [] {
  std::array<int, kJointCount> o{};
  size_t n = 0;
  o[n++] = idx(Joint::Wrist);
  for (int j = 0; j < kJointCount; ++j)
    if (j != idx(Joint::Wrist)) o[n++] = j;
  return o;
}();
static_assert([] {
  std::array<bool, kJointCount> seen{};
  for (const int j : kXrParentFirst) {
    const int p = kXrParent[static_cast<size_t>(j)];
    if (p >= 0 && !seen[static_cast<size_t>(p)]) return false;
    seen[static_cast<size_t>(j)] = true;
  }
  return true;
}(), "kXrParentFirst must list every parent before its children");

// A fingertip: a joint no other joint hangs off.
constexpr bool is_tip(int j) {
  if (j < 0 || j >= kJointCount || j == idx(Joint::Palm)) return false;
  for (int k = 0; k < kJointCount; ++k)
    if (kXrParent[static_cast<size_t>(k)] == j) return false;
  return true;
}

// Bones from joint j up to the wrist.
constexpr int xr_depth(int j) {
  int d = 0;
  for (int k = kXrParent[static_cast<size_t>(j)]; k >= 0; k = kXrParent[static_cast<size_t>(k)]) ++d;
  return d;
}

// Whether a lies on the path from joint j up to the wrist (j itself excluded).
constexpr bool xr_is_ancestor(int a, int j) {
  for (int k = kXrParent[static_cast<size_t>(j)]; k >= 0; k = kXrParent[static_cast<size_t>(k)])
    if (k == a) return true;
  return false;
}

// Bones between joints a and b on the hand tree (up to their common ancestor and down).
constexpr int xr_bones_between(int a, int b) {
  int da = xr_depth(a), db = xr_depth(b), n = 0;
  for (; da > db; --da, ++n) a = kXrParent[static_cast<size_t>(a)];
  for (; db > da; --db, ++n) b = kXrParent[static_cast<size_t>(b)];
  for (; a != b; n += 2) {
    a = kXrParent[static_cast<size_t>(a)];
    b = kXrParent[static_cast<size_t>(b)];
  }
  return n;
}

// The bone (from, to) along which joint j's -Z axis points in XR_EXT_hand_tracking:
// towards the next joint of its finger; tips use the bone that ends at them; the wrist
// points at the middle metacarpal and the palm at the middle proximal joint.
inline constexpr std::array<Edge, kJointCount> kXrFrameBone = [] {
  std::array<Edge, kJointCount> b{};
  for (int j = 0; j < kJointCount; ++j) {
    if (j == idx(Joint::Palm)) b[static_cast<size_t>(j)] = {j, idx(Joint::MiddleProximal)};
    else if (j == idx(Joint::Wrist)) b[static_cast<size_t>(j)] = {j, idx(Joint::MiddleMetacarpal)};
    else if (is_tip(j)) b[static_cast<size_t>(j)] = {kXrParent[static_cast<size_t>(j)], j};
    else b[static_cast<size_t>(j)] = {j, j + 1};  // within a finger the child is the next joint
  }
  return b;
}();

// "palm", "wrist", "thumb_metacarpal", ..., "little_tip".
const std::array<std::string_view, kJointCount>& xr_joint_names();
// Index of a joint name, or -1.
int xr_joint_index(std::string_view name);

struct Skeleton {
  std::string name;
  std::vector<std::string> joint_names;
  std::vector<int> parent;      // parent[j], -1 for the root
  std::vector<Edge> bones;      // (parent, child), one per non-root joint
  std::vector<Edge> symmetry;   // same level on adjacent fingers, a < b
  int joint_count() const { return static_cast<int>(joint_names.size()); }
};

// 26-joint OpenXR hand: root wrist; palm, thumb and finger metacarpals hang off the wrist.
const Skeleton& xr_hand_skeleton();
// Reference graphs of the papers (NYU 36 joints, SHREC'17 22 joints).
const Skeleton& nyu36_skeleton();
const Skeleton& shrec22_skeleton();
// "xr26", "nyu36", "shrec22"; throws std::invalid_argument otherwise.
const Skeleton& skeleton_by_name(std::string_view name);

// D^-1/2 A D^-1/2 of a symmetric 0/1 adjacency (zero-degree rows stay zero).
Eigen::MatrixXd normalize_adjacency(const Eigen::MatrixXd& adjacency);

// K = 3 subsets, each symmetric and normalised: A[0] self, A[1] bones, A[2] symmetry.
struct GraphPartition {
  std::array<Eigen::MatrixXd, 3> A;
};
GraphPartition hand_partition(const Skeleton& skeleton);

}  // namespace hs
