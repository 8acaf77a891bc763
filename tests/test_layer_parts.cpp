// The layer's parts below the dispatch, without the loader: the plausibility gate, the
// runtime time-semantics probe, the per-tracker filter state (restart rules, blend-in,
// the worker hand-off) and the pure joint rewrite.
#include "handsteady/filters.hpp"
#include "handsteady/hsm_format.hpp"
#include "hand_attachments.hpp"
#include "joint_gate.hpp"
#include "joint_rewrite.hpp"
#include "layer_config.hpp"
#include "runtime_semantics.hpp"
#include "test_support.hpp"
#include "tracker_filter.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

using namespace hs;
using namespace hs::layer;

namespace {

// The synthetic hand 0.4 m in front of the origin (no joint near the origin).
Pose hand_at(double x, double y = 0.0) {
  Pose p = test::synthetic_hand();
  for (int j = 0; j < kJointCount; ++j) p.row(j) += Eigen::RowVector3d(x, y, -0.4);
  return p;
}

std::unique_ptr<TrackerFilter> one_euro_filter(Execution exec) {
  FilterConfig c;
  c.method = FilterMethod::OneEuro;
  return std::make_unique<TrackerFilter>(make_filter(c), 0.5, 0.1, exec);
}

constexpr XrTime kPeriod = 11'111'111;

// A One Euro tracker filter fed a slow ramp for 31 periods, past its blend-in. feed()
// hands over a sample and leaves in `out` the answer at its time from the state that
// includes it (lockstep answers a sample's own call from the state before it).
struct RunningFilter {
  explicit RunningFilter(Execution e) : exec(e), f(one_euro_filter(e)) {
    for (int i = 0; i <= 30; ++i, t += kPeriod) REQUIRE(feed(t, p = hand_at(0.001 * i)));
    REQUIRE(out.weight == 1.0);
    t -= kPeriod;  // the newest sample's time
  }
  bool feed(XrTime at, const Pose& pose) {
    const bool ok = f->update(at, &pose, at, out);
    return exec == Execution::Inline ? ok : f->update(at, nullptr, at, out);
  }
  Execution exec;
  std::unique_ptr<TrackerFilter> f;
  Answer out;
  XrTime t = 10'000'000'000;
  Pose p;
};

// A runtime's answer of `raw`: every joint valid and tracked, identity orientations, 1 cm radii.
std::array<XrHandJointLocationEXT, kJointCount> tracked_joints(const Pose& raw) {
  std::array<XrHandJointLocationEXT, kJointCount> joints{};
  for (int j = 0; j < kJointCount; ++j) {
    joints[j].locationFlags = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT |
                              XR_SPACE_LOCATION_ORIENTATION_VALID_BIT | XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT;
    joints[j].pose.position = xr::to_xr(Eigen::Vector3d(raw.row(j).transpose()));
    joints[j].pose.orientation = {0, 0, 0, 1};
    joints[j].radius = 0.01f;
  }
  return joints;
}

}  // namespace

TEST_CASE("gate: origin, denormal, NaN, 1e30 and stray joints are marked missing, too few joints is no hand") {
  Pose p = hand_at(0.1);
  p.row(3).setZero();
  p.row(4) << 1e-40, 0.0, -1e-40;
  p.row(5) << kNaN, 0.0, 0.0;
  p.row(6).setConstant(1e30);
  p.row(7) += Eigen::RowVector3d(0.5, 0.0, 0.0);  // half a metre from its hand
  const GateResult g = gate_joints(p);
  CHECK(g.kept == kJointCount - 5);
  CHECK(g.rejected == 4);  // the NaN joint was missing already
  for (int j : {3, 4, 5, 6, 7}) CHECK_FALSE(joint_tracked(p, j));
  CHECK(joint_tracked(p, 8));
  CHECK(g.usable());
  CHECK((g.centre - Eigen::Vector3d(hand_at(0.1).colwise().mean().transpose())).norm() < 0.05);

  Pose few = untracked_pose();
  for (int j = 0; j < 5; ++j) few.row(j) = hand_at(0.0).row(j);
  CHECK_FALSE(gate_joints(few).usable());
  CHECK_FALSE(any_joint_tracked(few));
}

TEST_CASE("gate: a hand collapsed onto a point or a line is no hand, but small, flat and partial hands are") {
  const Pose hand = hand_at(0.0);
  const Eigen::RowVector3d palm = hand.row(0);
  Pose point = hand, line = hand, small = hand, flat = hand, finger = untracked_pose();
  for (int j = 0; j < kJointCount; ++j) {
    point.row(j) = palm + Eigen::RowVector3d::Constant(1e-4 * j);  // within a few mm: a runtime's collapsed hand
    line.row(j) = palm + Eigen::RowVector3d(0.005 * j, 0.0, 0.0);  // spread 13 cm, but on a line
    small.row(j) = palm + 0.5 * (hand.row(j) - palm);              // half a hand's size
    flat(j, 2) = palm(2);                                           // every joint in one plane
  }
  Pose a = point, b = line;
  CHECK_FALSE(gate_joints(a).usable());
  CHECK_FALSE(any_joint_tracked(a));
  const GateResult gl = gate_joints(b);
  CHECK_FALSE(gl.usable());
  CHECK(gl.rejected == kJointCount);
  CHECK(gate_joints(small).usable());
  CHECK(gate_joints(flat).usable());
  // Too few joints to judge the shape (one finger on a line): judged joint by joint.
  for (int j = 0; j < 19; ++j) finger.row(j) = line.row(j);
  CHECK(gate_joints(finger).usable());
  // Off (the layer's per-joint garbage marks use it so): every joint kept.
  GateLimits off;
  off.min_spread_m = 0.0;
  Pose c = line;
  CHECK(gate_joints(c, off).kept == kJointCount);
}

TEST_CASE("gate: a hand moving faster than any hand, or back from a loss elsewhere, jumped") {
  const Eigen::Vector3d a(0.0, 0.0, -0.4);
  CHECK_FALSE(hand_jumped(a, a + Eigen::Vector3d(0.02, 0, 0), 0.011));  // 1.8 m/s
  CHECK(hand_jumped(a, a + Eigen::Vector3d(0.3, 0, 0), 0.011));          // 27 m/s
  CHECK_FALSE(hand_jumped(a, a + Eigen::Vector3d(0.02, 0, 0), 0.3));    // back from a loss, where it was
  CHECK_FALSE(hand_jumped(a, a + Eigen::Vector3d(0.08, 0, 0), 0.2));    // ... or moved on at 0.4 m/s
  CHECK(hand_jumped(a, a + Eigen::Vector3d(0.3, 0, 0), 0.3));           // back 30 cm away
  CHECK_FALSE(hand_jumped(Eigen::Vector3d::Constant(kNaN), a, 0.011));  // nothing to compare
}

TEST_CASE("semantics probe: identical answers 25 ms apart while moving mean latest pose, a still hand proves nothing") {
  SemanticsProbe probe;
  const Pose a = hand_at(0.0), b = hand_at(0.01);
  CHECK(probe.semantics() == TimeSemantics::History);
  for (int i = 0; i < 20; ++i) probe.vote(a, a, false);  // still: no votes
  CHECK(probe.votes() == 0);
  for (int i = 0; i < 5; ++i) probe.vote(a, a, true);
  CHECK(probe.semantics() == TimeSemantics::Latest);
  for (int i = 0; i < 5; ++i) probe.vote(a, b, true);
  CHECK(probe.semantics() == TimeSemantics::History);  // the window moves on
  int due = 0;
  for (int i = 0; i < 256; ++i) due += probe.due() ? 1 : 0;
  CHECK(due == 1);  // every 256th call once it has a full window
  CHECK(same_pose(a, a));
  CHECK_FALSE(same_pose(a, b));
  // A repeat seen through the app's base space and back: float rounding is no new sample,
  // 20 um of motion of one joint is, and so is a joint lost or found.
  Pose rounded = a, moved = a, lost = a;
  rounded.row(3).array() += 3e-7;
  moved(7, 1) += 2e-5;
  lost.row(9).setConstant(std::nan(""));
  CHECK_FALSE(same_pose(a, rounded));
  CHECK(repeated_pose(a, rounded));
  CHECK_FALSE(repeated_pose(a, moved));
  CHECK_FALSE(repeated_pose(a, lost));
  CHECK_FALSE(repeated_pose(a, b));
}

