// libFuzzer target for the .hsm loader: any byte string must either load or throw
// hs::InputError; never crash, hang or leak. The first input of a run is replaced by a
// valid small model (when the corpus is empty) so the fuzzer starts from real structure.
#include "handsteady/hsm_format.hpp"
#include "handsteady/stgae_model.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace {
const std::vector<std::uint8_t>& seed_model() {
  static const std::vector<std::uint8_t> bytes = [] {
    hs::StgaeConfig c;
    c.window = 3;
    c.horizon = 1;
    c.encoder_channels = {6, 4};
    c.denoise_decoder_channels = {4, 3};
    c.predict_decoder_channels = {4, 3};
    c.temporal_kernel = 3;
    const auto w = hs::random_stgae_weights(c, 1);
    return hs::serialize_hsm(c, w, hs::make_stgae_reference(c, w, hs::synthetic_hand_input(c, c.window, 1)));
  }();
  return bytes;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::span<const std::uint8_t> in(data, size);
  if (size == 0) in = seed_model();
  try {
    (void)hs::parse_hsm(in, "fuzz.hsm");
  } catch (const hs::InputError&) {
  }
  return 0;
}

// Mutations that keep the checksum valid, so the fuzzer reaches the parser behind it.
extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);
extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size, std::size_t max_size,
                                               unsigned int /*seed*/) {
  if (size == 0 && max_size >= seed_model().size()) {
    std::copy(seed_model().begin(), seed_model().end(), data);
    return seed_model().size();
  }
  size = LLVMFuzzerMutate(data, size, max_size);
  if (size > 8 + 8) {
    std::uint64_t h = 0xcbf29ce484222325ULL;
    for (std::size_t i = 0; i + 8 < size; ++i) h = (h ^ data[i]) * 0x100000001b3ULL;
    for (int i = 0; i < 8; ++i) data[size - 8 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(h >> (8 * i));
  }
  return size;
}
