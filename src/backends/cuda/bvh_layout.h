// The cuda traversal's acceleration structure as the GPU reads it: flat arrays
// behind plain pointers (host memory in the CPU tests, device memory on the GPU),
// built on the host by bvh_build.cpp (Embree's SAH builder) and traversed by
// bvh_traverse.h. Two levels, as the OptiX backend's GAS-per-mesh + IAS and the
// CPU backend's Embree instances:
//
//   bottom level: one compressed 8-wide BVH per mesh over its triangles, in
//                 object space (CwbvhNode: Ylitie, Karras & Laine, "Efficient
//                 Incoherent Ray Traversal on GPUs Through Compressed Wide
//                 BVHs", HPG 2017): one 80-byte node read tests eight children;
//   top level:    one BVH2 over the placed instances (their meshes' root boxes
//                 moved to world space) and the spheres, one item per leaf
//                 (BvhNode: a node holds the boxes of its two children, Aila and
//                 Laine, "Understanding the Efficiency of Ray Traversal on GPUs",
//                 HPG 2009; one 64-byte read tests both).
#pragma once

#include <cstdint>

#include "core/common.h"
#include "core/transform.h"

namespace pn {

// A child reference of the top level: >= 0, an inner node (index into
// BvhView::nodes); < 0, a leaf ~(first << kLeafCountBits | (count - 1)), the
// top-level item `first` (count 1).
constexpr int kLeafCountBits = 4;
constexpr uint32_t kMaxLeafSize = 1u << kLeafCountBits;                 // 16
// Largest `first`; one less than the field holds, so that no leaf is kBvhPop.
constexpr uint32_t kMaxLeafFirst = (1u << (31 - kLeafCountBits)) - 2u;
constexpr uint32_t kMaxTriangleReferences = 0xFFFFFF00u;  // the wide nodes' uint32 triangle indices, with room
constexpr int32_t kBvhPop = INT32_MIN;  // the traversal's "take the next entry off the stack"
PN_FN int32_t bvh_leaf_ref(uint32_t first, uint32_t count) {
  return ~int32_t((first << kLeafCountBits) | (count - 1u));
}
PN_FN uint32_t bvh_leaf_first(int32_t ref) { return uint32_t(~ref) >> kLeafCountBits; }
PN_FN uint32_t bvh_leaf_count(int32_t ref) { return (uint32_t(~ref) & (kMaxLeafSize - 1u)) + 1u; }

// The top level's traversal stack: its depth (inner nodes) is checked against it at build time.
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

// A node of a mesh's compressed 8-wide BVH: eight child slots, each empty, an
// inner node or a leaf of 1 to 3 triangles. Child boxes are quantized to 8 bits
// a coordinate on a grid with origin p and a power-of-two step a axis, 2^(e - 127)
// (rounded outwards on the host, so that a decoded box holds the child's). The
// inner children are nodes child_base, child_base + 1, ... in slot order; the
// leaves' triangles lie from tri_base on, each leaf's consecutive.
//   meta[s]: 0, an empty slot; inner: 0b001'11xxx, 24 + s in the low five bits;
//            leaf of k triangles at tri_base + o (o < 24): k ones from bit 5, o
//            in the low five bits.
// The traversal (bvh_traverse.h) turns a node's hits into one 32-bit mask: bit
// 24 + (s ^ octinv) for an inner child (nearer children first for the ray's
// octant: the host puts in slot s the child that rays of octant s meet first),
// bit o + j for triangle j of a leaf. The field order is that of the five
// 16-byte loads the GPU makes.
struct alignas(16) CwbvhNode {
  float p[3];            // grid origin
  uint8_t e[3];          // biased exponents of the grid's steps
  uint8_t imask;         // bit s: slot s holds an inner node
  uint32_t child_base;   // first inner child (index into BvhView::wide)
  uint32_t tri_base;     // first triangle of the leaves (index into BvhView::triangles)
  uint8_t meta[8];
  uint8_t qlo_x[8], qlo_y[8], qlo_z[8];
  uint8_t qhi_x[8], qhi_y[8], qhi_z[8];
};
static_assert(sizeof(CwbvhNode) == 80, "CwbvhNode is five 16-byte reads");
constexpr uint32_t kCwbvhMaxLeaf = 3;     // triangles a leaf slot holds (the meta byte's three bits)
constexpr uint32_t kCwbvhStackSize = 32;  // node groups the traversal keeps: checked against the depth at build

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
  int32_t root = 0;           // the mesh's root node (index into BvhView::wide)
  uint32_t instance = 0;      // index into SceneView::instances (the HitRecord's instance)
  uint32_t alpha_masked = 0;  // 1: test hits with alpha_discards (some material of it is masked)
  uint32_t pad = 0;
};
static_assert(sizeof(BvhInstance) == 64, "BvhInstance is four 16-byte reads");

// A top-level item: an instance (index into BvhView::instances) or, with the
// bit, a sphere (index into SceneView::spheres and BvhView::spheres).
constexpr uint32_t kBvhItemSphere = 0x80000000u;

struct BvhView {
  const BvhNode* nodes = nullptr;          // the top level
  const CwbvhNode* wide = nullptr;         // every mesh's
  const BvhTriangle* triangles = nullptr;  // every mesh's, in leaf order
  const BvhInstance* instances = nullptr;
  const uint32_t* items = nullptr;         // top-level items
  const float* spheres = nullptr;          // 4 a sphere: center, radius
  int32_t root = 0;        // the top level's root: an inner node, or a leaf when there is one item
  uint32_t num_items = 0;  // 0: nothing to hit
  uint32_t num_nodes = 0;
  bool any_alpha_masked = false;  // whether alpha_discards can ever be asked (the SceneView is then needed)
  uint32_t postpone_lanes = 7;    // GPU closest hits: fewer lanes testing triangles put them off (bvh_traverse.h)
};

}  // namespace pn
