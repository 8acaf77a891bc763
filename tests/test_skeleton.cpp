#include "handsteady/skeleton.hpp"

#include "test_support.hpp"

#include <set>

using namespace hs;

namespace {

void check_normalised(const Eigen::MatrixXd& a, const std::vector<Edge>& edges, int n) {
  CHECK(a.rows() == n);
  CHECK((a - a.transpose()).cwiseAbs().maxCoeff() == doctest::Approx(0.0));
  std::vector<double> deg(static_cast<size_t>(n), 0.0);
  std::set<Edge> unique;
  for (auto [i, j] : edges) {
    if (unique.insert(i < j ? Edge{i, j} : Edge{j, i}).second) {
      deg[static_cast<size_t>(i)] += 1;
      deg[static_cast<size_t>(j)] += 1;
    }
  }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const bool edge = unique.count(i < j ? Edge{i, j} : Edge{j, i}) > 0;
      const double expect = edge ? 1.0 / std::sqrt(deg[static_cast<size_t>(i)] * deg[static_cast<size_t>(j)]) : 0.0;
      CHECK(a(i, j) == doctest::Approx(expect));
    }
}

}  // namespace

TEST_CASE("xr26 joint names follow XrHandJointEXT order") {
  const auto& names = xr_joint_names();
  CHECK(names[0] == "palm");
  CHECK(names[1] == "wrist");
  CHECK(names[5] == "thumb_tip");
  CHECK(names[10] == "index_tip");
  CHECK(names[11] == "middle_metacarpal");
  CHECK(names[18] == "ring_intermediate");
  CHECK(names[25] == "little_tip");
  CHECK(xr_joint_index("little_distal") == 24);
  CHECK(xr_joint_index("nope") == -1);
}

TEST_CASE("xr26 parent tree is a tree rooted at the wrist") {
  const Skeleton& s = xr_hand_skeleton();
  REQUIRE(s.joint_count() == 26);
  CHECK(s.bones.size() == 25);
  CHECK(s.parent[idx(Joint::Wrist)] == -1);
  CHECK(s.parent[idx(Joint::Palm)] == idx(Joint::Wrist));
  CHECK(s.parent[idx(Joint::ThumbMetacarpal)] == idx(Joint::Wrist));
  CHECK(s.parent[idx(Joint::ThumbTip)] == idx(Joint::ThumbDistal));
  CHECK(s.parent[idx(Joint::RingIntermediate)] == idx(Joint::RingProximal));
  CHECK(s.parent[idx(Joint::LittleMetacarpal)] == idx(Joint::Wrist));
  for (auto [p, c] : s.bones) CHECK(s.parent[c] == p);
  // Every joint reaches the root.
  for (int j = 0; j < 26; ++j) {
    int k = j, steps = 0;
    while (s.parent[k] != -1 && steps < 30) k = s.parent[k], ++steps;
    CHECK(k == idx(Joint::Wrist));
  }
}

TEST_CASE("the hand topology table: the skeleton, the tips and the orientation bones come from it") {
  const Skeleton& s = xr_hand_skeleton();
  for (int j = 0; j < kJointCount; ++j) CHECK(s.parent[static_cast<size_t>(j)] == kXrParent[static_cast<size_t>(j)]);
  // Tips: exactly the five joints named *_tip.
  for (int j = 0; j < kJointCount; ++j) {
    CAPTURE(j);
    CHECK(is_tip(j) == xr_joint_names()[static_cast<size_t>(j)].ends_with("_tip"));
  }
  CHECK_FALSE(is_tip(-1));
  CHECK_FALSE(is_tip(kJointCount));
  // XR_EXT_hand_tracking: -Z points along the bone to the next joint of the finger, tips
  // along the bone ending at them, the wrist at the middle metacarpal, the palm at the
  // middle proximal joint (the table the layer and replay runtime used before).
  const std::array<Edge, kJointCount> spec = {{
      {0, 12}, {1, 11},
      {2, 3}, {3, 4}, {4, 5}, {4, 5},
      {6, 7}, {7, 8}, {8, 9}, {9, 10}, {9, 10},
      {11, 12}, {12, 13}, {13, 14}, {14, 15}, {14, 15},
      {16, 17}, {17, 18}, {18, 19}, {19, 20}, {19, 20},
      {21, 22}, {22, 23}, {23, 24}, {24, 25}, {24, 25},
  }};
  for (int j = 0; j < kJointCount; ++j) {
    CAPTURE(j);
    CHECK(kXrFrameBone[static_cast<size_t>(j)] == spec[static_cast<size_t>(j)]);
  }
}

