#pragma once
// A trust region for a denoiser's output: the network may move a joint away from its input
// only as far as the input's own recent roughness says noise could have moved it, and its
// persistent offsets (a learnt bias on an unfamiliar hand: noise averages out of a
// correction, a bias does not) are taken out, of the denoised frame and of each predicted
// displacement; what is left of a correction is shrunk to the share that noise explains
// (read from the correction's own correlation over frames, and bounded by the noise
// measured at the input rate where there is one); a predicted displacement is shrunk by
// the share of it that the input's future has not been confirming (a Wiener gain per
// joint and horizon), then blended with the denoised frames' own velocity by the weight
// the input's future gives the two forecasts. A clean still hand is answered exactly,
// from the first frame on; a noisy hand leaves the network free. Per stream (frames one model
// period apart), no allocation after construction, noexcept. docs/STGAE.md "Trust region".
#include "handsteady/skeleton.hpp"

#include <Eigen/Core>

#include <array>
#include <span>
#include <vector>

namespace hs {

// Radius = max(kCorrectionNoiseFactor * noise, |second difference now|): `noise` is the
// RMS noise a white jitter with the joint's mean squared second difference would have
// (E|a|^2 = 6 E|n|^2), averaged over about kCorrectionRoughnessFrames earlier frames; the
// second term lets a one-frame outlier be taken back whole. That term is taken in the
// hand's frame (the palm's rigid motion over the three frames taken out) where the palm
// moved as one body and that motion explains most fingers' too: a hand that sweeps,
// stops or turns as a whole does not open the radius to the network's lag, a joint that
// jumped against its hand still does. Where the noise is not measured, each joint's
// correction is split into the whole hand's share (the median over joints) and its own:
// the first is bound by that radius, the second by the same radius read in the hand's
// frame (the roughness of the second differences taken there), where that noise is under
// kMeasuredNoiseMaxRms and the joint was seen in the two frames before: a hand that moves
// as a whole opens the one, not the other. The offsets are means over about
// kCorrectionBiasFrames frames, each step clipped to the noise radius, applied only beyond
// two of their standard errors.
inline constexpr double kCorrectionNoiseFactor = 3.0;
// With the noise measured at the input rate (InputNoise: motion does not feed it, so it is
// not inflated the way the stream's second difference is), radius = max(this factor times
// the joint's RMS noise, the row's own jump where it is one). Smaller is more accurate on
// the benchmark's tuning split, larger steadier (the demo's Parkinsonian ink jerk, which
// 1 takes over half of raw's and 1.5 keeps under by 2.6 %); 2 keeps it by 4 % for 1.7 %
// of the tuning split's error (docs/STGAE.md "Trust region").
inline constexpr double kMeasuredNoiseFactor = 2.0;
// On rows that are no jump, the correction c (after the offset) is scaled by
// min(1, E|n|^2 / E|c|^2), E|c|^2 its mean square over about kCorrectionBiasFrames frames:
// a correction much larger than the input's noise is mostly the network's own error (fast,
// nearly clean free-air motion it reshapes), and E|n|^2 / E|c|^2 is the least-squares share
// of it to keep when that error is independent of the noise. E|n|^2 is read from the
// correction itself, c = -n + e: the network's own error e is a drag that changes little
// from one frame to the next, the noise it removes does (white jitter is uncorrelated over
// frames, a 4-12 Hz tremor at 30 Hz anticorrelated at one or two frames), so E|n|^2 ~
// E|c|^2 less the smaller of c's mean products with itself one and two frames back (what e
// alone leaves). Where the noise is also measured at the input rate (InputNoise), E|n|^2 is
// at most kCorrectionShareFactor times that: each overstates the noise in its own way (the
// correlation counts the part of the network's error that does change between frames;
// InputNoise, doubled, sees little of a smooth tremor, which the demo's Parkinsonian ink
// needs removed: 1 takes its jerk from 0.48 to 0.53 of raw's, 2 to 0.49). The forms and
// factors were chosen on the tuning split, at 30 Hz for one stream (docs/STGAE.md "Trust
// region", "One stream: the correction's own correlation").
inline constexpr double kCorrectionShareFactor = 2.0;
// Joints whose measured noise is over this RMS (m) keep the stream's own radius and
// shrink, which open to the row's second difference and so let a one-row shift be taken
// back whole: the `paper` preset's shifts (10-50 mm on a few joints a row) read as ~10 mm
// RMS at the fingertips, mostly under the jump threshold, and a radius of twice that held
// a 40 mm shift 20 mm off. One stream on rows slower than the model (StgaeFilter, docs/
// STGAE.md "One stream on slow rows") passes it alone; chosen on the tuning split at 23.5 Hz
// (an ad-hoc build: 3 mm `paper` +2.7 %, unlimited +7.8 %).
inline constexpr double kMeasuredNoiseMaxRms = 3e-3;
// K >= 2 streams pass it with the residuals' shape (InputNoise::shapes): a joint over the
// limit whose shape is at least this is Gaussian noise of that size (white, correlated,
// tremor: shape ~1 or over), which the measured radius serves; a heavy tail (`paper`:
// ~0.5) keeps the stream's own. Without the shape the limit took Gaussian 1.5-5 mm cells
// up to 3.1 % further; with it at 0.75 none by 0.5 % at 90 Hz, `paper` 11-22 % closer
// (docs/STGAE.md "Heavy-tailed noise at K >= 2 streams").
inline constexpr double kMeasuredNoiseMinShape = 0.75;
// min(1, explained / mean2): the share of something of mean square `mean2` that a noise of
// mean square `explained` accounts for (the correction here, the older stream's weight in
// the adapter).
inline double explained_share(double mean2, double explained) noexcept {
  return mean2 > explained ? explained / mean2 : 1.0;
}
inline constexpr double kCorrectionRoughnessFrames = 15.0;
inline constexpr double kCorrectionBiasFrames = 30.0;
// Predicted displacements (frame f >= the first gained frame, joint j): e = d + v, d what
// the hand will do, v what it will not (noise or tremor the network extrapolated, its own
// error). Once the input of f frames later is in, |e_then|^2 - e_then . (x_now - den_then)
// samples E|v|^2 (the input's own noise then is independent of e_then); its running mean
// over kPredictionNoiseFrames frames is the displacement's noise, and e is scaled by the
// Wiener gain 1 - E|v|^2 / P, P the mean of |e|^2 over the last kPredictionPowerFrames
// frames (at least E|v|^2): a displacement well above its noise (a hand setting off) is
// kept, one at the level of its noise (a still or shaking hand) taken back towards the
// denoised frame. Fading in over kPredictionGainWarmRows samples. From frame 1 where the
// noise is measured at the input rate (K >= 2 streams): one period ahead is also the older
// stream's share of an answer at the input's own time, which gets steadier. One stream at
// the model's rate keeps frame 1 as predicted (gaining it there lost FPHA's 50 ms rows).
// Chosen on the tuning split (docs/STGAE.md "Prediction gain", "Frame 1 at K >= 2 streams").
inline constexpr int kPredictionGainFirstFrame = 2;          // one stream at the model's rate
inline constexpr int kPredictionGainFirstFrameMeasured = 1;  // the noise measured at the input rate
inline constexpr double kPredictionNoiseFrames = 30.0;
inline constexpr double kPredictionPowerFrames = 1.5;
inline constexpr int kPredictionGainWarmRows = 20;
// The gained displacement g of predicted frame f (f >= 1) is then combined with the
// denoised frames' constant velocity, c = f times their mean step over the last
// kPredictionBlendStepFrames frames: g + lambda (c - g), one lambda per path frame for the
// whole hand, the least-squares weight of two forecasts (Bates and Granger), read from the
// input's future as the gain's noise is: once the input of f frames later is in, y = x_now
// - den_then, and lambda = E[(c - g) . (y - g)] / E|c - g|^2 (sums over the joints, means
// over about kPredictionBlendFrames rows), held in [0, 1], fading in over
// kPredictionGainWarmRows rows. The network's displacement falls behind a hand that
// speeds up or turns; a still or shaking hand's velocity is its noise, whose forecast the
// future does not confirm (lambda 0). Chosen on the tuning split (docs/STGAE.md
// "Prediction blend").
inline constexpr double kPredictionBlendFrames = 30.0;
inline constexpr int kPredictionBlendStepFrames = 2;

class CorrectionBound {
 public:
  // frames: the length of the network's path, [denoised, predicted 1 .. frames - 1 periods ahead].
  explicit CorrectionBound(int frames = 1);
  // Forgets the history (tracking restarted).
  void reset() noexcept;
  // Input frame x (3 * kJointCount, joint-major xyz, NaN = missing) and the network's path
  // for it (frames() frames of 3 * kJointCount), rewritten in place:
  // - denoised: less the network's mean offset, then pulled to within the radius of x;
  // - predicted frame f: the denoised one plus the network's predicted displacement less
  //   its mean excess over the displacement the input then made (measured f frames later),
  //   scaled by its Wiener gain (from kPredictionGainFirstFrame on; with the noise
  //   measured, from kPredictionGainFirstFrameMeasured), blended with the
  //   denoised frames' velocity (kPredictionBlendFrames), then held within reach of
  //   constant velocity (x's last step) from the denoised one.
  // Joints missing in x are not bound.
  void apply(std::span<const float> x, std::span<float> path) noexcept { apply(x, path, RowEvidence{}); }
  static constexpr double kUnlimitedRms = 1e9;
  // The same with what the input's rows say beyond the frames (InputNoise); each empty
  // span or default is "not known", and the row is bound as above.
  struct RowEvidence {
    // The input's noise measured at the input rate: E|n|^2 per joint and this row's jump
    // (both or neither). They set the denoised frame's radius instead of this stream's
    // second differences, and bound the noise the correction's correlation reads for the
    // shrink (kCorrectionShareFactor). On a row that is no jump the correction is first
    // shrunk to the share of it that noise explains. Which rows teach the gain and the
    // blend is the stream's own either way: any row whose second difference is no outlier
    // of its frames' (InputNoise's jumps include a fast hand's rows, which the predictions
    // must learn from most).
    std::span<const double> noise2 = {}, jump = {};
    // Joints whose measured noise is over this RMS (m) keep the stream's own radius and
    // shrink (one stream on slow rows: kMeasuredNoiseMaxRms) ...
    double measured_max_rms = kUnlimitedRms;
    // ... unless their noise is Gaussian in shape (InputNoise::shapes, at least
    // kMeasuredNoiseMinShape): those take the measured radius all the same.
    std::span<const double> shape = {};
    // Per joint, InputNoise::followed: this row follows a tracker's re-fit (a jump that
    // kept its bones and stayed). The joint's radius does not open to the row's second
    // difference (the re-fit again) nor to its jump, and neither that nor the row
    // before's enters the stream's roughness (the re-fit row's, or where the re-fit's own
    // row is followed, the row before's): the answer follows the re-fit from its second
    // row, or from its first.
    std::span<const bool> followed = {};
    // Per joint, InputNoise::stretched: a bone it ends is off its length. Where the noise
    // is not measured, the joint's correction is bound by the world's radius alone, which
    // after a row that jumped against the hand opens to that jump: an outlier that lasts
    // rows is still off its bones on its later rows, whose second differences are
    // nothing; a re-fit that stays keeps them.
    std::span<const bool> stretched = {};
    // InputNoise::hand_refit: the joints followed are most of the hand, on their own row.
    // The row before is no re-fit's and stays in the roughness, and this row's second
    // difference enters it as any row's (the row after takes it back).
    bool followed_hand = false;
  };
  void apply(std::span<const float> x, std::span<float> path, const RowEvidence& row) noexcept;
  int frames() const noexcept { return frames_; }
  // The radius of joint j after the last apply (m); infinity when it was not bound.
  double radius(int j) const noexcept { return radius_[static_cast<size_t>(j)]; }

