#pragma once
// The palm is rigid: a zero-lag denoiser for its joints, learnt per hand.
//
// The palm, the wrist and the bases of the five metacarpals (OpenXR's PALM, WRIST and
// *_METACARPAL joints) and the four finger knuckles (*_PROXIMAL except the thumb's) move
// as one rigid body in every recording we have and in every runtime's hand model. Where
// a tracker's noise is independent per joint, the 11 noisy points determine only 7
// degrees of freedom (rotation, translation, scale), so fitting the hand's own palm to
// them removes most of their noise in the same frame, without lag. The shape (a template)
// is learnt online from the input: a running mean of the palm's points, each row aligned
// to it; any hand size or runtime's joint placement is learnt the same way.
//
// apply() fits the template to a row's palm joints (least squares: rotation, translation
// and uniform scale, since some trackers re-estimate the hand's size as they go), leaves
// joints far off the fit out of it, one at a time, worst first (outliers: a joint that
// jumped is put back where the palm says it is, and does not teach the template), and
// fills missing palm joints from the fit once the template knows them. Robust to its own
// mistakes: a joint off the fit several rows running is not an outlier but a template
// point learnt wrong (or a shape the tracker changed), and is learnt anew; rows no fit
// agrees with, many running, start a new template. A new take of the same hand (resume():
// tracking came back after a gap) keeps the template, unless the take's first two rows
// disagree with it in the same joints, moved the same way (another hand): then a new one. A joint whose typical (median)
// residual stays above the other joints' does not move with the palm in this tracker
// (ManipNet's THUMB_METACARPAL sits on the moving thumb; Leap Motion's WRIST bends under a
// millimetre against the knuckles): it passes through, unless it is far off
// its own usual place, where the fit answers it as an outlier. One seen far off the palm
// lately (its peak median against the other joints' peaks, over kPalmLooseRows) stays free
// while it rests: its median falls to nothing then (ManipNet's thumb rests for seconds),
// and taken for rigid its next move was answered where the palm put it, up to 16 mm off on
// clean input. Nothing
// changes until kPalmMinRows rows have taught the template, or where fewer than
// kPalmMinPoints palm joints are present. Other joints are never touched.
// noexcept, no allocation. make_filter puts it in front of the network methods by default
// (FilterConfig::palm_fit). docs/FILTERS.md "Palm fit".
#include "handsteady/skeleton.hpp"
#include "handsteady/track.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <array>

namespace hs {

// The palm's joints, rigid with each other.
inline constexpr std::array<int, 11> kPalmJoints = {
    idx(Joint::Palm),           idx(Joint::Wrist),          idx(Joint::ThumbMetacarpal), idx(Joint::IndexMetacarpal),
    idx(Joint::IndexProximal),  idx(Joint::MiddleMetacarpal), idx(Joint::MiddleProximal), idx(Joint::RingMetacarpal),
    idx(Joint::RingProximal),   idx(Joint::LittleMetacarpal), idx(Joint::LittleProximal)};
constexpr bool is_palm_joint(int j) noexcept {
  return std::find(kPalmJoints.begin(), kPalmJoints.end(), j) != kPalmJoints.end();
}

inline constexpr double kPalmTemplateRows = 120.0;  // rows in the template's running mean
inline constexpr int kPalmMinRows = 5;              // rows that teach the template before the fit applies
inline constexpr int kPalmMinPoints = 5;            // palm joints a fit needs
inline constexpr double kPalmOutlier = 4.0;         // a joint this many residual RMS off is left out
inline constexpr double kPalmOutlierFloorM = 0.003; // ... and at least this far (m)
inline constexpr double kPalmFirstCutM = 0.010;     // ... or this far before the residual is known
inline constexpr int kPalmMaxOutliers = 5;          // joints left out of one row's fit at most (6 of 11 decide)
inline constexpr int kPalmRelearnRows = 4;          // an outlier this many rows running is learnt anew
inline constexpr int kPalmRestartRows = 10;         // rows running without a fit start a new template
inline constexpr double kPalmRigidFactor = 2.0;     // a joint whose median residual is this many times
inline constexpr double kPalmRigidFloorM = 0.0005;  // the median joint's (plus this, in quadrature) is not rigid
// Each joint's peak median residual decays by 1 / kPalmLooseRows a row. A joint whose peak is
// over the same limit taken from the joints' peaks (the median joint's) is loose: not rigid
// even while it rests. Peaks against peaks, so that noise which lifts every joint's median in
// turn (80 ms correlated jitter, 4 mm quantisation) leaves no rigid joint loose.
inline constexpr double kPalmLooseRows = 1000.0;

class PalmFit {
 public:
  PalmFit() { reset(); }
  // Forgets the template (a new hand).
  void reset() noexcept;
  // A new take of the same hand (tracking resumed after a gap): keeps the template and
  // what it learnt of the tracker's noise. The take's first row it can fit checks the
  // template: one that fits but for a joint is fitted; else it passes unchanged and the
  // next decides: two or more joints off in both, moved alike, start a new template from
  // it (another hand, or a tracker that re-measured this one).
  void resume() noexcept;
  // Learns from the row and replaces its palm joints by the fitted template (see above).
  // Rows with non-finite joints: those joints are missing.
  void apply(Pose& pose) noexcept;
  // Rows the template has learnt from.
  int rows() const noexcept { return rows_; }

 private:
  static constexpr size_t kP = kPalmJoints.size();
  void learn(size_t i, const Eigen::Vector3d& local) noexcept;  // one row more of template point i
  // A new template from this row alone (the present joints of b).
  void start(const std::array<Eigen::Vector3d, kP>& b, const std::array<bool, kP>& have) noexcept;
  // The median joint's v (its median residual, or its peak) over the known joints that have one.
  double median_joint(const std::array<double, kP>& v, const std::array<bool, kP>& known) const noexcept;
  std::array<std::array<double, 3>, kP> tmpl_{};  // the template, in its own frame
  std::array<double, kP> count_{};                // rows each template point has learnt from
  int rows_ = 0;
  double resid2_ = 0.0, resid_rows_ = 0.0;  // running mean of an inlier's squared residual (m^2)
  std::array<double, kP> median_{};             // each joint's running median residual (m)
  std::array<int, kP> median_n_{};              // rows it has followed
  std::array<double, kP> peak_{};               // its largest median lately (decays over kPalmLooseRows)
  std::array<int, kP> off_run_{};               // rows running the joint was an outlier
  int unfit_run_ = 0;                           // rows running with no fit
  double last_scale_ = 0.0;                     // the last fit's scale (0: none yet)
  int check_ = 0;                               // a resumed take's rows to check the template by (2, 1; 0: none)
  std::array<bool, kP> check_off_{};            // the joints off it in the first checked row
  std::array<Eigen::Vector3d, kP> check_moved_{};  // and how far each had moved (template frame)
};

}  // namespace hs