TEST_CASE("tracker filter: first answer is the runtime's (weight 0), blends in, restarts on a jump and a time reset") {
  auto f = one_euro_filter(Execution::Inline);
  Answer out;
  XrTime t = 10'000'000'000;
  Pose p = hand_at(0.0);
  REQUIRE(f->update(t, &p, t, out));
  CHECK(out.weight == 0.0);
  for (int i = 1; i <= 30; ++i) {
    t += kPeriod;
    p = hand_at(0.001 * i);
    REQUIRE(f->update(t, &p, t, out));
  }
  CHECK(out.weight == 1.0);  // 0.33 s > the blend time
  // A jump of 30 cm in one period restarts: weight 0 again, the estimate is the new input.
  t += kPeriod;
  p = hand_at(0.33);
  REQUIRE(f->update(t, &p, t, out));
  CHECK(out.weight == 0.0);
  CHECK((out.pose - p).norm() < 1e-9);
  // Repeats and a little older: not new samples; far older once: ignored; three times: restart.
  const XrTime last = t;
  REQUIRE(f->update(last, &p, last, out));
  Pose q = hand_at(0.34);
  CHECK(f->update(last - 2'000'000'000, &q, last, out));
  CHECK(f->update(last - 2'000'000'000 + kPeriod, &q, last, out));
  CHECK((out.pose - p).norm() < 1e-9);  // still the state of `last`
  CHECK(f->update(last - 2'000'000'000 + 2 * kPeriod, &q, last - 2'000'000'000 + 2 * kPeriod, out));
  CHECK(out.weight == 0.0);  // restarted on the new time base
  CHECK((out.pose - q).norm() < 1e-9);
}

TEST_CASE("tracker filter: a world space announced to move restarts at the change, and passes through until then") {
  for (const Execution exec : {Execution::Inline, Execution::Lockstep}) {
    CAPTURE(static_cast<int>(exec));
    RunningFilter run(exec);
    auto& f = run.f;
    Answer& out = run.out;
    XrTime& t = run.t;
    Pose& p = run.p;
    const auto feed = [&](XrTime at, const Pose& pose) { return run.feed(at, pose); };
    const XrTime change = t + kPeriod / 2;
    f->space_changed(change);
    // Before the change nothing is different; asked at the change before a sample from the
    // new space came, the old space answers nothing.
    REQUIRE(f->update(t, nullptr, t, out));
    CHECK(out.weight == 1.0);
    CHECK_FALSE(f->update(t, nullptr, change, out));
    // 6 cm over in the new space, a step the engine would otherwise bridge: it restarts,
    // and the sample's own call (lockstep: answered before the worker restarted) passes through.
    t += kPeriod;
    p = hand_at(0.09);
    if (exec == Execution::Lockstep) CHECK_FALSE(f->update(t, &p, t, out));
    REQUIRE(feed(t, p));
    CHECK(out.weight == 0.0);
    CHECK((out.pose - p).norm() < 1e-9);
    // Once: the next samples blend in as after any restart.
    t += kPeriod;
    REQUIRE(feed(t, p = hand_at(0.091)));
    CHECK(out.weight > 0.0);
    CHECK(out.weight < 1.0);
    // An announcement of no time (0) restarts nothing.
    f->space_changed(0);
    t += kPeriod;
    const double before = out.weight;
    REQUIRE(feed(t, p = hand_at(0.092)));
    CHECK(out.weight > before);
  }
}

TEST_CASE("tracker filter: a hand from another source restarts at the first sample after the last one fed") {
  // The layer's call while a controller drives the hand: source_changed(last sample fed).
  // The next sample, however close to the old hand, starts a new run; until it has been
  // processed, times after the last sample pass through, earlier ones are answered.
  for (const Execution exec : {Execution::Inline, Execution::Lockstep}) {
    CAPTURE(static_cast<int>(exec));
    RunningFilter run(exec);
    const XrTime last = run.t;
    run.f->source_changed(last);
    CHECK(run.f->update(last, nullptr, last, run.out));             // the old hand's own times
    CHECK_FALSE(run.f->update(last, nullptr, last + 1, run.out));  // after it: the runtime's
    // Back 0.2 s later, 1 mm from where it was (a step the engine would bridge): restarted.
    const Pose back = hand_at(0.031);
    REQUIRE(run.feed(last + 18 * kPeriod, back));
    CHECK(run.out.weight == 0.0);
    CHECK((run.out.pose - back).norm() < 1e-9);
    REQUIRE(run.feed(last + 19 * kPeriod, hand_at(0.032)));  // once: then the blend-in goes on
    CHECK(run.out.weight > 0.0);
  }
}

TEST_CASE("tracker filter: answers ahead only as far as the path reaches, older times from the history, and says how it answered") {
  auto f = one_euro_filter(Execution::Inline);
  Answer out;
  XrTime t = 1'000'000'000;
  for (int i = 0; i < 20; ++i, t += kPeriod) {
    const Pose p = hand_at(0.001 * i);
    REQUIRE(f->update(t, &p, t, out));
  }
  const XrTime newest = t - kPeriod;
  CHECK(f->update(newest, nullptr, newest, out));
  CHECK(out.how == hs::TimeAnswer::Exact);
  CHECK(f->update(newest, nullptr, newest + 50'000'000, out));
  CHECK(out.how == hs::TimeAnswer::Predicted);
  CHECK_FALSE(f->update(newest, nullptr, newest + 500'000'000, out));  // 0.5 s ahead: pass through
  CHECK(f->update(newest, nullptr, newest - 5 * kPeriod, out));         // in the history
  CHECK(out.how == hs::TimeAnswer::Exact);                             // at a kept sample time
  CHECK(f->update(newest, nullptr, newest - 5 * kPeriod - kPeriod / 2, out));
  CHECK(out.how == hs::TimeAnswer::Interpolated);
  CHECK_FALSE(f->update(newest, nullptr, newest - 60 * kPeriod, out));  // older than the history
  CHECK_FALSE(f->update(newest, nullptr, 0, out));
  CHECK_FALSE(f->update(newest, nullptr, std::numeric_limits<XrTime>::max(), out));
}

TEST_CASE("tracker filter: the worker's answers equal lockstep's and hide the hand-off with the innovation") {
  // The same stream through Lockstep and through Inline: lockstep answers from the state
  // before each sample, moved by the learned gain times the innovation; on a ramp with
  // noise its error stays close to inline's and far below the one-sample-stale state's.
  auto inline_f = one_euro_filter(Execution::Inline);
  auto lock_f = one_euro_filter(Execution::Lockstep);
  Answer a, b;
  double err_inline = 0.0, err_lock = 0.0, err_stale = 0.0;
  XrTime t = 1'000'000'000;
  Pose prev_est = hand_at(0.0);
  uint64_t seed = 1;
  auto noise = [&] {
    seed = seed * 6364136223846793005ull + 1442695040888963407ull;
    return (static_cast<double>(seed >> 11) * 0x1.0p-53 - 0.5) * 0.004;
  };
  for (int i = 0; i < 300; ++i, t += kPeriod) {
    const double x = 0.5 * static_cast<double>(i) * 0.011;  // 0.5 m/s
    Pose p = hand_at(x);
    const Pose truth = p;
    for (int j = 0; j < kJointCount; ++j) p(j, 0) += noise();
    REQUIRE(inline_f->update(t, &p, t, a));
    const bool ok = lock_f->update(t, &p, t, b);
    if (i < 60) {
      prev_est = a.pose;
      continue;
    }
    REQUIRE(ok);
    CHECK(b.corrected);
    err_inline += (a.pose - truth).rowwise().norm().mean();
    err_lock += (b.pose - truth).rowwise().norm().mean();
    err_stale += (prev_est - truth).rowwise().norm().mean();
    prev_est = a.pose;
  }
  MESSAGE("inline " << err_inline / 240 * 1e3 << " mm, lockstep " << err_lock / 240 * 1e3 << " mm, one sample stale "
                    << err_stale / 240 * 1e3 << " mm");
  CHECK(err_lock < 1.25 * err_inline);
  CHECK(err_lock < 0.7 * err_stale);
}

namespace {
// An engine that answers its input for its first 0.1 s after a reset (a network adapter's
// start-up: core/src/stgae_filter.cpp) and then holds its last answer (no response to
// innovation at all).
class StartsThenHolds final : public PoseFilter {
 public:
  void reset() noexcept override {
    t0_ = last_ = kNaN;
    held_ = untracked_pose();
  }
  bool push(double t, const Pose& observed) noexcept override {
    if (!std::isnan(last_) && !(t > last_)) return false;
    if (std::isnan(t0_)) t0_ = t;
    if (t - t0_ < 0.1) held_ = observed;
    last_ = t;
    return true;
  }
  void estimate(double, Pose& out) const noexcept override { out = held_; }
  double last_time() const noexcept override { return last_; }

 private:
  double t0_ = kNaN, last_ = kNaN;
  Pose held_ = untracked_pose();
};
}  // namespace

TEST_CASE("tracker filter: the hand-off's gain is not learnt while the engine starts up") {
  // The engine follows its input 1:1 only while it starts (within the blend-in after a
  // restart), then holds. Lockstep answers before the engine has each sample, moved by the
  // learnt gain times the innovation: learnt from the start-up, that gain would be about
  // 1 and decay by 5 % a sample, moving the held answer towards each new sample.
  TrackerFilter f(std::make_unique<StartsThenHolds>(), 0.5, 0.1, Execution::Lockstep);
  Answer a;
  XrTime t = 1'000'000'000;
  double moved = 0.0;
  int answered = 0;
  for (int i = 0; i < 60; ++i, t += kPeriod) {
    const Pose p = hand_at(0.5 * static_cast<double>(i) * 0.011);  // 0.5 m/s
    if (!f.update(t, &p, t, a)) continue;
    if (i < 40) continue;  // past the blend-in (0.25 s: 23 samples) and some samples after it
    REQUIRE(a.corrected);
    const Pose held = hand_at(0.5 * 9.0 * 0.011);  // sample 9, the last within the engine's 0.1 s
    moved = std::max(moved, (a.pose - held).rowwise().norm().maxCoeff());
    ++answered;
  }
  CHECK(answered == 20);
  MESSAGE("the answer moved from the engine's held pose by up to " << moved * 1e3 << " mm");
  CHECK(moved < 1e-9);
}

TEST_CASE("tracker filter: a joint that was unknown gets its velocity from more than one difference a millisecond long") {
  // Apps ask from several threads at times a millisecond apart, and runtimes drop joints.
  // The velocity is a low-passed difference of the estimates; a joint unknown to the
  // engine (missing when it restarted) must not take one difference over a millisecond as
  // its velocity, where 5 mm of re-acquisition noise is 5 m/s.
  for (const FilterMethod method : {FilterMethod::Raw, FilterMethod::OneEuro}) {
    CAPTURE(static_cast<int>(method));
    FilterConfig c;
    c.method = method;  // raw: the estimate is the input, a joint not seen since the start unknown
    TrackerFilter f(make_filter(c), 0.5, 0.1, Execution::Inline);
    Answer out;
    XrTime t = 1'000'000'000;
    const double speed = 0.5;  // m/s along x
    double offset = 0.0;       // the hand's jumps
    auto at = [&](XrTime time) { return hand_at(offset + speed * static_cast<double>(time - 1'000'000'000) * 1e-9); };
    constexpr int kJoint = 8;
    double fastest = 0.0;
    for (int jump = 0; jump <= 3; ++jump) {
      for (int i = 0; i < 30; ++i, t += kPeriod) {
        const Pose p = at(t);
        REQUIRE(f.update(t, &p, t, out));
        if (jump > 0) fastest = std::max(fastest, out.velocity.row(kJoint).norm());
      }
      if (jump == 3) break;
      offset += 0.3;  // the hand re-acquired 30 cm away: the engine restarts ...
      Pose p = at(t);
      p.row(kJoint).setConstant(std::numeric_limits<double>::quiet_NaN());  // ... without this joint
      REQUIRE(f.update(t, &p, t, out));
      REQUIRE(out.weight == 0.0);
      t += kPeriod;
      p = at(t);
      p(kJoint, 1) += 0.005;  // the joint back, 5 mm off
      REQUIRE(f.update(t, &p, t, out));
      t += TrackerFilter::kMinStep;  // the next sample a millisecond later, on the track
      p = at(t);
      REQUIRE(f.update(t, &p, t, out));
      if (std::isfinite(out.velocity(kJoint, 0))) fastest = std::max(fastest, out.velocity.row(kJoint).norm());
      t += kPeriod;
    }
    MESSAGE("fastest velocity of the joint: " << fastest << " m/s (the hand moves at " << speed << " m/s)");
    CHECK(fastest < 2.0 * speed);
    CHECK(std::abs(out.velocity(kJoint, 0) - speed) < 0.2 * speed);  // and it follows the hand
  }
}

TEST_CASE("joint rewrite: weight, smoothing and garbage, an estimate elsewhere replaces nothing") {
  const Pose raw = hand_at(0.0);
  auto joints = tracked_joints(raw);
  joints[9].pose.position = {0.0f, 0.0f, 0.0f};  // garbage flagged tracked
  auto centre = [](Pose p) { return gate_joints(p).centre; };
  Answer ans;
  ans.pose = hand_at(0.004);
  ans.centre = centre(ans.pose);
  ans.velocity.setConstant(0.0);
  ans.weight = 1.0;
  const xr::Rigid identity = xr::Rigid::Identity();
  auto copy = joints;
  JointMask garbage = garbage_joints(copy.data());
  CHECK(garbage[9]);
  CHECK(std::count(garbage.begin(), garbage.end(), true) == 1);
  const RewriteStats s = rewrite_joints(ans, 0.5, identity, BaseMotion{}, garbage, 0.08, copy.data(), nullptr);
  CHECK(s.replaced == kJointCount);
  CHECK(s.repaired == 1);
  CHECK_FALSE(garbage[9]);
  CHECK(copy[0].pose.position.x == doctest::Approx(raw(0, 0) + 0.002));  // halfway (smoothing 0.5)
  CHECK(copy[9].pose.position.x == doctest::Approx(ans.pose(9, 0)));     // garbage: the estimate whole

  // An estimate 30 cm away (a hand re-acquired elsewhere): nothing replaced, garbage repaired.
  ans.pose = hand_at(0.3);
  ans.centre = centre(ans.pose);
  copy = joints;
  garbage = garbage_joints(copy.data());
  const RewriteStats far = rewrite_joints(ans, 1.0, identity, BaseMotion{}, garbage, 0.08, copy.data(), nullptr);
  CHECK(far.diverged);
  CHECK(far.replaced == 0);
  CHECK(repair_garbage(garbage, copy.data(), nullptr) == 1);
  CHECK(xr::to_eigen(copy[9].pose.position).norm() > 0.1);  // a neighbour's position, not the origin
  CHECK((copy[9].locationFlags & XR_SPACE_LOCATION_POSITION_TRACKED_BIT) == 0);
  CHECK((copy[9].locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) != 0);
}

TEST_CASE("repair: a garbage joint takes the plausible joint fewest bones away, not the wrist") {
  const Pose raw = hand_at(0.0);
  auto joints = tracked_joints(raw);
  // The ring finger's metacarpal, proximal and intermediate at the origin, flagged tracked.
  const int meta = XR_HAND_JOINT_RING_METACARPAL_EXT, prox = XR_HAND_JOINT_RING_PROXIMAL_EXT,
            inter = XR_HAND_JOINT_RING_INTERMEDIATE_EXT, distal = XR_HAND_JOINT_RING_DISTAL_EXT;
  for (const int j : {meta, prox, inter}) joints[j].pose.position = {0.f, 0.f, 0.f};
  const JointMask garbage = garbage_joints(joints.data());
  CHECK(std::count(garbage.begin(), garbage.end(), true) == 3);
  CHECK(repair_garbage(garbage, joints.data(), nullptr) == 3);
  const auto at = [&](int j) { return Eigen::Vector3d(xr::to_eigen(joints[j].pose.position)); };
  const auto truth = [&](int j) { return Eigen::Vector3d(raw.row(j).transpose()); };
  CHECK((at(inter) - truth(distal)).norm() < 1e-6);                    // one bone away (the wrist is three)
  CHECK((at(meta) - truth(XR_HAND_JOINT_WRIST_EXT)).norm() < 1e-6);    // one bone away
  CHECK((at(prox) - truth(XR_HAND_JOINT_WRIST_EXT)).norm() < 1e-6);    // two either way: the ancestor
  MESSAGE("ring intermediate repaired " << (at(inter) - truth(inter)).norm() * 1e3 << " mm off; the wrist is "
                                        << (truth(XR_HAND_JOINT_WRIST_EXT) - truth(inter)).norm() * 1e3 << " mm away");
  for (const int j : {meta, prox, inter}) {
    CHECK((joints[j].locationFlags & XR_SPACE_LOCATION_POSITION_TRACKED_BIT) == 0);
  }
  CHECK((at(inter) - truth(inter)).norm() < 0.04);
}

TEST_CASE("forearm: the elbow moves with the wrist's correction and is never garbage") {
  // Ultraleap's forearm set: the hand's 26 joints, then the elbow (index 26).
  const auto hand = tracked_joints(hand_at(0.1));
  std::array<XrHandJointLocationEXT, kJointCount + 1> joints{};
  std::copy(hand.begin(), hand.end(), joints.begin());
  XrHandJointLocationEXT& elbow = joints[kJointCount];
  const XrHandJointLocationEXT& wrist = joints[XR_HAND_JOINT_WRIST_EXT];
  const auto reset_elbow = [&] {
    elbow = wrist;
    elbow.pose.position = xr::to_xr(Eigen::Vector3d(xr::to_eigen(wrist.pose.position) + Eigen::Vector3d(0.0, -0.18, 0.18)));
    elbow.radius = 0.035f;
  };
  reset_elbow();
  std::array<XrHandJointVelocityEXT, kJointCount + 1> vel{};
  // The layer moved the wrist by 4 mm: the elbow by as much, still tracked.
  const XrVector3f before = wrist.pose.position;
  joints[XR_HAND_JOINT_WRIST_EXT].pose.position.x += 0.004f;
  const Eigen::Vector3d expected = xr::to_eigen(elbow.pose.position) + Eigen::Vector3d(0.004, 0.0, 0.0);
  CHECK(rewrite_forearm(before, joints.data(), kJointCount + 1, vel.data()) == 0);
  CHECK((xr::to_eigen(elbow.pose.position) - expected).norm() < 1e-6);
  CHECK((elbow.locationFlags & XR_SPACE_LOCATION_POSITION_TRACKED_BIT) != 0);
  // The runtime's wrist was garbage (1e30, since repaired): no correction is carried over.
  reset_elbow();
  const Eigen::Vector3d kept = xr::to_eigen(elbow.pose.position);
  CHECK(rewrite_forearm(XrVector3f{1e30f, 0.0f, 0.0f}, joints.data(), kJointCount + 1, nullptr) == 0);
  CHECK((xr::to_eigen(elbow.pose.position) - kept).norm() < 1e-6);
  // Garbage flagged valid: NaN, 1e30, 2 m from the wrist -> the wrist's position, not tracked;
  // an unusable orientation and radius, and a velocity of 1e6 m/s.
  for (const float bad : {std::numeric_limits<float>::quiet_NaN(), 1e30f, 2.0f}) {
    CAPTURE(bad);
    reset_elbow();
    elbow.pose.position.y = bad;
    CHECK(rewrite_forearm(wrist.pose.position, joints.data(), kJointCount + 1, nullptr) == 1);
    CHECK((xr::to_eigen(elbow.pose.position) - xr::to_eigen(wrist.pose.position)).norm() == 0.0);
    CHECK((elbow.locationFlags & XR_SPACE_LOCATION_POSITION_VALID_BIT) != 0);
    CHECK((elbow.locationFlags & XR_SPACE_LOCATION_POSITION_TRACKED_BIT) == 0);
  }
  reset_elbow();
  elbow.pose.orientation = {0, 0, 0, 0};
  elbow.radius = -1.0f;
  vel[kJointCount].velocityFlags = XR_SPACE_VELOCITY_LINEAR_VALID_BIT;
  vel[kJointCount].linearVelocity = {1e6f, 0.0f, 0.0f};
  CHECK(rewrite_forearm(wrist.pose.position, joints.data(), kJointCount + 1, vel.data()) == 3);
  CHECK(xr::usable(elbow.pose.orientation));
  CHECK(elbow.radius == wrist.radius);
  CHECK(vel[kJointCount].velocityFlags == 0);
}

TEST_CASE("the base located from the runtime's joints in both spaces (xrLocateSpace failed)") {
  const Pose world = hand_at(0.1, 0.05);
  const xr::Rigid base_from_world = Eigen::Translation3d(0.2, -0.1, 0.4) *
                                    Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, 1.0, -0.2).normalized());
  Pose in_base = world;
  for (int j = 0; j < kJointCount; ++j) in_base.row(j) = (base_from_world * Eigen::Vector3d(world.row(j).transpose())).transpose();
  auto joints = tracked_joints(in_base);
  JointMask garbage{};
  xr::Rigid fit;
  REQUIRE(fit_base_from_world(joints.data(), garbage, world, fit));
  CHECK((fit.matrix() - base_from_world.matrix()).cwiseAbs().maxCoeff() < 1e-5);
  // Garbage and untracked joints are left out of the fit.
  joints[3].pose.position = {1e30f, 0.0f, 0.0f};
  garbage[3] = true;
  joints[4].locationFlags = XR_SPACE_LOCATION_POSITION_VALID_BIT;
  joints[4].pose.position.x += 0.05f;
  REQUIRE(fit_base_from_world(joints.data(), garbage, world, fit));
  CHECK((fit.matrix() - base_from_world.matrix()).cwiseAbs().maxCoeff() < 1e-5);
  // Answers that are not the same hand (a joint 2 cm off), or too few joints: no fit.
  auto moved = joints;
  moved[12].pose.position.y += 0.02f;
  CHECK_FALSE(fit_base_from_world(moved.data(), garbage, world, fit));
  Pose few = world;
  for (int j = 3; j < kJointCount; ++j) few.row(j).setConstant(std::numeric_limits<double>::quiet_NaN());
  CHECK_FALSE(fit_base_from_world(joints.data(), garbage, few, fit));
}

TEST_CASE("Meta's capsules and aim: moved with their joint's rigid change, never garbage") {
  JointsBefore before;
  const auto runtime = tracked_joints(hand_at(0.1));
  std::copy(runtime.begin(), runtime.end(), before.loc.begin());
  const int k = XR_HAND_JOINT_INDEX_PROXIMAL_EXT, palm = XR_HAND_JOINT_PALM_EXT;
  const auto capsule_of = [&](const std::array<XrHandJointLocationEXT, kJointCount>& joints) {
    XrHandTrackingCapsulesStateFB c{};
    c.type = XR_TYPE_HAND_TRACKING_CAPSULES_STATE_FB;
    for (XrHandCapsuleFB& cap : c.capsules) {
      cap.joint = static_cast<XrHandJointEXT>(k);
      cap.points[0] = joints[k].pose.position;
      cap.points[1] = joints[k + 1].pose.position;
      cap.radius = 0.009f;
    }
    return c;
  };
  // The layer turned the joint by 10 degrees about its own position and moved it by 3 mm:
  // the capsule the same, its far end on the turned bone.
  auto answered = runtime;
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.17, Eigen::Vector3d::UnitX()));
  const xr::Rigid change = Eigen::Translation3d(xr::to_eigen(runtime[k].pose.position) + Eigen::Vector3d(0.003, 0, 0)) *
                           turn * Eigen::Translation3d(-xr::to_eigen(runtime[k].pose.position));
  answered[k].pose = xr::to_xr(change * xr::to_rigid(runtime[k].pose));
  auto caps = capsule_of(runtime);
  CHECK(move_capsules(before, answered.data(), caps) == 0);
  const Eigen::Vector3d far_end = change * xr::to_eigen(runtime[k + 1].pose.position);
  CHECK((xr::to_eigen(caps.capsules[0].points[0]) - xr::to_eigen(answered[k].pose.position)).norm() < 1e-6);
  CHECK((xr::to_eigen(caps.capsules[0].points[1]) - far_end).norm() < 1e-6);
  CHECK(caps.capsules[0].radius == 0.009f);
  // Without a usable orientation on either side, the translation alone.
  auto unoriented = answered;
  unoriented[k].pose.orientation = {0, 0, 0, 0};
  caps = capsule_of(runtime);
  CHECK(move_capsules(before, unoriented.data(), caps) == 0);
  const Eigen::Vector3d shift = xr::to_eigen(answered[k].pose.position) - xr::to_eigen(runtime[k].pose.position);
  CHECK((xr::to_eigen(caps.capsules[0].points[1]) - (xr::to_eigen(runtime[k + 1].pose.position) + shift)).norm() < 1e-6);
  // A runtime's joint that was garbage tells no change: the capsule is judged as it is.
  before.garbage[k] = true;
  caps = capsule_of(runtime);
  CHECK(move_capsules(before, answered.data(), caps) == 0);
  CHECK((xr::to_eigen(caps.capsules[0].points[1]) - xr::to_eigen(runtime[k + 1].pose.position)).norm() < 1e-6);
  before.garbage[k] = false;
  // Garbage: a point NaN, 1e30 or 40 cm from its joint, a radius NaN, a joint no hand has.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  caps = capsule_of(runtime);
  caps.capsules[1].points[0].x = nan;
  caps.capsules[2].points[1] = {1e30f, 0.0f, 0.0f};
  caps.capsules[3].points[1].y += 0.4f;
  caps.capsules[4].radius = nan;
  caps.capsules[5].joint = static_cast<XrHandJointEXT>(99);
  CHECK(move_capsules(before, runtime.data(), caps) == 5);
  for (int c : {1, 2, 3})
    for (const XrVector3f& p : caps.capsules[c].points) CHECK(xr::to_eigen(p) == xr::to_eigen(runtime[k].pose.position));
  CHECK(caps.capsules[4].radius == runtime[k].radius);
  for (const XrVector3f& p : caps.capsules[5].points) CHECK(xr::to_eigen(p) == xr::to_eigen(runtime[palm].pose.position));

  // The aim's origin moves as the palm did; its direction stays the runtime's.
  XrHandTrackingAimStateFB aim{};
  aim.type = XR_TYPE_HAND_TRACKING_AIM_STATE_FB;
  const auto reset_aim = [&] {
    aim.status = XR_HAND_TRACKING_AIM_COMPUTED_BIT_FB | XR_HAND_TRACKING_AIM_VALID_BIT_FB;
    aim.aimPose = {{0.0f, 0.6f, 0.0f, 0.8f}, runtime[k].pose.position};
    aim.pinchStrengthIndex = 0.5f;
    aim.pinchStrengthMiddle = aim.pinchStrengthRing = aim.pinchStrengthLittle = 0.0f;
  };
  reset_aim();
  auto palm_moved = runtime;
  palm_moved[palm].pose.position.z -= 0.02f;
  CHECK(move_aim(before, palm_moved.data(), aim) == 0);
  CHECK((xr::to_eigen(aim.aimPose.position) - (xr::to_eigen(runtime[k].pose.position) + Eigen::Vector3d(0, 0, -0.02))).norm() < 1e-6);
  CHECK(aim.aimPose.orientation.y == 0.6f);
  CHECK(aim.pinchStrengthIndex == 0.5f);
  // Garbage flagged valid loses its valid bit and sits at the palm; pinches clamped.
  for (const XrPosef bad : {XrPosef{{0, 0, 0, 0}, runtime[k].pose.position}, XrPosef{{0, 0, 0, 1}, {nan, 0, 0}},
                            XrPosef{{0, 0, 0, 1}, {0.0f, 2.0f, 0.0f}}}) {
    reset_aim();
    aim.aimPose = bad;
    aim.pinchStrengthMiddle = nan;
    aim.pinchStrengthRing = 3.0f;
    CHECK(move_aim(before, runtime.data(), aim) == 3);
    CHECK((aim.status & XR_HAND_TRACKING_AIM_VALID_BIT_FB) == 0);
    CHECK((aim.status & XR_HAND_TRACKING_AIM_COMPUTED_BIT_FB) != 0);
    CHECK(xr::to_eigen(aim.aimPose.position) == xr::to_eigen(runtime[palm].pose.position));
    CHECK(xr::usable(aim.aimPose.orientation));
    CHECK(aim.pinchStrengthMiddle == 0.0f);
    CHECK(aim.pinchStrengthRing == 1.0f);
  }
}

TEST_CASE("the hand interaction profile's poses: moved with their joints, never garbage") {
  JointsBefore before;
  const auto runtime = tracked_joints(hand_at(0.1));
  std::copy(runtime.begin(), runtime.end(), before.loc.begin());
  const int palm = XR_HAND_JOINT_PALM_EXT, tip = XR_HAND_JOINT_INDEX_TIP_EXT, thumb = XR_HAND_JOINT_THUMB_TIP_EXT;
  constexpr XrSpaceLocationFlags kAll = XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_POSITION_TRACKED_BIT |
                                        XR_SPACE_LOCATION_ORIENTATION_VALID_BIT |
                                        XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT;
  const XrPosef none{{0, 0, 0, 1}, {0, 0, 0}};
  const auto located = [&](const XrPosef& pose) { return XrSpaceLocation{XR_TYPE_SPACE_LOCATION, nullptr, kAll, pose}; };
  // The layer turned the palm and the index tip by 10 degrees about themselves and moved
  // them (3 mm, and 2 mm the other way); the thumb's tip by 4 mm.
  auto answered = runtime;
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.17, Eigen::Vector3d::UnitX()));
  const auto change_at = [&](int j, const Eigen::Vector3d& by) {
    const Eigen::Vector3d at = xr::to_eigen(runtime[j].pose.position);
    return xr::Rigid(Eigen::Translation3d(at + by) * turn * Eigen::Translation3d(-at));
  };
  const xr::Rigid palm_change = change_at(palm, {0.003, 0, 0}), tip_change = change_at(tip, {-0.002, 0, 0});
  answered[palm].pose = xr::to_xr(palm_change * xr::to_rigid(runtime[palm].pose));
  answered[tip].pose = xr::to_xr(tip_change * xr::to_rigid(runtime[tip].pose));
  answered[thumb].pose.position.z += 0.004f;
  const auto pos = [](const XrSpaceLocation& l) { return xr::to_eigen(l.pose.position); };

  // Grip and poke: their joint's rigid change, whatever the app's offset in the action.
  const XrPosef offset{{0.258819f, 0.0f, 0.0f, 0.965926f}, {0.0f, 0.0f, -0.02f}};
  const xr::Rigid grip_rt = xr::to_rigid(runtime[palm].pose) * xr::to_rigid(offset);
  auto grip = located(xr::to_xr(grip_rt));
  CHECK(move_hand_pose(HandPose::Grip, before, answered.data(), offset, grip) == 0);
  const xr::Rigid grip_want = xr::to_rigid(answered[palm].pose) * xr::to_rigid(offset);
  CHECK((pos(grip) - grip_want.translation()).norm() < 1e-6);
  CHECK(xr::to_eigen(grip.pose.orientation).angularDistance(Eigen::Quaterniond(grip_want.rotation())) < 1e-5);
  auto poke = located(runtime[tip].pose);
  CHECK(move_hand_pose(HandPose::Poke, before, answered.data(), none, poke) == 0);
  CHECK((pos(poke) - xr::to_eigen(answered[tip].pose.position)).norm() < 1e-6);
  CHECK(xr::to_eigen(poke.pose.orientation).angularDistance(xr::to_eigen(answered[tip].pose.orientation)) < 1e-5);
  // Aim: the palm's position change, the runtime's direction.
  const XrPosef aim_rt{{0.0f, 0.6f, 0.0f, 0.8f}, runtime[XR_HAND_JOINT_INDEX_PROXIMAL_EXT].pose.position};
  auto aim = located(aim_rt);
  CHECK(move_hand_pose(HandPose::Aim, before, answered.data(), none, aim) == 0);
  CHECK((pos(aim) - (xr::to_eigen(aim_rt.position) + xr::to_eigen(answered[palm].pose.position) -
                     xr::to_eigen(runtime[palm].pose.position))).norm() < 1e-6);
  CHECK(aim.pose.orientation.y == 0.6f);
  // Pinch: the mean change of the two tips; between them before, between them after.
  const auto mid = [&](const std::array<XrHandJointLocationEXT, kJointCount>& j) {
    return Eigen::Vector3d(0.5 * (xr::to_eigen(j[thumb].pose.position) + xr::to_eigen(j[tip].pose.position)));
  };
  auto pinch = located(XrPosef{aim_rt.orientation, xr::to_xr(mid(runtime))});
  CHECK(move_hand_pose(HandPose::Pinch, before, answered.data(), none, pinch) == 0);
  CHECK((pos(pinch) - mid(answered)).norm() < 1e-6);
  // Not located: left as it is. A runtime's joint that was garbage tells no change.
  auto unlocated = located(runtime[tip].pose);
  unlocated.locationFlags = 0;
  CHECK(move_hand_pose(HandPose::Poke, before, answered.data(), none, unlocated) == 0);
  CHECK(pos(unlocated) == xr::to_eigen(runtime[tip].pose.position));
  before.garbage[tip] = true;
  poke = located(runtime[tip].pose);
  CHECK(move_hand_pose(HandPose::Poke, before, answered.data(), none, poke) == 0);
  CHECK(pos(poke) == xr::to_eigen(runtime[tip].pose.position));
  before.garbage[tip] = false;
  // Garbage flagged valid loses its valid and tracked bits: NaN, 1e30, an unusable
  // orientation, 60 cm from the palm; 60 cm of the app's own offset is no garbage.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const XrPosef bad : {XrPosef{{0, 0, 0, 1}, {nan, 0, 0}}, XrPosef{{0, 0, 0, 1}, {1e30f, 0, 0}},
                            XrPosef{{0, 0, 0, 0}, runtime[tip].pose.position},
                            XrPosef{{0, 0, 0, 1}, xr::to_xr(xr::to_eigen(runtime[palm].pose.position) + Eigen::Vector3d(0, 0.6, 0))}}) {
    auto l = located(bad);
    CHECK(move_hand_pose(HandPose::Poke, before, answered.data(), none, l) == 1);
    CHECK((l.locationFlags & kAll) == 0);
  }
  const XrPosef far_offset{{0, 0, 0, 1}, {0.0f, 0.6f, 0.0f}};
  auto far = located(xr::to_xr(xr::to_rigid(runtime[tip].pose) * xr::to_rigid(far_offset)));
  CHECK(move_hand_pose(HandPose::Poke, before, answered.data(), far_offset, far) == 0);
  CHECK(far.locationFlags == kAll);
}

