// libFuzzer target for the BVH importer (docs/IMPORTERS.md#bvh): the parser, then, for
// a hierarchy with the ManipNet joint names, forward kinematics and the mapping to XR
// joints. Any byte string must either import or throw hs::InputError; never crash, hang
// or leak.
#include "handsteady/import.hpp"

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const hs::BvhData bvh = hs::parse_bvh(in, "fuzz.bvh");
    hs::BvhImportOptions options;
    options.hand = hs::Hand::Right;  // the file name cannot say
    (void)hs::bvh_to_track(bvh, "fuzz.bvh", options);
  } catch (const hs::InputError&) {
  }
  return 0;
}
