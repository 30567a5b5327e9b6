// The sampling primitives against their own pdfs: chi-square goodness of fit,
// pdf integrals, inverse round trips, and the solid angles the spherical
// samplers use against independent quadrature. Fixed seeds: deterministic.
// (Light-sampling strategies: test_light_strategies.cpp.)
#include <gtest/gtest.h>

#include "core/geometry.h"
#include "core/projected_cap.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/spherical_polygons.h"
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
                        const std::function<double(Vec3)>& pdf, uint32_t seed, int res = 12) {
  auto r = test::chi2_directions(grid, sample, pdf, kSamples, seed, res);
  EXPECT_GT(r.p_value, kMinP) << r.message;
}

double integrate_pdf(const DirectionGrid& grid, const std::function<double(Vec3)>& pdf, int res = 24) {
  auto e = grid.integrate(pdf, res);
  double s = 0;
  for (int i = 0; i + 1 < grid.bins(); ++i) s += e[i];
  return s;
}

// Chi-square of points in [0,1]^2 (or any box) on an n x n grid against the
// integrals of `density` over the cells (midpoint rule on res x res sub-cells).
void expect_points_match_density(const std::function<Vec2(Vec2)>& sample, const std::function<double(Vec2)>& density,
                                 Vec2 lo, Vec2 hi, uint32_t seed, int n = 16, int res = 8) {
  // Cells: n x n over [lo, hi]; points outside go to one more bin.
  std::vector<double> expected(n * n + 1, 0.0), observed(n * n + 1, 0.0);
  const double cw = (hi.x - lo.x) / n, ch = (hi.y - lo.y) / n;
  double total = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      double acc = 0;
      for (int a = 0; a < res; ++a)
        for (int b = 0; b < res; ++b)
          acc += density(Vec2(float(lo.x + cw * (i + (a + 0.5) / res)), float(lo.y + ch * (j + (b + 0.5) / res))));
      expected[i * n + j] = acc * cw * ch / (res * res);
      total += expected[i * n + j];
    }
  Rng rng(0, 0, seed);
  for (int k = 0; k < kSamples; ++k) {
    Vec2 p = sample(rng.uniform2());
    int i = int((p.x - lo.x) / cw), j = int((p.y - lo.y) / ch);
    if (i < 0 || j < 0 || i >= n || j >= n) observed.back() += 1;
    else observed[i * n + j] += 1;
  }
  // A cell that a curved boundary cuts to a sliver between the midpoints can
  // come out empty although points land in it: integrate it again, finer.
  for (int c = 0; c < n * n; ++c)
    if (observed[c] > 0 && expected[c] * kSamples < 0.5) {
      const int i = c / n, j = c % n, fine = 256;
      double acc = 0;
      for (int a = 0; a < fine; ++a)
        for (int b = 0; b < fine; ++b)
          acc += density(Vec2(float(lo.x + cw * (i + (a + 0.5) / fine)), float(lo.y + ch * (j + (b + 0.5) / fine))));
      total += acc * cw * ch / (double(fine) * fine) - expected[c];
      expected[c] = acc * cw * ch / (double(fine) * fine);
    }
  expected.back() = std::max(0.0, 1.0 - total);
  for (double& e : expected) e *= kSamples;
  auto r = chi2_test(observed, expected);
  EXPECT_GT(r.p_value, kMinP) << r.message;
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

// sin^2(theta_max) from a hemisphere down to a cone far narrower than float's
// 1 - cos can resolve (1e-9: a light 30,000 radii away).
class UniformCone : public ::testing::TestWithParam<float> {};

TEST_P(UniformCone, MatchesPdfAndInverts) {
  const Cone c = make_cone(GetParam());
  double sin2 = GetParam(), cos_max = std::sqrt(1.0 - sin2);
  EXPECT_NEAR(c.one_minus_cos_max, sin2 / (1.0 + cos_max), 1e-6 * c.one_minus_cos_max);
  auto pdf = [&](Vec3 w) { return cone_contains(c, w) ? double(uniform_cone_pdf(c)) : 0.0; };
  if (sin2 > 1e-4) {  // a grid in cos(theta) resolves the cone
    DirectionGrid grid(Vec3(0, 0, 1), cos_max, 16, 16);
    expect_matches_pdf(
        grid, [&](Vec2 u, Vec3* w) { *w = sample_uniform_cone(u, c).direction(); return true; }, pdf, 3);
    EXPECT_NEAR(integrate_pdf(DirectionGrid(Vec3(0, 0, 1), cos_max, 8, 8), pdf), 1.0, 1e-4);
  }
  // In any case: u.x is (1 - cos) / (1 - cos_max) and u.y the azimuth, which the
  // inverse recovers; every sample lies in the cone.
  Rng rng(3, 3, 3);
  for (int i = 0; i < 20000; ++i) {
    Vec2 u = rng.uniform2();
    ConeSample s = sample_uniform_cone(u, c);
    Vec3 w = s.direction();
    ASSERT_TRUE(cone_contains(c, w)) << "u " << u.x << " " << u.y;
    const double omc = sin2 / (1.0 + cos_max), t = u.x * omc;  // 1 - cos(theta), in double
    EXPECT_NEAR(s.sin2_theta, t * (2 - t), 1e-5 * sin2 + 1e-15);
    Vec2 v = invert_uniform_cone_sample(w, c);
    EXPECT_NEAR(v.x, u.x, 2e-3);
    EXPECT_NEAR(std::fmod(v.y - u.y + 1.5f, 1.f) - 0.5f, 0.f, 2e-4);
  }
}