TEST_CASE("xr26 symmetry edges join the same level of adjacent fingers") {
  const Skeleton& s = xr_hand_skeleton();
  CHECK(s.symmetry.size() == 19);  // thumb-index 4, then 5 for each of 3 finger pairs
  std::set<Edge> sym(s.symmetry.begin(), s.symmetry.end());
  CHECK(sym.size() == s.symmetry.size());
  CHECK(sym.count({idx(Joint::ThumbTip), idx(Joint::IndexTip)}) == 1);
  CHECK(sym.count({idx(Joint::ThumbDistal), idx(Joint::IndexDistal)}) == 1);
  CHECK(sym.count({idx(Joint::MiddleIntermediate), idx(Joint::RingIntermediate)}) == 1);
  CHECK(sym.count({idx(Joint::RingTip), idx(Joint::LittleTip)}) == 1);
  CHECK(sym.count({idx(Joint::IndexTip), idx(Joint::RingTip)}) == 0);  // not adjacent
  for (auto [a, b] : s.symmetry) CHECK(a < b);
}

TEST_CASE("hand partition: identity, bones, symmetry, each normalised D^-1/2 A D^-1/2") {
  for (const Skeleton* s : {&xr_hand_skeleton(), &nyu36_skeleton(), &shrec22_skeleton()}) {
    CAPTURE(s->name);
    const int n = s->joint_count();
    GraphPartition g = hand_partition(*s);
    CHECK(g.A[0].isApprox(Eigen::MatrixXd::Identity(n, n)));
    check_normalised(g.A[1], s->bones, n);
    check_normalised(g.A[2], s->symmetry, n);
  }
}

TEST_CASE("normalize_adjacency leaves zero-degree rows zero and matches a hand computation") {
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3, 3);
  a(0, 1) = a(1, 0) = 1;  // path 0-1, joint 2 isolated
  Eigen::MatrixXd n = normalize_adjacency(a);
  CHECK(n(0, 1) == doctest::Approx(1.0));
  CHECK(n.row(2).isZero());
  a(1, 2) = a(2, 1) = 1;  // path 0-1-2: degrees 1, 2, 1
  n = normalize_adjacency(a);
  CHECK(n(0, 1) == doctest::Approx(1.0 / std::sqrt(2.0)));
  CHECK(n(1, 2) == doctest::Approx(1.0 / std::sqrt(2.0)));
  CHECK(n(0, 2) == 0.0);
}

TEST_CASE("reference graphs: NYU-36 and SHREC-22 edge counts") {
  const Skeleton& nyu = nyu36_skeleton();
  CHECK(nyu.joint_count() == 36);
  CHECK(nyu.bones.size() == 29);      // the published "direct" list
  CHECK(nyu.symmetry.size() == 24);   // the published "indirect" list
  for (int j = 30; j < 36; ++j) CHECK(nyu.parent[j] == -1);  // unused NYU joints stay isolated
  const Skeleton& sh = shrec22_skeleton();
  CHECK(sh.joint_count() == 22);
  CHECK(sh.bones.size() == 21);
  CHECK(sh.symmetry.size() == 16);
  CHECK(&skeleton_by_name("shrec22") == &sh);
  CHECK_THROWS_AS(skeleton_by_name("mano"), std::invalid_argument);
}

TEST_CASE("hand tree distances from the topology table") {
  using hs::idx;
  using hs::Joint;
  CHECK(hs::xr_depth(idx(Joint::Wrist)) == 0);
  CHECK(hs::xr_depth(idx(Joint::RingIntermediate)) == 3);
  CHECK(hs::xr_bones_between(idx(Joint::RingIntermediate), idx(Joint::Wrist)) == 3);
  CHECK(hs::xr_bones_between(idx(Joint::RingIntermediate), idx(Joint::RingDistal)) == 1);
  CHECK(hs::xr_bones_between(idx(Joint::IndexTip), idx(Joint::ThumbTip)) == 9);
  CHECK(hs::xr_bones_between(idx(Joint::Palm), idx(Joint::Palm)) == 0);
  CHECK(hs::xr_is_ancestor(idx(Joint::Wrist), idx(Joint::LittleTip)));
  CHECK(hs::xr_is_ancestor(idx(Joint::LittleProximal), idx(Joint::LittleTip)));
  CHECK_FALSE(hs::xr_is_ancestor(idx(Joint::LittleTip), idx(Joint::LittleProximal)));
  CHECK_FALSE(hs::xr_is_ancestor(idx(Joint::Palm), idx(Joint::IndexTip)));
}
