#include "report.hpp"

#include "handsteady/metrics.hpp"
#include "handsteady/track_ops.hpp"
#include "handsteady_render/plot.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>

namespace hs::demo {
namespace {

// JSON has no NaN: unmeasured values are null.
nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

std::string fmt_num(double v, int decimals) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : std::string("-");
}

// A tracking gap (no frame for over 0.1 s) becomes an untracked frame: a gap in the
// plotted curve, not a straight line across it.
HandSeries with_gaps(const HandSeries& in) {
  HandSeries out;
  for (size_t i = 0; i < in.size(); ++i) {
    if (i > 0 && in.t[i] - in.t[i - 1] > 0.1) {
      out.t.push_back(0.5 * (in.t[i] + in.t[i - 1]));
      out.pos.push_back(untracked_pose());
    }
    out.t.push_back(in.t[i]);
    out.pos.push_back(in.pos[i]);
  }
  return out;
}

}  // namespace

std::string write_report(const std::filesystem::path& dir, const ReportInputs& in) {
  std::filesystem::create_directories(dir);
  nlohmann::json j;
  j["layer_mode"] = in.layer_mode;
  std::string md = "| panel | ink strokes | mean dist. to font (mm) | p95 dist. (mm) | coverage | jerk RMS (m/s^3) |"
                   " latency (ms) | index-tip error (mm) | MPJPE (mm) |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const PanelRecord& p : in.panels) {
    Track seen;
    seen.set_meta("source", fmt::format("handsteady_demo: joints the app received, {}", p.label));
    add_hand_series(seen, Hand::Right, p.seen);
    write_track_csv(seen, dir / (p.name + "_seen.csv"));

    nlohmann::json pj;
    pj["label"] = p.label;
    pj["frames"] = p.seen.size();
    InkMetrics m;
    m.ink_strokes = p.ink.size();
    m.mean_distance_mm = m.p95_distance_mm = m.coverage = m.jerk_rms_m_s3 = m.latency_ms =
        std::numeric_limits<double>::quiet_NaN();
    if (in.strokes) m = ink_metrics(p.ink, in.strokes->strokes, in.truth ? &*in.truth : nullptr);
    pj["ink"] = {{"strokes", m.ink_strokes},
                 {"font_strokes", m.font_strokes},
                 {"points", m.ink_points},
                 {"mean_distance_mm", num(m.mean_distance_mm)},
                 {"p95_distance_mm", num(m.p95_distance_mm)},
                 {"coverage", num(m.coverage)},
                 {"jerk_rms_m_s3", num(m.jerk_rms_m_s3)},
                 {"latency_ms", num(m.latency_ms)}};
    // Joint errors against the truth at the same (track) times.
    double tip_mm = std::numeric_limits<double>::quiet_NaN(), mpjpe = tip_mm;
    if (in.truth) {
      Track truth_track;
      add_hand_series(truth_track, Hand::Right, *in.truth);
      const Metrics e = evaluate_tracks(truth_track, seen);
      mpjpe = e.mpjpe_mm;
      double sum = 0.0;
      long n = 0;
      for (size_t i = 0; i < p.seen.size(); ++i) {
        const Pose t = interpolate_pose(*in.truth, p.seen.t[i]);
        const int k = idx(Joint::IndexTip);
        if (!joint_tracked(t, k) || !joint_tracked(p.seen.pos[i], k)) continue;
        sum += (t.row(k) - p.seen.pos[i].row(k)).norm() * 1e3;
        ++n;
      }
      if (n > 0) tip_mm = sum / static_cast<double>(n);
      pj["mpjpe_mm"] = num(mpjpe);
      pj["index_tip_error_mm"] = num(tip_mm);
      pj["joint_lag_ms"] = num(e.lag_ms);
      pj["jitter_mm"] = num(e.jitter_mm);
    }
    j["panels"][p.name] = pj;
    md += fmt::format("| {} | {} / {} | {} | {} | {} | {} | {} | {} | {} |\n", p.label, m.ink_strokes, m.font_strokes,
                      fmt_num(m.mean_distance_mm, 2), fmt_num(m.p95_distance_mm, 2), fmt_num(m.coverage, 3),
                      fmt_num(m.jerk_rms_m_s3, 1), fmt_num(m.latency_ms, 1), fmt_num(tip_mm, 2), fmt_num(mpjpe, 2));
  }
  if (in.prediction && in.truth && !in.panels.empty()) {
    // Index-tip error against the truth at t + H: the prediction, and the raw joints of t.
    const Prediction& pr = *in.prediction;
    const HandSeries& raw = in.panels.front().seen;
    const double h = pr.horizon_ms * 1e-3;
    const int k = idx(Joint::IndexTip);
    double sp = 0.0, sr = 0.0;
    long n = 0;
    for (size_t i = 0; i < pr.at_row.size() && i < raw.size(); ++i) {
      const Pose t = interpolate_pose(*in.truth, pr.at_row.t[i] + h);
      if (!joint_tracked(t, k) || !joint_tracked(pr.at_row.pos[i], k) || !joint_tracked(raw.pos[i], k)) continue;
      sp += (t.row(k) - pr.at_row.pos[i].row(k)).norm() * 1e3;
      sr += (t.row(k) - raw.pos[i].row(k)).norm() * 1e3;
      ++n;
    }
    const double ep = n ? sp / static_cast<double>(n) : std::nan(""), er = n ? sr / static_cast<double>(n) : std::nan("");
    j["prediction"] = {{"horizon_ms", pr.horizon_ms},
                       {"model", pr.model},
                       {"index_tip_error_mm", num(ep)},
                       {"raw_index_tip_error_mm", num(er)}};
    md += fmt::format("\nMulti-STGAE prediction +{:g} ms from the raw joints ({}): index-tip error {} mm against the "
                      "truth at t + {:g} ms; the raw joints of t: {} mm.\n",
                      pr.horizon_ms, pr.model, fmt_num(ep, 2), pr.horizon_ms, fmt_num(er, 2));
  }
  std::ofstream(dir / "summary.json") << j.dump(2) << "\n";
  std::ofstream(dir / "summary.md") << md;

  if (in.truth) {
    // The index fingertip over time: what each panel received and the truth.
    render::TrajectoryPlot plot;
    plot.title = "Index fingertip (" + in.layer_mode + ")";
    const render::Color colors[] = {render::Color::rgb8(220, 60, 50), render::Color::rgb8(30, 110, 220)};
    size_t c = 0;
    for (const PanelRecord& p : in.panels) {
      const HandSeries s = with_gaps(p.seen);
      plot.series.push_back(render::joint_series(p.label, colors[c++ % 2], s.t, s.pos, idx(Joint::IndexTip)));
      plot.series.back().width_px = 1.5f;
    }
    if (in.prediction) {
      const Prediction& pr = *in.prediction;
      const HandSeries s = with_gaps(pr.at_row);
      plot.series.push_back(render::joint_series(fmt::format("predicted +{:g} ms (from raw)", pr.horizon_ms),
                                                 render::Color::rgb8(40, 160, 70), s.t, s.pos, idx(Joint::IndexTip),
                                                 pr.horizon_ms * 1e-3));
      plot.series.back().width_px = 1.5f;
    }
    plot.series.push_back(
        render::joint_series("truth", render::Color::rgb8(20, 20, 20), in.truth->t, in.truth->pos, idx(Joint::IndexTip)));
    render::write_trajectory_plot(dir / "index_tip_plot.png", plot);
  }
  return md;
}

}  // namespace hs::demo
