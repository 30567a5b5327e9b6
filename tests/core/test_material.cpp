// The metallic-roughness BSDF (core/material.h) against itself and against
// closed forms: GGX normalisation, visible-normal sampling against its pdf
// (chi-square), bsdf_sample against bsdf_pdf (chi-square in the space of
// directions and in the space of half-vectors), the sample weight against
// f cos / pdf, the pdf's integral against the mass lost below the horizon, a
// white furnace (albedo <= 1) over the parameter grid, and reciprocity.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "core/material.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "grid_util.h"
#include "stat_util.h"

namespace pn {
namespace {

using test::chi2_on_grid;
using test::grid_total;
using test::integrate_grid;
using test::MeanEstimator;

constexpr double kMinP = 1e-3;  // fixed seeds: a correct sampler passes deterministically

Vec3 view_dir(float theta_deg, float phi_deg = 0.f) {
  float t = theta_deg * kPi / 180.f, p = phi_deg * kPi / 180.f;
  return Vec3(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
}

// --- GGX ---------------------------------------------------------------------

// Integral of D(h) cos(theta_h) over the hemisphere (projected microfacet area
// = 1), as a 1D integral in theta with tan(theta) = alpha * r / (1 - r).
double ndf_projected_integral(float alpha) {
  const int n = 200000;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    double r = (i + 0.5) / n, s = r / (1 - r), theta = std::atan(alpha * s);
    double dtheta = alpha / (1 + double(alpha) * alpha * s * s) / ((1 - r) * (1 - r));
    Vec3 h(float(std::sin(theta)), 0.f, float(std::cos(theta)));
    sum += ggx_d(h, alpha) * std::cos(theta) * std::sin(theta) * dtheta;
  }
  return 2 * M_PI * sum / n;
}

TEST(Ggx, DistributionIsNormalised) {
  for (float alpha : {0.05f, 0.3f, 0.8f, 1.f}) {
    EXPECT_NEAR(ndf_projected_integral(alpha), 1.0, 2e-4) << "alpha " << alpha;
  }
  // Below the surface D is 0.
  EXPECT_EQ(ggx_d(Vec3(0.f, 0.6f, -0.8f), 0.3f), 0.f);
}

// Near-mirror lobes, down to kMinGgxAlpha (roughness 0.0316): D's denominator
// c2 (a2 - 1) + 1 cancels catastrophically in float when a2 is below float's
// resolution near c2 = 1; a2 c2 + (x^2 + y^2) does not.
TEST(Ggx, DistributionIsNormalisedNearMirror) {
  for (float alpha : {kMinGgxAlpha, 0.0025f, 0.01f}) {
    EXPECT_NEAR(ndf_projected_integral(alpha), 1.0, 2e-4) << "alpha " << alpha;
  }
}

struct GgxCase {
  float alpha, theta_deg;
};

class GgxVisibleNormals : public ::testing::TestWithParam<GgxCase> {};

// Visible normals of wo against ggx_visible_normal_pdf: the pdf integrates to 1
// (which checks G1 against D: cos_o / G1 = integral of max(0, wo.h) D), the
// sampled normals fit it (chi-square in GGX slope space), and every sample is
// a unit vector in the upper hemisphere facing wo.
TEST_P(GgxVisibleNormals, MatchPdf) {
  const GgxCase c = GetParam();
  const Vec3 wo = view_dir(c.theta_deg, 30.f);
  const Frame frame = Frame::from_z(Vec3(0.f, 0.f, 1.f));
  test::ParamGrid grid = test::slope_grid(frame, c.alpha, 20, 24);
  auto pdf = [&](Vec3 h) { return double(ggx_visible_normal_pdf(wo, h, c.alpha)); };
  std::vector<double> integrals = integrate_grid(grid, pdf);
  EXPECT_NEAR(grid_total(integrals), 1.0, 1e-3) << "alpha " << c.alpha << ", view " << c.theta_deg;
  int bad = 0;
  auto r = chi2_on_grid(
      grid, integrals, 300000,
      [&](Rng& rng, Vec3* h) {
        *h = ggx_sample_visible_normal(wo, c.alpha, rng.uniform2());
        if (!(std::fabs(length(*h) - 1.f) < 1e-5f) || !(h->z > 0.f) || dot(*h, wo) < -1e-6f) ++bad;
        return true;
      },
      11, pdf);
  EXPECT_GT(r.p_value, kMinP) << "alpha " << c.alpha << ", view " << c.theta_deg << ": " << r.message;
  EXPECT_EQ(bad, 0);
}

INSTANTIATE_TEST_SUITE_P(AlphaView, GgxVisibleNormals,
                         ::testing::Values(GgxCase{0.05f, 0.f}, GgxCase{0.05f, 45.f}, GgxCase{0.05f, 80.f},
                                           GgxCase{0.05f, 89.f}, GgxCase{0.3f, 0.f}, GgxCase{0.3f, 60.f},
                                           GgxCase{0.3f, 85.f}, GgxCase{0.3f, 89.f}, GgxCase{0.8f, 10.f},
                                           GgxCase{0.8f, 70.f}, GgxCase{0.8f, 89.f}),
                         [](const ::testing::TestParamInfo<GgxCase>& i) {
                           return "alpha_" + std::to_string(int(i.param.alpha * 100 + 0.5f)) + "e2_view_" +
                                  std::to_string(int(i.param.theta_deg));
                         });

// --- The whole BSDF: sampling against pdf --------------------------------------

struct BsdfCase {
  float metallic, roughness, specular, theta_deg;
};

std::string case_name(const BsdfCase& c) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "metallic %.2f roughness %.2f specular %.2f view %.0f deg", c.metallic, c.roughness,
                c.specular, c.theta_deg);
  return buf;
}

