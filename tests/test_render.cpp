// Whole renders through the CPU backend: strategies agree on every built-in
// scene, energy is conserved in closed forms, and images are deterministic.
#include <gtest/gtest.h>

#include "render/backend.h"
#include "render/compare.h"
#include "scene/scene.h"

namespace pn {
namespace {

using json = nlohmann::json;

Film render(const Scene& s, int threads = 0, uint32_t first = 0, uint32_t count = 0, Film* into = nullptr) {
  std::string note;
  auto backend = make_backend("cpu", s, BackendOptions{threads}, &note);
  Film local(s.render.width, s.render.height);
  Film& film = into ? *into : local;
  backend->render(frame_spec(s), film, first, count ? count : uint32_t(s.render.spp));
  return film;
}

// gtest names may not contain '-': "cornell-near" -> "cornell_near".
std::string param_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string n = info.param;
  for (char& c : n)
    if (c == '-') c = '_';
  return n;
}

Scene small(const std::string& name, const std::string& strategy, int spp, std::vector<std::string> extra = {}) {
  std::vector<std::string> o = {"render.width=64", "render.height=64", "render.spp=" + std::to_string(spp),
                                "render.strategy=" + strategy, "render.seed=" + std::to_string(strategy.size())};
  o.insert(o.end(), extra.begin(), extra.end());
  return load_scene(name, o);
}

// area and solid-angle are two unbiased estimators of the same image.
class StrategiesAgree : public ::testing::TestWithParam<std::string> {};

TEST_P(StrategiesAgree, AreaAndSolidAngleConvergeToTheSameImage) {
  Film a = render(small(GetParam(), "area", 384));
  Film b = render(small(GetParam(), "solid-angle", 384));
  CompareResult r = compare_images(a.mean(), a.variance_of_mean(), b.mean(), b.variance_of_mean());
  EXPECT_TRUE(r.pass) << GetParam() << ": " << r.summary();
  EXPECT_LT(r.mean_rel_diff, 0.01) << r.summary();
  EXPECT_GT(r.mean_z2, 0.7) << "variance estimates look too large: " << r.summary();
  EXPECT_LT(r.mean_z2, 1.4) << "differences exceed their standard errors: " << r.summary();
  EXPECT_GT(r.mean_a, 0.01) << "the image is black";
}

TEST_P(StrategiesAgree, BsdfStrategyAgreesAtImageLevel) {
  // Without NEE, emission is counted on every hit: tests the no-double-counting rule.
  Film a = render(small(GetParam(), "solid-angle", 64, {"render.width=24", "render.height=24"}));
  Film b = render(small(GetParam(), "bsdf", 1024, {"render.width=24", "render.height=24"}));
  CompareOptions loose;
  loose.max_mean_rel_diff = 0.05;  // bsdf sampling is far noisier: the z-test is what matters
  loose.max_outlier_fraction = 0.01;
  CompareResult r = compare_images(a.mean(), a.variance_of_mean(), b.mean(), b.variance_of_mean(), loose);
  EXPECT_LT(std::fabs(r.image_z), 4.0) << GetParam() << ": " << r.summary();
}

INSTANTIATE_TEST_SUITE_P(Builtins, StrategiesAgree, ::testing::Values("cornell-sphere", "cornell-near", "occlusion"),
                         param_name);

TEST(Render, SameImageForAnyThreadCount) {
  Scene s = small("cornell-near", "solid-angle", 4);
  Film one = render(s, 1), many = render(s, 3);
  EXPECT_EQ(std::vector<double>(one.sum(), one.sum() + one.pixel_count() * 3),
            std::vector<double>(many.sum(), many.sum() + many.pixel_count() * 3));
}

TEST(Render, ProgressiveEqualsOneShot) {
  Scene s = small("cornell-sphere", "area", 8, {"render.width=16", "render.height=16"});
  Film once = render(s);
  Film prog(16, 16);
  render(s, 0, 0, 3, &prog);
  render(s, 0, 3, 5, &prog);
  ASSERT_EQ(prog.samples(), 8u);
  auto a = once.mean(), b = prog.mean();
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-5f * (1 + std::fabs(a[i])));
}

