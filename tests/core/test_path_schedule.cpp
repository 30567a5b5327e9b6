// The integrator's step functions (core/integrator.h) hold a path's whole state
// between trace calls: a breadth-first schedule (the CPU backend's pools, in a
// wavefront GPU's order: every closest hit, then every shadow query, consumed
// after the next closest hits and in reverse path order) renders the image the
// depth-first one renders, bit for bit, on built-in scenes and techniques.
// So do the wavefront path tracer's stages (backends/wavefront/wavefront.h; restir's passes: restir_passes.h),
// run by the CPU backend's Wavefront schedule (loops over a pool, Embree as the
// trace stage): with pools smaller than the frame (several waves a call, a
// pixel's samples in different waves), pools holding several samples of a
// pixel, and one wave for everything. Also the wavefront pool's memory at 1080p
// (the GPU issue's bound: under 1 GiB), and that a path does not trace the ray
// to a last vertex that can add nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <ostream>
#include <string>
#include <vector>

#include "backends/cpu/cpu_backend.h"
#include "backends/cuda/bvh_build.h"
#include "backends/cuda/bvh_traverse.h"
#include "backends/wavefront/restir_passes.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {
namespace {

struct Image {
  std::vector<double> sum, sum_sq;
  uint64_t nonfinite = 0;
};

// Samples [first, first + count) of every pixel; `pool`: the Wavefront schedule's paths a wave (0: its default).
Image render(const Scene& scene, CpuSchedule schedule, uint32_t first, uint32_t count, uint32_t seed,
             uint32_t pool = 0) {
  auto backend = make_cpu_backend(scene, 2, schedule, pool);
  FrameSpec frame = frame_spec(scene);
  frame.seed = seed;
  Film film(scene.render.width, scene.render.height);
  backend->render(frame, film, first, count);
  const size_t n = film.pixel_count() * 3;
  return Image{std::vector<double>(film.sum(), film.sum() + n), std::vector<double>(film.sum_sq(), film.sum_sq() + n),
               backend->last_render_stats().nonfinite};
}

double total(const std::vector<double>& v) {
  double t = 0;
  for (double x : v) t += x;
  return t;
}

struct Case {
  const char* scene;
  std::vector<std::string> sets;
};

std::string describe(const Case& c) {
  std::string s = c.scene;
  for (const std::string& o : c.sets) s += " " + o;
  return s;
}

// A case's scene at 40x24, seed 3. Empty `missing` unless its model data is not on this machine (glossy's bunny,
// Sponza: ../shared/scenes or PENUMBRA_SCENES): the test then skips, as the other built-in-scene tests do. Any
// other error fails.
Scene load_case(const Case& c, std::string* missing) {
  std::vector<std::string> o = {"render.width=40", "render.height=24", "render.seed=3"};
  o.insert(o.end(), c.sets.begin(), c.sets.end());
  try {
    return load_scene(c.scene, o);
  } catch (const SceneError& e) {
    if (std::string(e.what()).find("not found") == std::string::npos) throw;
    *missing = e.what();
    return Scene();
  }
}

void PrintTo(const Case& c, std::ostream* os) { *os << describe(c); }

class Schedules : public ::testing::TestWithParam<Case> {};

TEST_P(Schedules, BreadthFirstEqualsDepthFirstBitForBit) {
  const Case& c = GetParam();
  std::string missing;
  const Scene scene = load_case(c, &missing);
  if (!missing.empty()) GTEST_SKIP() << missing;
  // 20 samples from sample 5: a tile's pool holds 16 samples of its 256 pixels
  // (CpuBackend::kPoolPaths), so a second, partial pool runs too.
  const Image depth = render(scene, CpuSchedule::DepthFirst, 5, 20, 3);
  const Image breadth = render(scene, CpuSchedule::BreadthFirst, 5, 20, 3);
  ASSERT_GT(total(depth.sum), 0.0) << describe(c) << ": the image is black, which proves nothing";
  EXPECT_EQ(depth.sum, breadth.sum) << describe(c);
  EXPECT_EQ(depth.sum_sq, breadth.sum_sq) << describe(c);
  EXPECT_EQ(depth.nonfinite, breadth.nonfinite) << describe(c);
  // The comparison can fail: another seed gives another image.
  EXPECT_NE(depth.sum, render(scene, CpuSchedule::BreadthFirst, 5, 20, 4).sum) << describe(c);
}

const Case kCases[] = {
    {"cornell-sphere", {"render.strategy=solid-angle", "render.mis=power"}},
    {"cornell-quad", {"render.strategy=area", "render.mis=none", "render.light_selection=uniform"}},
    {"cornell-quad", {"render.strategy=bsdf"}},
    {"occlusion", {"render.strategy=projected-solid-angle", "render.mis=balance"}},
    {"polygon-near", {"render.strategy=solid-angle", "render.mis=power", "render.light_selection=bvh"}},
    {"glossy", {"render.strategy=solid-angle", "render.mis=power", "render.max_depth=3", "render.rr_depth=1"}},
    // restir: resampling at the first vertex inside the path, and the frame-level
    // passes whose primary pass records the first vertex and its reservoir.
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.spatial_passes=0"}},
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir"}},
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.unbiased=false",
                      "render.mis=none"}},
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.temporal=true",
                      "render.restir.spatial_passes=1"}},
    // slc: a shadow query per node of the cut (on_hit's `more`), consumed in the order they were made.
    {"many-spheres", {"defaults.lights=200", "render.light_selection=slc", "render.slc_cut=8"}},
    {"glossy", {"render.light_selection=slc", "render.slc_cut=4", "render.max_depth=3", "render.rr_depth=1"}},
};

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string n = std::to_string(info.index) + "_" + info.param.scene;
  for (char& ch : n)
    if (ch == '-') ch = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(Builtins, Schedules, ::testing::ValuesIn(kCases), case_name);

