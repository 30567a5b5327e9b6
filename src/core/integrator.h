// The path tracer: one piece of code for every backend.
//
// A backend supplies a Tracer with two queries and nothing else:
//     bool intersect(const Ray&, float tmax, HitRecord*) const;  // closest hit
//     bool occluded(const Ray&, float tmax) const;               // any hit
// The CPU backend answers them with Embree, the OptiX backend with optixTrace;
// both skip alpha-masked holes (alpha_discards) in both queries. The hit is
// turned into a shading point here, by core/scene_view.h, for both.
//
// Estimator. A path x0 (camera) -> x1 -> x2 ... carries throughput
//     beta_k = prod_{j<k} f(x_j) |cos theta_j| / p_bsdf(w_j)
// and at every vertex x_k (k <= max_depth) next-event estimation adds, for one
// light chosen with probability P(light | x_k) and one direction w drawn from it
// by the strategy with solid-angle density p_light(w),
//     beta_k * f(x_k, w) * L_e * cos theta / (P(light) p_light(w)) * w_light
// if the shadow ray is clear. Emission that a BSDF-sampled ray finds (a light's
// surface, an emissive triangle, the environment) adds beta_k * L_e * w_bsdf.
// The weights (core/strategy.h, mis_weight):
//   --mis none:   w_light = 1; w_bsdf = 1 where no light sampling happened
//                 (camera rays, the bsdf strategy), else 0: each light path is
//                 counted once, by light sampling (the thesis's estimator);
//   --mis balance|power: w_light = h(P p_light, p_bsdf), w_bsdf = h(p_bsdf,
//                 P p_light), both densities of the same direction at the same
//                 vertex, so that the weights sum to 1 wherever both techniques
//                 can produce it (Veach & Guibas 1995).
// Russian roulette from vertex rr_depth on keeps the estimator unbiased
// (beta /= survival probability).
#pragma once

#include "camera.h"
#include "common.h"
#include "geometry.h"
#include "light_sampler.h"
#include "material.h"
#include "rng.h"
#include "scene_view.h"
#include "strategy.h"
#include "vec.h"

namespace pn {

struct IntegratorSettings {
  Strategy strategy = Strategy::SolidAngle;
  Mis mis = Mis::Power;
  LightSelection light_selection = LightSelection::Power;
  int max_depth = 8;  // maximum number of scattering vertices on a path
  int rr_depth = 5;   // Russian roulette from this vertex on
};

// Next-event estimation at a shading point: radiance from one light sample,
// f * L * cos / (P(light) p_light) times its MIS weight. Shared by the path
// loop and the direct-lighting tests.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 estimate_direct(const Tracer& tracer, const SceneView& scene, const IntegratorSettings& s,
                           const Bsdf& bsdf, Vec3 p, Vec3 wo, float u_select, Vec2 u) {
  constexpr bool kSpecular = (kFeatures & kFeatureSpecular) != 0;
  const LightSampleContext ctx{p, bsdf.frame.n};
  const SelectedLight sel = select_light(scene.selection, scene.num_lights, s.light_selection, ctx, u_select);
  if (!(sel.pmf > 0.f)) return Vec3(0.f);
  const Light& light = scene.lights[sel.index];
  const LightSample ls = sample_light<kFeatures>(scene, s.strategy, light, ctx, u);
  if (!(ls.pdf > 0.f)) return Vec3(0.f);
  const Vec3 f = bsdf_eval<kSpecular>(bsdf, wo, ls.wi);
  if (is_black(f)) return Vec3(0.f);
  // The shadow ray leaves on the side of the geometric surface wi points to
  // (bsdf_eval is 0 otherwise) and runs to the sampled point itself, so that
  // the offset can never carry it past the light's surface.
  const Vec3 o = offset_ray_origin(p, bsdf.ng);
  if (ls.infinite) {
    if (tracer.occluded(Ray(o, ls.wi), kInf)) return Vec3(0.f);
  } else {
    const Vec3 to_light = ls.y - o;
    const float dist = length(to_light);
    if (tracer.occluded(Ray(o, to_light / dist), dist * (1.f - kShadowEpsilon))) return Vec3(0.f);
  }
  const float p_light = ls.pdf * sel.pmf;
  const float w = s.mis == Mis::None ? 1.f : mis_weight(s.mis, p_light, bsdf_pdf<kSpecular>(bsdf, wo, ls.wi));
  return f * ls.L * (dot(bsdf.frame.n, ls.wi) * w / p_light);
}