INSTANTIATE_TEST_SUITE_P(Sin2ThetaMax, UniformCone, ::testing::Values(1.f, 0.51f, 0.002f, 1e-6f, 1e-9f));

TEST(Sampling, ParallelogramIsUniform) {
  // Uniform over the parameter square means uniform over area (affine map).
  Vec3 p0(1, 2, 3), e1(2, 0, 0), e2(0.5, 1, 0);
  expect_points_match_density(
      [&](Vec2 u) {
        Vec3 q = sample_uniform_parallelogram(u, p0, e1, e2) - p0;
        float v = q.y / e2.y;
        return Vec2((q.x - v * e2.x) / e1.x, v);
      },
      [](Vec2) { return 1.0; }, Vec2(0, 0), Vec2(1, 1), 4, 8);
}

TEST(Sampling, LinearAndBilinearMatchPdfAndInvert) {
  for (auto ab : {std::pair<float, float>{1.f, 1.f}, {0.f, 2.f}, {3.f, 0.1f}, {0.01f, 0.01f}}) {
    const float a = ab.first, b = ab.second;
    expect_points_match_density([&](Vec2 u) { return Vec2(sample_linear(u.x, a, b), u.y); },
                                [&](Vec2 p) { return double(linear_pdf(p.x, a, b)); }, Vec2(0, 0), Vec2(1, 1), 5, 32, 4);
    Rng rng(5, 5, 5);
    for (int i = 0; i < 1000; ++i) {
      float u = rng.uniform();
      EXPECT_NEAR(invert_linear_sample(sample_linear(u, a, b), a, b), u, 1e-5f);
    }
  }
  const float corner_sets[3][4] = {{1, 2, 3, 4}, {0.01f, 1, 0.01f, 0.5f}, {1, 1, 1, 1}};
  for (const auto& w : corner_sets) {
    expect_points_match_density([&](Vec2 u) { return sample_bilinear(u, w); },
                                [&](Vec2 p) { return double(bilinear_pdf(p, w)); }, Vec2(0, 0), Vec2(1, 1), 6);
    Rng rng(6, 6, 6);
    for (int i = 0; i < 1000; ++i) {
      Vec2 u = rng.uniform2();
      Vec2 v = invert_bilinear_sample(sample_bilinear(u, w), w);
      EXPECT_NEAR(v.x, u.x, 1e-4f);
      EXPECT_NEAR(v.y, u.y, 1e-4f);
    }
  }
}

// A segment of the unit disk, x >= cos(theta_d): uniform over its area.
class DiskSegment : public ::testing::TestWithParam<float> {};

TEST_P(DiskSegment, IsUniformOverItsArea) {
  const float theta = GetParam();
  const double d = std::cos(double(theta));
  const double area = std::acos(d) - d * std::sqrt(std::max(0.0, 1 - d * d));
  const float A = disk_segment_area(theta);
  EXPECT_NEAR(A, area, 2e-6 * area + 1e-9) << "the segment's area (series below 0.25)";
  Vec2 lo(float(d), -float(std::sin(std::min<double>(theta, M_PI / 2)))), hi(1.f, -lo.y);
  expect_points_match_density(
      [&](Vec2 u) { return sample_disk_segment(u, theta, A); },
      [&](Vec2 p) { return (p.x >= d && p.x * p.x + p.y * p.y <= 1.f) ? 1.0 / area : 0.0; }, lo, hi, 7, 16, 12);
  Rng rng(7, 7, 7);
  for (int i = 0; i < 10000; ++i) {
    Vec2 p = sample_disk_segment(rng.uniform2(), theta, A);
    ASSERT_GE(p.x, d - 1e-6);
    ASSERT_LE(p.x * p.x + p.y * p.y, 1.f + 1e-5f);
  }
}

