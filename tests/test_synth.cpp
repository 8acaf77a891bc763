#include "handsteady/synth.hpp"

#include "test_support.hpp"

using namespace hs;

namespace {
double dist(const Pose& p, Joint a, Joint b) { return (p.row(idx(a)) - p.row(idx(b))).norm(); }
}  // namespace

TEST_CASE("synthetic hand pose has adult bone lengths that articulation does not change") {
  HandArticulation open, fist;
  fist.curl = {1.2, 1.5, 1.5, 1.5, 1.5};
  Pose a = synth_hand_pose(open), b = synth_hand_pose(fist);
  CHECK(tracked_joint_count(a) == kJointCount);
  CHECK(dist(a, Joint::Wrist, Joint::MiddleProximal) == doctest::Approx(0.095).epsilon(0.01));
  for (auto [p, c] : xr_hand_skeleton().bones) {
    CAPTURE(c);
    const double la = (a.row(p) - a.row(c)).norm(), lb = (b.row(p) - b.row(c)).norm();
    CHECK(la > 0.005);
    CHECK(la < 0.1);
    CHECK(lb == doctest::Approx(la).epsilon(1e-9));
  }
  // Curling brings the fingertips towards the wrist.
  CHECK(dist(b, Joint::Wrist, Joint::IndexTip) < dist(a, Joint::Wrist, Joint::IndexTip) - 0.03);
  // Scale scales every length.
  Pose c = synth_hand_pose(open, {1.2});
  CHECK(dist(c, Joint::Wrist, Joint::LittleTip) == doctest::Approx(1.2 * dist(a, Joint::Wrist, Joint::LittleTip)));
}

TEST_CASE("synthetic hand pose is a right hand, palm down: thumb towards -X, fingers curl towards -Y") {
  HandArticulation open, fist;
  fist.curl = {1.2, 1.5, 1.5, 1.5, 1.5};
  const Pose a = synth_hand_pose(open), b = synth_hand_pose(fist);
  CHECK(a(idx(Joint::ThumbTip), 0) < a(idx(Joint::IndexProximal), 0));
  CHECK(a(idx(Joint::IndexProximal), 0) < a(idx(Joint::LittleProximal), 0));
  for (Joint tip : {Joint::IndexTip, Joint::MiddleTip, Joint::RingTip, Joint::LittleTip, Joint::ThumbTip}) {
    CAPTURE(idx(tip));
    CHECK(b(idx(tip), 1) < a(idx(tip), 1) - 0.01);  // curling goes towards the palm side
  }
  // A right hand: (index -> little) x (wrist -> middle) is the back of the hand, and the
  // fingers curl away from it (a left hand's would curl towards it).
  const Eigen::Vector3d across = (a.row(idx(Joint::LittleProximal)) - a.row(idx(Joint::IndexProximal))).transpose();
  const Eigen::Vector3d along = (a.row(idx(Joint::MiddleProximal)) - a.row(idx(Joint::Wrist))).transpose();
  const Eigen::Vector3d back = across.cross(along);
  CHECK(back.y() > 0.0);
  CHECK((b.row(idx(Joint::MiddleTip)) - a.row(idx(Joint::MiddleTip))).dot(back.transpose()) < 0.0);
}

TEST_CASE("synthetic motion is smooth, seeded, and the left hand mirrors the right") {
  SynthMotionParams prm;
  prm.duration_s = 4.0;
  Track t1 = synth_track(prm, 5), t2 = synth_track(prm, 5), t3 = synth_track(prm, 6);
  REQUIRE(t1.rows.size() == 2 * 121);
  CHECK(t1.rows[10].pos == t2.rows[10].pos);
  CHECK(t1.rows[10].pos != t3.rows[10].pos);
  HandSeries r = hand_series(t1, Hand::Right), l = hand_series(t1, Hand::Left);
  CHECK(r.pos[0](idx(Joint::Wrist), 0) > 0.0);
  CHECK(l.pos[0](idx(Joint::Wrist), 0) < 0.0);
  // Smooth: per-frame wrist steps are bounded (a few cm/frame at most) and non-zero.
  double max_step = 0, total = 0;
  for (size_t i = 1; i < r.size(); ++i) {
    const double step = (r.pos[i].row(1) - r.pos[i - 1].row(1)).norm();
    max_step = std::max(max_step, step);
    total += step;
  }
  CHECK(max_step < 0.03);
  CHECK(total > 0.1);
  // Bone lengths stay constant under motion.
  for (auto [p, c] : xr_hand_skeleton().bones)
    CHECK((r.pos[50].row(p) - r.pos[50].row(c)).norm() == doctest::Approx((r.pos[0].row(p) - r.pos[0].row(c)).norm()));
}
