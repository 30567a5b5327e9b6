// The denoiser's guides (core/aov.h) through the CPU backend, against closed
// forms: a diffuse wall seen directly, the same wall seen in a mirror, a rough
// metal that is not followed; and the guides' ranges on every built-in scene.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "core/aov.h"
#include "render/backend.h"
#include "backends/denoise.h"
#include "backends/make_backend.h"
#include "render/oidn.h"
#include "render/film.h"
#include "scene/scene.h"

namespace pn {
namespace {

using json = nlohmann::json;

constexpr float kWall[3] = {0.3f, 0.5f, 0.7f};

// A camera at z = 5 looking down -z at `front` (a large quad at z = 0), with a
// diffuse wall of albedo kWall at z = 10 behind the camera, facing it, and a
// light far above both.
json mirror_scene(const json& front) {
  return {{"camera", {{"eye", {0, 0, 5}}, {"target", {0, 0, 0}}, {"fov", 40}}},
          {"render", {{"width", 24}, {"height", 16}}},
          {"materials", {{"wall", {{"albedo", {kWall[0], kWall[1], kWall[2]}}}}, {"front", front}}},
          {"shapes",
           {{{"type", "quad"}, {"corner", {-50, -50, 0}}, {"edge1", {100, 0, 0}}, {"edge2", {0, 100, 0}},
             {"material", "front"}},
            {{"type", "quad"}, {"corner", {-200, -200, 10}}, {"edge1", {0, 400, 0}}, {"edge2", {400, 0, 0}},
             {"material", "wall"}}}},
          {"lights", {{{"type", "sphere"}, {"center", {0, 400, 5}}, {"radius", 1}, {"radiance", 5}}}}};
}

GuideImages guides_of(const Scene& s, uint32_t samples = 4) {
  std::string note;
  auto backend = make_backend("cpu", s, BackendOptions{2}, &note);
  GuideImages g = backend->render_guides(frame_spec(s), samples);
  EXPECT_EQ(g.width, s.render.width);
  EXPECT_EQ(g.height, s.render.height);
  EXPECT_EQ(g.albedo.size(), size_t(g.width) * g.height * 3);
  EXPECT_EQ(g.normal.size(), g.albedo.size());
  return g;
}

TEST(Guides, DiffuseWallSeenDirectlyHasItsAlbedoAndFacesTheCamera) {
  const json wall = {{"albedo", {kWall[0], kWall[1], kWall[2]}}};
  const Scene s = parse_scene(mirror_scene(wall), "wall", ".");
  const GuideImages g = guides_of(s);
  for (size_t p = 0; p < g.albedo.size() / 3; ++p) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_NEAR(g.albedo[3 * p + c], kWall[c], 1e-6f) << "pixel " << p;
      ASSERT_NEAR(g.normal[3 * p + c], c == 2 ? 1.f : 0.f, 1e-6f) << "pixel " << p;  // +z: towards the camera
    }
  }
}

TEST(Guides, MirrorShowsTheAlbedoAndNormalOfWhatItReflects) {
  const json mirror = {{"base_color", 1.0}, {"metallic", 1}, {"roughness", 0}};
  const Scene s = parse_scene(mirror_scene(mirror), "mirror", ".");
  const GuideImages g = guides_of(s);
  for (size_t p = 0; p < g.albedo.size() / 3; ++p) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_NEAR(g.albedo[3 * p + c], kWall[c], 1e-6f) << "pixel " << p;  // F = 1 for a white metal
      ASSERT_NEAR(g.normal[3 * p + c], c == 2 ? -1.f : 0.f, 1e-6f) << "pixel " << p;  // the wall, facing -z
    }
  }
}

