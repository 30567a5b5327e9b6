// penumbra: a path tracer for comparing how area lights are sampled.
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>

#include "apps/commands.h"
#include "apps/exit_status.h"
#include "io/output.h"

namespace {

// Ctrl-C (or SIGTERM) stops any command at once with one line. Outputs are
// written atomically (io/output.h): a write in progress leaves only its
// temporary file, which is removed here, and the previous file stays intact.
extern "C" void on_interrupt(int sig) {
  pn::remove_partial_output();
  const char* msg = sig == SIGINT ? "\npenumbra: interrupted (Ctrl-C): stopped; files already written are complete\n"
                                  : "\npenumbra: terminated: stopped; files already written are complete\n";
  ssize_t ignored = write(STDERR_FILENO, msg, std::strlen(msg));
  (void)ignored;
  _exit(pn::kExitInterrupted);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "penumbra: a progressive path tracer (CPU/Embree and GPU/OptiX) for comparing direct-lighting\n"
      "strategies for area lights: uniform area sampling versus uniform solid-angle (cone) sampling."};
  app.require_subcommand(1);
  app.footer(pn::kExitStatusHelp);
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
  for (const auto& c : commands) c.sub->footer(pn::kExitStatusHelp);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);  // prints help (0) or the one-line failure message
    return rc == 0 ? pn::kExitOk : pn::kExitUsage;
  }
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  try {
    for (const auto& c : commands)
      if (c.sub->parsed()) return c.run();
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr,
                 "penumbra: error: out of memory: an allocation failed that the estimates made before it did not "
                 "foresee\n");
    return pn::kExitError;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra: error: %s\n", e.what());
    return pn::kExitError;
  }
  return pn::kExitError;
}
