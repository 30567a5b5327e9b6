// Light selection: the light BVH's pmf against its traversal (exhaustively on
// small trees, by chi-square on large ones), its importance never zero where a
// light can contribute, the environment beside the tree, every method's pick
// reporting its own pmf, and resampled (restir) next-event estimation against
// closed-form irradiance. Whole renders of the many-light scenes are compared
// in test_render.cpp.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <functional>

#include "core/integrator.h"
#include "core/light_bvh.h"
#include "core/light_strategies.h"
#include "core/restir.h"
#include "io/image.h"
#include "scene/light_bvh_build.h"
#include "scene/scene.h"
#include "stat_util.h"

namespace pn {
namespace {

Vec3 random_unit(Rng& r) { return sample_uniform_sphere(r.uniform2()); }
Vec3 random_point(Rng& r, float extent) {
  return Vec3((2 * r.uniform() - 1) * extent, (2 * r.uniform() - 1) * extent, (2 * r.uniform() - 1) * extent);
}

// n lights of the three types in turn (or of one type), in a cube of half-size
// `extent`, of random size, radiance and orientation.
std::vector<Light> random_lights(int n, uint32_t seed, float extent = 5.f, int only_type = -1) {
  Rng r(0, 0, seed);
  std::vector<Light> lights;
  for (int i = 0; i < n; ++i) {
    const Vec3 c = random_point(r, extent);
    const Vec3 L(0.5f + 10 * r.uniform(), 0.5f + 10 * r.uniform(), 0.5f + 10 * r.uniform());
    const float size = 0.05f + 0.6f * r.uniform();
    switch (only_type >= 0 ? only_type : i % 3) {
      case 0:
        lights.push_back(Light::sphere(c, size, L));
        break;
      case 1: {
        const Frame f = Frame::from_z(random_unit(r));
        lights.push_back(Light::quad(c, f.s * size, f.t * (size * (0.3f + r.uniform())), L));
        break;
      }
      default:
        lights.push_back(Light::triangle(c, c + random_unit(r) * size, c + random_unit(r) * size, L));
        break;
    }
  }
  return lights;
}

std::vector<float> light_powers(const std::vector<Light>& lights) {
  std::vector<float> p;
  for (const Light& l : lights) p.push_back(kPi * l.area * luminance(l.radiance));
  return p;
}

// A shading point; with `lobes`, the BSDF's lobes sg-bvh weighs by: a view above the surface, a GGX alpha from
// mirror-like to rough, and lobe weights (a third of them without a diffuse lobe, a third without a specular one).
LightSampleContext random_context(Rng& r, float extent = 7.f, bool lobes = false) {
  LightSampleContext c{random_point(r, extent), random_unit(r)};
  if (lobes) {
    const Frame f = Frame::from_z(c.n);
    c.wo = f.to_world(sample_cosine_hemisphere(r.uniform2()));
    c.alpha = 0.01f + r.uniform() * r.uniform();
    const int kind = int(r.uniform() * 3.f);
    c.specular = kind == 1 ? 0.f : 0.04f + 0.96f * r.uniform();
    c.diffuse = kind == 2 ? 0.f : r.uniform();
  }
  return c;
}

// Every leaf's probability by walking the whole tree: the product of the
// child probabilities along each path, independent of any u.
template <bool kSg>
void exhaustive(const LightBvhView& v, uint32_t node, float pmf, const LightBvhQuery& q, std::vector<double>* out) {
  if (v.nodes[node].index & kLightBvhLeaf) {
    if (node == 0 && !light_bvh_root_leaf_visible(v, q)) return;
    (*out)[v.nodes[node].index & ~kLightBvhLeaf] += pmf;
    return;
  }
  const float p0 = light_bvh_first_child_probability<kSg>(v, node, q);
  if (p0 < 0.f) return;
  exhaustive<kSg>(v, node + 1, pmf * p0, q, out);
  exhaustive<kSg>(v, v.nodes[node].index, pmf * (1.f - p0), q, out);
}

// The traversal's functions with the method chosen at run time (the tests loop over both).
LightBvhPick bvh_select(const LightBvhView& v, const LightSampleContext& ctx, float u, bool sg) {
  return sg ? light_bvh_select<true>(v, ctx, u) : light_bvh_select<false>(v, ctx, u);
}
float bvh_pmf(const LightBvhView& v, const LightSampleContext& ctx, uint32_t light, bool sg) {
  return sg ? light_bvh_pmf<true>(v, ctx, light) : light_bvh_pmf<false>(v, ctx, light);
}
void bvh_exhaustive(const LightBvhView& v, const LightSampleContext& ctx, bool sg, std::vector<double>* out) {
  if (sg)
    exhaustive<true>(v, 0, 1.f, light_bvh_query<true>(ctx), out);
  else
    exhaustive<false>(v, 0, 1.f, light_bvh_query<false>(ctx), out);
}

LightBvhView view_of(const LightBvh& t) { return LightBvhView{t.nodes.data(), t.trails.data()}; }

TEST(LightBvh, EveryLightHasATrailToItsOwnLeaf) {
  for (int n : {1, 2, 3, 7, 64, 1000}) {
    const std::vector<Light> lights = random_lights(n, uint32_t(n));
    const LightBvh t = build_light_bvh(lights, light_powers(lights));
    ASSERT_EQ(t.nodes.size(), size_t(2 * n - 1));
    ASSERT_EQ(t.lights, uint32_t(n));
    for (int i = 0; i < n; ++i) {
      uint64_t trail = t.trails[size_t(i)];
      ASSERT_NE(trail, 0u) << "light " << i << " of " << n;
      uint32_t node = 0;
      for (; trail > 1; trail >>= 1) {
        ASSERT_FALSE(t.nodes[node].index & kLightBvhLeaf);
        node = (trail & 1) ? t.nodes[node].index : node + 1;
      }
      ASSERT_TRUE(t.nodes[node].index & kLightBvhLeaf);
      EXPECT_EQ(t.nodes[node].index & ~kLightBvhLeaf, uint32_t(i));
    }
    // Interior nodes bound their children: boxes, power, and cones.
    for (size_t k = 0; k < t.nodes.size(); ++k) {
      const LightBvhNode& a = t.nodes[k];
      if (a.index & kLightBvhLeaf) continue;
      for (uint32_t c : {uint32_t(k + 1), a.index}) {
        const LightBvhNode& b = t.nodes[c];
        for (int d = 0; d < 3; ++d) {
          EXPECT_LE(a.lo[d], b.lo[d]);
          EXPECT_GE(a.hi[d], b.hi[d]);
        }
        EXPECT_GE(a.phi, b.phi);
        if (a.cos_theta_o > -1.f) {  // the child's cone inside the parent's
          const double angle = std::atan2(double(length(cross(a.w, b.w))), double(dot(a.w, b.w)));
          EXPECT_LE(angle + std::acos(double(b.cos_theta_o)), std::acos(double(a.cos_theta_o)) + 1e-5);
        }
      }
    }
  }
}

// Lights of zero power and the environment stay out of the tree (trail 0, pmf 0).
TEST(LightBvh, LightsWithoutPowerStayOutside) {
  std::vector<Light> lights = random_lights(6, 3);
  Light env;
  env.type = LightType::Environment;
  lights.push_back(env);
  std::vector<float> power = light_powers(lights);
  power[2] = 0.f;
  power.back() = 5.f;
  const LightBvh t = build_light_bvh(lights, power);
  EXPECT_EQ(t.lights, 5u);
  EXPECT_EQ(t.trails[2], 0u);
  EXPECT_EQ(t.trails[6], 0u);
  Rng r(0, 0, 1);
  for (int k = 0; k < 50; ++k) {
    const LightSampleContext ctx = random_context(r);
    EXPECT_EQ(light_bvh_pmf(view_of(t), ctx, 2), 0.f);
    EXPECT_EQ(light_bvh_pmf(view_of(t), ctx, 6), 0.f);
  }
}

// pmf() equals the product along an exhaustive walk, and selection over a
// fine grid of u picks each light with its pmf, reporting exactly the pmf that
// pmf() computes. The pmfs sum to at most 1: where a node has importance but
// neither child has any (its bound was looser than theirs), traversal ends
// without a light, as in pbrt; every light that can contribute keeps a pmf > 0
// (ImportanceIsConservative).
TEST(LightBvh, PmfEqualsTheTraversalsProbabilityExhaustively) {
  const int G = 1 << 14;
  for (const bool sg : {false, true})
  for (int n : {1, 2, 3, 5, 8, 13, 40}) {
    const std::vector<Light> lights = random_lights(n, uint32_t(100 + n));
    const LightBvh t = build_light_bvh(lights, light_powers(lights));
    const LightBvhView v = view_of(t);
    Rng r(0, 0, uint32_t(n) + (sg ? 1000u : 0u));
    int contexts_with_light = 0;
    for (int k = 0; k < 30; ++k) {
      const LightSampleContext ctx = random_context(r, 7.f, sg);
      std::vector<double> walk(size_t(n), 0.0), counts(size_t(n), 0.0);
      bvh_exhaustive(v, ctx, sg, &walk);
      double sum = 0;
      for (int i = 0; i < n; ++i) {
        const float pmf = bvh_pmf(v, ctx, uint32_t(i), sg);
        EXPECT_NEAR(pmf, walk[size_t(i)], 1e-6 * std::max(1.0, walk[size_t(i)])) << "n " << n << " light " << i;
        sum += pmf;
      }
      EXPECT_LE(sum, 1.0 + 1e-5);
      if (sum == 0) continue;  // nothing has importance here (every light faces away or is below)
      ++contexts_with_light;
      double none = 0;
      for (int g = 0; g < G; ++g) {
        const LightBvhPick pick = bvh_select(v, ctx, (float(g) + 0.5f) / float(G), sg);
        if (!(pick.pmf > 0.f)) {
          none += 1;
          continue;
        }
        ASSERT_LT(pick.light, uint32_t(n));
        ASSERT_EQ(pick.pmf, bvh_pmf(v, ctx, pick.light, sg)) << "the pick's pmf is not pmf()'s";
        counts[pick.light] += 1;
      }
      // Each light's u form one interval of length pmf: at most one grid point
      // off at each end (and the "no light" intervals take the rest).
      for (int i = 0; i < n; ++i)
        EXPECT_NEAR(counts[size_t(i)] / G, walk[size_t(i)], 2.0 / G + 1e-5) << "n " << n << " light " << i << " sg " << sg;
      EXPECT_NEAR(none / G, 1.0 - sum, 2.0 * n / G + 1e-5);
    }
    EXPECT_GT(contexts_with_light, 10) << "too few shading points see any light: the test checks little";
  }
}

// Stochastic lightcuts: the cut at a shading point holds at most its size in nodes, no two of which hold the
// same light; the traversal from each node picks its lights with light_cut_pmf()'s probabilities (walked
// exhaustively); a light has a probability under the cut exactly where bvh gives it one; and the cut of one node
// is the root, with bvh's very probabilities.
TEST(LightCut, PartitionsTheLightsAndItsPmfIsTheTraversals) {
  for (int n : {1, 2, 5, 40, 300}) {
    const std::vector<Light> lights = random_lights(n, uint32_t(300 + n));
    const LightBvh t = build_light_bvh(lights, light_powers(lights));
    const LightBvhView v = view_of(t);
    Rng r(0, 0, uint32_t(n));
    int cuts_checked = 0;
    for (int k = 0; k < 20; ++k) {
      const LightSampleContext ctx = random_context(r);
      const LightBvhQuery q = light_bvh_query<false>(ctx);
      for (uint32_t size : {1u, 2u, 7u, 64u}) {
        const LightCut cut = light_bvh_cut(v, q, size);
        ASSERT_LE(cut.count, size);
        std::vector<double> walk(size_t(n), 0.0);
        std::vector<int> holders(size_t(n), 0);
        for (uint32_t c = 0; c < cut.count; ++c) {
          std::vector<double> below(size_t(n), 0.0);
          exhaustive<false>(v, cut.node[c], 1.f, q, &below);
          for (int i = 0; i < n; ++i)
            if (below[size_t(i)] > 0.0) {
              walk[size_t(i)] = below[size_t(i)];
              ++holders[size_t(i)];
            }
        }
        for (int i = 0; i < n; ++i) {
          ASSERT_LE(holders[size_t(i)], 1) << "light " << i << " under two nodes of the cut";
          const float pmf = light_cut_pmf(v, q, cut, uint32_t(i));
          EXPECT_NEAR(pmf, walk[size_t(i)], 1e-6 * std::max(1.0, walk[size_t(i)])) << "n " << n << " light " << i;
          EXPECT_EQ(pmf > 0.f, light_bvh_pmf<false>(v, ctx, uint32_t(i)) > 0.f) << "n " << n << " light " << i;
          if (size == 1) {
            EXPECT_EQ(pmf, light_bvh_pmf<false>(v, ctx, uint32_t(i)));
          }
        }
        // Picks carry the pmf of the light they pick.
        for (uint32_t c = 0; c < cut.count; ++c)
          for (float u : {0.01f, 0.37f, 0.8f}) {
            const LightBvhPick pick = light_bvh_select_below<false>(v, q, cut.node[c], u);
            if (pick.pmf > 0.f) {
              EXPECT_EQ(pick.pmf, light_cut_pmf(v, q, cut, pick.light));
            }
          }
        if (cut.count > 1) ++cuts_checked;
        if (size == 64 && n <= 40 && cut.count > 0) {  // room for every light: leaves only
          for (uint32_t c = 0; c < cut.count; ++c) EXPECT_TRUE(v.nodes[cut.node[c]].index & kLightBvhLeaf);
        }
      }
    }
    if (n >= 5) {
      EXPECT_GT(cuts_checked, 10) << "n " << n;
    }
  }
}

// Chi-square of selection frequencies against pmf() on a thousand lights.
TEST(LightBvh, SelectionFrequenciesMatchPmfOnAThousandLights) {
  const std::vector<Light> lights = random_lights(1000, 77);
  const LightBvh t = build_light_bvh(lights, light_powers(lights));
  const LightBvhView v = view_of(t);
  for (const bool sg : {false, true}) {
  Rng r(0, 0, 5);
  int tested = 0;
  for (int k = 0; k < 6; ++k) {
    const LightSampleContext ctx = random_context(r, 7.f, sg);
    const int N = 200000;
    // One bin per light and one for "no light".
    std::vector<double> observed(lights.size() + 1, 0.0), expected(lights.size() + 1, 0.0);
    double sum = 0;
    for (size_t i = 0; i < lights.size(); ++i) sum += expected[i] = bvh_pmf(v, ctx, uint32_t(i), sg);
    ASSERT_LE(sum, 1.0 + 1e-4);
    if (sum == 0) continue;  // every light behind the surface: nothing to choose
    ++tested;
    expected.back() = std::max(0.0, 1.0 - sum);
    for (double& e : expected) e *= N;
    for (int s = 0; s < N; ++s) {
      const LightBvhPick pick = bvh_select(v, ctx, r.uniform(), sg);
      observed[pick.pmf > 0.f ? pick.light : lights.size()] += 1;
    }
    const test::Chi2Result c = test::chi2_test(observed, expected);
    EXPECT_GT(c.p_value, 1e-4) << c.message << (sg ? " (sg)" : "");
  }
  EXPECT_GE(tested, 4);
  }
}

// Wherever a light can send light to a shading point (some point of it on the
// emitting side's front, above the point's surface), its pmf is > 0: the
// importance never culls a contribution. Points are taken on and near the
// lights, where the bounds are tightest.
TEST(LightBvh, ImportanceIsConservative) {
  for (const bool sg : {false, true})
  for (int type = 0; type < 3; ++type) {
    const std::vector<Light> lights = random_lights(60, uint32_t(7 + type), 3.f, type);
    const LightBvh t = build_light_bvh(lights, light_powers(lights));
    const LightBvhView v = view_of(t);
    Rng r(0, 0, uint32_t(11 + type));
    int contributing = 0;
    for (int k = 0; k < 300; ++k) {
      LightSampleContext ctx = random_context(r, 4.f, sg);
      if (k % 3 == 0) {  // close to a light: just off its surface
        const Light& l = lights[size_t(r.uniform() * lights.size()) % lights.size()];
        ctx.p = l.p + (l.type == LightType::Sphere ? random_unit(r) * (l.radius * 1.01f) : l.e1 * 0.3f + l.n * 1e-3f);
      }
      for (size_t i = 0; i < lights.size(); ++i) {
        const Light& l = lights[i];
        bool contributes = false;
        for (int s = 0; s < 64 && !contributes; ++s) {
          const LightSample ls = (type == 0 ? AreaSampling::sample_sphere(l, ctx, r.uniform2())
                                  : type == 1 ? AreaSampling::sample_quad(l, ctx, r.uniform2())
                                              : AreaSampling::sample_triangle(l, ctx, r.uniform2()));
          contributes = ls.pdf > 0.f && dot(ctx.n, ls.wi) > 1e-4f;
        }
        if (!contributes) continue;
        ++contributing;
        EXPECT_GT(bvh_pmf(v, ctx, uint32_t(i), sg), 0.f) << "type " << type << ", light " << i << ", sg " << sg;
      }
    }
    EXPECT_GT(contributing, 1000);
  }
}

// The whole pipeline on a hundred thousand lights: built within the time the
// issue asks (50 ms; the bound here is loose, CI machines are shared), every
// light in the tree, a trail that fits, pmfs that sum to 1.
TEST(LightBvh, HundredThousandLights) {
  const std::vector<Light> lights = random_lights(100000, 9, 50.f);
  const std::vector<float> power = light_powers(lights);
  const LightBvh t = build_light_bvh(lights, power);
  std::printf("[          ] light BVH of %zu lights: %.1f ms, depth %u, %.1f MiB\n", lights.size(), t.build_ms, t.depth,
              double(t.bytes()) / (1 << 20));
  RecordProperty("build_ms", std::to_string(t.build_ms));
  EXPECT_LT(t.build_ms, 1000.0);
  EXPECT_LT(t.depth, 63u);
  EXPECT_EQ(t.lights, 100000u);
  Rng r(0, 0, 3);
  const LightSampleContext ctx = random_context(r, 50.f);
  double sum = 0;
  for (size_t i = 0; i < lights.size(); ++i) sum += light_bvh_pmf(view_of(t), ctx, uint32_t(i));
  EXPECT_LE(sum, 1.0 + 1e-3);
  EXPECT_GT(sum, 0.1);
}

// --- Selection as the integrator sees it --------------------------------------------

Scene scene_with_lights(int count, bool environment) {
  nlohmann::json doc = {
      {"camera", {{"eye", {0, 2, -6}}, {"target", {0, 0, 0}}}},
      {"materials", {{"floor", {{"albedo", 0.5}}}}},
      {"shapes",
       {{{"type", "quad"}, {"corner", {-4, 0, -4}}, {"edge1", {0, 0, 8}}, {"edge2", {8, 0, 0}}, {"material", "floor"}}}},
      {"lights", {{{"type", "scatter"}, {"count", count}, {"seed", 3}, {"min", {-3, 0.3, -3}}, {"max", {3, 2, 3}},
                   {"radius", {0.05, 0.2}}, {"power", 100}, {"power_spread", 50}},
                  {{"type", "quad"}, {"corner", {-1, 3, -1}}, {"edge1", {2, 0, 0}}, {"edge2", {0, 0, 2}},
                   {"radiance", 2}}}}};
  if (environment) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / "penumbra-test-selection";
    fs::create_directories(dir);
    const std::string file = (dir / "sky.exr").string();
    std::vector<float> px(16 * 8 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = 0.2f + float(i % 7) * 0.1f;
    write_image(file, 16, 8, px);
    doc["environment"] = {{"file", file}};
  }
  return parse_scene(doc, "selection-test", ".");
}

// Every method's pick carries the pmf selection_pmf() gives that light, and
// the pmfs sum to 1; bvh picks the environment with its fixed probability.
TEST(LightSelection, PicksReportTheirPmfAndPmfsSumToOne) {
  for (bool env : {false, true}) {
    const Scene s = scene_with_lights(40, env);
    auto host = make_host_view(s);
    const SceneView& v = host->view;
    ASSERT_EQ(v.num_lights, 41u + (env ? 1u : 0u));
    if (env) {
      ASSERT_EQ(v.selection.infinite_light, int32_t(v.num_lights - 1));
      EXPECT_GE(v.selection.infinite_probability, kMinInfiniteProbability);
      EXPECT_LE(v.selection.infinite_probability, 1.f - kMinInfiniteProbability);
    }
    Rng r(0, 0, 9);
    for (LightSelection m : {LightSelection::Uniform, LightSelection::Power, LightSelection::Bvh}) {
      for (int k = 0; k < 20; ++k) {
        const LightSampleContext ctx{Vec3(6 * r.uniform() - 3, 0.f, 6 * r.uniform() - 3), Vec3(0.f, 1.f, 0.f)};
        double sum = 0;
        for (uint32_t i = 0; i < v.num_lights; ++i) sum += selection_pmf(v.selection, v.num_lights, m, ctx, i);
        EXPECT_NEAR(sum, 1.0, 1e-5) << light_selection_name(m);
        int env_picks = 0;
        const int G = 4096;
        for (int g = 0; g < G; ++g) {
          const SelectedLight sel = select_light(v.selection, v.num_lights, m, ctx, (g + 0.5f) / G);
          ASSERT_GT(sel.pmf, 0.f);
          ASSERT_EQ(sel.pmf, selection_pmf(v.selection, v.num_lights, m, ctx, sel.index)) << light_selection_name(m);
          env_picks += int32_t(sel.index) == v.selection.infinite_light;
        }
        if (env && m == LightSelection::Bvh) {
          EXPECT_NEAR(double(env_picks) / G, v.selection.infinite_probability, 2.0 / G);
        }
      }
    }
  }
}

// --- Resampled next-event estimation --------------------------------------------------

struct NoOccluder {
  bool occluded(const Ray&, float) const { return false; }
};

// Irradiance at the origin (normal +y) from spheres wholly above its horizon
// (no light shadows another: they are lights, not occluders, for NEE), in
// closed form: sum of pi L sin^2(theta_max) cos(beta). The one-vertex
// estimator: a light sample (resampled for restir) and, with MIS, a BSDF
// sample weighted against the selection method's density.
struct SphereField {
  std::vector<Light> lights;
  std::vector<float> cdf;
  LightBvh bvh;
  double exact = 0;
  explicit SphereField(int n) {
    Rng r(0, 0, 21);
    std::vector<float> power;
    for (int i = 0; i < n; ++i) {
      const Vec3 c(8 * r.uniform() - 4, 0.8f + 3 * r.uniform(), 8 * r.uniform() - 4);
      const float radius = 0.05f + 0.2f * r.uniform(), L = 1.f + 200.f * r.uniform() * r.uniform();
      lights.push_back(Light::sphere(c, radius, Vec3(L)));
      power.push_back(kPi * lights.back().area * L);
      const float d = length(c), s2 = radius * radius / (d * d);
      exact += kPi * L * s2 * (c.y / d);
    }
    cdf.assign(size_t(n) + 1, 0.f);
    double total = 0;
    for (float p : power) total += p;
    double acc = 0;
    for (int i = 0; i < n; ++i) cdf[size_t(i) + 1] = float((acc += power[size_t(i)]) / total);
    cdf.back() = 1.f;
    bvh = build_light_bvh(lights, power);
  }
  SceneView view() const {
    SceneView v;
    v.lights = lights.data();
    v.num_lights = uint32_t(lights.size());
    v.selection.power_cdf = cdf.data();
    v.selection.bvh = LightBvhView{bvh.nodes.data(), bvh.trails.data()};
    return v;
  }
};

test::MeanEstimator field_irradiance(const SphereField& field, const IntegratorSettings& s, int samples, uint32_t seed) {
  const SceneView scene = field.view();
  const Vec3 x(0.f), n(0.f, 1.f, 0.f);
  const Bsdf white = make_lambert(Vec3(1.f), n);
  const bool ris = s.light_selection == LightSelection::Restir;
  Rng rng(0, 0, seed);
  test::MeanEstimator est;
  for (int i = 0; i < samples; ++i) {
    double e = 0;
    if (s.light_selection == LightSelection::Slc) {  // a sample per node of the cut
      SurfaceHit hit;
      hit.p = x;
      hit.n = hit.ns = n;
      light_cut_queries<kAllFeatures>(scene, s, white, hit, n, Vec3(1.f), rng,
                                      [&](const ShadowQuery& q) { e += kPi * q.contribution.x; });
    } else {
      const float us = rng.uniform();
      const Vec2 u = rng.uniform2();
      const DirectSample d = choose_direct_sample(scene, s, white, x, n, ris, us, u, &rng);
      e = kPi * shade_direct_sample(NoOccluder{}, s, white, x, 0.f, n, d).x;
    }
    const float ul = rng.uniform();
    const Vec2 ub = rng.uniform2();
    if (s.mis != Mis::None) {
      const BsdfSample bs = bsdf_sample(white, n, ul, ub);
      for (uint32_t k = 0; bs.pdf > 0.f && k < scene.num_lights; ++k) {
        float t;
        if (!sphere_light_distance(field.lights[k], x, bs.wi, &t, false)) continue;
        const PrevVertex prev =
            PrevVertex::at(LightSampleContext{x, white.frame.n}, bs.pdf, ris ? float(s.restir.candidates) : 1.f);
        e += kPi * field.lights[k].radiance.x * bs.weight.x * bsdf_emission_weight(scene, s, prev, k, bs.wi);
      }
    }
    est.add(e);
  }
  return est;
}

TEST(Restir, ResampledNextEventEstimationMatchesClosedForm) {
  const SphereField field(60);
  IntegratorSettings power;
  power.strategy = Strategy::SolidAngle;
  power.mis = Mis::None;
  const test::MeanEstimator base = field_irradiance(field, power, 40000, 1);
  EXPECT_NEAR(base.mean(), field.exact, 4 * base.std_error());
  for (LightSelection source : {LightSelection::Power, LightSelection::Bvh})
    for (Mis mis : {Mis::None, Mis::Power})
      for (Strategy st : {Strategy::Area, Strategy::SolidAngle}) {
        IntegratorSettings s;
        s.strategy = st;
        s.mis = mis;
        s.light_selection = LightSelection::Restir;
        s.restir.candidates = 16;
        s.restir.source = source;
        const test::MeanEstimator e = field_irradiance(field, s, 20000, 2 + uint32_t(st));
        EXPECT_NEAR(e.mean(), field.exact, 4 * e.std_error())
            << "source " << light_selection_name(source) << ", " << mis_name(mis) << ", " << strategy_name(st);
        // Sixteen candidates resampled by contribution beat one chosen by power, per sample.
        if (st == Strategy::SolidAngle && mis == Mis::None) {
          EXPECT_LT(e.std_error() * std::sqrt(20000.0), 0.5 * base.std_error() * std::sqrt(40000.0));
        }
      }
  // The light BVH alone, too.
  IntegratorSettings bvh = power;
  bvh.light_selection = LightSelection::Bvh;
  const test::MeanEstimator b = field_irradiance(field, bvh, 40000, 3);
  EXPECT_NEAR(b.mean(), field.exact, 4 * b.std_error());
}

// Stochastic lightcuts: the sum of a cut's samples is the irradiance, with and without MIS (the BSDF sample weighed
// against the probability of the light's node's sample), and a cut of 8 nodes has far less variance than one
// sample by the light BVH; a cut of one node is bvh, sample for sample.
TEST(LightCut, EstimatorMatchesClosedFormAndBeatsOneSample) {
  const SphereField field(200);
  IntegratorSettings bvh;
  bvh.strategy = Strategy::SolidAngle;
  bvh.mis = Mis::None;
  bvh.light_selection = LightSelection::Bvh;
  const test::MeanEstimator b = field_irradiance(field, bvh, 40000, 3);
  for (Mis mis : {Mis::None, Mis::Power})
    for (uint32_t cut : {1u, 8u, 64u}) {
      IntegratorSettings s = bvh;
      s.mis = mis;
      s.light_selection = LightSelection::Slc;
      s.slc_cut = cut;
      const test::MeanEstimator e = field_irradiance(field, s, 20000, 4 + cut);
      EXPECT_NEAR(e.mean(), field.exact, 4 * e.std_error()) << "cut " << cut << ", " << mis_name(mis);
      if (cut == 8 && mis == Mis::None) {
        EXPECT_LT(e.std_error() * std::sqrt(20000.0), 0.5 * b.std_error() * std::sqrt(40000.0));
      }
    }
  IntegratorSettings one = bvh;
  one.light_selection = LightSelection::Slc;
  one.slc_cut = 1;
  const test::MeanEstimator o = field_irradiance(field, one, 40000, 3);
  EXPECT_EQ(o.mean(), b.mean()) << "a cut of one node is the light BVH's sample";
}

// Spatial reuse against an exact answer where it is hardest: a frame of
// shading points on a plane under sphere lights, where pixels of a
// checkerboard see only the even lights and the others only the odd ones, so
// that every neighbour a pixel reuses from sees a different set of lights. The
// per-pixel means of the unbiased passes (core/restir.h) match each pixel's
// irradiance in closed form; the biased combination's do not (the test can
// tell).
struct Checkerboard {
  static constexpr int kSize = 8;
  static constexpr float kPitch = 0.1f;
  const SphereField* field;
  static int parity(Vec3 p) { return (int(std::lround(p.x / kPitch)) + int(std::lround(p.z / kPitch))) & 1; }
  bool occluded(const Ray& ray, float tmax) const {
    const Vec3 end = ray.o + ray.d * tmax;
    uint32_t nearest = 0;
    for (uint32_t i = 1; i < field->lights.size(); ++i)
      if (length_sq(end - field->lights[i].p) < length_sq(end - field->lights[nearest].p)) nearest = i;
    return int(nearest & 1) != parity(ray.o);
  }
};

// Per-pixel estimators of restir's frames over an 8x8 grid of floor points (pitch 0.1, white Lambert) lit by
// `field`, with visibility from `tracer`. With rs.temporal, frames come in chains of `chain` frames, each
// chain starting without history: the estimator's samples are the chains' means (frames of one chain are
// correlated, chains are not), and `position` (if given) gets each frame's value by its place in the chain.
template <class Tracer>
std::vector<test::MeanEstimator> restir_frames(const SphereField& field, const Tracer& tracer, const RestirSettings& rs,
                                               int frames, Strategy strategy = Strategy::SolidAngle,
                                               double* largest = nullptr, int chain = 1,
                                               std::vector<std::vector<test::MeanEstimator>>* position = nullptr) {
  const int N = Checkerboard::kSize;
  const SceneView scene = field.view();
  IntegratorSettings s;
  s.strategy = strategy;
  s.mis = Mis::None;
  s.light_selection = LightSelection::Restir;
  s.restir = rs;
  std::vector<RestirPixel> pixels(size_t(N * N));
  std::vector<Reservoir> in(pixels.size()), out(pixels.size());
  std::vector<RestirPixel> history_pixels(pixels.size());
  std::vector<Reservoir> history(pixels.size());
  std::vector<double> chain_sum(pixels.size(), 0.0);
  std::vector<test::MeanEstimator> est(pixels.size());
  if (position) position->assign(size_t(chain), std::vector<test::MeanEstimator>(pixels.size()));
  const Vec3 up(0.f, 1.f, 0.f);
  for (int f = 0; f < frames; ++f) {
    if (f % chain == 0) std::fill(history_pixels.begin(), history_pixels.end(), RestirPixel());  // no history
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) {
        RestirPixel& q = pixels[size_t(y * N + x)];
        q.p = Vec3(x * Checkerboard::kPitch, 0.f, y * Checkerboard::kPitch);
        const Bsdf white = make_lambert(Vec3(1.f), up);
        q.bsdf = pack_bsdf(white);
        q.wo = up;
        q.t = 1.f;
        q.valid = 1;
        Rng rng(uint32_t(y * N + x), uint32_t(f), 17);
        const float us = rng.uniform();
        const Vec2 u = rng.uniform2();
        const DirectSample d = choose_direct_sample(scene, s, white, q.p, q.wo, true, us, u, &rng);
        in[size_t(y * N + x)] = make_reservoir(tracer, scene, white, q.p, q.p_bound, q.wo, d, rs.visibility_reuse != 0);
      }
    if (rs.temporal) {
      for (size_t i = 0; i < pixels.size(); ++i)
        out[i] = restir_temporal_reuse(tracer, scene, rs, pixels[i], in[i], history_pixels[i], history[i], uint32_t(i),
                                       uint32_t(f), 17);
      std::swap(in, out);
    }
    for (uint32_t pass = 0; pass < rs.spatial_passes; ++pass) {
      for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x)
          out[size_t(y * N + x)] =
              restir_spatial_reuse(tracer, scene, rs, pixels.data(), in.data(), N, N, x, y, uint32_t(f), 17, pass);
      std::swap(in, out);
    }
    for (size_t i = 0; i < pixels.size(); ++i) {
      const double e = kPi * restir_shade(tracer, scene, s, pixels[i], in[i]).x;
      chain_sum[i] += e;
      if (position) (*position)[size_t(f % chain)][i].add(e);
      if (f % chain == chain - 1) est[i].add(chain_sum[i] / chain), chain_sum[i] = 0.0;
      if (largest) *largest = std::max(*largest, e);
    }
    history_pixels = pixels;
    history = in;
  }
  return est;
}