INSTANTIATE_TEST_SUITE_P(HalfAngles, DiskSegment, ::testing::Values(0.05f, 0.3f, 1.0f, 1.5707964f, 2.5f, 3.1415926f));

// --- Spherical polygons ------------------------------------------------------------

// Solid angle of a planar polygon seen from x, by quadrature of
// cos_l / d^2 dA over it (double, n x n midpoints per triangle fan piece).
double quadrature_solid_angle(Vec3 x, const std::vector<Vec3>& poly, int n = 400) {
  double sum = 0;
  for (size_t k = 1; k + 1 < poly.size(); ++k) {
    Vec3 p0 = poly[0], e1 = poly[k] - p0, e2 = poly[k + 1] - p0;
    Vec3 N = cross(e1, e2);
    double A2 = length(N);
    Vec3 nn = N / float(A2);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n - i; ++j)
        for (int up = 0; up < (j < n - i - 1 ? 2 : 1); ++up) {
          // Sub-triangles of the barycentric grid, by their centroids.
          double b1 = up ? (i + 2.0 / 3) / n : (i + 1.0 / 3) / n, b2 = up ? (j + 2.0 / 3) / n : (j + 1.0 / 3) / n;
          Vec3 y = p0 + e1 * float(b1) + e2 * float(b2);
          Vec3 d = y - x;
          double d2 = length_sq(d);
          sum += std::fabs(dot(nn, d)) / (d2 * std::sqrt(d2)) * A2 / (2.0 * n * n);
        }
  }
  return sum;
}

struct PolygonView {
  Vec3 x, p0, e1, e2;
};

// Directions from x towards the plane of (p0, e1, e2), binned by where they
// meet it: plane coordinates (a, b) for a parallelogram, (s, t) with a = s,
// b = t (1 - s) for a triangle (so that every cell is a whole square);
// expected = the solid-angle density times |d omega / dA| = cos_l / d^2 times
// the area element, over each cell.
void expect_plane_samples_uniform_in_solid_angle(const PolygonView& v, bool triangle, float omega,
                                                 const std::function<Vec3(Vec2)>& sample, uint32_t seed) {
  const Vec3 N = cross(v.e1, v.e2);
  const double jac_area = length(N);
  const Vec3 nn = normalize(N);
  expect_points_match_density(
      [&](Vec2 u) {
        Vec3 w = sample(u);
        float t = dot(v.p0 - v.x, nn) / dot(w, nn);
        Vec3 q = v.x + w * t - v.p0;
        float e11 = dot(v.e1, v.e1), e12 = dot(v.e1, v.e2), e22 = dot(v.e2, v.e2), det = e11 * e22 - e12 * e12;
        float q1 = dot(q, v.e1), q2 = dot(q, v.e2);
        Vec2 ab((q1 * e22 - q2 * e12) / det, (q2 * e11 - q1 * e12) / det);
        return triangle ? Vec2(ab.x, ab.x < 1.f ? ab.y / (1.f - ab.x) : 0.f) : ab;
      },
      [&](Vec2 st) {
        Vec2 ab = triangle ? Vec2(st.x, st.y * (1.f - st.x)) : st;
        Vec3 d = v.p0 + v.e1 * ab.x + v.e2 * ab.y - v.x;
        double d2 = length_sq(d);
        return std::fabs(dot(nn, d)) / (d2 * std::sqrt(d2)) * jac_area / omega * (triangle ? 1.0 - st.x : 1.0);
      },
      Vec2(0, 0), Vec2(1, 1), seed, 12, 12);
}

struct PolyCase {
  const char* name;
  PolygonView v;
};
const PolyCase kPolygons[] = {
    {"overhead", {Vec3(0, 0, 0), Vec3(-0.5f, 1, -0.3f), Vec3(1.2f, 0, 0), Vec3(0, 0, 0.8f)}},
    {"oblique", {Vec3(0.2f, -0.1f, 0.3f), Vec3(1, 0.3f, -1), Vec3(0, 1.5f, 0.2f), Vec3(0.9f, 0, 0.6f)}},
    {"close", {Vec3(0.1f, 0.05f, 0.2f), Vec3(-1, 0.1f, -1), Vec3(2, 0, 0), Vec3(0, 0, 2)}},
    // About 1e-3 sr, a few times the lights' lower bound on spherical sampling.
    {"far", {Vec3(0, 0, 0), Vec3(5, 5, 5), Vec3(0.5f, 0, 0), Vec3(0, 0.4f, 0.2f)}},
};

