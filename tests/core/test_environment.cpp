// Environment lights (core/environment.h, built by finalize_scene), texture
// lookups (core/texture.h), triangle lights (core/lights.h) and
// power-proportional light selection (core/scene_view.h), against their pdfs
// and closed forms. Fixed seeds: deterministic.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <memory>

#include "core/integrator.h"
#include "scene/scene.h"
#include "stat_util.h"

namespace pn {
namespace {

using json = nlohmann::json;
using test::chi2_test;
using test::MeanEstimator;

constexpr double kMinP = 1e-3;

struct NoOccluder {
  bool occluded(const Ray&, float) const { return false; }
};

// --- Environment ------------------------------------------------------------------

// A scene holding only an environment map (Rgba32f, nearest, as the loaders
// make them), finalised like any scene.
struct EnvScene {
  Scene scene;
  std::unique_ptr<HostSceneView> host;
  const EnvironmentView& env() const { return host->view.environment; }
};

std::unique_ptr<EnvScene> make_env_scene(int W, int H, const std::function<Vec3(int, int)>& texel, float rotation = 0.f,
                                         Vec3 scale = Vec3(1.f)) {
  auto e = std::make_unique<EnvScene>();
  Scene& s = e->scene;
  s.source = "test";
  Material black;
  black.base_color = Vec3(0.f);
  s.materials.push_back(black);
  TextureImage img;
  img.path = "synthetic";
  img.width = W;
  img.height = H;
  img.format = TexelFormat::Rgba32f;
  img.nearest = true;
  img.texels.resize(size_t(W) * H * 16);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      Vec3 c = texel(x, y);
      float px[4] = {c.x, c.y, c.z, 1.f};
      std::memcpy(&img.texels[(size_t(y) * W + x) * 16], px, 16);
    }
  s.textures.push_back(img);
  s.environment.texture = 0;
  s.environment.rotation = rotation;
  s.environment.scale = scale;
  finalize_scene(s);
  e->host = make_host_view(s);
  return e;
}

// A gradient with a bright spot, coloured.
Vec3 spotty(int x, int y) {
  Vec3 c(0.2f + 0.5f * x / 64.f, 0.1f + 0.8f * y / 32.f, 0.3f);
  if ((x - 40) * (x - 40) + (y - 10) * (y - 10) <= 4) c = c + Vec3(60.f, 40.f, 20.f);
  return c;
}

float lum(Vec3 c) { return luminance(c); }

TEST(Environment, MappingConvention) {
  auto near = [](Vec3 a, Vec3 b) { return length(a - b) < 1e-5f; };
  EXPECT_TRUE(near(equirect_direction(Vec2(0.5f, 0.f)), Vec3(0, 1, 0)));   // top row: up
  EXPECT_TRUE(near(equirect_direction(Vec2(0.5f, 0.5f)), Vec3(0, 0, -1)));  // centre column: -z
  Rng rng(1, 1, 1);
  for (int i = 0; i < 1000; ++i) {
    Vec3 d = sample_uniform_sphere(rng.uniform2());
    EXPECT_LT(length(equirect_direction(equirect_uv(d)) - d), 2e-5f);
  }
}

// The distribution is lum * sin(row centre), computed here independently, and
// environment_pdf is that density carried to solid angle.
TEST(Environment, PdfIsLuminanceTimesSine) {
  const int W = 64, H = 32;
  auto e = make_env_scene(W, H, spotty);
  double total = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) total += lum(spotty(x, y)) * std::sin(M_PI * (y + 0.5) / H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double pdf_uv = lum(spotty(x, y)) * std::sin(M_PI * (y + 0.5) / H) / (total / (W * H));
      Vec2 uv((x + 0.3f) / W, (y + 0.6f) / H);
      double t = M_PI * uv.y;
      double expect = pdf_uv / (2 * M_PI * M_PI * std::sin(t));
      Vec3 w = equirect_direction(uv);
      ASSERT_NEAR(environment_pdf(e->env(), w), expect, 1e-4 * expect) << x << " " << y;
      // Radiance: the texel, nearest.
      ASSERT_LT(length(environment_radiance(e->env(), w) - spotty(x, y)), 1e-5f * length(spotty(x, y)));
    }
}