TEST_CASE("repair: a radius no hand has, where the position is valid, becomes a neighbour's, 0 stays") {
  auto joints = tracked_joints(hand_at(0.0));
  for (int j = 0; j < kJointCount; ++j)
    joints[j].radius = 0.005f + 0.0001f * static_cast<float>(j);  // each joint its own, to see whose is taken
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int inter = XR_HAND_JOINT_INDEX_INTERMEDIATE_EXT, distal = XR_HAND_JOINT_INDEX_DISTAL_EXT,
            tip = XR_HAND_JOINT_INDEX_TIP_EXT, ring = XR_HAND_JOINT_RING_PROXIMAL_EXT,
            little = XR_HAND_JOINT_LITTLE_PROXIMAL_EXT, thumb = XR_HAND_JOINT_THUMB_TIP_EXT;
  joints[inter].radius = nan;
  joints[distal].radius = -1e-4f;
  joints[tip].radius = -0.01f;
  joints[ring].radius = 1e30f;
  joints[little].radius = std::numeric_limits<float>::infinity();
  // Not valid: its radius is undefined, neither repaired nor taken.
  joints[thumb].locationFlags = 0;
  joints[thumb].radius = 0.5f;
  const int middle = XR_HAND_JOINT_MIDDLE_DISTAL_EXT;
  joints[middle].radius = 0.0f;  // a runtime that gives no radius: not invented
  const JointMask none{};
  CHECK(repair_garbage(none, joints.data(), nullptr) == 5);
  CHECK(joints[middle].radius == 0.0f);
  for (int j = 0; j < kJointCount; ++j) {
    if (j == thumb || j == middle) continue;
    CHECK(joints[j].radius > 0.0f);
    CHECK(joints[j].radius < 0.1f);
  }
  CHECK(joints[thumb].radius == 0.5f);
  // The nearest usable joint up or down the finger, the ancestor on a tie, never a repaired one.
  const float proximal = 0.005f + 0.0001f * static_cast<float>(XR_HAND_JOINT_INDEX_PROXIMAL_EXT);
  CHECK(joints[inter].radius == proximal);  // one bone up; the distal below is bad too
  CHECK(joints[distal].radius == proximal);  // two up, none closer: not the intermediate repaired before it
  CHECK(joints[tip].radius == proximal);
  CHECK(joints[ring].radius == 0.005f + 0.0001f * static_cast<float>(XR_HAND_JOINT_RING_METACARPAL_EXT));

  // No usable radius at all: a defined default, a finger's.
  for (auto& j : joints) j.radius = nan;
  joints[thumb].locationFlags = joints[0].locationFlags;
  CHECK(repair_garbage(none, joints.data(), nullptr) == kJointCount);
  for (const auto& j : joints) CHECK(j.radius == doctest::Approx(0.009).epsilon(0.15));
}

