// An HDR environment at infinity: an equirectangular (latitude-longitude) image,
// rotated about +y and scaled, importance-sampled for next-event estimation.
//
// Mapping (y up): a direction d = (sin t sin p, cos t, -sin t cos p) has image
// coordinates u = p / (2 pi) + 1/2, v = t / pi, so the top row is straight up
// and the image's centre column looks down -z. The importance distribution is
// piecewise constant over the image's pixels with density proportional to
// luminance x sin t (pbrt-v4's ImageInfiniteLight), sampled by inverting the
// marginal CDF over rows and the conditional CDF over the chosen row. Densities
// convert from (u, v) to solid angle by p(w) = p(u, v) / (2 pi^2 sin t). The
// image is looked up without filtering (nearest texel) so that radiance and
// density are constant over the same cells: the density is then never zero
// where radiance is not.
//
// MIS compensation (Karlik, Sik, Vevoda, Skrivan & Krivanek 2019, as pbrt-v4
// does it): where the light sample is weighed by MIS against a BSDF sample, it
// may come from a second distribution, max(0, luminance - the mean luminance
// over the sphere) x sin t, which leaves the directions no brighter than the
// mean to the BSDF sample (its MIS weight is 1 there, where the light
// technique's density is 0): the light technique spends its samples where it
// beats BSDF sampling. Where no texel is above the mean (a constant
// environment) the compensated distribution is empty and the full one is used.
#pragma once

#include "common.h"
#include "sampling.h"
#include "texture.h"
#include "vec.h"

