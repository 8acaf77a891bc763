#include "handsteady/prediction_smoothing.hpp"
#include "handsteady/filters.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hs {

PredictionSmoother::PredictionSmoother(int frames) : frames_(frames < 1 ? 1 : frames) {
  disp_.resize(static_cast<size_t>(frames_ - 1) * kFs);
  t_.resize(static_cast<size_t>(frames_ - 1) * kJointCount);
  reset();
}

void PredictionSmoother::reset() noexcept {
  std::fill(disp_.begin(), disp_.end(), kNaN);
  std::fill(t_.begin(), t_.end(), kNaN);
}

void PredictionSmoother::apply(double t, std::span<float> path) noexcept {
  if (path.size() < static_cast<size_t>(frames_) * kFs) return;
  for (int f = 1; f < frames_; ++f) {
    const size_t frame = static_cast<size_t>(f) * kFs;
    for (size_t j = 0; j < kJointCount; ++j) {
      double d[3];
      bool ok = true;
      for (size_t c = 0; c < 3; ++c) {
        d[c] = static_cast<double>(path[frame + 3 * j + c]) - static_cast<double>(path[3 * j + c]);
        ok = ok && std::isfinite(d[c]);
      }
      double* s = &disp_[static_cast<size_t>(f - 1) * kFs + 3 * j];
      double& last = t_[static_cast<size_t>(f - 1) * kJointCount + j];
      if (!ok) {  // missing now: the next one starts afresh
        last = kNaN;
        continue;
      }
      const double dt = t - last;
      if (std::isnan(last) || !(dt > 0.0)) {
        for (size_t c = 0; c < 3; ++c) s[c] = d[c];
      } else {
        const double change = std::sqrt((d[0] - s[0]) * (d[0] - s[0]) + (d[1] - s[1]) * (d[1] - s[1]) +
                                         (d[2] - s[2]) * (d[2] - s[2]));
        const double a = low_pass_alpha(kPredictionMinCutoffHz + kPredictionBeta * change / dt, dt);
        for (size_t c = 0; c < 3; ++c) s[c] += a * (d[c] - s[c]);
      }
      last = t;
      for (size_t c = 0; c < 3; ++c)
        path[frame + 3 * j + c] = static_cast<float>(static_cast<double>(path[3 * j + c]) + s[c]);
    }
  }
}

}  // namespace hs
