// Bad input that used to lose work or give a wrong image without a word (issue
// 12), each class on real files in tests/data (made by make_bad_inputs.py).
// The executable's side of it (outputs, exit statuses, memory, long jobs,
// Ctrl-C) is tested by cli_robustness.py.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <string>
#include <tuple>

#include "backends/make_backend.h"
#include "core/texture.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {
namespace {

const std::string kData = PENUMBRA_TEST_DATA;

std::string data(const std::string& name) { return kData + "/" + name; }

struct Rendered {
  Film film;
  RenderStats stats;
};

Rendered render(const Scene& s) {
  std::string note;
  auto backend = make_backend("cpu", s, BackendOptions{2}, &note);
  Rendered r{Film(s.render.width, s.render.height), {}};
  backend->render(frame_spec(s), r.film, 0, uint32_t(s.render.spp));
  r.stats = backend->last_render_stats();
  return r;
}

bool any_warning_has(const Scene& s, const std::string& a, const std::string& b) {
  for (const std::string& w : s.warnings)
    if (w.find(a) != std::string::npos && w.find(b) != std::string::npos) return true;
  return false;
}

// Loads a scene that must fail; returns the message.
std::string scene_error(const std::string& file, const std::vector<std::string>& overrides = {}) {
  try {
    load_scene(data(file), overrides);
  } catch (const SceneError& e) {
    return e.what();
  }
  ADD_FAILURE() << file << " loaded without an error";
  return "";
}

// --- 3. A finished render is never thrown away -------------------------------------

// An environment of 1e35 at intensity 1e6 overflows floats: every camera ray
// that sees it is infinite. The render still completes; the samples are counted.
TEST(BadInput, NonFiniteSamplesAreCountedNotFatal) {
  Scene s = load_scene(data("overflow_env_scene.json"));
  Rendered r;
  ASSERT_NO_THROW(r = render(s));
  EXPECT_GT(r.stats.nonfinite, 0u);
  EXPECT_LE(r.stats.nonfinite, uint64_t(s.render.width) * s.render.height * s.render.spp);
  ASSERT_FALSE(r.stats.nonfinite_pixels.empty());
  // The first pixels in row order: the top row sees the sky.
  EXPECT_EQ(r.stats.nonfinite_pixels[0], (std::array<int, 2>{0, 0}));
  for (size_t i = 1; i < r.stats.nonfinite_pixels.size(); ++i) {
    const auto& a = r.stats.nonfinite_pixels[i - 1];
    const auto& b = r.stats.nonfinite_pixels[i];
    EXPECT_LT(a[1] * s.render.width + a[0], b[1] * s.render.width + b[0]);
  }
  // The film holds only finite values: the dropped samples count as black.
  for (float v : r.film.mean()) EXPECT_TRUE(std::isfinite(v));
  const std::string line = describe_nonfinite(r.stats);
  EXPECT_NE(line.find(std::to_string(r.stats.nonfinite) + " samples"), std::string::npos) << line;
  EXPECT_NE(line.find("(0, 0)"), std::string::npos) << line;
}

// --- 4. Non-finite or negative texels ---------------------------------------------------

// nan_env.exr: 16x8 texels of radiance 1, but for a NaN, an infinite and a
// negative one. They become 0 in the texels (lookups) and so in the
// environment's sampling distribution, with one warning naming the file.
TEST(BadInput, NonFiniteTexelsAreRepairedWithAWarning) {
  Scene s = load_scene(data("nan_env_scene.json"));
  EXPECT_TRUE(any_warning_has(s, "nan_env.exr", "3 of 128 texels")) << (s.warnings.empty() ? "" : s.warnings[0]);
  ASSERT_GE(s.environment.texture, 0);
  const TextureImage& t = s.textures[size_t(s.environment.texture)];
  auto texel = [&](int x, int y) {
    float c[4];
    std::memcpy(c, &t.texels[(size_t(y) * t.width + x) * 16], sizeof c);
    return Vec3(c[0], c[1], c[2]);
  };
  EXPECT_EQ(texel(3, 2).x, 0.f);   // was NaN
  EXPECT_EQ(texel(9, 5).y, 0.f);   // was +Inf
  EXPECT_EQ(texel(12, 6).z, 0.f);  // was -5
  EXPECT_EQ(texel(3, 2).y, 1.f);   // the texel's finite channels are kept
  EXPECT_EQ(texel(0, 0).x, 1.f);
  // The distribution: the integral of luminance x sin(theta) over the texels,
  // as finalize_scene defines it, of the repaired image.
  double sum = 0;
  for (int y = 0; y < t.height; ++y) {
    double row = 0;
    for (int x = 0; x < t.width; ++x) row += luminance(texel(x, y));
    sum += row / t.width * std::sin(kPi * (y + 0.5) / t.height);
  }
  const double expected = sum / t.height;
  EXPECT_NEAR(s.environment.distribution.integral, expected, 1e-5 * expected);
  for (float c : s.environment.distribution.marginal_cdf) EXPECT_TRUE(std::isfinite(c));
  // Rendered: no sample is lost to the bad texels, and the sky is bright.
  Rendered r = render(s);
  EXPECT_EQ(r.stats.nonfinite, 0u);
  double mean = 0;
  for (float v : r.film.mean()) mean += v;
  EXPECT_GT(mean / double(r.film.pixel_count() * 3), 0.3);
}

// --- 5. Graphs that explode -------------------------------------------------------------

TEST(BadInput, GltfNodeWithTwoParentsIsRejected) {
  const std::string e = scene_error("gltf_two_parents_scene.json");
  EXPECT_NE(e.find("gltf_two_parents.gltf"), std::string::npos) << e;
  EXPECT_NE(e.find("node 2 has two parents"), std::string::npos) << e;
}

// 2.5 KB that a walk of every path would turn into 2^32 placements: rejected at
// once, naming the file and the node.
TEST(BadInput, ExplodingGltfIsRejectedQuickly) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string e = scene_error("gltf_explode_scene.json");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_NE(e.find("gltf_explode.gltf"), std::string::npos) << e;
  EXPECT_NE(e.find("two parents"), std::string::npos) << e;
  EXPECT_LT(seconds, 5.0);
}

