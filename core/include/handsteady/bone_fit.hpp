#pragma once
// A finger's bones keep their length: a zero-lag denoiser behind any method, learnt per hand.
//
// Every runtime's hand model and most recordings keep a finger bone's length from frame to
// frame; a method's answer does not quite (noise left in it moves a joint along its bone as
// much as across). BoneFit learns each finger bone's length from the method's answers
// (learn(), a clipped running mean over kBoneTauS) and moves each finger's three outer
// joints, the chain's root fixed, the least distance (least squares, the constraints
// linearised at the answer, kBoneIterations times) that brings its bones towards those
// lengths (apply()). How far: each bone's Wiener weight, the share of its length's
// deviation that is fast (the step-to-step variance over the total), so a tracker whose
// bones really change length (FPHA's mocap: 2-4 mm over a recording, slowly) is moved
// little and a rigid skeleton's bones all the way. The same least squares turns each
// finger's hinge plane (the plane of the chain's first three joints: a finger's two outer
// joints bend in one plane) by moving its intermediate and distal joints, never the tip,
// until the tip sits at an offset from it learnt the same way, with its own Wiener weight
// (a tracker whose tips sit off that plane by a fixed distance keeps it); its pull fades
// in with the chain's bend (kPlaneFadeSin), and a chain bent less than kPlaneMinSin
// teaches none. Chains with a missing
// joint are left alone; nothing changes before kBoneMinRows answers of a take. Other
// joints are never touched.
// noexcept, no allocation. make_filter puts it behind the network methods by default
// (FilterConfig::bone_fit). docs/FILTERS.md "Bone fit".
#include "handsteady/skeleton.hpp"
#include "handsteady/track.hpp"

#include <array>

namespace hs {

// Each finger's chain: its root (the thumb's metacarpal, a finger's knuckle), then the
// three joints apply() moves.
inline constexpr std::array<std::array<int, 4>, 5> kFingerChains = {{
    {idx(Joint::ThumbMetacarpal), idx(Joint::ThumbProximal), idx(Joint::ThumbDistal), idx(Joint::ThumbTip)},
    {idx(Joint::IndexProximal), idx(Joint::IndexIntermediate), idx(Joint::IndexDistal), idx(Joint::IndexTip)},
    {idx(Joint::MiddleProximal), idx(Joint::MiddleIntermediate), idx(Joint::MiddleDistal), idx(Joint::MiddleTip)},
    {idx(Joint::RingProximal), idx(Joint::RingIntermediate), idx(Joint::RingDistal), idx(Joint::RingTip)},
    {idx(Joint::LittleProximal), idx(Joint::LittleIntermediate), idx(Joint::LittleDistal), idx(Joint::LittleTip)},
}};

inline constexpr double kBoneTauS = 1.0;      // time constant of a bone's length and of its two variances
inline constexpr double kBoneClipM = 0.002;   // a row moves the length estimate by at most this share of its deviation (m)
inline constexpr int kBoneMinRows = 10;       // answers that teach the lengths before apply() moves a joint
inline constexpr int kBoneIterations = 2;     // linearised least-squares steps per chain
inline constexpr double kBoneStepGapS = 0.1;  // rows further apart do not measure a step
inline constexpr double kBoneVarCapM2 = 1e-4; // a row adds at most (10 mm)^2 to a variance (an outlier's)
inline constexpr double kBoneFilledGive = 10.0; // a joint the method filled in moves this many times as readily
inline constexpr double kPlaneMinSin = 0.25;    // a chain whose first two bones are nearer a line (sine of their angle) teaches no plane
inline constexpr std::array<double, 2> kPlaneFadeSin = {0.15, 0.35};  // the plane's pull fades in over this bend (sine)

// Which joints the method's last input row had (apply() moves the others first).
using JointMask = std::array<bool, kJointCount>;

class BoneFit {
 public:
  BoneFit() { reset(); }
  // Forgets the hand.
  void reset() noexcept;
  // A new take after a gap: keeps the variances (the tracker's noise), learns the lengths
  // anew from the take's first answers (a tracker may re-measure the hand: Leap Motion
  // does) and forgets the last answer (a step over a gap is not noise). Nothing moves
  // before the take's kBoneMinRows-th answer.
  void resume() noexcept;
  // Learns each finger bone's length from the method's answer at time t (rows with a
  // chain's joint missing teach that chain nothing).
  void learn(double t, const Pose& answer) noexcept;
  // Moves each finger chain's outer joints towards the learnt lengths (see above); with
  // `observed`, a joint missing from the method's input gives way first.
  void apply(Pose& pose, const JointMask* observed = nullptr) const noexcept;
  // Answers learnt from since reset().
  int rows() const noexcept { return rows_; }
  // Bone b (0-2) of chain c: its learnt length (m) and its weight in [0, 1].
  double length(size_t c, size_t b) const noexcept { return bones_[c][b].mean; }
  double weight(size_t c, size_t b) const noexcept { return bones_[c][b].weight(); }
  // Chain c's learnt offset of its tip from the plane of its first three joints (m), and its weight.
  double plane_offset(size_t c) const noexcept { return planes_[c].mean; }
  double plane_weight(size_t c) const noexcept { return planes_[c].weight(); }

 private:
  // What is learnt of one quantity a rigid hand keeps (a bone's length, a tip's offset
  // from its finger's plane): its running mean and two running variances, the deviation
  // from that mean (total) and half the squared step between answers (fast).
  struct Stat {
    double mean = 0.0;
    double total = 0.0;
    double fast = 0.0;
    double last = 0.0;      // the last answer's value (when has_last)
    bool known = false;     // mean set (kept over a take, and relearnt from its first answers)
    bool has_last = false;  // last is a base for the next step
    int seen = 0;           // answers learnt from (the means are plain means at first)
    int steps = 0;          // steps learnt from
    // Learns value v; step: the answer before is close enough for a step; a: the share
    // of the running means a row moves.
    void learn(double v, bool step, double a) noexcept;
    // The Wiener weight in [0, 1]: fast over total (0 before any variance is learnt).
    double weight() const noexcept;
  };
  std::array<std::array<Stat, 3>, kFingerChains.size()> bones_{};
  std::array<Stat, kFingerChains.size()> planes_{};
  double last_t_ = 0.0;
  int rows_ = 0;
  int take_rows_ = 0;  // answers learnt from since the take began
};

}  // namespace hs