TEST_CASE("repair: non-finite or impossible velocities lose their valid bit") {
  std::array<XrHandJointLocationEXT, kJointCount> joints{};
  std::array<XrHandJointVelocityEXT, kJointCount> vel{};
  const Pose raw = hand_at(0.0);
  for (int j = 0; j < kJointCount; ++j) {
    joints[j].pose.position = xr::to_xr(Eigen::Vector3d(raw.row(j).transpose()));
    joints[j].pose.orientation = {0, 0, 0, 1};
    vel[j].velocityFlags = XR_SPACE_VELOCITY_LINEAR_VALID_BIT | XR_SPACE_VELOCITY_ANGULAR_VALID_BIT;
  }
  vel[2].linearVelocity = {1e6f, 0.f, 0.f};
  vel[3].linearVelocity = {std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f};
  vel[4].angularVelocity = {0.f, std::numeric_limits<float>::infinity(), 0.f};
  const JointMask none{};
  CHECK(repair_garbage(none, joints.data(), vel.data()) == 3);
  CHECK((vel[2].velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) == 0);
  CHECK((vel[3].velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) == 0);
  CHECK((vel[4].velocityFlags & XR_SPACE_VELOCITY_ANGULAR_VALID_BIT) == 0);
  CHECK((vel[4].velocityFlags & XR_SPACE_VELOCITY_LINEAR_VALID_BIT) != 0);
  CHECK(vel[5].velocityFlags == (XR_SPACE_VELOCITY_LINEAR_VALID_BIT | XR_SPACE_VELOCITY_ANGULAR_VALID_BIT));
}

