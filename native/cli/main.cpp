// The `gradphoton` command: its subcommands (commands.h; one file per group) wired into one
// CLI11 app. Argument parsing by CLI11; any error a command throws is one line on stderr.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "cli/commands.h"

int main(int argc, char** argv) {
  using namespace gp::cli;
  CLI::App app{"gradphoton: a physically based renderer for caustics, glass and dispersion"};
  app.set_version_flag("--version", GRADPHOTON_VERSION);
  app.require_subcommand(1);
  std::vector<Command> commands;
  for (auto* add : {add_render_commands, add_image_commands, add_bench_commands})
    for (Command& c : add(app)) commands.push_back(std::move(c));
  CLI11_PARSE(app, argc, argv);
  try {
    for (const Command& c : commands)
      if (*c.app) return c.run();
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
  return 0;
}
