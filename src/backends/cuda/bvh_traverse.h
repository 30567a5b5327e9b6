// The cuda traversal: closest hit and any hit over bvh_layout.h's two-level BVH,
// host and device code (the CPU tests check it against Embree; the GPU's
// trace kernels run it one ray per thread).
//
// One loop for both levels (a stack of child references, nearest child first,
// over four-wide nodes):
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

// Entry distance of a box, and whether the ray meets it in [0, tmax]
// (t_near <= t_far, the far end widened).
PN_FN bool bvh_box_hit(float lox, float hix, float loy, float hiy, float loz, float hiz, const BvhRay& r, float tmax,
                       float* t_near) {
  constexpr float kWiden = 1.f + 2.f * 3.58e-7f;  // 1 + 2 gamma(3), gamma(n) = n u / (1 - n u), u = 2^-24
  const float x0 = (lox - r.o.x) * r.inv_d.x, x1 = (hix - r.o.x) * r.inv_d.x;
  const float y0 = (loy - r.o.y) * r.inv_d.y, y1 = (hiy - r.o.y) * r.inv_d.y;
  const float z0 = (loz - r.o.z) * r.inv_d.z, z1 = (hiz - r.o.z) * r.inv_d.z;
  const float tn = pn_max(pn_max(pn_min(x0, x1), pn_min(y0, y1)), pn_max(pn_min(z0, z1), 0.f));
  const float tf = pn_min(pn_min(pn_max(x0, x1), pn_max(y0, y1)), pn_min(pn_max(z0, z1), tmax));
  *t_near = tn;
  return tn <= tf * kWiden;
}

PN_FN BvhNode bvh_load_node(const BvhNode* nodes, int32_t i) {
#if defined(__CUDA_ARCH__)
  BvhNode n;
  const float4* p = reinterpret_cast<const float4*>(nodes + i);
  float4* q = reinterpret_cast<float4*>(&n);
#pragma unroll
  for (int k = 0; k < 7; ++k) q[k] = __ldg(p + k);
  return n;
#else
  return nodes[i];
#endif
}

// Orders two (distance, reference) pairs, nearer first.
PN_FN void bvh_order(float& ta, int32_t& ca, float& tb, int32_t& cb) {
  if (tb < ta) {
    const float t = ta;
    ta = tb;
    tb = t;
    const int32_t c = ca;
    ca = cb;
    cb = c;
  }
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

// Closest hit (kAnyHit false: *hit gets the nearest hit in (0, tmax)) or any hit
// (kAnyHit true: returns at the first hit in (0, tmax), *hit is that one). `scene`
// is read only for alpha masks (bvh.any_alpha_masked) and may be null otherwise.
template <bool kAnyHit>
PN_FN bool bvh_trace(const BvhView& bvh, const SceneView* scene, const Ray& ray, float tmax, HitRecord* hit) {
  if (bvh.num_items == 0) return false;
  // Entries: a reference and the distance at which the ray enters its box; an
  // entry whose box the ray enters beyond the closest hit found since is
  // skipped when popped.
  int32_t stack[kBvhStackSize];
  float stack_t[kBvhStackSize];
  int sp = 0;
  int inst_sp = -1;   // stack depth at which the current instance was entered; -1: top level
  uint32_t inst = 0;  // the current instance (index into bvh.instances) when inst_sp >= 0
  BvhRay r = make_bvh_ray(ray.o, ray.d);
  HitRecord best;
  best.t = tmax;
  bool found = false;
  int32_t ref = bvh.root;
  for (;;) {
    // Inner nodes: on to the nearest child the ray meets; the others onto the
    // stack, farthest first. Children missed (or missing) sort last with
    // distance infinity (a sorting network: no indexing by variables).
    while (ref >= 0) {
      const BvhNode n = bvh_load_node(bvh.nodes, ref);
      constexpr float kMissed = __builtin_huge_valf();
      float t[kBvhWidth];
      int32_t c[kBvhWidth];
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
      for (int k = 0; k < kBvhWidth; ++k) {
        float tk;
        const bool h = bvh_box_hit(n.lo_x[k], n.hi_x[k], n.lo_y[k], n.hi_y[k], n.lo_z[k], n.hi_z[k], r, best.t, &tk);
        t[k] = (h && n.child[k] != kBvhPop) ? tk : kMissed;
        c[k] = n.child[k];
      }
      bvh_order(t[0], c[0], t[1], c[1]);
      bvh_order(t[2], c[2], t[3], c[3]);
      bvh_order(t[0], c[0], t[2], c[2]);
      bvh_order(t[1], c[1], t[3], c[3]);
      bvh_order(t[1], c[1], t[2], c[2]);
      if (t[3] < kMissed) stack_t[sp] = t[3], stack[sp++] = c[3];
      if (t[2] < kMissed) stack_t[sp] = t[2], stack[sp++] = c[2];
      if (t[1] < kMissed) stack_t[sp] = t[1], stack[sp++] = c[1];
      ref = t[0] < kMissed ? c[0] : kBvhPop;
    }
    if (ref != kBvhPop) {
      const uint32_t first = bvh_leaf_first(ref);
      if (inst_sp < 0) {  // a top-level item
        const uint32_t item = bvh.items[first];
        if (item & kBvhItemSphere) {
          const uint32_t s = item & ~kBvhItemSphere;
          const float* sc = bvh.spheres + 4 * s;
          float ts;
          if (intersect_sphere(ray, Vec3(sc[0], sc[1], sc[2]), sc[3], 0.f, best.t, &ts)) {
            best.t = ts;
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
          r = make_bvh_ray(bi.to_object.point(ray.o), bi.to_object.vector(ray.d));
          ref = bi.root;
          continue;
        }
      } else {  // triangles of the current instance's mesh
        const uint32_t count = bvh_leaf_count(ref);
        bool stop = false;
        for (uint32_t i = 0; i < count; ++i) {
          Vec3 p0, p1, p2;
          uint32_t prim;
          bvh_load_triangle(bvh.triangles, first + i, &p0, &p1, &p2, &prim);
          float th, b1, b2;
          if (!intersect_triangle(r.tri, p0, p1, p2, 0.f, best.t, &th, &b1, &b2)) continue;
          if (bvh.any_alpha_masked) {
            const BvhInstance& bi = bvh.instances[inst];
            if (bi.alpha_masked && alpha_discards(*scene, scene->instances[bi.instance], prim, b1, b2)) continue;
          }
          best.t = th;
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
    // Next entry (leaving the instance once its subtree is done), skipping
    // those the closest hit so far lies before.
    ref = kBvhPop;
    while (ref == kBvhPop) {
      if (sp == inst_sp) {
        inst_sp = -1;
        r = make_bvh_ray(ray.o, ray.d);
      }
      if (sp == 0) break;
      --sp;
      if (kAnyHit || stack_t[sp] <= best.t) ref = stack[sp];
    }
    if (ref == kBvhPop) break;
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
