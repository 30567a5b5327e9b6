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
//     beta_k = prod_{j<k} f(x_j) |cos theta_j| / p(w_j)
// and at every vertex x_k (k <= max_depth) next-event estimation adds
//     beta_k * f(x_k) * L_e(y) * |cos theta_k| / (p_light(w) * P(choose light))
// for one light, chosen in proportion to its power, and one direction w drawn
// by the chosen strategy, if the shadow ray to y is clear. Emission hit by a
// path (lights, emissive triangles, the environment) is added only where NEE
// did not already count it: on camera rays, and on every vertex in the `bsdf`
// strategy. Russian roulette from vertex rr_depth on keeps the estimator
// unbiased (beta /= survival prob).
#pragma once

#include "camera.h"
#include "common.h"
#include "environment.h"
#include "geometry.h"
#include "lights.h"
#include "material.h"
#include "rng.h"
#include "scene_view.h"
#include "strategy.h"
#include "vec.h"

namespace pn {

struct IntegratorSettings {
  Strategy strategy = Strategy::SolidAngle;
  int max_depth = 8;  // maximum number of scattering vertices on a path
  int rr_depth = 5;   // Russian roulette from this vertex on
};

// Radiance arriving at x from the lights along one strategy-sampled direction,
// weighted by f * cos / pdf. Shared by the path loop and the direct-lighting tests.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 estimate_direct(const Tracer& tracer, const SceneView& scene, Strategy strategy,
                           const Bsdf& bsdf, Vec3 p, Vec3 wo, float u_select, Vec2 u) {
  constexpr bool kSpecular = (kFeatures & kFeatureSpecular) != 0;
  if (scene.num_lights == 0) return Vec3(0.f);
  float select_pdf;
  const Light& light = scene.lights[select_light(scene, u_select, &select_pdf)];
  LightSample ls;
  if ((kFeatures & kFeatureEnvironment) && light.type == LightType::Environment) {
    // Not a subject of the comparison: every strategy samples the environment's image.
    EnvironmentSample es = environment_sample(scene.environment, u);
    ls.wi = es.wi;
    ls.L = es.L;
    ls.pdf = es.pdf;
    ls.infinite = true;
  } else {
    ls = sample_light(strategy, light, p, u);
  }
  if (!(ls.pdf > 0.f)) return Vec3(0.f);
  Vec3 f = bsdf_eval<kSpecular>(bsdf, wo, ls.wi);
  if (is_black(f)) return Vec3(0.f);
  const float cos_theta = dot(bsdf.frame.n, ls.wi);
  // The shadow ray leaves on the side of the geometric surface wi points to
  // (bsdf_eval is 0 otherwise) and runs to the sampled point itself, so that
  // the offset can never carry it past the light's surface.
  Vec3 o = offset_ray_origin(p, bsdf.ng);
  if (ls.infinite) {
    if (tracer.occluded(Ray(o, ls.wi), kInf)) return Vec3(0.f);
  } else {
    Vec3 to_light = ls.y - o;
    float dist = length(to_light);
    if (tracer.occluded(Ray(o, to_light / dist), dist * (1.f - kShadowEpsilon))) return Vec3(0.f);
  }
  Vec3 L = ls.L;
  if ((kFeatures & kFeatureTextures) && light.type == LightType::Triangle && light.emission_tex >= 0)
    L = L * texture_lookup(scene.textures[light.emission_tex],
                           lerp_uv(light.uv0, light.uv1, light.uv2, ls.b.x, ls.b.y)).rgb;
  return f * L * (cos_theta / (ls.pdf * select_pdf));
}

// Radiance of a ray that leaves the scene.
template <uint32_t kFeatures = kAllFeatures>
PN_FN Vec3 escaped_radiance(const SceneView& scene, Vec3 d) {
  if ((kFeatures & kFeatureEnvironment) && scene.environment.present()) return environment_radiance(scene.environment, d);
  return scene.background;
}

// One path sample along `ray`; returns its radiance estimate. kFeatures must
// cover the scene's features (SceneFeature); fewer compile to less code.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 trace_path(const Tracer& tracer, const SceneView& scene, const IntegratorSettings& s,
                      Ray ray, Rng& rng) {
  const bool nee = strategy_uses_nee(s.strategy);
  Vec3 L(0.f), beta(1.f);
  for (int depth = 0;; ++depth) {
    HitRecord rec;
    if (!tracer.intersect(ray, kInf, &rec)) {
      if (depth == 0 || !nee || scene.environment_light < 0) L += beta * escaped_radiance<kFeatures>(scene, ray.d);
      break;
    }
    const SurfaceHit hit = resolve_hit<kFeatures>(scene, ray, rec);
    const bool front = dot(hit.n, ray.d) < 0.f;
    // Emission, unless NEE already accounted for this light at the previous vertex.
    if (hit.light >= 0 && front && (depth == 0 || !nee)) L += beta * surface_emission<kFeatures>(scene, hit);
    if (depth == s.max_depth) break;

    const Vec3 wo = -ray.d;
    const Bsdf bsdf = surface_bsdf<kFeatures>(scene, hit, wo);
    if (is_black(bsdf.diffuse) && !bsdf.has_specular) break;

    // Next-event estimation.
    if (nee) {
      float u_select = rng.uniform();
      Vec2 u_light = rng.uniform2();
      L += beta * estimate_direct<kFeatures>(tracer, scene, s.strategy, bsdf, hit.p, wo, u_select, u_light);
    }

    // Continue the path by sampling the BSDF.
    float u_lobe = rng.uniform();
    BsdfSample bs = bsdf_sample<(kFeatures & kFeatureSpecular) != 0>(bsdf, wo, u_lobe, rng.uniform2());
    if (!(bs.pdf > 0.f)) break;
    beta *= bs.weight;

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
                         const IntegratorSettings& s, int px, int py, uint32_t sample_index,
                         uint32_t seed) {
  Rng rng(uint32_t(py) * uint32_t(camera.width) + uint32_t(px), sample_index, seed);
  Vec2 j = rng.uniform2();
  Ray ray = camera.generate_ray(float(px) + j.x, float(py) + j.y);
  return trace_path<kFeatures>(tracer, scene, s, ray, rng);
}

}  // namespace pn