class Wavefront : public ::testing::TestWithParam<Case> {};

TEST_P(Wavefront, EqualsDepthFirstBitForBit) {
  const Case& c = GetParam();
  std::string missing;
  const Scene scene = load_case(c, &missing);
  if (!missing.empty()) GTEST_SKIP() << missing;
  const Image depth = render(scene, CpuSchedule::DepthFirst, 5, 12, 3);
  ASSERT_GT(total(depth.sum), 0.0) << describe(c) << ": the image is black, which proves nothing";
  // 960 pixels x 12 samples = 11,520 paths: pools of 700 (17 waves, each less than a frame, cutting pixels'
  // sample runs anywhere), 4,000 (three waves of several samples a pixel, the last partial) and 2^20 (one).
  for (uint32_t pool : {700u, 4000u, 0u}) {
    const Image wave = render(scene, CpuSchedule::Wavefront, 5, 12, 3, pool);
    EXPECT_EQ(depth.sum, wave.sum) << describe(c) << ", pool " << pool;
    EXPECT_EQ(depth.sum_sq, wave.sum_sq) << describe(c) << ", pool " << pool;
    EXPECT_EQ(depth.nonfinite, wave.nonfinite) << describe(c) << ", pool " << pool;
  }
  // The comparison can fail: another seed gives another image.
  EXPECT_NE(depth.sum, render(scene, CpuSchedule::Wavefront, 5, 12, 4, 700).sum) << describe(c);
}

