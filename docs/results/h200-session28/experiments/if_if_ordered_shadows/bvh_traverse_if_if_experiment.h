// EXPERIMENT (session 28, not for commit): session 27 if-if loop, for the ordered shadow stage only.
#pragma once
#include "backends/cuda/bvh_traverse.h"
namespace pn {
template <bool kAnyHit>
PN_FN bool bvh_trace_if_if(const BvhView& bvh, const SceneView* scene, const Ray& ray, float tmax, HitRecord* hit) {
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
  uint32_t tri = 0, tri_end = 0;  // the current leaf's triangles still to test
  // One step an iteration (Aila and Laine's if-if loop): a triangle of the current leaf, else a node. A warp's
  // lanes then wait for each other one step at a time, not for the longest run of nodes and then the largest leaf.
  for (;;) {
    if (tri < tri_end) {  // a triangle of the current instance's mesh
      Vec3 p0, p1, p2;
      uint32_t prim;
      bvh_load_triangle(bvh.triangles, tri, &p0, &p1, &p2, &prim);
      ++tri;
      float t, b1, b2;
      bool hit_here = intersect_triangle(r.tri, p0, p1, p2, 0.f, best.t, &t, &b1, &b2);
      if (hit_here && bvh.any_alpha_masked) {
        const BvhInstance& bi = bvh.instances[inst];
        if (bi.alpha_masked && alpha_discards(*scene, scene->instances[bi.instance], prim, b1, b2)) hit_here = false;
      }
      if (hit_here) {
        best.t = t;
        best.instance = bvh.instances[inst].instance;
        best.prim = prim;
        best.b1 = b1;
        best.b2 = b2;
        found = true;
        if (kAnyHit) break;
      }
      if (tri < tri_end) continue;
      ref = kBvhPop;  // the leaf is done
    } else if (ref >= 0) {  // an inner node: on to the nearer child the ray meets, the other onto the stack
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
      if (ref >= 0) continue;
    }
    if (ref != kBvhPop) {  // a leaf, just reached
      const uint32_t first = bvh_leaf_first(ref);
      if (inst_sp >= 0) {  // the current mesh's triangles, one an iteration from the next on
        tri = first;
        tri_end = first + bvh_leaf_count(ref);
        ref = kBvhPop;
        continue;
      }
      const uint32_t item = bvh.items[first];  // a top-level item
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
}  // namespace pn
