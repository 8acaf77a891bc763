#include "handsteady/skeleton.hpp"

#include <algorithm>
#include <cmath>
#include <queue>
#include <stdexcept>
#include <string>

namespace hs {

namespace {

constexpr std::array<std::string_view, kJointCount> kXrNames = {
    "palm", "wrist",
    "thumb_metacarpal", "thumb_proximal", "thumb_distal", "thumb_tip",
    "index_metacarpal", "index_proximal", "index_intermediate", "index_distal", "index_tip",
    "middle_metacarpal", "middle_proximal", "middle_intermediate", "middle_distal", "middle_tip",
    "ring_metacarpal", "ring_proximal", "ring_intermediate", "ring_distal", "ring_tip",
    "little_metacarpal", "little_proximal", "little_intermediate", "little_distal", "little_tip",
};

Edge ordered(int a, int b) { return a < b ? Edge{a, b} : Edge{b, a}; }

// Builds parent[] and (parent, child) bones by breadth-first search from the root over
// undirected edges. Joints unreachable from the root keep parent -1 and no bone.
void set_tree(Skeleton& s, int root, const std::vector<Edge>& edges) {
  const int n = s.joint_count();
  std::vector<std::vector<int>> adj(static_cast<size_t>(n));
  for (auto [a, b] : edges) {
    adj[static_cast<size_t>(a)].push_back(b);
    adj[static_cast<size_t>(b)].push_back(a);
  }
  s.parent.assign(static_cast<size_t>(n), -1);
  std::vector<bool> seen(static_cast<size_t>(n), false);
  std::queue<int> q;
  q.push(root);
  seen[static_cast<size_t>(root)] = true;
  while (!q.empty()) {
    int v = q.front();
    q.pop();
    for (int w : adj[static_cast<size_t>(v)]) {
      if (seen[static_cast<size_t>(w)]) continue;
      seen[static_cast<size_t>(w)] = true;
      s.parent[static_cast<size_t>(w)] = v;
      s.bones.emplace_back(v, w);
      q.push(w);
    }
  }
  std::sort(s.bones.begin(), s.bones.end(), [](Edge a, Edge b) { return a.second < b.second; });
}

Skeleton make_xr26() {
  Skeleton s;
  s.name = "xr26";
  s.joint_names.assign(kXrNames.begin(), kXrNames.end());
  std::vector<Edge> edges;
  const int wrist = idx(Joint::Wrist);
  for (int j = 0; j < kJointCount; ++j)
    if (const int p = kXrParent[static_cast<size_t>(j)]; p >= 0) edges.emplace_back(p, j);
  set_tree(s, wrist, edges);
  // Symmetry: same anatomical level on adjacent fingers. The thumb lacks an
  // intermediate phalanx, so it pairs metacarpal/proximal/distal/tip with the index's.
  const int t = idx(Joint::ThumbMetacarpal), i = idx(Joint::IndexMetacarpal);
  s.symmetry = {{t, i}, {t + 1, i + 1}, {t + 2, i + 3}, {t + 3, i + 4}};
  for (int f = 0; f < 3; ++f) {
    const int a = idx(Joint::IndexMetacarpal) + 5 * f;
    for (int k = 0; k < 5; ++k) s.symmetry.push_back(ordered(a + k, a + 5 + k));
  }
  return s;
}

// NYU (36 joints) as in the STGAE authors' graph: 1-based "direct" (bones) and
// "indirect" (symmetry) lists; joints 31-36 are unused there and stay isolated.
// The published indirect list repeats the bone (30, 24); it is kept as published.
Skeleton make_nyu36() {
  Skeleton s;
  s.name = "nyu36";
  const char* fingers[] = {"f1", "f2", "f3", "f4", "f5"};
  for (const char* f : fingers)
    for (int k = 1; k <= 6; ++k) s.joint_names.push_back(std::string(f) + "_" + std::to_string(k));
  for (int k = 31; k <= 36; ++k) s.joint_names.push_back("palm_" + std::to_string(k));
  const std::vector<Edge> direct1 = {
      {1, 2},   {3, 2},   {4, 3},   {5, 4},   {6, 5},   {30, 6},  {8, 7},   {9, 8},
      {10, 9},  {11, 10}, {12, 11}, {30, 12}, {14, 13}, {15, 14}, {16, 15}, {17, 16},
      {18, 17}, {30, 18}, {20, 19}, {21, 20}, {22, 21}, {23, 22}, {24, 23}, {30, 24},
      {26, 25}, {27, 26}, {28, 27}, {29, 28}, {30, 29}};
  const std::vector<Edge> indirect1 = {
      {1, 7},   {8, 2},   {9, 3},   {10, 4},  {11, 5},  {12, 6},  {13, 7},  {14, 8},
      {15, 9},  {16, 10}, {17, 11}, {18, 12}, {19, 13}, {20, 14}, {21, 15}, {22, 16},
      {23, 17}, {24, 18}, {25, 19}, {26, 20}, {27, 21}, {28, 22}, {29, 23}, {30, 24}};
  std::vector<Edge> direct;
  for (auto [a, b] : direct1) direct.emplace_back(a - 1, b - 1);
  set_tree(s, 29, direct);
  for (auto [a, b] : indirect1) s.symmetry.push_back(ordered(a - 1, b - 1));
  return s;
}

// SHREC'17 / DHG (22 joints): wrist, palm, then thumb and four fingers with
// base, first, second joint and tip each. Thumb base hangs off the wrist, the
// other finger bases off the palm.
Skeleton make_shrec22() {
  Skeleton s;
  s.name = "shrec22";
  s.joint_names = {"wrist", "palm"};
  const char* fingers[] = {"thumb", "index", "middle", "ring", "little"};
  const char* levels[] = {"base", "first", "second", "tip"};
  for (const char* f : fingers)
    for (const char* l : levels) s.joint_names.push_back(std::string(f) + "_" + l);
  std::vector<Edge> edges = {{0, 1}};
  for (int f = 0; f < 5; ++f) {
    const int base = 2 + 4 * f;
    edges.emplace_back(f == 0 ? 0 : 1, base);
    for (int k = 1; k < 4; ++k) edges.emplace_back(base + k - 1, base + k);
  }
  set_tree(s, 0, edges);
  for (int f = 0; f < 4; ++f)
    for (int k = 0; k < 4; ++k) s.symmetry.push_back(ordered(2 + 4 * f + k, 2 + 4 * (f + 1) + k));
  return s;
}

Eigen::MatrixXd adjacency_of(int n, const std::vector<Edge>& edges) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  for (auto [i, j] : edges) {
    a(i, j) = 1.0;
    a(j, i) = 1.0;
  }
  return a;
}

}  // namespace

