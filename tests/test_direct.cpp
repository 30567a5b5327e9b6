// The direct-lighting estimator of each strategy against closed forms.
//
// Irradiance from a uniform sphere light of radiance L whose centre is at
// distance d, with sin(theta_max) = r / d:
//   normal facing the centre:           E = pi L sin^2(theta_max)
//   normal tilted by beta (sphere wholly above the horizon, beta + theta_max <= 90 deg):
//                                       E = pi L sin^2(theta_max) cos(beta)
// estimate_direct() returns f * L * cos / pdf; with albedo 1, f = 1/pi, so
// pi * estimate is an unbiased estimate of E.
#include <gtest/gtest.h>

#include "core/integrator.h"
#include "stat_util.h"

namespace pn {
namespace {

struct NoOccluder {
  bool occluded(const Ray&, float) const { return false; }
};

test::MeanEstimator irradiance(Strategy strategy, const Light& light, Vec3 x, Vec3 n, int samples, uint32_t seed) {
  SceneView scene;
  scene.lights = &light;
  scene.num_lights = 1;
  const Bsdf white = make_lambert(Vec3(1.f), n);
  Rng rng(0, 0, seed);
  test::MeanEstimator est;
  for (int i = 0; i < samples; ++i) {
    float us = rng.uniform();
    Vec2 u = rng.uniform2();
    est.add(kPi * estimate_direct(NoOccluder{}, scene, strategy, white, x, n, us, u).x);
  }
  return est;
}

struct Case {
  float d_over_r;
  float beta_deg;
};

class DirectIrradiance : public ::testing::TestWithParam<Case> {};

TEST_P(DirectIrradiance, EachStrategyMatchesTheClosedForm) {
  const Case c = GetParam();
  const float r = 0.25f, L = 3.f;
  const float d = c.d_over_r * r;
  Light light = Light::sphere(Vec3(1.f, 2.f, -1.f), r, Vec3(L));
  Vec3 to_light = normalize(Vec3(0.2f, 1.f, 0.3f));
  Vec3 x = light.p - to_light * d;
  // Tilt the normal away from the light direction by beta.
  Frame f = Frame::from_z(to_light);
  float b = c.beta_deg * kPi / 180.f;
  Vec3 n = normalize(f.to_world(Vec3(std::sin(b), 0.f, std::cos(b))));
  double sin2 = double(r) * r / (double(d) * d);
  double expected = M_PI * L * sin2 * std::cos(double(b));
  ASSERT_LE(c.beta_deg + std::asin(std::sqrt(sin2)) * 180 / M_PI, 90.0) << "case must keep the sphere above the horizon";

  const int N = 200000;
  auto area = irradiance(Strategy::Area, light, x, n, N, 1);
  auto cone = irradiance(Strategy::SolidAngle, light, x, n, N, 2);
  for (const auto& [name, e] : {std::pair<const char*, test::MeanEstimator>{"area", area}, {"solid-angle", cone}}) {
    EXPECT_NEAR(e.mean(), expected, 4 * e.std_error() + 5e-5 * expected)  // + float rounding
        << name << ": d/r " << c.d_over_r << ", beta " << c.beta_deg << ", E " << expected << ", se " << e.std_error();
  }
  double se = std::sqrt(area.std_error() * area.std_error() + cone.std_error() * cone.std_error());
  EXPECT_NEAR(area.mean(), cone.mean(), 4 * se) << "the two strategies disagree";
  // Cone sampling never wastes a sample on the far side: lower variance here.
  EXPECT_LT(cone.std_error(), area.std_error());
}

INSTANTIATE_TEST_SUITE_P(Geometry, DirectIrradiance,
                         ::testing::Values(Case{1.2f, 0.f}, Case{2.f, 0.f}, Case{2.f, 25.f}, Case{5.f, 60.f},
                                           Case{20.f, 45.f}, Case{100.f, 0.f}, Case{100.f, 80.f}),
                         [](const ::testing::TestParamInfo<Case>& info) {  // e.g. "d_over_r_1_2_beta_0"
                           std::string n = "d_over_r_" + std::to_string(info.param.d_over_r).substr(0, 5) +
                                           "_beta_" + std::to_string(int(info.param.beta_deg));
                           for (char& c : n)
                             if (c == '.') c = '_';
                           return n;
                         });

// Without the cosine, L / pdf of cone sampling is the constant L * solid angle:
// a zero-variance estimator of the light's solid angle (Taylor branch included).
TEST(DirectIrradiance, ConeSamplingOfSolidAngleHasZeroVariance) {
  for (float d_over_r : {1.5f, 10.f, 1000.f}) {
    const float r = 0.1f;
    Light light = Light::sphere(Vec3(0.f), r, Vec3(2.f));
    Vec3 x(0.f, 0.f, -d_over_r * r);
    double sin2 = 1.0 / (double(d_over_r) * d_over_r);
    double omega = 2 * M_PI * sin2 / (1 + std::sqrt(1 - sin2));  // 2 pi (1 - cos), stably
    Rng rng(1, 1, 1);
    for (int i = 0; i < 1000; ++i) {
      LightSample s = sample_light_solid_angle(light, x, rng.uniform2());
      ASSERT_GT(s.pdf, 0.f);
      EXPECT_NEAR(s.L.x / s.pdf, 2.0 * omega, 2e-3 * 2.0 * omega) << "d/r " << d_over_r;
    }
  }
}

TEST(DirectIrradiance, BsdfStrategyDoesNoLightSampling) {
  Light light = Light::sphere(Vec3(0.f, 1.f, 0.f), 0.5f, Vec3(1.f));
  EXPECT_FALSE(strategy_uses_nee(Strategy::Bsdf));
  EXPECT_TRUE(strategy_uses_nee(Strategy::Area));
  EXPECT_TRUE(strategy_uses_nee(Strategy::SolidAngle));
  auto e = irradiance(Strategy::Bsdf, light, Vec3(0.f), Vec3(0, 1, 0), 100, 1);
  EXPECT_EQ(e.mean(), 0.0);
}

TEST(Strategy, NamesRoundTrip) {
  for (int i = 0; i < kNumStrategies; ++i) {
    std::string name = strategy_name(Strategy(i));
    EXPECT_FALSE(name.empty());
    EXPECT_STRNE(strategy_description(Strategy(i)), "?");
  }
  EXPECT_STREQ(strategy_name(Strategy::Area), "area");
  EXPECT_STREQ(strategy_name(Strategy::SolidAngle), "solid-angle");
  EXPECT_STREQ(strategy_name(Strategy::Bsdf), "bsdf");
}

}  // namespace
}  // namespace pn
