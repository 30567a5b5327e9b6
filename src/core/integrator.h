// The path tracer: one piece of code for every backend.
//
// A backend supplies a Tracer with two queries and nothing else:
//     bool intersect(const Ray&, float tmax, SurfaceHit*) const;  // closest hit
//     bool occluded(const Ray&, float tmax) const;                // any hit
// The CPU backend answers them with Embree, the OptiX backend with optixTrace.
//
// Estimator. A path x0 (camera) -> x1 -> x2 ... carries throughput
//     beta_k = prod_{j<k} f(x_j) |cos theta_j| / p(w_j)
// and at every diffuse vertex x_k (k <= max_depth) next-event estimation adds
//     beta_k * f(x_k) * L_e(y) * |cos theta_k| / (p_light(w) * P(choose light))
// for one light direction w drawn by the chosen strategy, if the shadow ray to y
// is clear. Emission hit by a path is added only where NEE did not already count
// it: on camera rays, and on every vertex in the `bsdf` strategy. Russian roulette
// from vertex rr_depth on keeps the estimator unbiased (beta /= survival prob).
#pragma once

#include "camera.h"
#include "common.h"
#include "geometry.h"
#include "lights.h"
#include "material.h"
#include "rng.h"
#include "strategy.h"
#include "vec.h"

namespace pn {

// What a backend reports for a closest hit, in world space.
struct SurfaceHit {
  float t = kInf;
  Vec3 p;          // hit point
  Vec3 n;          // unit geometric normal, as modelled (not flipped towards the ray)
  uint32_t material = 0;
  int32_t light = -1;  // index into SceneView::lights if the surface emits, else -1
};

// Read-only scene data the integrator needs beyond ray queries.
struct SceneView {
  const Light* lights = nullptr;
  uint32_t num_lights = 0;
  const Material* materials = nullptr;
  uint32_t num_materials = 0;
  Vec3 background;  // radiance of rays that escape (always found by BSDF rays)
};

struct IntegratorSettings {
  Strategy strategy = Strategy::SolidAngle;
  int max_depth = 8;  // maximum number of scattering vertices on a path
  int rr_depth = 5;   // Russian roulette from this vertex on
};

// Radiance arriving at x from the lights along one strategy-sampled direction,
// weighted by f * cos / pdf. Shared by the path loop and the direct-lighting tests.
template <class Tracer>
PN_HD Vec3 estimate_direct(const Tracer& tracer, const SceneView& scene, Strategy strategy,
                           const Material& m, Vec3 p, Vec3 n, Vec3 wo, float u_select, Vec2 u) {
  if (scene.num_lights == 0) return Vec3(0.f);
  uint32_t li = pn_min(uint32_t(u_select * float(scene.num_lights)), scene.num_lights - 1);
  float select_pdf = 1.f / float(scene.num_lights);
  LightSample ls = sample_light(strategy, scene.lights[li], p, u);
  if (!(ls.pdf > 0.f)) return Vec3(0.f);
  float cos_theta = dot(n, ls.wi);
  if (cos_theta <= 0.f) return Vec3(0.f);
  // The shadow ray runs from the offset origin to the sampled point itself, so
  // that the offset can never carry it past the light's surface.
  Vec3 o = offset_ray_origin(p, n);
  Vec3 to_light = ls.y - o;
  float dist = length(to_light);
  if (tracer.occluded(Ray(o, to_light / dist), dist * (1.f - kShadowEpsilon))) return Vec3(0.f);
  return bsdf_eval(m, n, wo, ls.wi) * ls.L * (cos_theta / (ls.pdf * select_pdf));
}

// One path sample along `ray`; returns its radiance estimate.
template <class Tracer>
PN_HD Vec3 trace_path(const Tracer& tracer, const SceneView& scene, const IntegratorSettings& s,
                      Ray ray, Rng& rng) {
  const bool nee = strategy_uses_nee(s.strategy);
  Vec3 L(0.f), beta(1.f);
  for (int depth = 0;; ++depth) {
    SurfaceHit hit;
    if (!tracer.intersect(ray, kInf, &hit)) {
      L += beta * scene.background;
      break;
    }
    const bool front = dot(hit.n, ray.d) < 0.f;
    // Emission, unless NEE already accounted for this light at the previous vertex.
    if (hit.light >= 0 && front && (depth == 0 || !nee)) L += beta * scene.lights[hit.light].radiance;
    if (depth == s.max_depth) break;

    const Material& m = scene.materials[hit.material];
    if (is_black(m.albedo)) break;
    const Vec3 n = front ? hit.n : -hit.n;  // two-sided shading
    const Vec3 wo = -ray.d;

    // Next-event estimation.
    if (nee) {
      float u_select = rng.uniform();
      Vec2 u_light = rng.uniform2();
      L += beta * estimate_direct(tracer, scene, s.strategy, m, hit.p, n, wo, u_select, u_light);
    }

    // Continue the path by sampling the BSDF.
    BsdfSample bs = bsdf_sample(m, n, wo, rng.uniform2());
    if (!(bs.pdf > 0.f)) break;
    beta *= bs.weight;

    // Russian roulette.
    if (depth + 1 >= s.rr_depth) {
      float q = pn_max(0.05f, 1.f - max_component(beta));
      if (rng.uniform() < q) break;
      beta *= 1.f / (1.f - q);
    }
    ray = Ray(offset_ray_origin(hit.p, n), bs.wi);
  }
  return L;
}

// One camera sample of pixel (px, py): its own RNG stream, a uniformly jittered
// position in the pixel (box filter), one path.
template <class Tracer>
PN_HD Vec3 render_sample(const Tracer& tracer, const SceneView& scene, const Camera& camera,
                         const IntegratorSettings& s, int px, int py, uint32_t sample_index,
                         uint32_t seed) {
  Rng rng(uint32_t(py) * uint32_t(camera.width) + uint32_t(px), sample_index, seed);
  Vec2 j = rng.uniform2();
  Ray ray = camera.generate_ray(float(px) + j.x, float(py) + j.y);
  return trace_path(tracer, scene, s, ray, rng);
}

}  // namespace pn