// 1024 placements of a model with 1025 mesh nodes: past kMaxInstances.
TEST(BadInput, InstanceLimit) {
  const std::string e = scene_error("many_instances.json");
  EXPECT_NE(e.find("many_instances.json: models[0]"), std::string::npos) << e;
  EXPECT_NE(e.find(std::to_string(kMaxInstances)), std::string::npos) << e;
  // Fewer placements are fine.
  Scene s = load_scene(data("many_instances.json"), {"models.0.transforms=[{}, {}]"});
  EXPECT_EQ(s.instances.size(), 2u * 1025u);
}

// render.mis_compensation (--mis-compensation): true or false, anything else one line naming the field.
TEST(BadInput, MisCompensationIsABoolean) {
  EXPECT_TRUE(load_scene("cornell-sphere", {"render.mis_compensation=true"}).render.integrator.mis_compensation);
  EXPECT_FALSE(load_scene("cornell-sphere").render.integrator.mis_compensation);
  for (const char* bad : {"render.mis_compensation=1", "render.mis_compensation=\"yes\""}) {
    try {
      load_scene("cornell-sphere", {bad});
      ADD_FAILURE() << bad << " was accepted";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("mis_compensation"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("expected true or false"), std::string::npos) << e.what();
    }
  }
}

// --- 7. Options that don't apply -----------------------------------------------------

// Render settings are overrides of the "render" block; a scene file without
// one takes them (the CLI's --spp, --width, ... are these overrides).
TEST(BadInput, RenderOptionsWorkWithoutARenderBlock) {
  Scene s = load_scene(data("no_render_block.json"), {"render.spp=3", "render.width=20", "render.strategy=\"area\""});
  EXPECT_EQ(s.render.spp, 3);
  EXPECT_EQ(s.render.width, 20);
  EXPECT_EQ(s.render.integrator.strategy, Strategy::Area);
  // Other missing blocks are still errors, naming the --set.
  try {
    load_scene(data("no_render_block.json"), {"nosuch.x=1"});
    ADD_FAILURE() << "an override into a missing block was accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("--set nosuch.x=1"), std::string::npos) << e.what();
  }
}

TEST(BadInput, SceneWithoutLightWarns) {
  Scene s = load_scene(data("no_light.json"));
  EXPECT_TRUE(any_warning_has(s, "no_light.json", "no light")) << (s.warnings.empty() ? "" : s.warnings[0]);
  Scene lit = load_scene(data("no_render_block.json"));
  EXPECT_FALSE(any_warning_has(lit, "no_render_block.json", "no light"));
  // A bright background is a light.
  Scene sky = load_scene(data("no_light.json"), {"background=[1,1,1]"});
  EXPECT_FALSE(any_warning_has(sky, "no_light.json", "no light"));
}

// --- 9. Geometry robustness -----------------------------------------------------------

// The camera inside a closed box (one mesh, turned so that its seams are not
// axis-aligned; closed_box_instanced.json places it as an instance turned about
// a tilted axis); a sphere light and a white sky outside. Every path stays in
// the box, so every pixel is exactly 0: no ray slips through a seam, and no
// bounce or shadow ray starts behind a neighbouring wall.
class ClosedBox : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {};

TEST_P(ClosedBox, SeesExactlyNothing) {
  const auto& [file, strategy] = GetParam();
  Scene s = load_scene(data(file), {"render.strategy=\"" + strategy + "\""});
  Rendered r = render(s);
  const std::vector<float> img = r.film.mean();
  size_t lit = 0;
  float brightest = 0;
  for (float v : img) {
    lit += v != 0.f;
    brightest = std::max(brightest, v);
  }
  EXPECT_EQ(lit, 0u) << file << " " << strategy << ": brightest " << brightest;
  EXPECT_EQ(r.stats.nonfinite, 0u);
}

INSTANTIATE_TEST_SUITE_P(Strategies, ClosedBox,
                         ::testing::Combine(::testing::Values("closed_box.json", "closed_box_instanced.json"),
                                            ::testing::Values("area", "solid-angle", "projected-solid-angle", "bsdf")),
                         [](const ::testing::TestParamInfo<std::tuple<std::string, std::string>>& i) {
                           std::string n = std::get<0>(i.param) + "_" + std::get<1>(i.param);
                           for (char& c : n)
                             if (c == '-' || c == '.') c = '_';
                           return n;
                         });

}  // namespace
}  // namespace pn