// A tilted shading frame, so that the world <-> local conversions are exercised.
const Vec3 kNormal = normalize(Vec3(0.3f, -0.5f, 0.8f));

Bsdf case_bsdf(const BsdfCase& c, Vec3 base = Vec3(1.f)) {
  return make_bsdf(base, c.metallic, c.roughness, c.specular, kNormal, kNormal);
}
Vec3 case_wo(const BsdfCase& c) { return Frame::from_z(kNormal).to_world(view_dir(c.theta_deg, 70.f)); }

// Probability that a visible normal reflects wo below the horizon, by
// integrating the visible-normal pdf where reflect(wo, h).z <= 0.
double vndf_mass_below_horizon(Vec3 o, float alpha) {
  test::ParamGrid g = test::slope_grid(Frame::from_z(Vec3(0, 0, 1)), alpha, 16, 16);
  auto e = integrate_grid(g, [&](Vec3 h) {
    return reflect(o, h).z <= 0.f ? double(ggx_visible_normal_pdf(o, h, alpha)) : 0.0;
  });
  return grid_total(e);
}

class BsdfSampling : public ::testing::TestWithParam<BsdfCase> {};

TEST_P(BsdfSampling, SamplesMatchPdfAndWeightsMatchEval) {
  const BsdfCase c = GetParam();
  // A coloured base colour: the weight is checked per channel.
  const Bsdf b = case_bsdf(c, Vec3(0.9f, 0.6f, 0.3f));
  const Vec3 wo = case_wo(c);
  const std::string name = case_name(c);
  const int n = 120000;

  // Every sample: pdf = bsdf_pdf(wi), weight = f cos / pdf.
  {
    Rng rng(1, 2, 3);
    int checked = 0;
    for (int i = 0; i < 20000; ++i) {
      float ul = rng.uniform();
      BsdfSample s = bsdf_sample(b, wo, ul, rng.uniform2());
      if (!(s.pdf > 0.f)) continue;
      ++checked;
      ASSERT_NEAR(length(s.wi), 1.f, 1e-5f) << name;
      float p = bsdf_pdf(b, wo, s.wi);
      ASSERT_NEAR(s.pdf, p, 1e-4f * p) << name;
      Vec3 expect = bsdf_eval(b, wo, s.wi) * (dot(s.wi, kNormal) / p);
      // Float rounding: cos near the horizon in the local frame against the world
      // dot product, and D of the half-vector rebuilt from wo + wi for sharp lobes.
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(s.weight[k], expect[k], 2e-3f * expect[k] + 2e-6f) << name;
      ASSERT_TRUE(is_finite(s.weight)) << name;
    }
    EXPECT_GT(checked, 10000) << name;  // metals lose up to ~30% below the horizon
  }

  // The pdf's integral over the hemisphere is 1 minus the specular lobe's mass
  // below the horizon, and that is also the fraction of samples lost.
  const Frame frame = Frame::from_z(kNormal);
  const Vec3 o = frame.to_local(wo);
  const float ps = bsdf_specular_probability(b, o.z);
  const double lost = ps > 0.f ? ps * vndf_mass_below_horizon(o, b.alpha) : 0.0;
  auto pdf = [&](Vec3 w) { return double(bsdf_pdf(b, wo, w)); };

  auto sample_wi = [&](Rng& rng, Vec3* w) {
    float ul = rng.uniform();
    BsdfSample s = bsdf_sample(b, wo, ul, rng.uniform2());
    *w = s.wi;
    return s.pdf > 0.f;
  };
  // (A lobe far narrower than the cells, alpha < 0.005, is left to the
  // half-vector grid below: the cubature cannot find it in this one.)
  test::ParamGrid hemi = test::hemisphere_grid(frame, 16, 32);
  if (b.alpha >= 0.005f) {
    std::vector<double> e_hemi = integrate_grid(hemi, pdf);
    EXPECT_NEAR(grid_total(e_hemi), 1.0 - lost, 2e-3) << name << ": lost below the horizon " << lost;
    EXPECT_LE(grid_total(e_hemi), 1.0 + 1e-3) << name;
    auto r = chi2_on_grid(hemi, e_hemi, n, sample_wi, 21, pdf);
    EXPECT_GT(r.p_value, kMinP) << name << ", directions: " << r.message;
  }

  // The same samples as half-vectors h = normalize(wo + wi), in GGX slope space,
  // which resolves the specular lobe however narrow: p_h = p_wi * 4 (wo . h).
  if (b.has_specular) {
    test::ParamGrid hg = test::slope_grid(frame, b.alpha, 16, 16);
    auto pdf_h = [&](Vec3 h) {
      float oh = dot(wo, h);
      if (!(oh > 0.f)) return 0.0;
      return double(bsdf_pdf(b, wo, reflect(wo, h))) * 4.0 * oh;
    };
    std::vector<double> e_h = integrate_grid(hg, pdf_h);
    EXPECT_NEAR(grid_total(e_h), 1.0 - lost, 2e-3) << name << " (half-vector space)";
    auto sample_h = [&](Rng& rng, Vec3* h) {
      Vec3 w;
      if (!sample_wi(rng, &w)) return false;
      *h = normalize(wo + w);
      return true;
    };
    auto rh = chi2_on_grid(hg, e_h, n, sample_h, 22, pdf_h, /*strict_support=*/false);
    EXPECT_GT(rh.p_value, kMinP) << name << ", half-vectors: " << rh.message;
  }
}

