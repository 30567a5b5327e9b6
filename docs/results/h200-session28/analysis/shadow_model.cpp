// A model of the cuda traversal's SIMD efficiency on shadow rays (session 28; session 27's simd_model.cpp
// for closest hits). The shadow queries of the camera rays' hits and of the first bounce's, in the order the
// wavefront queues them (pixel order), are traced by bvh_traverse.h's any-hit loop with a recorder of its steps,
// forward (from the shading point to the light, as the core makes them) and reversed (from the light's end of
// the segment back to the shading point: the same segment). Warps of 32 consecutive rays then run in lock step:
// an iteration costs its slowest lane's node visits and its slowest lane's leaf work. Printed: the efficiency
// (the lanes' own work / 32 x the warp's) and the work issued per ray (instructions, model), the cost.
//
// From a CPU build folder `build` (cmake -S . -B build -DPENUMBRA_OPTIX=OFF; cmake --build build):
//   c++ -std=c++17 -O2 -Isrc docs/results/h200-session28/analysis/shadow_model.cpp build/libpenumbra_lib.a \
//     -ljpeg -lstb -lembree3 -ltinyexr -ltinyobjloader -ltbb -lpthread -o shadow_model
//   PENUMBRA_SCENES=../shared/scenes ./shadow_model sponza 480 270
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "backends/cuda/bvh_build.h"
#include "backends/cuda/bvh_traverse.h"
#include "core/integrator.h"
#include "scene/scene.h"

using namespace pn;

struct Step {
  uint16_t inner = 0, leaf = 0;
};

struct StepRecorder {
  mutable std::vector<Step>* steps;
  mutable uint16_t inner = 0;
  void node() const { ++inner; }
  void leaf(uint32_t n) const {
    steps->push_back(Step{inner, uint16_t(n)});
    inner = 0;
  }
};

constexpr double kNode = 55, kTri = 40;

double lane_work(const std::vector<Step>& s) {
  double w = 0;
  for (const Step& x : s) w += kNode * x.inner + kTri * x.leaf;
  return w;
}

struct Eff {
  double efficiency, issued_per_ray, own_per_ray;
};

Eff while_while(const std::vector<std::vector<Step>>& steps, const std::vector<uint32_t>& order) {
  double useful = 0, issued = 0;
  for (size_t w = 0; w < order.size(); w += 32) {
    const size_t end = std::min(order.size(), w + 32);
    size_t iters = 0;
    for (size_t l = w; l < end; ++l) iters = std::max(iters, steps[order[l]].size());
    for (size_t k = 0; k < iters; ++k) {
      uint16_t mi = 0, ml = 0;
      for (size_t l = w; l < end; ++l) {
        const auto& s = steps[order[l]];
        if (k < s.size()) mi = std::max(mi, s[k].inner), ml = std::max(ml, s[k].leaf);
      }
      issued += kNode * mi + kTri * ml;
    }
    for (size_t l = w; l < end; ++l) useful += lane_work(steps[order[l]]);
  }
  const double n = double(order.size());
  return {useful / (32.0 * issued), 32.0 * issued / n, useful / n};
}

