#include "handsteady/oscillation_guard.hpp"

#include "handsteady/time_series.hpp"

#include <algorithm>
#include <cmath>

namespace hs {

void OscillationGuard::reset() noexcept {
  e_in_ = e_out_ = 0.0;
  diffs_ = 0;
  clear();
}

void OscillationGuard::clear() noexcept {
  rows_ = 0;
  kept_ = 1.0;
  shift_.fill(0.0);
}

void OscillationGuard::observe(std::span<const float> x, const Pose& answer) noexcept {
  if (x.size() < kFs) return;
  auto& x0 = x_[static_cast<size_t>(older_)];  // two rows back, overwritten by this one
  const auto& x1 = x_[static_cast<size_t>(1 - older_)];
  auto& y0 = y_[static_cast<size_t>(older_)];
  const auto& y1 = y_[static_cast<size_t>(1 - older_)];
  // The mean second difference of input and answer over joints in all three rows, and the
  // mean correction over joints in this one.
  std::array<double, 3> dx{}, dy{}, corr{};
  int n2 = 0, n1 = 0;
  for (int j = 0; j < kJointCount; ++j) {
    const auto i = static_cast<size_t>(3 * j);
    const bool here = finite_xyz(x.data() + i) && joint_finite(answer, j);
    const bool before = rows_ >= 2 && std::isfinite(x0[i]) && std::isfinite(x1[i]) && std::isfinite(y0[i]) &&
                        std::isfinite(y1[i]);
    for (int c = 0; c < 3; ++c) {
      const double xi = here ? static_cast<double>(x[i + static_cast<size_t>(c)]) : kNaN;
      const double yi = here ? answer(j, c) : kNaN;
      if (here) {
        corr[static_cast<size_t>(c)] += yi - xi;
        if (before) {
          const auto k = i + static_cast<size_t>(c);
          dx[static_cast<size_t>(c)] += xi - 2.0 * x1[k] + x0[k];
          dy[static_cast<size_t>(c)] += yi - 2.0 * y1[k] + y0[k];
        }
      }
      x0[i + static_cast<size_t>(c)] = xi;
      y0[i + static_cast<size_t>(c)] = yi;
    }
    n1 += here ? 1 : 0;
    n2 += here && before ? 1 : 0;
  }
  rows_ = std::min(rows_ + 1, 2);
  older_ = 1 - older_;
  if (n2 >= kGuardMinJoints) {
    double ex = 0.0, ey = 0.0;
    for (int c = 0; c < 3; ++c) {
      ex += dx[static_cast<size_t>(c)] * dx[static_cast<size_t>(c)];
      ey += dy[static_cast<size_t>(c)] * dy[static_cast<size_t>(c)];
    }
    const double n = static_cast<double>(n2);
    constexpr double lambda = 1.0 - 1.0 / kGuardRows;
    e_in_ = lambda * e_in_ + ex / (n * n);
    e_out_ = lambda * e_out_ + ey / (n * n);
    diffs_ = std::min(diffs_ + 1, kGuardWarmRows);
  }
  kept_ = diffs_ >= kGuardWarmRows && e_out_ > e_in_ ? std::pow(e_in_ / e_out_, kGuardPower) : 1.0;
  if (n1 < kGuardMinJoints || !std::isfinite(kept_)) {
    kept_ = 1.0;
    shift_.fill(0.0);
    return;
  }
  for (int c = 0; c < 3; ++c) shift_[static_cast<size_t>(c)] = -(1.0 - kept_) * corr[static_cast<size_t>(c)] / n1;
}

}  // namespace hs
