// The cuda traversal's BVH, built on the host: Embree 3's SAH builder
// (rtcBuildBVH, RTC_BUILD_QUALITY_HIGH, spatial splits in the meshes' trees)
// makes a binary tree per mesh and one over the instances and spheres (each
// optimized by reinsertion with --tune cuda_reinsert, bvh_optimize.h); they
// are flattened into bvh_layout.h's arrays. The same arrays are traced on the
// CPU by the tests and uploaded as they are for the GPU (trace_kernels.h).
#pragma once

#include <cstdint>
#include <vector>

#include "backends/cuda/bvh_layout.h"
#include "render/gpu_tuning.h"  // BvhBuildOptions
#include "scene/scene.h"

namespace pn {

struct BvhStats {
  double build_ms = 0;           // host clock: every rtcBuildBVH call and the flattening
  uint32_t meshes = 0;           // meshes with a BVH (non-empty, placed)
  uint32_t top_depth = 0;        // inner nodes on the longest root-to-leaf path of the top level
  uint32_t max_mesh_depth = 0;   // ... of the deepest mesh BVH
  double mean_leaf_size = 0;     // triangle references per bottom-level leaf
  uint64_t mesh_triangles = 0;   // the built meshes' triangles
  uint64_t triangle_references = 0;  // BvhHost::triangles: more than mesh_triangles where splits copied some
  // The surface area heuristic's nodes a ray visits below the roots: the sum over inner nodes (both levels, a
  // mesh's once for each instance of it) of their children's box areas over the root's, a mesh's boxes taken
  // through its instance's transform (the area of the parallelepiped each becomes). The chance that a random line through a box meets a convex box inside it is the ratio of
  // their surface areas (Cauchy-Crofton), so this counts the visits of a line that nothing stops (each visit of
  // an inner node tests two boxes): how long a ray's traversal is in this scene.
  double sah_visits_per_ray = 0;
  uint64_t reinserted = 0;    // subtrees put back by the reinsertion optimization (cuda_reinsert), both levels
  double reinsertion_ms = 0;  // host clock, part of build_ms
};

struct BvhHost {
  std::vector<BvhNode> nodes;
  std::vector<BvhTriangle> triangles;
  std::vector<BvhInstance> instances;
  std::vector<uint32_t> items;
  std::vector<float> spheres;
  int32_t root = 0;
  bool any_alpha_masked = false;
  BvhBuildOptions options;  // as built: rebuild_bvh_top builds the top level with them again
  BvhStats stats;
  // What the top level is built over: nodes[0, bottom_nodes) are the meshes' trees; by Scene::meshes index, each
  // mesh's root, whether it has a tree, and its box in its own space.
  struct MeshBox {
    Vec3 lo, hi;
  };
  size_t bottom_nodes = 0;
  std::vector<int32_t> mesh_root;
  std::vector<bool> mesh_built;
  std::vector<MeshBox> mesh_bounds;

  BvhView view() const;  // over these vectors: valid while they live unchanged
  uint64_t bytes() const;
};

// Builds the two levels for `scene`. Throws std::runtime_error with one line
// (Embree failed, the scene is beyond the layout's limits).
// `options`: GpuTuning::bvh (render/gpu_tuning.h: --tune cuda_leaf, cuda_splits, cuda_sah_tri).
BvhHost build_bvh(const Scene& scene, const BvhBuildOptions& options = BvhBuildOptions());

// The top level of `bvh` (built by build_bvh for `scene`) built again over its meshes' trees as they are, after the
// scene's spheres moved or resized (set_sphere_light): the same top level build_bvh makes for the edited scene.
void rebuild_bvh_top(const Scene& scene, BvhHost& bvh);

}  // namespace pn
