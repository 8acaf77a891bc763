// libFuzzer target for the HoloLens 2 / MRTK CSV importer (docs/IMPORTERS.md#mrtk): any
// byte string must either import or throw hs::InputError; never crash, hang or leak.
#include "handsteady/import.hpp"

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    (void)hs::parse_mrtk(in, "fuzz.csv");
  } catch (const hs::InputError&) {
  }
  return 0;
}
