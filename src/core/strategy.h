// The registry of direct-lighting strategies, chosen per render by name.
//
// To add a strategy:
//   1. write its struct in core/light_strategies.h: sample_<type> and pdf_<type>
//      for type = sphere, quad, triangle (a LightSample and a solid-angle pdf);
//   2. add one X(...) line to PN_STRATEGIES below.
// The enum, the name table, the CLI, the device-side switch and the GPU's
// per-strategy programs all follow from it.
#pragma once

#include "enum_names.h"
#include "light_strategies.h"
#include "ltc.h"

namespace pn {

//  X(Enum,               "cli-name",              struct,                      does NEE, description)
#define PN_STRATEGIES(X)                                                                                           \
  X(Area, "area", AreaSampling, true,                                                                              \
    "uniform point on the light's surface, pdf converted to solid angle (thesis strategy A)")                      \
  X(SolidAngle, "solid-angle", SolidAngleSampling, true,                                                           \
    "uniform in the light's solid angle: a sphere's cone (strategy B), spherical rectangles and triangles; "       \
    "area sampling for polygons under 3e-4 sr or over 6.22 sr")                                                    \
  X(ProjectedSolidAngle, "projected-solid-angle", ProjectedSolidAngleSampling, true,                               \
    "density proportional to cos(theta) over the light's solid angle: a sphere's projected cap (exact); "          \
    "polygons by the bilinear cosine warp of their spherical rectangle/triangle (approximately cos-proportional)") \
  X(Bsdf, "bsdf", NoLightSampling, false,                                                                          \
    "no light sampling: light is found only by BSDF-sampled rays (naive baseline)")                                \
  X(Ltc, "ltc", LtcSampling, true,                                                                                 \
    "the BSDF's lobes: a mixture of the GGX lobe's linearly transformed cosine over quads and triangles "          \
    "(Peters 2021) and projected-solid-angle sampling, weighed by the lobes' estimated contributions; "            \
    "spheres by projected-solid-angle")

enum class Strategy : uint32_t {
#define PN_X(e, name, impl, nee, desc) e,
  PN_STRATEGIES(PN_X)
#undef PN_X
      Count
};

constexpr int kNumStrategies = int(Strategy::Count);

PN_FN bool strategy_uses_nee(Strategy s) {
  switch (s) {
#define PN_X(e, name, impl, nee, desc) \
  case Strategy::e:                    \
    return nee;
    PN_STRATEGIES(PN_X)
#undef PN_X
    case Strategy::Count:
      break;
  }
  return false;
}

// Host-side name tables.
inline const char* strategy_name(Strategy s) {
  static const char* names[] = {
#define PN_X(e, name, impl, nee, desc) name,
      PN_STRATEGIES(PN_X)
#undef PN_X
  };
  return int(s) < kNumStrategies ? names[int(s)] : "?";
}
// The strategy named `name` (false: none is), and every name: "area, solid-angle, ...".
inline bool find_strategy(const std::string& name, Strategy* out) {
  return find_enum(name, kNumStrategies, strategy_name, out);
}
inline std::string strategy_names() { return enum_names(kNumStrategies, strategy_name); }
inline const char* strategy_description(Strategy s) {
  static const char* descs[] = {
#define PN_X(e, name, impl, nee, desc) desc,
      PN_STRATEGIES(PN_X)
#undef PN_X
  };
  return int(s) < kNumStrategies ? descs[int(s)] : "?";
}

// --- Multiple importance sampling (Veach & Guibas 1995) ----------------------------
// With MIS, every vertex takes one light sample and one BSDF sample, and each
// contribution is weighted by a heuristic of the two techniques' densities for
// its direction; with `none`, light samples alone count emission from lights,
// BSDF-sampled rays only where no light sampling took place (camera rays, the
// bsdf strategy), which is the thesis's estimator.
#define PN_MIS_MODES(X)                                                                 \
  X(None, "none", "light sampling only; emission hit by BSDF rays is not counted")     \
  X(Balance, "balance", "one light and one BSDF sample, balance heuristic p_a / sum p") \
  X(Power, "power", "one light and one BSDF sample, power heuristic p_a^2 / sum p^2")

enum class Mis : uint32_t {
#define PN_X(e, name, desc) e,
  PN_MIS_MODES(PN_X)
#undef PN_X
      Count
};
constexpr int kNumMisModes = int(Mis::Count);

inline const char* mis_name(Mis m) {
  static const char* names[] = {
#define PN_X(e, name, desc) name,
      PN_MIS_MODES(PN_X)
#undef PN_X
  };
  return int(m) < kNumMisModes ? names[int(m)] : "?";
}
// The MIS mode named `name` (false: none is), and every name: "none, balance, power".
inline bool find_mis(const std::string& name, Mis* out) { return find_enum(name, kNumMisModes, mis_name, out); }
inline std::string mis_names() { return enum_names(kNumMisModes, mis_name); }
inline const char* mis_description(Mis m) {
  static const char* descs[] = {
#define PN_X(e, name, desc) desc,
      PN_MIS_MODES(PN_X)
#undef PN_X
  };
  return int(m) < kNumMisModes ? descs[int(m)] : "?";
}

// The weight of technique a for a direction both techniques can sample, with
// densities pa (> 0) and pb: pa / (pa + pb) or pa^2 / (pa^2 + pb^2), written as
// a function of their ratio so that huge densities (area sampling at grazing
// angles) neither overflow nor turn into inf / inf.
PN_FN float mis_weight(Mis m, float pa, float pb) {
  if (m == Mis::None) return 1.f;
  if (!(pb > 0.f)) return 1.f;
  if (!(pa > 0.f)) return 0.f;
  const bool power = m == Mis::Power;
  if (pa >= pb) {
    const float r = pb / pa, r2 = power ? r * r : r;
    return 1.f / (1.f + r2);
  }
  const float r = pa / pb, r2 = power ? r * r : r;
  return r2 / (1.f + r2);
}

}  // namespace pn
