// The replay runtime's action system, its pure parts (see shim_actions.hpp).
#include "shim_actions.hpp"

#include <algorithm>
#include <array>
#include <string_view>
#include <utility>

namespace hs::shim {

bool well_formed_path(std::string_view path) {
  if (path.size() < 2 || path.front() != '/' || path.back() == '/' || path.size() >= kMaxPathLength) return false;
  size_t start = 1;
  while (start <= path.size()) {
    const size_t end = std::min(path.find('/', start), path.size());
    const std::string_view part = path.substr(start, end - start);
    if (part.empty() || part == "." || part == "..") return false;
    for (char c : part)
      if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_' || c == '.')) return false;
    start = end + 1;
  }
  return true;
}

std::optional<int> user_hand(std::string_view path) {
  if (path == "/user/hand/left") return 0;
  if (path == "/user/hand/right") return 1;
  return std::nullopt;
}

std::optional<HandBinding> hand_binding(std::string_view path) {
  constexpr std::array<std::pair<std::string_view, HandInput>, 11> kInputs = {{
      {"/input/palm_ext/pose", HandInput::PalmPose},
      {"/input/grip/pose", HandInput::GripPose},
      {"/input/aim/pose", HandInput::AimPose},
      {"/input/pinch_ext/pose", HandInput::PinchPose},
      {"/input/poke_ext/pose", HandInput::PokePose},
      {"/input/pinch_ext/value", HandInput::PinchValue},
      {"/input/pinch_ext/ready_ext", HandInput::PinchReady},
      {"/input/aim_activate_ext/value", HandInput::AimActivateValue},
      {"/input/aim_activate_ext/ready_ext", HandInput::AimActivateReady},
      {"/input/grasp_ext/value", HandInput::GraspValue},
      {"/input/grasp_ext/ready_ext", HandInput::GraspReady},
  }};
  for (const auto& [prefix, hand] : {std::pair<std::string_view, int>{"/user/hand/left", 0}, {"/user/hand/right", 1}}) {
    if (path.substr(0, prefix.size()) != prefix) continue;
    const std::string_view rest = path.substr(prefix.size());
    for (const auto& [name, input] : kInputs)
      if (rest == name) return HandBinding{hand, input};
  }
  return std::nullopt;
}

}  // namespace hs::shim