// Of 5000 random u (stream `seed`), how many come back from sample-then-invert more than 2e-3 away.
template <class RoundTrip>
int far_round_trips(uint32_t seed, RoundTrip round_trip) {
  Rng rng(seed, seed, seed);
  int far = 0;
  for (int i = 0; i < 5000; ++i) {
    const Vec2 u = rng.uniform2();
    const Vec2 back = round_trip(u);
    far += std::fabs(back.x - u.x) > 2e-3f || std::fabs(back.y - u.y) > 2e-3f;
  }
  return far;
}

TEST(SphericalTriangle, SolidAngleUniformSamplesAndInverse) {
  for (const PolyCase& c : kPolygons) {
    SCOPED_TRACE(c.name);
    const PolygonView& v = c.v;
    SphericalTriangle t = make_spherical_triangle(v.x, v.p0, v.p0 + v.e1, v.p0 + v.e2);
    double q = quadrature_solid_angle(v.x, {v.p0, v.p0 + v.e1, v.p0 + v.e2});
    EXPECT_NEAR(t.area, q, 2e-4 * q);
    expect_plane_samples_uniform_in_solid_angle(v, true, t.area, [&](Vec2 u) { return sample_spherical_triangle(t, u); },
                                                8);
    EXPECT_LE(far_round_trips(8, [&](Vec2 u) {
                return invert_spherical_triangle_sample(t, sample_spherical_triangle(t, u));
              }),
              5)
        << "inverse round trips off by more than 2e-3";
  }
}

TEST(SphericalRectangle, SolidAngleUniformSamplesAndInverse) {
  for (const PolyCase& c : kPolygons) {
    SCOPED_TRACE(c.name);
    PolygonView v = c.v;
    v.e2 = normalize(cross(cross(v.e1, v.e2), v.e1)) * length(v.e2);  // a rectangle
    SphericalRectangle r = make_spherical_rectangle(v.x, v.p0, v.e1, v.e2);
    double q = quadrature_solid_angle(v.x, {v.p0, v.p0 + v.e1, v.p0 + v.e1 + v.e2, v.p0 + v.e2});
    EXPECT_NEAR(r.area, q, 2e-4 * q);
    expect_plane_samples_uniform_in_solid_angle(v, false, r.area,
                                                [&](Vec2 u) { return normalize(sample_spherical_rectangle(r, u) - v.x); }, 9);
    // u = (0, 0) is the corner p0, u.x runs along e1 and u.y along e2.
    Vec3 c00 = sample_spherical_rectangle(r, Vec2(0.f, 0.f)), c11 = sample_spherical_rectangle(r, Vec2(kOneMinusEpsilon, kOneMinusEpsilon));
    EXPECT_LT(length(c00 - v.p0), 1e-3f * length(v.e1));
    EXPECT_LT(length(c11 - (v.p0 + v.e1 + v.e2)), 1e-3f * length(v.e1));
    EXPECT_LT(length(sample_spherical_rectangle(r, Vec2(kOneMinusEpsilon, 0.f)) - (v.p0 + v.e1)), 1e-3f * length(v.e1));
    EXPECT_LE(far_round_trips(9, [&](Vec2 u) {
                return invert_spherical_rectangle_sample(r, sample_spherical_rectangle(r, u));
              }),
              5)
        << "inverse round trips off by more than 2e-3";
  }
}

// --- Projected spherical cap -----------------------------------------------------------

// Omega_p = integral over the cap of max(0, n . w), by quadrature in the cap's
// own (theta, phi) (double; the integrand is continuous).
double quadrature_projected_cap(Vec3 axis, double sin2, Vec3 n, int nt = 800, int np = 1600) {
  double cos_max = std::sqrt(1 - sin2), sum = 0;
  Frame f = Frame::from_z(axis);
  for (int i = 0; i < nt; ++i) {
    double z = 1 - (1 - cos_max) * (i + 0.5) / nt;  // uniform in cos: d omega = dz dphi
    double s = std::sqrt(std::max(0.0, 1 - z * z));
    for (int j = 0; j < np; ++j) {
      double phi = 2 * M_PI * (j + 0.5) / np;
      Vec3 w = f.to_world(Vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(z)));
      sum += std::max(0.0, double(dot(w, n)));
    }
  }
  return sum * (1 - cos_max) * 2 * M_PI / (double(nt) * np);
}

struct CapCase {
  const char* name;
  float sin2, beta_deg;
  ProjectedCapMode mode;
};