std::vector<BsdfCase> sampling_cases() {
  std::vector<BsdfCase> v;
  for (float m : {0.f, 0.5f, 1.f})
    for (float r : {0.1f, 0.35f, 0.8f})
      for (auto [s, t] : {std::pair<float, float>{0.5f, 10.f}, {0.5f, 85.f}, {1.f, 60.f}}) {
        if (m == 1.f && s == 1.f) continue;  // the coat does not exist on a full metal
        v.push_back({m, r, s, t});
      }
  v.push_back({0.f, 1.f, 0.f, 40.f});  // Lambert
  v.push_back({0.5f, 0.5f, 0.f, 89.f});  // no coat, grazing
  return v;
}

INSTANTIATE_TEST_SUITE_P(Grid, BsdfSampling, ::testing::ValuesIn(sampling_cases()),
                         [](const ::testing::TestParamInfo<BsdfCase>& i) {
                           const BsdfCase& c = i.param;
                           return "m" + std::to_string(int(c.metallic * 100)) + "_r" +
                                  std::to_string(int(c.roughness * 100 + 0.5f)) + "_s" +
                                  std::to_string(int(c.specular * 100)) + "_v" + std::to_string(int(c.theta_deg));
                         });

// --- White furnace -----------------------------------------------------------------

// Directional albedo of base colour 1, two ways: the mean of bsdf_sample's
// weights, and f cos / p over uniform hemisphere samples.
struct Albedo {
  MeanEstimator sampled, uniform;
};