TEST(Guides, TintedMirrorMultipliesByItsFresnelReflectance) {
  const json mirror = {{"base_color", {0.9, 0.6, 0.3}}, {"metallic", 1}, {"roughness", 0.05}};
  const Scene s = parse_scene(mirror_scene(mirror), "tinted", ".");
  const GuideImages g = guides_of(s, 1);
  // The centre pixel's ray meets the mirror almost head on: F ~ F0 = base colour.
  const size_t p = size_t(s.render.height / 2) * s.render.width + s.render.width / 2;
  const float f0[3] = {0.9f, 0.6f, 0.3f};
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(g.albedo[3 * p + c], kWall[c] * f0[c], 2e-3f) << c;
}

TEST(Guides, RoughMetalIsNotFollowed) {
  // roughness 0.5 (alpha 0.25) is far above the mirror threshold: the metal's own reflectance.
  const json metal = {{"base_color", {0.9, 0.6, 0.3}}, {"metallic", 1}, {"roughness", 0.5}};
  const Scene s = parse_scene(mirror_scene(metal), "metal", ".");
  const GuideImages g = guides_of(s, 1);
  const size_t p = size_t(s.render.height / 2) * s.render.width + s.render.width / 2;
  const float f0[3] = {0.9f, 0.6f, 0.3f};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(g.albedo[3 * p + c], f0[c], 2e-3f) << c;
    EXPECT_NEAR(g.normal[3 * p + c], c == 2 ? 1.f : 0.f, 1e-5f) << c;
  }
}

TEST(Guides, RaysThatEscapeWriteTheClampedSkyAndNoNormal) {
  json doc = mirror_scene({{"albedo", 0.5}});
  doc["shapes"] = json::array();
  doc["background"] = {0.25, 2.0, 0.5};
  const Scene s = parse_scene(doc, "sky", ".");
  const GuideImages g = guides_of(s, 2);
  for (size_t p = 0; p < g.albedo.size() / 3; ++p) {
    EXPECT_FLOAT_EQ(g.albedo[3 * p], 0.25f);
    EXPECT_FLOAT_EQ(g.albedo[3 * p + 1], 1.f);  // clamped
    EXPECT_FLOAT_EQ(g.albedo[3 * p + 2], 0.5f);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(g.normal[3 * p + c], 0.f);
  }
}

TEST(Guides, TheSameSamplesGiveTheSameGuidesWhateverTheThreads) {
  const Scene s = load_scene("cornell-sphere", {"render.width=40", "render.height=24"});
  std::string note;
  auto one = make_backend("cpu", s, BackendOptions{1}, &note);
  auto two = make_backend("cpu", s, BackendOptions{2}, &note);
  const GuideImages a = one->render_guides(frame_spec(s), 3), b = two->render_guides(frame_spec(s), 3);
  EXPECT_EQ(a.albedo, b.albedo);
  EXPECT_EQ(a.normal, b.normal);
}

// Albedo in [0, 1] and normals unit (or 0 where the rays escaped) on every
// built-in scene, its metals, coats, textures and emitters included.
class GuidesInRange : public ::testing::TestWithParam<std::string> {};

TEST_P(GuidesInRange, AlbedoInUnitRangeAndNormalsUnit) {
  Scene s;
  try {
    s = load_scene(GetParam(), {"render.width=48", "render.height=32"});
  } catch (const SceneError& e) {
    GTEST_SKIP() << GetParam() << " cannot be loaded here: " << e.what();
  }
  const GuideImages g = guides_of(s, 4);
  size_t surface = 0;
  for (size_t p = 0; p < g.albedo.size() / 3; ++p) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(std::isfinite(g.albedo[3 * p + c]) && std::isfinite(g.normal[3 * p + c])) << p;
      ASSERT_GE(g.albedo[3 * p + c], 0.f) << GetParam() << " pixel " << p;
      ASSERT_LE(g.albedo[3 * p + c], 1.f) << GetParam() << " pixel " << p;
    }
    const float len = std::sqrt(g.normal[3 * p] * g.normal[3 * p] + g.normal[3 * p + 1] * g.normal[3 * p + 1] +
                                g.normal[3 * p + 2] * g.normal[3 * p + 2]);
    if (len == 0.f) continue;
    ASSERT_NEAR(len, 1.f, 1e-4f) << GetParam() << " pixel " << p;
    ++surface;
  }
  EXPECT_GT(surface, g.albedo.size() / 6) << "most pixels of every built-in scene see a surface";
}

