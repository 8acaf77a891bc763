#pragma once
// The .hsm model file (docs/MODEL_FORMAT.md): bytes <-> configuration, weights and
// reference data, every field checked. Independent of the engine: a runnable model
// (hs::load_hsm, stgae_model.hpp) is this plus the engine's net and reference check.
#include "handsteady/stgae_model.hpp"

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace hs {

inline constexpr std::uint32_t kHsmVersion = 1;

// What an .hsm file holds.
struct HsmContents {
  StgaeConfig config;
  StgaeWeights weights;
  StgaeReference reference;
};

// Serialisation checks config/weights/reference shapes (InputError, source "<serialize>").
std::vector<std::uint8_t> serialize_hsm(const StgaeConfig& config, const StgaeWeights& weights,
                                        const StgaeReference& reference);
void save_hsm(const std::filesystem::path& path, const StgaeConfig& config,
              const StgaeWeights& weights, const StgaeReference& reference);

// Parses and checks (magic, version, checksum, config, tensor names/shapes/values,
// reference shape). Any defect -> InputError naming the source (file), the part
// (header/config/tensor name/reference/checksum) and byte offset.
HsmContents read_hsm(std::span<const std::uint8_t> bytes, const std::string& source);
HsmContents read_hsm_file(const std::filesystem::path& path);

// Throws InputError (field "reference") when the reference does not fit the configuration
// (frames = window, sizes frames x N x 3 and horizon x N x 3) or has a non-finite output.
void check_stgae_reference(const StgaeConfig& config, const StgaeReference& reference,
                           const std::string& source = "");

}  // namespace hs
