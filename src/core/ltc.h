// The `ltc` strategy: BRDF importance sampling of polygon lights with linearly
// transformed cosines (Peters, "BRDF Importance Sampling for Polygonal Lights",
// SIGGRAPH 2021; the LTCs of Heitz, Dupuy, Hill & Neubelt 2016).
//
// An LTC is the clamped cosine D_o(w_o) = max(0, w_o.z) / pi seen through a
// matrix M: its density is D(w) = D_o(Minv w / |Minv w|) det(Minv) / |Minv w|^3.
// scripts/fit_ltc.py fits one to the GGX lobe of core/material.h for each view
// angle and roughness (core/ltc_table.h), in the frame where z is the shading
// normal and wo lies in the xz plane (x towards wo). Because Minv is linear, a
// planar polygon stays a planar polygon under it, with the same affine
// coordinates for corresponding points: sampling D restricted to a light is
// sampling a cosine-weighted direction towards the transformed polygon
// ("cosine space"), which penumbra's projected-solid-angle sampler does (the
// bilinear cosine warp of the polygon's spherical rectangle or triangles, Hart et
// al. 2020), and mapping the point back by its affine coordinates. The density
// is exact: the cosine-space sampler's, times the Jacobian det(Minv) / |Minv w|^3.
// (Peters samples the cosine-space polygon exactly by its projected solid angle;
// the warp is an approximation of that density, never of the pdf.)
//
// As in the paper, the LTC sample is one technique of two, combined by
// one-sample MIS with the balance heuristic (a mixture): with probability q the
// LTC, else projected-solid-angle sampling of the light itself (the diffuse
// lobe's ideal). q weighs the specular lobe's estimated contribution,
// F(cos_o) rho E_ltc, against the diffuse one, kd E_cos, where E is the light's
// form factor in cosine space and in the shading frame (clipped to the horizon,
// closed form), rho the lobe's albedo; q is kept in [0.05, 0.95] where there is
// a specular lobe, so that each technique covers what the other's support
// misses, and is 0 without one (a Lambertian surface samples exactly as
// projected-solid-angle does). Sphere lights use projected-solid-angle sampling
// (the exact projected cap): the LTC of a sphere's cap is not a polygon.
#pragma once

#include "common.h"
#include "light_strategies.h"
#include "lights.h"
#include "ltc_table.h"
#include "vec.h"

namespace pn {

#if defined(__CUDACC__)
static __device__ const float kLtcTableDevice[] = {PN_LTC_TABLE_DATA};
#endif
static const float kLtcTableHost[] = {PN_LTC_TABLE_DATA};
constexpr int kLtcTableSize = PN_LTC_TABLE_SIZE;
constexpr int kLtcCell = 5;  // a, b, c, d, rho

// Minv = [[a, 0, b], [0, c, 0], [d, 0, 1]] in the lobe's frame, and the lobe's albedo (F = 1).
struct Ltc {
  float a = 1.f, b = 0.f, c = 1.f, d = 0.f;
  float rho = 0.f;
  PN_FN Vec3 inverse(Vec3 w) const { return Vec3(a * w.x + b * w.z, c * w.y, d * w.x + w.z); }
  PN_FN float det_inverse() const { return c * (a - b * d); }
};

// The table's LTC for GGX alpha and the view's cosine, bilinear between cells.
PN_FN Ltc ltc_lookup(float alpha, float cos_o) {
#if defined(__CUDA_ARCH__)
  const float* table = kLtcTableDevice;
#else
  const float* table = kLtcTableHost;
#endif
  constexpr float kLast = float(kLtcTableSize - 1);
  const float x = clamp(std::sqrt(pn_max(alpha, 0.f)) * kLast, 0.f, kLast);
  const float y = clamp(safe_sqrt(1.f - cos_o) * kLast, 0.f, kLast);
  const int i0 = pn_min(int(x), kLtcTableSize - 2), j0 = pn_min(int(y), kLtcTableSize - 2);
  const float fx = x - float(i0), fy = y - float(j0);
  float v[kLtcCell];
  for (int k = 0; k < kLtcCell; ++k) {
    const float v00 = table[(i0 * kLtcTableSize + j0) * kLtcCell + k];
    const float v01 = table[(i0 * kLtcTableSize + j0 + 1) * kLtcCell + k];
    const float v10 = table[((i0 + 1) * kLtcTableSize + j0) * kLtcCell + k];
    const float v11 = table[((i0 + 1) * kLtcTableSize + j0 + 1) * kLtcCell + k];
    v[k] = (1.f - fx) * ((1.f - fy) * v00 + fy * v01) + fx * ((1.f - fy) * v10 + fy * v11);
  }
  Ltc l;
  l.a = v[0];
  l.b = v[1];
  l.c = v[2];
  l.d = v[3];
  l.rho = v[4];
  return l;
}

// --- Form factors: the cosine-weighted solid angle of a polygon, / pi ---------------------------------------

// The polygon v[0..n) (directions from the shading point, n <= 4) clipped to z >= 0; returns the count (<= 5).
PN_FN int clip_polygon_to_horizon(const Vec3* v, int n, Vec3* out) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3 a = v[i], b = v[i + 1 < n ? i + 1 : 0];
    if (a.z >= 0.f) out[m++] = a;
    if ((a.z >= 0.f) != (b.z >= 0.f)) out[m++] = a + (b - a) * (a.z / (a.z - b.z));
  }
  return m;
}

