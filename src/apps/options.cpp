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
  sub->add_option("--light-selection", o->light_selection,
                  "How the light of each light sample is chosen: " + light_selection_names() + " (default: power)");
}

void add_gpus_option(CLI::App* sub, std::string* gpus) {
  *gpus = "all";
  sub->add_option("--gpus", *gpus,
                  "GPUs of the optix backend: all, a number N (the first N) or a list of CUDA device indices "
                  "such as 0,2; the samples of every pixel are split across them in disjoint ranges (the same "
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
}

}  // namespace pn
