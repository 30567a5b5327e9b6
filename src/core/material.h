// Materials: the metallic-roughness model of glTF 2.0, as a BSDF.
//
//   f(wo, wi) = (1 - m) c / pi * (1 - F_d(cos_o)) (1 - F_d(cos_i))      diffuse
//             + D(h) G2(wo, wi) F(wo . h) / (4 cos_o cos_i)            GGX specular
//   F = (1 - m) F_d + m F_c
//
// c is the base colour, m the metallic factor, F_c Schlick's Fresnel with
// F0 = c (the metal), F_d Schlick's with F0 = 0.08 * specular (the dielectric's
// coat; F_d = 0 when specular = 0: no coat at all).
// D is the isotropic GGX (Trowbridge-Reitz) distribution with alpha =
// roughness^2, G2 Smith's height-correlated masking-shadowing (Heitz 2014).
// The diffuse term loses what the dielectric's Fresnel reflects, on the way in
// and on the way out, so that the sum never reflects more than arrives (tested
// by a white furnace for every combination of parameters in test_material.cpp).
// With specular = 0 and metallic = 0 the BSDF is exactly Lambert's, c / pi: the
// Cornell-box scenes of the thesis use that.
//
// Sampling picks one lobe with a probability from the lobes' estimated albedos
// and returns f cos / p with p the mixture of both lobes' densities (one-sample
// MIS with the balance heuristic). The specular lobe samples visible normals
// (Heitz 2018, "Sampling the GGX Distribution of Visible Normals").
//
// The BSDF is two-sided and works in a shading frame: the shading normal faces
// the side wo lies on. A direction below the GEOMETRIC surface gets f = 0, so
// that interpolated or normal-mapped shading normals never leak light through
// a surface.
#pragma once

#include "common.h"
#include "sampling.h"
#include "vec.h"

