// Window mode over a whole recording (stgae_offline.hpp).
#include "handsteady/stgae_offline.hpp"

#include "handsteady/gap_policy.hpp"
#include "handsteady/stgae_engine.hpp"
#include "handsteady/time_series.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace hs {
namespace {

// One segment of tracked rows resampled onto the model grid.
struct Segment {
  StgaeFrames<float> grid;
  std::vector<double> gt;  // sample time of each grid frame (the last one is clamped to the last row)
  std::array<bool, kJointCount> seen{};
  double t0 = 0.0;
  int frames() const { return static_cast<int>(grid.rows()); }
};

Segment resample_segment(const HandSeries& in, const std::vector<size_t>& tracked, size_t a, size_t b,
                         double period) {
  Segment s;
  s.t0 = in.t[tracked[a]];
  const double t1 = in.t[tracked[b]];
  const int frames = 1 + static_cast<int>(std::ceil((t1 - s.t0) / period - 1e-9));
  s.grid.resize(frames, 3 * kJointCount);
  s.gt.resize(static_cast<size_t>(frames));
  for (size_t r = a; r <= b; ++r)
    for (int j = 0; j < kJointCount; ++j) s.seen[static_cast<size_t>(j)] = s.seen[static_cast<size_t>(j)] || joint_tracked(in.pos[tracked[r]], j);
  size_t r = a;
  for (int k = 0; k < frames; ++k) {
    const double g = std::min(s.t0 + k * period, t1);  // the last tick may lie after t1: it takes the last row
    s.gt[static_cast<size_t>(k)] = g;
    while (r < b && in.t[tracked[r + 1]] <= g) ++r;
    const size_t r1 = std::min(r + 1, b);
    const double ta = in.t[tracked[r]], tb = in.t[tracked[r1]];
    const double w = tb > ta ? std::clamp((g - ta) / (tb - ta), 0.0, 1.0) : 0.0;
    lerp_frame<double, float>({in.pos[tracked[r]].data(), 3 * kJointCount}, {in.pos[tracked[r1]].data(), 3 * kJointCount},
                              w, OneSided::Either, {s.grid.row(k).data(), 3 * kJointCount});
  }
  return s;
}

// Window-mode prediction: for each row, the window of T grid frames ending at the row's
// grid frame (at or before the row), its path [denoised last frame, predicted DT frames]
// read at row time + horizon.
void predict_rows(const StgaeNet<float>& net, const Segment& s, double horizon_s, const std::vector<size_t>& tracked,
                  size_t a, size_t b, HandSeries& out) {
  const StgaeConfig& c = net.config();
  const int T = c.window, DT = c.horizon, frames = s.frames();
  const double period = 1.0 / c.rate_hz;
  StgaeFrames<float> window(T, s.grid.cols());
  int cached = -1;
  StgaeOutput<float> y;
  for (size_t q = a; q <= b; ++q) {
    const size_t row = tracked[q];
    const double tr = out.t[row];
    // A grid frame within the tick tolerance after the row counts as at it; never a later one.
    int k = std::clamp(static_cast<int>(std::floor((tr + kTickToleranceS - s.t0) / period)), 0, frames - 1);
    while (k > 0 && s.gt[static_cast<size_t>(k)] > tr + kTickToleranceS) --k;
    if (k != cached) {
      for (int i = 0; i < T; ++i) window.row(i) = s.grid.row(std::max(0, k - (T - 1) + i));
      y = stgae_window_forward(net, window);
      cached = k;
    }
    const PathPlace at = path_place((tr + horizon_s - s.gt[static_cast<size_t>(k)]) / period, DT);
    const auto point = [&](int i, Eigen::Index col) { return i == 0 ? y.denoised(T - 1, col) : y.predicted(i - 1, col); };
    Pose& p = out.pos[row];
    for (int j = 0; j < kJointCount; ++j)
      for (int d = 0; d < 3; ++d) {
        const Eigen::Index col = 3 * j + d;
        p(j, d) = s.seen[static_cast<size_t>(j)] ? lerp_value(point(at.seg, col), point(at.seg + 1, col), at.f) : kNaN;
      }
  }
}

// Window-mode denoising of one segment, back onto its rows.
void denoise_rows(const StgaeNet<float>& net, const Segment& s, const std::vector<size_t>& tracked, size_t a,
                  size_t b, const HandSeries& in, HandSeries& out) {
  const StgaeConfig& c = net.config();
  const int T = c.window, centre = (T - 1) / 2, frames = s.frames();
  const double period = 1.0 / c.rate_hz;
  // One window per start position; each grid frame taken from its window.
  StgaeFrames<float> den(frames, s.grid.cols());
  StgaeFrames<float> window(T, s.grid.cols());
  if (frames < T) {
    const int pad = (T - frames) / 2;
    for (int i = 0; i < T; ++i) window.row(i) = s.grid.row(std::clamp(i - pad, 0, frames - 1));
    const StgaeOutput<float> y = stgae_window_forward(net, window);
    for (int k = 0; k < frames; ++k) den.row(k) = y.denoised.row(k + pad);
  } else {
    for (int ws = 0; ws + T <= frames; ++ws) {
      window = s.grid.middleRows(ws, T);
      const StgaeOutput<float> y = stgae_window_forward(net, window);
      const int first = ws == 0 ? 0 : ws + centre;
      const int last = ws + T == frames ? frames - 1 : ws + centre;
      for (int k = first; k <= last; ++k) den.row(k) = y.denoised.row(k - ws);
    }
  }
  // Back to the rows, linearly between the grid frames' sample times.
  for (size_t q = a; q <= b; ++q) {
    const size_t row = tracked[q];
    const int k0 = std::clamp(static_cast<int>(std::floor((in.t[row] - s.t0) / period)), 0, frames - 1);
    const int k1 = std::min(k0 + 1, frames - 1);
    const double g0 = s.gt[static_cast<size_t>(k0)], g1 = s.gt[static_cast<size_t>(k1)];
    const double f = g1 > g0 ? std::clamp((in.t[row] - g0) / (g1 - g0), 0.0, 1.0) : 0.0;
    Pose& p = out.pos[row];
    for (int j = 0; j < kJointCount; ++j)
      for (int d = 0; d < 3; ++d)
        p(j, d) = s.seen[static_cast<size_t>(j)] ? lerp_value(den(k0, 3 * j + d), den(k1, 3 * j + d), f) : kNaN;
  }
}

}  // namespace

