#pragma once
// The replay runtime's action system, its pure parts: the path syntax, and the inputs of
// XR_EXT_hand_interaction's profile (among them the poses a runtime derives from the
// tracked hand: grip, aim, pinch, poke; where each sits: shim_hand.hpp hand_input_pose).
// Strings in, no handles, no clock, no lock (fuzzed: tests/fuzz/fuzz_replay_paths.cpp).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

namespace hs::shim {

// Not in older SDK headers (the extension has no structures of its own, only paths).
constexpr const char* kHandInteractionExtension = "XR_EXT_hand_interaction";
constexpr uint32_t kHandInteractionSpecVersion = 1;
// Adds `/input/palm_ext/pose` to the profiles (here: the hand interaction profile).
constexpr const char* kPalmPoseExtension = "XR_EXT_palm_pose";
constexpr uint32_t kPalmPoseSpecVersion = 2;
constexpr std::string_view kHandInteractionProfile = "/interaction_profiles/ext/hand_interaction_ext";
// Accepted for suggestions (apps suggest several profiles), never current: no controllers here.
constexpr std::string_view kSimpleControllerProfile = "/interaction_profiles/khr/simple_controller";

// A well-formed path (the spec's "Path names"): starts with '/', components of
// [a-z0-9-_.] that are not "." or "..", no empty component, no trailing '/', shorter than
// XR_MAX_PATH_LENGTH.
constexpr std::size_t kMaxPathLength = 256;
bool well_formed_path(std::string_view path);

// The hand a top-level user path names: 0 left, 1 right.
std::optional<int> user_hand(std::string_view path);

enum class HandInput { GripPose, AimPose, PinchPose, PokePose, PalmPose, PinchValue, PinchReady, AimActivateValue,
                       AimActivateReady, GraspValue, GraspReady };
struct HandBinding {
  int hand;  // 0 left, 1 right
  HandInput input;
};
// A binding path of the hand interaction profile ("/user/hand/left/input/pinch_ext/pose"; the
// palm's only with XR_EXT_palm_pose, which the caller checks); nullopt for any other path.
std::optional<HandBinding> hand_binding(std::string_view path);
inline bool is_pose(HandInput i) {
  return i == HandInput::GripPose || i == HandInput::AimPose || i == HandInput::PinchPose || i == HandInput::PokePose ||
         i == HandInput::PalmPose;
}

}  // namespace hs::shim