std::vector<std::string> builtin_names() {
  std::vector<std::string> v;
  for (const BuiltinScene& b : builtin_scenes()) v.push_back(b.name);
  return v;
}

std::string param_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string n = info.param;
  for (char& c : n)
    if (c == '-') c = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(Builtin, GuidesInRange, ::testing::ValuesIn(builtin_names()), param_name);

// The estimate of the directional albedo is the base colour for Lambert, and
// stays in [0, 1] for a coat over white (before the clamp).
TEST(Guides, AlbedoEstimateOfLambertIsItsBaseColour) {
  const Vec3 n(0, 0, 1);
  const Bsdf lambert = make_lambert(Vec3(0.2f, 0.4f, 0.6f), n);
  const Vec3 a = guide_albedo(lambert, normalize(Vec3(0.3f, 0.1f, 1.f)));
  EXPECT_FLOAT_EQ(a.x, 0.2f);
  EXPECT_FLOAT_EQ(a.y, 0.4f);
  EXPECT_FLOAT_EQ(a.z, 0.6f);
  for (float c : {1.f, 0.5f, 0.05f}) {
    const Bsdf coated = make_bsdf(Vec3(1.f), 0.f, 0.3f, 1.f, n, n);
    const Vec3 wo = normalize(Vec3(std::sqrt(1 - c * c), 0.f, c));
    const Vec3 b = guide_albedo(coated, wo);
    EXPECT_LE(max_component(b), 1.f + 1e-6f) << c;
    EXPECT_GT(b.x, 0.9f) << c;
  }
  EXPECT_FALSE(guide_follows_specular(make_bsdf(Vec3(1.f), 1.f, 0.2f, 0.f, n, n)));  // alpha 0.04
  EXPECT_TRUE(guide_follows_specular(make_bsdf(Vec3(1.f), 1.f, 0.09f, 0.f, n, n)));  // alpha 0.0081
  EXPECT_FALSE(guide_follows_specular(make_bsdf(Vec3(1.f), 0.5f, 0.f, 0.f, n, n)));  // half diffuse
}

