// libFuzzer target for the track CSV reader (docs/TRACK_FORMAT.md): any byte string must
// either parse or throw hs::InputError; never crash, hang or leak.
#include "handsteady/track.hpp"

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    (void)hs::parse_track_csv(in, "fuzz.csv");
  } catch (const hs::InputError&) {
  }
  return 0;
}
