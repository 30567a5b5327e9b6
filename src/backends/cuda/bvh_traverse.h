// The cuda traversal: closest hit and any hit over bvh_layout.h's two-level BVH,
// host and device code (the CPU tests check it against Embree; the GPU's
// trace kernels run it one ray per thread).
//
// One loop for both levels (a stack of child references, nearer child first):
// a top-level leaf holds one item, a sphere (the core's intersect_sphere on the
// world ray) or an instance, which is entered by moving the ray into its object
// space and continuing at its mesh's root; when the stack is popped back to the
// depth at which the instance was entered, the ray returns to world space.
// Object-space directions are not renormalised, so t is the world ray's at both
// levels, as with Embree and OptiX instances.
//
// Triangles: the core's watertight test (core/geometry.h), as Embree's robust
// mode. Alpha-masked triangles are skipped where the core's alpha_discards says
// so, as the CPU backend's Embree filters and OptiX's any-hit program do.
// Boxes: slab test with t_far widened by 1 + 2 gamma(3) (Ize, "Robust BVH Ray
// Traversal", JCGT 2(2), 2013), so that rounding never culls a box the ray meets.
#pragma once

#include <cstdint>

#include "backends/cuda/bvh_layout.h"
#include "core/geometry.h"
#include "core/scene_view.h"

