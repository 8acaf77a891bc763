#pragma once
// The input's noise per joint, estimated at the input rate by two measures that the hand's
// motion does not feed (the trust region's own estimate, the second difference of frames a
// model period apart, takes fast motion for noise):
// - smoothness: each row against the quadratic through the three rows before it, at their
//   own times (the third difference on a regular grid); motion leaks into it only as its
//   third derivative times the interval cubed, white noise in full;
// - rigidity: each bone's length against its running mean; a hand's bones do not stretch
//   however it moves, noise on either end of a bone does, correlated or not.
// The estimate is the larger of the two: E|n|^2 of the joint, m^2. A row far off the
// quadratic is a jump (an outlier), held out of both with the rows it spoils, unless the
// joint moved with its parent: fast motion moves a finger, an outlier one joint; a jump
// that keeps the bones and stays is followed from its second row (from its first where the
// hand's re-fits have mostly stayed). The smoothness residuals' shape tells Gaussian noise
// from a heavy tail of shifts that no jump bar catches. Per hand, per input row, no
// allocation, noexcept. docs/STGAE.md "Trust region".
#include "handsteady/skeleton.hpp"

#include <array>
#include <span>

namespace hs {

// Rows in the running means (squared residuals, bone lengths and their spread).
inline constexpr double kInputNoiseRows = 30.0;
// A row's residual from the quadratic is a jump (an outlier) only beyond this many RMS of
// what the noise measured before it gives (white noise gives (1 + sum of the weights
// squared) E|n|^2, about 20 E|n|^2: every row's residual is ~4.5 noise RMS; beyond 2 RMS,
// under 1 % of white-noise rows). 2 rather than 3 on the benchmark's tuning split.
inline constexpr double kInputNoiseJump = 2.0;
// A jump's residual mostly shared with its reference joint's (the parent; the wrist's, the
// palm), which is no jump, is the hand's motion: beyond this share (the reference's residual
// projected on the joint's, over the joint's), the joint is a jump only if its residual less
// the reference's exceeds kInputNoiseJump RMS of the two joints' noise.
inline constexpr double kInputNoiseShared = 0.5;
// A jump that kept the joint's bones (none changed length by more than this many RMS of
// its spread, at least kInputNoiseStretchFloor) and that the next row stays at (nearer
// where it jumped to than where it came from) is the tracker's new answer, not an
// outlier: Leap Motion re-fits a thumb 50 mm away between two rows and keeps it there.
// It is reported on its first row (a one-row shift that keeps the bones, the papers'
// corruption, looks the same), not on the rows after, whose quadratic runs through it:
// the trust region then lets the answer follow. An outlier stretches its bones and stays
// one. Either way the rows are held out of the means.
inline constexpr double kInputNoiseStretch = 3.0;
inline constexpr double kInputNoiseStretchFloor = 1e-3;  // m
// Where the hand's recent candidate re-fits (jumps that kept their bones, moved with a
// neighbour and were no outlier's end) mostly stayed a second row, a new one is followed
// from its own row: the stream is a tracker that re-fits (Leap Motion swings a thumb tip
// 116 mm in one row and keeps it), not one whose shifts come back (the papers'). The share
// is a running mean over the last kInputNoiseRefitRows candidates, used from
// kInputNoiseRefitSeen on; over kInputNoiseRefitShare it follows (0.8 from the Leap takes
// and FPHA's `paper` preset: at 0.65 or 0.5 FPHA's shifts that happen to stay a second row
// lift the share over the bar more often; docs/STGAE.md "A re-fit's own row").
inline constexpr int kInputNoiseRefitRows = 20;
inline constexpr int kInputNoiseRefitSeen = 3;
inline constexpr double kInputNoiseRefitShare = 0.8;
// Where at least this share of the joints seen are candidate re-fits in one row (most of
// the hand jumped as rigid chains: Leap Motion opening a whole hand 40-116 mm in one row at
// 23.5 Hz, a re-fit of the hand or its motion faster than the rows), they are followed from
// their own row whatever the share above: an outlier is one joint, the papers' shifts a few
// and their chains. The Leap takes at 23.5-27 Hz (scripts/leap_rates.sh; docs/STGAE.md "Most
// of the hand in one row").
inline constexpr double kInputNoiseHandRefitShare = 0.5;
// A sample enters the running means only up to this many RMS of the mean it enters, so one
// outlier does not inflate the noise of the next 30 rows (after kInputNoiseWarmRows
// samples; before them everything counts).
inline constexpr double kInputNoiseClip = 3.0;
inline constexpr int kInputNoiseWarmRows = 10;
// A jump's residual and the 3 after it are held out of the means (an outlier of 1-3 rows
// spoils up to 6); more rows than this in a row are a noise that rose, and count. A re-fit
// that stays a second row is no part of such a run: what its rows did to the mean and the
// run is taken back (Leap Motion's re-fits a few rows apart made runs that counted).
inline constexpr int kInputNoiseHeldRows = 6;
// The smallest RMS the clipping assumes (m): a clean input's estimate near 0 can still rise.
inline constexpr double kInputNoiseFloor = 1e-4;

class InputNoise {
 public:
  void reset() noexcept;
  // A tracking gap of the same hand: the rows before it are no history, but the tracker is
  // the same, and so is how its re-fits behave: as reset(), but refit_share() is kept (the
  // benchmark's takes follow one another after a gap; the layer resumes a hand after one).
  void resume() noexcept;
  // Row x (3 * kJointCount, joint-major xyz, NaN = missing) at time t (increasing).
  void push(double t, std::span<const float> x) noexcept;
  // E|n|^2 of joint j (m^2), 0 before any evidence.
  double noise2(int j) const noexcept { return noise2_[static_cast<size_t>(j)]; }
  // |row - the quadratic through the rows before| of joint j at the last row (m) where it
  // exceeds kInputNoiseJump times what the noise measured before this row explains: a
  // jump of this row alone (an outlier). 0 otherwise, when the joint lacked three rows
  // before, and on the rows after a jump that kept its bones and stayed (see above).
  double jump(int j) const noexcept { return jump_[static_cast<size_t>(j)]; }
  // Both for every joint (what CorrectionBound::apply takes).
  std::span<const double> noise2() const noexcept { return noise2_; }
  // E|n|^2 per joint from the smoothness measure alone (m^2): white noise in full, noise
  // that the next rows predict (correlated jitter, tremor) hardly. noise2() less this is
  // what only the bones saw: slow noise (CorrectionGain's low band).
  std::span<const double> smooth2() const noexcept { return smooth2_; }
  std::span<const double> jumps() const noexcept { return jump_; }
  // Per joint: whether a bone it ends (to its parent or a child) changed length in the last
  // row by more than kInputNoiseStretch RMS of its spread, the length learnt (false without
  // that evidence). An outlier of one joint mostly stretches one; the hand's motion keeps
  // them all.
  std::span<const bool> stretched() const noexcept { return stretched_; }
  // Per joint: whether the last row follows a re-fit, a jump that kept its bones and
  // stayed (while their quadratic runs through it; jump() is 0 on them), but not one back
  // to within half its length of where the joint was the row before (an outlier's end):
  // the tracker's new answer, whose jump is no noise (CorrectionBound::RowEvidence::followed).
  // Also the re-fit's own row (a candidate, jump() > 0), where refit_share() is over
  // kInputNoiseRefitShare or the row's candidates are most of the hand (hand_refit()).
  std::span<const bool> followed() const noexcept { return followed_; }
  // Whether the last row's followed joints are most of the hand on their own row
  // (kInputNoiseHandRefitShare): a re-fit of the hand or its motion faster than the rows,
  // whose row before is no re-fit's (CorrectionBound::RowEvidence::followed_hand).
  bool hand_refit() const noexcept { return hand_refit_; }
  // The share of the hand's recent candidate re-fits that stayed a second row, 0 before
  // kInputNoiseRefitSeen of them.
  double refit_share() const noexcept { return refit_seen_ >= kInputNoiseRefitSeen ? refit_share_ : 0.0; }
  // The shape of joint j's smoothness residuals: the sum over axes of (E|r_axis|)^2 over
  // 2 / pi times E|r|^2, 1 for Gaussian jitter of any covariance (white or correlated,
  // isotropic or mostly in depth), over 1 for tremor, well under 1 for a heavy tail (most
  // rows clean, a few shifted far: the `paper` preset), whose mean square the few rows
  // make. 1 before any evidence.
  double shape(int j) const noexcept { return shape_[static_cast<size_t>(j)]; }
  std::span<const double> shapes() const noexcept { return shape_; }

