#pragma once
// Helpers shared by the tests: where fixtures and the optional recorded data live.
#include <doctest/doctest.h>

#include "handsteady/stgae_model.hpp"
#include "handsteady/synth.hpp"
#include "handsteady/track.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

namespace hs::test {

inline std::filesystem::path fixture(const std::string& name) { return std::filesystem::path(HS_FIXTURES) / name; }

// The repository's models/ folder, and the shipped Multi-STGAE model in it.
inline std::filesystem::path models_dir() { return std::filesystem::path(HS_FIXTURES) / ".." / ".." / "models"; }
inline std::shared_ptr<const StgaeModel> shipped_model() { return load_hsm(models_dir() / "handsteady_xr26_causal.hsm"); }

// ../shared/data, or empty when absent (tests then skip with a message).
inline std::filesystem::path shared_data() {
  std::filesystem::path p(HS_SHARED_DATA);
  return std::filesystem::is_directory(p) ? p : std::filesystem::path{};
}

// The Leap tuning subject's first takes (../shared/data/leap/guinevere/s03_*-1.csv; not a
// benchmark test set), sorted, those whose name contains `part` (all when empty).
inline std::vector<std::filesystem::path> leap_tuning_takes(const std::string& part = "") {
  std::vector<std::filesystem::path> takes;
  for (const auto& e : std::filesystem::directory_iterator(shared_data() / "leap" / "guinevere")) {
    const std::string name = e.path().filename().string();
    if (name.starts_with("s03_") && name.ends_with("-1.csv") && name.find(part) != std::string::npos)
      takes.push_back(e.path());
  }
  std::sort(takes.begin(), takes.end());
  return takes;
}

// A whole file's text ("" when it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// This process's stderr (where the layer logs) goes to `file` while the object lives.
class StderrToFile {
 public:
  explicit StderrToFile(const std::filesystem::path& file) : saved_(::dup(STDERR_FILENO)) {
    std::fflush(stderr);
    const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    REQUIRE(fd >= 0);
    ::dup2(fd, STDERR_FILENO);
    ::close(fd);
  }
  ~StderrToFile() {
    std::fflush(stderr);
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
  }
  StderrToFile(const StderrToFile&) = delete;
  StderrToFile& operator=(const StderrToFile&) = delete;

 private:
  int saved_;
};

// p with white noise added to every coordinate, joint-major (the draw order is part of
// each test's seeded sequence).
inline Pose jittered(Pose p, std::mt19937_64& rng, std::normal_distribution<double>& noise) {
  for (int j = 0; j < kJointCount; ++j)
    for (int c = 0; c < 3; ++c) p(j, c) += noise(rng);
  return p;
}

// p with each joint, at probability `share`, shifted by up to `reach` (m) along each axis
// (uniform): the `paper` preset's way of corrupting, a heavy tail of far rows on clean ones.
inline Pose shifted(Pose p, std::mt19937_64& rng, double share, double reach) {
  std::uniform_real_distribution<double> u01(0.0, 1.0), shift(-reach, reach);
  for (int j = 0; j < kJointCount; ++j)
    if (u01(rng) < share)
      for (int c = 0; c < 3; ++c) p(j, c) += shift(rng);
  return p;
}

// Every directory temp_dir made is removed when the test process exits (also those kept
// for the whole run, such as generated fixtures), so repeated runs do not fill /tmp.
// HANDSTEADY_KEEP_TEST_FILES=1 keeps them for a look after a failure.
struct TempDirs {
  std::mutex mutex;
  std::vector<std::filesystem::path> made;
  ~TempDirs() {
    const char* keep = std::getenv("HANDSTEADY_KEEP_TEST_FILES");
    if (keep && std::string(keep) == "1") return;
    std::error_code ec;
    for (const auto& p : made) std::filesystem::remove_all(p, ec);
  }
};

inline std::filesystem::path temp_dir(const std::string& name) {
  static TempDirs dirs;
  auto p = std::filesystem::temp_directory_path() / ("handsteady_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(p);
  const std::lock_guard<std::mutex> lock(dirs.mutex);
  dirs.made.push_back(p);
  return p;
}

// A right hand in smooth synthetic motion (synth_motion: translation, rotation and finger
// curl varying), `seconds` long at `rate_hz`, from `seed`.
inline HandSeries moving_hand(double seconds, double rate_hz, uint64_t seed) {
  SynthMotionParams p;
  p.duration_s = seconds;
  p.rate_hz = rate_hz;
  return synth_motion(p, Hand::Right, seed);
}

// A plausible open right hand (metres): fingers straight along +y, palm in the xy plane,
// wrist at the origin. Straight fingers make bone and offset answers easy to compute.
inline Pose synthetic_hand() {
  Pose p = Pose::Zero();
  auto set = [&](Joint j, double x, double y, double z) { p.row(idx(j)) << x, y, z; };
  set(Joint::Palm, 0, 0.05, 0.002);
  set(Joint::ThumbMetacarpal, 0.02, 0.02, 0.0);
  set(Joint::ThumbProximal, 0.045, 0.045, 0.005);
  set(Joint::ThumbDistal, 0.06, 0.075, 0.008);
  set(Joint::ThumbTip, 0.07, 0.10, 0.01);
  const Joint first[4] = {Joint::IndexMetacarpal, Joint::MiddleMetacarpal, Joint::RingMetacarpal,
                          Joint::LittleMetacarpal};
  for (int f = 0; f < 4; ++f) {
    const double x = 0.025 - 0.017 * f, y0 = 0.09 - 0.006 * std::abs(f - 1), z = 0.001 * f;
    const int j = idx(first[f]);
    p.row(j) << 0.6 * x, 0.025, z;
    p.row(j + 1) << x, y0, z;
    p.row(j + 2) << x, y0 + 0.04, z;
    p.row(j + 3) << x, y0 + 0.065, z;
    p.row(j + 4) << x, y0 + 0.085, z;
  }
  return p;
}

// A hand writing fast: strokes of 1 cm at 4 Hz along x and 6 mm at 5 Hz along y, the hand
// turning by 10 degrees at 1 Hz (rigid: the bones keep their lengths).
inline Pose writing_hand(double t) {
  constexpr double pi = std::numbers::pi;
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.17 * std::sin(2.0 * pi * t), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::RowVector3d shift(0.1 + 0.01 * std::sin(2.0 * pi * 4.0 * t), -0.2 + 0.006 * std::sin(2.0 * pi * 5.0 * t + 1.0),
                                 -0.35);
  return (synthetic_hand() * r.transpose()).rowwise() + shift;
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
