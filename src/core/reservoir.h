// Reservoirs for resampled importance sampling of lights (ReSTIR DI, Bitterli
// et al. 2020; the unbiased contribution weights of Lin et al. 2022, "Generalized
// Resampled Importance Sampling").
//
// A reservoir holds one light sample y, a point on a light (for the
// environment, a direction), and its unbiased contribution weight W: for any
// function g that is 0 wherever the reservoir's target is,
//     E[g(y) W] = integral of g,
// so f(y) W estimates the direct light f integrates to. Candidates are drawn
// by a source density p (light selection x strategy) and picked with
// probability proportional to w = p_hat / (M p) (RIS); then
//     W = (sum of w) / p_hat(y).
// The target p_hat is the luminance of the unshadowed contribution
// f(wo, wi) L cos(theta) at the shading point, in the AREA measure of the
// light's surface (times G = cos(theta_light) / d^2), so that reservoirs can be
// moved between pixels without a Jacobian: the same point on the same light
// (identity shift). Directions to the environment are their own domain, in
// solid angle (G = 1). Per-vertex RIS needs no such care; its weights are the
// same numbers in either measure.
#pragma once

#include <type_traits>

#include "common.h"
#include "environment.h"
#include "geometry.h"
#include "light_sampler.h"
#include "lights.h"
#include "material.h"
#include "scene_view.h"
#include "vec.h"

namespace pn {

// A light sample as a reservoir keeps it: enough to evaluate its target and
// its contribution at any shading point.
struct LightPoint {
  Vec3 y;          // the point on the light; the environment: the unit direction towards it
  Vec3 n;          // the light's unit normal at y (the side that emits)
  Vec2 b;          // triangle lights: barycentrics of y (emission textures)
  uint32_t light = 0;
  uint32_t infinite = 0;  // 1: the environment
};

PN_FN LightPoint light_point(const Light& l, uint32_t index, const LightSample& ls) {
  LightPoint p;
  p.light = index;
  if (ls.infinite) {
    p.y = ls.wi;
    p.infinite = 1;
    return p;
  }
  p.y = ls.y;
  p.b = ls.b;
  p.n = l.type == LightType::Sphere ? normalize(ls.y - l.p) : l.n;
  return p;
}

struct Reservoir {
  LightPoint s;
  float w_sum = 0.f;  // sum of the resampling weights seen
  float W = 0.f;      // unbiased contribution weight of s (0: no sample, or one known to be occluded)
  float M = 0.f;      // candidates it stands for (its confidence weight when reservoirs are combined)
  float p_hat = 0.f;  // its target at its own pixel

  // Streaming RIS: keep x with probability w / (sum of w so far).
  PN_FN bool update(const LightPoint& x, float w, float u) {
    if (!(w > 0.f)) return false;
    w_sum += w;
    if (u * w_sum < w) {
      s = x;
      return true;
    }
    return false;
  }
};

// The first vertex of a camera path as a frame-level pass needs it: the
// shading point and its BSDF. The rest of the path's radiance (without the
// first vertex's direct light) is kept by the backend apart: the reuse passes,
// which read these records of every neighbour, never need it. The BSDF is
// packed (its normal, not its frame): 112 bytes, aligned for 16-byte loads.
struct alignas(16) RestirPixel {
  PackedBsdf bsdf;
  Vec3 p;
  Vec3 wo;
  float t = 0.f;        // distance from the camera (neighbour similarity)
  uint32_t valid = 0;   // 0: the camera ray found no surface that reflects
  PointBound p_bound;  // SurfaceHit::p_bound, for shadow rays from p
};

// Where a camera sample's primary pass writes (null: an ordinary path).
struct RestirPrimaryOut {
  RestirPixel* pixel = nullptr;
  Reservoir* reservoir = nullptr;
};

// A light point seen from a shading point.
struct TargetEval {
  Vec3 contribution;  // f(wo, wi) L cos(theta): the integrand in solid angle, unshadowed
  float p_hat = 0.f;  // luminance(contribution) * G: the target, area measure
  float G = 0.f;      // cos(theta_light) / d^2 (1 for the environment)
  Vec3 wi;
  float dist = 0.f;   // to y (kInf for the environment)
};

template <uint32_t kFeatures = kAllFeatures>
PN_FN TargetEval restir_target(const SceneView& scene, const Bsdf& bsdf, Vec3 p, Vec3 wo, const LightPoint& y) {
  TargetEval t;
  const Light& l = scene.lights[y.light];
  Vec3 L;
  if (y.infinite) {
    if (!(kFeatures & kFeatureEnvironment)) return t;
    t.wi = y.y;
    t.dist = kInf;
    t.G = 1.f;
    L = environment_radiance(scene.environment, t.wi);
  } else {
    const Vec3 d = y.y - p;
    const float d2 = length_sq(d);
    if (!(d2 > 0.f)) return t;
    t.dist = std::sqrt(d2);
    t.wi = d / t.dist;
    const float cos_l = -dot(y.n, t.wi);
    if (!(cos_l > 0.f)) return t;
    t.G = cos_l / d2;
    L = light_emission<kFeatures>(scene, l, l.type == LightType::Triangle ? lerp_uv(l.uv0, l.uv1, l.uv2, y.b.x, y.b.y)
                                                                         : Vec2());
  }
  const Vec3 f = bsdf_eval<(kFeatures & kFeatureSpecular) != 0>(bsdf, wo, t.wi);
  const float c = dot(bsdf.frame.n, t.wi);
  if (is_black(f) || !(c > 0.f)) return t;
  t.contribution = f * L * c;
  t.p_hat = luminance(t.contribution) * t.G;
  if (!(t.p_hat > 0.f) || !std::isfinite(t.p_hat)) t.p_hat = 0.f;
  return t;
}

// The shadow ray of next-event estimation from shading point p (its bounds
// p_bound; ng the geometric normal on wi's side) towards the light point
// y: from the offset origin to y itself, stopping kShadowEpsilon short;
// unbounded for the environment.
struct ShadowRay {
  Ray ray;
  float tmax = 0.f;
};

PN_FN ShadowRay light_shadow_ray(Vec3 p, PointBound p_bound, Vec3 ng, Vec3 wi, Vec3 y, bool infinite) {
  const Vec3 o = offset_ray_origin(p, ng, p_bound, wi);
  if (infinite) return ShadowRay{Ray(o, wi), kInf};
  const Vec3 to_light = y - o;
  const float dist = length(to_light);
  return ShadowRay{Ray(o, to_light / dist), dist * (1.f - kShadowEpsilon)};
}

// A tracer that only records the queries made of it, for a later run that replays their answers
// (backends/wavefront's RecordShadowQueries), declares `static constexpr bool kRecordsOnly = true`: its answers
// are placeholders and the run's result is discarded, so code may return right after its last query.
template <class Tracer, class = void>
struct tracer_records_only : std::false_type {};
template <class Tracer>
struct tracer_records_only<Tracer, std::void_t<decltype(Tracer::kRecordsOnly)>>
    : std::integral_constant<bool, Tracer::kRecordsOnly> {};

// Whether the light point is visible from shading point p: its shadow ray is clear.
template <class Tracer>
PN_HD bool light_visible(const Tracer& tracer, Vec3 p, PointBound p_bound, Vec3 ng, Vec3 wi, Vec3 y, bool infinite) {
  const ShadowRay r = light_shadow_ray(p, p_bound, ng, wi, y, infinite);
  return !tracer.occluded(r.ray, r.tmax);
}

}  // namespace pn