// environment_sample against environment_pdf: the pdf each sample reports, and
// a chi-square over the image's cells (binned through the sampled world
// direction, so the direction mapping and the rotation are part of the test).
// The expectation of a cell is the integral of environment_pdf over it, which
// the midpoint rule gets exactly (pdf * Jacobian is constant on a cell).
void expect_env_samples_match_pdf(float rotation, uint32_t seed, bool compensated = false) {
  const int W = 64, H = 32, n = 400000;
  auto e = make_env_scene(W, H, spotty, rotation, Vec3(2.f, 1.f, 0.5f));
  const EnvironmentView& env = e->env();
  std::vector<double> expected(W * H + 1, 0.0), observed(W * H + 1, 0.0);
  double total = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double acc = 0;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          Vec2 uv((x + (a + 0.5f) / 3) / W, (y + (b + 0.5f) / 3) / H);
          Vec3 w = env_to_world(env, equirect_direction(uv));
          acc += environment_pdf(env, w, compensated) * 2 * M_PI * M_PI * std::sin(M_PI * uv.y) / 9;
        }
      expected[y * W + x] = acc / (W * H);
      total += acc / (W * H);
    }
  EXPECT_NEAR(total, 1.0, 1e-4);
  for (double& v : expected) v *= n;
  Rng rng(0, 0, seed);
  int mismatched = 0, edge_crossings = 0;
  for (int i = 0; i < n; ++i) {
    EnvironmentSample s = environment_sample(env, rng.uniform2(), compensated);
    if (!(s.pdf > 0.f)) {
      observed.back() += 1;
      continue;
    }
    if (i < 20000) {
      // Near the poles environment_pdf loses precision (see PdfPreciseNearThePoles).
      const float tol = std::fabs(s.wi.y) < 0.999f ? 2e-3f : 3e-2f;
      if (std::fabs(s.pdf - environment_pdf(env, s.wi, compensated)) > tol * s.pdf) {
        Vec2 uv = equirect_uv(env_from_world(env, s.wi));
        if (++mismatched < 5)
          ADD_FAILURE() << "sample pdf " << s.pdf << ", environment_pdf " << environment_pdf(env, s.wi, compensated)
                        << " at u*W "
                        << uv.x * W << ", v*H " << uv.y * H;
      }
      Vec3 L = environment_radiance(env, s.wi);
      ASSERT_LT(length(s.L - L), 1e-5f * length(L));
    }
    Vec2 uv = equirect_uv(env_from_world(env, s.wi));
    int x = std::min(W - 1, int(uv.x * W)), y = std::min(H - 1, int(uv.y * H));
    // A sample on a cell's edge can cross it through the rotation's rounding. Where the cell beyond has density 0
    // (the compensated distribution's dim cells) that is a bin of no expectation: counted apart, and rare.
    const float fx = uv.x * W - float(x), fy = uv.y * H - float(y);
    const bool on_edge = std::min(std::min(fx, 1.f - fx), std::min(fy, 1.f - fy)) < 1e-3f;
    if (expected[y * W + x] == 0.0 && on_edge) {
      ++edge_crossings;
      continue;
    }
    observed[y * W + x] += 1;
  }
  auto r = chi2_test(observed, expected);
  EXPECT_GT(r.p_value, kMinP) << "rotation " << rotation << ": " << r.message;
  EXPECT_EQ(mismatched, 0);
  EXPECT_LE(edge_crossings, n / 10000) << "samples across a cell edge into a cell of density 0";
}

TEST(Environment, SamplesMatchPdf) { expect_env_samples_match_pdf(0.f, 1); }
TEST(Environment, SamplesMatchPdfRotated) { expect_env_samples_match_pdf(70.f, 2); }
TEST(Environment, CompensatedSamplesMatchTheirPdf) { expect_env_samples_match_pdf(70.f, 3, true); }

// MIS compensation's distribution (Karlik et al. 2019): luminance less its mean over the sphere (texels weighted by
// sin t, their solid angle), clamped at 0, times sin t; 0 at the texels no brighter than the mean.
TEST(Environment, CompensatedPdfIsTheExcessOverTheMean) {
  const int W = 64, H = 32;
  auto e = make_env_scene(W, H, spotty);
  double weighted = 0, weights = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double st = std::sin(M_PI * (y + 0.5) / H);
      weighted += lum(spotty(x, y)) * st;
      weights += st;
    }
  const double mean = weighted / weights;
  auto excess = [&](int x, int y) { return std::max(0.0, lum(spotty(x, y)) - mean) * std::sin(M_PI * (y + 0.5) / H); };
  double total = 0;
  int zero = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) total += excess(x, y);
  ASSERT_GT(total, 0.0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const Vec2 uv((x + 0.3f) / W, (y + 0.6f) / H);
      const double expect = excess(x, y) / (total / (W * H)) / (2 * M_PI * M_PI * std::sin(M_PI * uv.y));
      const Vec3 w = equirect_direction(uv);
      ASSERT_NEAR(environment_pdf(e->env(), w, true), expect, 1e-3 * expect + 1e-7) << x << " " << y;
      zero += expect == 0.0;
    }
  EXPECT_GT(zero, W * H / 4);  // the gradient's dim half is left to BSDF samples
  EXPECT_GT(environment_pdf(e->env(), equirect_direction(Vec2(40.5f / W, 10.5f / H)), true),
            environment_pdf(e->env(), equirect_direction(Vec2(40.5f / W, 10.5f / H))));  // the spot gains
}

