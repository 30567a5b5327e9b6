// The cuda traversal (backends/cuda/bvh_traverse.h) is host-device code: here it
// runs on the CPU against the CPU backend's own Embree answers, on every built-in
// scene (those whose data is missing are skipped) and on an alpha-textured scene,
// with random rays inside the scene's bounds and camera rays. Also the BVH's
// invariants: every triangle of a mesh in at least one leaf (exactly one without
// spatial splits) and every point of it inside one of its leaves' boxes, every
// box inside its parent's, every item of the top level once.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "backends/cpu/cpu_backend.h"
#include "backends/cuda/bvh_build.h"
#include "backends/cuda/bvh_traverse.h"
#include "backends/cuda/trace_forms.h"
#include "backends/probe_rays.h"
#include "scene/scene.h"

namespace pn {
namespace {

using json = nlohmann::json;

constexpr uint32_t kRandomRays = 20000;
constexpr uint32_t kSeed = 11;

// How two traversals' answers to the same rays compare.
struct Agreement {
  uint64_t rays = 0, hits = 0;
  uint64_t ties = 0;   // different primitives at the same distance (shared edges, coplanar faces)
  uint64_t other = 0;  // hit against miss, or different primitives at different distances
  uint64_t t_off = 0;  // the same primitive at distances further apart than kRelT
  uint64_t bary_off = 0;  // the same triangle with barycentrics further apart than kBary
  std::string first;   // the first disagreement, for the failure message
};

// Tolerances relative to the size of the coordinates (1 + |o| + t): both tests
// round at that scale, and a grazing ray turns such rounding into larger
// differences of t. Barycentrics are compared by the points they give.
constexpr float kRelT = 2e-5f;  // the same primitive: difference of t, distance of the points
constexpr float kTieT = 1e-4f;  // different primitives: a tie within this difference

void note(Agreement* a, const std::string& what) {
  if (a->first.empty()) a->first = what;
}

std::string describe(const Ray& r) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "ray o=(%.7g, %.7g, %.7g) d=(%.7g, %.7g, %.7g)", r.o.x, r.o.y, r.o.z, r.d.x, r.d.y,
                r.d.z);
  return buf;
}

// Both answers go to *embree and *cuda where given (instance kTraceMiss: a miss).
void compare_closest(const RayQueries& ref, const BvhView& bvh, const SceneView& view, const Ray& ray, float tmax,
                     Agreement* a, HitRecord* embree = nullptr, HitRecord* cuda = nullptr) {
  ++a->rays;
  HitRecord e, c;
  const bool he = ref.intersect(ray, tmax, &e), hc = bvh_intersect(bvh, &view, ray, tmax, &c);
  if (embree) *embree = e, embree->instance = he ? e.instance : kTraceMiss;
  if (cuda) *cuda = c, cuda->instance = hc ? c.instance : kTraceMiss;
  if (!he && !hc) return;
  if (he != hc) {
    ++a->other;
    note(a, describe(ray) + (he ? ": Embree hits, cuda misses" : ": cuda hits, Embree misses"));
    return;
  }
  ++a->hits;
  const float scale = 1.f + max_component(vmax(ray.o, -ray.o)) + std::fabs(e.t);
  if (e.instance == c.instance && e.prim == c.prim) {
    if (std::fabs(e.t - c.t) > kRelT * scale) {
      ++a->t_off;
      note(a, describe(ray) + ": t " + std::to_string(e.t) + " (Embree) vs " + std::to_string(c.t));
    }
    if (e.instance != kSphereInstance) {  // barycentrics: the points they give, in world space
      const InstanceView& inst = view.instances[e.instance];
      const uint32_t* idx = inst.mesh.indices + 3 * e.prim;
      const Vec3 p0 = inst.mesh.positions[idx[0]];
      const Vec3 dp =
          (inst.mesh.positions[idx[1]] - p0) * (e.b1 - c.b1) + (inst.mesh.positions[idx[2]] - p0) * (e.b2 - c.b2);
      if (length(inst.to_world.vector(dp)) > kRelT * scale) {
        ++a->bary_off;
        note(a, describe(ray) + ": barycentrics (" + std::to_string(e.b1) + ", " + std::to_string(e.b2) +
                    ") (Embree) vs (" + std::to_string(c.b1) + ", " + std::to_string(c.b2) + ")");
      }
    }
  } else if (std::fabs(e.t - c.t) <= kTieT * scale) {
    ++a->ties;
  } else {
    ++a->other;
    note(a, describe(ray) + ": Embree hits " + std::to_string(e.instance) + "/" + std::to_string(e.prim) + " at " +
                std::to_string(e.t) + ", cuda " + std::to_string(c.instance) + "/" + std::to_string(c.prim) + " at " +
                std::to_string(c.t));
  }
}

