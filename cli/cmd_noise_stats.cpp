// handsteady noise-stats: tracker-noise statistics of a track, measured the same way as
// tools/measure_hl2_noise.py (docs/CORRUPTION.md): frame period, dropouts, dropped
// joints, robust jitter (all rows and still hand), second differences, jumps. Useful to
// check that a `corrupt --preset tracker` output resembles the real recordings.
#include "commands.hpp"

#include "handsteady/track.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace hs::cli {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}
// 1.4826 * median absolute deviation: the SD of a Gaussian, robust to outliers.
double mad_sd(const std::vector<double>& v) {
  const double m = median(v);
  std::vector<double> d;
  d.reserve(v.size());
  for (double x : v) d.push_back(std::abs(x - m));
  return 1.4826 * median(std::move(d));
}

struct NoiseStats {
  std::vector<double> periods, dropout_s, residuals, still_residuals, resid_norms;
  std::vector<std::vector<double>> row_norms;  // per triple, for the jump test
  size_t rows_span = 0, rows_tracked = 0, dropouts = 0, cells = 0, cells_dropped = 0;
  double tracked_time = 0;
};

void measure_hand(const HandSeries& s, NoiseStats& st) {
  for (size_t i = 1; i < s.size(); ++i) st.periods.push_back(s.t[i] - s.t[i - 1]);
  std::vector<size_t> tracked;
  for (size_t i = 0; i < s.size(); ++i)
    if (any_joint_tracked(s.pos[i])) tracked.push_back(i);
  if (tracked.empty()) return;
  st.rows_span += tracked.back() - tracked.front() + 1;
  st.rows_tracked += tracked.size();
  for (size_t k = 1; k < tracked.size(); ++k) {
    const size_t a = tracked[k - 1], b = tracked[k];
    if (b == a + 1) {
      st.tracked_time += s.t[b] - s.t[a];
    } else {
      ++st.dropouts;
      st.dropout_s.push_back(s.t[b] - s.t[a]);
    }
  }
  for (size_t i : tracked) {
    st.cells += kJointCount;
    st.cells_dropped += static_cast<size_t>(kJointCount - tracked_joint_count(s.pos[i]));
  }
  const int w = idx(Joint::Wrist);
  for (size_t i = 1; i + 1 < s.size(); ++i) {
    const Pose &a = s.pos[i - 1], &b = s.pos[i], &c = s.pos[i + 1];
    const bool still = joint_tracked(a, w) && joint_tracked(c, w) && (c.row(w) - a.row(w)).norm() < 0.004;
    std::vector<double> norms;
    for (int j = 0; j < kJointCount; ++j) {
      if (!joint_tracked(a, j) || !joint_tracked(b, j) || !joint_tracked(c, j)) continue;
      const Eigen::RowVector3d r = b.row(j) - 0.5 * (a.row(j) + c.row(j));
      for (int k = 0; k < 3; ++k) {
        st.residuals.push_back(r(k));
        if (still) st.still_residuals.push_back(r(k));
      }
      norms.push_back(r.norm());
      st.resid_norms.push_back(r.norm());
    }
    if (!norms.empty()) st.row_norms.push_back(std::move(norms));
  }
}

void print(const std::string& name, const std::string& value) {
  std::fputs(fmt::format("{:<34} {}\n", name, value).c_str(), stdout);
}

void run_noise_stats(const std::string& in) {
  const Track track = read_track_csv(in);
  NoiseStats st;
  for (Hand h : {Hand::Left, Hand::Right}) measure_hand(hand_series(track, h), st);
  if (st.rows_tracked == 0) throw std::runtime_error(fmt::format("{}: no tracked rows", in));
  const double period = median(st.periods);
  const double mm = 1e3;
  print("median frame period", fmt::format("{:.1f} ms ({:.1f} Hz)", period * mm, 1.0 / period));
  print("untracked fraction (inside span)",
        fmt::format("{:.4f} ({} of {} rows)", 1.0 - static_cast<double>(st.rows_tracked) / static_cast<double>(st.rows_span),
                    st.rows_span - st.rows_tracked, st.rows_span));
  print("whole-hand dropouts", fmt::format("{} ({:.4f} per tracked second)", st.dropouts,
                                           st.tracked_time > 0 ? static_cast<double>(st.dropouts) / st.tracked_time : 0.0));
  if (!st.dropout_s.empty()) {
    double sum = 0;
    for (double& d : st.dropout_s) sum += (d = std::max(d - period, 0.0));
    print("dropout duration", fmt::format("mean {:.0f} ms, median {:.0f} ms", sum / static_cast<double>(st.dropout_s.size()) * mm,
                                          median(st.dropout_s) * mm));
  }
  print("dropped joints in tracked rows",
        fmt::format("{:.5f}", static_cast<double>(st.cells_dropped) / static_cast<double>(st.cells)));
  if (st.residuals.empty()) return;
  // White noise of SD s gives residual variance 1.5 s^2.
  print("jitter SD (all rows)", fmt::format("{:.2f} mm", mad_sd(st.residuals) / std::sqrt(1.5) * mm));
  if (!st.still_residuals.empty())
    print("jitter SD (wrist still < 4 mm)", fmt::format("{:.2f} mm", mad_sd(st.still_residuals) / std::sqrt(1.5) * mm));
  print("median |second difference|", fmt::format("{:.2f} mm/frame^2", 2.0 * median(st.resid_norms) * mm));
  const double thresh = 6.0 * mad_sd(st.resid_norms) + median(st.resid_norms);
  size_t jumps = 0;
  double jump_sq = 0;
  for (const auto& norms : st.row_norms) {
    if (norms.size() < 3) continue;
    const double row_median = median(norms);
    for (double n : norms)
      if (n > thresh && n > 3.0 * row_median) {
        ++jumps;
        jump_sq += n * n;
      }
  }
  print("jumps per joint per row", fmt::format("{:.5f} (|r| > {:.1f} mm)", static_cast<double>(jumps) / static_cast<double>(st.resid_norms.size()),
                                               thresh * mm));
  if (jumps > 0)
    print("jump SD per coordinate", fmt::format("{:.1f} mm", std::sqrt(jump_sq / static_cast<double>(jumps) / 3.0) * mm));
}

void setup_noise_stats(CLI::App& app) {
  auto in = std::make_shared<std::string>();
  CLI::App* sub = app.add_subcommand(
      "noise-stats", "Tracker-noise statistics of a track (method of docs/CORRUPTION.md)");
  sub->add_option("--in", *in, "Track CSV")->required();
  sub->callback([in] { run_noise_stats(*in); });
}

const CommandRegistration register_noise_stats(&setup_noise_stats);

}  // namespace
}  // namespace hs::cli
