#pragma once
// Ink: what the AR handwriting demo draws. The pen is the index tip while thumb tip and
// index tip pinch (with hysteresis). Metrics compare ink with the font strokes and, when
// the truth is known, the ink pen with the true index tip (docs/HANDWRITING.md).
#include "handsteady/handwriting.hpp"
#include "handsteady/track.hpp"

#include <Eigen/Core>

#include <span>
#include <vector>

namespace hs {

// Hysteresis on the thumb_tip - index_tip distance: the pinch closes below close_m and
// opens above open_m. The synthetic track pinches at ~6 mm (parametric; 1-5 mm for the
// HoloLens 2 frames) and opens to 5-7 cm; tremor and tracker noise move the distance by a
// few mm, so 2.0 / 3.5 cm gives one ink stroke per font stroke without chatter.
struct PinchThresholds {
  double close_m = 0.020;
  double open_m = 0.035;
};

// Streaming, real-time: no allocation, no exceptions. A frame where thumb tip or index
// tip is untracked keeps the state (a dropout does not lift the pen).
class PinchDetector {
 public:
  PinchDetector() noexcept = default;
  explicit PinchDetector(PinchThresholds thresholds) noexcept : th_(thresholds) {}
  // Feeds one frame; returns the state after it.
  bool update(const Pose& pose) noexcept;
  bool update_distance(double distance_m) noexcept;  // NaN keeps the state
  bool pinched() const noexcept { return pinched_; }
  void reset() noexcept { pinched_ = false; }
  const PinchThresholds& thresholds() const noexcept { return th_; }

 private:
  PinchThresholds th_{};
  bool pinched_ = false;
};

// One ink stroke: pen positions (index tip) and their times, from the frame the pinch
// closed to the last frame before it opened. Frames with the index tip untracked add no
// point (a gap inside the stroke).
struct InkStroke {
  std::vector<double> t;
  std::vector<Eigen::Vector3d> p;
  size_t size() const { return t.size(); }
};

// Builds ink frame by frame (the demo app calls push once per rendered frame). Allocates
// as the ink grows: not for the real-time thread.
class InkRecorder {
 public:
  explicit InkRecorder(PinchThresholds thresholds = {}) : detector_(thresholds) {}
  void push(double t, const Pose& pose);
  bool pen_down() const noexcept { return detector_.pinched(); }
  const std::vector<InkStroke>& strokes() const noexcept { return strokes_; }
  void clear();

 private:
  PinchDetector detector_;
  std::vector<InkStroke> strokes_;
};

std::vector<InkStroke> extract_ink(const HandSeries& hand, PinchThresholds thresholds = {});

// ---------------------------------------------------------------------------------------
// Metrics. NaN = nothing to measure.
struct InkMetrics {
  size_t ink_strokes = 0, font_strokes = 0, ink_points = 0;
  double mean_distance_mm = 0.0;  // ink point -> nearest font stroke polyline, mean
  double p95_distance_mm = 0.0;   // ... 95th percentile (linear between order statistics)
  double coverage = 0.0;          // fraction of font length within coverage_radius of the ink
  double jerk_rms_m_s3 = 0.0;     // RMS |third derivative| of the ink path, within strokes
  double latency_ms = 0.0;        // ink pen behind the true index tip (+ = late); NaN without truth
};

// Distance from p to the nearest point of any polyline (a one-point polyline is a point).
double distance_to_polylines(const Eigen::Vector3d& p, std::span<const Polyline> lines);
// Per ink point, metres.
std::vector<double> ink_distances_m(std::span<const InkStroke> ink, std::span<const Polyline> font);
// Fraction of the font strokes' length within radius_m of the ink, the ink taken as
// polylines through consecutive points of each stroke (so the answer does not depend on
// the frame rate). Font strokes are sampled every 0.5 mm.
double ink_coverage(std::span<const InkStroke> ink, std::span<const Polyline> font, double radius_m = 0.005);
// Third divided differences over every 4 consecutive points of a stroke (exact for a
// cubic, valid for irregular times): j = 6 * p[t0, t1, t2, t3]. RMS of |j| in m/s^3.
double ink_jerk_rms(std::span<const InkStroke> ink);
// Lag of the ink pen behind truth's index tip, ms: the shift tau maximising the normalised
// cross-correlation of the ink velocity at t with the truth velocity at t - tau (truth
// interpolated; finite differences over the same time step), searched in steps of the
// median ink frame period over +-max_lag_s, refined by a parabola through the peak.
double ink_latency_ms(std::span<const InkStroke> ink, const HandSeries& truth, double max_lag_s = 0.3);

InkMetrics ink_metrics(std::span<const InkStroke> ink, std::span<const Polyline> font,
                       const HandSeries* truth /* may be null */, double coverage_radius_m = 0.005);

}  // namespace hs