// A form of the traversal (bvh_traverse.h's kBvhFlat, kBvhIfIf, kBvhFmaBox, as the GPU's kernels compile them)
// against the plain one on the same rays: shadow answers equal; closest hits at the same t, on the same primitive
// but where two are hit at that same t (the one found first wins, and the FMA box test may order children
// differently where their entries are a rounding apart). Returns the rays that differ; counts the ties.
template <int kForm>
uint64_t form_differences(const BvhView& bvh, const SceneView& view, const std::vector<TraceRay>& closest,
                          const std::vector<TraceRay>& shadow, uint64_t* ties) {
  uint64_t differ = 0;
  for (const TraceRay& r : closest) {
    HitRecord a, b;
    const bool ha = bvh_trace<false>(bvh, &view, Ray(r.o, r.d), r.tmax, &a);
    const bool hb = bvh_trace<false, kForm>(bvh, &view, Ray(r.o, r.d), r.tmax, &b);
    if (ha != hb || (ha && a.t != b.t)) {
      ++differ;
    } else if (ha && (a.instance != b.instance || a.prim != b.prim)) {
      ++*ties;
    } else if (ha && (a.b1 != b.b1 || a.b2 != b.b2)) {
      ++differ;
    }
  }
  for (const TraceRay& r : shadow) {
    HitRecord unused;
    differ += bvh_trace<true>(bvh, &view, Ray(r.o, r.d), r.tmax, &unused) !=
              bvh_trace<true, kForm>(bvh, &view, Ray(r.o, r.d), r.tmax, &unused);
  }
  return differ;
}