namespace pn {

// A piecewise-constant density over [0, 1) of n pieces: func (n values >= 0),
// cdf (n + 1 values, cdf[0] = 0, cdf[n] = 1), integral = sum(func) / n.
struct Distribution1DView {
  const float* func = nullptr;
  const float* cdf = nullptr;
  uint32_t n = 0;
  float integral = 0.f;
};

// Continuous sample x in [0, 1) with density func[i] / integral; *piece gets i.
PN_FN float sample_distribution(const Distribution1DView& d, float u, float* pdf, uint32_t* piece) {
  const uint32_t lo = find_cdf_piece(d.cdf, d.n, u);
  *piece = lo;
  float width = d.cdf[lo + 1] - d.cdf[lo];
  float du = width > 0.f ? (u - d.cdf[lo]) / width : 0.5f;
  du = clamp(du, 0.f, kOneMinusEpsilon);
  *pdf = d.integral > 0.f ? d.func[lo] / d.integral : 0.f;
  return pn_min((float(lo) + du) / float(d.n), kOneMinusEpsilon);
}

// A density over the image: a marginal over rows (height pieces) and a conditional per row.
struct EnvironmentDistributionView {
  Distribution1DView marginal;
  const float* conditional_func = nullptr;  // height x width
  const float* conditional_cdf = nullptr;   // height x (width + 1)
};

struct EnvironmentView {
  TextureView image;                  // Rgba32f, linear radiance, nearest-texel lookup
  EnvironmentDistributionView distribution;  // luminance x sin t
  EnvironmentDistributionView compensated;   // max(0, luminance - mean) x sin t; integral 0: empty
  uint32_t width = 0, height = 0;     // of the distributions (the image's size)
  float cos_rot = 1.f, sin_rot = 0.f; // rotation about +y, world = R * env
  Vec3 scale{1.f};                    // intensity (and tint)
  PN_HD bool present() const { return width > 0; }
};

// Direction in the environment's frame <-> world.
PN_FN Vec3 env_to_world(const EnvironmentView& e, Vec3 d) {
  return Vec3(e.cos_rot * d.x + e.sin_rot * d.z, d.y, -e.sin_rot * d.x + e.cos_rot * d.z);
}
PN_FN Vec3 env_from_world(const EnvironmentView& e, Vec3 d) {
  return Vec3(e.cos_rot * d.x - e.sin_rot * d.z, d.y, e.sin_rot * d.x + e.cos_rot * d.z);
}

// Image coordinates of an environment-frame direction, and back.
PN_FN Vec2 equirect_uv(Vec3 d) {
  // atan2 rather than acos(d.y): well conditioned near the poles too.
  float t = std::atan2(std::sqrt(d.x * d.x + d.z * d.z), d.y);
  float p = std::atan2(d.x, -d.z);  // in (-pi, pi]
  return Vec2(p * kInvTwoPi + 0.5f, t * kInvPi);
}
PN_FN Vec3 equirect_direction(Vec2 uv) {
  float t = uv.y * kPi, p = (uv.x - 0.5f) * kTwoPi;
  float st = std::sin(t);
  return Vec3(st * std::sin(p), std::cos(t), -st * std::cos(p));
}

// Radiance arriving from world direction w.
PN_FN Vec3 environment_radiance(const EnvironmentView& e, Vec3 w) {
  return texture_lookup(e.image, equirect_uv(env_from_world(e, w))).rgb * e.scale;
}

// The distribution light samples come from: the compensated one where asked for and not empty.
PN_FN const EnvironmentDistributionView& environment_distribution(const EnvironmentView& e, bool compensated) {
  return compensated && e.compensated.marginal.integral > 0.f ? e.compensated : e.distribution;
}

// The row-th conditional distribution.
PN_FN Distribution1DView environment_row(const EnvironmentView& e, const EnvironmentDistributionView& dist,
                                         uint32_t row) {
  Distribution1DView d;
  d.func = dist.conditional_func + size_t(row) * e.width;
  d.cdf = dist.conditional_cdf + size_t(row) * (e.width + 1);
  d.n = e.width;
  d.integral = dist.marginal.func[row];  // the row's integral is the marginal's value
  return d;
}

// Solid-angle density of environment_sample() returning world direction w (`compensated`: the same as there).
PN_FN float environment_pdf(const EnvironmentView& e, Vec3 w, bool compensated = false) {
  const EnvironmentDistributionView& dist = environment_distribution(e, compensated);
  if (!(dist.marginal.integral > 0.f)) return 0.f;
  Vec3 d = env_from_world(e, w);
  Vec2 uv = equirect_uv(d);
  float st = std::sqrt(d.x * d.x + d.z * d.z);  // sin t, without a round trip through t
  if (!(st > 0.f)) return 0.f;
  uint32_t col = pn_min(uint32_t(pn_max(0.f, uv.x) * float(e.width)), e.width - 1);
  uint32_t row = pn_min(uint32_t(pn_max(0.f, uv.y) * float(e.height)), e.height - 1);
  float pdf_uv = dist.conditional_func[size_t(row) * e.width + col] / dist.marginal.integral;
  return pdf_uv / (2.f * kPi * kPi * st);
}

// A direction towards the environment, with density proportional to the
// distribution; the sample's radiance is looked up in the (filtered) image.
struct EnvironmentSample {
  Vec3 wi;
  Vec3 L;
  float pdf = 0.f;
};

// `compensated`: from the MIS-compensated distribution (where it is not empty).
PN_FN EnvironmentSample environment_sample(const EnvironmentView& e, Vec2 u, bool compensated = false) {
  EnvironmentSample s;
  const EnvironmentDistributionView& dist = environment_distribution(e, compensated);
  if (!(dist.marginal.integral > 0.f)) return s;
  float pdf_v, pdf_u;
  uint32_t row, col;
  float v = sample_distribution(dist.marginal, u.y, &pdf_v, &row);
  float uu = sample_distribution(environment_row(e, dist, row), u.x, &pdf_u, &col);
  float st = std::sin(v * kPi);
  if (!(st > 0.f) || !(pdf_u * pdf_v > 0.f)) return s;
  s.wi = env_to_world(e, equirect_direction(Vec2(uu, v)));
  s.pdf = pdf_u * pdf_v / (2.f * kPi * kPi * st);
  s.L = environment_radiance(e, s.wi);
  return s;
}

}  // namespace pn