// A constant environment has nothing above its mean: no compensated distribution, the full one is used.
TEST(Environment, ConstantEnvironmentIsNotCompensated) {
  auto e = make_env_scene(16, 8, [](int, int) { return Vec3(0.7f); });
  EXPECT_EQ(e->scene.environment.compensated.integral, 0.f);
  Rng rng(9, 9, 9);
  for (int i = 0; i < 1000; ++i) {
    const Vec2 u = rng.uniform2();
    const EnvironmentSample a = environment_sample(e->env(), u), b = environment_sample(e->env(), u, true);
    ASSERT_GT(a.pdf, 0.f);
    EXPECT_EQ(a.pdf, b.pdf);
    EXPECT_EQ(a.wi.x, b.wi.x);
    EXPECT_EQ(environment_pdf(e->env(), a.wi), environment_pdf(e->env(), a.wi, true));
  }
}

// environment_pdf of a direction near a pole: sin(theta) from acos(d.y)
// cancels (d.y is -1 + sin^2/2 in float), while the sampler's own pdf uses the
// sampled v. Directions within a row's height of the pole carry the same pdf
// as the formula (pdf_uv / (2 pi^2 sin theta)) only if sin theta is computed
// from sqrt(x^2 + z^2).
TEST(Environment, PdfPreciseNearThePoles) {
  const int W = 64, H = 32;
  auto e = make_env_scene(W, H, spotty);
  double total = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) total += lum(spotty(x, y)) * std::sin(M_PI * (y + 0.5) / H);
  for (int y : {0, H - 1})
    for (float fy : {0.02f, 0.2f, 0.5f, 0.8f, 0.98f}) {
      const int x = 13;
      Vec2 uv((x + 0.5f) / W, (y + fy) / H);
      Vec3 w = equirect_direction(uv);
      double st = std::sqrt(double(w.x) * w.x + double(w.z) * w.z);
      double pdf_uv = lum(spotty(x, y)) * std::sin(M_PI * (y + 0.5) / H) / (total / (W * H));
      double expect = pdf_uv / (2 * M_PI * M_PI * st);
      EXPECT_NEAR(environment_pdf(e->env(), w), expect, 2e-3 * expect) << "row " << y << " + " << fy;
    }
}

TEST(Environment, PdfIntegratesToOneOverTheSphere) {
  auto e = make_env_scene(64, 32, spotty, 33.f);
  // Midpoint rule over (z, phi) cells that do not follow the image's: the
  // pdf's steps cost some accuracy, hence the tolerance.
  const int nz = 600, np = 1200;
  double sum = 0;
  for (int i = 0; i < nz; ++i)
    for (int j = 0; j < np; ++j) {
      double z = -1 + 2 * (i + 0.5) / nz, phi = 2 * M_PI * (j + 0.5) / np, r = std::sqrt(1 - z * z);
      sum += environment_pdf(e->env(), Vec3(float(r * std::cos(phi)), float(z), float(r * std::sin(phi))));
    }
  EXPECT_NEAR(sum * 4 * M_PI / (double(nz) * np), 1.0, 2e-3);
}