// Each checkerboard pixel's irradiance from the lights of its parity (closed form: small spheres).
std::vector<double> checkerboard_irradiance(const SphereField& field) {
  const int N = Checkerboard::kSize;
  std::vector<double> exact(size_t(N * N), 0.0);
  for (int y = 0; y < N; ++y)
    for (int x = 0; x < N; ++x) {
      const Vec3 p(x * Checkerboard::kPitch, 0.f, y * Checkerboard::kPitch);
      for (size_t i = 0; i < field.lights.size(); ++i) {
        if (int(i & 1) != ((x + y) & 1)) continue;
        const Light& l = field.lights[i];
        const Vec3 d = l.p - p;
        const double dist = length(d);
        exact[size_t(y * N + x)] += kPi * l.radiance.x * double(l.radius) * l.radius / (dist * dist) * (d.y / dist);
      }
    }
  return exact;
}

TEST(Restir, SpatialReuseIsUnbiasedWhereNeighboursSeeOtherLights) {
  const SphereField field(24);
  const int N = Checkerboard::kSize;
  const std::vector<double> exact = checkerboard_irradiance(field);
  auto z2 = [&](const std::vector<test::MeanEstimator>& est, int* beyond5) {
    double sum = 0;
    *beyond5 = 0;
    for (size_t i = 0; i < est.size(); ++i) {
      const double z = (est[i].mean() - exact[i]) / est[i].std_error();
      sum += z * z;
      *beyond5 += std::fabs(z) > 5;
    }
    return sum / double(est.size());
  };
  RestirSettings rs;
  rs.candidates = 8;
  rs.spatial_passes = 2;
  rs.neighbors = 3;
  rs.radius = 3.f;
  int beyond = 0;
  const double unbiased = z2(restir_frames(field, Checkerboard{&field}, rs, 3000), &beyond);
  EXPECT_LT(unbiased, 1.5);
  EXPECT_EQ(beyond, 0);
  rs.pairwise = 1;  // pairwise MIS: unbiased too
  int beyond_pairwise = 0;
  const double pairwise = z2(restir_frames(field, Checkerboard{&field}, rs, 3000), &beyond_pairwise);
  EXPECT_LT(pairwise, 1.5);
  EXPECT_EQ(beyond_pairwise, 0);
  std::printf("[          ] checkerboard visibility, pairwise MIS: mean z^2 %.2f\n", pairwise);
  // Without visibility reuse (unshadowed targets, a shadow ray when shading): unbiased with either MIS, though every
  // pixel reuses its neighbours' samples of lights it cannot see.
  rs.visibility_reuse = 0;
  for (uint32_t pw : {0u, 1u}) {
    rs.pairwise = pw;
    int beyond_unshadowed = 0;
    const double unshadowed = z2(restir_frames(field, Checkerboard{&field}, rs, 3000), &beyond_unshadowed);
    EXPECT_LT(unshadowed, 1.5) << (pw ? "pairwise" : "generalized balance");
    EXPECT_EQ(beyond_unshadowed, 0) << (pw ? "pairwise" : "generalized balance");
    std::printf("[          ] checkerboard visibility, unshadowed targets%s: mean z^2 %.2f\n", pw ? ", pairwise" : "",
                unshadowed);
  }
  rs.visibility_reuse = 1;
  rs.pairwise = 0;
  rs.unbiased = 0;
  int beyond_biased = 0;
  const double biased = z2(restir_frames(field, Checkerboard{&field}, rs, 3000), &beyond_biased);
  EXPECT_GT(biased, 10.0) << "the biased combination looks unbiased here: this test would not see a bias";
  std::printf("[          ] checkerboard visibility: mean z^2 %.2f unbiased, %.2f biased (%d of %d pixels beyond 5 "
              "sigma)\n", unbiased, biased, beyond_biased, N * N);
}

