// The `gradphoton` subcommands, one file per group: render.cpp (render, methods), images.cpp
// (diff, info, reconstruct, merge), bench.cpp (bench, bench-photons, bench-reconstruct);
// main.cpp wires them. Each add_*_commands registers its subcommands and their options on the
// app and returns, for each, how to run it once the command line is parsed.
#pragma once

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace gp::cli {

struct Command {
  CLI::App* app;            // the subcommand, given when the command line names it
  std::function<int()> run;  // its work; the exit status (exceptions: main prints them)
};

std::vector<Command> add_render_commands(CLI::App& app);
std::vector<Command> add_image_commands(CLI::App& app);
std::vector<Command> add_bench_commands(CLI::App& app);

// EXR headers: the run's record (distributed/run_info.h).
using Attributes = std::map<std::string, std::string>;

inline void make_parent_dirs(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
}

inline void print_warnings(const Scene& scene) {
  for (const auto& line : scene.warnings.summary()) fmt::print(stderr, "warning: {}\n", line);
}

}  // namespace gp::cli
