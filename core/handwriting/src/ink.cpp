// Pinch detection and ink extraction (docs/HANDWRITING.md, "Ink").
#include "handsteady/ink.hpp"

#include <cmath>

namespace hs {

bool PinchDetector::update_distance(double distance_m) noexcept {
  if (std::isnan(distance_m)) return pinched_;  // not seen: keep the pen where it was
  if (pinched_ && distance_m > th_.open_m) pinched_ = false;
  else if (!pinched_ && distance_m < th_.close_m) pinched_ = true;
  return pinched_;
}

bool PinchDetector::update(const Pose& pose) noexcept {
  // Inline rather than thumb_index_distance() to stay on the real-time path: no throw.
  const int thumb = idx(Joint::ThumbTip), index = idx(Joint::IndexTip);
  if (!joint_tracked(pose, thumb) || !joint_tracked(pose, index)) return pinched_;
  return update_distance((pose.row(thumb) - pose.row(index)).norm());
}

void InkRecorder::push(double t, const Pose& pose) {
  const bool was_down = detector_.pinched();
  const bool down = detector_.update(pose);
  if (!down) return;
  if (!was_down) strokes_.emplace_back();
  const int index = idx(Joint::IndexTip);
  if (!joint_tracked(pose, index)) return;  // a gap in the stroke
  strokes_.back().t.push_back(t);
  strokes_.back().p.emplace_back(pose.row(index).transpose());
}

void InkRecorder::clear() {
  strokes_.clear();
  detector_.reset();
}

std::vector<InkStroke> extract_ink(const HandSeries& hand, PinchThresholds thresholds) {
  InkRecorder rec(thresholds);
  for (size_t i = 0; i < hand.size(); ++i) rec.push(hand.t[i], hand.pos[i]);
  return rec.strokes();
}

}  // namespace hs