namespace {
// A tiny causal Multi-STGAE configuration, and a model file of it with random weights.
hs::StgaeConfig tiny_model_config() {
  hs::StgaeConfig c;
  c.window = 4;
  c.horizon = 2;
  c.encoder_channels = {6, 8};
  c.denoise_decoder_channels = {8, 3};
  c.predict_decoder_channels = {8, 3};
  c.temporal_kernel = 3;
  return c;
}
std::filesystem::path save_tiny_model(const std::filesystem::path& dir, const hs::StgaeConfig& cfg, const char* name) {
  const auto w = hs::random_stgae_weights(cfg, 3, 1.0);
  hs::save_hsm(dir / name, cfg, w, hs::make_stgae_reference(cfg, w, hs::synthetic_hand_input(cfg, cfg.window, 1)));
  return dir / name;
}
}  // namespace

TEST_CASE("configuration: HANDSTEADY_METHOD=dgn loads a DGN model, and a model of the other family falls back with an error") {
  const auto dir = hs::test::temp_dir("layer_dgn_config");
  hs::StgaeConfig c = tiny_model_config();
  auto save = [&](const hs::StgaeConfig& cfg, const char* name) { return save_tiny_model(dir, cfg, name); };
  const auto stgae = save(c, "stgae.hsm");
  c.family = hs::StgaeFamily::Dgn;
  c.gates = false;
  const auto dgn = save(c, "dgn.hsm");
  for (const char* v : {"HANDSTEADY_CONFIG", "HANDSTEADY_MODE", "HANDSTEADY_STGAE_PHASES"}) ::unsetenv(v);
  ::setenv("HANDSTEADY_METHOD", "dgn", 1);
  ::setenv("HANDSTEADY_MODEL", dgn.c_str(), 1);
  ::setenv("HANDSTEADY_CORRECTION_GAIN", "on", 1);
  hs::layer::LoadedConfig loaded = hs::layer::load_layer_config();
  ::unsetenv("HANDSTEADY_CORRECTION_GAIN");
  CHECK(loaded.config.filter.stgae.gain == true);
  REQUIRE_FALSE(loaded.engine_messages.empty());
  CHECK(loaded.engine_messages.back().text.find(", correction gain on at every rate") != std::string::npos);
  CHECK(loaded.engine_messages.back().text.find("predictions smoothed") == std::string::npos);
  CHECK(loaded.config.filter.method == hs::FilterMethod::Dgn);
  REQUIRE(loaded.config.filter.stgae.model != nullptr);
  CHECK(loaded.config.filter.stgae.model->config.family == hs::StgaeFamily::Dgn);
  CHECK(std::string(hs::layer::engine_name(loaded.config)) == "dgn");
  ::setenv("HANDSTEADY_MODEL", stgae.c_str(), 1);  // a Multi-STGAE model for method dgn
  loaded = hs::layer::load_layer_config();
  CHECK_FALSE(hs::is_network(loaded.config.filter.method));
  REQUIRE_FALSE(loaded.engine_messages.empty());
  CHECK(loaded.engine_messages.back().text.find("dgn") != std::string::npos);
  for (const char* v : {"HANDSTEADY_METHOD", "HANDSTEADY_MODEL"}) ::unsetenv(v);
  std::filesystem::remove_all(dir);
}

