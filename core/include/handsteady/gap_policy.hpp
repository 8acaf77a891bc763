#pragma once
// The gap policy of every time series (tracks, filters, the model's grid, ink), in one
// place. A gap is time without a tracked sample. Three questions, three answers:
namespace hs {

// Interpolation (resampling, the model grid's reader, ink metrics): two samples farther
// apart than this are not joined; the time between them is untracked. A quarter second
// bridges a few dropped tracker frames at 20-120 Hz but not a hand that left the view.
inline constexpr double kInterpolateMaxGapS = 0.25;

// The network's history: after a tracking gap longer than this the streams restart (the
// history no longer describes the hand, and the layer's blend-in covers the restart).
inline constexpr double kModelResetGapS = 0.3;

// A classical filter forgets a joint unseen for longer than this (FilterConfig::max_gap_s
// default): its state is cheap to rebuild, and holding it a little longer keeps a joint
// that flickers smooth.
inline constexpr double kFilterForgetGapS = 0.5;

}  // namespace hs