const Case kWavefrontCases[] = {
    {"cornell-sphere", {"render.strategy=solid-angle", "render.mis=power"}},
    {"cornell-sphere", {"render.strategy=projected-solid-angle", "render.mis=balance"}},
    {"cornell-quad", {"render.strategy=area", "render.mis=none", "render.light_selection=uniform"}},
    {"cornell-quad", {"render.strategy=bsdf"}},
    {"occlusion", {"render.strategy=projected-solid-angle", "render.mis=balance"}},
    {"polygon-near", {"render.strategy=solid-angle", "render.mis=power", "render.light_selection=bvh"}},
    {"glossy", {"render.strategy=solid-angle", "render.mis=power", "render.max_depth=3", "render.rr_depth=1"}},
    {"glossy", {"render.strategy=area", "render.mis=none"}},
    // restir without spatial reuse: resampling at the first vertex inside on_hit.
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.spatial_passes=0"}},
    // restir's frame-level passes: the primary pass as waves (RestirFrame: reservoir queries in the shadow
    // queue, records and reservoirs written by the first vertices), then the reuse passes; every combination.
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir"}},
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.pairwise=true"}},
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.pairwise=true",
                      "render.restir.visibility_reuse=false"}},
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.unbiased=false",
                      "render.strategy=area"}},
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.temporal=true",
                      "render.restir.spatial_passes=1", "render.restir.source=bvh"}},
    // 6 close neighbours with the generalized balance heuristic: up to 42 queries a pixel, so a pool of 700 holds
    // chunks of 16 pixels (the bound and the chunking, where most neighbours are found).
    {"many-spheres", {"defaults.lights=200", "render.light_selection=restir", "render.restir.neighbors=6",
                      "render.restir.radius=4"}},
    {"many-spheres", {"defaults.lights=200", "render.light_selection=power", "render.max_depth=1"}},
    // slc with a cut of one node in a scene without an environment: one query a vertex, one slot a path, as bvh's
    // (WavefrontView::shared_slots off; glossy's sky takes a second slot, WavefrontSlc below): the same sums.
    {"many-spheres", {"defaults.lights=200", "render.light_selection=slc", "render.slc_cut=1"}},
};

INSTANTIATE_TEST_SUITE_P(Builtins, Wavefront, ::testing::ValuesIn(kWavefrontCases), case_name);

// slc with larger cuts: several queries of a path in the shadow queue at once, their results added in no set order,
// so the wavefront's image is the depth-first one up to the rounding of those sums.
TEST(WavefrontSlc, EqualsDepthFirstUpToTheOrderOfSums) {
  for (const Case& c : {Case{"many-spheres", {"defaults.lights=200", "render.light_selection=slc",
                                              "render.slc_cut=8"}},
                        Case{"glossy", {"render.light_selection=slc", "render.slc_cut=3", "render.max_depth=3"}}}) {
    std::string missing;
    const Scene scene = load_case(c, &missing);
    if (!missing.empty()) {
      std::cout << "skipped " << describe(c) << ": " << missing << "\n";
      continue;
    }
    const Image depth = render(scene, CpuSchedule::DepthFirst, 5, 12, 3);
    ASSERT_GT(total(depth.sum), 0.0) << describe(c);
    for (uint32_t pool : {700u, 0u}) {
      const Image wave = render(scene, CpuSchedule::Wavefront, 5, 12, 3, pool);
      ASSERT_EQ(depth.sum.size(), wave.sum.size());
      for (size_t i = 0; i < depth.sum.size(); ++i)
        ASSERT_NEAR(wave.sum[i], depth.sum[i], 1e-5 * (std::fabs(depth.sum[i]) + 1e-3))
            << describe(c) << ", pool " << pool << ", value " << i;
    }
  }
}

// restir's reuse passes keep each pixel's shadow queries in the pool: a pool smaller than one pixel's (16
// neighbours with the generalized balance heuristic: 272) is a one-line error; one that holds exactly one pixel's
// renders, a pixel a chunk, the depth-first image; and the default pool, one path a pixel, grows to one pixel's
// queries where the frame (here 96 pixels) has fewer pixels than that.
// restir_shade stops after its shadow query when recording (core/reservoir.h): only the recorder may say so, or the
// replay's result would be the placeholder's. (The bit-identity tests above hold the recorder to its queries.)
static_assert(tracer_records_only<RecordShadowQueries>::value, "the wavefront's recorder");
static_assert(!tracer_records_only<ReplayShadowQueries>::value, "the replay computes the result");

