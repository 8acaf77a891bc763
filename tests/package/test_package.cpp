// The Debian package (cmake/Packaging.cmake) the way a user gets it: built with cpack,
// unpacked into a scratch root (dpkg-deb -x: no root rights, nothing touches /usr) and
// used from there only. The real Khronos loader finds the packaged layer through the
// packaged manifests (explicit and implicit) and the packaged replay runtime; the layer
// and the packaged CLI find the packaged model. No packaged file names the source or
// build tree.
#include "handsteady/model_path.hpp"
#include "handsteady/track.hpp"
#include "handsteady/track_ops.hpp"
#include "test_support.hpp"
#include "xr_test_app.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace hs::xrtest;
using hs::test::slurp;
using hs::test::StderrToFile;

namespace {

int sh(const std::string& cmd) {
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

std::string quoted(const fs::path& p) { return "\"" + p.string() + "\""; }

// Builds the package into dir/out (its Depends and Version fields into dir/depends.txt and
// dir/version.txt) and unpacks it into dir/root; returns the root's /usr
// (CPACK_PACKAGING_INSTALL_PREFIX), canonical as the layer and the CLI see their paths.
fs::path unpack_package(const fs::path& dir) {
  const fs::path out = dir / "out", root = dir / "root";
  const fs::path log = dir / "cpack.log";
  const int rc = sh(quoted(HS_CPACK_COMMAND) + " --config " + quoted(HS_CPACK_CONFIG) + " -G DEB -B " + quoted(out) +
                    " > " + quoted(log) + " 2>&1");
  INFO("cpack output:\n" << slurp(log));
  REQUIRE(rc == 0);
  std::vector<fs::path> debs;
  for (const auto& e : fs::directory_iterator(out))
    if (e.path().extension() == ".deb") debs.push_back(e.path());
  REQUIRE(debs.size() == 1);
  REQUIRE(sh("dpkg-deb -f " + quoted(debs[0]) + " Depends > " + quoted(dir / "depends.txt")) == 0);
  REQUIRE(sh("dpkg-deb -f " + quoted(debs[0]) + " Version > " + quoted(dir / "version.txt")) == 0);
  MESSAGE("package: " << debs[0].filename().string() << ", Depends: " << slurp(dir / "depends.txt"));
  REQUIRE(sh("dpkg-deb -x " + quoted(debs[0]) + " " + quoted(root)) == 0);
  return fs::canonical(root / "usr");
}

// What the package must hold, relative to /usr.
std::vector<fs::path> expected_files() {
  const fs::path lib = fs::path(HS_INSTALL_LIBDIR) / "handsteady";
  const fs::path layers = "share/openxr/1/api_layers";
  std::vector<fs::path> files = {"bin/handsteady",
                                 lib / HS_LAYER_FILE,
                                 lib / HS_RUNTIME_FILE,
                                 layers / "explicit.d/XrApiLayer_handsteady.json",
                                 layers / "implicit.d/XrApiLayer_handsteady.json",
                                 fs::path("share/handsteady/models") / hs::kDefaultModelFile,
                                 "share/handsteady/handsteady_replay_runtime.json"};
#ifdef HS_LAYER_V3_FILE
  files.push_back(lib / HS_LAYER_V3_FILE);
#endif
  return files;
}

// Regular files under `dir` whose bytes contain `needle` (what `grep -rl` lists).
std::vector<fs::path> files_containing(const fs::path& dir, const std::string& needle) {
  std::vector<fs::path> hits;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file() && slurp(e.path()).find(needle) != std::string::npos) hits.push_back(e.path());
  return hits;
}

// Files mapped into this process whose path contains `name` (/proc/self/maps).
std::vector<std::string> mapped(const std::string& name) {
  std::ifstream maps("/proc/self/maps");
  std::vector<std::string> paths;
  for (std::string line; std::getline(maps, line);) {
    const auto slash = line.find('/');
    if (slash != std::string::npos && line.find(name, slash) != std::string::npos) paths.push_back(line.substr(slash));
  }
  return paths;
}

bool all_under(const std::vector<std::string>& paths, const fs::path& dir) {
  return std::all_of(paths.begin(), paths.end(), [&](const std::string& p) { return p.rfind(dir.string() + "/", 0) == 0; });
}

// Runs an app with hand tracking for `frames` frames; returns the mean joint error (m)
// against the clean track of the layer's answers ([0]) and of the raw replay ([1]).
std::array<double, 2> run_errors(App& app, const TrackFiles& f, int frames) {
  const XrPosef kIdentity{{0, 0, 0, 1}, {0, 0, 0}};
  std::array<double, 2> sum{};
  std::array<long, 2> n{};
  for (int i = 0; i < frames; ++i) {
    const XrTime T = app.frame();
    for (XrHandEXT hand : {XR_HAND_LEFT_EXT, XR_HAND_RIGHT_EXT}) {
      const Joints j = app.locate(hand, app.local, T);
      REQUIRE(j.result == XR_SUCCESS);
      if (i < 30) continue;  // the engine's warm-up
      const hs::Pose truth = hs::interpolate_pose(f.clean_series[hand - 1], track_time(f, T));
      accumulate_error(j, kIdentity, truth, sum[0], n[0]);  // asked in LOCAL itself
      accumulate_error(hs::interpolate_pose(f.noisy_series[hand - 1], track_time(f, T)), truth, sum[1], n[1]);
    }
  }
  REQUIRE(n[0] > 0);
  REQUIRE(n[1] > 0);
  return {sum[0] / static_cast<double>(n[0]), sum[1] / static_cast<double>(n[1])};
}

// The loader's and the layer's environment for an app using only the package under usr.
void package_env(const TrackFiles& f, const fs::path& usr) {
  reset_env(f);                      // no build-tree layer path, no system implicit layers
  unset_env("HANDSTEADY_METHOD");    // the layer's default: the shipped model
  set_env("HANDSTEADY_LOG", "info");  // the layer logs the model it loaded
  set_env("HANDSTEADY_WORKER", "lockstep");  // simulated clock: the worker's real-time answers
  set_env("XR_RUNTIME_JSON", (usr / "share/handsteady/handsteady_replay_runtime.json").string());
}

}  // namespace

