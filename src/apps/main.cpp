// penumbra: a path tracer for comparing how area lights are sampled.
#include <cstdio>
#include <exception>

#include "apps/commands.h"

int main(int argc, char** argv) {
  CLI::App app{
      "penumbra: a progressive path tracer (CPU/Embree and GPU/OptiX) for comparing direct-lighting\n"
      "strategies for area lights: uniform area sampling versus uniform solid-angle (cone) sampling."};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Help for every subcommand");
  // Errors are one line, like every other error penumbra reports.
  app.failure_message([](const CLI::App*, const CLI::Error& e) {
    return "penumbra: error: " + std::string(e.what()) + " (see --help)\n";
  });
  const pn::Command commands[] = {
      pn::add_render_command(app),
      pn::add_scenes_command(app),
      pn::add_compare_command(app),
      pn::add_converge_command(app),
      pn::add_bench_command(app),
      pn::add_view_command(app),
  };
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    for (const auto& c : commands)
      if (c.sub->parsed()) return c.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra: error: %s\n", e.what());
    return 1;
  }
  return 1;
}
