#pragma once
// Where the shipped Multi-STGAE model is found when no model file is given.
// Order: $HANDSTEADY_MODEL (when set, it is the only candidate: a user who names a file
// means that file); else <anchor>/<relative>/handsteady_xr26_causal.hsm for each installed
// location. No build-time path is compiled in: build-tree binaries find the source tree's
// models/ through a link at the installed relative place (models/CMakeLists.txt).
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace hs {

inline constexpr std::string_view kDefaultModelFile = "handsteady_xr26_causal.hsm";  // Multi-STGAE
inline constexpr std::string_view kDgnModelFile = "handsteady_xr26_dgn.hsm";
inline constexpr std::string_view kStgaeModelFile = "handsteady_xr26_stgae.hsm";  // denoise-only STGAE
inline constexpr std::string_view kModelEnvVar = "HANDSTEADY_MODEL";

struct ModelLookup {
  std::filesystem::path found;                // empty when no candidate exists
  std::vector<std::filesystem::path> tried;   // every candidate, in order
  bool from_env = false;                      // the candidate came from $HANDSTEADY_MODEL
  // "not found; tried: a, b, c" style description of the candidates.
  std::string describe_tried() const;
};

// Candidates: env, else each installed_dirs[i]/file.
ModelLookup lookup_default_model(const std::vector<std::filesystem::path>& installed_dirs,
                                 std::string_view file = kDefaultModelFile);

// Folder of the running executable (/proc/self/exe), empty when unknown.
std::filesystem::path executable_dir();

// For programs installed in <prefix>/bin: <exe_dir>/../share/handsteady/models.
std::filesystem::path installed_models_dir_for_executable();

// The CLI's default model. Throws InputError (field "--model") naming every path tried
// when none exists.
std::filesystem::path default_model_path(std::string_view file = kDefaultModelFile);

}  // namespace hs
