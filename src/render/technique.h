// A technique of the comparison: a light-sampling strategy with an MIS mode.
// Named "area" (MIS none, the thesis's estimator) or "area+power"; strategies
// without light sampling (bsdf) take no MIS mode.
#pragma once

#include <string>
#include <vector>

#include "core/strategy.h"

namespace pn {

struct Technique {
  Strategy strategy = Strategy::SolidAngle;
  Mis mis = Mis::None;
};

inline std::string technique_name(const Technique& t) {
  std::string n = strategy_name(t.strategy);
  if (strategy_uses_nee(t.strategy) && t.mis != Mis::None) n += std::string("+") + mis_name(t.mis);
  return n;
}

// Every strategy with every MIS mode, in that order; a strategy without light
// sampling once, with MIS none.
inline std::vector<Technique> cross_techniques(const std::vector<Strategy>& strategies, const std::vector<Mis>& modes) {
  std::vector<Technique> out;
  for (Strategy s : strategies) {
    if (!strategy_uses_nee(s)) {
      out.push_back({s, Mis::None});
      continue;
    }
    for (Mis m : modes) out.push_back({s, m});
  }
  return out;
}

}  // namespace pn