// The vertex a path ends at (depth == max_depth) adds only emission; with next-event estimation and no MIS
// that is the light samples' (and the environment's, where it is a light, or a black background's), so the
// ray to it is not traced.
TEST(LastVertex, AddsOnlyWhereItsEmissionCounts) {
  IntegratorSettings s;
  SceneView v;
  v.environment_light = -1;
  v.background = Vec3(0.f);
  s.strategy = Strategy::SolidAngle;
  s.mis = Mis::None;
  EXPECT_FALSE(last_vertex_adds(v, s));
  s.mis = Mis::Power;
  EXPECT_TRUE(last_vertex_adds(v, s));  // emission found by the BSDF sample is weighted in
  s.mis = Mis::None;
  s.strategy = Strategy::Bsdf;
  EXPECT_TRUE(last_vertex_adds(v, s));  // no light samples: emission is found only by rays
  s.strategy = Strategy::Area;
  v.background = Vec3(0.f, 0.f, 0.5f);
  EXPECT_TRUE(last_vertex_adds(v, s));  // the background is no light: rays that escape add it
}

// Closest rays a path traces, counted by a tracer around the cuda traversal's host code.
struct CountingTracer {
  const BvhView* bvh;
  const SceneView* scene;
  mutable uint32_t closest = 0;
  bool intersect(const Ray& r, float tmax, HitRecord* h) const {
    ++closest;
    return bvh_intersect(*bvh, scene, r, tmax, h);
  }
  bool occluded(const Ray& r, float tmax) const { return bvh_occluded(*bvh, scene, r, tmax); }
};

// In cornell-sphere without Russian roulette, at max depth 4: under MIS a path that keeps going traces 5 closest
// rays (the camera's and 4 BSDF samples); with MIS none, 4. (That the estimate is unchanged is the strategies'
// agreement tests' and the closed forms'.)
TEST(LastVertex, NoMisTracesOneClosestRayFewer) {
  const Scene scene = load_scene("cornell-sphere", {"render.width=16", "render.height=16", "render.max_depth=4",
                                                    "render.rr_depth=100", "render.strategy=solid-angle"});
  const std::unique_ptr<HostSceneView> host = make_host_view(scene);
  const BvhHost b = build_bvh(scene);
  const BvhView bvh = b.view();
  const Camera camera = scene.make_camera();
  for (Mis mis : {Mis::None, Mis::Power}) {
    IntegratorSettings s = scene.integrator();
    s.mis = mis;
    const uint32_t expected_most = mis == Mis::None ? 4u : 5u;
    uint32_t most = 0, at_most = 0, paths = 0;
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) {
        CountingTracer tracer{&bvh, &host->view};
        PathState st = start_path(camera, x, y, 0, 7);
        trace_path(tracer, host->view, s, st);
        most = std::max(most, tracer.closest);
        at_most += tracer.closest == expected_most;
        ++paths;
      }
    EXPECT_EQ(most, expected_most) << (mis == Mis::None ? "none" : "power");
    EXPECT_GT(at_most, paths / 2);  // most paths reach the last vertex: the test would see a change
  }
}

TEST(WavefrontRestir, PoolSmallerThanOnePixelsQueriesIsAnError) {
  const Case c{"many-spheres", {"defaults.lights=50", "render.light_selection=restir", "render.restir.neighbors=16",
                                "render.restir.radius=3", "render.restir.spatial_passes=1", "render.width=12",
                                "render.height=8"}};
  std::string missing;
  const Scene scene = load_case(c, &missing);
  ASSERT_TRUE(missing.empty()) << missing;
  try {
    render(scene, CpuSchedule::Wavefront, 0, 1, 3, 271);
    FAIL() << "a pool of 271 paths took restir's 272 queries a pixel";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("272 shadow queries"), std::string::npos) << e.what();
  }
  const Image depth = render(scene, CpuSchedule::DepthFirst, 0, 2, 3);
  ASSERT_GT(total(depth.sum), 0.0);
  EXPECT_EQ(depth.sum, render(scene, CpuSchedule::Wavefront, 0, 2, 3, 272).sum);
  EXPECT_EQ(depth.sum, render(scene, CpuSchedule::Wavefront, 0, 2, 3).sum);
}

