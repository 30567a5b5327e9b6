// The registry of direct-lighting strategies, chosen per render by name.
//
// To add a strategy:
//   1. write  PN_FN LightSample sample_light_<name>(const Light&, Vec3 x, Vec2 u)
//      in lights.h, returning a direction with its solid-angle pdf (pdf 0: none);
//   2. add one X(...) line to PN_STRATEGIES below.
// The enum, the name table, the CLI and the device-side switch all follow from it.
#pragma once

#include "lights.h"

namespace pn {

//  X(Enum,        "cli-name",    sampling function,        does NEE, one-line description)
#define PN_STRATEGIES(X)                                                                         \
  X(Area,       "area",        sample_light_area,        true,                                  \
    "uniform point on the light's surface, pdf converted to solid angle (thesis strategy A)")   \
  X(SolidAngle, "solid-angle", sample_light_solid_angle, true,                                  \
    "uniform direction in the cone a sphere light subtends; quads use area (strategy B)")       \
  X(Bsdf,       "bsdf",        sample_light_none,        false,                                 \
    "no light sampling: light is found only by BSDF-sampled rays (naive baseline)")

enum class Strategy : uint32_t {
#define PN_X(e, name, fn, nee, desc) e,
  PN_STRATEGIES(PN_X)
#undef PN_X
      Count
};

constexpr int kNumStrategies = int(Strategy::Count);

// Static dispatch, usable in device code.
PN_FN LightSample sample_light(Strategy s, const Light& light, Vec3 x, Vec2 u) {
  switch (s) {
#define PN_X(e, name, fn, nee, desc) \
  case Strategy::e:                  \
    return fn(light, x, u);
    PN_STRATEGIES(PN_X)
#undef PN_X
    default:
      return LightSample();
  }
}

PN_FN bool strategy_uses_nee(Strategy s) {
  switch (s) {
#define PN_X(e, name, fn, nee, desc) \
  case Strategy::e:                  \
    return nee;
    PN_STRATEGIES(PN_X)
#undef PN_X
    default:
      return false;
  }
}

// Host-side name tables.
inline const char* strategy_name(Strategy s) {
  static const char* names[] = {
#define PN_X(e, name, fn, nee, desc) name,
      PN_STRATEGIES(PN_X)
#undef PN_X
  };
  return int(s) < kNumStrategies ? names[int(s)] : "?";
}
inline const char* strategy_description(Strategy s) {
  static const char* descs[] = {
#define PN_X(e, name, fn, nee, desc) desc,
      PN_STRATEGIES(PN_X)
#undef PN_X
  };
  return int(s) < kNumStrategies ? descs[int(s)] : "?";
}

}  // namespace pn
