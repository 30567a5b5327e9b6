// A model of the cuda traversal's SIMD efficiency (not built by CMake; session 27's analysis, see README.md).
// The first BSDF bounce's rays of a scene, in the order the wavefront queues them (pixel order), are traced by
// bvh_traverse.h's closest-hit loop with a recorder of its steps (BvhNoSteps): per ray, each outer iteration's
// inner-node visits and leaf work. Warps of 32 consecutive rays then run in lock step: an iteration costs its slowest lane's inner
// visits and its slowest lane's leaf work, lanes that are done idle. Efficiency = the lanes' own work / (32 x the
// warp's). Orders compared: the queue's, random, and sorted by several keys.
//
// From a CPU build folder `build` (cmake -S . -B build -DPENUMBRA_OPTIX=OFF; cmake --build build):
//   c++ -std=c++17 -O2 -Isrc docs/results/h200-session27/analysis/simd_model.cpp build/libpenumbra_lib.a \
//     -ljpeg -lstb -lembree3 -ltinyexr -ltinyobjloader -ltbb -lpthread -o simd_model
//   PENUMBRA_SCENES=../shared/scenes ./simd_model sponza 480 270
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

int main(int argc, char** argv) {
  const std::string name = argc > 1 ? argv[1] : "sponza";
  const int W = argc > 2 ? std::atoi(argv[2]) : 480, H = argc > 3 ? std::atoi(argv[3]) : 270;
  const Scene scene = load_scene(name, {"render.width=" + std::to_string(W), "render.height=" + std::to_string(H),
                                        "render.strategy=solid-angle", "render.mis=none"});
  const auto host = make_host_view(scene);
  const BvhHost b = build_bvh(scene);
  const BvhView bvh = b.view();
  const Camera camera = scene.make_camera();
  const IntegratorSettings s = scene.integrator();
  std::vector<Ray> rays[2];  // camera rays; the first bounce's, in pixel order (the wavefront's queue)
  std::vector<uint32_t> prim1;  // the first bounce's hit primitive (for the oracle order)
  std::vector<std::vector<Step>> steps[2];
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      PathState st = start_path(camera, x, y, 0, 5);
      HitRecord rec;
      rays[0].push_back(st.ray);
      steps[0].push_back(traced_steps(bvh, host->view, st.ray, &rec));
      if (!(rec.t < kInf)) continue;
      on_hit(st, host->view, s, rec);
      if (!st.active) continue;
      rays[1].push_back(st.ray);
      HitRecord h2;
      steps[1].push_back(traced_steps(bvh, host->view, st.ray, &h2));
      prim1.push_back(h2.t < kInf ? h2.prim : ~0u);
    }
  const Bounds3 sb = scene_bounds(scene);
  const Vec3 lo = sb.lo, ext = sb.hi - sb.lo;
  for (int bounce = 0; bounce < 2; ++bounce) {
    const auto& R = rays[bounce];
    const auto& S = steps[bounce];
    const size_t n = R.size();
    std::vector<uint32_t> queue(n);
    std::iota(queue.begin(), queue.end(), 0u);
    auto sorted = [&](auto key) {
      std::vector<uint32_t> o = queue;
      std::stable_sort(o.begin(), o.end(), [&](uint32_t a, uint32_t c) { return key(a) < key(c); });
      return o;
    };
    auto octant = [&](uint32_t i) { const Vec3 d = R[i].d; return uint32_t(d.x < 0) | uint32_t(d.y < 0) << 1 | uint32_t(d.z < 0) << 2; };
    auto morton = [&](uint32_t i, int bits) {
      const Vec3 q0 = R[i].o - lo, p(q0.x / ext.x, q0.y / ext.y, q0.z / ext.z);
      const uint32_t m = (1u << bits) - 1u;
      auto q = [&](float v) { return uint32_t(std::clamp(v, 0.f, 1.f) * float(m)); };
      return (spread10(q(p.x)) | spread10(q(p.y)) << 1 | spread10(q(p.z)) << 2);
    };
    // The direction as a point on an octahedron, quantized to 2^bits per axis.
    auto dir_cell = [&](uint32_t i, int bits) {
      const Vec3 d = R[i].d;
      const float a = std::fabs(d.x) + std::fabs(d.y) + std::fabs(d.z);
      float u = d.x / a, v = d.y / a;
      if (d.z < 0) { const float uu = (1 - std::fabs(v)) * (u < 0 ? -1 : 1); v = (1 - std::fabs(u)) * (v < 0 ? -1 : 1); u = uu; }
      const uint32_t m = (1u << bits) - 1u;
      return uint32_t((u * 0.5f + 0.5f) * m) << bits | uint32_t((v * 0.5f + 0.5f) * m);
    };
    std::vector<uint32_t> shuffled = queue;
    std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(3));
    double work = 0;
    for (const auto& x : S) work += lane_work(x);
    std::printf("%s %dx%d, %s: %zu rays, %.0f instructions a ray (model)\n", name.c_str(), W, H,
                bounce ? "first bounce" : "camera rays", n, work / double(n));
    std::printf("  %-58s %.1f%%\n", "queue order (pixels)", 100 * efficiency(S, queue));
    std::printf("  %-58s %.1f%%\n", "random", 100 * efficiency(S, shuffled));
    std::printf("  %-58s %.1f%%\n", "queue order, dynamic fetch (one warp, persistent)", 100 * efficiency_fetch(S, queue));
    std::printf("  %-58s %.1f%%\n", "queue order, if-if loop", 100 * efficiency_if_if(S, queue));
    if (!bounce) continue;
    std::printf("  %-58s %.1f%%\n", "by direction octant (session 25's sort)", 100 * efficiency(S, sorted(octant)));
    std::printf("  %-58s %.1f%%\n", "by direction, 8x8 octahedral cells",
                100 * efficiency(S, sorted([&](uint32_t i) { return dir_cell(i, 3); })));
    std::printf("  %-58s %.1f%%\n", "by direction, 32x32 cells",
                100 * efficiency(S, sorted([&](uint32_t i) { return dir_cell(i, 5); })));
    std::printf("  %-58s %.1f%%\n", "by origin (Morton, 2^5 a side), then octant",
                100 * efficiency(S, sorted([&](uint32_t i) { return uint64_t(morton(i, 5)) << 3 | octant(i); })));
    std::printf("  %-58s %.1f%%\n", "by octant, then origin (Morton, 2^5 a side)",
                100 * efficiency(S, sorted([&](uint32_t i) { return uint64_t(octant(i)) << 30 | morton(i, 5); })));
    std::printf("  %-58s %.1f%%\n", "by 8x8 direction cells, then origin (2^4 a side)",
                100 * efficiency(S, sorted([&](uint32_t i) { return uint64_t(dir_cell(i, 3)) << 30 | morton(i, 4); })));
    std::printf("  %-58s %.1f%%\n", "oracle: by the primitive the ray hits",
                100 * efficiency(S, sorted([&](uint32_t i) { return prim1[i]; })));
  }
  return 0;
}