TEST_CASE("configuration: rate models from HANDSTEADY_RATE_MODELS or the file's rate_models, one that cannot be used left out with an error") {
  const auto dir = hs::test::temp_dir("layer_rate_models");
  hs::StgaeConfig c = tiny_model_config();
  auto save = [&](const hs::StgaeConfig& cfg, const char* name) { return save_tiny_model(dir, cfg, name); };
  const auto m30 = save(c, "m30.hsm");
  c.rate_hz = 90;
  const auto m90 = save(c, "m90.hsm");
  c.rate_hz = 60;
  c.padding = hs::StgaePadding::Centred;
  const auto centred = save(c, "centred60.hsm");
  for (const char* v : {"HANDSTEADY_CONFIG", "HANDSTEADY_MODE", "HANDSTEADY_STGAE_PHASES", "HANDSTEADY_METHOD"}) ::unsetenv(v);
  ::setenv("HANDSTEADY_MODEL", m30.c_str(), 1);
  const std::string list = m90.string() + ":" + (dir / "missing.hsm").string() + ":" + centred.string() + ":" + m30.string();
  ::setenv("HANDSTEADY_RATE_MODELS", list.c_str(), 1);
  hs::layer::LoadedConfig loaded = hs::layer::load_layer_config();
  CHECK(loaded.config.filter.method == hs::FilterMethod::Stgae);
  REQUIRE(loaded.config.filter.stgae.rate_models.size() == 1);  // m90; the missing, centred and same-rate ones left out
  CHECK(loaded.config.filter.stgae.rate_models[0]->config.rate_hz == 90.0);
  int errors = 0;
  for (const auto& m : loaded.engine_messages) {
    if (m.level != hs::layer::LogLevel::Error) continue;
    ++errors;
    CHECK(m.text.find("rate model") != std::string::npos);
  }
  CHECK(errors == 3);
  // The file's array; the environment, when set, replaces it.
  ::unsetenv("HANDSTEADY_RATE_MODELS");
  const auto cfg = dir / "cfg.json";
  std::ofstream(cfg) << R"({"rate_models": [")" << m90.string() << R"("]})";
  ::setenv("HANDSTEADY_CONFIG", cfg.c_str(), 1);
  loaded = hs::layer::load_layer_config();
  REQUIRE(loaded.config.filter.stgae.rate_models.size() == 1);
  std::ofstream(cfg) << R"({"rate_models": "m90.hsm"})";
  loaded = hs::layer::load_layer_config();
  CHECK(loaded.config.filter.stgae.rate_models.empty());
  bool warned = false;
  for (const auto& w : loaded.warnings) warned = warned || w.find("'rate_models' must be an array") != std::string::npos;
  CHECK(warned);
  for (const char* v : {"HANDSTEADY_CONFIG", "HANDSTEADY_MODEL"}) ::unsetenv(v);
  std::filesystem::remove_all(dir);
}

