#pragma once
// The checkout this binary was built from, for records that must name the code behind a
// number or a model (training meta, benchmark reports, --version): a model trained by the
// same command at another commit can differ (docs/TRAINING.md "Reproducibility").

namespace hs {

// The git commit (40 hex digits), followed by "-dirty" when the checkout had changed or
// untracked files (the build folder aside) at build time; "unknown" when it was built
// outside a git checkout. Refreshed at every build (cmake/source_revision.cmake).
const char* source_revision() noexcept;

// The release version, CMake's project(VERSION) (the one the Debian package carries too).
const char* project_version() noexcept;

}  // namespace hs
