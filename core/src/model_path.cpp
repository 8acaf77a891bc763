#include "handsteady/model_path.hpp"

#include "handsteady/error.hpp"

#include <cstdlib>
#include <system_error>

namespace hs {
namespace {

bool is_file(const std::filesystem::path& p) {
  std::error_code ec;
  return std::filesystem::is_regular_file(p, ec);
}

}  // namespace

std::string ModelLookup::describe_tried() const {
  std::string s;
  for (const auto& p : tried) {
    if (!s.empty()) s += ", ";
    s += p.string();
  }
  return s.empty() ? std::string("(no candidate)") : s;
}

ModelLookup lookup_default_model(const std::vector<std::filesystem::path>& installed_dirs, std::string_view file) {
  ModelLookup r;
  const char* env = std::getenv(std::string(kModelEnvVar).c_str());
  if (env && *env) {
    r.from_env = true;
    r.tried.emplace_back(env);
    if (is_file(r.tried.back())) r.found = r.tried.back();
    return r;
  }
  for (const auto& d : installed_dirs) {
    if (!d.empty()) r.tried.push_back((d / file).lexically_normal());
  }
  for (const auto& p : r.tried) {
    if (is_file(p)) {
      r.found = p;
      break;
    }
  }
  return r;
}

std::filesystem::path executable_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path{} : exe.parent_path();
}

std::filesystem::path installed_models_dir_for_executable() {
  const auto dir = executable_dir();
  return dir.empty() ? dir : dir / ".." / "share" / "handsteady" / "models";
}

std::filesystem::path default_model_path(std::string_view file) {
  const ModelLookup r = lookup_default_model({installed_models_dir_for_executable()}, file);
  if (!r.found.empty()) return r.found;
  const std::string what = r.from_env ? std::string("the model named by ") + std::string(kModelEnvVar) +
                                            " does not exist: " + r.describe_tried()
                                      : "no model given and the shipped model " + std::string(file) +
                                            " was not found (give --model FILE.hsm or set " +
                                            std::string(kModelEnvVar) + "); tried: " + r.describe_tried();
  throw InputError({"", 0, "--model"}, what);
}

}  // namespace hs