TEST(Environment, RotatedMapSamplesRotatedDirections) {
  const float deg = 70.f;
  auto a = make_env_scene(64, 32, spotty, 0.f), b = make_env_scene(64, 32, spotty, deg);
  const float c = std::cos(deg * kPi / 180.f), s = std::sin(deg * kPi / 180.f);
  auto rot = [&](Vec3 d) { return Vec3(c * d.x + s * d.z, d.y, -s * d.x + c * d.z); };  // about +y
  Rng rng(5, 5, 5);
  for (int i = 0; i < 5000; ++i) {
    Vec2 u = rng.uniform2();
    EnvironmentSample sa = environment_sample(a->env(), u), sb = environment_sample(b->env(), u);
    ASSERT_GT(sa.pdf, 0.f);
    EXPECT_LT(length(sb.wi - rot(sa.wi)), 1e-5f);
    EXPECT_NEAR(sb.pdf, sa.pdf, 1e-4f * sa.pdf);
    EXPECT_LT(length(sb.L - sa.L), 1e-5f * length(sa.L));
    Vec3 d = sample_uniform_sphere(rng.uniform2());
    EXPECT_LT(length(environment_radiance(b->env(), rot(d)) - environment_radiance(a->env(), d)), 1e-5f);
  }
  // The spot (texel 40, 10) of the unrotated map, rotated by 90 degrees about +y.
  auto q = make_env_scene(64, 32, spotty, 90.f);
  Vec3 spot = equirect_direction(Vec2(40.5f / 64, 10.5f / 32));
  Vec3 spot_world(spot.z, spot.y, -spot.x);  // R_y(90) (x, y, z) = (z, y, -x)
  EXPECT_GT(environment_radiance(q->env(), spot_world).x, 50.f);
}

// Irradiance through estimate_direct (NEE of the environment light).
MeanEstimator env_irradiance(const EnvScene& e, Vec3 n, int samples, uint32_t seed) {
  const SceneView& scene = e.host->view;
  const Bsdf white = make_lambert(Vec3(1.f), n);
  Rng rng(0, 0, seed);
  MeanEstimator est;
  for (int i = 0; i < samples; ++i) {
    float us = rng.uniform();
    Vec2 u = rng.uniform2();
    est.add(kPi * estimate_direct(NoOccluder{}, scene, Strategy::SolidAngle, white, Vec3(0.f), n, us, u).x);
  }
  return est;
}

TEST(Environment, ConstantEnvironmentIrradianceIsPi) {
  auto e = make_env_scene(16, 8, [](int, int) { return Vec3(1.f); });
  ASSERT_EQ(e->host->view.num_lights, 1u);
  ASSERT_EQ(e->host->view.environment_light, 0);
  for (Vec3 n : {Vec3(0, 1, 0), normalize(Vec3(0.3f, -0.2f, 0.9f)), Vec3(0, -1, 0)}) {
    auto est = env_irradiance(*e, n, 200000, 3);
    EXPECT_NEAR(est.mean(), M_PI, 4 * est.std_error() + 1e-5) << "se " << est.std_error();
  }
}

