// The cuda traversal: closest hit and any hit over bvh_layout.h's two-level BVH,
// host and device code (the CPU tests check it against Embree; the GPU's
// trace kernels run it one ray per thread).
//
// The top level is a BVH2 (a stack of child references, nearer child first): a
// leaf holds one item, a sphere (the core's intersect_sphere on the world ray)
// or an instance, whose mesh's wide BVH is then traversed with the ray moved
// into its object space (cwbvh_trace). Object-space directions are not
// renormalised, so t is the world ray's at both levels, as with Embree and
// OptiX instances.
//
// The wide BVH's traversal is Ylitie, Karras & Laine's (HPG 2017, algorithm 1):
// a stack of node groups, each a node's base index and a mask of its children
// still to visit (bits 24..31, nearest first) above its inner-node mask (bits
// 0..7); a node's hit leaves make a triangle group (bits 0..23) tested before
// its inner children, or put back on the stack for later when few lanes of
// the warp have triangles to test. Quantized boxes are tested in the form t = q * (step /
// d) + (p - o) / d (one FMA a plane); its rounding against (b - o) / d is at
// most gamma(2) |p - o| / |d| on each axis, by which each axis's planes are
// moved out.
//
// Triangles: the core's watertight test (core/geometry.h), as Embree's robust
// mode. Alpha-masked triangles are skipped where the core's alpha_discards says
// so, as the CPU backend's Embree filters and OptiX's any-hit program do.
// Boxes: slab test with t_far widened by 1 + 2 gamma(3) (Ize, "Robust BVH Ray
// Traversal", JCGT 2(2), 2013), so that rounding never culls a box the ray meets.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

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
  const float tn = pn_max(pn_max(pn_min(x0, x1), pn_min(y0, y1)), pn_max(pn_min(z0, z1), 0.f));
  const float tf = pn_min(pn_min(pn_max(x0, x1), pn_max(y0, y1)), pn_min(pn_max(z0, z1), tmax));
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

PN_FN uint32_t bvh_highest_bit(uint32_t x) {
#if defined(__CUDA_ARCH__)
  return 31u - uint32_t(__clz(x));
#else
  return 31u - uint32_t(__builtin_clz(x));
#endif
}
PN_FN uint32_t bvh_lowest_bit(uint32_t x) {
#if defined(__CUDA_ARCH__)
  return uint32_t(__ffs(x)) - 1u;
#else
  return uint32_t(__builtin_ctz(x));
#endif
}
PN_FN uint32_t bvh_popcount(uint32_t x) {
#if defined(__CUDA_ARCH__)
  return uint32_t(__popc(x));
#else
  return uint32_t(__builtin_popcount(x));
#endif
}

// A wide node as the 20 words of its five 16-byte loads (bvh_layout.h's field order).
PN_FN void bvh_load_wide(const CwbvhNode* nodes, uint32_t i, uint32_t w[20]) {
#if defined(__CUDA_ARCH__)
  const uint4* p = reinterpret_cast<const uint4*>(nodes + i);
  for (int k = 0; k < 5; ++k) {
    const uint4 q = __ldg(p + k);
    w[4 * k] = q.x, w[4 * k + 1] = q.y, w[4 * k + 2] = q.z, w[4 * k + 3] = q.w;
  }
#else
  std::memcpy(w, nodes + i, sizeof(CwbvhNode));
#endif
}

// 2^23 + byte b of a word, exactly: the byte under the exponent of 2^23 (one
// byte permute on the GPU, where a conversion instruction runs at a quarter of
// FMA's rate). cwbvh_hits takes the 2^23 off in its per-node terms.
PN_FN float bvh_byte(uint32_t word, uint32_t b) {
#if defined(__CUDA_ARCH__)
  return __uint_as_float(__byte_perm(word, 0x4B000000u, 0x7650u | b));
#else
  const uint32_t bits = 0x4B000000u | ((word >> (8u * b)) & 0xFFu);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
#endif
}