// Temporal reuse (core/restir.h) on the checkerboard: each pixel also combines its own final reservoir of the
// previous frame (M capped at 20 x), then spatial reuse with neighbours that see other lights. Unbiased: the
// chains' means match every pixel's closed form; and it pays: late in a chain a frame's variance is well below
// the chain's first frame's, which has no history.
TEST(Restir, TemporalReuseIsUnbiasedAndLowersTheVariance) {
  const SphereField field(24);
  const std::vector<double> exact = checkerboard_irradiance(field);
  RestirSettings rs;
  rs.candidates = 4;
  rs.spatial_passes = 1;
  rs.neighbors = 3;
  rs.radius = 3.f;
  rs.temporal = 1;
  const int chain = 8;
  std::vector<std::vector<test::MeanEstimator>> position;
  const auto est = restir_frames(field, Checkerboard{&field}, rs, 1200 * chain, Strategy::SolidAngle, nullptr, chain,
                                 &position);
  double z2 = 0, var_first = 0, var_last = 0;
  int beyond = 0;
  for (size_t i = 0; i < est.size(); ++i) {
    const double z = (est[i].mean() - exact[i]) / est[i].std_error();
    z2 += z * z;
    beyond += std::fabs(z) > 5;
    auto var = [](const test::MeanEstimator& e) { return e.std_error() * e.std_error() * double(e.n); };
    var_first += var(position[0][i]);
    var_last += var(position[chain - 1][i]);
  }
  z2 /= double(est.size());
  EXPECT_LT(z2, 1.5);
  EXPECT_EQ(beyond, 0);
  EXPECT_LT(var_last, 0.7 * var_first) << "temporal reuse did not lower a frame's variance";
  std::printf("[          ] temporal reuse on the checkerboard: mean z^2 %.2f; a frame's variance %.3g at the "
              "chain's start, %.3g after %d frames\n", z2, var_first / est.size(), var_last / est.size(), chain - 1);
}