class ProjectedCapSampling : public ::testing::TestWithParam<CapCase> {};

TEST_P(ProjectedCapSampling, DensityIsCosineOverProjectedSolidAngle) {
  const CapCase c = GetParam();
  const Vec3 n(0, 0, 1);
  const float b = c.beta_deg * kPi / 180.f;
  const Vec3 axis = normalize(Vec3(std::sin(b) * 0.8f, std::sin(b) * 0.6f, std::cos(b)));
  const ProjectedCap cap = make_projected_cap(axis, c.sin2, n);
  ASSERT_EQ(int(cap.mode), int(c.mode));
  const double omega_p = quadrature_projected_cap(axis, c.sin2, n);
  // The density's normaliser is Omega_p, except in the rejection case (the
  // disk segment's area, larger: some samples are rejected).
  if (c.mode == ProjectedCapMode::Rejection) EXPECT_GT(cap.norm, omega_p * (1 - 1e-4));
  else if (c.mode != ProjectedCapMode::Cone && c.mode != ProjectedCapMode::Empty)
    EXPECT_NEAR(cap.norm, omega_p, 1e-4 * omega_p + 1e-7);
  auto pdf = [&](Vec3 w) { return double(projected_cap_pdf(cap, w)); };
  auto sample = [&](Vec2 u, Vec3* w) {
    float p;
    return sample_projected_cap(cap, u, w, &p);
  };
  const double cos_max = std::sqrt(1.0 - c.sin2);
  if (c.sin2 > 1e-4) {
    expect_matches_pdf(DirectionGrid(axis, cos_max, 16, 24), sample, pdf, 10);
    const double mass = integrate_pdf(DirectionGrid(axis, cos_max, 16, 32), pdf, 16);
    EXPECT_NEAR(mass, c.mode == ProjectedCapMode::Empty       ? 0.0
                      : c.mode == ProjectedCapMode::Rejection ? omega_p / cap.norm
                                                              : 1.0,
                2e-3);
  }
  // Every sample: in the cap, above the horizon, its pdf that of pdf(); the
  // estimate of Omega_p, cos / pdf, is exact (zero variance) where nothing is
  // rejected.
  Rng rng(11, 11, 11);
  int rejected = 0, mismatched = 0;
  for (int i = 0; i < 20000; ++i) {
    Vec3 w;
    float p;
    if (!sample_projected_cap(cap, rng.uniform2(), &w, &p)) {
      ++rejected;
      continue;
    }
    ASSERT_GT(p, 0.f);
    EXPECT_GT(dot(w, n), 0.f);
    mismatched += std::fabs(pdf(w) - p) > 1e-4 * p;
    if (c.mode != ProjectedCapMode::Cone && c.mode != ProjectedCapMode::Rejection)
      EXPECT_NEAR(dot(w, n) / p, omega_p, 2e-3 * omega_p);
  }
  EXPECT_LE(mismatched, 2) << "pdf() differs from the sampled pdf";
  if (c.mode == ProjectedCapMode::Rejection) EXPECT_NEAR(rejected / 20000.0, 1 - omega_p / cap.norm, 0.02);
  else if (c.mode == ProjectedCapMode::Empty) EXPECT_EQ(rejected, 20000);
  else EXPECT_EQ(rejected, 0);
}

INSTANTIATE_TEST_SUITE_P(Modes, ProjectedCapSampling,
                         ::testing::Values(CapCase{"ellipse_overhead", 0.25f, 0.f, ProjectedCapMode::Ellipse},
                                           CapCase{"ellipse_tilted", 0.1f, 55.f, ProjectedCapMode::Ellipse},
                                           CapCase{"ellipse_small", 2e-4f, 70.f, ProjectedCapMode::Ellipse},
                                           CapCase{"crossing_high", 0.5f, 60.f, ProjectedCapMode::Crossing},
                                           CapCase{"crossing_low", 0.2f, 85.f, ProjectedCapMode::Crossing},
                                           CapCase{"crossing_wide", 0.95f, 30.f, ProjectedCapMode::Crossing},
                                           CapCase{"rejection_horizon", 0.3f, 91.f, ProjectedCapMode::Rejection},
                                           CapCase{"rejection_below", 0.4f, 110.f, ProjectedCapMode::Rejection},
                                           CapCase{"cone_tiny", 4e-7f, 30.f, ProjectedCapMode::Cone},
                                           CapCase{"empty", 0.1f, 120.f, ProjectedCapMode::Empty}),
                         [](const ::testing::TestParamInfo<CapCase>& info) { return std::string(info.param.name); });

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