TEST_CASE("Debian package unpacked into a scratch root: complete, no build paths, the loader loads its layer and model") {
  const fs::path dir = hs::test::temp_dir("package");
  const fs::path usr = unpack_package(dir);

  for (const auto& f : expected_files()) {
    INFO("packaged file: /usr/" << f.string());
    CHECK(fs::is_regular_file(usr / f));
  }
  for (const std::string tree : {HS_SOURCE_DIR, HS_BUILD_DIR}) {
    std::string hits;
    for (const auto& p : files_containing(usr, tree)) hits += " " + p.string();
    INFO("files naming " << tree << ":" << hits);
    CHECK(hits.empty());
  }

  const fs::path model = usr / "share/handsteady/models" / hs::kDefaultModelFile;
  const std::string model_line = "engine stgae: model " + model.string();
  const TrackFiles f = make_tracks("package", 4.0);

  // Explicit manifest: the layer (and the runtime) mapped from the package, with the
  // packaged model, denoising.
  {
    package_env(f, usr);
    set_env("XR_API_LAYER_PATH", (usr / "share/openxr/1/api_layers/explicit.d").string());
    set_env("XR_ENABLE_API_LAYERS", kLayer);
    std::array<double, 2> err{};
    {
      StderrToFile log(dir / "explicit.log");
      App app;
      const auto layers = mapped("libXrApiLayer_handsteady");
      const auto runtimes = mapped("libhandsteady_replay_runtime");
      CHECK(!layers.empty());
      CHECK(!runtimes.empty());
      CHECK(all_under(layers, usr));
      CHECK(all_under(runtimes, usr));
      err = run_errors(app, f, 300);
      app.shutdown();
    }
    const std::string log = slurp(dir / "explicit.log");
    INFO("layer log:\n" << log);
    CHECK(log.find(model_line) != std::string::npos);
    MESSAGE("packaged layer: " << err[0] * 1e3 << " mm, raw " << err[1] * 1e3 << " mm");
    CHECK(err[0] < 0.8 * err[1]);
  }

  // Implicit manifest (XDG_DATA_DIRS = the package's share/): on without any setting, and
  // off with its disable_environment variable. The layer library stays loaded between
  // instances (loader 1.0.20), so its log tells whether this instance went through it.
  for (const bool disabled : {false, true}) {
    package_env(f, usr);
    set_env("XDG_DATA_DIRS", (usr / "share").string());
    if (disabled) set_env("DISABLE_XR_APILAYER_NOVENDOR_handsteady", "1");
    const fs::path file = dir / (disabled ? "implicit_disabled.log" : "implicit.log");
    {
      StderrToFile log(file);
      App app;
      (void)run_errors(app, f, 40);
      app.shutdown();
    }
    const std::string log = slurp(file);
    INFO("disabled: " << disabled << ", layer log:\n" << log);
    CHECK((log.find(model_line) != std::string::npos) == !disabled);
  }

  // The packaged CLI finds the packaged model next to itself.
  {
    const fs::path out = dir / "cli_out.csv";
    REQUIRE(sh("env -u HANDSTEADY_MODEL " + quoted(usr / "bin/handsteady") + " filter --method stgae --in " +
               quoted(f.noisy_csv) + " --out " + quoted(out)) == 0);
    CHECK(hs::read_track_csv(out).meta("filter").value_or("").find(model.string()) != std::string::npos);
  }

  // The packaged CLI reports the package's version (both from CMake's project version).
  {
    std::string version = slurp(dir / "version.txt");
    version.erase(version.find_last_not_of(" \n") + 1);
    REQUIRE(!version.empty());
    REQUIRE(sh(quoted(usr / "bin/handsteady") + " --version > " + quoted(dir / "cli_version.txt")) == 0);
    CHECK(slurp(dir / "cli_version.txt").rfind("handsteady " + version + " (revision ", 0) == 0);
  }
  fs::remove_all(dir);
}
