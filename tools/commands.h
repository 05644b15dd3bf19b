/// @file commands.h
/// @brief The CLI commands that call stage functions directly: `check` (the quality node alone on a mesh
/// file) and `shapes` (write a built-in shape).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

namespace polyhex {

struct CommandOptions {
  CLI::App* check = nullptr;
  std::string check_mesh, check_surface;
  bool check_json = false;
  int check_samples = 100000;
  CLI::App* shapes = nullptr;
  std::string shape_name, shape_out;
  int shape_resolution = 64;
};

void add_extra_commands(CLI::App& app, CommandOptions& o);
/// \return the exit code
int run_extra_commands(const CLI::App& app, const CommandOptions& o);

}  // namespace polyhex