// Runs every check on one scene.
void check_scene(const Scene& scene, const BvhBuildOptions& options = BvhBuildOptions()) {
  const std::unique_ptr<RayQueries> ref = make_cpu_ray_queries(scene);
  const std::unique_ptr<HostSceneView> host = make_host_view(scene);
  const BvhHost built = build_bvh(scene, options);
  const BvhView bvh = built.view();
  const Bounds3 bounds = scene_bounds(scene);
  ASSERT_FALSE(bounds.empty()) << scene.source;

  // Closest hits: random rays inside the bounds, then camera rays.
  Agreement closest;
  for (const TraceRay& r : probe_closest_rays(bounds, kRandomRays, kSeed))
    compare_closest(*ref, bvh, host->view, Ray(r.o, r.d), r.tmax, &closest);
  const Camera cam = scene.make_camera();
  constexpr int kCamW = 96, kCamH = 54;
  for (int y = 0; y < kCamH; ++y)
    for (int x = 0; x < kCamW; ++x) {
      const Ray r = cam.generate_ray((x + 0.5f) * cam.width / kCamW, (y + 0.5f) * cam.height / kCamH);
      compare_closest(*ref, bvh, host->view, r, kInf, &closest);
    }
  // The rays must test something: most of them hit.
  EXPECT_GT(closest.hits, closest.rays / 4) << scene.source;
  EXPECT_EQ(closest.t_off, 0u) << scene.source << ": " << closest.first;
  EXPECT_EQ(closest.bary_off, 0u) << scene.source << ": " << closest.first;
  // Edges and vertices: at most 1 ray in 5,000 disagrees on whether or what it hits.
  EXPECT_LE(closest.other, closest.rays / 5000) << scene.source << ": " << closest.first;
  // Ties: rays from inside a box through its face on the floor, coplanar faces.
  EXPECT_LE(closest.ties, closest.rays / 100) << scene.source;

  // Shadow rays between random points of the bounds.
  uint64_t blocked = 0, mismatched = 0;
  std::string first;
  const std::vector<TraceRay> shadow = probe_shadow_rays(bounds, kRandomRays, kSeed);
  for (const TraceRay& r : shadow) {
    const Ray ray(r.o, r.d);
    const bool e = ref->occluded(ray, r.tmax), c = bvh_occluded(bvh, &host->view, ray, r.tmax);
    blocked += e;
    if (e != c) {
      ++mismatched;
      if (first.empty())
        first = describe(ray) + " tmax " + std::to_string(r.tmax) + (e ? ": Embree blocked" : ": cuda blocked");
    }
  }
  EXPECT_LE(mismatched, shadow.size() / 5000) << scene.source << ": " << first;
  EXPECT_GT(blocked, 0u) << scene.source;

  // Rays that leave surfaces, as paths make them (probe_surface_rays): neither Embree nor the cuda traversal finds
  // the triangle a ray leaves (a self-intersection, which adds a vertex and light where there is none), and the
  // two agree as on random rays.
  {
    const SurfaceRays sr = probe_surface_rays(scene, kRandomRays, kSeed + 3);
    ASSERT_EQ(sr.closest.size(), size_t(kRandomRays)) << scene.source;
    Agreement surface;
    uint64_t self_embree = 0, self_cuda = 0, surface_mismatched = 0;
    std::string first_self;
    for (size_t i = 0; i < sr.closest.size(); ++i) {
      const TraceRay& r = sr.closest[i];
      const Ray ray(r.o, r.d);
      HitRecord e, c;
      compare_closest(*ref, bvh, host->view, ray, r.tmax, &surface, &e, &c);
      const bool se = e.instance == sr.origin_instance[i] && e.prim == sr.origin_prim[i];
      const bool sc = c.instance == sr.origin_instance[i] && c.prim == sr.origin_prim[i];
      self_embree += se;
      self_cuda += sc;
      if ((se || sc) && first_self.empty())
        first_self = describe(ray) + " from its triangle " + std::to_string(sr.origin_instance[i]) + "/" +
                     std::to_string(sr.origin_prim[i]) + ": t " +
                     std::to_string(se ? e.t : c.t) + (se ? " (Embree)" : " (cuda)");
      const TraceRay& q = sr.shadow[i];
      surface_mismatched += ref->occluded(Ray(q.o, q.d), q.tmax) != bvh_occluded(bvh, &host->view, Ray(q.o, q.d), q.tmax);
    }
    EXPECT_EQ(self_embree, 0u) << scene.source << ": " << first_self;
    EXPECT_EQ(self_cuda, 0u) << scene.source << ": " << first_self;
    EXPECT_GT(surface.hits, 0u) << scene.source;
    EXPECT_EQ(surface.t_off, 0u) << scene.source << ": " << surface.first;
    EXPECT_LE(surface.other, surface.rays / 5000) << scene.source << ": " << surface.first;
    // Ties: a ray leaves on a random side, so some start inside a closed object and find its bottom face and the
    // floor it stands on, coplanar (2.4% of glossy's, 1.4% of cornell-quad's at 200,000 rays).
    EXPECT_LE(surface.ties, surface.rays / 20) << scene.source;
    EXPECT_LE(surface_mismatched, sr.shadow.size() / 5000) << scene.source;
    std::printf("[ surfaces  ] %s: closest %llu rays, %llu hits, %llu ties, %llu other, self-hits %llu / %llu "
                "(Embree / cuda); shadow %llu mismatched\n",
                scene.source.c_str(), (unsigned long long)surface.rays, (unsigned long long)surface.hits,
                (unsigned long long)surface.ties, (unsigned long long)surface.other, (unsigned long long)self_embree,
                (unsigned long long)self_cuda, (unsigned long long)surface_mismatched);
  }

  // Instances whose transform is the identity keep the world ray (no object-space ray made on entry, none
  // remade on exit): the same answers as the general path, with the flags cleared, to the last bit but the
  // sign of zeros (a float ==).
  BvhHost general = built;
  uint32_t identities = 0;
  for (BvhInstance& bi : general.instances) {
    identities += bi.identity;
    EXPECT_EQ(bi.identity != 0, bi.to_object.is_identity()) << scene.source;
    bi.identity = 0;
  }
  if (identities > 0) {
    uint64_t differ = 0;
    const BvhView gv = general.view();
    for (const TraceRay& r : probe_closest_rays(bounds, kRandomRays, kSeed + 1)) {
      HitRecord a, b;
      const bool ha = bvh_intersect(bvh, &host->view, Ray(r.o, r.d), r.tmax, &a);
      const bool hb = bvh_intersect(gv, &host->view, Ray(r.o, r.d), r.tmax, &b);
      differ += ha != hb || (ha && (a.t != b.t || a.instance != b.instance || a.prim != b.prim || a.b1 != b.b1 ||
                                    a.b2 != b.b2));
    }
    for (const TraceRay& r : shadow)
      differ += bvh_occluded(bvh, &host->view, Ray(r.o, r.d), r.tmax) !=
                bvh_occluded(gv, &host->view, Ray(r.o, r.d), r.tmax);
    EXPECT_EQ(differ, 0u) << scene.source << ": the identity instances' fast path differs from the general one";
  }
  // The forms the GPU's kernels are compiled in: the same answers. Flat ones only where the scene is flat.
  {
    const std::vector<TraceRay> rays = probe_closest_rays(bounds, kRandomRays / 4, kSeed + 2);
    const std::vector<TraceRay> segs = probe_shadow_rays(bounds, kRandomRays / 4, kSeed + 2);
    uint64_t ties = 0;
    EXPECT_EQ((form_differences<kBvhIfIf>(bvh, host->view, rays, segs, &ties)), 0u) << scene.source << ": if-if";
    EXPECT_EQ(ties, 0u) << scene.source << ": if-if visits in the same order";
    EXPECT_EQ((form_differences<kBvhFmaBox>(bvh, host->view, rays, segs, &ties)), 0u) << scene.source << ": fma";
    EXPECT_EQ((form_differences<kBvhFmaBox | kBvhIfIf>(bvh, host->view, rays, segs, &ties)), 0u) << scene.source;
    const bool flat = !built.any_alpha_masked &&
                      std::all_of(scene.instances.begin(), scene.instances.end(),
                                  [](const Instance& i) { return i.to_object.is_identity(); });
    EXPECT_EQ(bvh.flat, flat) << scene.source;
    if (bvh.flat) {
      EXPECT_EQ((form_differences<kBvhFlat>(bvh, host->view, rays, segs, &ties)), 0u) << scene.source << ": flat";
      EXPECT_EQ((form_differences<kBvhFlat | kBvhIfIf | kBvhFmaBox>(bvh, host->view, rays, segs, &ties)), 0u)
          << scene.source << ": flat, if-if, fma";
    }
    EXPECT_LE(ties, 3 * rays.size() / 100) << scene.source;
  }
  std::printf("[ agreement ] %s: closest %llu rays, %llu hits, %llu ties, %llu other; shadow %zu rays, %llu blocked, "
              "%llu mismatched%s\n",
              scene.source.c_str(), (unsigned long long)closest.rays, (unsigned long long)closest.hits,
              (unsigned long long)closest.ties, (unsigned long long)closest.other, shadow.size(),
              (unsigned long long)blocked, (unsigned long long)mismatched, bvh.flat ? "; flat" : "");
}

