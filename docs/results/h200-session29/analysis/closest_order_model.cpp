// A model of the cuda traversal's SIMD efficiency on the closest-hit rays of the bounces, by the order they are
// traced in (session 29; session 27's simd_model.cpp, whose lock-step functions this copies, did the first bounce
// at 480 x 270). Every pixel's path is followed through bvh_traverse.h's closest-hit loop with a recorder of its
// steps; the rays of each depth, in the order the wavefront queues them (pixel order of the paths still going), then
// sorted by several keys: the direction's octahedral cell, the origin's Morton cell in the scene's box, or both.
// Warps of 32 consecutive rays run in lock step: an iteration costs its slowest lane's node visits and leaf work.
// Printed per order: the work issued per ray (model instructions), its change from queue order, the efficiency.
//
// From a CPU build folder `build` (cmake -S . -B build -DPENUMBRA_OPTIX=OFF; cmake --build build):
//   c++ -std=c++17 -O2 -Isrc docs/results/h200-session29/analysis/closest_order_model.cpp build/libpenumbra_lib.a \
//     -ljpeg -lstb -lembree3 -ltinyexr -ltinyobjloader -ltbb -lpthread -o closest_order_model
//   PENUMBRA_SCENES=../shared/scenes ./closest_order_model sponza 1920 1080 2
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "backends/cuda/bvh_build.h"
#include "backends/cuda/bvh_traverse.h"
#include "core/integrator.h"
#include "backends/probe_rays.h"
#include "scene/scene.h"

using namespace pn;

struct Step {
  uint16_t inner = 0, leaf = 0;  // node visits (two boxes each) before the leaf; triangles (or one item) at it
};

// bvh_traverse.h's closest-hit loop itself, its steps recorded (BvhNoSteps' interface).
struct StepRecorder {
  mutable std::vector<Step>* steps;
  mutable uint16_t inner = 0;
  void node() const { ++inner; }
  void leaf(uint32_t n) const {
    steps->push_back(Step{inner, uint16_t(n)});
    inner = 0;
  }
};

std::vector<Step> traced_steps(const BvhView& bvh, const SceneView& scene, const Ray& ray, HitRecord* out) {
  std::vector<Step> steps;
  if (!bvh_trace<false>(bvh, &scene, ray, kInf, out, StepRecorder{&steps})) out->t = kInf;
  return steps;
}

constexpr double kNode = 55, kTri = 40;  // instructions a node visit / a triangle (or item), roughly (PTX)

double lane_work(const std::vector<Step>& s) {
  double w = 0;
  for (const Step& x : s) w += kNode * x.inner + kTri * x.leaf;
  return w;
}

// Efficiency of warps of 32 over `order`.
double efficiency(const std::vector<std::vector<Step>>& steps, const std::vector<uint32_t>& order) {
  double useful = 0, issued = 0;
  for (size_t w = 0; w < order.size(); w += 32) {
    size_t iters = 0;
    for (size_t l = w; l < std::min(order.size(), w + 32); ++l) iters = std::max(iters, steps[order[l]].size());
    for (size_t k = 0; k < iters; ++k) {
      uint16_t mi = 0, ml = 0;
      for (size_t l = w; l < std::min(order.size(), w + 32); ++l) {
        const auto& s = steps[order[l]];
        if (k < s.size()) mi = std::max(mi, s[k].inner), ml = std::max(ml, s[k].leaf);
      }
      issued += kNode * mi + kTri * ml;
    }
    for (size_t l = w; l < std::min(order.size(), w + 32); ++l) useful += lane_work(steps[order[l]]);
  }
  return useful / (32.0 * issued);
}