 private:
  static constexpr size_t kFs = 3 * kJointCount;
  std::array<std::array<float, kFs>, 3> rows_{};  // the last rows, newest first
  std::array<double, 3> t_{};
  int have_ = 0;                                  // rows in rows_
  std::array<double, kJointCount> smooth2_{}, bone_mean_{}, bone_var_{}, jump_{}, noise2_{};
  std::array<double, kJointCount> shape_ = [] {
    std::array<double, kJointCount> a{};
    a.fill(1.0);
    return a;
  }();
  std::array<bool, kJointCount> stretched_{}, followed_{};
  std::array<int, kJointCount> smooth_n_{}, bone_n_{};
  std::array<int, kJointCount> taint_{};  // rows still to come whose quadratic runs through a jump
  std::array<int, kJointCount> held_{};   // residuals held out in a row
  // A jump that kept its bones in the last row, awaiting the next (where it went from and
  // to are rows_[1] and rows_[0] then); rows still to come in which the jump it made is
  // followed.
  std::array<bool, kJointCount> moved_{};
  std::array<bool, kJointCount> returned_{};  // the last jump that may be a re-fit went back (followed())
  bool hand_refit_ = false;  // hand_refit()
  double refit_share_ = 0.0;  // running mean of whether candidates stayed (refit_share())
  int refit_seen_ = 0;        // candidates in it, at most kInputNoiseRefitRows
  std::array<int, kJointCount> follow_{};
  // The smoothness mean, its count and the run of held rows as they were before the last
  // jump that may be a re-fit (taken back if it stays a second row); rows a re-fit that
  // stayed still spoils, held out of the run.
  std::array<double, kJointCount> before_smooth2_{};
  // Per axis, the running mean of |residual| (the shape's numerator), and before the last jump.
  std::array<double, kFs> smooth_abs_{}, before_abs_{};
  std::array<int, kJointCount> before_n_{}, before_held_{}, aside_{};
};

}  // namespace hs