Albedo directional_albedo(const Bsdf& b, Vec3 wo, int n, uint32_t seed) {
  Albedo a;
  Rng rng(7, 7, seed);
  const Frame frame = Frame::from_z(b.ng);
  for (int i = 0; i < n; ++i) {
    float ul = rng.uniform();
    BsdfSample s = bsdf_sample(b, wo, ul, rng.uniform2());
    a.sampled.add(s.pdf > 0.f ? double(s.weight.x) : 0.0);
    Vec2 u = rng.uniform2();
    float z = u.x, r = safe_sqrt(1.f - z * z), phi = kTwoPi * u.y;
    Vec3 wi = frame.to_world(Vec3(r * std::cos(phi), r * std::sin(phi), z));
    a.uniform.add(double(bsdf_eval(b, wo, wi).x) * z * 2 * M_PI);
  }
  return a;
}

TEST(BsdfFurnace, AlbedoNeverAboveOne) {
  const int n = 50000;
  int cases = 0;
  double worst = 0;
  std::string worst_case;
  for (float m : {0.f, 0.5f, 1.f})
    for (float rough : {0.05f, 0.2f, 0.5f, 1.f})
      for (float spec : {0.f, 0.5f, 1.f})
        for (float view : {0.f, 30.f, 60.f, 75.f, 85.f, 89.f}) {
          const BsdfCase c{m, rough, spec, view};
          const Bsdf b = case_bsdf(c);
          const Albedo a = directional_albedo(b, case_wo(c), n, uint32_t(++cases));
          const double ms = a.sampled.mean(), se = a.sampled.std_error();
          const double mu = a.uniform.mean(), seu = a.uniform.std_error();
          EXPECT_LE(ms, 1.0 + 4 * se + 1e-5) << case_name(c) << ": albedo (bsdf_sample) " << ms << " +- " << se;
          EXPECT_LE(mu, 1.0 + 4 * seu + 1e-5) << case_name(c) << ": albedo (uniform) " << mu << " +- " << seu;
          // Both are unbiased estimators of the same integral (uniform sampling
          // of a near-delta lobe has a heavy tail, its standard error means nothing).
          if (rough >= 0.2f) {
            EXPECT_NEAR(ms, mu, 4.5 * std::sqrt(se * se + seu * seu) + 1e-5)
                << case_name(c) << ": bsdf_sample " << ms << " +- " << se << ", uniform " << mu << " +- " << seu;
          }
          if (ms > worst) {
            worst = ms;
            worst_case = case_name(c);
          }
        }
  std::printf("[ furnace ] largest albedo %.5f (%s)\n", worst, worst_case.c_str());
  // A sanity floor: a full white metal keeps most of the light at normal view.
  const Albedo metal = directional_albedo(case_bsdf({1.f, 0.2f, 0.5f, 0.f}), case_wo({1.f, 0.2f, 0.5f, 0.f}), n, 99);
  EXPECT_GT(metal.sampled.mean(), 0.95);
}

TEST(BsdfFurnace, LambertReflectsExactlyItsAlbedo) {
  for (float a : {0.f, 0.3f, 0.8f, 1.f}) {
    const Bsdf b = make_lambert(Vec3(a), kNormal);
    EXPECT_FALSE(b.has_specular);
    for (float view : {0.f, 45.f, 89.f}) {
      const Vec3 wo = Frame::from_z(kNormal).to_world(view_dir(view, 20.f));
      Rng rng(3, 3, 3);
      for (int i = 0; i < 1000; ++i) {
        float ul = rng.uniform();
        BsdfSample s = bsdf_sample(b, wo, ul, rng.uniform2());
        ASSERT_GT(s.pdf, 0.f);
        // Zero variance: cosine sampling cancels f cos / p to the albedo.
        EXPECT_NEAR(s.weight.x, a, 1e-6f);
        EXPECT_NEAR(bsdf_eval(b, wo, s.wi).x, a * kInvPi, 1e-6f);
        EXPECT_NEAR(s.pdf, dot(s.wi, kNormal) * kInvPi, 1e-5f);
      }
      const Albedo u = directional_albedo(b, wo, 40000, 5);
      EXPECT_NEAR(u.uniform.mean(), a, 4 * u.uniform.std_error() + 1e-6) << "albedo " << a << ", view " << view;
    }
  }
}

// --- Reciprocity and the geometric-normal rule -----------------------------------------