// Convenience for tests: a strategy with the default MIS and selection off.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 estimate_direct(const Tracer& tracer, const SceneView& scene, Strategy strategy, const Bsdf& bsdf, Vec3 p,
                           Vec3 wo, float u_select, Vec2 u) {
  IntegratorSettings s;
  s.strategy = strategy;
  s.mis = Mis::None;
  return estimate_direct<kFeatures>(tracer, scene, s, bsdf, p, wo, u_select, u);
}

// The vertex a BSDF-sampled ray left from: what the MIS weight of emission it
// finds needs to know (the density NEE would have had for that direction).
struct PrevVertex {
  LightSampleContext ctx;
  float bsdf_pdf = 0.f;
};

// The weight of emission from light `index` found along direction w by a
// BSDF-sampled ray (depth > 0, NEE on, MIS on).
template <uint32_t kFeatures = kAllFeatures>
PN_FN float bsdf_emission_weight(const SceneView& scene, const IntegratorSettings& s, const PrevVertex& prev,
                                 uint32_t index, Vec3 w) {
  const float p_light = selection_pmf(scene.selection, scene.num_lights, s.light_selection, prev.ctx, index) *
                        light_pdf<kFeatures>(scene, s.strategy, scene.lights[index], prev.ctx, w);
  return mis_weight(s.mis, prev.bsdf_pdf, p_light);
}

// One path sample along `ray`; returns its radiance estimate. kFeatures must
// cover the scene's features (SceneFeature); fewer compile to less code.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 trace_path(const Tracer& tracer, const SceneView& scene, const IntegratorSettings& s, Ray ray, Rng& rng) {
  const bool nee = strategy_uses_nee(s.strategy);
  const bool mis = nee && s.mis != Mis::None;
  Vec3 L(0.f), beta(1.f);
  PrevVertex prev;
  for (int depth = 0;; ++depth) {
    HitRecord rec;
    if (!tracer.intersect(ray, kInf, &rec)) {
      const Vec3 Le = escaped_radiance<kFeatures>(scene, ray.d);
      if (depth == 0 || !nee || scene.environment_light < 0) L += beta * Le;
      else if (mis) L += beta * Le * bsdf_emission_weight<kFeatures>(scene, s, prev, uint32_t(scene.environment_light), ray.d);
      break;
    }
    const SurfaceHit hit = resolve_hit<kFeatures>(scene, ray, rec);
    // Emission, from the front of an emitting surface.
    if (hit.light >= 0 && dot(hit.n, ray.d) < 0.f) {
      const Vec3 Le = light_emission<kFeatures>(scene, scene.lights[hit.light], hit.uv);
      if (depth == 0 || !nee) L += beta * Le;
      else if (mis) L += beta * Le * bsdf_emission_weight<kFeatures>(scene, s, prev, uint32_t(hit.light), ray.d);
    }
    if (depth == s.max_depth) break;

    const Vec3 wo = -ray.d;
    const Bsdf bsdf = surface_bsdf<kFeatures>(scene, hit, wo);
    if (is_black(bsdf.diffuse) && !bsdf.has_specular) break;

    // Next-event estimation.
    if (nee) {
      float u_select = rng.uniform();
      Vec2 u_light = rng.uniform2();
      L += beta * estimate_direct<kFeatures>(tracer, scene, s, bsdf, hit.p, wo, u_select, u_light);
    }

    // Continue the path by sampling the BSDF.
    float u_lobe = rng.uniform();
    BsdfSample bs = bsdf_sample<(kFeatures & kFeatureSpecular) != 0>(bsdf, wo, u_lobe, rng.uniform2());
    if (!(bs.pdf > 0.f)) break;
    beta *= bs.weight;
    prev.ctx = LightSampleContext{hit.p, bsdf.frame.n};
    prev.bsdf_pdf = bs.pdf;

    // Russian roulette.
    if (depth + 1 >= s.rr_depth) {
      float q = pn_max(0.05f, 1.f - max_component(beta));
      if (rng.uniform() < q) break;
      beta *= 1.f / (1.f - q);
    }
    ray = Ray(offset_ray_origin(hit.p, bsdf.ng), bs.wi);
  }
  return L;
}

// One camera sample of pixel (px, py): its own RNG stream, a uniformly jittered
// position in the pixel (box filter), one path.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 render_sample(const Tracer& tracer, const SceneView& scene, const Camera& camera,
                         const IntegratorSettings& s, int px, int py, uint32_t sample_index, uint32_t seed) {
  Rng rng(uint32_t(py) * uint32_t(camera.width) + uint32_t(px), sample_index, seed);
  Vec2 j = rng.uniform2();
  Ray ray = camera.generate_ray(float(px) + j.x, float(py) + j.y);
  return trace_path<kFeatures>(tracer, scene, s, ray, rng);
}

}  // namespace pn
