#include "apps/options.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "core/integrator.h"
#include "io/image.h"
#include "render/backend.h"
#include "backends/denoise.h"
#include "render/gpu_tuning.h"
#include "scene/scene.h"

namespace pn {

CLI::Validator render_setting(const std::string& key, bool name) {
  return CLI::Validator(
      [key, name](std::string& text) -> std::string {
        // The text as JSON: a name quoted; an integer as the option stores it (CLI11 reads "+4" and "08" too);
        // else as JSON reads it, and the scene says what it expected ("nan", "4.5" for --spp).
        std::string value = nlohmann::json(text).dump();
        if (!name) {
          char* end = nullptr;
          errno = 0;
          const long long i = std::strtoll(text.c_str(), &end, 10);
          value = !text.empty() && *end == '\0' && errno == 0 ? std::to_string(i) : text;
        }
        nlohmann::json doc = nlohmann::json::object();
        try {
          apply_override(doc, "render." + key + "=" + value, "option");
          CameraDesc camera;
          RenderSettings render;
          parse_frame_settings(doc, "option", &camera, &render);
        } catch (const SceneError& e) {
          // "option: render.spp: must be in [1, 16777216] (got 0)": CLI11 puts "--spp: " before the rest.
          const std::string why = e.what();
          return why.substr(why.find(": ") + 2);
        }
        return std::string();
      },
      "");
}

namespace {

CLI::Validator known_names(const std::string& what, std::function<bool(const std::string&)> known,
                           const std::string& names) {
  return CLI::Validator(
      [what, known, names](std::string& text) -> std::string {
        std::stringstream list(text);
        for (std::string item; std::getline(list, item, ',');)
          if (!item.empty() && !known(item))
            return "unknown " + what + " '" + item + "' (expected one of: " + names + ")";
        return std::string();
      },
      "");
}

}  // namespace

CLI::Validator strategy_names_check() {
  return known_names("strategy", [](const std::string& s) { Strategy x; return find_strategy(s, &x); },
                     strategy_names());
}

CLI::Validator mis_names_check() {
  return known_names("MIS mode", [](const std::string& s) { Mis x; return find_mis(s, &x); }, mis_names());
}

CLI::Validator light_selection_names_check(bool restir) {
  std::string names;
  for (int i = 0; i < kNumLightSelections; ++i)
    if (restir || LightSelection(i) != LightSelection::Restir)
      names += std::string(names.empty() ? "" : ", ") + light_selection_name(LightSelection(i));
  return known_names(
      "light selection",
      [restir](const std::string& s) {
        LightSelection x;
        return find_light_selection(s, &x) && (restir || x != LightSelection::Restir);
      },
      names);
}

CLI::Validator image_path_check() {
  return CLI::Validator(
      [](std::string& path) -> std::string {
        try {
          check_image_path(path);
        } catch (const std::runtime_error& e) {
          return e.what();
        }
        return std::string();
      },
      "");
}

std::string mis_help() {
  std::string out;
  for (int i = 0; i < kNumMisModes; ++i)
    out += std::string(i ? "; " : "") + mis_name(Mis(i)) + ": " + mis_description(Mis(i));
  return out;
}

void add_integrator_options(CLI::App* sub, IntegratorOptions* o) {
  std::string strategies;
  for (int i = 0; i < kNumStrategies; ++i)
    strategies += std::string("\n  ") + strategy_name(Strategy(i)) + ": " + strategy_description(Strategy(i));
  sub->add_option("--strategy", o->strategy, "Direct-lighting strategy (default: the scene's):" + strategies)
      ->check(render_setting("strategy", true));
  sub->add_option("--mis", o->mis,
                  "Multiple importance sampling of light and BSDF samples (default: the scene's; power for scenes "
                  "that do not say, none for the thesis's cornell-sphere, cornell-near and occlusion): " + mis_help())
      ->check(render_setting("mis", true));
  sub->add_flag("--mis-compensation", o->mis_compensation,
                "MIS compensation of the environment light (Karlik et al. 2019): with --mis balance or power, its "
                "light samples come from its distribution less its mean radiance, leaving the dim directions to the "
                "BSDF sample (render.mis_compensation; no effect without MIS or with restir)");
  std::string selections;
  for (int i = 0; i < kNumLightSelections; ++i)
    selections += std::string("\n  ") + light_selection_name(LightSelection(i)) + ": " +
                  light_selection_description(LightSelection(i));
  sub->add_option("--light-selection", o->light_selection,
                  "How the light of each light sample is chosen (default: the scene's, else power):" + selections)
      ->check(render_setting("light_selection", true));
  sub->add_option("--slc-cut", o->slc_cut,
                  "--light-selection slc: the most nodes of a cut, 1.." + std::to_string(kMaxLightCut) +
                      ", a light sample and shadow ray each (default: the scene's render.slc_cut, else 8)")
      ->check(render_setting("slc_cut"));
  sub->add_option("--max-depth", o->max_depth, "Maximum number of bounces (default: the scene's)")
      ->check(render_setting("max_depth"));
  sub->add_option("--seed", o->seed, "Random seed, 0..4294967295 (default: the scene's)")->check(render_setting("seed"));
  auto* g = sub->add_option_group("restir", "ReSTIR DI (--light-selection restir); defaults: the scene's render.restir");
  g->add_option("--restir-candidates", o->restir_candidates, "Candidates per pixel, M (default 32)")
      ->check(render_setting("restir.candidates"));
  g->add_option("--restir-spatial", o->restir_spatial, "Spatial reuse passes (default 2; 0: candidates only)")
      ->check(render_setting("restir.spatial_passes"));
  g->add_option("--restir-neighbors", o->restir_neighbors, "Neighbours per pixel and pass, k (default 3)")
      ->check(render_setting("restir.neighbors"));
  g->add_option("--restir-radius", o->restir_radius, "Radius of spatial reuse in pixels (default 30)")
      ->check(render_setting("restir.radius"));
  g->add_option("--restir-source", o->restir_source,
                "Selection of the candidates: uniform, power or bvh (default power)")
      ->check(render_setting("restir.source", true));
  auto* biased = g->add_flag("--restir-biased", o->restir_biased,
                             "BIASED combination (the paper's: no visibility in the reuse, Z = sum of M): cheaper, "
                             "darker where neighbours see other lights");
  g->add_flag("--restir-pairwise", o->restir_pairwise,
              "Pairwise MIS in the unbiased reuse: 2k shadow rays per pixel and pass instead of k^2 + k")
      ->excludes(biased);
  g->add_flag("--restir-unshadowed", o->restir_unshadowed,
              "No visibility reuse: unshadowed targets in the reuse (no shadow rays there), one shadow ray when "
              "shading; unbiased all the same");
  g->add_flag("--restir-temporal", o->restir_temporal,
              "Temporal reuse: each sample's reservoirs also combine the same pixel's final ones of the previous "
              "sample (the camera is static: a progressive render, the viewer until the view changes)");
  g->add_option("--restir-temporal-cap", o->restir_temporal_cap,
                "The history's M at most this times the new reservoir's (default 20)")
      ->check(render_setting("restir.temporal_cap"));
}

static void add_wavefront_options(CLI::App* sub, bool* wavefront, Traversal* traversal) {
  *wavefront = true;
  *traversal = Traversal::Auto;
  auto* wf = sub->add_flag("--wavefront", *wavefront,
                           "GPU: the wavefront path tracer (kernels per stage over a pool of paths, restir's frame "
                           "passes included), the default. The cpu backend ignores it");
  sub->add_flag_callback(
         "--megakernel", [wavefront]() { *wavefront = false; },
         "GPU: the megakernel (the whole path loop in one OptiX raygen program) instead of the wavefront; "
         "restir there without spatial or temporal reuse only")
      ->excludes(wf);
  std::vector<std::string> names;
  for (int i = 0; i < kNumTraversals; ++i) names.push_back(traversal_name(Traversal(i)));
  sub->add_option_function<std::string>(
         "--traversal", [traversal](const std::string& name) { find_traversal(name, traversal); },
         "GPU wavefront's trace stage: optix (trace-only OptiX launches), cuda (penumbra's BVH2 traversal) or auto "
         "(optix where the GPU has RT cores, else cuda; one line says which)")
      ->default_str(traversal_name(Traversal::Auto))
      ->check(CLI::IsMember(names));
}

static void add_tune_option(CLI::App* sub, GpuTuning* tuning) {
  *tuning = GpuTuning();
  sub->add_option_function<std::vector<std::string>>(
         "--tune",
         [tuning](const std::vector<std::string>& items) {
           try {
             *tuning = parse_gpu_tuning(items);
           } catch (const std::invalid_argument& e) {  // one line naming the key: "--tune: cuda_occ must be ..."
             throw CLI::ValidationError("--tune", e.what());
           }
         },
         "GPU tuning for measurements (repeatable, or comma-separated; the defaults are the measured choices; the "
         "cpu backend ignores it):" + gpu_tuning_help())
      ->type_name("KEY=VALUE")
      ->delimiter(',')
      ->allow_extra_args(false);
}

void add_denoise_options(CLI::App* sub, DenoiseArgs* a) {
  sub->add_option("--denoiser", a->denoiser,
                  "With --denoise: oidn (Intel Open Image Denoise, on every backend: its CPU device for the CPU "
                  "backend, its CUDA device on the GPU) or optix (the OptiX AI denoiser, GPU backend, where the "
                  "driver's weights file exists)")
      ->capture_default_str()
      ->check(CLI::IsMember({"oidn", "optix"}));
  sub->add_option("--denoise-quality", a->quality, "With --denoiser oidn: fast, balanced or high")
      ->capture_default_str()
      ->check(CLI::IsMember({"fast", "balanced", "high"}));
  sub->add_flag("--denoise-clean-aux", a->clean_aux,
                "With --denoiser oidn: take the albedo and normal guides as noise-free (OIDN's cleanAux)");
  sub->add_option("--oidn-library", a->oidn_library,
                  "Path of libOpenImageDenoise.so.2 (default: the PyPI package pyoidn's, found through python3, "
                  "else the system's)")
      ->check(CLI::ExistingFile);
}

std::string find_oidn_library(const std::string& explicit_path, std::string* how) {
  if (!explicit_path.empty()) {
    if (how) *how = "--oidn-library";
    return explicit_path;
  }
  // pyoidn (PyPI) ships OIDN's libraries in <package>/oidn/lib.
  const char* ask =
      "python3 -c \"import importlib.util as u, os; s = u.find_spec('pyoidn'); "
      "print(os.path.join(os.path.dirname(s.origin), 'oidn', 'lib', 'libOpenImageDenoise.so.2') if s else '')\" "
      "2>/dev/null";
  if (FILE* p = popen(ask, "r")) {
    char line[4096] = {0};
    const bool got = std::fgets(line, sizeof line, p) != nullptr;
    pclose(p);
    std::string path = got ? line : "";
    while (!path.empty() && (path.back() == '\n' || path.back() == '\r')) path.pop_back();
    if (!path.empty() && std::ifstream(path).good()) {
      if (how) *how = "the Python package pyoidn";
      return path;
    }
  }
  if (how) *how = "the system's library path";
  return "";
}

DenoiseOptions denoise_options(const DenoiseArgs& a, std::string* how) {
  DenoiseOptions o = make_denoise_options(a.denoiser, a.quality, a.clean_aux);
  if (o.denoiser == DenoiserKind::Oidn) o.oidn_library = find_oidn_library(a.oidn_library, how);
  return o;
}

static void add_gpus_option(CLI::App* sub, std::string* gpus) {
  *gpus = "all";
  sub->add_option("--gpus", *gpus,
                  "GPUs of the optix backend: all, a number N (the first N) or a list of CUDA device indices "
                  "such as 0,2 (1, for GPU 1 alone); the samples of every pixel are split across them in disjoint ranges (the same "
                  "image). The cpu backend ignores it")
      ->capture_default_str()
      ->check([](const std::string& v) {
        try {
          check_gpus(v);
        } catch (const std::invalid_argument& e) {  // CLI11 puts "--gpus: " before it
          std::string why = e.what();
          return why.substr(why.find(": ") + 2);
        }
        return std::string();
      });
}

void append_integrator_overrides(const IntegratorOptions& o, std::vector<std::string>* overrides) {
  if (!o.strategy.empty()) overrides->push_back("render.strategy=\"" + o.strategy + "\"");
  if (!o.mis.empty()) overrides->push_back("render.mis=\"" + o.mis + "\"");
  if (o.mis_compensation) overrides->push_back("render.mis_compensation=true");
  if (!o.light_selection.empty()) overrides->push_back("render.light_selection=\"" + o.light_selection + "\"");
  if (o.slc_cut != IntegratorOptions::kUnset) overrides->push_back("render.slc_cut=" + std::to_string(o.slc_cut));
  if (o.max_depth != IntegratorOptions::kUnset) overrides->push_back("render.max_depth=" + std::to_string(o.max_depth));
  if (o.seed != IntegratorOptions::kUnset) overrides->push_back("render.seed=" + std::to_string(o.seed));
  // Validated with the scene (render.restir.*: one line naming the field).
  auto set_int = [&](const char* key, long long v) {
    if (v != IntegratorOptions::kUnset) overrides->push_back(std::string("render.restir.") + key + "=" + std::to_string(v));
  };
  set_int("candidates", o.restir_candidates);
  set_int("spatial_passes", o.restir_spatial);
  set_int("neighbors", o.restir_neighbors);
  if (o.restir_radius != -std::numeric_limits<double>::infinity())
    overrides->push_back("render.restir.radius=" + std::to_string(o.restir_radius));
  if (!o.restir_source.empty()) overrides->push_back("render.restir.source=\"" + o.restir_source + "\"");
  if (o.restir_biased) overrides->push_back("render.restir.unbiased=false");
  if (o.restir_pairwise) overrides->push_back("render.restir.pairwise=true");
  if (o.restir_unshadowed) overrides->push_back("render.restir.visibility_reuse=false");
  if (o.restir_temporal) overrides->push_back("render.restir.temporal=true");
  if (o.restir_temporal_cap != -std::numeric_limits<double>::infinity())
    overrides->push_back("render.restir.temporal_cap=" + std::to_string(o.restir_temporal_cap));
}

void add_backend_options(CLI::App* sub, std::string* backend, BackendOptions* options, bool gpus) {
  *backend = "auto";
  sub->add_option("--backend", *backend, "cpu, optix, or auto: optix when a GPU and OptiX work, else cpu")
      ->capture_default_str()
      ->check(CLI::IsMember({"cpu", "optix", "auto"}));
  sub->add_option("--threads", options->threads, "CPU threads (default: all)")->check(CLI::Range(0, 4096));
  if (gpus) add_gpus_option(sub, &options->gpus);
  add_wavefront_options(sub, &options->wavefront, &options->traversal);
  add_tune_option(sub, &options->tuning);
}

void add_set_option(CLI::App* sub, std::vector<std::string>* sets) {
  sub->add_option("--set", *sets,
                  "Override any scene value (repeatable), e.g. --set light.radius=0.05 --set camera.fov=30")
      ->take_all()
      ->allow_extra_args(false);
}

}  // namespace pn
