// The light-sampling strategies penumbra compares, one struct each.
//
// A strategy answers, for every light type with a surface, two questions, as
// pbrt-v4's SampleLi / PDF_Li or Mitsuba's sample_direction / pdf_direction do:
//   sample_<type>(light, ctx, u) -> LightSample {wi, y, pdf, ...}
//   pdf_<type>(light, ctx, wi)   -> the solid-angle density sample_<type> has at wi
// and the two agree (tests/core/test_light_strategies.cpp checks it on random
// configurations, with chi-square tests of the samples against pdf()). MIS needs
// pdf() for directions that BSDF sampling found. The environment is sampled by
// its image for every strategy (core/light_sampler.h); the strategies compare
// ways of sampling lights with a surface.
//
// To add a strategy: a struct here with the six functions below, and one line in
// PN_STRATEGIES (core/strategy.h). Where a strategy has no exact method for a
// light type it calls another strategy's, and says so in its registry line.
//
//   area                   uniform over the light's area (thesis strategy A)
//   solid-angle            uniform in the light's solid angle (strategy B): the
//                          sphere's cone; a rectangle's spherical rectangle
//                          (Urena et al. 2013); a triangle's spherical triangle
//                          (Arvo 1995); other parallelograms as two spherical
//                          triangles, chosen by their solid angles
//   projected-solid-angle  density proportional to cos(theta) at the shading
//                          point over the light's solid angle: the sphere's
//                          projected cap, exact (core/projected_cap.h);
//                          polygons by the bilinear cosine warp of their
//                          spherical rectangle/triangle's parameters (Hart et
//                          al. 2020, as pbrt-v4): an exact pdf, a density only
//                          approximately proportional to cos(theta)
//   bsdf                   no light sampling
//
// Spherical polygons are sampled only where their solid angle lies in
// [kMinSphericalSolidAngle, kMaxSphericalSolidAngle] sr (pbrt-v4's bounds):
// below, float cannot resolve their parametrization; above (a polygon filling
// nearly the hemisphere), the spherical-triangle formulas lose their precision.
// Outside those bounds both polygon strategies sample by area, in sample() and
// pdf() alike, so the pair stays consistent across the threshold.
#pragma once

#include "common.h"
#include "lights.h"
#include "projected_cap.h"
#include "sampling.h"
#include "spherical_polygons.h"
#include "vec.h"

