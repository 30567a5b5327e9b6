// Sampling routines as pure functions of an explicit uniform sample u in [0,1)^2.
//
// Each routine comes in a triad where one exists: sample, pdf and inverse (the
// u that a sample came from), so tests can feed any point set, check the pair
// against each other and round-trip the inverse (tests/core/test_sampling.cpp).
// Directions are unit vectors; pdfs of directions are per unit solid angle,
// pdfs of points per unit area, pdfs over [0,1]^2 per unit parameter area.
// Spherical triangles and rectangles are in core/spherical_polygons.h, the
// projected spherical cap in core/projected_cap.h.
#pragma once

#include "common.h"
#include "vec.h"

namespace pn {

PN_FN float lerp(float t, float a, float b) { return (1.f - t) * a + t * b; }

// --- Uniform sphere: pdf = 1 / (4 pi) -----------------------------------------
PN_FN Vec3 sample_uniform_sphere(Vec2 u) {
  float z = 1.f - 2.f * u.x;
  float r = safe_sqrt(1.f - z * z);
  float phi = kTwoPi * u.y;
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}
PN_FN float uniform_sphere_pdf() { return kInvFourPi; }

// --- Concentric disk (Shirley & Chiu 1997): unit disk, pdf = 1 / pi -----------
PN_FN Vec2 sample_uniform_disk_concentric(Vec2 u) {
  float ox = 2.f * u.x - 1.f, oy = 2.f * u.y - 1.f;
  if (ox == 0.f && oy == 0.f) return Vec2(0.f, 0.f);
  float r, theta;
  if (std::fabs(ox) > std::fabs(oy)) {
    r = ox;
    theta = (kPi / 4.f) * (oy / ox);
  } else {
    r = oy;
    theta = kPi / 2.f - (kPi / 4.f) * (ox / oy);
  }
  return Vec2(r * std::cos(theta), r * std::sin(theta));
}

// --- Cosine-weighted hemisphere around +z: pdf = cos(theta) / pi ---------------
PN_FN Vec3 sample_cosine_hemisphere(Vec2 u) {
  Vec2 d = sample_uniform_disk_concentric(u);
  float z = safe_sqrt(1.f - d.x * d.x - d.y * d.y);
  return Vec3(d.x, d.y, z);
}
PN_FN float cosine_hemisphere_pdf(float cos_theta) { return pn_max(cos_theta, 0.f) * kInvPi; }

// --- Uniform cone around +z with half-angle theta_max -------------------------
// Given by sin^2(theta_max), so that tiny cones (distant lights) lose nothing:
// 1 - cos = sin^2 / (1 + cos) and sin^2(theta) = (1 - cos)(1 + cos) are exact
// rewritings without cancellation, which also makes a Taylor branch unneeded.
// pdf = 1 / (2 pi (1 - cos theta_max)), constant over the cone.
struct Cone {
  float sin2_max = 0.f;           // sin^2(theta_max), in [0, 1]
  float cos_max = 1.f;            // cos(theta_max) >= 0 (at most a hemisphere)
  float one_minus_cos_max = 0.f;  // 1 - cos(theta_max): solid angle / 2 pi
};
PN_FN Cone make_cone(float sin2_max) {
  Cone c;
  c.sin2_max = clamp(sin2_max, 0.f, 1.f);
  c.cos_max = safe_sqrt(1.f - c.sin2_max);
  c.one_minus_cos_max = c.sin2_max / (1.f + c.cos_max);
  return c;
}

// A sampled direction's polar angle, in the forms its users need.
struct ConeSample {
  float cos_theta = 1.f, sin2_theta = 0.f, phi = 0.f;
  PN_HD Vec3 direction() const {
    float s = safe_sqrt(sin2_theta);
    return Vec3(std::cos(phi) * s, std::sin(phi) * s, cos_theta);
  }
};
PN_FN ConeSample sample_uniform_cone(Vec2 u, const Cone& c) {
  ConeSample s;
  float one_minus_cos = u.x * c.one_minus_cos_max;
  s.cos_theta = 1.f - one_minus_cos;
  s.sin2_theta = one_minus_cos * (2.f - one_minus_cos);
  s.phi = kTwoPi * u.y;
  return s;
}
PN_FN float uniform_cone_pdf(const Cone& c) { return 1.f / (kTwoPi * c.one_minus_cos_max); }
// Whether local direction w (unit, around +z) lies in the cone: compared by
// sin^2, which resolves cones far narrower than float's 1 - cos can, with a
// margin for the rounding of directions sampled on the rim (about 1e-7 in sin).
PN_FN float cone_containment_bound(const Cone& c) {
  return c.sin2_max * 1.00001f + 4e-7f * std::sqrt(c.sin2_max);
}
PN_FN bool cone_contains(const Cone& c, Vec3 w) {
  return w.z > 0.f && w.x * w.x + w.y * w.y <= cone_containment_bound(c);
}
PN_FN Vec2 invert_uniform_cone_sample(Vec3 w, const Cone& c) {
  float sin2 = w.x * w.x + w.y * w.y;
  float one_minus_cos = sin2 / (1.f + pn_max(0.f, w.z));
  float phi = std::atan2(w.y, w.x);
  if (phi < 0.f) phi += kTwoPi;
  return Vec2(clamp(one_minus_cos / c.one_minus_cos_max, 0.f, 1.f), pn_min(phi * kInvTwoPi, kOneMinusEpsilon));
}

// --- Linear and bilinear densities over [0, 1] and [0, 1]^2 ---------------------
// Density proportional to lerp(x, a, b), a, b >= 0 and a + b > 0.
PN_FN float linear_pdf(float x, float a, float b) {
  if (x < 0.f || x > 1.f) return 0.f;
  return 2.f * lerp(x, a, b) / (a + b);
}
PN_FN float sample_linear(float u, float a, float b) {
  if (u == 0.f && a == 0.f) return 0.f;
  // The root of the quadratic CDF, rationalized so that a == b is not a special case.
  float x = u * (a + b) / (a + std::sqrt(lerp(u, a * a, b * b)));
  return pn_min(x, kOneMinusEpsilon);
}
PN_FN float invert_linear_sample(float x, float a, float b) { return x * (a * (2.f - x) + b * x) / (a + b); }

// Density proportional to the bilinear interpolation of the corner values
// w[0] at (0,0), w[1] at (1,0), w[2] at (0,1), w[3] at (1,1) (all >= 0).
PN_FN float bilinear_pdf(Vec2 p, const float w[4]) {
  if (p.x < 0.f || p.x > 1.f || p.y < 0.f || p.y > 1.f) return 0.f;
  float sum = w[0] + w[1] + w[2] + w[3];
  if (!(sum > 0.f)) return 1.f;
  return 4.f *
         ((1.f - p.x) * (1.f - p.y) * w[0] + p.x * (1.f - p.y) * w[1] + (1.f - p.x) * p.y * w[2] + p.x * p.y * w[3]) /
         sum;
}
PN_FN Vec2 sample_bilinear(Vec2 u, const float w[4]) {
  Vec2 p;
  p.y = sample_linear(u.y, w[0] + w[1], w[2] + w[3]);             // the marginal in y
  p.x = sample_linear(u.x, lerp(p.y, w[0], w[2]), lerp(p.y, w[1], w[3]));  // x given y
  return p;
}
PN_FN Vec2 invert_bilinear_sample(Vec2 p, const float w[4]) {
  return Vec2(invert_linear_sample(p.x, lerp(p.y, w[0], w[2]), lerp(p.y, w[1], w[3])),
              invert_linear_sample(p.y, w[0] + w[1], w[2] + w[3]));
}

// --- Segment of the unit disk: {p : |p| <= 1, p.x >= cos(theta_d)} ------------------
// Its area as a function of the half-angle theta in [0, pi] of its chord:
// A(theta) = theta - sin(theta) cos(theta); A(pi) = pi is the whole disk. Near
// theta = 0 the difference cancels, so a series takes over there.
PN_FN float disk_segment_area(float theta) {
  if (theta < 0.25f) {
    float t2 = theta * theta;
    return theta * t2 * (2.f / 3.f - t2 * (2.f / 15.f - t2 * (4.f / 315.f)));
  }
  return theta - 0.5f * std::sin(2.f * theta);
}
// A point uniform over the segment of half-angle theta_d (pdf 1 / area):
// x = cos(theta) from inverting A(theta) = u.x A(theta_d) by safeguarded Newton
// iterations (A' = 2 sin^2), then y uniform along the chord at x.
PN_FN Vec2 sample_disk_segment(Vec2 u, float theta_d, float area) {
  const float target = u.x * area;
  float lo = 0.f, hi = theta_d;
  // Start from the small-theta inverse, A ~ 2/3 theta^3.
  float theta = pn_min(theta_d, std::cbrt(1.5f * target));
  for (int i = 0; i < 12; ++i) {
    float f = disk_segment_area(theta) - target;
    if (f > 0.f) hi = theta;
    else lo = theta;
    float s = std::sin(theta);
    float d = 2.f * s * s;
    float next = d > 0.f ? theta - f / d : 0.5f * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5f * (lo + hi);  // Newton left the bracket: bisect
    if (std::fabs(next - theta) <= 1e-7f * theta) {
      theta = next;
      break;
    }
    theta = next;
  }
  float h = std::sin(theta);
  return Vec2(std::cos(theta), (2.f * u.y - 1.f) * h);
}

// --- Uniform parallelogram p0 + u e1 + v e2: pdf = 1 / |e1 x e2| ----------------
PN_FN Vec3 sample_uniform_parallelogram(Vec2 u, Vec3 p0, Vec3 e1, Vec3 e2) {
  return p0 + e1 * u.x + e2 * u.y;
}

// --- Inverting a discrete CDF ---------------------------------------------------
// cdf holds n + 1 non-decreasing values from cdf[0] = 0 to cdf[n] = 1. Returns the
// piece i with cdf[i] <= u < cdf[i + 1], skipping pieces of zero probability that
// u may land on through rounding.
PN_FN uint32_t find_cdf_piece(const float* cdf, uint32_t n, float u) {
  uint32_t lo = 0, hi = n;  // largest i in [0, n) with cdf[i] <= u
  while (hi - lo > 1) {
    uint32_t mid = (lo + hi) / 2;
    if (cdf[mid] <= u) lo = mid;
    else hi = mid;
  }
  while (lo + 1 < n && cdf[lo + 1] <= cdf[lo]) ++lo;
  return lo;
}

// --- Uniform triangle: barycentrics (b1, b2) of a uniform point, pdf = 1 / area.
// The square-to-triangle map of Heitz 2019 ("A Low-Distortion Map Between
// Triangle and Square"), which keeps neighbouring u neighbouring.
PN_FN Vec2 sample_uniform_triangle(Vec2 u) {
  float b0, b1;
  if (u.x < u.y) {
    b0 = u.x / 2.f;
    b1 = u.y - b0;
  } else {
    b1 = u.y / 2.f;
    b0 = u.x - b1;
  }
  return Vec2(b0, b1);
}

}  // namespace pn
