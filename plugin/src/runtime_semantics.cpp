#include "runtime_semantics.hpp"

#include <bit>
#include <cstring>

namespace hs::layer {

bool SemanticsProbe::due() noexcept {
  // Rare once learnt (runtimes do not change their semantics): under 1 % of calls, so the
  // extra runtime call stays out of the layer's p99.
  const uint64_t every = votes_ < kWindow ? 4 : 256;
  return calls_++ % every == every - 1;
}

void SemanticsProbe::vote(const Pose& a, const Pose& b, bool moving) noexcept {
  const bool identical = same_pose(a, b);
  if (identical && !moving) return;
  const uint32_t mask = (1u << kWindow) - 1;
  history_ = ((history_ << 1) | (identical ? 1u : 0u)) & mask;
  votes_ = std::min(votes_ + 1, kWindow);
  latest_votes_ = std::popcount(history_);
}

bool same_pose(const Pose& a, const Pose& b) noexcept {
  for (int j = 0; j < kJointCount; ++j) {
    if (joint_tracked(a, j) != joint_tracked(b, j)) return false;
    if (joint_tracked(a, j) && std::memcmp(a.row(j).data(), b.row(j).data(), 3 * sizeof(double)) != 0) return false;
  }
  return true;
}

std::string_view semantics_name(TimeSemantics s) noexcept {
  return s == TimeSemantics::Latest ? "latest pose whatever the time" : "pose at the asked time";
}

}  // namespace hs::layer