namespace pn {

enum class AlphaMode : uint32_t { Opaque = 0, Mask = 1 };

// A material as scenes and model files describe it. Texture indices are -1 when
// absent; a texture multiplies its factor.
struct Material {
  Vec3 base_color{0.8f};         // c: diffuse albedo of dielectrics, F0 of metals
  float metallic = 0.f;          // m in [0, 1]
  float roughness = 1.f;         // perceptual roughness in [0, 1]; alpha = roughness^2
  float specular = 0.f;          // dielectric F0 = 0.08 * specular; glTF's 0.04 is 0.5; 0 = no coat
  Vec3 emission{0.f};            // emitted radiance (times the emission texture)
  int32_t base_color_tex = -1;   // RGB times base_color, A times alpha
  int32_t metallic_roughness_tex = -1;  // glTF layout: G times roughness, B times metallic
  int32_t normal_tex = -1;       // tangent-space normal map (glTF/OpenGL: +Y is up in the image)
  int32_t emission_tex = -1;     // RGB times emission
  float normal_scale = 1.f;
  float alpha = 1.f;             // coverage; with Mask, a surface point exists where alpha >= alpha_cutoff
  float alpha_cutoff = 0.5f;
  AlphaMode alpha_mode = AlphaMode::Opaque;
};

// A Material resolved at one surface point (textures applied), ready to shade.
struct Bsdf {
  Frame frame;          // shading frame; frame.n faces the side wo is on
  Vec3 ng;              // geometric normal, on the side of wo
  Vec3 diffuse;         // (1 - m) c
  Vec3 metal;           // c: F0 of the metallic part
  float metal_weight = 0.f;   // m
  float coat_weight = 0.f;    // 1 - m with a coat (specular > 0), else 0
  float f0_dielectric = 0.f;  // 0.08 specular: F0 of the coat
  float alpha = 1.f;    // GGX alpha
  bool has_specular = false;
};

// BSDF sample in world space. `weight` is f * |cos| / pdf, the throughput factor.
struct BsdfSample {
  Vec3 wi;
  Vec3 weight;
  float pdf = 0.f;
};

// Smallest GGX alpha: below it the lobe is a near-delta that float cannot
// evaluate reliably; roughness 0 renders as roughness 0.0316.
constexpr float kMinGgxAlpha = 1e-3f;

PN_FN Vec3 schlick_fresnel(Vec3 f0, float cos_theta) {
  float m = clamp(1.f - cos_theta, 0.f, 1.f);
  float m5 = (m * m) * (m * m) * m;
  return f0 + (Vec3(1.f) - f0) * m5;
}
PN_FN float schlick_fresnel(float f0, float cos_theta) {
  float m = clamp(1.f - cos_theta, 0.f, 1.f);
  float m5 = (m * m) * (m * m) * m;
  return f0 + (1.f - f0) * m5;
}

// --- GGX microfacet distribution, in the shading frame (z = normal) ----------

PN_FN float ggx_d(Vec3 h, float alpha) {
  if (h.z <= 0.f) return 0.f;
  float a2 = alpha * alpha;
  // a2 cos^2 + sin^2, written without the cancellation of cos^2 (a2 - 1) + 1,
  // which loses the peak of narrow lobes in float.
  float d = a2 * (h.z * h.z) + (h.x * h.x + h.y * h.y);
  return a2 / (kPi * d * d);
}

// Smith's Lambda for GGX: G1 = 1 / (1 + Lambda).
PN_FN float ggx_lambda(Vec3 w, float alpha) {
  float c2 = w.z * w.z;
  if (c2 <= 0.f) return kInf;
  float tan2 = pn_max(0.f, 1.f - c2) / c2;
  return 0.5f * (std::sqrt(1.f + alpha * alpha * tan2) - 1.f);
}
PN_FN float ggx_g1(Vec3 w, float alpha) { return 1.f / (1.f + ggx_lambda(w, alpha)); }
PN_FN float ggx_g2(Vec3 wo, Vec3 wi, float alpha) {
  return 1.f / (1.f + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
}

// A visible normal for the view direction wo (wo.z > 0); Heitz 2018, listing 1.
PN_FN Vec3 ggx_sample_visible_normal(Vec3 wo, float alpha, Vec2 u) {
  Vec3 vh = normalize(Vec3(alpha * wo.x, alpha * wo.y, wo.z));
  float lensq = vh.x * vh.x + vh.y * vh.y;
  Vec3 t1 = lensq > 0.f ? Vec3(-vh.y, vh.x, 0.f) * (1.f / std::sqrt(lensq)) : Vec3(1.f, 0.f, 0.f);
  Vec3 t2 = cross(vh, t1);
  float r = std::sqrt(u.x);
  float phi = kTwoPi * u.y;
  float p1 = r * std::cos(phi), p2 = r * std::sin(phi);
  float s = 0.5f * (1.f + vh.z);
  p2 = (1.f - s) * safe_sqrt(1.f - p1 * p1) + s * p2;
  Vec3 nh = t1 * p1 + t2 * p2 + vh * safe_sqrt(1.f - p1 * p1 - p2 * p2);
  return normalize(Vec3(alpha * nh.x, alpha * nh.y, pn_max(1e-6f, nh.z)));
}

// Density of visible normal h seen from wo: G1(wo) max(0, wo.h) D(h) / cos_o.
PN_FN float ggx_visible_normal_pdf(Vec3 wo, Vec3 h, float alpha) {
  if (wo.z <= 0.f) return 0.f;
  return ggx_g1(wo, alpha) * pn_max(0.f, dot(wo, h)) * ggx_d(h, alpha) / wo.z;
}

PN_FN Vec3 reflect(Vec3 w, Vec3 n) { return n * (2.f * dot(w, n)) - w; }

// --- The BSDF -----------------------------------------------------------------

// Whether a BSDF has a specular lobe: a metallic part or a coat.
PN_FN bool bsdf_has_specular(float metal_weight, float coat_weight) { return metal_weight > 0.f || coat_weight > 0.f; }

// Builds the BSDF from resolved parameters. ns: shading normal, ng: geometric
// normal, both unit and both already on the side of wo.
PN_FN Bsdf make_bsdf(Vec3 base_color, float metallic, float roughness, float specular, Vec3 ns, Vec3 ng) {
  Bsdf b;
  b.frame = Frame::from_z(ns);
  b.ng = ng;
  metallic = clamp(metallic, 0.f, 1.f);
  float f0d = 0.08f * clamp(specular, 0.f, 1.f);
  b.diffuse = base_color * (1.f - metallic);
  b.metal = base_color;
  b.metal_weight = is_black(base_color) ? 0.f : metallic;
  b.f0_dielectric = f0d;
  b.coat_weight = f0d > 0.f ? 1.f - metallic : 0.f;
  float r = clamp(roughness, 0.f, 1.f);
  b.alpha = pn_max(kMinGgxAlpha, r * r);
  b.has_specular = bsdf_has_specular(b.metal_weight, b.coat_weight);
  return b;
}

// F = (1 - m) F_d + m F_c, at the cosine between wo and the microfacet normal.
PN_FN Vec3 bsdf_fresnel(const Bsdf& b, float cos_theta) {
  Vec3 f = schlick_fresnel(b.metal, cos_theta) * b.metal_weight;
  if (b.coat_weight > 0.f) f += Vec3(schlick_fresnel(b.f0_dielectric, cos_theta) * b.coat_weight);
  return f;
}

// The diffuse term's loss to the coat, (1 - F_d(cos)); 1 without a coat.
//
// The functions below take kSpecular = false where the caller knows that no
// material of the scene has a specular lobe (a coat or a metal): the GGX code
// then compiles away, which keeps the GPU's megakernel small (see
// core/scene_view.h, SceneFeature).
template <bool kSpecular = true>
PN_FN float bsdf_coat_transmission(const Bsdf& b, float cos_theta) {
  return kSpecular && b.coat_weight > 0.f ? 1.f - schlick_fresnel(b.f0_dielectric, cos_theta) : 1.f;
}

// The Lambertian BSDF of albedo a around normal n (tests, simple scenes).
PN_FN Bsdf make_lambert(Vec3 albedo, Vec3 n) { return make_bsdf(albedo, 0.f, 1.f, 0.f, n, n); }

// A Bsdf in 64 bytes, for records that many threads read (restir's per-pixel
// records): the shading normal in place of the frame, which Frame::from_z
// rebuilds bit for bit as make_bsdf built it, and has_specular left to follow
// from the weights as make_bsdf sets it. unpack_bsdf(pack_bsdf(b)) == b for every
// b that make_bsdf returns.
struct PackedBsdf {
  Vec3 n, ng, diffuse, metal;
  float metal_weight = 0.f, coat_weight = 0.f, f0_dielectric = 0.f, alpha = 1.f;
};

PN_FN PackedBsdf pack_bsdf(const Bsdf& b) {
  return {b.frame.n, b.ng, b.diffuse, b.metal, b.metal_weight, b.coat_weight, b.f0_dielectric, b.alpha};
}

PN_FN Bsdf unpack_bsdf(const PackedBsdf& p) {
  Bsdf b;
  b.frame = Frame::from_z(p.n);
  b.ng = p.ng;
  b.diffuse = p.diffuse;
  b.metal = p.metal;
  b.metal_weight = p.metal_weight;
  b.coat_weight = p.coat_weight;
  b.f0_dielectric = p.f0_dielectric;
  b.alpha = p.alpha;
  b.has_specular = bsdf_has_specular(b.metal_weight, b.coat_weight);
  return b;
}

// Probability of sampling the specular lobe for view direction wo_local.
PN_FN float bsdf_specular_probability(const Bsdf& b, float cos_o) {
  if (!b.has_specular) return 0.f;
  float ws = luminance(bsdf_fresnel(b, cos_o));
  float wd = luminance(b.diffuse) * bsdf_coat_transmission(b, cos_o);
  if (!(wd > 0.f)) return 1.f;
  return clamp(ws / (ws + wd), 0.1f, 0.9f);
}

// f(wo, wi) without the cosine; world-space unit directions pointing away.
template <bool kSpecular = true>
PN_FN Vec3 bsdf_eval(const Bsdf& b, Vec3 wo, Vec3 wi) {
  if (dot(wi, b.ng) <= 0.f || dot(wo, b.ng) <= 0.f) return Vec3(0.f);
  Vec3 o = b.frame.to_local(wo), i = b.frame.to_local(wi);
  if (o.z <= 0.f || i.z <= 0.f) return Vec3(0.f);
  Vec3 f = b.diffuse * (kInvPi * bsdf_coat_transmission<kSpecular>(b, o.z) * bsdf_coat_transmission<kSpecular>(b, i.z));
  if (kSpecular && b.has_specular) {
    Vec3 h = normalize(o + i);
    float g = ggx_g2(o, i, b.alpha);
    f += bsdf_fresnel(b, dot(o, h)) * (ggx_d(h, b.alpha) * g / (4.f * o.z * i.z));
  }
  return f;
}

// Solid-angle density of bsdf_sample() returning wi.
template <bool kSpecular = true>
PN_FN float bsdf_pdf(const Bsdf& b, Vec3 wo, Vec3 wi) {
  if (dot(wi, b.ng) <= 0.f || dot(wo, b.ng) <= 0.f) return 0.f;
  Vec3 o = b.frame.to_local(wo), i = b.frame.to_local(wi);
  if (o.z <= 0.f || i.z <= 0.f) return 0.f;
  float ps = kSpecular ? bsdf_specular_probability(b, o.z) : 0.f;
  float pdf = (1.f - ps) * cosine_hemisphere_pdf(i.z);
  if (kSpecular && ps > 0.f) {
    Vec3 h = normalize(o + i);
    pdf += ps * ggx_visible_normal_pdf(o, h, b.alpha) / (4.f * dot(o, h));
  }
  return pdf;
}

// Samples wi; u_lobe picks the lobe, u the direction within it.
template <bool kSpecular = true>
PN_FN BsdfSample bsdf_sample(const Bsdf& b, Vec3 wo, float u_lobe, Vec2 u) {
  BsdfSample s;
  Vec3 o = b.frame.to_local(wo);
  if (o.z <= 0.f || dot(wo, b.ng) <= 0.f) return s;
  const float ps = kSpecular ? bsdf_specular_probability(b, o.z) : 0.f;
  Vec3 i;
  if (u_lobe < ps) {
    Vec3 h = ggx_sample_visible_normal(o, b.alpha, u);
    i = reflect(o, h);
  } else {
    i = sample_cosine_hemisphere(u);
  }
  if (i.z <= 0.f) return s;
  s.wi = b.frame.to_world(i);
  if (ps == 0.f) {
    // Pure diffuse: f cos / pdf reduces to the weighted albedo exactly.
    if (dot(s.wi, b.ng) <= 0.f) return BsdfSample();
    s.pdf = cosine_hemisphere_pdf(i.z);
    s.weight = b.diffuse * (bsdf_coat_transmission<kSpecular>(b, o.z) * bsdf_coat_transmission<kSpecular>(b, i.z));
    return s;
  }
  s.pdf = bsdf_pdf(b, wo, s.wi);
  if (!(s.pdf > 0.f)) return BsdfSample();
  s.weight = bsdf_eval(b, wo, s.wi) * (i.z / s.pdf);
  return s;
}

}  // namespace pn