// Spatial reuse near a large sphere light: a point near the silhouette of the cap a pixel's cone samples is
// seen almost edge-on there (small target) and frontally from a neighbour (large target). The generalized
// balance heuristic and pairwise MIS (core/restir.h) bound what reuse can make of it: one pass gives each pixel at most
// sum_i (M_i / M_q) S_i, S_i the neighbours' own estimates (luminance); the paper's 1/Z combination had no such
// bound (a weight p_hat_q(y) / p_hat_i(y), unbounded). Projected solid angle makes every pixel's own estimate
// exact (zero variance: f cos / pdf is constant), so the bound reads: no frame of any pixel above
// (1 + neighbours) times the largest exact irradiance. And reuse keeps every pixel's mean.
struct NeverOccluded {
  bool occluded(const Ray&, float) const { return false; }
};

TEST(Restir, SpatialReuseNearALargeSphereIsBoundedAndUnbiased) {
  SphereField field(0);
  field.lights.push_back(Light::sphere(Vec3(0.35f, 0.55f, 0.35f), 0.5f, Vec3(10.f)));
  field.cdf = {0.f, 1.f};
  field.bvh = build_light_bvh(field.lights, {1.f});
  const int frames = 4000;
  for (uint32_t pairwise : {0u, 1u})
  for (Strategy strategy : {Strategy::SolidAngle, Strategy::ProjectedSolidAngle}) {
    SCOPED_TRACE(pairwise ? "pairwise MIS" : "generalized balance heuristic");
    RestirSettings rs;
    rs.candidates = 4;
    rs.spatial_passes = 0;
    const auto alone = restir_frames(field, NeverOccluded{}, rs, frames, strategy);
    rs.spatial_passes = 1;
    rs.neighbors = 3;
    rs.radius = 3.f;
    rs.pairwise = pairwise;
    double largest = 0;
    const auto reused = restir_frames(field, NeverOccluded{}, rs, frames, strategy, &largest);
    double exact_max = 0, z2 = 0;
    for (size_t i = 0; i < alone.size(); ++i) {
      exact_max = std::max(exact_max, alone[i].mean());
      const double d = reused[i].mean() - alone[i].mean();
      z2 += d * d / (alone[i].std_error() * alone[i].std_error() + reused[i].std_error() * reused[i].std_error());
    }
    z2 /= double(alone.size());
    EXPECT_LT(z2, 1.5) << strategy_name(strategy);
    if (strategy == Strategy::ProjectedSolidAngle) {
      for (const auto& e : alone) EXPECT_LT(e.std_error(), 1e-4 * e.mean()) << "projected solid angle is not exact";
      EXPECT_LE(largest, (1 + rs.neighbors) * exact_max * 1.001);
    }
    std::printf("[          ] %s%s near a large sphere: largest frame %.3g (exact irradiances up to %.3g); mean z^2 "
                "%.2f against no reuse\n", strategy_name(strategy), pairwise ? " (pairwise)" : "", largest, exact_max,
                z2);
  }
}