// On the CPU, asking for the OptiX denoiser is one line that names the GPU backend and the way out.
TEST(Denoise, OptixNeedsTheGpuBackend) {
  DenoiseOptions optix;
  optix.denoiser = DenoiserKind::Optix;
  try {
    check_denoise_choice("--denoise", "cpu", optix);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("the OptiX AI denoiser needs the GPU backend"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("--denoiser oidn"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
  const Scene s = load_scene("cornell-sphere", {"render.width=8", "render.height=8"});
  std::string note;
  auto cpu = make_backend("cpu", s, BackendOptions{1}, &note);
  EXPECT_THROW(check_denoise_backend("denoise", *cpu, optix), std::runtime_error);
  EXPECT_THROW(denoise_render(*cpu, frame_spec(s), std::vector<float>(8 * 8 * 3, 0.5f), optix), std::runtime_error);
}

// Without Intel Open Image Denoise's library, one line names what was tried and how to get it.
TEST(Denoise, MissingOidnSaysHowToGetIt) {
  DenoiseOptions o;
  o.oidn_library = "/nonexistent/libOpenImageDenoise.so.2";
  try {
    check_denoise_choice("--denoise", "cpu", o);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("/nonexistent/libOpenImageDenoise.so.2"), std::string::npos) << m;
    EXPECT_NE(m.find("pip install pyoidn"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

DenoiseOptions oidn_or_skip() {
  DenoiseOptions o;
  o.oidn_library = PENUMBRA_TEST_OIDN_LIBRARY;
  return o;
}
#define SKIP_WITHOUT_OIDN(o)                                                                             \
  if ((o).oidn_library.empty())                                                                          \
  GTEST_SKIP() << "Intel Open Image Denoise not found at configure time (pip install pyoidn, then cmake again)"

// OIDN on the CPU backend: the denoised image of a noisy render is finite, of the image's size, and its guides
// are the backend's; bad input is a clear error, or a counted repair.
TEST(Denoise, OidnOnTheCpuBackend) {
  const DenoiseOptions o = oidn_or_skip();
  SKIP_WITHOUT_OIDN(o);
  const Scene s = load_scene("cornell-sphere", {"render.width=48", "render.height=32", "render.spp=4"});
  std::string note;
  auto cpu = make_backend("cpu", s, BackendOptions{1}, &note);
  Film film(48, 32);
  cpu->render(frame_spec(s), film, 0, 4);
  std::vector<float> mean = film.mean();
  const DenoisedImage d = denoise_render(*cpu, frame_spec(s), mean, o);
  ASSERT_EQ(d.rgb.size(), mean.size());
  for (float v : d.rgb) ASSERT_TRUE(std::isfinite(v));
  EXPECT_EQ(d.guides.albedo.size(), mean.size());
  EXPECT_NE(d.how.find("CPU device"), std::string::npos) << d.how;
  EXPECT_EQ(d.repaired, 0u);
  // A NaN and an infinity: set to 0 before denoising, counted, and the output stays finite.
  mean[5] = std::nanf("");
  mean[100] = INFINITY;
  size_t repaired = 0;
  const std::vector<float> r = denoise_image(*cpu, mean, d.guides, o, nullptr, nullptr, &repaired);
  EXPECT_EQ(repaired, 2u);
  for (float v : r) ASSERT_TRUE(std::isfinite(v));
  // Guides of another size: one line naming the guide.
  GuideImages wrong = d.guides;
  wrong.albedo.resize(10);
  try {
    denoise_image(*cpu, film.mean(), wrong, o);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("albedo guide"), std::string::npos) << e.what();
  }
}

// OIDN's filter is kept between calls (committing it loads the weights): a kept filter gives the image a new one
// gives, bit for bit, and another image or size in between leaves nothing behind.
TEST(Denoise, OidnKeptFilterDenoisesAsANewOne) {
  const DenoiseOptions o = oidn_or_skip();
  SKIP_WITHOUT_OIDN(o);
  auto render = [](int w, int h, uint32_t seed) {
    Scene s = load_scene("cornell-sphere", {"render.width=" + std::to_string(w), "render.height=" + std::to_string(h)});
    std::string note;
    auto cpu = make_backend("cpu", s, BackendOptions{1}, &note);
    FrameSpec f = frame_spec(s);
    f.seed = seed;
    Film film(w, h);
    cpu->render(f, film, 0, 2);
    return std::make_pair(film.mean(), cpu->render_guides(f, kGuideSamples));
  };
  std::string note;
  const Scene s = load_scene("cornell-sphere", {"render.width=40", "render.height=24"});
  auto cpu = make_backend("cpu", s, BackendOptions{1}, &note);
  const auto [a, guides] = render(40, 24, 1);
  const auto [b, unused] = render(40, 24, 2);
  const auto [small, small_guides] = render(24, 16, 3);
  release_oidn_filters();
  const std::vector<float> first = denoise_image(*cpu, a, guides, o);  // a new filter
  EXPECT_EQ(denoise_image(*cpu, a, guides, o), first);                  // the kept one
  const std::vector<float> other = denoise_image(*cpu, b, guides, o);
  EXPECT_NE(other, first);
  EXPECT_EQ(denoise_image(*cpu, small, small_guides, o).size(), small.size());  // another size: made again
  EXPECT_EQ(denoise_image(*cpu, a, guides, o), first);
  EXPECT_EQ(denoise_image(*cpu, b, guides, o), other);
}

}  // namespace
}  // namespace pn