// --- Invariants --------------------------------------------------------------------

struct Box {
  Vec3 lo, hi;
  bool contains(const Box& b) const {
    return lo.x <= b.lo.x && lo.y <= b.lo.y && lo.z <= b.lo.z && b.hi.x <= hi.x && b.hi.y <= hi.y && b.hi.z <= hi.z;
  }
  bool contains(Vec3 p) const { return contains(Box{p, p}); }
  bool contains(Vec3 p, float eps) const { return Box{lo - Vec3(eps), hi + Vec3(eps)}.contains(p); }
};

Box child_box(const BvhNode& n, int c) {
  const float* xy = c == 0 ? n.c0 : n.c1;
  return Box{Vec3(xy[0], xy[2], n.z[2 * c]), Vec3(xy[1], xy[3], n.z[2 * c + 1])};
}

// Walks a subtree whose box is `box`, calling leaf(ref) on its leaves.
template <class Leaf>
void walk(const BvhHost& b, int32_t ref, const Box& box, const Leaf& leaf, int* bad_boxes) {
  if (ref < 0) return leaf(ref, box);
  ASSERT_LT(size_t(ref), b.nodes.size());
  const BvhNode& n = b.nodes[size_t(ref)];
  for (int c = 0; c < 2; ++c) {
    const Box cb = child_box(n, c);
    if (!box.contains(cb)) ++*bad_boxes;
    walk(b, n.child[c], cb, leaf, bad_boxes);
  }
}

// Points of a triangle: its corners, edge midpoints and centroid, and random ones.
std::vector<Vec3> points_of(Vec3 a, Vec3 b, Vec3 c, Rng& rng) {
  std::vector<Vec3> p = {a, b, c, (a + b) * 0.5f, (b + c) * 0.5f, (c + a) * 0.5f, (a + b + c) * (1.f / 3.f)};
  for (int i = 0; i < 8; ++i) {
    float u = rng.uniform(), v = rng.uniform();
    if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
    p.push_back(a + (b - a) * u + (c - a) * v);
  }
  return p;
}

