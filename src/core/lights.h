// Area lights and the light-sampling strategies that penumbra compares.
//
// Measure convention: every LightSample carries its pdf PER UNIT SOLID ANGLE at
// the shading point. Strategies that pick points on a surface convert with the
// area-to-solid-angle Jacobian in one place, area_to_solid_angle() below.
//
// A light emits radiance L from its OUTER side only: a sphere outwards, a quad or
// a triangle on the side of its normal n = normalize(e1 x e2). L is constant,
// except on a triangle of an emissive mesh with an emission texture, where the
// texture (looked up by the integrator at the sampled point) multiplies it.
// The environment is a light too (type Environment), sampled by
// core/environment.h whatever the strategy: the strategies compare ways of
// sampling lights with a surface.
#pragma once

#include "common.h"
#include "geometry.h"
#include "sampling.h"
#include "vec.h"

namespace pn {

enum class LightType : uint32_t { Sphere = 0, Quad = 1, Triangle = 2, Environment = 3 };

struct Light {
  LightType type = LightType::Sphere;
  Vec3 radiance;  // L, constant over the surface
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

// A direction towards a light, with what is needed to evaluate and shadow-test it.
struct LightSample {
  Vec3 wi;          // unit direction from the shading point towards the light
  Vec3 y;           // the sampled point on the light (the shadow ray's target)
  float dist = 0.f; // distance to y
  Vec3 L;           // radiance arriving along wi (if unoccluded)
  float pdf = 0.f;  // solid-angle density of wi; 0 means "no sample"
  Vec2 b;           // triangle lights: barycentrics (b1, b2) of y, for textured emission
  bool infinite = false;  // environment: y is at infinity, the shadow ray is unbounded
};

// Converts a density over the light's area at point y (normal ny) into a density
// over directions at x:  p_w = p_A * d^2 / |cos theta_light|. A point whose
// emitting side faces away from x contributes nothing and yields pdf 0.
PN_FN LightSample area_to_solid_angle(Vec3 x, Vec3 y, Vec3 ny, float pdf_area, Vec3 radiance) {
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
  s.L = radiance;
  s.pdf = pdf_area * dist2 / cos_light;
  return s;
}

// --- Strategy A: uniform area sampling ----------------------------------------
// Sphere: y uniform over the whole sphere, p_A = 1 / (4 pi r^2); about half of the
// samples land on the far side and are wasted. Quad and triangle: y uniform,
// p_A = 1 / A. (Emissive meshes are many triangle lights: every strategy samples
// them this way.)
PN_FN LightSample sample_light_area(const Light& light, Vec3 x, Vec2 u) {
  if (light.type == LightType::Sphere) {
    Vec3 n = sample_uniform_sphere(u);
    Vec3 y = light.p + n * light.radius;
    return area_to_solid_angle(x, y, n, 1.f / light.area, light.radiance);
  }
  if (light.type == LightType::Triangle) {
    Vec2 b = sample_uniform_triangle(u);
    Vec3 y = light.p + light.e1 * b.x + light.e2 * b.y;
    LightSample s = area_to_solid_angle(x, y, light.n, 1.f / light.area, light.radiance);
    s.b = b;
    return s;
  }
  Vec3 y = sample_uniform_parallelogram(u, light.p, light.e1, light.e2);
  return area_to_solid_angle(x, y, light.n, 1.f / light.area, light.radiance);
}

// --- Strategy B: uniform sampling of the subtended cone (spheres) -------------
// sin theta_max = r / d, p_w = 1 / (2 pi (1 - cos theta_max)) over the cone, so
// the estimator L cos / p_w has no 1/d^2 term and never misses the light.
// For tiny cones (sin^2 theta_max below sin^2 1.5 deg) 1 - cos theta_max is
// computed from its Taylor series r^2/(2 d^2) to avoid cancellation. The sampled
// point on the sphere is computed from the angle alpha at the centre, which is
// exact where intersecting the sampled ray with the sphere would lose precision
// (pbrt-v4, Sphere::Sample; Wang 1992). A shading point inside or on the sphere
// sees only its non-emitting inner side: the area strategy handles it (giving
// pdf 0 for every sample) so no NaN arises from sqrt(1 - r^2/d^2).
PN_FN LightSample sample_light_solid_angle(const Light& light, Vec3 x, Vec2 u) {
  if (light.type != LightType::Sphere) return sample_light_area(light, x, u);
  Vec3 to_center = light.p - x;
  float dc2 = dot(to_center, to_center);
  float r2 = light.radius * light.radius;
  if (dc2 <= r2 * 1.00001f) return sample_light_area(light, x, u);
  float dc = std::sqrt(dc2);
  float sin2_max = r2 / dc2;
  float sin_max = std::sqrt(sin2_max);
  float cos_max = safe_sqrt(1.f - sin2_max);
  float one_minus_cos_max = 1.f - cos_max;
  float cos_theta = (cos_max - 1.f) * u.x + 1.f;
  float sin2_theta = 1.f - cos_theta * cos_theta;
  if (sin2_max < 0.00068523f) {  // sin^2(1.5 deg): Taylor branch
    sin2_theta = sin2_max * u.x;
    cos_theta = std::sqrt(1.f - sin2_theta);
    one_minus_cos_max = sin2_max * 0.5f;
  }
  // Angle alpha between -to_center and the normal at the sampled point.
  float cos_alpha = sin2_theta / sin_max + cos_theta * safe_sqrt(1.f - sin2_theta / sin2_max);
  float sin_alpha = safe_sqrt(1.f - cos_alpha * cos_alpha);
  float phi = kTwoPi * u.y;
  Frame frame = Frame::from_z(to_center / dc);
  Vec3 n_local(std::cos(phi) * sin_alpha, std::sin(phi) * sin_alpha, cos_alpha);
  Vec3 ny = -frame.to_world(n_local);  // outward normal at the sampled point
  Vec3 y = light.p + ny * light.radius;
  LightSample s;
  Vec3 d = y - x;
  s.dist = length(d);
  if (!(s.dist > 0.f)) return s;
  s.y = y;
  s.wi = d / s.dist;
  s.L = light.radiance;
  s.pdf = 1.f / (kTwoPi * one_minus_cos_max);
  return s;
}

// --- BSDF-only baseline: no light sample --------------------------------------
PN_FN LightSample sample_light_none(const Light&, Vec3, Vec2) { return LightSample(); }

}  // namespace pn