TEST_CASE("configuration: read_layer_config applies the file and the environment and loads no model, as an app beside the layer reads it") {
  const auto dir = hs::test::temp_dir("layer_read_config");
  const auto cfg = dir / "cfg.json";
  std::ofstream(cfg) << R"({"mode": "predict", "method": "stgae", "stgae_phases": 2})";
  ::setenv("HANDSTEADY_CONFIG", cfg.c_str(), 1);
  ::setenv("HANDSTEADY_MODEL", (dir / "no_such_model.hsm").c_str(), 1);
  ::unsetenv("HANDSTEADY_MODE");
  ::unsetenv("HANDSTEADY_METHOD");
  ::unsetenv("HANDSTEADY_STGAE_PHASES");
  const hs::layer::LoadedConfig read = hs::layer::read_layer_config();
  CHECK(read.config.mode == hs::layer::Mode::Predict);
  CHECK(read.config.filter.method == hs::FilterMethod::Stgae);  // as asked: nothing resolved yet
  CHECK(read.config.filter.stgae.phases == 2);
  CHECK(read.config.filter.stgae.model == nullptr);
  CHECK(read.engine_messages.empty());
  // The layer's own load resolves the engine: the model named is missing, so the mode's classical default.
  const hs::layer::LoadedConfig loaded = hs::layer::load_layer_config();
  CHECK(loaded.config.mode == hs::layer::Mode::Predict);
  CHECK(loaded.config.filter.method == hs::FilterMethod::Kalman);
  CHECK_FALSE(loaded.engine_messages.empty());
  ::setenv("HANDSTEADY_MODE", "denoise", 1);  // the environment overrides the file
  CHECK(hs::layer::read_layer_config().config.mode == hs::layer::Mode::Denoise);
  for (const char* v : {"HANDSTEADY_CONFIG", "HANDSTEADY_MODEL", "HANDSTEADY_MODE"}) ::unsetenv(v);
  std::filesystem::remove_all(dir);
}

// The layer's configuration from a JSON file (HANDSTEADY_CONFIG) with one environment
// variable set over it (the engine's other variables unset); both unset again after.
static hs::layer::LoadedConfig read_file_and_env(const std::filesystem::path& dir, const char* json, const char* var,
                                                 const char* value) {
  const auto cfg = dir / "cfg.json";
  std::ofstream(cfg) << json;
  ::setenv("HANDSTEADY_CONFIG", cfg.c_str(), 1);
  for (const char* v : {"HANDSTEADY_MODE", "HANDSTEADY_METHOD", "HANDSTEADY_MODEL"}) ::unsetenv(v);
  ::setenv(var, value, 1);
  hs::layer::LoadedConfig read = hs::layer::read_layer_config();
  for (const char* v : {"HANDSTEADY_CONFIG", var}) ::unsetenv(v);
  return read;
}

