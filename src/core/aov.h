// The denoiser's guides: per pixel, the albedo and the world-space shading
// normal of the first non-specular surface a camera ray meets, averaged over a
// few jittered camera rays. Like Mitsuba 3's separate `aov` integrator, this is
// its own small pass beside the path loop (core/integrator.h), run by every
// backend through the same closest-hit query (Tracer::intersect).
//
// Following mirrors. A surface whose BSDF is a near-delta lobe with no
// diffuse part (a metal, metallic = 1, with GGX alpha <= kGuideSpecularAlpha,
// i.e. roughness <= 0.1) shows a sharp image of what it reflects: the
// denoiser must keep the edges of that image, so the guides describe the
// reflected surface, reached by the mirror direction about the shading normal.
// alpha 0.01 spreads the lobe over about half a degree: at the distances of
// our scenes a texel-sharp reflection, while rougher lobes blur the reflection
// into the kind of smooth signal the denoiser may filter (their own albedo then
// guides it). At most kGuideMaxSpecular mirrors are followed.
//
// Albedo. At the first non-specular hit, the BSDF's directional albedo for
// the viewing direction, as the sampler estimates it (bsdf_specular_probability):
//     a = (1 - m) c (1 - F_d(cos_o)) + F(cos_o)
// (the diffuse part after the coat's reflection plus the specular lobe's
// Fresnel reflectance). For a Lambertian surface this is the base colour c
// exactly. It ignores GGX's masking loss and the coat's exit transmission,
// so it can err slightly high; each mirror followed multiplies it by its own
// Fresnel reflectance F(cos). The result is clamped to [0, 1] per channel: the
// denoiser is trained on reflectances, and a base colour factor > 1 or an
// over-estimated coat must never hand it more (Mitsuba 3 PR 1896 fixed albedo
// AOVs that left [0, 1]).
//
// Lights and the sky. A ray that meets the front of an emitting surface writes
// its radiance clamped to [0, 1] as albedo (a bright light is white) and that
// surface's normal; a ray that escapes writes the environment's (or the
// background's) radiance clamped to [0, 1] and a zero normal: there is no
// surface to describe, and the denoiser reads a zero normal as "none".
//
// Normal. The shading normal (normal maps applied), turned towards the ray
// that arrived (surface_bsdf's frame), in world space: the denoiser's AOV
// model takes world-space normals (the legacy HDR model wanted camera space).
// The pixel's normal is the normalized sum of its samples' normals.
#pragma once

#include "camera.h"
#include "common.h"
#include "geometry.h"
#include "light_sampler.h"
#include "material.h"
#include "rng.h"
#include "scene_view.h"
#include "vec.h"

namespace pn {

constexpr float kGuideSpecularAlpha = 0.01f;  // GGX alpha of a lobe followed as a mirror (roughness 0.1)
constexpr int kGuideMaxSpecular = 4;          // mirrors followed at most

// One camera ray's guides.
struct GuideSample {
  Vec3 albedo;  // in [0, 1]
  Vec3 normal;  // unit, or 0 where the ray escaped
};

// Whether the guides look through this BSDF to what it reflects (see above).
PN_FN bool guide_follows_specular(const Bsdf& b) {
  return b.has_specular && is_black(b.diffuse) && b.coat_weight == 0.f && b.alpha <= kGuideSpecularAlpha;
}

// The directional albedo estimate above, for the view direction wo
// (kSpecular = false: no material of the scene has a specular lobe).
template <bool kSpecular = true>
PN_FN Vec3 guide_albedo(const Bsdf& b, Vec3 wo) {
  const float cos_o = pn_max(0.f, dot(b.frame.n, wo));
  Vec3 a = b.diffuse * bsdf_coat_transmission<kSpecular>(b, cos_o);
  if (kSpecular && b.has_specular) a += bsdf_fresnel(b, cos_o);
  return a;
}

PN_FN Vec3 clamp01(Vec3 v) { return Vec3(clamp(v.x, 0.f, 1.f), clamp(v.y, 0.f, 1.f), clamp(v.z, 0.f, 1.f)); }

// The guides of one ray: follow mirrors to the first non-specular hit. The
// loop has one trace call site and is kept rolled on the GPU (unrolled, each
// copy would be a full shading point in the program the driver compiles);
// without specular lobes (kFeatures) it runs once.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD GuideSample trace_guides(const Tracer& tracer, const SceneView& scene, Ray ray) {
  constexpr bool kSpecular = (kFeatures & kFeatureSpecular) != 0;
  GuideSample g;
  Vec3 tint(1.f);  // product of the mirrors' Fresnel reflectances, in [0, 1]
#ifdef __CUDA_ARCH__
#pragma unroll 1
#endif
  for (int bounce = 0;; ++bounce) {
    HitRecord rec;
    if (!tracer.intersect(ray, kInf, &rec)) {
      g.albedo = clamp01(tint * escaped_radiance<kFeatures>(scene, ray.d));
      g.normal = Vec3(0.f);
      return g;
    }
    const SurfaceHit hit = resolve_hit<kFeatures>(scene, ray, rec);
    const Vec3 wo = -ray.d;
    if (hit.light >= 0 && dot(hit.n, ray.d) < 0.f) {
      g.albedo = clamp01(tint * light_emission<kFeatures>(scene, scene.lights[hit.light], hit.uv));
      g.normal = dot(hit.ns, wo) >= 0.f ? hit.ns : -hit.ns;
      return g;
    }
    const Bsdf bsdf = surface_bsdf<kFeatures>(scene, hit, wo);
    if (kSpecular && bounce < kGuideMaxSpecular && guide_follows_specular(bsdf)) {
      const float cos_o = dot(bsdf.frame.n, wo);
      const Vec3 wi = reflect(wo, bsdf.frame.n);
      if (cos_o > 0.f && dot(wi, bsdf.ng) > 0.f) {
        tint = tint * clamp01(bsdf_fresnel(bsdf, cos_o));
        ray = Ray(offset_ray_origin(hit.p, bsdf.ng, hit.p_bound, wi), wi);
        continue;
      }
    }
    g.albedo = clamp01(tint * clamp01(guide_albedo<kSpecular>(bsdf, wo)));
    g.normal = bsdf.frame.n;
    return g;
  }
}

// Pixel (px, py)'s guides from `samples` jittered camera rays: sample i uses
// the camera ray of the render's sample i (the same stream and the same first
// two numbers as render_sample), so the guides cover the pixel as the image
// does. Albedo: the mean; normal: the normalized sum (0 where every ray escaped).
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD GuideSample render_guides_pixel(const Tracer& tracer, const SceneView& scene, const Camera& camera, int px,
                                      int py, uint32_t samples, uint32_t seed) {
  Vec3 albedo(0.f), normal(0.f);
#ifdef __CUDA_ARCH__
#pragma unroll 1
#endif
  for (uint32_t i = 0; i < samples; ++i) {
    Rng rng(uint32_t(py) * uint32_t(camera.width) + uint32_t(px), i, seed);
    const Vec2 j = rng.uniform2();
    const GuideSample g = trace_guides<kFeatures>(tracer, scene, camera.generate_ray(float(px) + j.x, float(py) + j.y));
    albedo += g.albedo;
    normal += g.normal;
  }
  GuideSample out;
  out.albedo = samples > 0 ? clamp01(albedo * (1.f / float(samples))) : Vec3(0.f);
  const float len = length(normal);
  out.normal = len > 1e-6f ? normal / len : Vec3(0.f);
  return out;
}

}  // namespace pn
