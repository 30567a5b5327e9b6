// Sampling routines as pure functions of an explicit uniform sample u in [0,1)^2.
//
// Each routine comes with its pdf, so tests can feed any point set and check the
// pair against each other (tests/test_sampling.cpp). Directions are unit vectors;
// pdfs of directions are per unit solid angle, pdfs of points per unit area.
#pragma once

#include "common.h"
#include "vec.h"

namespace pn {

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
// pdf = 1 / (2 pi (1 - cos theta_max)), constant over the cone.
PN_FN Vec3 sample_uniform_cone(Vec2 u, float cos_theta_max) {
  float cos_theta = (1.f - u.x) + u.x * cos_theta_max;
  float sin_theta = safe_sqrt(1.f - cos_theta * cos_theta);
  float phi = kTwoPi * u.y;
  return Vec3(std::cos(phi) * sin_theta, std::sin(phi) * sin_theta, cos_theta);
}
PN_FN float uniform_cone_pdf(float cos_theta_max) {
  return 1.f / (kTwoPi * (1.f - cos_theta_max));
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
