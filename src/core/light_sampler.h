// Lights as the integrator sees them: choosing one (core/light_selection.h),
// sampling it with a strategy and asking a strategy's pdf for a direction
// (dispatched on the light's type by `switch`, the environment one of the
// types), and the radiance lights emit, evaluated here in one place for light
// samples, for hits on emitting surfaces and for rays that leave the scene.
#pragma once

#include <type_traits>

#include "common.h"
#include "environment.h"
#include "light_selection.h"
#include "light_strategies.h"
#include "lights.h"
#include "scene_view.h"
#include "strategy.h"
#include "texture.h"
#include "vec.h"

namespace pn {

// --- Emission --------------------------------------------------------------------

// Radiance a light with a surface emits from its front side at texture
// coordinates uv (only a textured emissive triangle depends on them).
template <uint32_t kFeatures = kAllFeatures>
PN_FN Vec3 light_emission(const SceneView& scene, const Light& l, Vec2 uv) {
  if ((kFeatures & kFeatureTextures) && l.type == LightType::Triangle && l.emission_tex >= 0)
    return l.radiance * texture_lookup(scene.textures[l.emission_tex], uv).rgb;
  return l.radiance;
}

// Radiance of a ray that leaves the scene: the environment, else the background
// (which is not a light: no light sampling finds it).
template <uint32_t kFeatures = kAllFeatures>
PN_FN Vec3 escaped_radiance(const SceneView& scene, Vec3 d) {
  if ((kFeatures & kFeatureEnvironment) && scene.environment.present()) return environment_radiance(scene.environment, d);
  return scene.background;
}

// --- Sampling and pdfs, by strategy and light type -------------------------------------

// The environment, whatever the strategy: its image's importance distribution (`compensated`: the MIS-compensated
// one, environment.h).
template <uint32_t kFeatures>
PN_FN LightSample sample_environment_light(const SceneView& scene, Vec2 u, bool compensated) {
  LightSample s;
  if (!(kFeatures & kFeatureEnvironment)) return s;
  const EnvironmentSample es = environment_sample(scene.environment, u, compensated);
  s.wi = es.wi;
  s.L = es.L;
  s.pdf = es.pdf;
  s.infinite = true;
  return s;
}

// `compensated`: the environment by its MIS-compensated distribution (environment_compensated, integrator.h); the
// pdf of the same light and direction must be asked with the same value.
template <class S, uint32_t kFeatures = kAllFeatures>
PN_FN LightSample sample_light_as(const SceneView& scene, const Light& l, const LightSampleContext& ctx, Vec2 u,
                                  bool compensated = false) {
  LightSample s;
  switch (l.type) {
    case LightType::Sphere:
      s = S::sample_sphere(l, ctx, u);
      break;
    case LightType::Quad:
      s = S::sample_quad(l, ctx, u);
      break;
    case LightType::Triangle:
      s = S::sample_triangle(l, ctx, u);
      break;
    case LightType::Environment:
      return sample_environment_light<kFeatures>(scene, u, compensated);
  }
  if (s.pdf > 0.f)
    s.L = light_emission<kFeatures>(scene, l, l.type == LightType::Triangle ? lerp_uv(l.uv0, l.uv1, l.uv2, s.b.x, s.b.y)
                                                                            : Vec2());
  return s;
}

template <class S, uint32_t kFeatures = kAllFeatures>
PN_FN float light_pdf_as(const SceneView& scene, const Light& l, const LightSampleContext& ctx, Vec3 wi,
                         bool compensated = false) {
  switch (l.type) {
    case LightType::Sphere:
      return S::pdf_sphere(l, ctx, wi);
    case LightType::Quad:
      return S::pdf_quad(l, ctx, wi);
    case LightType::Triangle:
      return S::pdf_triangle(l, ctx, wi);
    case LightType::Environment:
      return (kFeatures & kFeatureEnvironment) ? environment_pdf(scene.environment, wi, compensated) : 0.f;
  }
  return 0.f;
}

// The sampler of a strategy in code compiled with kFeatures: ltc's only with kFeatureLtc (else
// projected-solid-angle's, which ltc is where the BSDF has no GGX lobe: core/features.h).
template <class S, uint32_t kFeatures>
using StrategySampler = std::conditional_t<std::is_same_v<S, LtcSampling> && !(kFeatures & kFeatureLtc),
                                           ProjectedSolidAngleSampling, S>;

// The run-time strategy: one `switch` (the GPU compiles one program per
// strategy, where it folds away).
template <uint32_t kFeatures = kAllFeatures>
PN_FN LightSample sample_light(const SceneView& scene, Strategy strategy, const Light& l, const LightSampleContext& ctx,
                               Vec2 u, bool compensated = false) {
  switch (strategy) {
#define PN_X(e, name, impl, nee, desc) \
  case Strategy::e:                    \
    return sample_light_as<StrategySampler<impl, kFeatures>, kFeatures>(scene, l, ctx, u, compensated);
    PN_STRATEGIES(PN_X)
#undef PN_X
    case Strategy::Count:
      break;
  }
  return LightSample();
}

template <uint32_t kFeatures = kAllFeatures>
PN_FN float light_pdf(const SceneView& scene, Strategy strategy, const Light& l, const LightSampleContext& ctx,
                      Vec3 wi, bool compensated = false) {
  switch (strategy) {
#define PN_X(e, name, impl, nee, desc) \
  case Strategy::e:                    \
    return light_pdf_as<StrategySampler<impl, kFeatures>, kFeatures>(scene, l, ctx, wi, compensated);
    PN_STRATEGIES(PN_X)
#undef PN_X
    case Strategy::Count:
      break;
  }
  return 0.f;
}

}  // namespace pn
