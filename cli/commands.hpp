#pragma once
// Subcommands register themselves: each cmd_<name>.cpp defines a static
// CommandRegistration that adds its CLI11 subcommand and callback.
#include <CLI/CLI.hpp>

#include <functional>
#include <vector>

namespace hs::cli {

using CommandSetup = void (*)(CLI::App& app);

struct CommandRegistration {
  explicit CommandRegistration(CommandSetup setup);
};

const std::vector<CommandSetup>& registered_commands();

}  // namespace hs::cli
