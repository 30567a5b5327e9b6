// `penumbra render`: one image, written as EXR (linear) or PNG (sRGB).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "apps/commands.h"
#include "apps/exit_status.h"
#include "apps/options.h"
#include "apps/progress.h"
#include "io/image.h"
#include "io/output.h"
#include "render/backend.h"
#include "backends/denoise.h"
#include "backends/make_backend.h"
#include "io/host_memory.h"
#include "render/resources.h"
#include "scene/scene.h"

namespace pn {
namespace {

struct RenderArgs {
  std::string scene;
  std::string output;
  std::string variance;
  std::string backend = "auto";
  BackendOptions backend_options;  // --threads, --gpus, --wavefront, --traversal, --tune
  IntegratorOptions integrator;
  // kUnset: not given on the command line, keep the scene's value.
  static constexpr long long kUnset = std::numeric_limits<long long>::min();
  long long spp = kUnset, width = kUnset, height = kUnset, rr_depth = kUnset;
  float exposure = 0.f;
  std::string exr_compression = "zip";
  bool stats = false;
  bool denoise = false;  // also <name>_denoised.<ext>
  DenoiseArgs denoiser;
  bool aov = false;      // also <name>_albedo.exr and <name>_normal.exr (the denoiser's guides)
  std::vector<std::string> sets;
};

std::string default_output(const std::string& scene) {
  return std::filesystem::path(scene).stem().string() + ".png";
}

// "out/x.png" -> "out/x_denoised.png" (suffix "_denoised"), with another extension if `ext` is given.
std::string sibling_output(const std::string& out, const std::string& suffix, const std::string& ext = "") {
  std::filesystem::path p(out);
  const std::string name = p.stem().string() + suffix + (ext.empty() ? p.extension().string() : ext);
  return (p.parent_path() / name).string();
}

// A render split across devices: each device's samples and times.
void print_device_stats(const RenderStats& st, double pixels) {
  for (const DeviceTiming& d : st.devices) {
    const double ms = d.gpu_ms > 0 ? d.gpu_ms : d.wall_ms;
    std::fprintf(stderr, "stats: %s: samples [%u, %u), %.3f ms wall", d.device.c_str(), d.first_sample,
                 d.first_sample + d.count, d.wall_ms);
    if (d.gpu_ms > 0) std::fprintf(stderr, ", %.3f ms GPU", d.gpu_ms);
    std::fprintf(stderr, ", %.2f Msamples/s\n", ms > 0 ? pixels * d.count / (ms * 1e3) : 0.0);
  }
}

// GPU backends: per-launch times from CUDA events, and rays per second; over
// several GPUs, GPU time is summed over them and the rates are per GPU.
void print_launch_stats(const RenderStats& st, double pixels) {
  if (st.launches.empty()) return;
  std::vector<double> trace, acc;
  double gpu_ms = 0, samples = 0;
  for (const LaunchTiming& l : st.launches) {
    trace.push_back(l.trace_ms);
    acc.push_back(l.accumulate_ms);
    gpu_ms += double(l.trace_ms) + l.accumulate_ms;
    samples += pixels * l.spp;
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  };
  std::fprintf(stderr,
               "stats: %zu GPU launches of %u spp: median %.3f ms path tracing + %.3f ms accumulation per launch; "
               "%.3f ms GPU total, %.2f Msamples/s%s",
               st.launches.size(), st.launches.front().spp, median(trace), median(acc), gpu_ms,
               gpu_ms > 0 ? samples / (gpu_ms * 1e3) : 0.0, st.devices.size() > 1 ? " per GPU" : "");
  if (st.rays && gpu_ms > 0)
    std::fprintf(stderr, ", %.3g rays (%.2f Grays/s%s)", double(st.rays), double(st.rays) / (gpu_ms * 1e6),
                 st.devices.size() > 1 ? " per GPU" : "");
  std::fprintf(stderr, "\n");
  if (st.launches_wall_ms > 0)
    std::fprintf(stderr, "stats: wall (host clock): %.3f ms from the first launch until the GPU finished the last "
                 "(%.3f ms a launch), then %.1f ms copying the film to the host\n",
                 st.launches_wall_ms, st.launches_wall_ms / double(st.launches.size()), st.readback_ms);
}

int run_render(const RenderArgs& a) {
  // Outputs first: a typo in a folder name is found before the render, not after.
  const std::string out = a.output.empty() ? default_output(a.scene) : a.output;
  check_image_path(out);
  check_output_file(out, "-o");
  std::vector<std::pair<std::string, std::string>> outputs = {{"-o", out}};
  if (!a.variance.empty()) {
    check_image_path(a.variance);
    check_output_file(a.variance, "--variance");
    outputs.push_back({"--variance", a.variance});
  }
  const std::string denoised = sibling_output(out, "_denoised");
  const std::string albedo = sibling_output(out, "_albedo", ".exr"), normal = sibling_output(out, "_normal", ".exr");
  DenoiseOptions denoise;
  std::string oidn_found;
  if (a.denoise) {
    denoise = denoise_options(a.denoiser, &oidn_found);
    check_denoise_choice("--denoise", a.backend, denoise);
    check_output_file(denoised, "--denoise");
    outputs.push_back({"--denoise", denoised});
  }
  if (a.aov) {
    check_output_file(albedo, "--aov");
    check_output_file(normal, "--aov");
    outputs.push_back({"--aov", albedo});
    outputs.push_back({"--aov", normal});
  }
  check_distinct_outputs(outputs);

  // Command-line settings are overrides like any --set, validated in one place.
  std::vector<std::string> overrides = a.sets;
  auto set = [&](const char* key, const std::string& v) { overrides.push_back(std::string(key) + "=" + v); };
  append_integrator_overrides(a.integrator, &overrides);
  auto set_int = [&](const char* key, long long v) {
    if (v != RenderArgs::kUnset) set(key, std::to_string(v));
  };
  set_int("render.spp", a.spp);
  set_int("render.width", a.width);
  set_int("render.height", a.height);
  set_int("render.rr_depth", a.rr_depth);
  Scene scene = load_scene(a.scene, overrides);
  for (const std::string& w : scene.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());

  const RenderSettings& r = scene.render;
  check_memory(scene.source + ": rendering " + std::to_string(r.width) + "x" + std::to_string(r.height),
               {{"film", film_bytes(r.width, r.height)},
                {"writing the image", image_write_bytes(r.width, r.height)},
                {"acceleration structures", a.backend == "optix" ? 0 : cpu_backend_bytes(scene)}});
  std::string note;
  std::unique_ptr<Backend> backend = make_backend(a.backend, scene, a.backend_options, &note);
  if (a.denoise) check_denoise_backend("--denoise", *backend, denoise, note);  // one line: the note goes into it
  std::fprintf(stderr, "%s\n", note.c_str());

  const IntegratorSettings& in = r.integrator;
  std::fprintf(stderr, "%s: %dx%d, %d spp, strategy %s, MIS %s, light selection %s, max depth %d, seed %u\n",
               scene.source.c_str(), r.width, r.height, r.spp, strategy_name(in.strategy), mis_name(in.mis),
               light_selection_label(in.light_selection, in.restir).c_str(), in.max_depth, r.seed);
  Film film(r.width, r.height);
  ProgressBar bar("rendering");
  backend->render(frame_spec(scene), film, 0, uint32_t(r.spp),
                  [&](uint64_t done, uint64_t total) { bar.update(done, total); });
  const double render_seconds = bar.finish();
  const RenderStats stats = backend->last_render_stats();

  // The image is written even when samples were dropped: a finished render is never thrown away.
  ExrOptions exr;
  exr.compression = a.exr_compression == "none" ? ExrCompression::None : ExrCompression::Zip;
  std::fprintf(stderr, "writing %s\n", out.c_str());
  write_image(out, r.width, r.height, film.mean(), a.exposure, exr);
  if (!a.variance.empty()) {
    std::fprintf(stderr, "writing %s\n", a.variance.c_str());
    write_image(a.variance, r.width, r.height, film.variance_of_mean(), 0.f, exr);
  }
  if (a.denoise || a.aov) {
    const FrameSpec frame = frame_spec(scene);
    DenoisedImage d;
    if (a.denoise) {
      d = denoise_render(*backend, frame, film.mean(), denoise);
      release_denoisers();  // its GPU memory, before the process ends
      if (d.repaired)
        std::fprintf(stderr, "warning: %zu values of the image were not finite: 0 before denoising\n", d.repaired);
      std::fprintf(stderr, "denoised: guides %.1f ms (%u rays a pixel), %s%s %.1f ms; writing %s\n", d.guide_ms,
                   kGuideSamples, d.how.c_str(),
                   denoise.denoiser == DenoiserKind::Oidn ? (" (library from " + oidn_found + ")").c_str() : "",
                   d.denoise_ms, denoised.c_str());
      write_image(denoised, r.width, r.height, d.rgb, a.exposure, exr);
    } else {
      d.guides = backend->render_guides(frame, kGuideSamples);
    }
    if (a.aov) {
      std::fprintf(stderr, "writing %s and %s\n", albedo.c_str(), normal.c_str());
      write_image(albedo, r.width, r.height, d.guides.albedo, 0.f, exr);
      write_image(normal, r.width, r.height, d.guides.normal, 0.f, exr);
    }
  }
  const double seconds = bar.elapsed();  // rendering and writing
  double samples = double(r.width) * r.height * r.spp;
  std::fprintf(stderr, "wrote %s%s%s: %s wall (%s writing), %.3g samples/s (%.2f Msamples/s)\n", out.c_str(),
               a.variance.empty() ? "" : " and ", a.variance.c_str(), format_duration(seconds).c_str(),
               format_duration(seconds - render_seconds).c_str(), samples / render_seconds,
               samples / render_seconds * 1e-6);
  if (a.stats) {
    std::fprintf(stderr, "stats: %zu triangles, %zu spheres, %zu lights, %.3f ms per spp\n", scene.triangle_count(),
                 scene.spheres.size(), scene.lights.size(), render_seconds * 1e3 / r.spp);
    const LightBvh& bvh = scene.light_bvh;
    std::fprintf(stderr, "stats: light BVH: %u lights, %zu nodes, depth %u, %.2f MiB, built in %.2f ms\n", bvh.lights,
                 bvh.nodes.size(), bvh.depth, double(bvh.bytes()) / (1024.0 * 1024.0), bvh.build_ms);
    print_device_stats(stats, double(r.width) * r.height);
    print_launch_stats(stats, double(r.width) * r.height);
  }
  if (stats.nonfinite > 0) {
    std::fprintf(stderr, "warning: %s: %s; %s was written (exit status %d)\n", scene.source.c_str(),
                 describe_nonfinite(stats).c_str(), out.c_str(), int(kExitNonFinite));
    return kExitNonFinite;
  }
  return kExitOk;
}

}  // namespace

Command add_render_command(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  auto* sub = app.add_subcommand("render", "Render a scene to an image file (.exr linear float, .png sRGB)");
  sub->add_option("scene", a->scene, "Built-in scene name (see `penumbra scenes`) or a scene file (.json)")->required();
  sub->add_option("-o,--output", a->output, "Output image, .exr or .png (default: <scene>.png)")
      ->check(image_path_check());
  add_integrator_options(sub, &a->integrator);
  // Checked as the scene checks its render block (render.spp, ...): a wrong value is a usage error.
  sub->add_option("--spp", a->spp, "Samples per pixel (default: the scene's)")->check(render_setting("spp"));
  add_size_options(sub, &a->width, &a->height, "the scene's");
  sub->add_option("--rr-depth", a->rr_depth, "Russian roulette starts at this bounce (default: the scene's)")
      ->check(render_setting("rr_depth"));
  add_backend_options(sub, &a->backend, &a->backend_options, /*gpus=*/true);
  add_set_option(sub, &a->sets);
  sub->add_option("--exposure", a->exposure, "PNG exposure in stops (x 2^stops before sRGB)")
      ->capture_default_str()
      ->check(finite_number())
      ->check(CLI::Range(-64.f, 64.f));
  sub->add_option("--variance", a->variance, "Also write the per-pixel variance of the mean (EXR)")
      ->check(image_path_check());
  sub->add_option("--exr-compression", a->exr_compression,
                  "EXR files: zip (lossless, its blocks compressed on every core) or none (larger, written fastest)")
      ->capture_default_str()
      ->check(CLI::IsMember({"zip", "none"}));
  sub->add_flag("--stats", a->stats, "Print scene and timing statistics");
  sub->add_flag("--denoise", a->denoise,
                "Also write <output>_denoised.<ext>: denoised with albedo and normal guides (--denoiser: Intel Open "
                "Image Denoise by default, on every backend)");
  add_denoise_options(sub, &a->denoiser);
  sub->add_flag("--aov", a->aov, "Also write the denoiser's guides, <output>_albedo.exr and <output>_normal.exr");
  return {sub, [a]() { return run_render(*a); }};
}

}  // namespace pn
