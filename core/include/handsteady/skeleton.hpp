#pragma once
// Hand skeletons (joint names, parent tree, symmetry edges) and the Multi-STGAE
// hand-partition graph A1 (self), A2 (bones), A3 (symmetry).
#include <Eigen/Core>

#include <array>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hs {

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

// "palm", "wrist", "thumb_metacarpal", ..., "little_tip".
const std::array<std::string_view, kJointCount>& xr_joint_names();
// Index of a joint name, or -1.
int xr_joint_index(std::string_view name);

using Edge = std::pair<int, int>;  // (a, b); for bones (parent, child)

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