namespace pn {

// A ray in one space (world, or an instance's object space): what box and
// triangle tests need.
struct BvhRay {
  Vec3 o;
  Vec3 inv_d;  // 1 / d, a zero component replaced by a tiny one of its sign
  // The one-FMA box test's terms (kBvhFmaBox): a plane b is at t = fma(b, inv_d, -o_inv), which may be off by
  // up to `slack` beyond Ize's relative bound (make_bvh_ray).
  Vec3 o_inv;
  float slack;
  WatertightRay tri;
};

// A zero component's inverse is a power of two (2^100), so that o inv is exact for it.
PN_FN float bvh_safe_inverse(float x) {
  constexpr float kTiny = 0x1p-100f;
  return 1.f / (std::fabs(x) > kTiny ? x : std::copysign(kTiny, x));
}

PN_FN float bvh_fma(float a, float b, float c) {
#if defined(__CUDA_ARCH__)
  return __fmaf_rn(a, b, c);
#else
  return std::fma(a, b, c);
#endif
}

// o_inv = o inv - e, e exactly fma(o, inv, -o_inv); then fma(b, inv, -o_inv) = ((b - o) inv + e)(1 + d): beyond
// Ize's relative bound an absolute error |e| (1 + u) on each plane, which the box test allows 4 max |e| for.
PN_FN BvhRay make_bvh_ray(Vec3 o, Vec3 d) {
  BvhRay r;
  r.o = o;
  r.inv_d = Vec3(bvh_safe_inverse(d.x), bvh_safe_inverse(d.y), bvh_safe_inverse(d.z));
  r.o_inv = Vec3(o.x * r.inv_d.x, o.y * r.inv_d.y, o.z * r.inv_d.z);
  const float ex = std::fabs(bvh_fma(o.x, r.inv_d.x, -r.o_inv.x));
  const float ey = std::fabs(bvh_fma(o.y, r.inv_d.y, -r.o_inv.y));
  const float ez = std::fabs(bvh_fma(o.z, r.inv_d.z, -r.o_inv.z));
  r.slack = 4.f * pn_max(ex, pn_max(ey, ez));
  r.tri = make_watertight_ray(Ray(o, d));
  return r;
}

// A plane's distance along the ray: (b - o) / d as a subtraction and a product, or (kFma) one FMA.
template <bool kFma>
PN_FN float bvh_plane_t(float b, float o, float inv, float o_inv) {
  if (kFma) return bvh_fma(b, inv, -o_inv);
  return (b - o) * inv;
}

// Entry and exit distances of a box; the box is met when t_near <= t_far. kFma: the planes by one FMA each
// (Aila and Laine's form), the exit widened by the ray's slack besides.
template <bool kFma = false>
PN_FN bool bvh_box_hit(const float* xy, float zlo, float zhi, const BvhRay& r, float tmax, float* t_near) {
  constexpr float kWiden = 1.f + 2.f * 3.58e-7f;  // 1 + 2 gamma(3), gamma(n) = n u / (1 - n u), u = 2^-24
  const float x0 = bvh_plane_t<kFma>(xy[0], r.o.x, r.inv_d.x, r.o_inv.x);
  const float x1 = bvh_plane_t<kFma>(xy[1], r.o.x, r.inv_d.x, r.o_inv.x);
  const float y0 = bvh_plane_t<kFma>(xy[2], r.o.y, r.inv_d.y, r.o_inv.y);
  const float y1 = bvh_plane_t<kFma>(xy[3], r.o.y, r.inv_d.y, r.o_inv.y);
  const float z0 = bvh_plane_t<kFma>(zlo, r.o.z, r.inv_d.z, r.o_inv.z);
  const float z1 = bvh_plane_t<kFma>(zhi, r.o.z, r.inv_d.z, r.o_inv.z);
#if defined(__CUDA_ARCH__)
  // Three-way integer max and min of the floats' bits, one instruction each on sm_90 (Aila and Laine's trick;
  // commit cf489d0: Sponza's random rays 10% faster). The entry distance is clamped at 0, so a value that wins the
  // max is non-negative and orders as its bits do; the exit distance's min may take -0.f over a negative value,
  // which enters a box the float min would cull, never the other way round.
  const float tn = __int_as_float(__vimax3_s32_relu(__float_as_int(pn_min(x0, x1)), __float_as_int(pn_min(y0, y1)),
                                                    __float_as_int(pn_min(z0, z1))));
  const float tf = pn_min(__int_as_float(__vimin3_s32(__float_as_int(pn_max(x0, x1)), __float_as_int(pn_max(y0, y1)),
                                                      __float_as_int(pn_max(z0, z1)))),
                          tmax);
#else
  const float tn = pn_max(pn_max(pn_min(x0, x1), pn_min(y0, y1)), pn_max(pn_min(z0, z1), 0.f));
  const float tf = pn_min(pn_min(pn_max(x0, x1), pn_max(y0, y1)), pn_min(pn_max(z0, z1), tmax));
#endif
  *t_near = tn;
  if (kFma) return tn <= bvh_fma(tf, kWiden, r.slack);
  return tn <= tf * kWiden;
}

PN_FN BvhNode bvh_load_node(const BvhNode* nodes, int32_t i) {
#if defined(__CUDA_ARCH__)
  const float4* p = reinterpret_cast<const float4*>(nodes + i);
  const float4 a = __ldg(p), b = __ldg(p + 1), c = __ldg(p + 2);
  const int4 d = __ldg(reinterpret_cast<const int4*>(p + 3));
  BvhNode n;
  n.c0[0] = a.x, n.c0[1] = a.y, n.c0[2] = a.z, n.c0[3] = a.w;
  n.c1[0] = b.x, n.c1[1] = b.y, n.c1[2] = b.z, n.c1[3] = b.w;
  n.z[0] = c.x, n.z[1] = c.y, n.z[2] = c.z, n.z[3] = c.w;
  n.child[0] = d.x, n.child[1] = d.y;
  return n;
#else
  return nodes[i];
#endif
}

PN_FN void bvh_load_triangle(const BvhTriangle* tris, uint32_t i, Vec3* p0, Vec3* p1, Vec3* p2, uint32_t* prim) {
#if defined(__CUDA_ARCH__)
  const float4* p = reinterpret_cast<const float4*>(tris + i);
  const float4 a = __ldg(p), b = __ldg(p + 1), c = __ldg(p + 2);
  *p0 = Vec3(a.x, a.y, a.z);
  *prim = __float_as_uint(a.w);
  *p1 = Vec3(b.x, b.y, b.z);
  *p2 = Vec3(c.x, c.y, c.z);
#else
  const BvhTriangle& t = tris[i];
  *p0 = Vec3(t.p0[0], t.p0[1], t.p0[2]);
  *prim = t.prim;
  *p1 = Vec3(t.p1[0], t.p1[1], t.p1[2]);
  *p2 = Vec3(t.p2[0], t.p2[1], t.p2[2]);
#endif
}

// What a traversal does, step by step, for models of it (commit 45fdde8's docs/results, in git history): node() at each
// inner node visited, leaf(n) at the end of each pass of the loop below (n: the triangles tested there, 1 for a
// top-level item, 0 where the pass found no leaf). The default does nothing and compiles to nothing.
struct BvhNoSteps {
  PN_FN void node() const {}
  PN_FN void leaf(uint32_t) const {}
};

// The traversal's forms, fixed at compile time (a bit set, the kernels' template argument):
//   kBvhFlat: the scene is flat (BvhView::flat: no alpha masks, every instance the identity), so the ray never
//     leaves world space and the code for the rest is not compiled in: fewer registers live.
//   kBvhFmaBox: the box test's planes by one FMA each (bvh_box_hit).
//   kBvhIfIf: one step an iteration, a node or one triangle (Aila and Laine's if-if loop), instead of nodes
//     until a leaf and then the leaf's triangles (while-while); a warp's lanes wait for each other one step at
//     a time.
constexpr int kBvhAnyScene = 0;
constexpr int kBvhFlat = 1;
constexpr int kBvhIfIf = 2;
constexpr int kBvhFmaBox = 4;

// Closest hit (kAnyHit false: *hit gets the nearest hit in (0, tmax)) or any hit
// (kAnyHit true: returns at the first hit in (0, tmax), *hit is that one). `scene`
// is read only for alpha masks (bvh.any_alpha_masked) and may be null otherwise.
// kForm: kBvhFlat | kBvhIfIf | kBvhFmaBox (above); kBvhFlat only where bvh.flat.
template <bool kAnyHit, int kForm = kBvhAnyScene, class Steps = BvhNoSteps>
PN_FN bool bvh_trace(const BvhView& bvh, const SceneView* scene, const Ray& ray, float tmax, HitRecord* hit,
                     const Steps& steps = Steps()) {
  constexpr bool kFlat = (kForm & kBvhFlat) != 0;
  constexpr bool kIfIf = (kForm & kBvhIfIf) != 0;
  constexpr bool kFma = (kForm & kBvhFmaBox) != 0;
  if (bvh.num_items == 0) return false;
  int32_t stack[kBvhStackSize];
  int sp = 0;
  int inst_sp = -1;   // stack depth at which the current instance was entered; -1: top level
  uint32_t inst = 0;  // the current instance (index into bvh.instances) when inst_sp >= 0
  bool moved = false;  // the current instance moved the ray to its object space (it is not the identity)
  BvhRay r = make_bvh_ray(ray.o, ray.d);
  HitRecord best;
  best.t = tmax;
  bool found = false;
  int32_t ref = bvh.root;
  uint32_t tri = 0, tri_end = 0;  // if-if: the current leaf's triangles still to test
  // Triangle i of the current instance's mesh: true where it is hit nearer than the best so far, which it becomes.
  auto triangle = [&](uint32_t i) {
    Vec3 p0, p1, p2;
    uint32_t prim;
    bvh_load_triangle(bvh.triangles, i, &p0, &p1, &p2, &prim);
    float t, b1, b2;
    if (!intersect_triangle(r.tri, p0, p1, p2, 0.f, best.t, &t, &b1, &b2)) return false;
    if (!kFlat && bvh.any_alpha_masked) {
      const BvhInstance& bi = bvh.instances[inst];
      if (bi.alpha_masked && alpha_discards(*scene, scene->instances[bi.instance], prim, b1, b2)) return false;
    }
    best.t = t;
    best.instance = bvh.instances[inst].instance;
    best.prim = prim;
    best.b1 = b1;
    best.b2 = b2;
    found = true;
    return true;
  };
  for (;;) {
    if (kIfIf && tri < tri_end) {  // if-if: one triangle of the current leaf
      if (triangle(tri++) && kAnyHit) break;
      if (tri < tri_end) continue;
      ref = kBvhPop;  // the leaf is done
    } else {
      // Inner nodes: on to the nearer child the ray meets, the other onto the stack; until a leaf (while-while)
      // or one node (if-if).
      while (ref >= 0) {
        steps.node();
        const BvhNode n = bvh_load_node(bvh.nodes, ref);
        float t0, t1;
        const bool h0 = bvh_box_hit<kFma>(n.c0, n.z[0], n.z[1], r, best.t, &t0);
        const bool h1 = bvh_box_hit<kFma>(n.c1, n.z[2], n.z[3], r, best.t, &t1);
        if (h0 && h1) {
          const bool far0 = t1 < t0;
          ref = far0 ? n.child[1] : n.child[0];
          stack[sp++] = far0 ? n.child[0] : n.child[1];
        } else {
          ref = h0 ? n.child[0] : (h1 ? n.child[1] : kBvhPop);
        }
        if (kIfIf) break;
      }
      if (kIfIf && ref >= 0) continue;
      if (ref == kBvhPop) steps.leaf(0);
      if (ref != kBvhPop) {
        const uint32_t first = bvh_leaf_first(ref);
        if (inst_sp < 0) {  // a top-level item
          steps.leaf(1);
          const uint32_t item = bvh.items[first];
          if (item & kBvhItemSphere) {
            const uint32_t s = item & ~kBvhItemSphere;
            const float* c = bvh.spheres + 4 * s;
            float t;
            if (intersect_sphere(ray, Vec3(c[0], c[1], c[2]), c[3], 0.f, best.t, &t)) {
              best.t = t;
              best.instance = kSphereInstance;
              best.prim = s;
              best.b1 = best.b2 = 0.f;
              found = true;
              if (kAnyHit) break;
            }
          } else {  // enter the instance
            const BvhInstance& bi = bvh.instances[item];
            inst = item;
            inst_sp = sp;
            if (!kFlat) {
              moved = bi.identity == 0;
              if (moved) r = make_bvh_ray(bi.to_object.point(ray.o), bi.to_object.vector(ray.d));
            }
            ref = bi.root;
            continue;
          }
        } else {  // triangles of the current instance's mesh
          const uint32_t count = bvh_leaf_count(ref);
          steps.leaf(count);
          if (kIfIf) {  // one an iteration, from the next on
            tri = first;
            tri_end = first + count;
            continue;
          }
          bool stop = false;
          for (uint32_t i = 0; i < count; ++i) {
            if (triangle(first + i) && kAnyHit) {
              stop = true;
              break;
            }
          }
          if (stop) break;
        }
      }
    }
    // Next entry; leave the instance once its subtree is done (the world ray back only if the instance moved
    // it and entries are left: its divisions were a visible share of a short traversal).
    if (sp == inst_sp) {
      inst_sp = -1;
      if (!kFlat && moved && sp > 0) r = make_bvh_ray(ray.o, ray.d);
    }
    if (sp == 0) break;
    ref = stack[--sp];
  }
  if (found) *hit = best;
  return found;
}

PN_FN bool bvh_intersect(const BvhView& bvh, const SceneView* scene, const Ray& ray, float tmax, HitRecord* hit) {
  return bvh_trace<false>(bvh, scene, ray, tmax, hit);
}

PN_FN bool bvh_occluded(const BvhView& bvh, const SceneView* scene, const Ray& ray, float tmax) {
  HitRecord unused;
  return bvh_trace<true>(bvh, scene, ray, tmax, &unused);
}

}  // namespace pn