 private:
  static constexpr size_t kFs = 3 * kJointCount;
  int frames_ = 1, hist_ = 3;  // path length; frames of input history kept (>= 3, >= frames)
  long n_ = 0;                 // frames since reset
  std::vector<float> x_;       // input ring, hist_ frames
  std::vector<float> disp_;    // the network's predicted displacements per ring frame, (frames_ - 1) frames
  std::array<double, kJointCount> rough_{};  // mean squared second difference, m^2
  std::array<double, kJointCount> rough_before_{};  // rough_ before the last row's sample (a re-fit's, taken back)
  std::array<double, kJointCount> rough_hand_{}, rough_hand_before_{};  // the same in the hand's frame (the world's where none)
  std::array<double, kJointCount> hand_jump_{};  // the last row's jump against the hand (its hand-frame radius), else 0
  std::array<int, kJointCount> count_{};     // second differences averaged so far
  std::array<double, kJointCount> radius_{};
  std::vector<Eigen::Vector3d> bias_;  // per path frame and joint: mean offset (f = 0) or excess displacement
  std::vector<double> spread_;         // their samples' variance (the standard error's base)
  std::vector<Eigen::Vector3d> last_;  // their previous samples
  std::vector<int> bias_count_;
  std::array<double, kJointCount> corr2_{};  // mean squared correction on rows that were no jump, m^2
  std::array<int, kJointCount> corr_count_{};
  // The corrections of the ring's frames (NaN: none, or a jump), and the mean products of
  // each with those one and two frames before it, m^2.
  std::vector<Eigen::Vector3d> corr_;
  std::array<double, kJointCount> corr_lag1_{}, corr_lag2_{};
  // Prediction gain: the displacements applied (before the gain) and the denoised frames of
  // the ring's frames (NaN: none), and per path frame and joint the displacement's noise
  // E|v|^2 and recent power, m^2.
  std::vector<Eigen::Vector3d> applied_, den_;
  std::vector<double> pred_noise2_, pred_power2_;
  std::vector<int> pred_count_;
  // Prediction blend: per ring frame, path frame and joint the gained displacement g and
  // c - g (NaN: none); per path frame the running means of the hand's sums of (c - g) .
  // (y - g) and |c - g|^2, and this row's sums.
  std::vector<Eigen::Vector3d> gain_out_, cv_less_;
  std::vector<double> blend_num_, blend_den_, row_num_, row_den_;
  std::vector<int> blend_count_;

