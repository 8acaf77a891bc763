#pragma once
// How a runtime answers xrLocateHandJointsEXT(time), learned from its answers:
// - History: the pose at the asked time (interpolated from its history; a future time is
//   extrapolated). Monado's relation history, the replay runtime, Quest's extrapolation.
// - Latest: its newest pose whatever the time (Monado's remote driver, simple drivers).
//   The layer must then date samples by its own clock, not by the asked time, and skip
//   repeats, or it predicts from stale-looking samples.
// The layer probes now and then (every 4th call while learning, every 256th after): the
// same hand at two times 25 ms apart. Bit-identical
// answers while the hand moves vote Latest; different answers vote History. The verdict
// is the majority of the last kWindow votes (History until then). Pure state, no locks:
// the caller serialises. See docs/OPENXR_LAYER.md "Runtimes".
#include "handsteady/track.hpp"

#include <cstdint>

namespace hs::layer {

enum class TimeSemantics { History, Latest };

class SemanticsProbe {
 public:
  static constexpr int kWindow = 8;
  static constexpr int64_t kProbeOffsetNs = 25'000'000;

  // Whether this call should probe (every 4th call while learning, every 256th after).
  bool due() noexcept;
  // The hand answered `a` at one time and `b` kProbeOffsetNs earlier (world space, NaN =
  // missing); `moving`: the hand's answers changed since the last probe (a still hand
  // proves nothing).
  void vote(const Pose& a, const Pose& b, bool moving) noexcept;
  TimeSemantics semantics() const noexcept { return latest_votes_ * 2 > votes_ ? TimeSemantics::Latest : TimeSemantics::History; }
  int votes() const noexcept { return votes_; }

 private:
  uint64_t calls_ = 0;
  uint32_t history_ = 0;  // last kWindow votes, bit set = Latest
  int votes_ = 0, latest_votes_ = 0;
};

// Bit-identical tracked joints (and the same joints tracked).
bool same_pose(const Pose& a, const Pose& b) noexcept;

// The runtime's answer repeated: hs::repeated_pose (track.hpp).

std::string_view semantics_name(TimeSemantics s) noexcept;

}  // namespace hs::layer