PN_FN uint32_t bvh_bits(float f) {
#if defined(__CUDA_ARCH__)
  return __float_as_uint(f);
#else
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
#endif
}

// max(a, b, c, 0) and min(a, b, c, d) of floats compared as signed integers
// (Hopper's three-way DPX instructions): exact where the result is >= 0, and
// negative (a box behind the ray, rejected either way) where the float one is.
PN_FN float bvh_max3_0(float a, float b, float c) {
#if defined(__CUDA_ARCH__)
  return __int_as_float(__vimax3_s32_relu(__float_as_int(a), __float_as_int(b), __float_as_int(c)));
#else
  const int32_t m = std::max({int32_t(bvh_bits(a)), int32_t(bvh_bits(b)), int32_t(bvh_bits(c)), 0});
  float f;
  std::memcpy(&f, &m, sizeof f);
  return f;
#endif
}
PN_FN float bvh_min4(float a, float b, float c, float d) {
#if defined(__CUDA_ARCH__)
  return __int_as_float(__vimin3_s32(__float_as_int(a), __float_as_int(b), min(__float_as_int(c), __float_as_int(d))));
#else
  const int32_t m = std::min({int32_t(bvh_bits(a)), int32_t(bvh_bits(b)), int32_t(bvh_bits(c)), int32_t(bvh_bits(d))});
  float f;
  std::memcpy(&f, &m, sizeof f);
  return f;
#endif
}

// a * b + c rounded once, on both sides (the host's tests then compute what the GPU does).
PN_FN float bvh_fma(float a, float b, float c) {
#if defined(__CUDA_ARCH__)
  return __fmaf_rn(a, b, c);
#else
  return std::fma(a, b, c);
#endif
}

PN_FN float bvh_as_float(uint32_t w) {
#if defined(__CUDA_ARCH__)
  return __uint_as_float(w);
#else
  float f;
  std::memcpy(&f, &w, sizeof f);
  return f;
#endif
}

// A node group: the base index of a node's inner children (or of its triangles)
// and the mask of what is left to visit.
struct BvhGroup {
  uint32_t base;
  uint32_t bits;
};

// The triangles of `tri` (bits 0..23) against the ray, nearest hit into *best;
// true when kAnyHit and one was found. On the GPU, for closest hits, while
// nodes are left to visit (`nodes_left`), a group is put back on the stack
// when fewer than bvh.postpone_lanes of the warp's lanes are testing triangles
// (Ylitie et al.'s postponing): those lanes would run the loop alone while the
// others wait. (Shadow rays lost by it: a hit found early ends them.)
template <bool kAnyHit>
PN_FN bool cwbvh_triangles(const BvhView& bvh, const SceneView* scene, const BvhRay& r, uint32_t inst, BvhGroup tri,
                           bool nodes_left, BvhGroup* stack, int* sp, HitRecord* best, bool* found) {
  while (tri.bits != 0u) {
#if defined(__CUDA_ARCH__)
    if (!kAnyHit && nodes_left && __popc(__activemask()) < int(bvh.postpone_lanes)) {
      stack[(*sp)++] = tri;
      return false;
    }
#else
    (void)nodes_left, (void)stack, (void)sp;
#endif
    const uint32_t j = bvh_lowest_bit(tri.bits);
    tri.bits &= tri.bits - 1u;
    Vec3 p0, p1, p2;
    uint32_t prim;
    bvh_load_triangle(bvh.triangles, tri.base + j, &p0, &p1, &p2, &prim);
    float t, b1, b2;
    if (!intersect_triangle(r.tri, p0, p1, p2, 0.f, best->t, &t, &b1, &b2)) continue;
    const BvhInstance& bi = bvh.instances[inst];
    if (bvh.any_alpha_masked && bi.alpha_masked &&
        alpha_discards(*scene, scene->instances[bi.instance], prim, b1, b2))
      continue;
    best->t = t;
    best->instance = bi.instance;
    best->prim = prim;
    best->b1 = b1;
    best->b2 = b2;
    *found = true;
    if (kAnyHit) return true;
  }
  return false;
}

