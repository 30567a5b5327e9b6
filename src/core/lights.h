// Lights: their geometry, what a light sample is, and the geometric helpers
// every sampling strategy shares (core/light_strategies.h holds the strategies).
//
// Measure convention: every LightSample carries its pdf PER UNIT SOLID ANGLE at
// the shading point, and every strategy's pdf() answers in solid angle too.
// Strategies that pick points on a surface convert with the area-to-solid-angle
// Jacobian in one place, area_to_solid_angle() below.
//
// A light emits radiance from its OUTER side only: a sphere outwards, a quad or
// a triangle on the side of its unit normal n (for a quad n = normalize(e1 x e2);
// for an emissive triangle the side its winding makes front, which a mirroring
// instance transform flips). Radiance is constant over a light, except on a
// triangle with an emission texture; core/light_sampler.h evaluates emission
// (light_emission) in one place for samples and for hits alike.
#pragma once

#include "common.h"
#include "geometry.h"
#include "sampling.h"
#include "vec.h"

namespace pn {

enum class LightType : uint32_t { Sphere = 0, Quad = 1, Triangle = 2, Environment = 3 };

// 112 bytes, 16-aligned: the GPU reads one as seven 16-byte loads (load_light).
struct alignas(16) Light {
  LightType type = LightType::Sphere;
  Vec3 radiance;  // L, constant over the surface (environment: its intensity scale)
  Vec3 p;         // sphere: centre; quad: corner; triangle: vertex 0
  float radius = 0.f;  // sphere only
  Vec3 e1, e2;    // quad and triangle: edges from p
  Vec3 n;         // quad and triangle: unit normal of the emitting side
  float area = 0.f;
  Vec2 uv0, uv1, uv2;         // triangle: texture coordinates of its vertices
  int32_t emission_tex = -1;  // triangle: texture multiplying `radiance`, or -1

