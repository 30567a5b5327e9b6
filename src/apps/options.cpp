#include "apps/options.h"

#include "core/integrator.h"
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

void append_integrator_overrides(const IntegratorOptions& o, std::vector<std::string>* overrides) {
  if (!o.strategy.empty()) overrides->push_back("render.strategy=\"" + o.strategy + "\"");
  if (!o.mis.empty()) overrides->push_back("render.mis=\"" + o.mis + "\"");
  if (!o.light_selection.empty()) overrides->push_back("render.light_selection=\"" + o.light_selection + "\"");
}

}  // namespace pn
