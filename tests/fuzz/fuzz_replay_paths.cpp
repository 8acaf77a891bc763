// libFuzzer target for the replay runtime's path parsing (runtime_shim/src/shim_actions.hpp):
// the strings an app hands to xrStringToPath and, as binding paths, to
// xrSuggestInteractionProfileBindings. The input is one path. Checked: a path the hand
// interaction profile binds, or a hand's user path, is well formed; a well-formed path
// starts with '/', has no empty, "." or ".." component and no character outside
// [a-z0-9-_./]; never a crash, a hang or a read out of bounds.
#include "shim_actions.hpp"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view path(reinterpret_cast<const char*>(data), size);
  const bool formed = hs::shim::well_formed_path(path);
  if ((hs::shim::hand_binding(path) || hs::shim::user_hand(path)) && !formed) __builtin_trap();
  if (!formed) return 0;
  if (path.front() != '/' || path.back() == '/' || path.find("//") != std::string_view::npos ||
      path.find("/./") != std::string_view::npos || path.find("/../") != std::string_view::npos ||
      path.size() >= hs::shim::kMaxPathLength)
    __builtin_trap();
  for (char c : path)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_' || c == '.' || c == '/'))
      __builtin_trap();
  return 0;
}
