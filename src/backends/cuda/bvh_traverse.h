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
  WatertightRay tri;
};

PN_FN float bvh_safe_inverse(float x) {
  constexpr float kTiny = 1e-30f;
  return 1.f / (std::fabs(x) > kTiny ? x : std::copysign(kTiny, x));
}

PN_FN BvhRay make_bvh_ray(Vec3 o, Vec3 d) {
  BvhRay r;
  r.o = o;
  r.inv_d = Vec3(bvh_safe_inverse(d.x), bvh_safe_inverse(d.y), bvh_safe_inverse(d.z));
  r.tri = make_watertight_ray(Ray(o, d));
  return r;
}

// Entry and exit distances of a box; the box is met when t_near <= t_far.
PN_FN bool bvh_box_hit(const float* xy, float zlo, float zhi, const BvhRay& r, float tmax, float* t_near) {
  constexpr float kWiden = 1.f + 2.f * 3.58e-7f;  // 1 + 2 gamma(3), gamma(n) = n u / (1 - n u), u = 2^-24
  const float x0 = (xy[0] - r.o.x) * r.inv_d.x, x1 = (xy[1] - r.o.x) * r.inv_d.x;
  const float y0 = (xy[2] - r.o.y) * r.inv_d.y, y1 = (xy[3] - r.o.y) * r.inv_d.y;
  const float z0 = (zlo - r.o.z) * r.inv_d.z, z1 = (zhi - r.o.z) * r.inv_d.z;
#if defined(__CUDA_ARCH__)
  // Three-way integer max and min of the floats' bits, one instruction each on sm_90 (Aila and Laine's trick;
  // session 25: Sponza's random rays 10% faster). The entry distance is clamped at 0, so a value that wins the
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

// What a traversal does, step by step, for models of it (docs/results/h200-session27/analysis): node() at each
// inner node visited, leaf(n) at the end of each pass of the loop below (n: the triangles tested there, 1 for a
// top-level item, 0 where the pass found no leaf). The default does nothing and compiles to nothing.
struct BvhNoSteps {
  PN_FN void node() const {}
  PN_FN void leaf(uint32_t) const {}
};

// Closest hit (kAnyHit false: *hit gets the nearest hit in (0, tmax)) or any hit
// (kAnyHit true: returns at the first hit in (0, tmax), *hit is that one). `scene`
// is read only for alpha masks (bvh.any_alpha_masked) and may be null otherwise.
template <bool kAnyHit, class Steps = BvhNoSteps>
PN_FN bool bvh_trace(const BvhView& bvh, const SceneView* scene, const Ray& ray, float tmax, HitRecord* hit,
                     const Steps& steps = Steps()) {
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
  for (;;) {
    // Inner nodes: on to the nearer child the ray meets, the other onto the stack.
    while (ref >= 0) {
      steps.node();
      const BvhNode n = bvh_load_node(bvh.nodes, ref);
      float t0, t1;
      const bool h0 = bvh_box_hit(n.c0, n.z[0], n.z[1], r, best.t, &t0);
      const bool h1 = bvh_box_hit(n.c1, n.z[2], n.z[3], r, best.t, &t1);
      if (h0 && h1) {
        const bool far0 = t1 < t0;
        ref = far0 ? n.child[1] : n.child[0];
        stack[sp++] = far0 ? n.child[0] : n.child[1];
      } else {
        ref = h0 ? n.child[0] : (h1 ? n.child[1] : kBvhPop);
      }
    }
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
          moved = bi.identity == 0;
          if (moved) r = make_bvh_ray(bi.to_object.point(ray.o), bi.to_object.vector(ray.d));
          ref = bi.root;
          continue;
        }
      } else {  // triangles of the current instance's mesh
        const uint32_t count = bvh_leaf_count(ref);
        steps.leaf(count);
        bool stop = false;
        for (uint32_t i = 0; i < count; ++i) {
          Vec3 p0, p1, p2;
          uint32_t prim;
          bvh_load_triangle(bvh.triangles, first + i, &p0, &p1, &p2, &prim);
          float t, b1, b2;
          if (!intersect_triangle(r.tri, p0, p1, p2, 0.f, best.t, &t, &b1, &b2)) continue;
          if (bvh.any_alpha_masked) {
            const BvhInstance& bi = bvh.instances[inst];
            if (bi.alpha_masked && alpha_discards(*scene, scene->instances[bi.instance], prim, b1, b2)) continue;
          }
          best.t = t;
          best.instance = bvh.instances[inst].instance;
          best.prim = prim;
          best.b1 = b1;
          best.b2 = b2;
          found = true;
          if (kAnyHit) {
            stop = true;
            break;
          }
        }
        if (stop) break;
      }
    }
    // Next entry; leave the instance once its subtree is done (the world ray back only if the instance moved
    // it and entries are left: its divisions were a visible share of a short traversal).
    if (sp == inst_sp) {
      inst_sp = -1;
      if (moved && sp > 0) r = make_bvh_ray(ray.o, ray.d);
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
