// handsteady: one binary, subcommands registered by cmd_*.cpp.
#include "commands.hpp"

#include "handsteady/error.hpp"
#include "handsteady/source_revision.hpp"

#include <cstdio>
#include <exception>
#include <string>

namespace hs::cli {

static std::vector<CommandSetup>& registry() {
  static std::vector<CommandSetup> r;
  return r;
}
CommandRegistration::CommandRegistration(CommandSetup setup) { registry().push_back(setup); }
const std::vector<CommandSetup>& registered_commands() { return registry(); }

}  // namespace hs::cli

int main(int argc, char** argv) {
  CLI::App app{"HandSteady: steady, ahead-of-time XR hand tracking (Multi-STGAE, classical filters, OpenXR layer)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("handsteady ") + hs::project_version() + " (revision " + hs::source_revision() + ")");
  for (auto setup : hs::cli::registered_commands()) setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const hs::InputError& e) {
    std::fprintf(stderr, "handsteady: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "handsteady: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