TEST(Render, SeedsGiveIndependentImages) {
  Scene s1 = small("cornell-sphere", "area", 4), s2 = small("cornell-sphere", "area", 4, {"render.seed=99"});
  auto a = render(s1).mean(), b = render(s2).mean();
  EXPECT_NE(a, b);
}

// A closed box whose six walls are quad lights of radiance Le and albedo a:
// radiance is the same everywhere, L = Le * sum_{k=0..D} a^k for paths of at most
// D bounces, -> Le / (1 - a) as D grows (the integral equation's Neumann series).
json enclosure(float albedo, int max_depth, const std::string& strategy) {
  json lights = json::array();
  const float s = 2.f;
  auto q = [&](json c, json e1, json e2) {
    lights.push_back({{"type", "quad"}, {"corner", c}, {"edge1", e1}, {"edge2", e2}, {"radiance", 1.0},
                      {"material", "wall"}});
  };
  // Edges ordered so that every normal e1 x e2 points into the box.
  q({-1, -1, -1}, {0, 0, s}, {s, 0, 0});   // floor, normal +y
  q({-1, 1, -1}, {s, 0, 0}, {0, 0, s});    // ceiling, -y
  q({-1, -1, -1}, {s, 0, 0}, {0, s, 0});   // back z=-1, +z
  q({-1, -1, 1}, {0, s, 0}, {s, 0, 0});    // front z=1, -z
  q({-1, -1, -1}, {0, s, 0}, {0, 0, s});   // x=-1, +x
  q({1, -1, -1}, {0, 0, s}, {0, s, 0});    // x=1, -x
  return {{"camera", {{"eye", {0, 0, 0}}, {"target", {0.3, 0.2, -1}}, {"fov", 90}}},
          {"render", {{"width", 16}, {"height", 16}, {"spp", 512}, {"max_depth", max_depth}, {"rr_depth", 3},
                      {"strategy", strategy}}},
          {"materials", {{"wall", {{"albedo", albedo}}}}},
          {"lights", lights}};
}

class Enclosure : public ::testing::TestWithParam<std::string> {};

TEST_P(Enclosure, RadianceMatchesNeumannSeries) {
  const float a = 0.6f;
  for (int depth : {0, 1, 3, 40}) {
    Scene s = parse_scene(enclosure(a, depth, GetParam()), "enclosure", ".");
    Film f = render(s);
    auto m = f.mean();
    auto v = f.variance_of_mean();
    double sum = 0, var = 0;
    for (size_t i = 0; i < m.size(); ++i) {
      sum += m[i];
      var += v[i];
    }
    double n = double(m.size());
    double mean = sum / n, se = std::sqrt(var) / n;
    double expected = (1 - std::pow(double(a), depth + 1)) / (1 - a);
    EXPECT_NEAR(mean, expected, 4 * se + 1e-6) << GetParam() << ", max depth " << depth << ", se " << se;
    EXPECT_NEAR(mean, expected, 0.01 * expected) << GetParam() << ", max depth " << depth;
  }
}

INSTANTIATE_TEST_SUITE_P(Strategies, Enclosure, ::testing::Values("area", "solid-angle", "bsdf"),
                         param_name);

// White furnace: a diffuse sphere of albedo a under a uniform sky of radiance 1
// reflects exactly a (a convex object never sees itself); the estimator has
// zero variance because cosine sampling cancels f cos / pdf to the albedo.
TEST(Render, WhiteFurnaceSphereReflectsItsAlbedo) {
  json doc = {{"camera", {{"eye", {0, 0, -3}}, {"target", {0, 0, 0}}, {"fov", 10}}},
              {"render", {{"width", 8}, {"height", 8}, {"spp", 16}, {"strategy", "solid-angle"}}},
              {"background", 1.0},
              {"materials", {{"grey", {{"albedo", 0.8}}}}},
              {"shapes", {{{"type", "sphere"}, {"center", {0, 0, 0}}, {"radius", 1}, {"material", "grey"}}}}};
  Scene s = parse_scene(doc, "furnace", ".");
  Film f = render(s);
  for (float v : f.mean()) EXPECT_NEAR(v, 0.8f, 1e-5f);
}

}  // namespace
}  // namespace pn
