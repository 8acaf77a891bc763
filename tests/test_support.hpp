#pragma once
// Helpers shared by the tests: where fixtures and the optional recorded data live.
#include <doctest/doctest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

namespace hs::test {

inline std::filesystem::path fixture(const std::string& name) { return std::filesystem::path(HS_FIXTURES) / name; }

// ../shared/data, or empty when absent (tests then skip with a message).
inline std::filesystem::path shared_data() {
  std::filesystem::path p(HS_SHARED_DATA);
  return std::filesystem::is_directory(p) ? p : std::filesystem::path{};
}

inline std::filesystem::path temp_dir(const std::string& name) {
  auto p = std::filesystem::temp_directory_path() / ("handsteady_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(p);
  return p;
}

// Runs the handsteady CLI with arguments; returns its exit status.
inline int run_cli(const std::string& args) {
  std::string cmd = std::string("\"") + HS_CLI_PATH + "\" " + args;
  int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

}  // namespace hs::test

#define HS_SKIP_WITHOUT_SHARED_DATA()                                                     \
  do {                                                                                    \
    if (hs::test::shared_data().empty()) {                                                \
      MESSAGE("skipped: ../shared/data is absent (" << HS_SHARED_DATA << ")");           \
      return;                                                                             \
    }                                                                                     \
  } while (0)
