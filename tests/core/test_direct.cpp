// The direct-lighting estimator of each strategy, with and without MIS, against
// closed forms, within 4 standard errors.
//
// Irradiance at x (normal n) from a uniform light of radiance L:
//   sphere wholly above the horizon, centre at distance d, sin(theta_max) = r / d,
//   centre at angle beta from n:   E = pi L sin^2(theta_max) cos(beta)
//   sphere crossing the horizon:   E = L * integral of max(0, n.w) over its cone
//                                  (double quadrature: no closed form is simple)
//   polygon:                       Lambert's formula on the polygon clipped to
//                                  the upper half-space of n,
//                                  E = L / 2 |sum_i angle(v_i, v_i+1) n . unit(v_i x v_i+1)|
// estimate_direct() returns f * L * cos / pdf (times the MIS weight); with
// albedo 1, f = 1 / pi, so pi * estimate is an unbiased estimate of E (of its
// light-sampling share with MIS, to which the BSDF-sampled share is added here).
#include <gtest/gtest.h>

#include <array>

#include "core/integrator.h"
#include "stat_util.h"

namespace pn {
namespace {

struct NoOccluder {
  bool occluded(const Ray&, float) const { return false; }
};

constexpr Strategy kLightStrategies[] = {Strategy::Area, Strategy::SolidAngle, Strategy::ProjectedSolidAngle};

// Does unit w from x reach the light's emitting side? (Geometry only, no pdfs.)
bool hits_light(const Light& l, Vec3 x, Vec3 w) {
  float t;
  Vec2 b;
  switch (l.type) {
    case LightType::Sphere:
      return sphere_light_distance(l, x, w, &t, false);
    case LightType::Quad:
      return quad_light_distance(l, x, w, &t);
    case LightType::Triangle:
      return triangle_light_distance(l, x, w, &t, &b);
    case LightType::Environment:
      return true;
  }
  return false;
}

// The one-vertex estimator of the integrator: a light sample (estimate_direct,
// MIS-weighted) plus, with MIS, a BSDF sample weighted by bsdf_emission_weight()
// where it hits the light. Both weights come from the integrator's own code.
test::MeanEstimator irradiance(const IntegratorSettings& s, const Light& light, Vec3 x, Vec3 n, int samples,
                               uint32_t seed) {
  SceneView scene;
  scene.lights = &light;
  scene.num_lights = 1;
  const Bsdf white = make_lambert(Vec3(1.f), n);
  Rng rng(0, 0, seed);
  test::MeanEstimator est;
  for (int i = 0; i < samples; ++i) {
    float us = rng.uniform();
    Vec2 u = rng.uniform2();
    double e = kPi * estimate_direct(NoOccluder{}, scene, s, white, x, 0.f, n, us, u).x;
    float ul = rng.uniform();
    Vec2 ub = rng.uniform2();
    if (s.mis != Mis::None) {
      BsdfSample bs = bsdf_sample(white, n, ul, ub);
      if (bs.pdf > 0.f && hits_light(light, x, bs.wi)) {
        const PrevVertex prev = PrevVertex::at(LightSampleContext{x, white.frame.n}, bs.pdf);
        e += kPi * light.radiance.x * bs.weight.x * bsdf_emission_weight(scene, s, prev, 0, bs.wi);
      }
    }
    est.add(e);
  }
  return est;
}

// The same one-vertex estimator on a glossy surface seen from wo (luminance): the light sample and, with MIS, the
// BSDF sample, whose weight asks the light's pdf with the context the integrator keeps for it.
test::MeanEstimator glossy_direct(const IntegratorSettings& s, const Light& light, const Bsdf& bsdf, Vec3 x, Vec3 wo,
                                  int samples, uint32_t seed) {
  SceneView scene;
  scene.lights = &light;
  scene.num_lights = 1;
  Rng rng(0, 0, seed);
  test::MeanEstimator est;
  for (int i = 0; i < samples; ++i) {
    const float us = rng.uniform();
    const Vec2 u = rng.uniform2();
    double e = luminance(estimate_direct(NoOccluder{}, scene, s, bsdf, x, 0.f, wo, us, u));
    const float ul = rng.uniform();
    const Vec2 ub = rng.uniform2();
    if (s.mis != Mis::None) {
      const BsdfSample bs = bsdf_sample(bsdf, wo, ul, ub);
      if (bs.pdf > 0.f && hits_light(light, x, bs.wi)) {
        const PrevVertex prev = PrevVertex::at(light_sample_context(s, x, bsdf, wo), bs.pdf);
        e += luminance(light.radiance * bs.weight) * bsdf_emission_weight(scene, s, prev, 0, bs.wi);
      }
    }
    est.add(e);
  }
  return est;
}

IntegratorSettings settings(Strategy st, Mis mis) {
  IntegratorSettings s;
  s.strategy = st;
  s.mis = mis;
  return s;
}

// Integral of max(0, n . w) over the cone around `axis` with sin^2 = sin2 (double).
double projected_cone(Vec3 axis, double sin2, Vec3 n) {
  const int nt = 1000, np = 2000;
  double cos_max = std::sqrt(1 - sin2), sum = 0;
  Frame f = Frame::from_z(axis);
  for (int i = 0; i < nt; ++i) {
    double z = 1 - (1 - cos_max) * (i + 0.5) / nt, s = std::sqrt(std::max(0.0, 1 - z * z));
    for (int j = 0; j < np; ++j) {
      double phi = 2 * M_PI * (j + 0.5) / np;
      sum += std::max(0.0, double(dot(f.to_world(Vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(z))), n)));
    }
  }
  return sum * (1 - cos_max) * 2 * M_PI / (double(nt) * np);
}

// --- Sphere lights ------------------------------------------------------------------

struct SphereCase {
  float d_over_r;
  float beta_deg;
};

class SphereIrradiance : public ::testing::TestWithParam<SphereCase> {};

TEST_P(SphereIrradiance, EveryStrategyAndMisModeMatchesTheClosedForm) {
  const SphereCase c = GetParam();
  const float r = 0.25f, L = 3.f;
  const float d = c.d_over_r * r;
  Light light = Light::sphere(Vec3(1.f, 2.f, -1.f), r, Vec3(L));
  Vec3 to_light = normalize(Vec3(0.2f, 1.f, 0.3f));
  Vec3 x = light.p - to_light * d;
  Frame f = Frame::from_z(to_light);
  float b = c.beta_deg * kPi / 180.f;
  Vec3 n = normalize(f.to_world(Vec3(std::sin(b), 0.f, std::cos(b))));
  double sin2 = double(r) * r / (double(d) * d);
  const bool above = c.beta_deg + std::asin(std::sqrt(sin2)) * 180 / M_PI <= 90.0;
  double expected = above ? M_PI * L * sin2 * std::cos(double(b)) : L * projected_cone(to_light, sin2, n);
  for (Strategy st : kLightStrategies)
    for (Mis m : {Mis::None, Mis::Balance, Mis::Power}) {
      auto e = irradiance(settings(st, m), light, x, n, 100000, 1 + int(st) * 3 + int(m));
      EXPECT_NEAR(e.mean(), expected, 4 * e.std_error() + 2e-4 * expected)
          << strategy_name(st) << " + " << mis_name(m) << ": d/r " << c.d_over_r << ", beta " << c.beta_deg << ", E "
          << expected << ", se " << e.std_error();
    }
  // Cone sampling never wastes a sample on the far side: lower variance than area.
  auto area = irradiance(settings(Strategy::Area, Mis::None), light, x, n, 100000, 1);
  auto cone = irradiance(settings(Strategy::SolidAngle, Mis::None), light, x, n, 100000, 2);
  EXPECT_LT(cone.std_error(), area.std_error());
  // Projected solid angle: no variance at all where the sphere is above the horizon.
  auto proj = irradiance(settings(Strategy::ProjectedSolidAngle, Mis::None), light, x, n, 20000, 3);
  if (above && sin2 >= kMinProjectedCapSin2) {
    EXPECT_LT(proj.std_error(), 1e-5 * expected) << "projected-solid-angle should be exact here";
  }
}

INSTANTIATE_TEST_SUITE_P(Geometry, SphereIrradiance,
                         ::testing::Values(SphereCase{1.2f, 0.f}, SphereCase{2.f, 0.f}, SphereCase{2.f, 25.f},
                                           SphereCase{5.f, 60.f}, SphereCase{20.f, 45.f}, SphereCase{100.f, 0.f},
                                           SphereCase{100.f, 80.f}, SphereCase{2000.f, 10.f},  // the cone fallback
                                           SphereCase{1.5f, 70.f}, SphereCase{3.f, 85.f},      // across the horizon
                                           SphereCase{1.05f, 95.f}, SphereCase{2.f, 105.f}),   // centre below it
                         [](const ::testing::TestParamInfo<SphereCase>& info) {  // e.g. "d_over_r_1_2_beta_0"
                           std::string n = "d_over_r_" + std::to_string(info.param.d_over_r).substr(0, 6) +
                                           "_beta_" + std::to_string(int(info.param.beta_deg));
                           for (char& c : n)
                             if (c == '.') c = '_';
                           return n;
                         });

// Without the cosine, L / pdf of cone sampling is the constant L * solid angle:
// a zero-variance estimator of the light's solid angle, however far the light.
TEST(SphereIrradiance, ConeSamplingOfSolidAngleHasZeroVariance) {
  for (float d_over_r : {1.5f, 10.f, 1000.f, 30000.f}) {
    const float r = 0.1f;
    Light light = Light::sphere(Vec3(0.f), r, Vec3(2.f));
    LightSampleContext ctx{Vec3(0.f, 0.f, -d_over_r * r), Vec3(0, 0, 1)};
    double sin2 = 1.0 / (double(d_over_r) * d_over_r);
    double omega = 2 * M_PI * sin2 / (1 + std::sqrt(1 - sin2));  // 2 pi (1 - cos), stably
    Rng rng(1, 1, 1);
    for (int i = 0; i < 1000; ++i) {
      LightSample s = SolidAngleSampling::sample_sphere(light, ctx, rng.uniform2());
      ASSERT_GT(s.pdf, 0.f);
      EXPECT_NEAR(2.0 / s.pdf, 2.0 * omega, 2e-5 * 2.0 * omega) << "d/r " << d_over_r;
    }
  }
}

TEST(SphereIrradiance, BsdfStrategyDoesNoLightSampling) {
  Light light = Light::sphere(Vec3(0.f, 1.f, 0.f), 0.5f, Vec3(1.f));
  EXPECT_FALSE(strategy_uses_nee(Strategy::Bsdf));
  for (Strategy s : kLightStrategies) EXPECT_TRUE(strategy_uses_nee(s));
  auto e = irradiance(settings(Strategy::Bsdf, Mis::None), light, Vec3(0.f), Vec3(0, 1, 0), 100, 1);
  EXPECT_EQ(e.mean(), 0.0);
}

// --- Polygon lights ---------------------------------------------------------------------

// The part of a convex polygon with dot(p - x, n) >= 0 (Sutherland-Hodgman).
std::vector<Vec3> clip_to_upper_half(const std::vector<Vec3>& poly, Vec3 x, Vec3 n) {
  std::vector<Vec3> out;
  for (size_t i = 0; i < poly.size(); ++i) {
    Vec3 a = poly[i], b = poly[(i + 1) % poly.size()];
    double da = dot(a - x, n), db = dot(b - x, n);
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) out.push_back(a + (b - a) * float(da / (da - db)));
  }
  return out;
}

