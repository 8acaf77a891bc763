// libFuzzer target for the FPHA skeleton.txt importer (docs/IMPORTERS.md#fpha): any byte
// string must either import or throw hs::InputError; never crash, hang or leak.
#include "handsteady/import.hpp"

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    (void)hs::parse_fpha(in, "fuzz/skeleton.txt");
  } catch (const hs::InputError&) {
  }
  return 0;
}