// The same warps with dynamic fetch (Aila and Laine's persistent threads): a lane whose ray ends takes the next
// ray of `order` at the next iteration, so that no lane idles until the queue runs dry; each iteration still costs
// its slowest lane's inner visits and leaf work.
double efficiency_fetch(const std::vector<std::vector<Step>>& steps, const std::vector<uint32_t>& order) {
  double useful = 0, issued = 0;
  size_t next = 0;
  uint32_t ray[32];
  size_t pos[32];
  bool busy[32];
  for (int l = 0; l < 32; ++l) busy[l] = false;
  for (;;) {
    bool any = false;
    uint16_t mi = 0, ml = 0;
    for (int l = 0; l < 32; ++l) {
      if (!busy[l] && next < order.size()) ray[l] = order[next++], pos[l] = 0, busy[l] = true;
      if (!busy[l]) continue;
      any = true;
      const Step& x = steps[ray[l]][pos[l]];
      mi = std::max(mi, x.inner), ml = std::max(ml, x.leaf);
      useful += kNode * x.inner + kTri * x.leaf;
      if (++pos[l] == steps[ray[l]].size()) busy[l] = false;
    }
    if (!any) break;
    issued += kNode * mi + kTri * ml;
  }
  return useful / (32.0 * issued);
}

// The same warps with Aila and Laine's if-if loop: an iteration is one node visit or one triangle for each lane;
// it costs a node visit if some lane visits a node and a triangle if some lane tests one.
double efficiency_if_if(const std::vector<std::vector<Step>>& steps, const std::vector<uint32_t>& order) {
  double useful = 0, issued = 0;
  for (size_t w = 0; w < order.size(); w += 32) {
    const size_t end = std::min(order.size(), w + 32);
    std::vector<std::vector<uint8_t>> ops(end - w);  // 0 node, 1 triangle, in order
    size_t longest = 0;
    for (size_t l = w; l < end; ++l) {
      for (const Step& x : steps[order[l]]) {
        ops[l - w].insert(ops[l - w].end(), x.inner, uint8_t(0));
        ops[l - w].insert(ops[l - w].end(), x.leaf, uint8_t(1));
      }
      longest = std::max(longest, ops[l - w].size());
      useful += lane_work(steps[order[l]]);
    }
    for (size_t k = 0; k < longest; ++k) {
      bool node = false, tri = false;
      for (const auto& o : ops)
        if (k < o.size()) (o[k] ? tri : node) = true;
      issued += (node ? kNode : 0) + (tri ? kTri : 0);
    }
  }
  return useful / (32.0 * issued);
}

uint32_t spread10(uint32_t v) {  // 10 bits to every third of 30
  v &= 1023u;
  v = (v | (v << 16)) & 0x030000FFu;
  v = (v | (v << 8)) & 0x0300F00Fu;
  v = (v | (v << 4)) & 0x030C30C3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}


// Issued work per ray (model instructions, warps of 32 in lock step) for an order.
double issued(const std::vector<std::vector<Step>>& steps, const std::vector<uint32_t>& order) {
  const double e = efficiency(steps, order);
  double w = 0;
  for (uint32_t i : order) w += lane_work(steps[i]);
  return w / e / double(order.size());
}

