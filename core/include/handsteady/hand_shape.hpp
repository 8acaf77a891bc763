#pragma once
// Hand proportions and joint placements of other runtimes: the benchmark scores methods
// on such hands, and training augments with them, so a model does not impose one hand.
#include "handsteady/track.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace hs {

enum class ShapeKind { Standard, Scale, BoneJitter, WristProximal, PalmCentroid, ThumbBase };
struct ShapeVariant {
  std::string name;
  ShapeKind kind = ShapeKind::Standard;
  // Scale: factor on every bone; BoneJitter: each bone x a seeded factor in 1 +- amount;
  // WristProximal: the wrist moved this many metres away from the middle metacarpal;
  // ThumbBase: the thumb metacarpal moved this fraction of the way to the wrist.
  // PalmCentroid: the palm at the centroid of the finger metacarpals and proximals.
  double amount = 0.0;
};

// Reshapes every pose in place (the same bone factors for all; untracked joints stay
// untracked; a joint whose parent is untracked moves with its nearest tracked ancestor).
void apply_shape(std::vector<Pose>& poses, const ShapeVariant& shape, uint64_t seed);
HandSeries apply_shape(const HandSeries& series, const ShapeVariant& shape, uint64_t seed);

}  // namespace hs