  PN_HD static Light sphere(Vec3 center, float radius, Vec3 radiance) {
    Light l;
    l.type = LightType::Sphere;
    l.p = center;
    l.radius = radius;
    l.radiance = radiance;
    l.area = 4.f * kPi * radius * radius;
    return l;
  }
  PN_HD static Light quad(Vec3 corner, Vec3 e1, Vec3 e2, Vec3 radiance) {
    Light l;
    l.type = LightType::Quad;
    l.p = corner;
    l.e1 = e1;
    l.e2 = e2;
    Vec3 c = cross(e1, e2);
    l.area = length(c);
    l.n = c / l.area;
    l.radiance = radiance;
    return l;
  }
  PN_HD static Light triangle(Vec3 p0, Vec3 p1, Vec3 p2, Vec3 radiance) {
    Light l;
    l.type = LightType::Triangle;
    l.p = p0;
    l.e1 = p1 - p0;
    l.e2 = p2 - p0;
    Vec3 c = cross(l.e1, l.e2);
    float len = length(c);
    l.area = 0.5f * len;
    l.n = len > 0.f ? c / len : Vec3(0.f, 0.f, 1.f);
    l.radiance = radiance;
    return l;
  }
};

static_assert(sizeof(Light) == 112, "Light is seven 16-byte words");

// Light i, copied. On the GPU as seven 16-byte loads: the strategies read fields by type, and read through the
// array a word at a time, several times (commit cf489d0's PTX: a run of 96 scalar loads at the switch on the type).
PN_FN Light load_light(const Light* lights, uint32_t i) {
#if defined(__CUDA_ARCH__)
  const float4* p = reinterpret_cast<const float4*>(lights + i);
  float4 words[sizeof(Light) / 16];
  for (uint32_t k = 0; k < sizeof(Light) / 16; ++k) words[k] = __ldg(p + k);
  Light l;
  memcpy(&l, words, sizeof(Light));
  return l;
#else
  return lights[i];
#endif
}

// Where a light is sampled from: the shading point and its unit shading normal
// (on the side the light is sampled for). Area and solid-angle sampling use
// only p; projected-solid-angle sampling weights directions by max(0, n . w).
//
// The `ltc` strategy (core/ltc.h) and `sg-bvh` selection (core/light_bvh.h)
// also weigh by the BSDF's lobes: the view direction wo, the GGX alpha, and
// the luminances of the specular lobe's Fresnel weight F(cos_o) and of the
// diffuse lobe's albedo at wo (specular = 0: no specular lobe, and `ltc`
// samples as projected-solid-angle does). Every other strategy and selection
// ignores them (light_sample_context, core/integrator.h, fills them for those
// two only).
struct LightSampleContext {
  Vec3 p;
  Vec3 n;
  Vec3 wo{0.f, 0.f, 0.f};
  float alpha = 1.f;
  float specular = 0.f;
  float diffuse = 0.f;
};

// A direction towards a light, with what is needed to evaluate and shadow-test it.
struct LightSample {
  Vec3 wi;          // unit direction from the shading point towards the light
  Vec3 y;           // the sampled point on the light (the shadow ray's target)
  float dist = 0.f; // distance to y
  Vec3 L;           // radiance arriving along wi (if unoccluded); light_sampler.h fills it
  float pdf = 0.f;  // solid-angle density of wi; 0 means "no sample"
  Vec2 b;           // triangle lights: barycentrics (b1, b2) of y, for textured emission
  bool infinite = false;  // environment: y is at infinity, the shadow ray is unbounded
};

// Converts a density over the light's area at point y (normal ny) into a density
// over directions at x:  p_w = p_A * d^2 / |cos theta_light|. A point whose
// emitting side faces away from x contributes nothing and yields pdf 0.
PN_FN LightSample area_to_solid_angle(Vec3 x, Vec3 y, Vec3 ny, float pdf_area) {
  LightSample s;
  Vec3 d = y - x;
  float dist2 = dot(d, d);
  if (!(dist2 > 0.f)) return s;
  float dist = std::sqrt(dist2);
  Vec3 wi = d / dist;
  float cos_light = -dot(ny, wi);
  if (cos_light <= 0.f) return s;  // back side: no emission towards x
  s.wi = wi;
  s.y = y;
  s.dist = dist;
  s.pdf = pdf_area * dist2 / cos_light;
  return s;
}
// The same Jacobian for a direction wi that meets the light at distance t.
PN_FN float area_pdf_to_solid_angle(float pdf_area, float t, Vec3 ny, Vec3 wi) {
  float cos_light = -dot(ny, wi);
  return cos_light > 0.f ? pdf_area * t * t / cos_light : 0.f;
}

// --- Where a direction meets a light (for pdfs of given directions) --------------

// Distance along unit w from x to the sphere's near side; the discriminant is
// clamped at 0, so a direction that grazes the sphere within rounding still
// gets the tangent point. False when w misses by more or x is inside.
PN_FN bool sphere_light_distance(const Light& l, Vec3 x, Vec3 w, float* t, bool clamp_grazing) {
  const Vec3 f = x - l.p;
  const float r2 = l.radius * l.radius;
  const float c = dot(f, f) - r2;
  if (!(c > 0.f)) return false;
  const float b = dot(f, w);
  if (b >= 0.f) return false;  // the sphere is behind x
  const Vec3 perp = f - w * b;
  float disc = r2 - dot(perp, perp);
  if (disc < 0.f) {
    if (!clamp_grazing || disc < -1e-4f * r2) return false;
    disc = 0.f;
  }
  const float q = -b + std::sqrt(disc);  // the far distance; the near one is c / q (Haines et al.)
  *t = c / q;
  return true;
}

// Parameters (a, b) with y = p + a e1 + b e2 of a point y in the plane of the
// edges e1, e2 (any angle between them: the dual basis).
PN_FN Vec2 plane_coordinates(Vec3 e1, Vec3 e2, Vec3 q) {
  const float e11 = dot(e1, e1), e12 = dot(e1, e2), e22 = dot(e2, e2);
  const float det = e11 * e22 - e12 * e12;
  const float q1 = dot(q, e1), q2 = dot(q, e2);
  return Vec2((q1 * e22 - q2 * e12) / det, (q2 * e11 - q1 * e12) / det);
}

// Where unit w from x meets the plane of a quad or triangle light from its
// emitting side: distance t and plane coordinates (a, b) of the point.
PN_FN bool planar_light_hit(const Light& l, Vec3 x, Vec3 w, float* t, Vec2* ab) {
  const float dn = dot(w, l.n);
  if (!(dn < 0.f)) return false;  // parallel, or towards the back side
  *t = dot(l.p - x, l.n) / dn;
  if (!(*t > 0.f)) return false;
  *ab = plane_coordinates(l.e1, l.e2, x + w * *t - l.p);
  return true;
}
PN_FN bool quad_light_distance(const Light& l, Vec3 x, Vec3 w, float* t) {
  Vec2 ab;
  return planar_light_hit(l, x, w, t, &ab) && ab.x >= 0.f && ab.x <= 1.f && ab.y >= 0.f && ab.y <= 1.f;
}
PN_FN bool triangle_light_distance(const Light& l, Vec3 x, Vec3 w, float* t, Vec2* b) {
  return planar_light_hit(l, x, w, t, b) && b->x >= 0.f && b->y >= 0.f && b->x + b->y <= 1.f;
}

// Whether x sees the emitting side of a quad or triangle light.
PN_FN bool faces_emitting_side(const Light& l, Vec3 x) { return dot(x - l.p, l.n) > 0.f; }

// A quad light whose edges are orthogonal (within rounding): a rectangle, which
// the spherical-rectangle sampler handles; other parallelograms are two triangles.
PN_FN bool quad_is_rectangle(const Light& l) {
  return std::fabs(dot(l.e1, l.e2)) <= 1e-5f * length(l.e1) * length(l.e2);
}

// Barycentrics (b1, b2) of a point of a triangle light, clamped into the triangle.
PN_FN Vec2 clamp_barycentrics(Vec2 b) {
  b.x = clamp(b.x, 0.f, 1.f);
  b.y = clamp(b.y, 0.f, 1.f);
  const float s = b.x + b.y;
  if (s > 1.f) b = Vec2(b.x / s, b.y / s);
  return b;
}

}  // namespace pn
