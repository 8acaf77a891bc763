#pragma once
// A denoiser must not make the whole hand shake more than the input does. The networks
// do, on an oscillation of the whole hand at 8-12 Hz (physiological tremor): at 10 Hz
// under a 30 Hz model the shipped model answers 1.2 x the raw error, the trust region and
// the correction gain leave it (models/MODEL.md "What the networks do to an oscillation of
// the whole hand", scripts/tremor_response.sh). The whole hand's motion is the mean of
// its joints; where the answer's mean accelerates more than the input's, the network has
// added motion no noise explains. So, per hand: running energies (memory kGuardRows
// rows) of the second difference of the joints' mean, of the input (E_in) and of the
// answer (E_out); where E_out > E_in, the whole-hand part of the correction (the mean over
// joints of answer - input) is scaled by (E_in / E_out)^kGuardPower, the per-joint rest
// left as it is. The answer only ever moves towards the input, by at most that mean.
// Second differences are taken per joint over the joints present in all three rows
// (missing joints do not move the mean), kGuardMinJoints or more; it acts once
// kGuardWarmRows differences have been seen since reset (a start's first few are no
// measure of either energy). noexcept, no allocation.
// docs/STGAE.md "Oscillation guard".
#include "handsteady/skeleton.hpp"
#include "handsteady/track.hpp"

#include <array>
#include <span>

namespace hs {

inline constexpr double kGuardRows = 15.0;  // memory of the energies (rows)
inline constexpr double kGuardPower = 4.0;  // the whole-hand correction kept: (E_in / E_out)^this
inline constexpr int kGuardMinJoints = 5;   // joints a row's mean needs
inline constexpr int kGuardWarmRows = 8;    // differences seen before it acts (a few are no energy)

class OscillationGuard {
 public:
  OscillationGuard() { reset(); }
  // Forgets everything (a new hand).
  void reset() noexcept;
  // A row without the hand: the shift is cleared and the next rows start a new difference.
  void clear() noexcept;
  // The input row x (3 * kJointCount, joint-major xyz, NaN = missing) and the answer at its
  // time without this guard. Sets the shift for answers made from this row.
  void observe(std::span<const float> x, const Pose& answer) noexcept;
  // What to add to coordinate c of every joint of answers made from the last row (m).
  double shift(int c) const noexcept { return shift_[static_cast<size_t>(c)]; }
  // The share of the whole-hand correction kept at the last row, in [0, 1].
  double kept() const noexcept { return kept_; }

 private:
  static constexpr size_t kFs = 3 * kJointCount;
  std::array<std::array<double, kFs>, 2> x_{}, y_{};  // the last two rows' input and answer (NaN: missing)
  int rows_ = 0;                                      // rows in a row since reset or clear, up to 2
  int older_ = 0;                                     // the slot of x_, y_ with the row two back
  double e_in_ = 0.0, e_out_ = 0.0;                   // running energies (m^2)
  int diffs_ = 0;                                     // differences in them since reset
  double kept_ = 1.0;
  std::array<double, 3> shift_{};
};

}  // namespace hs
