// The cuda traversal's acceleration structure as the GPU reads it: flat arrays
// behind plain pointers (host memory in the CPU tests, device memory on the GPU),
// built on the host by bvh_build.cpp (Embree's SAH builder) and traversed by
// bvh_traverse.h. Two levels, as the OptiX backend's GAS-per-mesh + IAS and the
// CPU backend's Embree instances:
//
//   bottom level: one BVH2 per mesh over its triangles, in object space;
//   top level:    one BVH2 over the placed instances (their meshes' root boxes
//                 moved to world space) and the spheres, one item per leaf.
//
// Every BVH of the scene lives in one node array, so that the node visit is the
// same code at both levels. A node holds the boxes of its two children (Aila and
// Laine, "Understanding the Efficiency of Ray Traversal on GPUs", HPG 2009): one
// 64-byte node read (four 16-byte loads) tests both children.
#pragma once

#include <cstdint>

#include "core/common.h"
#include "core/transform.h"

namespace pn {

// A child reference: >= 0, an inner node (index into BvhView::nodes); < 0, a leaf
// ~(first << kLeafCountBits | (count - 1)): `count` consecutive triangles from
// `first` (bottom level), or the top-level item `first` (count 1).
constexpr int kLeafCountBits = 4;
constexpr uint32_t kMaxLeafSize = 1u << kLeafCountBits;                 // 16
// Largest `first`; one less than the field holds, so that no leaf is kBvhPop.
constexpr uint32_t kMaxLeafFirst = (1u << (31 - kLeafCountBits)) - 2u;
constexpr int32_t kBvhPop = INT32_MIN;  // the traversal's "take the next entry off the stack"
PN_FN int32_t bvh_leaf_ref(uint32_t first, uint32_t count) {
  return ~int32_t((first << kLeafCountBits) | (count - 1u));
}
PN_FN uint32_t bvh_leaf_first(int32_t ref) { return uint32_t(~ref) >> kLeafCountBits; }
PN_FN uint32_t bvh_leaf_count(int32_t ref) { return (uint32_t(~ref) & (kMaxLeafSize - 1u)) + 1u; }

// The traversal's stack: the deepest path it can meet, top-level depth + deepest
// mesh (inner nodes), is checked against it at build time.
constexpr uint32_t kBvhStackSize = 64;

// Two children: boxes and references. The order of the floats is that of the
// three 16-byte loads the GPU makes (x and y of each child, then both z ranges).
// An empty child (a mesh of one leaf has a root with one child) has an inverted
// box, which no ray enters.
struct alignas(16) BvhNode {
  float c0[4];  // child 0: lo.x, hi.x, lo.y, hi.y
  float c1[4];  // child 1: lo.x, hi.x, lo.y, hi.y
  float z[4];   // child 0: lo.z, hi.z; child 1: lo.z, hi.z
  int32_t child[2];
  int32_t pad[2] = {0, 0};
};
static_assert(sizeof(BvhNode) == 64, "BvhNode is one 64-byte read");

// A triangle, its vertices in object space; `prim` (the triangle's index in its
// mesh, as the HitRecord reports it) rides in p0's fourth float as raw bits.
struct alignas(16) BvhTriangle {
  float p0[3];
  uint32_t prim;
  float p1[4];  // [3]: unused
  float p2[4];
};
static_assert(sizeof(BvhTriangle) == 48, "BvhTriangle is three 16-byte reads");

// A placed mesh: the world-to-object transform rays are moved by, its BVH's root.
struct alignas(16) BvhInstance {
  Affine to_object;
  int32_t root = 0;           // the mesh's root node (an inner node)
  uint32_t instance = 0;      // index into SceneView::instances (the HitRecord's instance)
  uint32_t alpha_masked = 0;  // 1: test hits with alpha_discards (some material of it is masked)
  uint32_t identity = 0;      // 1: to_object is exactly the identity, so the world ray serves as it is
};
static_assert(sizeof(BvhInstance) == 64, "BvhInstance is four 16-byte reads");

// A top-level item: an instance (index into BvhView::instances) or, with the
// bit, a sphere (index into SceneView::spheres and BvhView::spheres).
constexpr uint32_t kBvhItemSphere = 0x80000000u;

struct BvhView {
  const BvhNode* nodes = nullptr;
  const BvhTriangle* triangles = nullptr;  // every mesh's, in leaf order
  const BvhInstance* instances = nullptr;
  const uint32_t* items = nullptr;         // top-level items
  const float* spheres = nullptr;          // 4 a sphere: center, radius
  int32_t root = 0;        // the top level's root: an inner node, or a leaf when there is one item
  uint32_t num_items = 0;  // 0: nothing to hit
  uint32_t num_nodes = 0;
  bool any_alpha_masked = false;  // whether alpha_discards can ever be asked (the SceneView is then needed)
  bool flat = false;  // no alpha masks, every instance the identity: rays stay in world space
};

}  // namespace pn