HandSeries stgae_offline_series(const StgaeModel& model, const HandSeries& in, double horizon_s) {
  const StgaeConfig& c = model.config;
  if (c.joint_count() != kJointCount) throw std::invalid_argument("window mode needs a 26-joint (xr26) model");
  if (!(horizon_s >= 0.0) || !std::isfinite(horizon_s)) throw std::invalid_argument("the horizon must be >= 0 s");
  if (horizon_s > 0.0 && !c.predict)
    throw std::invalid_argument("this model has no prediction branch: window mode with a horizon needs one");
  const double period = 1.0 / c.rate_hz;
  HandSeries out = in;
  std::vector<size_t> tracked;
  for (size_t i = 0; i < in.size(); ++i)
    if (any_joint_tracked(in.pos[i])) tracked.push_back(i);
  size_t a = 0;
  while (a < tracked.size()) {
    size_t b = a;  // segment = tracked[a..b]
    while (b + 1 < tracked.size() && in.t[tracked[b + 1]] - in.t[tracked[b]] <= kModelResetGapS) ++b;
    const Segment s = resample_segment(in, tracked, a, b, period);
    if (horizon_s > 0.0) predict_rows(*model.net, s, horizon_s, tracked, a, b, out);
    else denoise_rows(*model.net, s, tracked, a, b, in, out);
    a = b + 1;
  }
  return out;
}

}  // namespace hs