TEST(Environment, IrradianceMatchesQuadrature) {
  auto e = make_env_scene(64, 32, spotty, 25.f, Vec3(1.5f));
  for (Vec3 n : {Vec3(0, 1, 0), normalize(Vec3(0.7f, 0.4f, -0.5f))}) {
    // E = integral of L cos over the hemisphere, by the midpoint rule in (z, phi).
    const Frame f = Frame::from_z(n);
    const int nz = 800, np = 1600;
    double E = 0;
    for (int i = 0; i < nz; ++i)
      for (int j = 0; j < np; ++j) {
        double z = (i + 0.5) / nz, phi = 2 * M_PI * (j + 0.5) / np, r = std::sqrt(1 - z * z);
        Vec3 w = f.to_world(Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
        E += environment_radiance(e->env(), w).x * z;
      }
    E *= 2 * M_PI / (double(nz) * np);
    auto est = env_irradiance(*e, n, 200000, 4);
    EXPECT_NEAR(est.mean(), E, 4 * est.std_error() + 3e-3 * E) << "se " << est.std_error();
  }
}

// --- Textures ------------------------------------------------------------------------

struct Tex {
  std::vector<uint8_t> data;
  TextureView view;
};

Tex tex8(int w, int h, TexelFormat f, const std::vector<uint8_t>& rgba) {
  Tex t;
  t.data = rgba;
  t.view.texels = t.data.data();
  t.view.width = w;
  t.view.height = h;
  t.view.format = f;
  return t;
}

double srgb_decode(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

TEST(Texture, BilinearExactAtCentresLinearBetweenAndWraps) {
  // 4 x 2, red channel = 10 * index, green = 255 - that, alpha varies.
  std::vector<uint8_t> px;
  for (int i = 0; i < 8; ++i) px.insert(px.end(), {uint8_t(10 * i + 5), uint8_t(250 - 10 * i), 7, uint8_t(30 * i)});
  Tex t = tex8(4, 2, TexelFormat::Rgba8Linear, px);
  auto red = [&](int x, int y) { return px[4 * (((y % 2) + 2) % 2 * 4 + ((x % 4) + 4) % 4)] / 255.0; };
  auto alpha = [&](int x, int y) { return px[4 * (((y % 2) + 2) % 2 * 4 + ((x % 4) + 4) % 4) + 3] / 255.0; };
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) {
      Rgba r = texture_lookup(t.view, Vec2((x + 0.5f) / 4, (y + 0.5f) / 2));
      EXPECT_NEAR(r.rgb.x, red(x, y), 1e-6);
      EXPECT_NEAR(r.a, alpha(x, y), 1e-6);
    }
  // Linear in between (both directions), with wrapping across the edges.
  for (float fx : {0.f, 0.25f, 0.6f})
    for (float fy : {0.f, 0.3f, 0.8f})
      for (int x = -1; x < 4; ++x)
        for (int y = -1; y < 2; ++y) {
          Vec2 uv((x + 0.5f + fx) / 4, (y + 0.5f + fy) / 2);
          double expect = (red(x, y) * (1 - fx) + red(x + 1, y) * fx) * (1 - fy) +
                          (red(x, y + 1) * (1 - fx) + red(x + 1, y + 1) * fx) * fy;
          double ea = (alpha(x, y) * (1 - fx) + alpha(x + 1, y) * fx) * (1 - fy) +
                      (alpha(x, y + 1) * (1 - fx) + alpha(x + 1, y + 1) * fx) * fy;
          Rgba r = texture_lookup(t.view, uv);
          EXPECT_NEAR(r.rgb.x, expect, 2e-6) << uv.x << " " << uv.y;
          EXPECT_NEAR(r.a, ea, 2e-6) << uv.x << " " << uv.y;
        }
  // Repeat: whole periods do not matter, in either direction.
  for (Vec2 uv : {Vec2(0.25f, 0.3f), Vec2(0.f, 0.f), Vec2(0.9f, 0.95f)}) {
    Rgba a = texture_lookup(t.view, uv);
    for (Vec2 shift : {Vec2(1.f, 0.f), Vec2(-1.f, 0.f), Vec2(0.f, 2.f), Vec2(-3.f, -1.f)}) {
      Rgba b = texture_lookup(t.view, Vec2(uv.x + shift.x, uv.y + shift.y));
      EXPECT_NEAR(a.rgb.x, b.rgb.x, 1e-5f);
      EXPECT_NEAR(a.rgb.y, b.rgb.y, 1e-5f);
    }
  }
  EXPECT_NEAR(texture_lookup(t.view, Vec2(1.25f, 0.25f)).rgb.x, texture_lookup(t.view, Vec2(0.25f, 0.25f)).rgb.x, 1e-6f);
}

// The host's table of 8-bit sRGB values holds exactly what srgb_to_linear gives (the GPU's float texels are decoded
// by the same function), and the curve is the standard's: continuous at the knee, 1 at 255.
TEST(Texture, Srgb8TableIsTheDecodingCurveBitForBit) {
  for (int v = 0; v < 256; ++v) {
    const float expected = srgb_to_linear(float(v) * (1.f / 255.f));
    EXPECT_EQ(srgb8_to_linear(uint8_t(v)), expected) << v;
  }
  EXPECT_EQ(srgb8_to_linear(0), 0.f);
  EXPECT_NEAR(srgb8_to_linear(255), 1.f, 1e-6f);
  EXPECT_NEAR(srgb8_to_linear(128), 0.2158605f, 1e-6f);  // ((128/255 + 0.055) / 1.055)^2.4
  EXPECT_NEAR(srgb8_to_linear(10), 10.f / 255.f / 12.92f, 1e-9f);  // the linear segment below the knee
}

TEST(Texture, SrgbDecodedBeforeFiltering) {
  // Two texels, black and white, sRGB-encoded: halfway between them is linear
  // 0.5, not the decode of the encoded average (0.21).
  std::vector<uint8_t> px = {0, 64, 200, 0, 255, 128, 20, 255};
  Tex t = tex8(2, 1, TexelFormat::Rgba8Srgb, px);
  for (float f : {0.f, 0.3f, 0.5f, 0.9f}) {
    Rgba r = texture_lookup(t.view, Vec2((0.5f + f) / 2, 0.5f));
    for (int k = 0; k < 3; ++k) {
      double expect = srgb_decode(px[k] / 255.0) * (1 - f) + srgb_decode(px[4 + k] / 255.0) * f;
      EXPECT_NEAR(r.rgb[k], expect, 2e-6) << "f " << f << " channel " << k;
    }
    EXPECT_NEAR(r.a, (1 - f) * 0.0 + f * 1.0, 1e-6) << "alpha stays linear";
  }
  EXPECT_NEAR(texture_lookup(t.view, Vec2(0.5f, 0.5f)).rgb.x, 0.5f, 1e-6f);
  // Linear textures are not decoded.
  Tex l = tex8(2, 1, TexelFormat::Rgba8Linear, px);
  EXPECT_NEAR(texture_lookup(l.view, Vec2(0.25f, 0.5f)).rgb.y, 64 / 255.f, 1e-6f);
}

TEST(Texture, NearestPicksTheTexelContainingUv) {
  std::vector<uint8_t> px;
  for (int i = 0; i < 12; ++i) px.insert(px.end(), {uint8_t(20 * i), 0, 0, 255});
  Tex t = tex8(4, 3, TexelFormat::Rgba8Linear, px);
  t.view.nearest = true;
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x)
      for (float fx : {0.01f, 0.5f, 0.99f})
        for (float fy : {0.02f, 0.97f}) {
          float expect = 20 * (y * 4 + x) / 255.f;
          EXPECT_NEAR(texture_lookup(t.view, Vec2((x + fx) / 4, (y + fy) / 3)).rgb.x, expect, 1e-6f);
          EXPECT_NEAR(texture_lookup(t.view, Vec2((x + fx) / 4 - 2.f, (y + fy) / 3 + 1.f)).rgb.x, expect, 1e-6f);
        }
  EXPECT_NEAR(texture_lookup(t.view, Vec2(1.f, 0.f)).rgb.x, 0.f, 1e-6f);  // u = 1 wraps to column 0
}