Eff if_if(const std::vector<std::vector<Step>>& steps, const std::vector<uint32_t>& order) {
  double useful = 0, issued = 0;
  for (size_t w = 0; w < order.size(); w += 32) {
    const size_t end = std::min(order.size(), w + 32);
    std::vector<std::vector<uint8_t>> ops(end - w);
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
  const double n = double(order.size());
  return {useful / (32.0 * issued), 32.0 * issued / n, useful / n};
}

// The direction as a point on an octahedron, 2^bits cells a side.
uint32_t dir_cell(Vec3 d, int bits) {
  const float a = std::fabs(d.x) + std::fabs(d.y) + std::fabs(d.z);
  float u = d.x / a, v = d.y / a;
  if (d.z < 0) {
    const float uu = (1 - std::fabs(v)) * (u < 0 ? -1 : 1);
    v = (1 - std::fabs(u)) * (v < 0 ? -1 : 1);
    u = uu;
  }
  const uint32_t m = (1u << bits) - 1u;
  return uint32_t((u * 0.5f + 0.5f) * m) << bits | uint32_t((v * 0.5f + 0.5f) * m);
}

struct Query {
  Ray ray;
  float tmax;
};

int main(int argc, char** argv) {
  const std::string name = argc > 1 ? argv[1] : "sponza";
  const int W = argc > 2 ? std::atoi(argv[2]) : 480, H = argc > 3 ? std::atoi(argv[3]) : 270;
  const std::string strategy = argc > 4 ? argv[4] : "solid-angle";
  const Scene scene = load_scene(name, {"render.width=" + std::to_string(W), "render.height=" + std::to_string(H),
                                        "render.strategy=" + strategy, "render.mis=none"});
  const auto host = make_host_view(scene);
  const BvhHost b = build_bvh(scene);
  const BvhView bvh = b.view();
  const Camera camera = scene.make_camera();
  const IntegratorSettings s = scene.integrator();
  std::vector<Query> queries[2];
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      PathState st = start_path(camera, x, y, 0, 5);
      for (int depth = 0; depth < 2 && st.active; ++depth) {
        HitRecord rec;
        if (!bvh_trace<false>(bvh, &host->view, st.ray, kInf, &rec)) break;
        const ShadowQuery q = on_hit(st, host->view, s, rec);
        if (q.kind != ShadowKind::None) queries[depth].push_back(Query{q.ray, q.tmax});
      }
    }
  for (int depth = 0; depth < 2; ++depth) {
    const auto& Q = queries[depth];
    const size_t n = Q.size();
    std::vector<std::vector<Step>> fwd(n), rev(n);
    size_t blocked = 0, disagree = 0;
    for (size_t i = 0; i < n; ++i) {
      HitRecord h;
      StepRecorder rf{&fwd[i]}, rr{&rev[i]};
      const bool bf = bvh_trace<true>(bvh, &host->view, Q[i].ray, Q[i].tmax, &h, rf);
      // Reversed: from the light's end back toward the shading point, stopping a little short of it (the origin
      // rebuilt from the far end carries rounding; what a GPU version would have to allow for).
      const Vec3 far = Q[i].ray.o + Q[i].ray.d * Q[i].tmax;
      auto amax = [](Vec3 v) { return std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)}); };
      const float slack = 1e-5f * (amax(Q[i].ray.o) + amax(far) + Q[i].tmax);
      const bool br = bvh_trace<true>(bvh, &host->view, Ray(far, -Q[i].ray.d), Q[i].tmax - slack, &h, rr);
      blocked += bf;
      disagree += bf != br;
    }
    std::vector<uint32_t> queue(n);
    std::iota(queue.begin(), queue.end(), 0u);
    auto sorted = [&](auto key) {
      std::vector<uint32_t> o = queue;
      std::stable_sort(o.begin(), o.end(), [&](uint32_t a, uint32_t c) { return key(a) < key(c); });
      return o;
    };
    std::vector<uint32_t> shuffled = queue;
    std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(3));
    std::printf("%s %dx%d %s, shadow rays of depth %d: %zu, %.1f%% blocked, forward and reversed disagree on %zu\n",
                name.c_str(), W, H, strategy.c_str(), depth, n, 100.0 * double(blocked) / double(n), disagree);
    std::printf("  %-52s %10s %14s %12s\n", "", "efficiency", "issued a ray", "own a ray");
    auto row = [&](const char* what, Eff e) {
      std::printf("  %-52s %9.1f%% %14.0f %12.0f\n", what, 100 * e.efficiency, e.issued_per_ray, e.own_per_ray);
    };
    row("forward, queue order", while_while(fwd, queue));
    row("forward, random order", while_while(fwd, shuffled));
    row("forward, queue order, if-if", if_if(fwd, queue));
    row("reversed, queue order", while_while(rev, queue));
    row("reversed, queue order, if-if", if_if(rev, queue));
    for (int bits : {3, 5, 7, 9}) {
      char label[96];
      const auto by_dir = sorted([&](uint32_t i) { return dir_cell(Q[i].ray.d, bits); });
      std::snprintf(label, sizeof label, "forward, by direction (%dx%d octahedral cells)", 1 << bits, 1 << bits);
      row(label, while_while(fwd, by_dir));
      std::snprintf(label, sizeof label, "reversed, by direction (%dx%d cells)", 1 << bits, 1 << bits);
      row(label, while_while(rev, by_dir));
      std::snprintf(label, sizeof label, "reversed, by direction (%dx%d cells), if-if", 1 << bits, 1 << bits);
      row(label, if_if(rev, by_dir));
    }
  }
  return 0;
}