// Children of the wide node in words w (bvh_load_wide) that the ray meets
// before best_t: bits 24 + (slot ^ octinv) for inner ones, triangle bits for
// leaves (bvh_layout.h).
PN_FN uint32_t cwbvh_hits(const uint32_t w[20], const BvhRay& r, uint32_t octinv, float best_t) {
  constexpr float kWiden = 1.f + 2.f * 3.58e-7f;  // as bvh_box_hit
  constexpr float kGamma2 = 2.f * 1.2e-7f;        // gamma(2), with room
  const uint32_t e = w[3];
  // Per axis: a = step / d (the step 2^(e - 127): the exponent bits of a float) and the plane offset
  // o = (p - o) / d - 2^23 a, for coordinates read as 2^23 + q (bvh_byte): t = (2^23 + q) a + o. The rounding of
  // o is at most gamma(2) (|(p - o) / d| + |o|); the near planes move towards the ray by it, the far ones away.
  auto axis = [&](uint32_t shift, float p, float ro, float inv_d, float* a, float* near, float* far) {
    *a = bvh_as_float(((e >> shift) & 0xFFu) << 23) * inv_d;
    const float po = (p - ro) * inv_d;
    const float o = bvh_fma(-8388608.f, *a, po);
    const float err = kGamma2 * (std::fabs(po) + std::fabs(o));
    *near = o - err;
    *far = o + err;
  };
  float ax, ay, az, oxn, oxf, oyn, oyf, ozn, ozf;
  axis(0, bvh_as_float(w[0]), r.o.x, r.inv_d.x, &ax, &oxn, &oxf);
  axis(8, bvh_as_float(w[1]), r.o.y, r.inv_d.y, &ay, &oyn, &oyf);
  axis(16, bvh_as_float(w[2]), r.o.z, r.inv_d.z, &az, &ozn, &ozf);
  // Near and far planes' words (lo, or hi where the direction is negative), slots 0-3 then 4-7.
  const bool nx = r.inv_d.x < 0.f, ny = r.inv_d.y < 0.f, nz = r.inv_d.z < 0.f;
  const uint32_t xn[2] = {nx ? w[14] : w[8], nx ? w[15] : w[9]}, xf[2] = {nx ? w[8] : w[14], nx ? w[9] : w[15]};
  const uint32_t yn[2] = {ny ? w[16] : w[10], ny ? w[17] : w[11]}, yf[2] = {ny ? w[10] : w[16], ny ? w[11] : w[17]};
  const uint32_t zn[2] = {nz ? w[18] : w[12], nz ? w[19] : w[13]}, zf[2] = {nz ? w[12] : w[18], nz ? w[13] : w[19]};
  // Four slots' hit bits at once from their meta bytes: the bit index (24 + slot, flipped by octinv, for inner
  // children; the triangle offset for leaves) and the bits to set (1, or a leaf's unary triangle count; 0: empty).
  uint32_t index4[2], bits4[2];
  for (int h = 0; h < 2; ++h) {
    const uint32_t meta4 = w[6 + h];
    const uint32_t inner4 = ((meta4 & (meta4 << 1) & 0x10101010u) >> 4) * 0xFFu;
    index4[h] = (meta4 ^ ((octinv * 0x01010101u) & inner4)) & 0x1F1F1F1Fu;
    bits4[h] = (meta4 >> 5) & 0x07070707u;
  }
  uint32_t hits = 0;
#ifdef __CUDA_ARCH__
#pragma unroll
#endif
  for (uint32_t s = 0; s < 8; ++s) {
    const uint32_t h = s >> 2, b = s & 3u;
    const float x0 = bvh_fma(bvh_byte(xn[h], b), ax, oxn), x1 = bvh_fma(bvh_byte(xf[h], b), ax, oxf);
    const float y0 = bvh_fma(bvh_byte(yn[h], b), ay, oyn), y1 = bvh_fma(bvh_byte(yf[h], b), ay, oyf);
    const float z0 = bvh_fma(bvh_byte(zn[h], b), az, ozn), z1 = bvh_fma(bvh_byte(zf[h], b), az, ozf);
    const float tn = bvh_max3_0(x0, y0, z0), tf = bvh_min4(x1, y1, z1, best_t);
    if (tn <= tf * kWiden) hits |= ((bits4[h] >> (8u * b)) & 0xFFu) << ((index4[h] >> (8u * b)) & 0xFFu);
  }
  return hits;
}

