// `penumbra render`: one image, written as EXR (linear) or PNG (sRGB).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "apps/commands.h"
#include "apps/progress.h"
#include "io/image.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {
namespace {

struct RenderArgs {
  std::string scene;
  std::string output;
  std::string variance;
  std::string backend = "auto";
  std::string strategy;
  int spp = 0, width = 0, height = 0, max_depth = -1, rr_depth = 0;
  long long seed = -1;
  int threads = 0;
  float exposure = 0.f;
  bool stats = false;
  std::vector<std::string> sets;
};

std::string default_output(const std::string& scene) {
  return std::filesystem::path(scene).stem().string() + ".png";
}

int run_render(const RenderArgs& a) {
  // Command-line settings are overrides like any --set, validated in one place.
  std::vector<std::string> overrides = a.sets;
  auto set = [&](const char* key, const std::string& v) { overrides.push_back(std::string(key) + "=" + v); };
  if (!a.strategy.empty()) set("render.strategy", "\"" + a.strategy + "\"");
  if (a.spp) set("render.spp", std::to_string(a.spp));
  if (a.width) set("render.width", std::to_string(a.width));
  if (a.height) set("render.height", std::to_string(a.height));
  if (a.max_depth >= 0) set("render.max_depth", std::to_string(a.max_depth));
  if (a.rr_depth) set("render.rr_depth", std::to_string(a.rr_depth));
  if (a.seed >= 0) set("render.seed", std::to_string(a.seed));
  Scene scene = load_scene(a.scene, overrides);

  std::string out = a.output.empty() ? default_output(a.scene) : a.output;
  BackendOptions opts;
  opts.threads = a.threads;
  std::string note;
  std::unique_ptr<Backend> backend = make_backend(a.backend, scene, opts, &note);
  std::fprintf(stderr, "%s\n", note.c_str());

  const RenderSettings& r = scene.render;
  std::fprintf(stderr, "%s: %dx%d, %d spp, strategy %s, max depth %d, seed %u\n", scene.source.c_str(), r.width,
               r.height, r.spp, strategy_name(r.strategy), r.max_depth, r.seed);
  Film film(r.width, r.height);
  ProgressBar bar("rendering");
  backend->render(frame_spec(scene), film, 0, uint32_t(r.spp),
                  [&](uint64_t done, uint64_t total) { bar.update(done, total); });
  double seconds = bar.finish();

  write_image(out, r.width, r.height, film.mean(), a.exposure);
  if (!a.variance.empty()) write_image(a.variance, r.width, r.height, film.variance_of_mean());
  double samples = double(r.width) * r.height * r.spp;
  std::fprintf(stderr, "wrote %s%s%s: %s wall, %.3g samples/s (%.2f Msamples/s)\n", out.c_str(),
               a.variance.empty() ? "" : " and ", a.variance.c_str(), format_duration(seconds).c_str(),
               samples / seconds, samples / seconds * 1e-6);
  if (a.stats) {
    std::fprintf(stderr, "stats: %zu triangles, %zu spheres, %zu lights, %.3f ms per spp\n", scene.triangle_count(),
                 scene.spheres.size(), scene.lights.size(), seconds * 1e3 / r.spp);
  }
  return 0;
}

}  // namespace

Command add_render_command(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  auto* sub = app.add_subcommand("render", "Render a scene to an image file (.exr linear float, .png sRGB)");
  sub->add_option("scene", a->scene, "Built-in scene name (see `penumbra scenes`) or a scene file (.json)")->required();
  sub->add_option("-o,--output", a->output, "Output image, .exr or .png (default: <scene>.png)");
  sub->add_option("--strategy", a->strategy, "Direct-lighting strategy: " + strategy_names() + " (default: the scene's)");
  sub->add_option("--spp", a->spp, "Samples per pixel (default: the scene's)");
  sub->add_option("--width", a->width, "Image width in pixels (default: the scene's)");
  sub->add_option("--height", a->height, "Image height in pixels (default: the scene's)");
  sub->add_option("--seed", a->seed, "Random seed, 0..4294967295 (default: the scene's)");
  sub->add_option("--max-depth", a->max_depth, "Maximum number of bounces (default: the scene's)");
  sub->add_option("--rr-depth", a->rr_depth, "Russian roulette starts at this bounce (default: the scene's)");
  sub->add_option("--backend", a->backend, "cpu, optix, or auto: optix when a GPU and OptiX work, else cpu")
      ->capture_default_str()
      ->check(CLI::IsMember({"cpu", "optix", "auto"}));
  sub->add_option("--set", a->sets, "Override any scene value, e.g. --set light.radius=0.05 --set camera.fov=30")
      ->take_all()
      ->allow_extra_args(false);
  sub->add_option("--threads", a->threads, "CPU threads (default: all)")->check(CLI::Range(0, 4096));
  sub->add_option("--exposure", a->exposure, "PNG exposure in stops (x 2^stops before sRGB)")
      ->capture_default_str()
      ->check(CLI::Range(-64.f, 64.f));
  sub->add_option("--variance", a->variance, "Also write the per-pixel variance of the mean (EXR)");
  sub->add_flag("--stats", a->stats, "Print scene and timing statistics");
  return {sub, [a]() { return run_render(*a); }};
}

}  // namespace pn
