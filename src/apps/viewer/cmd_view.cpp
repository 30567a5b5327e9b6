// `penumbra view`: registered in every build, so that a penumbra built without
// GLFW/OpenGL/Dear ImGui says so in one line instead of "unknown subcommand".
#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>

#include "apps/commands.h"
#include "apps/options.h"
#include "apps/viewer/viewer.h"
#include "scene/scene.h"

namespace pn {
namespace {

struct ViewArgs {
  viewer::ViewerOptions o;
  IntegratorOptions integrator;  // --strategy, --mis, ..., --max-depth, --seed
};

int run_view(ViewArgs a) {
  // Like `render`, command-line settings are scene overrides, validated with the scene.
  append_integrator_overrides(a.integrator, &a.o.sets);
#if PENUMBRA_HAVE_VIEWER
  return viewer::run_viewer(a.o);
#else
  throw std::runtime_error(
      "this penumbra was built without the viewer (GLFW 3, OpenGL and Dear ImGui were not found when it was "
      "configured: run scripts/install-deps.sh and reconfigure); use `penumbra render` to render to a file");
#endif
}

}  // namespace

Command add_view_command(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  auto* sub = app.add_subcommand(
      "view", "Interactive viewer: navigate a scene, watch the strategies converge, split-screen comparison");
  sub->add_option("scene", a->o.scene, "Built-in scene name (see `penumbra scenes`) or a scene file (.json)")
      ->required();
  add_backend_options(sub, &a->o.backend, &a->o.backend_options, /*gpus=*/false);
  add_set_option(sub, &a->o.sets);
  // The window's size (at least 16 pixels, room for the panel); the image is --scale times it.
  add_size_options(sub, &a->o.width, &a->o.height, "the scene's, fitted to 1280x720; the window, --scale times it");
  sub->get_option("--width")->check(CLI::Range(16, 16384));
  sub->get_option("--height")->check(CLI::Range(16, 16384));
  sub->add_option("--scale", a->o.scale,
                  "Resolution scale: image pixels per window pixel (default 1; on the CPU at most ~640x360 pixels)")
      ->check(finite_number())
      ->check(CLI::Range(0.05f, 4.f));
  add_integrator_options(sub, &a->integrator);
  sub->add_option("--spp-per-frame", a->o.spp_per_frame, "Samples per pixel added each frame")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  sub->add_option("--exposure", a->o.exposure, "Display exposure in stops")
      ->capture_default_str()
      ->check(finite_number())
      ->check(CLI::Range(-64.f, 64.f));
  sub->add_option("--split", a->o.split, "Start in split screen: LEFT,RIGHT strategies, e.g. area,solid-angle")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            return std::count(v.begin(), v.end(), ',') == 1 ? "" : "expected LEFT,RIGHT (e.g. area,solid-angle)";
          },
          ""))
      ->check(strategy_names_check());
  sub->add_flag("--equal-time", a->o.equal_time, "Split screen at equal time instead of equal samples per pixel");
  sub->add_option("--display", a->o.display,
                  "How the image reaches the screen: auto (CUDA-OpenGL interop with the OptiX backend where it works, "
                  "else host upload), interop (or fail), host")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "interop", "host"}));
  sub->add_flag("--hide-panel", a->o.hide_panel, "Start with the control panel hidden (Tab shows it)");
  sub->add_option("--frames", a->o.frames, "Render this many frames, print the frame rate, and exit")
      ->check(CLI::Range(1, 100000000));
  sub->add_flag("--headless", a->o.headless,
                "No window and no display server: the same frames drawn into an offscreen OpenGL framebuffer of an "
                "EGL context (an NVIDIA GPU's, with interop; else Mesa's surfaceless), finished with glFinish; needs "
                "--frames or a --camera-path that quits. Size: --width/--height, default the scene's resolution");
  sub->add_option("--screenshot", a->o.screenshot,
                  "Image (.png or .exr) written after --frames frames, or when the window is closed");
  sub->add_option("--camera-path", a->o.camera_path,
                  "Replay a JSON list of timed actions (camera moves, settings, screenshots): docs/viewer.md");
  return {sub, [a]() { return run_view(*a); }};
}

}  // namespace pn