// --- Triangle lights -----------------------------------------------------------------

double triangle_raycast_pdf(Vec3 x, const Light& l, Vec3 w) {
  float t;
  if (!intersect_triangle(Ray(x, w), l.p, l.p + l.e1, l.p + l.e2, 0.f, kInf, &t)) return 0.0;
  double cos_l = -dot(l.n, w);
  return cos_l > 0 ? double(t) * t / (l.area * cos_l) : 0.0;
}

// Lambert's formula: irradiance at x (normal n) from a polygon of radiance L,
// E = L / 2 * sum_i angle(v_i, v_i+1) * (n . unit(v_i x v_i+1)), v_i = p_i - x.
double polygon_irradiance(Vec3 x, Vec3 n, const std::vector<Vec3>& poly, double L) {
  double sum = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    Vec3 a = normalize(poly[i] - x), b = normalize(poly[(i + 1) % poly.size()] - x);
    double angle = std::acos(std::max(-1.0, std::min(1.0, double(dot(a, b)))));
    sum += angle * dot(n, normalize(cross(a, b)));
  }
  return std::fabs(0.5 * L * sum);
}

TEST(TriangleLight, AreaSamplingMatchesRaycastPdfAndIsUniform) {
  const Vec3 p0(-0.4f, 1.f, -0.2f), p1(0.8f, 1.2f, 0.1f), p2(0.1f, 0.9f, 0.9f);
  Light l = Light::triangle(p0, p1, p2, Vec3(2.f));
  EXPECT_NEAR(l.area, 0.5f * length(cross(p1 - p0, p2 - p0)), 1e-6f);
  Vec3 centre = (p0 + p1 + p2) * (1.f / 3);
  Vec3 x = centre + l.n * 0.6f + Vec3(0.3f, 0.f, -0.2f);
  ASSERT_GT(dot(x - centre, l.n), 0.f);
  Rng rng(2, 2, 2);
  const int n = 10, N = 300000;
  std::vector<double> obs(n * n, 0.0), exp(n * n, 0.0);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) exp[i * n + j] = (i + j < n - 1 ? 2.0 : i + j == n - 1 ? 1.0 : 0.0) / (n * n) * N;
  for (int i = 0; i < N; ++i) {
    LightSample s = AreaSampling::sample_triangle(l, LightSampleContext{x, Vec3(0, 1, 0)}, rng.uniform2());
    ASSERT_GT(s.pdf, 0.f);
    ASSERT_GE(s.b.x, 0.f);
    ASSERT_GE(s.b.y, 0.f);
    ASSERT_LE(s.b.x + s.b.y, 1.f + 1e-6f);
    if (i < 3000) {
      EXPECT_LT(length(s.y - (p0 + l.e1 * s.b.x + l.e2 * s.b.y)), 1e-5f);
      EXPECT_LT(length(s.wi - normalize(s.y - x)), 1e-5f);
      EXPECT_NEAR(s.pdf, triangle_raycast_pdf(x, l, s.wi), 2e-3 * s.pdf);
    }
    obs[std::min(n - 1, int(s.b.x * n)) * n + std::min(n - 1, int(s.b.y * n))] += 1;
  }
  auto r = chi2_test(obs, exp);
  EXPECT_GT(r.p_value, kMinP) << r.message;
  // Behind the emitting side: nothing.
  const LightSampleContext behind{centre - l.n * 0.5f, Vec3(0, 1, 0)};
  for (int i = 0; i < 100; ++i) EXPECT_EQ(AreaSampling::sample_triangle(l, behind, rng.uniform2()).pdf, 0.f);
}