// The shadow queue's order by direction (wavefront.h's ShadowOrder): every cell of the octahedral grid is used, a
// cell holds directions within a small cone (so that rays of one cell toward one light run close together), and
// counting then placing puts every query once, in cell order, each cell's queries in their queue order.
TEST(ShadowOrder, CellsAreSmallConesCoveringTheSphere) {
  Rng rng(7, 0, 1);
  std::vector<Vec3> first(kShadowCells, Vec3(0.f));
  std::vector<uint32_t> seen(kShadowCells, 0);
  float widest = 0.f;
  for (int i = 0; i < 4000000; ++i) {
    const Vec3 d = sample_uniform_sphere(rng.uniform2());
    const uint32_t c = shadow_direction_cell(d);
    ASSERT_LT(c, kShadowCells);
    if (seen[c]++ == 0) first[c] = d;
    widest = std::max(widest, std::acos(std::min(1.f, dot(d, first[c]))));
  }
  uint32_t used = 0;
  for (uint32_t n : seen) used += n > 0;
  // 16,384 cells of 4 pi / 16,384 sr each on average (a cone of about 0.016 rad); the octahedral map stretches
  // cells by at most a few times.
  EXPECT_EQ(used, kShadowCells);
  EXPECT_LT(widest, 0.1f);
  EXPECT_EQ(shadow_direction_cell(Vec3(std::nanf(""), 0.f, 0.f)), 0u);
}

TEST(ShadowOrder, PlacesEveryQueryOnceInCellOrder) {
  const uint32_t n = 50000;
  std::vector<uint32_t> cell_count(kShadowCells, 0), cell_start(kShadowCells), cell(n), rank(n), order(n, ~0u);
  ShadowOrder o;
  o.cell_count = cell_count.data();
  o.cell_start = cell_start.data();
  o.cell = cell.data();
  o.rank = rank.data();
  o.order = order.data();
  Rng rng(11, 0, 1);
  std::vector<Vec3> dirs(n);
  for (uint32_t k = 0; k < n; ++k) {
    // Clustered, as shadow rays toward one light: a few directions, a little spread.
    const Vec3 axis = k % 3 == 0 ? Vec3(0.f, 1.f, 0.f) : normalize(Vec3(1.f, -0.5f, float(k % 5)));
    dirs[k] = normalize(axis + 0.05f * sample_uniform_sphere(rng.uniform2()));
    queue_order_count(o, k, shadow_direction_cell(dirs[k]));
  }
  uint32_t start = 0;  // the GPU's scan kernel, serially
  for (uint32_t c = 0; c < kShadowCells; ++c) {
    cell_start[c] = start;
    start += cell_count[c];
  }
  ASSERT_EQ(start, n);
  for (uint32_t j = 0; j < n; ++j) queue_order_place(j, o);
  std::vector<uint32_t> placed(n, 0);
  for (uint32_t i = 0; i < n; ++i) {
    ASSERT_LT(order[i], n);
    ++placed[order[i]];
    if (i > 0) {
      ASSERT_LE(cell[order[i - 1]], cell[order[i]]) << i;
      if (cell[order[i - 1]] == cell[order[i]]) {
        EXPECT_LT(order[i - 1], order[i]);
      }
    }
    EXPECT_EQ(cell[order[i]], shadow_direction_cell(dirs[order[i]]));
  }
  for (uint32_t j = 0; j < n; ++j) EXPECT_EQ(placed[j], 1u) << j;
}