TEST(Bsdf, Reciprocity) {
  Rng rng(4, 5, 6);
  int tested = 0;
  for (int i = 0; i < 20000; ++i) {
    const float m = rng.uniform(), rough = 0.02f + rng.uniform(), spec = rng.uniform();
    const Bsdf b = make_bsdf(Vec3(0.9f, 0.5f, 0.2f), m, pn_min(rough, 1.f), spec, kNormal, kNormal);
    const Frame f = Frame::from_z(kNormal);
    Vec3 wo = f.to_world(sample_cosine_hemisphere(rng.uniform2()));
    Vec3 wi = f.to_world(sample_cosine_hemisphere(rng.uniform2()));
    if (dot(wo, kNormal) < 1e-3f || dot(wi, kNormal) < 1e-3f) continue;
    ++tested;
    // The whole BSDF, its diffuse term alone, its specular term alone.
    Bsdf diffuse_only = b, specular_only = b;
    diffuse_only.has_specular = false;
    specular_only.diffuse = Vec3(0.f);
    for (const Bsdf* x : std::initializer_list<const Bsdf*>{&b, &diffuse_only, &specular_only}) {
      Vec3 a = bsdf_eval(*x, wo, wi), c = bsdf_eval(*x, wi, wo);
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(a[k], c[k], 2e-5f * (a[k] + c[k]) + 1e-7f) << "m " << m << " r " << rough << " s " << spec;
    }
  }
  EXPECT_GT(tested, 19000);
}

TEST(Bsdf, NothingBelowTheGeometricSurface) {
  // A shading normal tilted away from the geometric one: directions above the
  // shading hemisphere but below the geometric surface get f = 0 and pdf = 0,
  // and samples never go there.
  const Vec3 ng(0.f, 0.f, 1.f), ns = normalize(Vec3(0.6f, 0.f, 0.8f));
  const Bsdf b = make_bsdf(Vec3(0.8f), 0.3f, 0.4f, 0.5f, ns, ng);
  const Vec3 wo = normalize(Vec3(0.2f, 0.3f, 0.9f));
  const Vec3 wi = normalize(Vec3(1.f, 0.f, -0.2f));  // above ns, below ng
  ASSERT_GT(dot(wi, ns), 0.f);
  EXPECT_TRUE(is_black(bsdf_eval(b, wo, wi)));
  EXPECT_EQ(bsdf_pdf(b, wo, wi), 0.f);
  Rng rng(1, 1, 1);
  for (int i = 0; i < 20000; ++i) {
    float ul = rng.uniform();
    BsdfSample s = bsdf_sample(b, wo, ul, rng.uniform2());
    if (s.pdf > 0.f) {
      ASSERT_GT(dot(s.wi, ng), 0.f);
    }
  }
}


// restir's records keep a PackedBsdf: unpacking must give back make_bsdf's BSDF bit for bit (frame rebuilt from the
// normal, has_specular from the weights), or the records would shade differently from the path that wrote them.
TEST(Bsdf, PackedRoundTripIsExact) {
  auto same = [](Vec3 a, Vec3 b) {
    return std::memcmp(&a, &b, sizeof(Vec3)) == 0;
  };
  Rng rng(7, 3, 11);
  int specular = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 ns = sample_uniform_sphere(rng.uniform2()), ng = sample_uniform_sphere(rng.uniform2());
    const Vec3 base(rng.uniform(), rng.uniform(), rng.uniform());
    const float metallic = i % 4 == 0 ? 0.f : rng.uniform(), specular_level = i % 3 == 0 ? 0.f : rng.uniform();
    const Bsdf b = make_bsdf(i % 7 == 0 ? Vec3(0.f) : base, metallic, rng.uniform(), specular_level, ns, ng);
    const Bsdf u = unpack_bsdf(pack_bsdf(b));
    ASSERT_TRUE(same(u.frame.s, b.frame.s) && same(u.frame.t, b.frame.t) && same(u.frame.n, b.frame.n)) << i;
    ASSERT_TRUE(same(u.ng, b.ng) && same(u.diffuse, b.diffuse) && same(u.metal, b.metal)) << i;
    ASSERT_EQ(u.metal_weight, b.metal_weight);
    ASSERT_EQ(u.coat_weight, b.coat_weight);
    ASSERT_EQ(u.f0_dielectric, b.f0_dielectric);
    ASSERT_EQ(u.alpha, b.alpha);
    ASSERT_EQ(u.has_specular, b.has_specular) << i;
    specular += b.has_specular;
  }
  EXPECT_GT(specular, 5000);    // both kinds were packed
  EXPECT_LT(specular, 19000);
  EXPECT_EQ(sizeof(PackedBsdf), 64u);
}

}  // namespace
}  // namespace pn