int main(int argc, char** argv) {
  const std::string name = argc > 1 ? argv[1] : "sponza";
  const int W = argc > 2 ? std::atoi(argv[2]) : 1920, H = argc > 3 ? std::atoi(argv[3]) : 1080;
  const int depths = argc > 4 ? std::atoi(argv[4]) : 3;
  const Scene scene = load_scene(name, {"render.width=" + std::to_string(W), "render.height=" + std::to_string(H),
                                        "render.strategy=solid-angle", "render.mis=none"});
  const auto host = make_host_view(scene);
  const BvhHost b = build_bvh(scene);
  const BvhView bvh = b.view();
  const Camera camera = scene.make_camera();
  const IntegratorSettings s = scene.integrator();
  std::vector<PathState> paths;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) paths.push_back(start_path(camera, x, y, 0, 5));
  const Bounds3 sb = scene_bounds(scene);
  const Vec3 lo = sb.lo, ext = sb.hi - sb.lo;
  for (int depth = 0; depth <= depths; ++depth) {
    std::vector<Ray> R;
    std::vector<std::vector<Step>> S;
    std::vector<uint32_t> prim;
    std::vector<PathState> next;
    R.reserve(paths.size());
    S.reserve(paths.size());
    for (PathState& st : paths) {
      HitRecord rec;
      R.push_back(st.ray);
      S.push_back(traced_steps(bvh, host->view, st.ray, &rec));
      prim.push_back(rec.t < kInf ? rec.prim : ~0u);
      if (!(rec.t < kInf)) continue;
      on_hit(st, host->view, s, rec);
      if (st.active) next.push_back(st);
    }
    paths.swap(next);
    if (depth == 0) continue;
    const size_t n = R.size();
    std::vector<uint32_t> queue(n);
    std::iota(queue.begin(), queue.end(), 0u);
    auto sorted = [&](auto key) {
      std::vector<uint32_t> o = queue;
      std::stable_sort(o.begin(), o.end(), [&](uint32_t a, uint32_t c) { return key(a) < key(c); });
      return o;
    };
    auto morton = [&](uint32_t i, int bits) {
      const Vec3 q0 = R[i].o - lo, p(q0.x / ext.x, q0.y / ext.y, q0.z / ext.z);
      const uint32_t m = (1u << bits) - 1u;
      auto q = [&](float v) { return uint32_t(std::clamp(v, 0.f, 1.f) * float(m) + 0.5f); };
      return (spread10(q(p.x)) | spread10(q(p.y)) << 1 | spread10(q(p.z)) << 2);
    };
    auto dir_cell = [&](uint32_t i, int bits) {
      const Vec3 d = R[i].d;
      const float a = std::fabs(d.x) + std::fabs(d.y) + std::fabs(d.z);
      float u = d.x / a, v = d.y / a;
      if (d.z < 0) { const float uu = (1 - std::fabs(v)) * (u < 0 ? -1 : 1); v = (1 - std::fabs(u)) * (v < 0 ? -1 : 1); u = uu; }
      const uint32_t m = (1u << bits);
      auto q = [&](float t) { return std::min(m - 1u, uint32_t((t * 0.5f + 0.5f) * float(m))); };
      return q(u) << bits | q(v);
    };
    const double base = issued(S, queue);
    std::printf("%s %dx%d, closest rays of depth %d: %zu rays, queue order: %.0f issued a ray (model), efficiency %.1f%%\n",
                name.c_str(), W, H, depth, n, base, 100 * efficiency(S, queue));
    auto row = [&](const char* what, const std::vector<uint32_t>& o) {
      const double x = issued(S, o);
      std::printf("  %-52s %6.0f  %+6.1f%%  eff %.1f%%\n", what, x, 100 * (x / base - 1), 100 * efficiency(S, o));
    };
    char buf[128];
    for (int db = 2; db <= 6; ++db) {
      std::snprintf(buf, sizeof buf, "direction %dx%d", 1 << db, 1 << db);
      row(buf, sorted([&](uint32_t i) { return dir_cell(i, db); }));
    }
    for (int mb = 2; mb <= 6; ++mb) {
      std::snprintf(buf, sizeof buf, "origin Morton %d a side", 1 << mb);
      row(buf, sorted([&](uint32_t i) { return morton(i, mb); }));
    }
    for (int db : {2, 3, 4})
      for (int mb : {2, 3, 4, 5}) {
        std::snprintf(buf, sizeof buf, "direction %dx%d, then origin %d a side (%d cells)", 1 << db, 1 << db, 1 << mb,
                      1 << (2 * db + 3 * mb));
        row(buf, sorted([&](uint32_t i) { return uint64_t(dir_cell(i, db)) << 30 | morton(i, mb); }));
        std::snprintf(buf, sizeof buf, "origin %d a side, then direction %dx%d", 1 << mb, 1 << db, 1 << db);
        row(buf, sorted([&](uint32_t i) { return uint64_t(morton(i, mb)) << 20 | dir_cell(i, db); }));
      }
    row("oracle: by the primitive hit", sorted([&](uint32_t i) { return prim[i]; }));
    std::fflush(stdout);
  }
  return 0;
}