void check_invariants(const Scene& scene, bool splits, bool reinsertion = false) {
  BvhBuildOptions options;
  options.spatial_splits = splits;
  options.reinsertion = reinsertion;
  const BvhHost b = build_bvh(scene, options);
  Rng rng(0, 0, kSeed);
  const Box everything{Vec3(-kInf), Vec3(kInf)};
  int bad_boxes = 0;
  // Bottom level: each mesh once, through its first instance.
  std::vector<bool> seen_mesh(scene.meshes.size(), false);
  size_t triangles = 0;
  for (const BvhInstance& bi : b.instances) {
    const uint32_t mi = scene.instances.at(bi.instance).mesh;
    if (seen_mesh[mi]) continue;
    seen_mesh[mi] = true;
    const TriangleMesh& m = scene.meshes[mi];
    std::vector<std::vector<Box>> leaf_boxes(m.indices.size());  // of each triangle's leaves
    walk(b, bi.root, everything, [&](int32_t ref, const Box& box) {
      for (uint32_t i = 0; i < bvh_leaf_count(ref); ++i) {
        const BvhTriangle& t = b.triangles.at(bvh_leaf_first(ref) + i);
        ASSERT_LT(t.prim, m.indices.size());
        leaf_boxes[t.prim].push_back(box);
        ++triangles;
        // The copy is the mesh's triangle.
        for (int k = 0; k < 3; ++k) {
          const float* q = k == 0 ? t.p0 : (k == 1 ? t.p1 : t.p2);
          const Vec3 v = m.positions[m.indices[t.prim][k]];
          ASSERT_TRUE(q[0] == v.x && q[1] == v.y && q[2] == v.z) << scene.source << ": a copy that is not the triangle";
        }
      }
    }, &bad_boxes);
    // Every triangle in a leaf (in one alone without splits), and each of its
    // points inside some leaf's box: the split parts cover the whole triangle.
    float scale = 0.f;
    for (const Vec3& p : m.positions) scale = std::max({scale, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
    const float eps = 1e-5f * scale;
    for (size_t t = 0; t < leaf_boxes.size(); ++t) {
      const auto& boxes = leaf_boxes[t];
      if (splits) {
        ASSERT_GE(boxes.size(), 1u) << scene.source << ": mesh " << mi << " triangle " << t << " in no leaf";
      } else {
        ASSERT_EQ(boxes.size(), 1u) << scene.source << ": mesh " << mi << " triangle " << t;
      }
      const auto& idx = m.indices[t];
      for (const Vec3& p : points_of(m.positions[idx[0]], m.positions[idx[1]], m.positions[idx[2]], rng))
        ASSERT_TRUE(std::any_of(boxes.begin(), boxes.end(), [&](const Box& bx) { return bx.contains(p, eps); }))
            << scene.source << ": mesh " << mi << " triangle " << t << ": a point outside its leaves' boxes";
    }
  }
  EXPECT_EQ(triangles, b.triangles.size()) << scene.source << ": triangles outside every mesh's tree";
  // Top level: every item once; an instance's box holds its mesh's vertices placed.
  std::vector<int> items(b.items.size(), 0);
  walk(b, b.root, everything, [&](int32_t ref, const Box& box) {
    ASSERT_EQ(bvh_leaf_count(ref), 1u);
    const uint32_t item = bvh_leaf_first(ref);
    ASSERT_LT(item, items.size());
    ++items[item];
    if (b.items[item] & kBvhItemSphere) {
      const Sphere& s = scene.spheres.at(b.items[item] & ~kBvhItemSphere);
      if (!box.contains(Box{s.center - Vec3(s.radius), s.center + Vec3(s.radius)})) ++bad_boxes;
    } else {
      const Instance& inst = scene.instances.at(b.instances.at(b.items[item]).instance);
      for (const Vec3& p : scene.meshes[inst.mesh].positions)
        if (!box.contains(inst.to_world.point(p))) ++bad_boxes;
    }
  }, &bad_boxes);
  for (size_t i = 0; i < items.size(); ++i) ASSERT_EQ(items[i], 1) << scene.source << ": item " << i;
  EXPECT_EQ(bad_boxes, 0) << scene.source << ": boxes not inside their parent's";
  size_t spheres = 0, instances = 0;
  for (uint32_t it : b.items) (it & kBvhItemSphere) ? ++spheres : ++instances;
  EXPECT_EQ(spheres, scene.spheres.size());
  EXPECT_EQ(instances, b.instances.size());
}

// --- The scenes --------------------------------------------------------------------

std::vector<std::string> builtin_names() {
  std::vector<std::string> names;
  for (const BuiltinScene& s : builtin_scenes()) names.push_back(s.name);
  return names;
}

class CudaTraversalBuiltin : public ::testing::TestWithParam<std::string> {
 protected:
  Scene load() {
    try {
      return load_scene(GetParam(), {"render.width=320", "render.height=180"});
    } catch (const SceneError& e) {
      skipped_ = e.what();
      return Scene();
    }
  }
  std::string skipped_;
};

TEST_P(CudaTraversalBuiltin, AgreesWithEmbree) {
  const Scene scene = load();
  if (!skipped_.empty()) GTEST_SKIP() << skipped_;
  check_scene(scene);
}

TEST_P(CudaTraversalBuiltin, BvhInvariants) {
  const Scene scene = load();
  if (!skipped_.empty()) GTEST_SKIP() << skipped_;
  check_invariants(scene, true);
  check_invariants(scene, false);
}

// The trees optimized by reinsertion (--tune cuda_reinsert): the same answers as Embree, the same invariants, a
// lower SAH cost, and fewer nodes visited by the random rays of `bench --probe` (counted, printed).
struct StepCount {
  mutable uint64_t nodes = 0, triangles = 0;
  void node() const { ++nodes; }
  void leaf(uint32_t n) const { triangles += n; }
};

TEST_P(CudaTraversalBuiltin, ReinsertionKeepsAnswersAndLowersCost) {
  const Scene scene = load();
  if (!skipped_.empty()) GTEST_SKIP() << skipped_;
  BvhBuildOptions reinsert;
  reinsert.reinsertion = true;
  check_scene(scene, reinsert);
  check_invariants(scene, true, true);
  const BvhHost built = build_bvh(scene), optimized = build_bvh(scene, reinsert);
  EXPECT_LE(optimized.stats.sah_visits_per_ray, built.stats.sah_visits_per_ray * (1 + 1e-6)) << scene.source;
  const Bounds3 bounds = scene_bounds(scene);
  const std::vector<TraceRay> closest = probe_closest_rays(bounds, kRandomRays, kSeed),
                              shadow = probe_shadow_rays(bounds, kRandomRays, kSeed);
  auto count = [&](const BvhHost& b, bool any) {
    const BvhView v = b.view();
    const std::unique_ptr<HostSceneView> host = make_host_view(scene);
    StepCount c;
    HitRecord h;
    for (const TraceRay& r : any ? shadow : closest) {
      if (any) bvh_trace<true, kBvhAnyScene, StepCount>(v, &host->view, Ray(r.o, r.d), r.tmax, &h, c);
      else bvh_trace<false, kBvhAnyScene, StepCount>(v, &host->view, Ray(r.o, r.d), r.tmax, &h, c);
    }
    return std::array<double, 2>{double(c.nodes) / kRandomRays, double(c.triangles) / kRandomRays};
  };
  const auto c0 = count(built, false), c1 = count(optimized, false), s0 = count(built, true),
             s1 = count(optimized, true);
  std::printf("%s: SAH visits %.2f -> %.2f; closest rays: nodes %.2f -> %.2f, triangles %.2f -> %.2f; shadow rays: "
              "nodes %.2f -> %.2f, triangles %.2f -> %.2f; %llu subtrees moved in %.0f ms (build %.0f ms)\n",
              GetParam().c_str(), built.stats.sah_visits_per_ray, optimized.stats.sah_visits_per_ray, c0[0], c1[0],
              c0[1], c1[1], s0[0], s1[0], s0[1], s1[1], (unsigned long long)optimized.stats.reinserted,
              optimized.stats.reinsertion_ms, optimized.stats.build_ms);
  if (GetParam() == "sponza") {  // the scene the optimization is for: measured 46.4 -> 42.1, 19.7 -> 18.1 nodes
    EXPECT_LT(optimized.stats.sah_visits_per_ray, 0.95 * built.stats.sah_visits_per_ray);
    EXPECT_LT(c1[0], 0.95 * c0[0]);
  }
}

// BvhStats::sah_visits_per_ray against its meaning: the nodes below the root(s) that random lines through the
// scene's box meet (isotropic lines, uniform in the plane across each direction: the measure under which the
// chance of meeting a convex box is proportional to its area), counted by descending wherever a box is met.
bool line_meets(Vec3 o, Vec3 d, const float* xy, float zlo, float zhi) {
  float t0 = -kInf, t1 = kInf;
  const float lo[3] = {xy[0], xy[2], zlo}, hi[3] = {xy[1], xy[3], zhi};
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.f) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    float ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1;
}

uint32_t line_visits(const BvhHost& b, int32_t ref, Vec3 o, Vec3 d, bool top) {
  if (ref < 0) {
    if (!top) return 0;
    const uint32_t item = b.items[bvh_leaf_first(ref)];
    if (item & kBvhItemSphere) return 0;
    const BvhInstance& inst = b.instances[item];
    return line_visits(b, inst.root, inst.to_object.point(o), inst.to_object.vector(d), false);
  }
  const BvhNode& n = b.nodes[size_t(ref)];
  uint32_t v = 0;
  if (line_meets(o, d, n.c0, n.z[0], n.z[1])) v += 1 + line_visits(b, n.child[0], o, d, top);
  if (line_meets(o, d, n.c1, n.z[2], n.z[3])) v += 1 + line_visits(b, n.child[1], o, d, top);
  return v;
}

TEST_P(CudaTraversalBuiltin, SahVisitsAreThoseOfRandomLines) {
  const Scene scene = load();
  if (!skipped_.empty()) GTEST_SKIP() << skipped_;
  const BvhHost b = build_bvh(scene);
  ASSERT_GE(b.root, 0) << "every built-in scene has more than one top-level item";
  const BvhNode& r = b.nodes[size_t(b.root)];
  const float xy[4] = {std::min(r.c0[0], r.c1[0]), std::max(r.c0[1], r.c1[1]), std::min(r.c0[2], r.c1[2]),
                       std::max(r.c0[3], r.c1[3])};
  const float zlo = std::min(r.z[0], r.z[2]), zhi = std::max(r.z[1], r.z[3]);
  const Vec3 c(0.5f * (xy[0] + xy[1]), 0.5f * (xy[2] + xy[3]), 0.5f * (zlo + zhi));
  const float radius = 0.5f * length(Vec3(xy[1] - xy[0], xy[3] - xy[2], zhi - zlo));
  Rng rng(5, 0, 1);
  double sum = 0, sum_sq = 0;
  int n = 0;
  while (n < 20000) {
    const Vec3 d = sample_uniform_sphere(rng.uniform2());
    const Frame f = Frame::from_z(d);
    const Vec2 u = rng.uniform2();
    const Vec3 o = c + f.s * ((2.f * u.x - 1.f) * radius) + f.t * ((2.f * u.y - 1.f) * radius);
    if (!line_meets(o, d, xy, zlo, zhi)) continue;
    const double v = line_visits(b, b.root, o, d, true);
    sum += v;
    sum_sq += v * v;
    ++n;
  }
  const double mean = sum / n, se = std::sqrt(std::max(0.0, sum_sq / n - mean * mean) / n);
  std::printf("%-16s SAH visits a ray %.2f, random lines %.2f +- %.2f\n", GetParam().c_str(),
              b.stats.sah_visits_per_ray, mean, se);
  EXPECT_NEAR(b.stats.sah_visits_per_ray, mean, 4.0 * se + 0.02 * mean) << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Scenes, CudaTraversalBuiltin, ::testing::ValuesIn(builtin_names()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string n = info.param;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

// Alpha masks without scene data: a floor, a rotated and scaled occluder whose
// alpha texture is a 4 x 4 checkerboard of holes (nearest lookup), a second
// placement of it, and a sphere light. Rays through the holes must go on.
Scene alpha_scene() {
  json doc = {
      {"camera", {{"eye", {0, 3, 3}}, {"target", {0, 0, 0}}, {"fov", 50}}},
      {"render", {{"width", 32}, {"height", 32}}},
      {"materials", {{"floor", {{"albedo", 0.7}}}, {"mask", {{"albedo", 0.5}}}}},
      {"shapes",
       {{{"type", "quad"}, {"corner", {-2, 0, -2}}, {"edge1", {0, 0, 4}}, {"edge2", {4, 0, 0}}, {"material", "floor"}},
        {{"type", "quad"}, {"corner", {-1, 1, -1}}, {"edge1", {0, 0.3, 2}}, {"edge2", {2, 0.2, 0}},
         {"material", "mask"}},
        {{"type", "quad"}, {"corner", {-1.5, 0.5, -1.5}}, {"edge1", {0, 0, 3}}, {"edge2", {3, 0, 0.4}},
         {"material", "mask"}}}},
      {"lights", {{{"type", "sphere"}, {"center", {0, 2, 0}}, {"radius", 0.3}, {"radiance", 10}}}}};
  Scene scene = parse_scene(doc, "alpha-checker", ".");
  TextureImage img;
  img.path = "checker";
  img.width = img.height = 4;
  img.format = TexelFormat::Rgba8Srgb;
  img.nearest = true;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      img.texels.insert(img.texels.end(), {200, 200, 200, uint8_t((x + y) % 2 ? 255 : 0)});
  scene.textures.push_back(img);
  for (size_t i = 1; i < scene.instances.size(); ++i) {
    Material& m = scene.materials[scene.instances[i].material];
    m.alpha_mode = AlphaMode::Mask;
    m.alpha_cutoff = 0.5f;
    m.base_color_tex = int32_t(scene.textures.size() - 1);
    TriangleMesh& mesh = scene.meshes[scene.instances[i].mesh];
    mesh.uvs = {Vec2(0.f, 0.f), Vec2(0.f, 1.f), Vec2(1.f, 1.f), Vec2(1.f, 0.f)};
  }
  finalize_scene(scene);
  return scene;
}

TEST(CudaTraversal, AlphaMasksAgreeWithEmbree) {
  const Scene scene = alpha_scene();
  ASSERT_TRUE(scene.instance_alpha_masked(scene.instances[1]));
  const BvhHost b = build_bvh(scene);
  EXPECT_TRUE(b.any_alpha_masked);
  check_scene(scene);
  check_invariants(scene, true);
  check_invariants(scene, false);
  // The holes are there: straight down through the occluder, about half of the
  // rays that meet its quad reach the floor.
  const std::unique_ptr<HostSceneView> host = make_host_view(scene);
  const BvhView v = b.view();
  int floor = 0, occluder = 0;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      const Vec3 o(-0.95f + 1.9f * (i + 0.5f) / 40.f, 3.f, -0.95f + 1.9f * (j + 0.5f) / 40.f);
      const Ray r(o, Vec3(0, -1, 0));
      HitRecord h;
      ASSERT_TRUE(bvh_intersect(v, &host->view, r, kInf, &h));
      (h.instance == 0 ? floor : occluder) += 1;
    }
  EXPECT_GT(floor, 1600 / 8);
  EXPECT_GT(occluder, 1600 / 8);
}

// The kernels' forms: flat where the scene is, if-if where rays are long, the FMA box test for shadow rays; the
// tuning (--tune cuda_loop, cuda_box, cuda_flat) overrides each, and the reason says so.
TEST(CudaTraversal, TraceFormsFollowTheScene) {
  const GpuTuning defaults;
  CudaTraceForms f = choose_trace_forms(true, 46.4, defaults);
  EXPECT_EQ(f.closest, kBvhFlat | kBvhIfIf);
  EXPECT_EQ(f.shadow, kBvhFlat | kBvhIfIf | kBvhFmaBox);
  EXPECT_EQ(f.reason, "if-if loop (auto: rays visit 46.4 nodes, at least 24), flat scene, FMA box test for shadow rays");
  f = choose_trace_forms(false, 9.4, defaults);
  EXPECT_EQ(f.closest, 0);
  EXPECT_EQ(f.shadow, 0);
  EXPECT_EQ(f.reason, "while-while loop (auto: rays visit 9.4 nodes, under 24), general form, subtract-multiply box test");
  f = choose_trace_forms(true, 9.4, defaults);
  EXPECT_EQ(f.closest, kBvhFlat);
  EXPECT_EQ(f.shadow, kBvhFlat | kBvhFmaBox);
  EXPECT_EQ(choose_trace_forms(true, kIfIfMinVisits, defaults).closest & kBvhIfIf, kBvhIfIf);

  const GpuTuning general = parse_gpu_tuning({"cuda_loop=while", "cuda_box=slab", "cuda_flat=0"});
  f = choose_trace_forms(true, 46.4, general);
  EXPECT_EQ(f.closest, 0);
  EXPECT_EQ(f.shadow, 0);
  EXPECT_EQ(f.reason, "while-while loop (cuda_loop=while), general form (cuda_flat=false), subtract-multiply box test "
                      "(cuda_box=slab)");
  f = choose_trace_forms(false, 2.0, parse_gpu_tuning({"cuda_loop=ifif", "cuda_box=fma"}));
  EXPECT_EQ(f.closest, kBvhIfIf | kBvhFmaBox);
  EXPECT_EQ(f.shadow, kBvhIfIf | kBvhFmaBox);
}

// The build's measurement knobs reach the build: leaves of at most cuda_leaf references.
TEST(CudaTraversal, BuildKnobsReachTheBuild) {
  const GpuTuning t = parse_gpu_tuning({"cuda_leaf=2", "cuda_sah_tri=2.5", "cuda_splits=false"});
  EXPECT_EQ(t.bvh.leaf_size, 2u);
  EXPECT_FLOAT_EQ(t.bvh.triangle_cost, 2.5f);
  EXPECT_FALSE(t.bvh.spatial_splits);
  const Scene scene = load_scene("cornell-quad", {});
  const BvhHost b = build_bvh(scene, t.bvh);
  int leaves = 0;
  for (const BvhNode& n : b.nodes)
    for (int32_t c : n.child)
      if (c < 0 && c != kBvhPop) {
        EXPECT_LE(bvh_leaf_count(c), 2u);
        ++leaves;
      }
  EXPECT_GT(leaves, 0);
}

TEST(CudaTraversal, EmptySceneMissesEverything) {
  Scene scene;
  const BvhHost b = build_bvh(scene);
  HitRecord h;
  EXPECT_FALSE(bvh_intersect(b.view(), nullptr, Ray(Vec3(0.f), Vec3(0, 0, 1)), kInf, &h));
  EXPECT_FALSE(bvh_occluded(b.view(), nullptr, Ray(Vec3(0.f), Vec3(0, 0, 1)), kInf));
}

}  // namespace
}  // namespace pn
