// Every sampling routine against its own pdf: chi-square goodness of fit of the
// sampled directions, the pdf reported with each sample against the pdf
// computed independently from the geometry, and pdf integrals.
#include <gtest/gtest.h>

#include "core/geometry.h"
#include "core/lights.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "stat_util.h"

namespace pn {
namespace {

using test::chi2_test;
using test::DirectionGrid;

constexpr int kSamples = 400000;
constexpr double kMinP = 1e-3;  // fixed seeds: a correct sampler passes deterministically

// Draws kSamples directions, bins them, and compares with the pdf's integrals.
// `sample` returns false for a rejected sample (counted in the outside bin).
void expect_matches_pdf(const DirectionGrid& grid, const std::function<bool(Vec2, Vec3*)>& sample,
                        const std::function<double(Vec3)>& pdf, uint32_t seed) {
  std::vector<double> expected = grid.integrate(pdf);
  double inside = 0;
  for (int i = 0; i + 1 < grid.bins(); ++i) inside += expected[i];
  expected.back() = std::max(0.0, 1.0 - inside);
  for (double& e : expected) e *= kSamples;
  std::vector<double> observed(grid.bins(), 0.0);
  Rng rng(0, 0, seed);
  for (int i = 0; i < kSamples; ++i) {
    Vec3 w;
    if (sample(rng.uniform2(), &w)) observed[grid.bin(w)] += 1;
    else observed.back() += 1;
  }
  auto r = chi2_test(observed, expected);
  EXPECT_GT(r.p_value, kMinP) << r.message;
}

double integrate_pdf(const DirectionGrid& grid, const std::function<double(Vec3)>& pdf) {
  auto e = grid.integrate(pdf, 24);
  double s = 0;
  for (int i = 0; i + 1 < grid.bins(); ++i) s += e[i];
  return s;
}

// Adapts a light-sampling strategy to expect_matches_pdf: the sampled direction,
// rejected (outside bin) when the strategy returns pdf 0.
std::function<bool(Vec2, Vec3*)> direction_sampler(LightSample (*strategy)(const Light&, Vec3, Vec2),
                                                   const Light& l, Vec3 x) {
  return [strategy, &l, x](Vec2 u, Vec3* w) {
    LightSample s = strategy(l, x, u);
    *w = s.wi;
    return s.pdf > 0.f;
  };
}

// --- Independent pdfs from geometry --------------------------------------------

// Solid-angle pdf of uniform area sampling of a sphere light, by ray casting.
double sphere_area_pdf(Vec3 x, const Light& l, Vec3 w) {
  float t;
  if (!intersect_sphere(Ray(x, w), l.p, l.radius, 0.f, kInf, &t)) return 0.0;
  Vec3 y = x + w * t;
  Vec3 n = normalize(y - l.p);
  double cos_l = -dot(n, w);
  return cos_l > 0 ? double(t) * t / (l.area * cos_l) : 0.0;
}

double quad_area_pdf(Vec3 x, const Light& l, Vec3 w) {
  float t;
  Vec3 p0 = l.p, p1 = l.p + l.e1, p2 = l.p + l.e1 + l.e2, p3 = l.p + l.e2;
  Ray r(x, w);
  if (!intersect_triangle(r, p0, p1, p2, 0.f, kInf, &t) && !intersect_triangle(r, p0, p2, p3, 0.f, kInf, &t))
    return 0.0;
  double cos_l = -dot(l.n, w);
  return cos_l > 0 ? double(t) * t / (l.area * cos_l) : 0.0;
}

double cone_cos_max(Vec3 x, const Light& l) {
  double d2 = length_sq(l.p - x);
  return std::sqrt(std::max(0.0, 1.0 - double(l.radius) * l.radius / d2));
}

// --- Primitive samplers ---------------------------------------------------------

TEST(Sampling, UniformSphereMatchesPdf) {
  DirectionGrid grid(Vec3(0, 0, 1), -1.0, 16, 24);
  expect_matches_pdf(
      grid, [](Vec2 u, Vec3* w) { *w = sample_uniform_sphere(u); return true; },
      [](Vec3) { return double(uniform_sphere_pdf()); }, 1);
  EXPECT_NEAR(integrate_pdf(grid, [](Vec3) { return double(uniform_sphere_pdf()); }), 1.0, 1e-4);
}

TEST(Sampling, CosineHemisphereMatchesPdf) {
  DirectionGrid grid(Vec3(0, 0, 1), -1.0, 24, 24);
  auto pdf = [](Vec3 w) { return double(cosine_hemisphere_pdf(w.z)); };
  expect_matches_pdf(
      grid, [](Vec2 u, Vec3* w) { *w = sample_cosine_hemisphere(u); return true; }, pdf, 2);
  EXPECT_NEAR(integrate_pdf(grid, pdf), 1.0, 1e-4);
}

TEST(Sampling, UniformConeMatchesPdf) {
  for (float cos_max : {0.0f, 0.7f, 0.999f}) {
    DirectionGrid grid(Vec3(0, 0, 1), cos_max, 16, 16);  // bin edges on the pdf's discontinuity
    auto pdf = [cos_max](Vec3 w) { return w.z >= cos_max ? double(uniform_cone_pdf(cos_max)) : 0.0; };
    expect_matches_pdf(
        grid, [cos_max](Vec2 u, Vec3* w) { *w = sample_uniform_cone(u, cos_max); return true; }, pdf, 3);
    DirectionGrid exact(Vec3(0, 0, 1), cos_max, 8, 8);
    EXPECT_NEAR(integrate_pdf(exact, pdf), 1.0, 1e-4) << "cos_max " << cos_max;
  }
}

TEST(Sampling, ParallelogramIsUniform) {
  // Uniform over the parameter square means uniform over area (affine map).
  const int n = 8;
  std::vector<double> obs(n * n, 0.0), exp(n * n, double(kSamples) / (n * n));
  Rng rng(0, 0, 4);
  Vec3 p0(1, 2, 3), e1(2, 0, 0), e2(0.5, 1, 0);
  for (int i = 0; i < kSamples; ++i) {
    Vec3 y = sample_uniform_parallelogram(rng.uniform2(), p0, e1, e2);
    // Recover (u, v) from the point: solve y - p0 = u e1 + v e2 in the xy plane.
    Vec3 q = y - p0;
    double v = q.y / e2.y, u = (q.x - v * e2.x) / e1.x;
    obs[std::min(n - 1, int(v * n)) * n + std::min(n - 1, int(u * n))] += 1;
  }
  auto r = chi2_test(obs, exp);
  EXPECT_GT(r.p_value, kMinP) << r.message;
}

// --- Light-sampling strategies, in solid angle -----------------------------------

class SphereLightSampling : public ::testing::TestWithParam<float> {};

TEST_P(SphereLightSampling, AreaStrategyMatchesJacobianPdf) {
  const float r = 0.5f, d = GetParam() * r;
  Light l = Light::sphere(Vec3(0.3f, -0.2f, 1.f), r, Vec3(1.f));
  Vec3 x = l.p + normalize(Vec3(0.3f, 1.f, -0.4f)) * d;
  double cos_max = cone_cos_max(x, l);
  DirectionGrid grid(l.p - x, cos_max, 12, 16);
  auto pdf = [&](Vec3 w) { return sphere_area_pdf(x, l, w); };
  // The pdf each sample reports equals the one computed by casting its ray
  // (away from the silhouette, where grazing incidence makes the ray cast itself
  // ill-conditioned).
  Rng rng(9, 9, 9);
  int rejected = 0;
  for (int i = 0; i < 4000; ++i) {
    LightSample s = sample_light_area(l, x, rng.uniform2());
    if (s.pdf == 0.f) {
      ++rejected;
      continue;
    }
    EXPECT_NEAR(length(s.y - l.p), r, 1e-5f * d);
    if (-dot(normalize(s.y - l.p), s.wi) > 0.1f) {
      EXPECT_NEAR(s.pdf, pdf(s.wi), 2e-3 * s.pdf);
    }
  }
  // About half the sphere faces away and is rejected: (1 + r/d) / 2 of the samples.
  EXPECT_NEAR(rejected / 4000.0, 0.5 * (1.0 + r / d), 0.03);
  expect_matches_pdf(grid, direction_sampler(sample_light_area, l, x), pdf, 5);
  // Only the visible cap counts: its share of the area is (1 - r/d) / 2.
  DirectionGrid cone(l.p - x, cos_max, 16, 16);
  EXPECT_NEAR(integrate_pdf(cone, pdf), 0.5 * (1.0 - r / d), 2e-3);
}

TEST_P(SphereLightSampling, SolidAngleStrategyIsUniformInCone) {
  const float r = 0.5f, d = GetParam() * r;
  Light l = Light::sphere(Vec3(0.3f, -0.2f, 1.f), r, Vec3(1.f));
  Vec3 x = l.p + normalize(Vec3(-0.6f, 0.2f, 0.5f)) * d;
  double cos_max = cone_cos_max(x, l);
  double one_minus = double(r) * r / (double(d) * d) / (1.0 + cos_max);  // 1 - cos, without cancellation
  double p_cone = 1.0 / (2 * M_PI * one_minus);
  auto pdf = [&](Vec3 w) { return dot(w, normalize(l.p - x)) >= cos_max ? p_cone : 0.0; };
  Rng rng(8, 8, 8);
  for (int i = 0; i < 2000; ++i) {
    LightSample s = sample_light_solid_angle(l, x, rng.uniform2());
    ASSERT_GT(s.pdf, 0.f);
    EXPECT_NEAR(s.pdf, p_cone, 1e-3 * p_cone);
    EXPECT_NEAR(length(s.y - l.p), r, 1e-4f * d);  // the point lies on the sphere
    EXPECT_NEAR(length(normalize(s.y - x) - s.wi), 0.f, 1e-5f);
    EXPECT_GT(dot(s.wi, normalize(l.p - x)), cos_max - 1e-6);
  }
  DirectionGrid grid(l.p - x, cos_max, 12, 16);
  expect_matches_pdf(grid, direction_sampler(sample_light_solid_angle, l, x), pdf, 6);
  if (GetParam() < 20.f) {  // the grid resolves the cone's edge
    DirectionGrid cone(l.p - x, cos_max, 16, 16);
    EXPECT_NEAR(integrate_pdf(cone, pdf), 1.0, 1e-3);
  }
}

// d/r from touching-close to far enough for the Taylor branch (sin^2 < 6.9e-4).
INSTANTIATE_TEST_SUITE_P(Distances, SphereLightSampling, ::testing::Values(1.05f, 2.f, 8.f, 60.f));

TEST(LightSampling, QuadAreaStrategyMatchesJacobianPdf) {
  Light l = Light::quad(Vec3(-0.5f, 1.f, -0.3f), Vec3(1.2f, 0, 0), Vec3(0, 0, 0.8f), Vec3(1.f));
  // x on the emitting side (the side of n = e1 x e2 / |e1 x e2|).
  Vec3 center = l.p + l.e1 * 0.5f + l.e2 * 0.5f;
  Vec3 x = center + l.n * 0.7f + Vec3(0.4f, 0.f, 0.2f);
  auto pdf = [&](Vec3 w) { return quad_area_pdf(x, l, w); };
  Rng rng(7, 7, 7);
  for (int i = 0; i < 2000; ++i) {
    LightSample s = sample_light_area(l, x, rng.uniform2());
    ASSERT_GT(s.pdf, 0.f);
    EXPECT_NEAR(s.pdf, pdf(s.wi), 2e-3 * s.pdf);
  }
  // Distribution of the sampled points in the quad's (u, v) parameters against
  // the ray-cast pdf carried to that domain: p(u, v) = p_w(w) |dw / du dv| with
  // |dw / du dv| = |e1 x e2| cos_light / d^2.
  const int n = 12;
  std::vector<double> obs(n * n + 1, 0.0), exp(n * n + 1, 0.0);
  const int res = 8;
  for (int iv = 0; iv < n; ++iv)
    for (int iu = 0; iu < n; ++iu)
      for (int a = 0; a < res; ++a)
        for (int b = 0; b < res; ++b) {
          float u = (iu + (a + 0.5f) / res) / n, v = (iv + (b + 0.5f) / res) / n;
          Vec3 y = l.p + l.e1 * u + l.e2 * v;
          Vec3 w = normalize(y - x);
          double jac = l.area * -dot(l.n, w) / length_sq(y - x);
          exp[iv * n + iu] += pdf(w) * jac / (res * res * n * n) * kSamples;
        }
  Rng srng(10, 10, 10);
  for (int i = 0; i < kSamples; ++i) {
    LightSample s = sample_light_area(l, x, srng.uniform2());
    if (!(s.pdf > 0.f)) {
      obs.back() += 1;
      continue;
    }
    Vec3 q = s.y - l.p;
    double u = dot(q, l.e1) / length_sq(l.e1), v = dot(q, l.e2) / length_sq(l.e2);  // e1 is orthogonal to e2 here
    obs[std::min(n - 1, int(v * n)) * n + std::min(n - 1, int(u * n))] += 1;
  }
  auto r = chi2_test(obs, exp);
  EXPECT_GT(r.p_value, kMinP) << r.message;
  double z_min = 1;
  for (Vec3 c : {l.p, l.p + l.e1, l.p + l.e2, l.p + l.e1 + l.e2})
    z_min = std::min(z_min, double(dot(normalize(c - x), normalize(center - x))));
  EXPECT_NEAR(integrate_pdf(DirectionGrid(center - x, z_min - 0.05, 64, 96), pdf), 1.0, 3e-3);
  // From behind, a one-sided quad offers nothing.
  Vec3 behind = center - l.n * 0.5f;
  for (int i = 0; i < 100; ++i) EXPECT_EQ(sample_light_area(l, behind, rng.uniform2()).pdf, 0.f);
  // solid-angle falls back to area for quads.
  Vec2 u(0.3f, 0.6f);
  EXPECT_EQ(sample_light_solid_angle(l, x, u).pdf, sample_light_area(l, x, u).pdf);
}

TEST(LightSampling, InsideOrOnTheSphereGivesNoSampleAndNoNaN) {
  Light l = Light::sphere(Vec3(0, 0, 0), 1.f, Vec3(1.f));
  Rng rng(1, 2, 3);
  for (Vec3 x : {Vec3(0, 0, 0), Vec3(0.5f, 0, 0), Vec3(1.f, 0, 0), Vec3(0, 0.99999f, 0)}) {
    for (int i = 0; i < 1000; ++i) {
      Vec2 u = rng.uniform2();
      for (LightSample s : {sample_light_solid_angle(l, x, u), sample_light_area(l, x, u)}) {
        EXPECT_FALSE(std::isnan(s.pdf));
        if (s.pdf > 0.f) {  // only possible exactly on the surface, facing out
          EXPECT_TRUE(is_finite(s.wi));
        }
      }
    }
  }
}

TEST(Rng, DeterministicAndDecorrelated) {
  Rng a(5, 7, 11), b(5, 7, 11), c(5, 8, 11), d(6, 7, 11), e(5, 7, 12);
  for (int i = 0; i < 100; ++i) {
    float x = a.uniform();
    EXPECT_EQ(x, b.uniform());
    EXPECT_GE(x, 0.f);
    EXPECT_LT(x, 1.f);
  }
  // Neighbouring pixels, samples and seeds: uncorrelated streams.
  Rng s0(5, 7, 11);
  double sxy[3] = {0, 0, 0};
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    double x = s0.uniform() - 0.5;
    sxy[0] += x * (c.uniform() - 0.5);
    sxy[1] += x * (d.uniform() - 0.5);
    sxy[2] += x * (e.uniform() - 0.5);
  }
  for (double v : sxy) EXPECT_LT(std::fabs(v / n) / (1.0 / 12), 4.0 / std::sqrt(double(n)));
}

}  // namespace
}  // namespace pn
