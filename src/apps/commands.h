// Subcommands of the `penumbra` executable. Each registers its options on the
// CLI11 app and returns the function that runs it (exit status).
#pragma once

#include <functional>

#include <CLI/CLI.hpp>

namespace pn {

struct Command {
  CLI::App* sub;
  std::function<int()> run;
};

Command add_render_command(CLI::App& app);
Command add_scenes_command(CLI::App& app);
Command add_compare_command(CLI::App& app);
Command add_converge_command(CLI::App& app);
Command add_bench_command(CLI::App& app);
Command add_view_command(CLI::App& app);  // apps/viewer/cmd_view.cpp

}  // namespace pn
