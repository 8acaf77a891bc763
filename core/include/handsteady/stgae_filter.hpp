#pragma once
// The Multi-STGAE streaming engine as a PoseFilter: irregular input times onto the model's
// frames, interleaved streams for input faster than the model, answers at any time along
// the denoised/predicted path. Design notes: docs/STGAE.md "Streaming at any rate".
#include "handsteady/filters.hpp"
#include "handsteady/gap_policy.hpp"
#include "handsteady/stgae_model.hpp"

#include <memory>
#include <optional>

namespace hs {

// PoseFilter over a causal model: resamples irregular input (20-120 Hz) onto the model's
// grid by linear interpolation (each time the input passes a grid tick it pushes the
// interpolated frame). Input faster than the model runs K interleaved streams, each on
// the model's rate but offset by 1/K period, so each row is answered by a frame denoised
// at most 1/K period earlier (K = input rate / model rate rounded, measured over the first
// rows after a (re)start, 1..kStgaeMaxPhases; `phases` > 0 fixes it; at 45-52 Hz three
// streams with each interval split in two, nearer the model's trained speeds than two).
// Input within 20 % of K times the model rate (irregular times) locks the frames to the
// samples: each sample is a frame at its own time, missed samples are bridged
// (docs/STGAE.md). estimate(t):
// horizon 0 -> the denoised latest model frame, moved by the linear trend to t; horizon >
// 0 -> the predicted frames interpolated at t + horizon_s. The hand lost (no valid joint)
// for more than kModelResetGapS resets the streams. `bounded`: each stream's output is held
// within the trust region of its input (correction_bound.hpp), and where the noise is
// measured at the input rate (K >= 2, or one stream on rows slower than the model) the
// answer's correction along a fast joint's own motion is held (motion_lag_cap.hpp, fading
// out over one model period ahead); false = the network's raw answer (for comparison).
// `gain` (with bounded): the answers keep only the share of their correction that the
// input's next rows confirm, less the share the measured noise explains
// (correction_gain.hpp, fading out over one model period ahead); unset (auto) where the
// noise is measured at the input rate (K >= 2 streams, or one stream on rows slower than
// the model), true at every rate, false never. At one stream at the model's rate it would
// take the network's removal of a slow tremor back (docs/STGAE.md "Correction gain").
// `smooth` (with bounded): the predicted frames' displacements are smoothed over time
// (prediction_smoothing.hpp); false = each frame's own. `guard` (with bounded): the whole
// hand's correction is scaled back where the answer's whole-hand motion accelerates more
// than the input's (oscillation_guard.hpp; fading out over one model period ahead); false
// = without. Throws
// std::invalid_argument for a centred model, a negative horizon or phases outside 0..kStgaeMaxPhases.
inline constexpr int kStgaeMaxPhases = 4;
std::unique_ptr<PoseFilter> make_stgae_filter(std::shared_ptr<const StgaeModel> model, double horizon_s,
                                              int phases = 0, bool bounded = true,
                                              std::optional<bool> gain = std::nullopt,
                                              bool smooth = false, bool guard = true);

}  // namespace hs