// --- Scene files ---------------------------------------------------------------------

TEST(ManyLights, ScatterGivesTheCountAndTotalPower) {
  const Scene s = load_scene("many-spheres", {"defaults.lights=123"});
  EXPECT_EQ(s.lights.size(), 123u);
  double power = 0;
  for (const Light& l : s.lights) power += kPi * l.area * luminance(l.radiance);
  EXPECT_NEAR(power, 1500.0, 1.0);
  EXPECT_EQ(s.light_bvh.lights, 123u);
  // The same seed, the same lights.
  const Scene again = load_scene("many-spheres", {"defaults.lights=123"});
  for (size_t i = 0; i < s.lights.size(); ++i) {
    EXPECT_EQ(s.lights[i].p.x, again.lights[i].p.x);
    EXPECT_EQ(s.lights[i].radius, again.lights[i].radius);
  }
}

void expect_scene_error(const nlohmann::json& doc, const std::string& field) {
  try {
    parse_scene(doc, "bad.json", ".");
    ADD_FAILURE() << "accepted; expected an error naming " << field;
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_EQ(e.file(), "bad.json") << e.what();
  }
}

TEST(ManyLights, BadScatterAndRestirSettingsNameTheirField) {
  const nlohmann::json base = {
      {"camera", {{"eye", {0, 2, -6}}, {"target", {0, 0, 0}}}},
      {"lights", {{{"type", "scatter"}, {"count", 10}, {"min", {-1, 1, -1}}, {"max", {1, 2, 1}}, {"radius", 0.1},
                   {"power", 10}}}}};
  parse_scene(base, "ok.json", ".");
  auto with = [&](const std::string& path, const nlohmann::json& value) {
    nlohmann::json d = base;
    d[nlohmann::json::json_pointer(path)] = value;
    return d;
  };
  expect_scene_error(with("/lights/0/count", 0), "lights[0].count");
  expect_scene_error(with("/lights/0/count", 2.5), "lights[0].count");
  expect_scene_error(with("/lights/0/max", {0, 0.5, 1}), "lights[0].max");
  expect_scene_error(with("/lights/0/radius", {0.2, 0.1}), "lights[0].radius[1]");
  expect_scene_error(with("/lights/0/power", -1), "lights[0].power");
  expect_scene_error(with("/lights/0/layout", "grid"), "lights[0].layout");
  expect_scene_error(with("/lights/0/colors", {{0, 0, 0}}), "lights[0].colors[0]");
  expect_scene_error(with("/lights/0/radiance", 3), "lights[0].radiance");
  expect_scene_error(with("/render", {{"restir", {{"candidates", 0}}}}), "render.restir.candidates");
  expect_scene_error(with("/render", {{"restir", {{"source", "restir"}}}}), "render.restir.source");
  expect_scene_error(with("/render", {{"restir", {{"unbiased", 1}}}}), "render.restir.unbiased");
  expect_scene_error(with("/render", {{"restir", {{"pairwise", "yes"}}}}), "render.restir.pairwise");
  expect_scene_error(with("/render", {{"restir", {{"visibility_reuse", 0}}}}), "render.restir.visibility_reuse");
  expect_scene_error(with("/render", {{"restir", {{"pairwise", true}, {"unbiased", false}}}}),
                     "render.restir.pairwise");
  expect_scene_error(with("/render", {{"restir", {{"neighbors", 99}}}}), "render.restir.neighbors");
  expect_scene_error(with("/render", {{"restir", {{"radius", 0}}}}), "render.restir.radius");
  expect_scene_error(with("/render", {{"restir", {{"temporal", 1}}}}), "render.restir.temporal");
  expect_scene_error(with("/render", {{"restir", {{"temporal_cap", 0.5}}}}), "render.restir.temporal_cap");
  expect_scene_error(with("/render", {{"light_selection", "tree"}}), "render.light_selection");
}

}  // namespace
}  // namespace pn