// Whether a queue is ordered, and the reason the GPU prints and bench records: the trace stage's inability first,
// then the tuning (--tune shadow_order, ray_order), then the scene's rays' length against the threshold.
TEST(QueueOrder, ChoiceAndItsReason) {
  std::string why;
  EXPECT_FALSE(choose_order(false, "cannot", OrderMode::Ordered, "ray_order", "cell", 50.0, 24.0, &why));
  EXPECT_EQ(why, "queue order (cannot)");
  EXPECT_TRUE(choose_order(true, "cannot", OrderMode::Ordered, "ray_order", "cell", 2.0, 24.0, &why));
  EXPECT_EQ(why, "cell order (ray_order)");
  EXPECT_FALSE(choose_order(true, "cannot", OrderMode::Queue, "shadow_order", "direction", 50.0, 24.0, &why));
  EXPECT_EQ(why, "queue order (shadow_order)");
  EXPECT_TRUE(choose_order(true, "cannot", OrderMode::Auto, "shadow_order", "direction", 46.4, 24.0, &why));
  EXPECT_EQ(why, "direction order (auto: rays visit 46.4 nodes, at least 24)");
  EXPECT_FALSE(choose_order(true, "cannot", OrderMode::Auto, "ray_order", "cell", 9.4, 24.0, &why));
  EXPECT_EQ(why, "queue order (auto: rays visit 9.4 nodes, under 24)");
  EXPECT_TRUE(choose_order(true, "cannot", OrderMode::Auto, "ray_order", "cell", 24.0, 24.0, &why));
}

// The bounces' ray order (wavefront.h's RayOrder): a ray's cell is its direction's octahedral cell (8 x 8), then
// its origin's Morton cell (8 x 8 x 8 of the scene's box); origins outside the box clamp to its border cells.
TEST(RayOrder, CellsAreDirectionThenOriginCells) {
  RayOrder o;
  o.lo = Vec3(-1.f, 0.f, 2.f);
  const Vec3 hi(3.f, 8.f, 4.f);
  const float side = float(1u << kRayOriginBits);
  o.scale = Vec3(side / (hi.x - o.lo.x), side / (hi.y - o.lo.y), side / (hi.z - o.lo.z));
  Rng rng(5, 0, 1);
  std::vector<uint32_t> seen(kRayCells, 0);
  for (int i = 0; i < 2000000; ++i) {
    const Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
    const Vec3 p = o.lo + (hi - o.lo) * u;
    const Vec3 d = sample_uniform_sphere(rng.uniform2());
    const uint32_t c = ray_order_cell(o, Ray(p, d));
    ASSERT_LT(c, kRayCells);
    ++seen[c];
    ASSERT_EQ(c >> (3 * kRayOriginBits), octahedral_cell(d, kRayDirectionBits));
    // The origin's cell: Morton bits x, y, z from the lowest, each axis's index in the box.
    const uint32_t m = c & ((1u << (3 * kRayOriginBits)) - 1u);
    for (int a = 0; a < 3; ++a) {
      uint32_t idx = 0;
      for (uint32_t b = 0; b < kRayOriginBits; ++b) idx |= ((m >> (3 * b + a)) & 1u) << b;
      ASSERT_EQ(idx, std::min(uint32_t(u[a] * side), uint32_t(side) - 1u)) << "axis " << a;
    }
  }
  uint32_t used = 0;
  for (uint32_t n : seen) used += n > 0;
  EXPECT_EQ(used, kRayCells);  // every cell reached by uniform origins and directions
  // Outside the box: the border cells; a NaN direction: a cell all the same.
  EXPECT_EQ(ray_order_cell(o, Ray(Vec3(-9.f, -9.f, -9.f), Vec3(0.f, 0.f, 1.f))) & 511u, 0u);
  EXPECT_EQ(ray_order_cell(o, Ray(Vec3(9.f, 99.f, 9.f), Vec3(0.f, 0.f, 1.f))) & 511u, 511u);
  EXPECT_LT(ray_order_cell(o, Ray(Vec3(0.f), Vec3(std::nanf(""), 0.f, 0.f))), kRayCells);
}

