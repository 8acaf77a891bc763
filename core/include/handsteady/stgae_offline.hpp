#pragma once
// Window mode over a whole recording (not causal): a centred Multi-STGAE model denoises
// each frame from the window centred on it, or, with a horizon, the window ending at each
// row predicts (the paper's protocol). The streaming counterpart: stgae_filter.hpp.
#include "handsteady/stgae_model.hpp"
#include "handsteady/track.hpp"

namespace hs {

// One hand. The tracked rows are cut into segments wherever the hand is lost for more
// than kModelResetGapS (as the streaming adapter resets there). Each segment is resampled
// onto the model grid t0 + k / rate_hz (a joint missing in one bracketing row takes the
// other's value; missing in both: NaN, hole-filled by the model). horizon_s = 0: every
// grid frame k is denoised by the window of T frames centred on it; at the segment's ends
// the window is clamped inside the segment, so frame k comes off-centre from the
// first/last full window; a segment shorter than T frames is padded by repeating its
// first and last frames; the denoised grid is interpolated back to the rows.
// horizon_s > 0 (needs a prediction branch): grid frame k is answered by the window that
// ends at it (frames k-T+1..k, the first frame repeated before the segment's start): the
// path [denoised k, predicted k+1..k+DT] read at horizon_s after the row, taken from the
// row's own grid frame or the one before, so only rows up to the row are used.
// Joints never observed in a segment stay NaN. Throws std::invalid_argument for a model
// that is not a 26-joint model, or a horizon it cannot answer.
HandSeries stgae_offline_series(const StgaeModel& model, const HandSeries& in, double horizon_s);

}  // namespace hs
