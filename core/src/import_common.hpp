#pragma once
// Helpers shared by the importers (private to hs_core).
#include "handsteady/error.hpp"
#include "handsteady/track.hpp"

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace hs::detail {

// Finger metacarpal = wrist + a * (proximal - wrist), a measured on HoloLens 2 tracking
// (../shared/data/README.md), for index, middle, ring, little.
inline constexpr std::array<double, 4> kMetacarpalRatio = {0.25, 0.24, 0.27, 0.33};

// Fills the four finger metacarpals from wrist and proximal joints (left untracked
// when either is missing).
void derive_finger_metacarpals(Pose& p);
// Palm = midpoint of middle metacarpal and middle proximal.
void derive_palm(Pose& p);

// Comma-separated XR joint names, in XR order.
std::string joint_list(const std::vector<int>& joints);

// Whitespace-separated tokens of a line.
std::vector<std::string_view> split_ws(std::string_view line);
std::string_view trim(std::string_view s);

}  // namespace hs::detail