const std::array<std::string_view, kJointCount>& xr_joint_names() { return kXrNames; }

int xr_joint_index(std::string_view name) {
  for (int j = 0; j < kJointCount; ++j)
    if (kXrNames[static_cast<size_t>(j)] == name) return j;
  return -1;
}

const Skeleton& xr_hand_skeleton() {
  static const Skeleton s = make_xr26();
  return s;
}
const Skeleton& nyu36_skeleton() {
  static const Skeleton s = make_nyu36();
  return s;
}
const Skeleton& shrec22_skeleton() {
  static const Skeleton s = make_shrec22();
  return s;
}

const Skeleton& skeleton_by_name(std::string_view name) {
  if (name == "xr26") return xr_hand_skeleton();
  if (name == "nyu36") return nyu36_skeleton();
  if (name == "shrec22") return shrec22_skeleton();
  throw std::invalid_argument("unknown skeleton '" + std::string(name) + "' (expected xr26, nyu36 or shrec22)");
}

Eigen::MatrixXd normalize_adjacency(const Eigen::MatrixXd& a) {
  const Eigen::VectorXd deg = a.colwise().sum().transpose();
  Eigen::VectorXd inv_sqrt(deg.size());
  for (Eigen::Index i = 0; i < deg.size(); ++i) inv_sqrt(i) = deg(i) > 0.0 ? 1.0 / std::sqrt(deg(i)) : 0.0;
  return inv_sqrt.asDiagonal() * a * inv_sqrt.asDiagonal();
}

GraphPartition hand_partition(const Skeleton& s) {
  const int n = s.joint_count();
  GraphPartition g;
  g.A[0] = normalize_adjacency(Eigen::MatrixXd::Identity(n, n));
  g.A[1] = normalize_adjacency(adjacency_of(n, s.bones));
  g.A[2] = normalize_adjacency(adjacency_of(n, s.symmetry));
  return g;
}

}  // namespace hs
