#include "apps/options.h"

#include <stdexcept>

#include "core/integrator.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {

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
  sub->add_option("--strategy", o->strategy, "Direct-lighting strategy (default: the scene's):" + strategies);
  sub->add_option("--mis", o->mis,
                  "Multiple importance sampling of light and BSDF samples (default: the scene's; power for scenes "
                  "that do not say, none for the thesis's cornell-sphere, cornell-near and occlusion): " + mis_help());
  std::string selections;
  for (int i = 0; i < kNumLightSelections; ++i)
    selections += std::string("\n  ") + light_selection_name(LightSelection(i)) + ": " +
                  light_selection_description(LightSelection(i));
  sub->add_option("--light-selection", o->light_selection,
                  "How the light of each light sample is chosen (default: the scene's, else power):" + selections);
  auto* g = sub->add_option_group("restir", "ReSTIR DI (--light-selection restir); defaults: the scene's render.restir");
  g->add_option("--restir-candidates", o->restir_candidates, "Candidates per pixel, M (default 32)");
  g->add_option("--restir-spatial", o->restir_spatial, "Spatial reuse passes (default 2; 0: candidates only)");
  g->add_option("--restir-neighbors", o->restir_neighbors, "Neighbours per pixel and pass, k (default 3)");
  g->add_option("--restir-radius", o->restir_radius, "Radius of spatial reuse in pixels (default 30)");
  g->add_option("--restir-source", o->restir_source, "Selection of the candidates: uniform, power or bvh (default power)");
  g->add_flag("--restir-biased", o->restir_biased,
              "BIASED combination (the paper's: no visibility in the reuse, Z = sum of M): cheaper, darker where "
              "neighbours see other lights");
  g->add_flag("--restir-pairwise", o->restir_pairwise,
              "Pairwise MIS in the unbiased reuse: 2k shadow rays per pixel and pass instead of k^2 + k");
  g->add_flag("--restir-unshadowed", o->restir_unshadowed,
              "No visibility reuse: unshadowed targets in the reuse (no shadow rays there), one shadow ray when "
              "shading; unbiased all the same");
  g->add_flag("--restir-temporal", o->restir_temporal,
              "Temporal reuse: each sample's reservoirs also combine the same pixel's final ones of the previous "
              "sample (the camera is static: a progressive render, the viewer until the view changes)");
  g->add_option("--restir-temporal-cap", o->restir_temporal_cap,
                "The history's M at most this times the new reservoir's (default 20)");
}

void add_wavefront_options(CLI::App* sub, bool* wavefront, std::string* traversal) {
  *wavefront = true;
  *traversal = "auto";
  auto* wf = sub->add_flag("--wavefront", *wavefront,
                           "GPU: the wavefront path tracer (kernels per stage over a pool of paths, restir's frame "
                           "passes included), the default. The cpu backend ignores it");
  sub->add_flag_callback(
         "--megakernel", [wavefront]() { *wavefront = false; },
         "GPU: the megakernel (the whole path loop in one OptiX raygen program) instead of the wavefront; "
         "restir there without spatial or temporal reuse only")
      ->excludes(wf);
  sub->add_option("--traversal", *traversal,
                  "GPU wavefront's trace stage: optix (trace-only OptiX launches), cuda (penumbra's BVH2 "
                  "traversal) or auto (optix where the GPU has RT cores, else cuda; one line says which)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "optix", "cuda"}));
}

void add_gpus_option(CLI::App* sub, std::string* gpus) {
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
  if (!o.light_selection.empty()) overrides->push_back("render.light_selection=\"" + o.light_selection + "\"");
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

}  // namespace pn