// The GPU's ordered shadow queries can be traced from the light back (reversed_shadow_ray, with
// --tune shadow_reverse=true): every built-in scene's shadow queries, made by real paths, get the same answers both
// ways from the cuda traversal's host code (a sample: on the H200 Sponza's image differed by 0.021%, which is why
// it is off by default).
struct BothWaysTracer {
  const BvhView* bvh;
  const SceneView* scene;
  mutable uint32_t queries = 0, finite = 0, blocked = 0, differ = 0;
  bool intersect(const Ray& r, float tmax, HitRecord* h) const { return bvh_intersect(*bvh, scene, r, tmax, h); }
  bool occluded(const Ray& r, float tmax) const {
    const bool forward = bvh_occluded(*bvh, scene, r, tmax);
    float back_tmax = tmax;
    const Ray back = reversed_shadow_ray(r, &back_tmax);
    ++queries;
    if (tmax < kInf) {
      ++finite;
      // The same segment: it ends where the forward ray starts, short of it by the slack only.
      const Vec3 end = back.o + back.d * back_tmax;
      EXPECT_LT(length(end - r.o), 2e-5f * (std::fabs(r.o.x) + std::fabs(r.o.y) + std::fabs(r.o.z) + 3.f * tmax));
    }
    blocked += forward;
    differ += forward != bvh_occluded(*bvh, scene, back, back_tmax);
    return forward;
  }
};

TEST(ShadowOrder, ReversedShadowRaysGiveTheSameAnswers) {
  int scenes = 0;
  for (const BuiltinScene& b : builtin_scenes()) {
    Scene scene;
    try {
      scene = load_scene(b.name, {"render.width=48", "render.height=32", "render.max_depth=3"});
    } catch (const SceneError& e) {  // the scenes of ../shared (Sponza, the bunny) where they are not found
      std::printf("%-16s skipped: %s\n", b.name, e.what());
      continue;
    }
    ++scenes;
    const std::unique_ptr<HostSceneView> host = make_host_view(scene);
    const BvhHost bvh_host = build_bvh(scene);
    const BvhView bvh = bvh_host.view();
    const Camera camera = scene.make_camera();
    const IntegratorSettings s = scene.integrator();
    BothWaysTracer tracer{&bvh, &host->view};
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 48; ++x) {
        PathState st = start_path(camera, x, y, 0, 9);
        trace_path(tracer, host->view, s, st);
      }
    std::printf("%-16s %5u shadow queries (%u finite), %5.1f%% blocked, %u answered differently\n", b.name,
                tracer.queries, tracer.finite, 100.0 * tracer.blocked / pn_max(1u, tracer.queries), tracer.differ);
    EXPECT_GT(tracer.queries, 500u) << b.name;
    EXPECT_EQ(tracer.differ, 0u) << b.name;
  }
  EXPECT_GE(scenes, 5);  // the procedural scenes at least
}

// The pool's bytes per path from the sizes of its arrays, and at 1080p (one slot per pixel: one sample of every
// pixel in one wave, the GPU's default pool) under the 1 GiB.
TEST(WavefrontMemory, PoolAt1080pIsUnderOneGiB) {
  const uint64_t per_path = kWavefrontBytesPerPath;
  const uint64_t pool = wavefront_bytes(1920u * 1080u);
  std::printf("wavefront path state: %llu bytes a path; 1920x1080 pool: %llu bytes (%.1f MiB)\n",
              (unsigned long long)per_path, (unsigned long long)pool, double(pool) / (1 << 20));
  EXPECT_GE(per_path, sizeof(Vec3) * 2 + sizeof(Rng) + sizeof(HitRecord));
  EXPECT_GE(pool, uint64_t(1920u * 1080u) * per_path);
  EXPECT_LT(pool, uint64_t(1) << 30);
}

}  // namespace
}  // namespace pn