TEST(TriangleLight, IrradianceMatchesLambertsFormula) {
  struct Case {
    Vec3 p0, p1, p2, x, n;
  };
  const Case cases[] = {
      {Vec3(-0.5f, 1, -0.5f), Vec3(0.5f, 1, -0.5f), Vec3(0, 1, 0.6f), Vec3(0, 0, 0), Vec3(0, 1, 0)},
      {Vec3(-0.5f, 1, -0.5f), Vec3(0, 1, 0.6f), Vec3(0.5f, 1, -0.5f), Vec3(0, 0, 0), Vec3(0, 1, 0)},  // other winding
      {Vec3(1, 0.3f, -1), Vec3(2, 0.2f, 1), Vec3(1.5f, 2, 0.3f), Vec3(0, 0, 0), normalize(Vec3(0.5f, 1, 0.2f))},
      {Vec3(-3, 0.5f, -3), Vec3(3, 0.5f, -3), Vec3(0, 0.5f, 4), Vec3(0.2f, 0, 0.1f), Vec3(0, 1, 0)},  // close and large
      {Vec3(10, 10, 10), Vec3(10.3f, 10, 10), Vec3(10, 10.2f, 10.1f), Vec3(0, 0, 0), normalize(Vec3(1, 1, 1))},  // far
  };
  for (const Case& c : cases) {
    const float L = 3.f;
    Light l = Light::triangle(c.p0, c.p1, c.p2, Vec3(L));
    // Light towards x: flip the winding where needed (lights are one-sided).
    if (dot(c.x - c.p0, l.n) < 0.f) l = Light::triangle(c.p0, c.p2, c.p1, Vec3(L));
    SceneView scene;
    scene.lights = &l;
    scene.num_lights = 1;
    const Bsdf white = make_lambert(Vec3(1.f), c.n);
    Rng rng(0, 0, 8);
    MeanEstimator est;
    for (int i = 0; i < 200000; ++i) {
      float us = rng.uniform();
      Vec2 u = rng.uniform2();
      est.add(kPi * estimate_direct(NoOccluder{}, scene, Strategy::Area, white, c.x, c.n, us, u).x);
    }
    double E = polygon_irradiance(c.x, c.n, {c.p0, c.p1, c.p2}, L);
    EXPECT_NEAR(est.mean(), E, 4 * est.std_error() + 1e-4 * E) << "E " << E << ", se " << est.std_error();
  }
}

// --- Light selection --------------------------------------------------------------------

json lights_scene() {
  return {{"camera", {{"eye", {0, 0, 5}}, {"target", {0, 0, 0}}}},
          {"materials",
           {{"glow", {{"albedo", 0.5}, {"emission", {4.0, 2.0, 1.0}}}},
            {"dim", {{"base_color", 0.5}, {"emission", 0.5}}},
            {"grey", {{"albedo", 0.5}}}}},
          {"shapes",
           {{{"type", "mesh"},
             {"positions", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {2, 3, 0}}},
             {"indices", {{0, 1, 2}, {1, 3, 4}, {0, 2, 1}}},
             {"material", "glow"},
             {"transform", {{"scale", 0.5}, {"rotate", {0, 1, 0, 30}}, {"translate", {1, 2, 3}}}}},
            {{"type", "quad"}, {"corner", {-1, -1, 0}}, {"edge1", {0.5, 0, 0}}, {"edge2", {0, 0.25, 0}}, {"material", "dim"}},
            {{"type", "sphere"}, {"center", {0, -3, 0}}, {"radius", 1}, {"material", "grey"}}}},
          {"lights",
           {{{"type", "sphere"}, {"center", {0, 3, 0}}, {"radius", 0.2}, {"radiance", 5}},
            {{"type", "quad"}, {"corner", {-1, 2, -1}}, {"edge1", {2, 0, 0}}, {"edge2", {0, 0, 1}}, {"radiance", {1, 2, 3}}}}}};
}