TEST_CASE("configuration: palm_fit and bone_fit switch their fit for any engine, auto leaves make_filter's default, a bad value warns") {
  auto parse = [](const std::string& text, std::vector<std::string>& warnings) {
    return hs::layer::parse_layer_config_json(text, "cfg.json", warnings);
  };
  struct Fit {
    std::string key;  // the JSON key
    const char* var;  // the environment variable
    std::optional<bool> hs::FilterConfig::*field;
    bool (*on)(const hs::FilterConfig&) noexcept;
  };
  for (const Fit& f : {Fit{"palm_fit", "HANDSTEADY_PALM_FIT", &hs::FilterConfig::palm_fit, &hs::palm_fit_on},
                       Fit{"bone_fit", "HANDSTEADY_BONE_FIT", &hs::FilterConfig::bone_fit, &hs::bone_fit_on}}) {
    CAPTURE(f.key);
    const auto json = [&](const std::string& value) { return "{\"" + f.key + "\": " + value + "}"; };
    std::vector<std::string> w;
    CHECK_FALSE((parse("{}", w).filter.*f.field).has_value());
    CHECK((parse(json("false"), w).filter.*f.field) == false);
    CHECK((parse(json("\"on\""), w).filter.*f.field) == true);
    CHECK_FALSE((parse(json("\"auto\""), w).filter.*f.field).has_value());
    CHECK(w.empty());
    CHECK_FALSE((parse(json("\"sometimes\""), w).filter.*f.field).has_value());
    REQUIRE(w.size() == 1);
    CHECK(w[0].find("cfg.json: " + f.key) != std::string::npos);
    CHECK(w[0].find("sometimes") != std::string::npos);
    (void)parse(json("1"), w);
    REQUIRE(w.size() == 2);
    CHECK(w[1].find("'" + f.key + "' must be") != std::string::npos);
    // What the setting does: the classical engine gets the fit only when asked.
    hs::FilterConfig oneeuro = parse("{\"method\": \"oneeuro\", \"" + f.key + "\": true}", w).filter;
    CHECK(f.on(oneeuro));
    (oneeuro.*f.field).reset();
    CHECK_FALSE(f.on(oneeuro));
    // The environment overrides the file.
    const auto dir = hs::test::temp_dir("layer_" + f.key + "_config");
    const std::string file = "{\"method\": \"kalman\", \"" + f.key + "\": true}";
    hs::layer::LoadedConfig read = read_file_and_env(dir, file.c_str(), f.var, "off");
    CHECK((read.config.filter.*f.field) == false);
    CHECK(read.warnings.empty());
    read = read_file_and_env(dir, file.c_str(), f.var, "maybe");
    CHECK((read.config.filter.*f.field) == true);  // the file's, kept
    REQUIRE(read.warnings.size() == 1);
    CHECK(read.warnings[0].find(f.var) != std::string::npos);
    std::filesystem::remove_all(dir);
  }
}

TEST_CASE("configuration: tremor_cancel puts the tremor canceller in front of any engine, off by default, a bad value warns") {
  auto parse = [](const char* text, std::vector<std::string>& warnings) {
    return hs::layer::parse_layer_config_json(text, "cfg.json", warnings);
  };
  std::vector<std::string> w;
  CHECK_FALSE(parse("{}", w).filter.tremor_cancel);
  CHECK(parse(R"({"tremor_cancel": true})", w).filter.tremor_cancel);
  CHECK(parse(R"({"tremor_cancel": "on"})", w).filter.tremor_cancel);
  CHECK_FALSE(parse(R"({"tremor_cancel": "off"})", w).filter.tremor_cancel);
  CHECK(w.empty());
  CHECK_FALSE(parse(R"({"tremor_cancel": "strong"})", w).filter.tremor_cancel);
  REQUIRE(w.size() == 1);
  CHECK(w[0].find("cfg.json: tremor_cancel") != std::string::npos);
  CHECK(w[0].find("strong") != std::string::npos);
  (void)parse(R"({"tremor_cancel": 1})", w);
  REQUIRE(w.size() == 2);
  CHECK(w[1].find("'tremor_cancel' must be") != std::string::npos);
  // What the setting does: the engine's filter has the canceller (its summary says so).
  const hs::FilterConfig kalman = parse(R"({"method": "kalman", "tremor_cancel": true})", w).filter;
  CHECK(hs::filter_params_summary(kalman).find("tremor_cancel=1") != std::string::npos);
  // The environment overrides the file.
  const auto dir = hs::test::temp_dir("layer_tremor_cancel_config");
  const char* file = R"({"method": "kalman", "tremor_cancel": true})";
  hs::layer::LoadedConfig read = read_file_and_env(dir, file, "HANDSTEADY_TREMOR_CANCEL", "off");
  CHECK_FALSE(read.config.filter.tremor_cancel);
  CHECK(read.warnings.empty());
  read = read_file_and_env(dir, file, "HANDSTEADY_TREMOR_CANCEL", "maybe");
  CHECK(read.config.filter.tremor_cancel);  // the file's, kept
  REQUIRE(read.warnings.size() == 1);
  CHECK(read.warnings[0].find("HANDSTEADY_TREMOR_CANCEL") != std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("configuration: prediction_smoothing (off by default), correction_gain (auto by default) and oscillation_guard (on by default) set the network's options, a bad value warns") {
  auto parse = [](const std::string& text, std::vector<std::string>& warnings) {
    return hs::layer::parse_layer_config_json(text, "cfg.json", warnings);
  };
  // Each option's state as a word: on, off, auto.
  using State = std::string (*)(const hs::StgaeParams&);
  struct Case {
    std::string key, env, fallback;  // fallback: the state by default
    State state;
    bool has_auto;
  };
  const State smooth = [](const hs::StgaeParams& p) { return std::string(p.smooth ? "on" : "off"); };
  const State gain = [](const hs::StgaeParams& p) { return std::string(!p.gain ? "auto" : *p.gain ? "on" : "off"); };
  const State guard = [](const hs::StgaeParams& p) { return std::string(p.guard ? "on" : "off"); };
  for (const Case& k : {Case{"prediction_smoothing", "HANDSTEADY_PREDICTION_SMOOTHING", "off", smooth, false},
                        Case{"correction_gain", "HANDSTEADY_CORRECTION_GAIN", "auto", gain, true},
                        Case{"oscillation_guard", "HANDSTEADY_OSCILLATION_GUARD", "on", guard, false}}) {
    CAPTURE(k.key);
    const auto set = [&](const std::string& value, std::vector<std::string>& w) {
      return k.state(parse("{\"" + k.key + "\": " + value + "}", w).filter.stgae);
    };
    std::vector<std::string> w;
    CHECK(k.state(parse("{}", w).filter.stgae) == k.fallback);
    CHECK(set("true", w) == "on");
    CHECK(set("\"on\"", w) == "on");
    CHECK(set("false", w) == "off");
    CHECK(set("\"off\"", w) == "off");
    CHECK(w.empty());
    if (k.has_auto) {
      CHECK(set("\"auto\"", w) == "auto");
      CHECK(w.empty());
    }
    CHECK(set("\"lots\"", w) == k.fallback);
    REQUIRE(w.size() == 1);
    CHECK(w[0].find("cfg.json: " + k.key) != std::string::npos);
    CHECK(w[0].find("lots") != std::string::npos);
    (void)set("2", w);
    REQUIRE(w.size() == 2);
    CHECK(w[1].find("'" + k.key + "' must be") != std::string::npos);
    // Each key sets its own option only.
    const auto only = parse("{\"" + k.key + "\": true}", w);
    CHECK(smooth(only.filter.stgae) == (k.key == "prediction_smoothing" ? "on" : "off"));
    CHECK(gain(only.filter.stgae) == (k.key == "correction_gain" ? "on" : "auto"));
    CHECK(guard(parse("{\"" + k.key + "\": false}", w).filter.stgae) == (k.key == "oscillation_guard" ? "off" : "on"));
    // The environment overrides the file; a bad value there keeps the file's.
    const auto dir = hs::test::temp_dir("layer_switch_config");
    const std::string file = R"({"method": "kalman", ")" + k.key + R"(": true})";
    hs::layer::LoadedConfig read = read_file_and_env(dir, file.c_str(), k.env.c_str(), "off");
    CHECK(k.state(read.config.filter.stgae) == "off");
    CHECK(read.warnings.empty());
    read = read_file_and_env(dir, file.c_str(), k.env.c_str(), "maybe");
    CHECK(k.state(read.config.filter.stgae) == "on");
    REQUIRE(read.warnings.size() == 1);
    CHECK(read.warnings[0].find(k.env) != std::string::npos);
    std::filesystem::remove_all(dir);
  }
}