// Lambert's formula: (1 / 2 pi) |sum over edges of theta_e (v_i x v_j / |v_i x v_j|) . z| for the polygon's part
// above the horizon, its angles by atan2 (accurate for short edges).
PN_FN float polygon_form_factor(const Vec3* v, int n) {
  Vec3 c[5];
  const int m = clip_polygon_to_horizon(v, n, c);
  if (m < 3) return 0.f;
  float sum = 0.f;
  for (int i = 0; i < m; ++i) {
    const Vec3 a = normalize(c[i]), b = normalize(c[i + 1 < m ? i + 1 : 0]);
    const Vec3 x = cross(a, b);
    const float s = length(x);
    if (s > 0.f) sum += std::atan2(s, dot(a, b)) * (x.z / s);
  }
  return std::fabs(sum) * kInvTwoPi;
}

// A quad's or triangle's corners relative to the shading point, in `frame`; returns the count.
PN_FN int light_polygon(const Light& l, Vec3 x, const Frame& frame, Vec3 v[4]) {
  const int n = l.type == LightType::Triangle ? 3 : 4;
  const Vec3 p = l.p - x;
  v[0] = p;
  v[1] = p + l.e1;
  if (n == 3) {
    v[2] = p + l.e2;
  } else {
    v[2] = p + l.e1 + l.e2;
    v[3] = p + l.e2;
  }
  for (int i = 0; i < n; ++i) v[i] = frame.to_local(v[i]);
  return n;
}

// --- The lobe at a shading point ------------------------------------------------------------------------------

// The LTC of the specular lobe at ctx, its frame, and the probability q of sampling it for light l.
struct LtcLobe {
  Frame frame;  // z: the shading normal; x: towards wo
  Ltc ltc;
  bool specular = false;
  // A world vector in cosine space: into the lobe's frame, then through Minv.
  PN_FN Vec3 to_cosine(Vec3 w) const { return ltc.inverse(frame.to_local(w)); }
  // A cosine-space density as a solid-angle density at the unit world direction whose cosine-space vector is
  // v = to_cosine(w): times the Jacobian d w_o / d w = det(Minv) / |v|^3.
  PN_FN float solid_angle_pdf(float cosine_pdf, Vec3 v) const {
    const float len2 = dot(v, v);
    return cosine_pdf * ltc.det_inverse() / (len2 * std::sqrt(len2));
  }
};

PN_FN LtcLobe make_ltc_lobe(const LightSampleContext& ctx) {
  LtcLobe lobe;
  const float cos_o = dot(ctx.wo, ctx.n);
  if (!(ctx.specular > 0.f) || !(cos_o > 0.f)) return lobe;
  const Vec3 t = ctx.wo - ctx.n * cos_o;
  const float tl = length(t);
  if (tl > 1e-6f) {
    lobe.frame.n = ctx.n;
    lobe.frame.s = t / tl;
    lobe.frame.t = cross(ctx.n, lobe.frame.s);
  } else {
    lobe.frame = Frame::from_z(ctx.n);  // wo along the normal: the lobe is symmetric about it
  }
  lobe.ltc = ltc_lookup(ctx.alpha, cos_o);
  lobe.specular = true;
  return lobe;
}

// The probability of the LTC technique for light l: 0 without a specular lobe.
PN_FN float ltc_probability(const Light& l, const LightSampleContext& ctx, const LtcLobe& lobe) {
  if (!lobe.specular) return 0.f;
  Vec3 v[4];
  const int n = light_polygon(l, ctx.p, lobe.frame, v);
  const float diffuse = ctx.diffuse * polygon_form_factor(v, n);
  for (int i = 0; i < n; ++i) v[i] = lobe.ltc.inverse(v[i]);
  const float specular = ctx.specular * lobe.ltc.rho * polygon_form_factor(v, n);
  const float total = diffuse + specular;
  return clamp(total > 0.f ? specular / total : 0.5f, 0.05f, 0.95f);
}

// The light in cosine space: its corner and edges through Minv (the shading point at the origin), the normal of
// its emitting side kept on the same side (det(Minv) > 0 keeps the orientation of e1 x e2).
PN_FN Light ltc_space_light(const Light& l, Vec3 x, const LtcLobe& lobe) {
  Light c = l;
  c.p = lobe.to_cosine(l.p - x);
  c.e1 = lobe.to_cosine(l.e1);
  c.e2 = lobe.to_cosine(l.e2);
  const Vec3 n = cross(c.e1, c.e2);
  const float len = length(n);
  const float side = dot(cross(l.e1, l.e2), l.n) >= 0.f ? 1.f : -1.f;
  c.n = n * (side / len);
  c.area = l.type == LightType::Triangle ? 0.5f * len : len;
  return c;
}

