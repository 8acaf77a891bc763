#include "handsteady/source_revision.hpp"

#include "handsteady_revision_value.hpp"

namespace hs {

const char* source_revision() noexcept { return HS_SOURCE_REVISION; }

const char* project_version() noexcept { return HS_PROJECT_VERSION; }

}  // namespace hs