TEST(LightSelection, ProportionalToPowerWithTheReportedPmf) {
  Scene s = parse_scene(lights_scene(), "lights", ".");
  auto host = make_host_view(s);
  const SceneView& v = host->view;
  // 2 explicit lights, 3 emissive triangles, 2 of the emissive quad.
  ASSERT_EQ(v.num_lights, 7u);
  std::vector<double> power(v.num_lights);
  double total = 0;
  for (uint32_t i = 0; i < v.num_lights; ++i) {
    const Light& l = v.lights[i];
    double area = l.type == LightType::Sphere ? 4 * M_PI * l.radius * l.radius
                  : l.type == LightType::Quad ? double(length(cross(l.e1, l.e2)))
                                              : 0.5 * length(cross(l.e1, l.e2));
    power[i] = M_PI * area * luminance(l.radiance);
    total += power[i];
  }
  // Each emissive triangle is the world-space triangle of its mesh, with the
  // material's emission, and a hit on it resolves to that light.
  int triangles = 0;
  for (uint32_t k = 0; k < v.num_instances; ++k) {
    const InstanceView& inst = v.instances[k];
    for (uint32_t t = 0; t < inst.mesh.num_triangles; ++t) {
      SurfaceHit hit;
      resolve_triangle_hit(inst, t, 0.25f, 0.25f, &hit);
      const uint32_t* I = inst.mesh.indices + 3 * t;
      Vec3 w0 = inst.to_world.point(inst.mesh.positions[I[0]]), w1 = inst.to_world.point(inst.mesh.positions[I[1]]),
           w2 = inst.to_world.point(inst.mesh.positions[I[2]]);
      const Material& m = v.materials[hit.material];
      if (is_black(m.emission) || inst.light >= 0) continue;
      ++triangles;
      ASSERT_GE(hit.light, 0);
      const Light& l = v.lights[hit.light];
      EXPECT_EQ(int(l.type), int(LightType::Triangle));
      EXPECT_LT(length(l.p - w0) + length(l.p + l.e1 - w1) + length(l.p + l.e2 - w2), 1e-5f);
      EXPECT_LT(length(l.radiance - m.emission), 1e-6f);
      // One side emits, the side of the hit's geometric normal (the winding's).
      EXPECT_GT(dot(l.n, hit.n), 0.999f);
    }
  }
  EXPECT_EQ(triangles, 5);
  Rng rng(3, 1, 4);
  const int N = 400000;
  std::vector<double> obs(v.num_lights, 0.0), exp(v.num_lights, 0.0);
  for (uint32_t i = 0; i < v.num_lights; ++i) exp[i] = N * power[i] / total;
  for (int i = 0; i < N; ++i) {
    float pmf = 0;
    SelectedLight sel = select_light(v.selection, v.num_lights, LightSelection::Power, LightSampleContext(), rng.uniform());
    uint32_t k = sel.index;
    pmf = sel.pmf;
    ASSERT_LT(k, v.num_lights);
    ASSERT_EQ(pmf, selection_pmf(v.selection, v.num_lights, LightSelection::Power, LightSampleContext(), k));
    ASSERT_NEAR(pmf, power[k] / total, 1e-5 + 1e-4 * power[k] / total) << "light " << k;
    obs[k] += 1;
  }
  auto r = chi2_test(obs, exp);
  EXPECT_GT(r.p_value, kMinP) << r.message;
  // The edges of u: never out of range, never a zero-power light.
  for (float u : {0.f, 0.5f, kOneMinusEpsilon}) {
    SelectedLight sel = select_light(v.selection, v.num_lights, LightSelection::Power, LightSampleContext(), u);
    EXPECT_LT(sel.index, v.num_lights);
    EXPECT_GT(sel.pmf, 0.f);
  }
}

TEST(LightSelection, UniformGivesEveryLightTheSameChance) {
  Scene s = parse_scene(lights_scene(), "lights", ".");
  auto host = make_host_view(s);
  const SceneView& v = host->view;
  Rng rng(3, 1, 5);
  const int N = 200000;
  std::vector<double> obs(v.num_lights, 0.0), exp(v.num_lights, double(N) / v.num_lights);
  for (int i = 0; i < N; ++i) {
    SelectedLight sel = select_light(v.selection, v.num_lights, LightSelection::Uniform, LightSampleContext(), rng.uniform());
    ASSERT_EQ(sel.pmf, 1.f / v.num_lights);
    obs[sel.index] += 1;
  }
  auto r = chi2_test(obs, exp);
  EXPECT_GT(r.p_value, kMinP) << r.message;
  EXPECT_EQ(select_light(v.selection, 0, LightSelection::Power, LightSampleContext(), 0.5f).pmf, 0.f);  // no lights
}

}  // namespace
}  // namespace pn