namespace pn {

constexpr float kMinSphericalSolidAngle = 3e-4f;
constexpr float kMaxSphericalSolidAngle = 6.22f;

// --- area ------------------------------------------------------------------------

struct AreaSampling {
  // A point uniform over the whole sphere, p_A = 1 / (4 pi r^2): about half of
  // them lie on the far side, face away and are wasted (pdf 0).
  PN_FN static LightSample sample_sphere(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    Vec3 n = sample_uniform_sphere(u);
    return area_to_solid_angle(ctx.p, l.p + n * l.radius, n, 1.f / l.area);
  }
  PN_FN static float pdf_sphere(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    float t;
    if (!sphere_light_distance(l, ctx.p, wi, &t, false)) return 0.f;
    Vec3 ny = (ctx.p + wi * t - l.p) / l.radius;
    return area_pdf_to_solid_angle(1.f / l.area, t, ny, wi);
  }
  PN_FN static LightSample sample_quad(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    return area_to_solid_angle(ctx.p, sample_uniform_parallelogram(u, l.p, l.e1, l.e2), l.n, 1.f / l.area);
  }
  PN_FN static float pdf_quad(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    float t;
    return quad_light_distance(l, ctx.p, wi, &t) ? area_pdf_to_solid_angle(1.f / l.area, t, l.n, wi) : 0.f;
  }
  PN_FN static LightSample sample_triangle(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    Vec2 b = sample_uniform_triangle(u);
    LightSample s = area_to_solid_angle(ctx.p, l.p + l.e1 * b.x + l.e2 * b.y, l.n, 1.f / l.area);
    s.b = b;
    return s;
  }
  PN_FN static float pdf_triangle(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    float t;
    Vec2 b;
    return triangle_light_distance(l, ctx.p, wi, &t, &b) ? area_pdf_to_solid_angle(1.f / l.area, t, l.n, wi) : 0.f;
  }
};

// --- Spherical polygons: the shared machinery of solid-angle and projected-solid-angle

// The solid angle of a quad or triangle light at x (float, Van Oosterom &
// Strackee per triangle): what decides between spherical and area sampling,
// and the density 1 / Omega both sample() and pdf() report.
PN_FN float planar_light_solid_angle(const Light& l, Vec3 x) {
  const Vec3 a = l.p - x, b = a + l.e1, c = a + l.e2;
  if (l.type == LightType::Triangle) return triangle_solid_angle(a, b, c);
  const Vec3 d = b + l.e2;  // the far corner
  return triangle_solid_angle(a, b, d) + triangle_solid_angle(a, d, c);
}

// The same light as spherical polygons for the samplers: one spherical
// rectangle, one spherical triangle, or (a parallelogram that is not a
// rectangle) two spherical triangles (p, p+e1, p+e1+e2) and (p, p+e1+e2, p+e2).
struct SphericalLight {
  enum Kind : uint32_t { kRectangle, kTriangle, kTwoTriangles } kind = kTriangle;
  SphericalRectangle rect;
  SphericalTriangle tri[2];
  float area = 0.f;  // total solid angle: planar_light_solid_angle()
};

PN_FN bool spherical_sampling_applies(float solid_angle) {
  return solid_angle >= kMinSphericalSolidAngle && solid_angle <= kMaxSphericalSolidAngle;
}

PN_FN SphericalLight make_spherical_light(const Light& l, Vec3 x, float solid_angle) {
  SphericalLight s;
  s.area = solid_angle;
  if (l.type == LightType::Triangle) {
    s.kind = SphericalLight::kTriangle;
    s.tri[0] = make_spherical_triangle(x, l.p, l.p + l.e1, l.p + l.e2);
  } else if (quad_is_rectangle(l)) {
    s.kind = SphericalLight::kRectangle;
    s.rect = make_spherical_rectangle(x, l.p, l.e1, l.e2);
  } else {
    s.kind = SphericalLight::kTwoTriangles;
    const Vec3 p2 = l.p + l.e1 + l.e2;
    s.tri[0] = make_spherical_triangle(x, l.p, l.p + l.e1, p2);
    s.tri[1] = make_spherical_triangle(x, l.p, p2, l.p + l.e2);
  }
  return s;
}

// Hart et al. 2020's warp: the bilinear interpolation of cos(theta) at the
// corners of the sampler's parameter square. The corners of Urena's square are
// the rectangle's corners p, p+e1, p+e2, p+e1+e2 (u = (0,0), (1,0), (0,1), (1,1));
// those of Arvo's are b, b, a, c (u.y = 0 is vertex b for any u.x). A corner
// below the horizon gets a small positive weight, so that the density stays
// positive wherever the polygon is. False: the whole polygon is below the
// horizon (the integrand is 0 there: no sample).
PN_FN bool cosine_warp_weights(Vec3 x, Vec3 n, Vec3 c00, Vec3 c10, Vec3 c01, Vec3 c11, float w[4]) {
  const Vec3 c[4] = {c00, c10, c01, c11};
  float top = 0.f;
  for (int i = 0; i < 4; ++i) {
    w[i] = dot(n, normalize(c[i] - x));
    top = pn_max(top, w[i]);
  }
  if (!(top > 0.f)) return false;
  for (int i = 0; i < 4; ++i) w[i] = pn_max(w[i], 0.01f);
  return true;
}
PN_FN bool triangle_warp_weights(const Light& l, const LightSampleContext& ctx, int which, float w[4]) {
  // Vertices of spherical triangle `which`: (a, b, c) as make_spherical_light built them.
  Vec3 a = l.p, b, c;
  if (l.type == LightType::Triangle) {
    b = l.p + l.e1;
    c = l.p + l.e2;
  } else if (which == 0) {
    b = l.p + l.e1;
    c = l.p + l.e1 + l.e2;
  } else {
    b = l.p + l.e1 + l.e2;
    c = l.p + l.e2;
  }
  return cosine_warp_weights(ctx.p, ctx.n, b, b, a, c, w);
}

// The point where direction w from x meets a planar light's plane, with the
// barycentrics of a triangle light; clamped onto the light, so that the shadow
// ray ends on it even where rounding put the direction a hair outside.
PN_FN LightSample planar_sample_from_direction(const Light& l, Vec3 x, Vec3 w, float pdf) {
  LightSample s;
  float t;
  Vec2 ab;
  if (!planar_light_hit(l, x, w, &t, &ab)) return s;
  if (l.type == LightType::Triangle) {
    ab = clamp_barycentrics(ab);
    s.b = ab;
  } else {
    ab = Vec2(clamp(ab.x, 0.f, 1.f), clamp(ab.y, 0.f, 1.f));
  }
  s.y = l.p + l.e1 * ab.x + l.e2 * ab.y;
  const Vec3 d = s.y - x;
  s.dist = length(d);
  if (!(s.dist > 0.f)) return LightSample();
  s.wi = d / s.dist;
  s.pdf = pdf;
  return s;
}

// Solid-angle (kProjected = false) or warped projected-solid-angle sampling of a
// quad or triangle light; area sampling outside the solid-angle bounds.
template <bool kProjected>
PN_FN LightSample sample_spherical_polygon(const Light& l, const LightSampleContext& ctx, Vec2 u) {
  if (!faces_emitting_side(l, ctx.p)) return LightSample();
  const float omega = planar_light_solid_angle(l, ctx.p);
  if (!spherical_sampling_applies(omega))
    return l.type == LightType::Triangle ? AreaSampling::sample_triangle(l, ctx, u) : AreaSampling::sample_quad(l, ctx, u);
  const SphericalLight s = make_spherical_light(l, ctx.p, omega);
  float warp_pdf = 1.f;
  if (s.kind == SphericalLight::kRectangle) {
    if (kProjected) {
      float w[4];
      if (!cosine_warp_weights(ctx.p, ctx.n, l.p, l.p + l.e1, l.p + l.e2, l.p + l.e1 + l.e2, w)) return LightSample();
      u = sample_bilinear(u, w);
      warp_pdf = bilinear_pdf(u, w);
    }
    const Vec3 y = sample_spherical_rectangle(s.rect, u);
    LightSample ls;
    const Vec3 d = y - ctx.p;
    ls.dist = length(d);
    if (!(ls.dist > 0.f)) return LightSample();
    ls.y = y;
    ls.wi = d / ls.dist;
    ls.pdf = warp_pdf / s.area;
    return ls;
  }
  int which = 0;
  if (s.kind == SphericalLight::kTwoTriangles) {  // choose a triangle by its solid angle, reuse u.x
    const float p0 = s.tri[0].area / (s.tri[0].area + s.tri[1].area);
    if (u.x < p0) {
      u.x = pn_min(u.x / p0, kOneMinusEpsilon);
    } else {
      which = 1;
      u.x = pn_min((u.x - p0) / (1.f - p0), kOneMinusEpsilon);
    }
  }
  // Chosen by value: an index into s.tri would put the whole light in local memory on the GPU.
  const SphericalTriangle tri = which ? s.tri[1] : s.tri[0];
  if (!(tri.area > 0.f)) return LightSample();
  if (kProjected) {
    float w[4];
    if (!triangle_warp_weights(l, ctx, which, w)) return LightSample();
    u = sample_bilinear(u, w);
    warp_pdf = bilinear_pdf(u, w);
  }
  // For two triangles: P(triangle) * warp / its area = warp / total area.
  return planar_sample_from_direction(l, ctx.p, sample_spherical_triangle(tri, u), warp_pdf / s.area);
}

template <bool kProjected>
PN_FN float pdf_spherical_polygon(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
  if (!faces_emitting_side(l, ctx.p)) return 0.f;
  const float omega = planar_light_solid_angle(l, ctx.p);
  if (!spherical_sampling_applies(omega))
    return l.type == LightType::Triangle ? AreaSampling::pdf_triangle(l, ctx, wi) : AreaSampling::pdf_quad(l, ctx, wi);
  float t;
  Vec2 ab;
  if (!planar_light_hit(l, ctx.p, wi, &t, &ab)) return 0.f;
  const bool inside = l.type == LightType::Triangle ? (ab.x >= 0.f && ab.y >= 0.f && ab.x + ab.y <= 1.f)
                                                    : (ab.x >= 0.f && ab.x <= 1.f && ab.y >= 0.f && ab.y <= 1.f);
  if (!inside) return 0.f;
  if (!kProjected) return 1.f / omega;  // no parametrization needed: the density is uniform
  const SphericalLight s = make_spherical_light(l, ctx.p, omega);
  float w[4];
  Vec2 u;
  if (s.kind == SphericalLight::kRectangle) {
    if (!cosine_warp_weights(ctx.p, ctx.n, l.p, l.p + l.e1, l.p + l.e2, l.p + l.e1 + l.e2, w)) return 0.f;
    u = invert_spherical_rectangle_sample(s.rect, ctx.p + wi * t);
  } else {
    // Of two triangles, (p, p+e1, p+e1+e2) holds the points with b <= a.
    const int which = (s.kind == SphericalLight::kTwoTriangles && ab.y > ab.x) ? 1 : 0;
    if (!triangle_warp_weights(l, ctx, which, w)) return 0.f;
    const SphericalTriangle tri = which ? s.tri[1] : s.tri[0];  // by value, as in sample_spherical_polygon
    u = invert_spherical_triangle_sample(tri, wi);
  }
  return bilinear_pdf(u, w) / s.area;
}

// The quad and triangle functions of the two spherical strategies.
template <bool kProjected>
struct SphericalPolygonSampling {
  PN_FN static LightSample sample_quad(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    return sample_spherical_polygon<kProjected>(l, ctx, u);
  }
  PN_FN static float pdf_quad(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    return pdf_spherical_polygon<kProjected>(l, ctx, wi);
  }
  PN_FN static LightSample sample_triangle(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    return sample_spherical_polygon<kProjected>(l, ctx, u);
  }
  PN_FN static float pdf_triangle(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    return pdf_spherical_polygon<kProjected>(l, ctx, wi);
  }
};

// --- solid-angle ----------------------------------------------------------------

struct SolidAngleSampling : SphericalPolygonSampling<false> {
  // Uniform in the cone the sphere subtends, sin theta_max = r / d, so the
  // estimator L cos / p_w has no 1/d^2 term and never misses the light. The
  // point on the sphere comes from the angle alpha at the centre, exact where
  // intersecting the sampled ray with the sphere would lose precision
  // (pbrt-v4's Sphere::Sample; Wang 1992). From inside or on the sphere only
  // its non-emitting inner side is seen: area sampling gives pdf 0 there.
  PN_FN static LightSample sample_sphere(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    const Vec3 to_center = l.p - ctx.p;
    const float dc2 = dot(to_center, to_center), r2 = l.radius * l.radius;
    if (dc2 <= r2 * 1.00001f) return AreaSampling::sample_sphere(l, ctx, u);
    const float dc = std::sqrt(dc2);
    const float sin2_max = r2 / dc2, sin_max = std::sqrt(sin2_max);
    const Cone cone = make_cone(sin2_max);
    const ConeSample cs = sample_uniform_cone(u, cone);
    // Angle alpha between -to_center and the normal at the sampled point.
    const float cos_alpha =
        cs.sin2_theta / sin_max + cs.cos_theta * safe_sqrt(1.f - cs.sin2_theta / sin2_max);
    const float sin_alpha = safe_sqrt(1.f - cos_alpha * cos_alpha);
    const Frame frame = Frame::from_z(to_center / dc);
    const Vec3 n_local(std::cos(cs.phi) * sin_alpha, std::sin(cs.phi) * sin_alpha, cos_alpha);
    const Vec3 ny = -frame.to_world(n_local);  // outward normal at the sampled point
    LightSample s;
    s.y = l.p + ny * l.radius;
    const Vec3 d = s.y - ctx.p;
    s.dist = length(d);
    if (!(s.dist > 0.f)) return LightSample();
    s.wi = d / s.dist;
    s.pdf = uniform_cone_pdf(cone);
    return s;
  }
  PN_FN static float pdf_sphere(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    const Vec3 to_center = l.p - ctx.p;
    const float dc2 = dot(to_center, to_center), r2 = l.radius * l.radius;
    if (dc2 <= r2 * 1.00001f) return AreaSampling::pdf_sphere(l, ctx, wi);
    const Cone cone = make_cone(r2 / dc2);
    const Vec3 axis = to_center / std::sqrt(dc2);
    if (!(dot(wi, axis) > 0.f) || length_sq(cross(wi, axis)) > cone_containment_bound(cone)) return 0.f;
    return uniform_cone_pdf(cone);
  }
};

// --- projected-solid-angle -----------------------------------------------------------

struct ProjectedSolidAngleSampling : SphericalPolygonSampling<true> {
  // The projected spherical cap (core/projected_cap.h); the point on the sphere
  // where the sampled direction enters it.
  PN_FN static LightSample sample_sphere(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    const Vec3 to_center = l.p - ctx.p;
    const float dc2 = dot(to_center, to_center), r2 = l.radius * l.radius;
    if (dc2 <= r2 * 1.00001f) return AreaSampling::sample_sphere(l, ctx, u);
    const ProjectedCap cap = make_projected_cap(to_center / std::sqrt(dc2), r2 / dc2, ctx.n);
    LightSample s;
    Vec3 w;
    float pdf, t;
    if (!sample_projected_cap(cap, u, &w, &pdf)) return s;
    if (!sphere_light_distance(l, ctx.p, w, &t, true)) return s;
    s.wi = w;
    s.y = ctx.p + w * t;
    s.dist = t;
    s.pdf = pdf;
    return s;
  }
  PN_FN static float pdf_sphere(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    const Vec3 to_center = l.p - ctx.p;
    const float dc2 = dot(to_center, to_center), r2 = l.radius * l.radius;
    if (dc2 <= r2 * 1.00001f) return AreaSampling::pdf_sphere(l, ctx, wi);
    return projected_cap_pdf(make_projected_cap(to_center / std::sqrt(dc2), r2 / dc2, ctx.n), wi);
  }
};

// --- bsdf: no light sampling ------------------------------------------------------------

struct NoLightSampling {
  PN_FN static LightSample sample_sphere(const Light&, const LightSampleContext&, Vec2) { return LightSample(); }
  PN_FN static float pdf_sphere(const Light&, const LightSampleContext&, Vec3) { return 0.f; }
  PN_FN static LightSample sample_quad(const Light&, const LightSampleContext&, Vec2) { return LightSample(); }
  PN_FN static float pdf_quad(const Light&, const LightSampleContext&, Vec3) { return 0.f; }
  PN_FN static LightSample sample_triangle(const Light&, const LightSampleContext&, Vec2) { return LightSample(); }
  PN_FN static float pdf_triangle(const Light&, const LightSampleContext&, Vec3) { return 0.f; }
};

}  // namespace pn
