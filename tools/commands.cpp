#include "tools/commands.h"

namespace polyhex {

void add_extra_commands(CLI::App& app, CommandOptions& o) {}

int run_extra_commands(const CLI::App& app, const CommandOptions& o) { return 2; }

}  // namespace polyhex