  // The rings' slot of the frame `back` frames ago (0 = now); every ring is indexed by it.
  size_t ring(long back) const noexcept { return static_cast<size_t>((n_ - back) % hist_); }
  const float* x_back(long back) const noexcept;  // the input `back` frames ago (0 = now)
  const Eigen::Vector3d& corr_back(long back, size_t joint) const noexcept;  // a correction `back` frames ago
  // The index of path frame f's entry for a joint, `back` frames ago, in the rings kept per predicted frame.
  size_t predicted_slot(long back, size_t f, size_t joint) const noexcept;
  // The displacement applied to path frame f (before its gain) and the denoised frame, `back` frames ago.
  Eigen::Vector3d& applied_back(long back, size_t f, size_t joint) noexcept;
  Eigen::Vector3d& den_back(long back, size_t joint) noexcept;
  // The gained displacement of path frame f and the velocity forecast less it, `back` frames ago.
  Eigen::Vector3d& gain_out_back(long back, size_t f, size_t joint) noexcept;
  Eigen::Vector3d& cv_less_back(long back, size_t f, size_t joint) noexcept;
  // Takes correction c (joint j, a row that is no jump) into the running means and returns
  // E|n|^2 as they read it.
  double correlated_noise2(size_t j, const Eigen::Vector3d& c) noexcept;
  // Displacement e of path frame f (index b = f * kJointCount + j) scaled by its Wiener
  // gain from frame `first` on, after taking in `went`, where the input went since the
  // denoised frame f frames ago (NaN: no evidence on this row), against the displacement
  // made then.
  Eigen::Vector3d gained(size_t f, size_t j, const Eigen::Vector3d& e, const Eigen::Vector3d& went,
                         size_t first) noexcept;
  // Gained displacement g of path frame f combined with the velocity forecast c (NaN: none)
  // by the hand's blend weight, after adding what `went` (as for gained) says of the pair
  // made f frames ago to this row's sums.
  Eigen::Vector3d blended(size_t f, size_t j, const Eigen::Vector3d& g, const Eigen::Vector3d& c,
                          const Eigen::Vector3d& went) noexcept;
};

}  // namespace hs