// The LTC technique's density at world direction wi: the cosine-space sampler's at Minv wi, times the Jacobian.
PN_FN float ltc_technique_pdf(const Light& l, const LightSampleContext& ctx, const LtcLobe& lobe, Vec3 wi) {
  const Light c = ltc_space_light(l, ctx.p, lobe);
  if (!(c.area > 0.f)) return 0.f;
  const LightSampleContext cosine_ctx{Vec3(0.f), Vec3(0.f, 0.f, 1.f)};
  const Vec3 v = lobe.to_cosine(wi);
  return lobe.solid_angle_pdf(pdf_spherical_polygon<true>(c, cosine_ctx, v / length(v)), v);
}

// A sample of the LTC technique: a cosine-space sample of the transformed light, mapped back by its affine
// coordinates on the light; its pdf is the LTC technique's alone (the caller mixes).
PN_FN LightSample ltc_technique_sample(const Light& l, const LightSampleContext& ctx, const LtcLobe& lobe, Vec2 u) {
  const Light c = ltc_space_light(l, ctx.p, lobe);
  if (!(c.area > 0.f)) return LightSample();
  const LightSampleContext cosine_ctx{Vec3(0.f), Vec3(0.f, 0.f, 1.f)};
  const LightSample cs = sample_spherical_polygon<true>(c, cosine_ctx, u);
  if (!(cs.pdf > 0.f)) return LightSample();
  const Vec2 ab = plane_coordinates(c.e1, c.e2, cs.y - c.p);
  const Vec3 d = l.p + l.e1 * ab.x + l.e2 * ab.y - ctx.p;
  const float dist = length(d);
  if (!(dist > 0.f)) return LightSample();
  const Vec3 wi = d / dist;
  return planar_sample_from_direction(l, ctx.p, wi, lobe.solid_angle_pdf(cs.pdf, lobe.to_cosine(wi)));
}

struct LtcSampling {
  PN_FN static LightSample sample_sphere(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    return ProjectedSolidAngleSampling::sample_sphere(l, ctx, u);
  }
  PN_FN static float pdf_sphere(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    return ProjectedSolidAngleSampling::pdf_sphere(l, ctx, wi);
  }
  PN_FN_CALLED static LightSample sample_polygon(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    if (!faces_emitting_side(l, ctx.p)) return LightSample();
    const LtcLobe lobe = make_ltc_lobe(ctx);
    const float q = ltc_probability(l, ctx, lobe);
    if (!(q > 0.f)) return sample_spherical_polygon<true>(l, ctx, u);
    // The mixture's density: the sampled technique's own density is the sample's; only the other's is evaluated.
    LightSample s;
    float p_ltc, p_polygon;
    if (u.x < q) {
      u.x = pn_min(u.x / q, kOneMinusEpsilon);
      s = ltc_technique_sample(l, ctx, lobe, u);
      if (!(s.pdf > 0.f)) return LightSample();
      p_ltc = s.pdf;
      p_polygon = pdf_spherical_polygon<true>(l, ctx, s.wi);
    } else {
      u.x = pn_min((u.x - q) / (1.f - q), kOneMinusEpsilon);
      s = sample_spherical_polygon<true>(l, ctx, u);
      if (!(s.pdf > 0.f)) return LightSample();
      p_polygon = s.pdf;
      p_ltc = ltc_technique_pdf(l, ctx, lobe, s.wi);
    }
    s.pdf = q * p_ltc + (1.f - q) * p_polygon;
    return s.pdf > 0.f ? s : LightSample();
  }
  PN_FN_CALLED static float pdf_polygon(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    if (!faces_emitting_side(l, ctx.p)) return 0.f;
    const LtcLobe lobe = make_ltc_lobe(ctx);
    const float q = ltc_probability(l, ctx, lobe);
    if (!(q > 0.f)) return pdf_spherical_polygon<true>(l, ctx, wi);
    return mixture_pdf(l, ctx, lobe, q, wi);
  }
  PN_FN static float mixture_pdf(const Light& l, const LightSampleContext& ctx, const LtcLobe& lobe, float q, Vec3 wi) {
    return q * ltc_technique_pdf(l, ctx, lobe, wi) + (1.f - q) * pdf_spherical_polygon<true>(l, ctx, wi);
  }
  PN_FN static LightSample sample_quad(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    return sample_polygon(l, ctx, u);
  }
  PN_FN static float pdf_quad(const Light& l, const LightSampleContext& ctx, Vec3 wi) { return pdf_polygon(l, ctx, wi); }
  PN_FN static LightSample sample_triangle(const Light& l, const LightSampleContext& ctx, Vec2 u) {
    return sample_polygon(l, ctx, u);
  }
  PN_FN static float pdf_triangle(const Light& l, const LightSampleContext& ctx, Vec3 wi) {
    return pdf_polygon(l, ctx, wi);
  }
};

}  // namespace pn
