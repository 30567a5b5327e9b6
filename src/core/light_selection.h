// Light selection: which light one light sample goes to, a choice of its own
// beside how the chosen light is sampled (core/light_strategies.h). The
// probability of choosing light i, P(i | x), multiplies every light pdf,
// MIS weights included. The shading point is an argument because methods that
// adapt to it (a light BVH, resampling) belong here too.
#pragma once

#include "common.h"
#include "lights.h"
#include "sampling.h"

namespace pn {

#define PN_LIGHT_SELECTIONS(X)                                                                  \
  X(Uniform, "uniform", "every light with the same probability")                                \
  X(Power, "power", "in proportion to emitted power (luminance of pi A L; the environment's by " \
                    "its image over the scene's bounding disk)")

enum class LightSelection : uint32_t {
#define PN_X(e, name, desc) e,
  PN_LIGHT_SELECTIONS(PN_X)
#undef PN_X
      Count
};
constexpr int kNumLightSelections = int(LightSelection::Count);

inline const char* light_selection_name(LightSelection s) {
  static const char* names[] = {
#define PN_X(e, name, desc) name,
      PN_LIGHT_SELECTIONS(PN_X)
#undef PN_X
  };
  return int(s) < kNumLightSelections ? names[int(s)] : "?";
}
inline const char* light_selection_description(LightSelection s) {
  static const char* descs[] = {
#define PN_X(e, name, desc) desc,
      PN_LIGHT_SELECTIONS(PN_X)
#undef PN_X
  };
  return int(s) < kNumLightSelections ? descs[int(s)] : "?";
}

// What selection needs of the scene beside the number of lights: the power CDF
// (count + 1 entries, built by the host's finalize_scene).
struct LightSelectionView {
  const float* power_cdf = nullptr;  // null: power selection falls back to uniform
};

struct SelectedLight {
  uint32_t index = 0;
  float pmf = 0.f;  // 0: nothing selected (no lights)
};

PN_FN SelectedLight select_light(const LightSelectionView& v, uint32_t n, LightSelection method,
                                 const LightSampleContext&, float u) {
  SelectedLight s;
  if (n == 0) return s;
  switch (method) {
    case LightSelection::Power:
      if (v.power_cdf) {
        s.index = find_cdf_piece(v.power_cdf, n, u);
        s.pmf = v.power_cdf[s.index + 1] - v.power_cdf[s.index];
        return s;
      }
      break;
    case LightSelection::Uniform:
    case LightSelection::Count:
      break;
  }
  s.index = pn_min(uint32_t(u * float(n)), n - 1);
  s.pmf = 1.f / float(n);
  return s;
}

// P(light i | x), as select_light() chooses.
PN_FN float selection_pmf(const LightSelectionView& v, uint32_t n, LightSelection method, const LightSampleContext&,
                          uint32_t i) {
  if (i >= n) return 0.f;
  if (method == LightSelection::Power && v.power_cdf) return v.power_cdf[i + 1] - v.power_cdf[i];
  return 1.f / float(n);
}

}  // namespace pn
