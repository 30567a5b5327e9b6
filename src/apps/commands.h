// Subcommands of the `penumbra` executable. Each registers its options on the
// CLI11 app and returns the function that runs it (exit status).
#pragma once

#include <cmath>
#include <cstdlib>
#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace pn {

// Every floating-point option checks with this: CLI11's Range lets NaN through
// (every comparison with NaN is false), and "inf" parses as a number.
inline CLI::Validator finite_number() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || *end != '\0') return "not a number: " + text;
        if (!std::isfinite(v)) return "must be a finite number, not " + text;
        return "";
      },
      "FINITE");
}

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
