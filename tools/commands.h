/// @file commands.h
/// @brief CLI command modules. Each `tools/*.cpp` file that provides subcommands registers a module
/// with a static registrar; `main` (tools/polyhex.cpp) adds every module's subcommands and runs the
/// chosen one. A new command is a new file, no edit elsewhere:
///
/// @code
///   const bool registered = polyhex::register_commands([](CLI::App& app, std::vector<polyhex::Command>& out) {
///     auto opts = std::make_shared<MyOptions>();
///     CLI::App* c = app.add_subcommand("mine", "what it does");
///     c->add_option("--x", opts->x, "...");
///     out.push_back({c, [opts] { return run_mine(*opts); }});
///   });
/// @endcode
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <vector>

namespace polyhex {

/// One subcommand and the function that runs it (returns the exit code). Global flags that a command
/// needs (`-v`) are in CommandEnv.
struct Command {
  CLI::App* sub = nullptr;
  std::function<int()> run;
};

/// Options of the top-level app, filled before a command runs.
struct CommandEnv {
  int verbosity = 0;
};
CommandEnv& command_env();

using CommandModule = std::function<void(CLI::App& app, std::vector<Command>& out)>;
/// Registers a module (static registration; order of registration = order in --help).
bool register_commands(CommandModule module);
/// Every registered module.
const std::vector<CommandModule>& command_modules();

}  // namespace polyhex