// Lambert's formula after clipping at the horizon, in double: its terms cancel
// for small, distant polygons.
double polygon_irradiance(Vec3 x, Vec3 n, const std::vector<Vec3>& poly, double L) {
  using D3 = std::array<double, 3>;
  auto sub = [](Vec3 p, Vec3 q) { return D3{double(p.x) - q.x, double(p.y) - q.y, double(p.z) - q.z}; };
  auto dot3 = [](D3 a, D3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  auto cross3 = [](D3 a, D3 b) {
    return D3{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  };
  std::vector<Vec3> p = clip_to_upper_half(poly, x, n);
  const D3 N{n.x, n.y, n.z};
  double sum = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    D3 a = sub(p[i], x), b = sub(p[(i + 1) % p.size()], x);
    D3 c = cross3(a, b);
    double l = std::sqrt(dot3(c, c));
    if (l > 0) sum += std::atan2(l, dot3(a, b)) * dot3(c, N) / l;
  }
  return std::fabs(0.5 * L * sum);
}

struct PolygonCase {
  const char* name;
  LightType type;
  Vec3 p, e1, e2, x;
  float beta_deg;  // the normal's angle from the direction to the light's centre
};

class PolygonIrradiance : public ::testing::TestWithParam<PolygonCase> {};

TEST_P(PolygonIrradiance, EveryStrategyAndMisModeMatchesLambertsFormula) {
  const PolygonCase c = GetParam();
  const float L = 3.f;
  Light l = c.type == LightType::Quad ? Light::quad(c.p, c.e1, c.e2, Vec3(L)) : Light::triangle(c.p, c.p + c.e1, c.p + c.e2, Vec3(L));
  if (!faces_emitting_side(l, c.x))  // lights are one-sided: face x
    l = c.type == LightType::Quad ? Light::quad(c.p, c.e2, c.e1, Vec3(L)) : Light::triangle(c.p, c.p + c.e2, c.p + c.e1, Vec3(L));
  std::vector<Vec3> poly = {c.p, c.p + c.e1};
  if (c.type == LightType::Quad) poly.push_back(c.p + c.e1 + c.e2);
  poly.push_back(c.p + c.e2);
  Vec3 centre(0.f);
  for (Vec3 q : poly) centre += q * (1.f / poly.size());
  Frame f = Frame::from_z(normalize(centre - c.x));
  float b = c.beta_deg * kPi / 180.f;
  Vec3 n = normalize(f.to_world(Vec3(std::sin(b), 0.f, std::cos(b))));
  const double expected = polygon_irradiance(c.x, n, poly, L);
  ASSERT_GT(expected, 0.0);
  // ltc's mixture weighs its lobes by the same form factor in float (core/ltc.h): E = pi L F (within 1e-3: the edge
  // terms of a polygon far away nearly cancel, 3e-4 of tiny_far_triangle's is rounding).
  Vec3 corners[4];
  const int count = light_polygon(l, c.x, Frame::from_z(n), corners);
  EXPECT_NEAR(kPi * L * polygon_form_factor(corners, count), expected, 1e-3 * expected) << c.name;
  const float sl_area = planar_light_solid_angle(l, c.x);
  for (Strategy st : kLightStrategies)
    for (Mis m : {Mis::None, Mis::Balance, Mis::Power}) {
      auto e = irradiance(settings(st, m), l, c.x, n, 100000, 7 + int(st) * 3 + int(m));
      EXPECT_NEAR(e.mean(), expected, 4 * e.std_error() + 3e-4 * expected)
          << c.name << ", " << strategy_name(st) << " + " << mis_name(m) << ": E " << expected << ", se "
          << e.std_error() << ", solid angle " << sl_area;
    }
}

// ltc samples by the BSDF's lobes: on a coated and on a metallic GGX surface, seen from the mirror direction of
// the light's centre, its estimate with and without MIS is area sampling's (both within four standard errors of
// their difference; area sampling's pdf knows no lobe).
TEST_P(PolygonIrradiance, LtcMatchesAreaSamplingOnGlossySurfaces) {
  const PolygonCase c = GetParam();
  const float L = 3.f;
  Light l = c.type == LightType::Quad ? Light::quad(c.p, c.e1, c.e2, Vec3(L)) : Light::triangle(c.p, c.p + c.e1, c.p + c.e2, Vec3(L));
  if (!faces_emitting_side(l, c.x))
    l = c.type == LightType::Quad ? Light::quad(c.p, c.e2, c.e1, Vec3(L)) : Light::triangle(c.p, c.p + c.e2, c.p + c.e1, Vec3(L));
  const Vec3 centre = l.p + (l.e1 + l.e2) * (c.type == LightType::Quad ? 0.5f : 1.f / 3);
  Frame f = Frame::from_z(normalize(centre - c.x));
  const float b = c.beta_deg * kPi / 180.f;
  const Vec3 n = normalize(f.to_world(Vec3(std::sin(b), 0.f, std::cos(b))));
  const Vec3 to_light = normalize(centre - c.x);
  Vec3 wo = n * (2.f * dot(n, to_light)) - to_light;
  if (dot(wo, n) < 0.1f) wo = normalize(wo + n * (0.1f - dot(wo, n) + 0.05f));
  struct Surface {
    const char* name;
    Bsdf bsdf;
  };
  const Surface surfaces[] = {{"coated, roughness 0.3", make_bsdf(Vec3(0.5f), 0.f, 0.3f, 0.5f, n, n)},
                              {"metal, roughness 0.15", make_bsdf(Vec3(0.9f), 1.f, 0.15f, 0.f, n, n)}};
  for (const Surface& sf : surfaces) {
    const auto area = glossy_direct(settings(Strategy::Area, Mis::None), l, sf.bsdf, c.x, wo, 200000, 11);
    for (Mis m : {Mis::None, Mis::Power}) {
      const auto e = glossy_direct(settings(Strategy::Ltc, m), l, sf.bsdf, c.x, wo, 100000, 12 + int(m));
      const double se = std::sqrt(e.std_error() * e.std_error() + area.std_error() * area.std_error());
      EXPECT_NEAR(e.mean(), area.mean(), 4 * se + 3e-4 * area.mean())
          << c.name << ", " << sf.name << ", ltc + " << mis_name(m) << " (se " << e.std_error() << ") against area (se "
          << area.std_error() << ")";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    Geometry, PolygonIrradiance,
    ::testing::Values(
        PolygonCase{"rectangle_overhead", LightType::Quad, Vec3(-0.5f, 1, -0.5f), Vec3(1, 0, 0), Vec3(0, 0, 1.2f), Vec3(0.f), 0.f},
        PolygonCase{"rectangle_tilted", LightType::Quad, Vec3(-0.5f, 1, -0.5f), Vec3(1, 0.3f, 0), Vec3(0, 0, 1.2f), Vec3(0.3f, 0, 0), 40.f},
        PolygonCase{"rectangle_across_horizon", LightType::Quad, Vec3(-0.5f, 1, -0.5f), Vec3(1, 0, 0), Vec3(0, 0, 1.2f), Vec3(0.f), 70.f},
        PolygonCase{"parallelogram", LightType::Quad, Vec3(-0.4f, 1.2f, -0.3f), Vec3(1.1f, 0.1f, 0), Vec3(0.6f, 0.2f, 0.9f), Vec3(0.f), 20.f},
        PolygonCase{"triangle", LightType::Triangle, Vec3(1, 0.3f, -1), Vec3(1, -0.1f, 2), Vec3(0.5f, 1.7f, 1.3f), Vec3(0.f), 15.f},
        PolygonCase{"triangle_close_and_large", LightType::Triangle, Vec3(-3, 0.5f, -3), Vec3(6, 0, 0), Vec3(3, 0, 7), Vec3(0.2f, 0, 0.1f), 5.f},
        PolygonCase{"triangle_near_horizon", LightType::Triangle, Vec3(0.5f, 0.02f, -1), Vec3(0.1f, 0.8f, 0.2f), Vec3(0.3f, 0.05f, 2), Vec3(0.f), 75.f},
        PolygonCase{"tiny_far_triangle", LightType::Triangle, Vec3(10, 10, 10), Vec3(0.1f, 0, 0), Vec3(0, 0.1f, 0.05f), Vec3(0.f), 30.f},
        PolygonCase{"almost_on_the_rectangle", LightType::Quad, Vec3(-0.3f, 0.003f, -0.3f), Vec3(1, 0, 0), Vec3(0, 0, 1), Vec3(0.f), 0.f},
        PolygonCase{"almost_on_the_triangle", LightType::Triangle, Vec3(-0.3f, 0.003f, -0.3f), Vec3(1, 0, 0), Vec3(0, 0, 1), Vec3(0.f), 0.f}),
    [](const ::testing::TestParamInfo<PolygonCase>& info) { return std::string(info.param.name); });

TEST(PolygonIrradiance, TheCasesCoverBothSolidAngleBounds) {
  // "tiny_far_triangle" lies below kMinSphericalSolidAngle, the "almost_on" cases above kMaxSphericalSolidAngle.
  Light tiny = Light::triangle(Vec3(10, 10, 10), Vec3(10.1f, 10, 10), Vec3(10, 10.1f, 10.05f), Vec3(1.f));
  if (!faces_emitting_side(tiny, Vec3(0.f))) tiny = Light::triangle(Vec3(10, 10, 10), Vec3(10, 10.1f, 10.05f), Vec3(10.1f, 10, 10), Vec3(1.f));
  EXPECT_LT(planar_light_solid_angle(tiny, Vec3(0.f)), kMinSphericalSolidAngle);
  Light near = Light::quad(Vec3(-0.3f, 0.003f, -0.3f), Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(1.f));
  EXPECT_GT(planar_light_solid_angle(near, Vec3(0.f)), kMaxSphericalSolidAngle);
}

TEST(Strategy, NamesRoundTrip) {
  for (int i = 0; i < kNumStrategies; ++i) {
    std::string name = strategy_name(Strategy(i));
    EXPECT_FALSE(name.empty());
    EXPECT_STRNE(strategy_description(Strategy(i)), "?");
  }
  EXPECT_STREQ(strategy_name(Strategy::Area), "area");
  EXPECT_STREQ(strategy_name(Strategy::SolidAngle), "solid-angle");
  EXPECT_STREQ(strategy_name(Strategy::ProjectedSolidAngle), "projected-solid-angle");
  EXPECT_STREQ(strategy_name(Strategy::Bsdf), "bsdf");
  EXPECT_STREQ(strategy_name(Strategy::Ltc), "ltc");
  EXPECT_STREQ(mis_name(Mis::Power), "power");
}

}  // namespace
}  // namespace pn