// A mesh's wide BVH from `root` (instance `inst`), r in its object space; true
// when kAnyHit and a hit was found.
template <bool kAnyHit>
PN_FN bool cwbvh_trace(const BvhView& bvh, const SceneView* scene, const BvhRay& r, uint32_t root, uint32_t inst,
                       HitRecord* best, bool* found) {
  BvhGroup stack[kCwbvhStackSize];
  int sp = 0;
  const uint32_t octinv = 7u - ((r.inv_d.x < 0.f ? 4u : 0u) | (r.inv_d.y < 0.f ? 2u : 0u) | (r.inv_d.z < 0.f ? 1u : 0u));
  BvhGroup node{root, 1u << 31};  // the root as the one child of a group whose inner-node mask is empty
  for (;;) {
    BvhGroup tri{0u, 0u};
    if (node.bits <= 0x00FFFFFFu) {  // a triangle group taken off the stack
      tri = node;
      node = BvhGroup{0u, 0u};
    } else {
      const uint32_t bit = bvh_highest_bit(node.bits);
      node.bits &= ~(1u << bit);
      const uint32_t slot = (bit - 24u) ^ octinv;
      const uint32_t child = node.base + bvh_popcount(node.bits & ((1u << slot) - 1u) & 0xFFu);
      if (node.bits > 0x00FFFFFFu) stack[sp++] = node;
      uint32_t w[20];
      bvh_load_wide(bvh.wide, child, w);
      const uint32_t hits = cwbvh_hits(w, r, octinv, best->t);
      node = BvhGroup{w[4], (hits & 0xFF000000u) | (w[3] >> 24)};  // child_base; the inner-node mask
      tri = BvhGroup{w[5], hits & 0x00FFFFFFu};                   // tri_base
    }
    if (cwbvh_triangles<kAnyHit>(bvh, scene, r, inst, tri, node.bits > 0x00FFFFFFu, stack, &sp, best, found))
      return true;
    if (node.bits <= 0x00FFFFFFu) {
      if (sp == 0) return false;
      node = stack[--sp];
    }
  }
}

// Closest hit (kAnyHit false: *hit gets the nearest hit in (0, tmax)) or any hit
// (kAnyHit true: returns at the first hit in (0, tmax), *hit is that one). `scene`
// is read only for alpha masks (bvh.any_alpha_masked) and may be null otherwise.
template <bool kAnyHit>
PN_FN bool bvh_trace(const BvhView& bvh, const SceneView* scene, const Ray& ray, float tmax, HitRecord* hit) {
  if (bvh.num_items == 0) return false;
  int32_t stack[kBvhStackSize];
  int sp = 0;
  const BvhRay r = make_bvh_ray(ray.o, ray.d);
  HitRecord best;
  best.t = tmax;
  bool found = false;
  int32_t ref = bvh.root;
  for (;;) {
    // Inner nodes: on to the nearer child the ray meets, the other onto the stack.
    while (ref >= 0) {
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
    if (ref != kBvhPop) {  // a top-level item
      const uint32_t item = bvh.items[bvh_leaf_first(ref)];
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
      } else {  // an instance: its mesh's wide BVH, in object space
        const BvhInstance& bi = bvh.instances[item];
        const BvhRay obj = make_bvh_ray(bi.to_object.point(ray.o), bi.to_object.vector(ray.d));
        if (cwbvh_trace<kAnyHit>(bvh, scene, obj, uint32_t(bi.root), item, &best, &found)) break;
      }
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
